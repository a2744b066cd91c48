//! The HDF5 file: every rank creates every group, attribute and dataset and
//! writes its rows of each dataset in one (collective) transfer.

use std::cell::{Cell, RefCell};
use std::mem::ManuallyDrop;
use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use hdf5_metno_sys::h5i::hid_t;
use hdf5_metno_sys::h5p::H5P_DEFAULT;

use super::collective::RowSelection;
use super::team::{agree, Writers};
use super::{entries, time_key, OutputError, Results, Share};

fn h5err(target: &Path, action: String) -> impl FnOnce(hdf5::Error) -> OutputError {
    let path = target.to_path_buf();
    move |source| OutputError::Hdf5 {
        path,
        action,
        source,
    }
}

/// Set once a file could not be written and was left open (see [`write_h5`]).
static LEFT_OPEN: AtomicBool = AtomicBool::new(false);

/// Whether an HDF5 file failed part-way and was left open. HDF5 would close it when the
/// library terminates, which it does inside `MPI_Finalize` (through an attribute of
/// `MPI_COMM_SELF`): closing a file whose writes failed flushes its metadata again, which
/// hangs with the MPI-IO driver (the ranks leave HDF5's internal collectives at different
/// points) or crashes (HDF5 1.10 frees the half-closed file twice). A process for which
/// this is true must therefore end without `MPI_Finalize` (`main` does). The same on every
/// rank of a write: the ranks agreed on the failure.
pub fn file_left_open() -> bool {
    LEFT_OPEN.load(Ordering::SeqCst)
}

/// Writes the HDF5 file at `tmp` (created, must not exist; on every rank of
/// `w`). Errors name `target`.
///
/// In three steps, every one agreed on by the ranks: every group, attribute and dataset is
/// created (metadata; contiguous datasets get their space at creation), then rank 0 reserves
/// the file's extent on disk (`posix_fallocate` up to the end of the last dataset),
/// then every dataset is written. A full disk or the file-size limit (`ulimit -f`) thus fails
/// the reservation, on one rank and outside HDF5, and the datasets and the metadata flushed
/// when the file is closed land in space that exists. Any failure after the file was created
/// leaves it open ([`file_left_open`]) rather than closing it: its close would flush into the
/// failed file again (see there).
pub(super) fn write_h5<W: Writers>(
    w: &W,
    tmp: &Path,
    target: &Path,
    results: &Results,
    shares: &[Share],
) -> Result<(), OutputError> {
    let xfer = agree(
        w,
        w.transfer().map_err(h5err(
            target,
            "creating the data transfer property list".into(),
        )),
    )?;
    let created = hdf5::File::with_options()
        .with_fapl(|p| w.file_access(p.fclose_degree(hdf5::file::FileCloseDegree::Strong)))
        .create_excl(tmp)
        .map_err(h5err(target, "creating the file".into()));
    let file = ManuallyDrop::new(agree(w, created)?);
    let out = H5Out {
        w,
        target,
        xfer: xfer.as_ref().map_or(H5P_DEFAULT, |p| p.id()),
        datasets: RefCell::new(Vec::new()),
        writing: Cell::new(false),
    };
    let filled = (|| {
        // `-nndd_fault RANK:output`: a failure of one rank with the file open on all.
        agree(
            w,
            crate::parallel::fault::check(crate::parallel::fault::Phase::Output)
                .map_err(OutputError::from),
        )?;
        fill_h5(&out, &file, results, shares)?;
        reserve(&out, tmp)?;
        out.writing.set(true);
        fill_h5(&out, &file, results, shares)
    })();
    // The objects are closed in the same order on every rank (closing them writes nothing).
    drop(out);
    if let Err(e) = filled {
        LEFT_OPEN.store(true, Ordering::SeqCst);
        return Err(e);
    }
    let closed = ManuallyDrop::into_inner(file)
        .close()
        .map_err(h5err(target, "closing the file".into()));
    if closed.is_err() {
        LEFT_OPEN.store(true, Ordering::SeqCst);
    }
    agree(w, closed)
}

/// Rank 0 extends the file at `tmp` to the end of its last dataset (datasets are
/// contiguous, their space allocated at creation, the metadata before them), with its blocks
/// allocated (`posix_fallocate`), so that writing the data and the metadata needs no new
/// space. File systems without `fallocate` (where the C library's emulation fails too) skip
/// the reservation. Agreed on.
fn reserve<W: Writers>(out: &H5Out<W>, tmp: &Path) -> Result<(), OutputError> {
    let reserved = if out.w.rank() == 0 {
        let end = out
            .datasets
            .borrow()
            .iter()
            .filter_map(|(ds, _)| Some(ds.offset()? + ds.storage_size()))
            .max()
            .unwrap_or(0);
        allocate(tmp, end).map_err(|source| OutputError::Io {
            path: out.target.to_path_buf(),
            action: "reserve the space of the file",
            source,
        })
    } else {
        Ok(())
    };
    agree(out.w, reserved)
}

/// `posix_fallocate(0, len)` of the file at `path` (no error where the file system cannot).
fn allocate(path: &Path, len: u64) -> std::io::Result<()> {
    use std::os::unix::io::AsRawFd as _;
    if len == 0 {
        return Ok(()); // no space allocated yet (the serial driver allocates when writing)
    }
    let f = std::fs::OpenOptions::new().write(true).open(path)?;
    let len = libc::off_t::try_from(len).map_err(std::io::Error::other)?;
    // SAFETY: an open descriptor and a non-negative length.
    let rc = unsafe { libc::posix_fallocate(f.as_raw_fd(), 0, len) };
    match rc {
        0 => Ok(()),
        libc::EOPNOTSUPP | libc::EINVAL | libc::ENODEV => Ok(()),
        e => Err(std::io::Error::from_raw_os_error(e)),
    }
}

/// Writing an HDF5 file on the ranks of `w`: every step that can fail is
/// agreed on. [`fill_h5`] walks the file twice: first creating every object
/// (keeping the datasets), then (`writing`) writing the datasets in the same order.
struct H5Out<'a, W> {
    w: &'a W,
    target: &'a Path,
    /// Data transfer property list.
    xfer: hid_t,
    /// The datasets created by the first walk, in order, each with whether it is empty.
    datasets: RefCell<Vec<(hdf5::Dataset, bool)>>,
    /// The second walk: the objects exist, the datasets are written.
    writing: Cell<bool>,
}

impl<W: Writers> H5Out<'_, W> {
    fn agreed<T>(
        &self,
        r: hdf5::Result<T>,
        action: impl FnOnce() -> String,
    ) -> Result<T, OutputError> {
        agree(
            self.w,
            r.map_err(|source| OutputError::Hdf5 {
                path: self.target.to_path_buf(),
                action: action(),
                source,
            }),
        )
    }

    fn group(&self, parent: &hdf5::Group, name: &str) -> Result<hdf5::Group, OutputError> {
        if self.writing.get() {
            return self.agreed(parent.group(name), || {
                format!(
                    "opening group {}/{name}",
                    parent.name().trim_end_matches('/')
                )
            });
        }
        self.agreed(parent.create_group(name), || {
            format!(
                "creating group {}/{name}",
                parent.name().trim_end_matches('/')
            )
        })
    }

    /// A scalar `f64` attribute of `loc` (called `at` in messages).
    fn attribute(
        &self,
        loc: &hdf5::Location,
        at: &str,
        name: &str,
        value: f64,
    ) -> Result<(), OutputError> {
        if self.writing.get() {
            return Ok(());
        }
        let attr = self.agreed(loc.new_attr::<f64>().create(name), || {
            format!("creating attribute {name:?} of {at}")
        })?;
        self.agreed(attr.write_scalar(&value), || {
            format!("writing attribute {name:?} of {at}")
        })
    }

    /// A text attribute of `loc` (called `at` in messages).
    fn text_attribute(
        &self,
        loc: &hdf5::Location,
        at: &str,
        name: &str,
        value: &str,
    ) -> Result<(), OutputError> {
        use hdf5::types::VarLenUnicode;
        if self.writing.get() {
            return Ok(());
        }
        let text: VarLenUnicode = value
            .replace('\0', " ")
            .parse()
            .expect("a string without NUL is valid HDF5 text");
        let attr = self.agreed(loc.new_attr::<VarLenUnicode>().create(name), || {
            format!("creating attribute {name:?} of {at}")
        })?;
        self.agreed(attr.write_scalar(&text), || {
            format!("writing attribute {name:?} of {at}")
        })
    }

    /// Creates dataset `name` of `shape` (contiguous) in the first walk; writes
    /// `data()`, its rows `rows` (first dimension) from this rank, in the second.
    fn dataset<T: hdf5::H5Type>(
        &self,
        parent: &hdf5::Group,
        name: &str,
        shape: &[usize],
        rows: Range<usize>,
        data: impl FnOnce() -> Vec<T>,
    ) -> Result<(), OutputError> {
        let path = format!("{}/{name}", parent.name().trim_end_matches('/'));
        if !self.writing.get() {
            let created = parent
                .new_dataset::<T>()
                .no_chunk()
                .shape(shape.to_vec())
                .create(name);
            let ds = self.agreed(created, || format!("creating dataset {path}"))?;
            let empty = shape.iter().product::<usize>() == 0;
            self.datasets.borrow_mut().push((ds, empty));
            return Ok(());
        }
        let (ds, empty) = self.datasets.borrow_mut().remove(0);
        if empty {
            return Ok(()); // nothing to write on any rank
        }
        let data = data();
        let selected = self.agreed(RowSelection::new(&ds, rows, data.len()), || {
            format!("selecting rows of dataset {path}")
        })?;
        self.agreed(selected.write(&ds, &data, self.xfer), || {
            format!("writing dataset {path}")
        })
    }
}

fn fill_h5<W: Writers>(
    out: &H5Out<W>,
    file: &hdf5::File,
    results: &Results,
    shares: &[Share],
) -> Result<(), OutputError> {
    for (name, value) in &results.attributes {
        out.attribute(file, "/", name, *value)?;
    }
    for (name, value) in &results.text {
        out.text_attribute(file, "/", name, value)?;
    }
    let meshes = out.group(file, "Mesh")?;
    for (g, share) in results.grids.iter().zip(shares) {
        let group = out.group(&meshes, &g.name)?;
        let rows = share.points.clone();
        let points = || g.stored_points(rows.clone());
        out.dataset::<f64>(
            &group,
            "geometry",
            &[g.extent.points, 2],
            rows.clone(),
            points,
        )?;
        let rows = share.cells.clone();
        let cells = || g.stored_cells(rows.clone());
        let shape = [g.extent.cells, g.topology.nodes_per_cell()];
        out.dataset(&group, "topology", &shape, rows.clone(), cells)?;
        for field in &g.fields {
            let all = entries(Some(g), field.center);
            let shape = field.stored_shape(all);
            let rows = share.rows(field.center);
            let data = || field.stored_rows(rows.clone(), all);
            out.dataset(&group, &field.name, &shape, rows.clone(), data)?;
        }
    }
    let functions = out.group(file, "Function")?;
    for (g, share) in results.grids.iter().zip(shares) {
        // The grid's fields in the order they first appear, each with the steps that have it.
        let mut names: Vec<&str> = Vec::new();
        for step in &results.steps {
            for f in step.fields_of(&g.name) {
                if !names.contains(&f.name.as_str()) {
                    names.push(&f.name);
                }
            }
        }
        if names.is_empty() {
            continue;
        }
        let gg = out.group(&functions, &g.name)?;
        for name in names {
            let fg = out.group(&gg, name)?;
            for step in &results.steps {
                let Some(field) = step.fields_of(&g.name).find(|f| f.name == name) else {
                    continue;
                };
                let all = entries(Some(g), field.center);
                let shape = field.stored_shape(all);
                let rows = share.rows(field.center);
                let data = || field.stored_rows(rows.clone(), all);
                out.dataset(&fg, &time_key(step.time), &shape, rows.clone(), data)?;
            }
        }
    }
    Ok(())
}
