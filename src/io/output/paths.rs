//! Every file name of a run's output, made from the one prefix PREFIX (`-nndd_output`):
//! `PREFIX.h5`, `PREFIX.xdmf`, `PREFIX-<grid>.xdmf` (`PREFIX-contact.xdmf`),
//! `PREFIX-final.xdmf`, `PREFIX.json`, `PREFIX.checkpoint.json`, `PREFIX.body<α>_schur.json`,
//! and the hidden temporaries each is written to before it is renamed into place
//! (`.NAME.tmp.*` beside it, the directory's probe `.NAME.probe.*`).

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

/// The file names of one output prefix.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputPaths {
    prefix: PathBuf,
}

impl OutputPaths {
    pub fn new(prefix: impl Into<PathBuf>) -> OutputPaths {
        OutputPaths {
            prefix: prefix.into(),
        }
    }

    /// PREFIX itself.
    pub fn prefix(&self) -> &Path {
        &self.prefix
    }

    /// `PREFIX.ext`, appended (a prefix may contain dots: never replace an extension).
    pub fn with_ext(&self, ext: &str) -> PathBuf {
        let mut s = self.prefix.as_os_str().to_owned();
        s.push(".");
        s.push(ext);
        s.into()
    }

    /// `PREFIX.h5`: the data.
    pub fn h5(&self) -> PathBuf {
        self.with_ext("h5")
    }

    /// `PREFIX.xdmf`: the first grid's series.
    pub fn xdmf(&self) -> PathBuf {
        self.with_ext("xdmf")
    }

    /// `PREFIX-<grid>.xdmf`: the series of a grid other than the first.
    pub fn grid_xdmf(&self, grid: &str) -> PathBuf {
        let mut s = self.prefix.as_os_str().to_owned();
        s.push(format!("-{grid}.xdmf"));
        s.into()
    }

    /// `PREFIX-contact.xdmf`: nndd's contact grid (Γc).
    pub fn contact_xdmf(&self) -> PathBuf {
        self.grid_xdmf("contact")
    }

    /// `PREFIX-final.xdmf`: the first grid at the last step alone.
    pub fn final_xdmf(&self) -> PathBuf {
        self.grid_xdmf("final")
    }

    /// `PREFIX.json`: the run's summary.
    pub fn json(&self) -> PathBuf {
        self.with_ext("json")
    }

    /// `PREFIX.checkpoint.json`: the restart point.
    pub fn checkpoint(&self) -> PathBuf {
        self.with_ext("checkpoint.json")
    }

    /// `PREFIX.body<α>_schur.json`: body α's interface operators (`-nndd_schur_view`).
    pub fn schur_json(&self, alpha: usize) -> PathBuf {
        self.with_ext(&format!("body{alpha}_schur.json"))
    }

    /// The directory of the files (`.` for a bare file name).
    pub fn dir(&self) -> PathBuf {
        parent_dir(&self.prefix)
    }

    /// The probe file of the directory's check (`.NAME.probe.<unique>`), with `name` PREFIX's
    /// file name.
    pub fn probe(&self, name: &str) -> PathBuf {
        self.dir()
            .join(format!(".{name}.probe.{}", unique_suffix()))
    }
}

/// The hidden temporary `target` is written to before its rename: `.NAME.tmp.<unique>` in the
/// same directory (`None` without a file name).
pub fn temporary(target: &Path) -> Option<PathBuf> {
    let name = target.file_name()?;
    let mut tmp_name = OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp.{}", unique_suffix()));
    Some(parent_dir(target).join(tmp_name))
}

/// The directory of `path` (`.` for a bare file name).
pub fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A suffix no other temporary of this process or another has: pid, counter, nanoseconds.
fn unique_suffix() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    format!("{}.{n}.{nanos}", std::process::id())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_appends_to_the_prefix() {
        let p = OutputPaths::new("out/run.1");
        assert_eq!(p.h5(), PathBuf::from("out/run.1.h5"));
        assert_eq!(p.xdmf(), PathBuf::from("out/run.1.xdmf"));
        assert_eq!(p.contact_xdmf(), PathBuf::from("out/run.1-contact.xdmf"));
        assert_eq!(p.final_xdmf(), PathBuf::from("out/run.1-final.xdmf"));
        assert_eq!(p.json(), PathBuf::from("out/run.1.json"));
        assert_eq!(p.checkpoint(), PathBuf::from("out/run.1.checkpoint.json"));
        assert_eq!(p.schur_json(2), PathBuf::from("out/run.1.body2_schur.json"));
        assert_eq!(p.dir(), PathBuf::from("out"));
        assert_eq!(OutputPaths::new("run").dir(), PathBuf::from("."));
        let tmp = temporary(&p.h5()).unwrap();
        assert!(tmp.starts_with("out"), "{tmp:?}");
        let name = tmp.file_name().unwrap().to_str().unwrap();
        assert!(name.starts_with(".run.1.h5.tmp."), "{name}");
    }
}
