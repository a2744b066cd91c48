//! Atomic writes: temporaries next to their targets, synced, renamed into
//! place, removed on any error.

use std::ffi::OsString;
use std::fs;
use std::io::{self, Write as _};
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::path::{Path, PathBuf};

use super::paths::{parent_dir, temporary};
use super::team::{agree, Writers};
use super::OutputError;

/// Atomic write of a small text file (temporary + rename), used for
/// PREFIX.json.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = TempFile::for_target(path)?;
    write_synced(&tmp.path, bytes, path)?;
    tmp.commit(path)?;
    sync_dir(&parent_dir(path));
    Ok(())
}

/// Writes the `.h5` through `write_h5` (on every rank) and the `.xdmf` texts
/// (rank 0) to temporaries, then rank 0 renames them into place (`.h5`
/// first). Temporaries are removed on any error.
pub(super) fn commit_files<W: Writers>(
    w: &W,
    h5_path: &Path,
    write_h5: impl FnOnce(&Path) -> Result<(), OutputError>,
    xdmfs: &[(PathBuf, String)],
) -> Result<(), OutputError> {
    // Rank 0 checks the targets and picks the temporary name; all learn it.
    let picked = if w.rank() == 0 {
        h5_temporary(h5_path, xdmfs).map(Some)
    } else {
        Ok(None)
    };
    let h5_tmp = agree(w, picked)?;
    let name = h5_tmp
        .as_ref()
        .map(|t| t.path.as_os_str().as_bytes().to_vec())
        .unwrap_or_default();
    let tmp_path = PathBuf::from(OsString::from_vec(w.broadcast(0, name)));
    agree(w, write_h5(&tmp_path))?;
    let renamed = match h5_tmp {
        Some(tmp) => rename_all(tmp, h5_path, xdmfs),
        None => Ok(()),
    };
    agree(w, renamed)
}

/// The temporary for `h5_path`, once neither target is a directory.
fn h5_temporary(h5_path: &Path, xdmfs: &[(PathBuf, String)]) -> Result<TempFile, OutputError> {
    for target in std::iter::once(h5_path).chain(xdmfs.iter().map(|(p, _)| p.as_path())) {
        if target.is_dir() {
            return Err(OutputError::Io {
                path: target.to_path_buf(),
                action: "replace a directory with a file",
                source: io::Error::other("it is a directory"),
            });
        }
    }
    TempFile::for_target(h5_path)
}

/// Syncs the written `.h5` temporary, writes the `.xdmf` one, renames both.
fn rename_all(
    h5_tmp: TempFile,
    h5_path: &Path,
    xdmfs: &[(PathBuf, String)],
) -> Result<(), OutputError> {
    fs::File::open(&h5_tmp.path)
        .and_then(|f| f.sync_all())
        .map_err(|e| OutputError::Io {
            path: h5_path.to_path_buf(),
            action: "sync the temporary HDF5 file",
            source: e,
        })?;
    let mut temporaries = Vec::with_capacity(xdmfs.len());
    for (path, text) in xdmfs {
        let tmp = TempFile::for_target(path)?;
        write_synced(&tmp.path, text.as_bytes(), path)?;
        temporaries.push((tmp, path));
    }
    h5_tmp.commit(h5_path)?;
    for (tmp, path) in temporaries {
        tmp.commit(path)?;
    }
    sync_dir(&parent_dir(h5_path));
    Ok(())
}

/// A temporary file next to its target, removed on drop unless committed.
struct TempFile {
    path: PathBuf,
}

impl TempFile {
    fn for_target(target: &Path) -> Result<TempFile, OutputError> {
        let path = temporary(target).ok_or_else(|| OutputError::BadPrefix {
            path: target.to_path_buf(),
            reason: "no file name".into(),
        })?;
        Ok(TempFile { path })
    }

    fn commit(self, target: &Path) -> Result<(), OutputError> {
        fs::rename(&self.path, target).map_err(|e| OutputError::Io {
            path: target.to_path_buf(),
            action: "rename the temporary file into place",
            source: e,
        })?;
        std::mem::forget(self);
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

/// Creates `tmp` (which must not exist), writes `bytes`, syncs. Errors name
/// `target`.
fn write_synced(tmp: &Path, bytes: &[u8], target: &Path) -> Result<(), OutputError> {
    fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(tmp)
        .and_then(|mut f| {
            f.write_all(bytes)?;
            f.sync_all()
        })
        .map_err(|e| OutputError::Io {
            path: target.to_path_buf(),
            action: "write a temporary file next to it",
            source: e,
        })
}

/// Best effort: make the renames durable.
fn sync_dir(dir: &Path) {
    if let Ok(d) = fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::super::team::Alone;
    use super::super::testutil::{sample, TestDir};
    use super::super::write_results;
    use super::*;

    #[test]
    fn failed_write_keeps_previous_results() {
        let dir = TestDir::new("keep");
        let prefix = dir.0.join("run");
        write_results(&prefix, &sample()).expect("write");
        let files = dir.entries();
        assert_eq!(files.len(), 4, "{files:?}");
        let before: Vec<Vec<u8>> = files
            .iter()
            .map(|f| fs::read(dir.0.join(f)).unwrap())
            .collect();
        let mut bad = sample();
        bad.steps[0].grids[0].fields[0].values.clear();
        assert!(write_results(&prefix, &bad).is_err());
        assert_eq!(dir.entries(), files);
        for (f, bytes) in files.iter().zip(&before) {
            assert_eq!(&fs::read(dir.0.join(f)).unwrap(), bytes, "{f}");
        }
    }

    #[test]
    fn error_after_temporary_is_written_removes_it() {
        let dir = TestDir::new("midway");
        let h5 = dir.0.join("run.h5");
        let xdmf = dir.0.join("run.xdmf");
        let result = commit_files(
            &Alone,
            &h5,
            |tmp| {
                fs::write(tmp, b"half an HDF5 file").unwrap();
                Err(OutputError::Io {
                    path: h5.clone(),
                    action: "simulate a failure",
                    source: io::Error::other("simulated"),
                })
            },
            &[(xdmf, "<Xdmf/>".to_string())],
        );
        assert!(result.is_err());
        assert!(dir.entries().is_empty(), "{:?}", dir.entries());
    }

    #[test]
    fn write_atomic_replaces_whole_file() {
        let dir = TestDir::new("atomic");
        let path = dir.0.join("run.json");
        write_atomic(&path, b"{\"a\": 1}").expect("write");
        write_atomic(&path, b"{\"b\": 2}").expect("rewrite");
        assert_eq!(fs::read(&path).unwrap(), b"{\"b\": 2}");
        assert_eq!(dir.entries(), vec!["run.json"]);
    }
}
