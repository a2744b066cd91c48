//! Result files: `PREFIX.h5` (HDF5, the data) + `PREFIX.xdmf` (XDMF 3, the
//! description ParaView reads), written whole or not at all, and
//! [`write_atomic`] for small text files such as `PREFIX.json`.
//!
//! # Processes
//!
//! [`write_results_parallel`] is collective over an MPI communicator and
//! writes one `PREFIX.h5` whatever the number of ranks. Every rank passes
//! [`Results`] of the same structure (the same grids with their full
//! geometry, the same steps, field names, kinds and centers, the same
//! attributes; checked with a hash) and, per grid, a [`Share`]: the
//! contiguous rows of points and of cells it writes. The ranks' shares tile
//! each grid (checked); a rank's field values may be empty where its share is.
//! All ranks open the file with the MPI-IO driver (`H5Pset_fapl_mpio`),
//! create every group, attribute and dataset together in the same order
//! (creation is collective in parallel HDF5; datasets are contiguous), and
//! write their hyperslab of every dataset (points, cells, each field at each
//! step) in one collective transfer (`H5FD_MPIO_COLLECTIVE`) per dataset,
//! ranks without rows taking part with an empty selection. Rank 0 alone
//! writes `PREFIX.xdmf` and renames the files. The result is the same, dataset
//! by dataset and attribute by attribute, as the one-process file.
//!
//! [`write_results`] is the same code on one process: each grid is one share,
//! the file uses HDF5's default (serial) driver, and no MPI call is made (MPI
//! need not be initialised).
//!
//! # Atomicity
//!
//! [`write_results`] first validates the whole [`Results`] (nothing is
//! created when that fails), then writes both files to hidden temporaries in
//! the destination directory (`.NAME.h5.tmp.*`, `.NAME.xdmf.tmp.*`),
//! syncs them, and renames the `.h5` into place and then the `.xdmf`. On any
//! error the temporaries are removed, so no partial file remains and
//! previously written results are untouched. The `.xdmf` is renamed last, so
//! an `.xdmf` that names `PREFIX.h5` never appears before that file is
//! complete (when a pair is overwritten, the old `.xdmf` sits beside the new
//! `.h5` between the two renames). The destination directory is not created by the writers: call
//! [`check_writable`] first (it creates it).
//!
//! [`write_results_parallel`] keeps the same contract. Every rank validates
//! its `Results` and shares before anything is created; rank 0 picks the
//! temporary name and broadcasts it; the temporary is closed collectively,
//! then rank 0 syncs it, writes the `.xdmf` temporary and renames both. The
//! ranks agree on success after every step that can fail (validation, the
//! temporary name, file creation, each group, attribute and dataset, the
//! close, the renames): an all-reduce of a failure flag, then the message of
//! the first failing rank is broadcast. So either every rank goes on or every
//! rank returns an error (its own, or [`OutputError::OtherRank`]), and no rank
//! waits in a collective call the others have left.
//!
//! # Names
//!
//! Grid and field names are used as HDF5 link names and inside XDMF paths, so
//! they must be non-empty, made of ASCII letters, digits, `_`, `-`, `.`, and
//! must not start with `.`. The file name of PREFIX must be valid UTF-8 and
//! must not contain `:` (XDMF separates file and dataset with `:`).
//!
//! # HDF5 layout (the contract for users and tests)
//!
//! All floating-point data are little-endian `f64`; connectivity is `i64`
//! (0-based point indices).
//!
//! | path | shape | content |
//! | --- | --- | --- |
//! | `/` attributes | scalar `f64` each | [`Results::attributes`], by name |
//! | `/grids/<grid>/points` | N×2 `f64` | x, y of each point |
//! | `/grids/<grid>/cells` | M×3 `i64` (triangles) or M×2 `i64` (segments) | point indices of each cell |
//! | `/steps/<k>` | group | k = 0, 1, … is the index in [`Results::steps`] |
//! | `/steps/<k>` attribute `time` | scalar `f64` | [`Step::time`] (the NNDD iteration number) |
//! | `/steps/<k>/<grid>/<field>` | see below | one field of one grid at step k |
//!
//! Field datasets, with n = N (points, [`Center::Node`]) or M (cells,
//! [`Center::Cell`]):
//!
//! | [`Kind`] | values given | dataset shape |
//! | --- | --- | --- |
//! | `Scalar` | n | n (one-dimensional) |
//! | `Vector` | n×2 (x, y per entry) | n×3, z column = 0 |
//! | `Tensor` | n×6 (xx yy zz xy yz xz per entry) | n×9, the full symmetric 3×3 tensor row by row: xx xy xz, xy yy yz, xz yz zz |
//!
//! Tensors are written with 9 components (XDMF `Tensor`) rather than 6
//! (`Tensor6`) because ParaView 5.11's readers disagree on `Tensor6`: the
//! "XDMF Reader" expands it as xx xy xz yy yz zz, the Xdmf3 readers pass the
//! 6 values through to VTK, which labels them xx yy zz xy yz xz. A 9-component
//! tensor is read identically, and correctly, by all three.
//!
//! A `/steps/<k>/<grid>` group exists only for the grids that step lists.
//! Times must be finite and strictly increasing (so that every step is a
//! distinct time step in ParaView).
//!
//! # XDMF
//!
//! `PREFIX.xdmf` (XDMF `Version="3.0"`) holds one `Domain` with a temporal
//! collection; each step is a spatial collection (with its `Time`) of *all*
//! grids, in the order of [`Results::grids`], so the block structure is the
//! same at every time. Each grid's `Topology` (`Triangle`, or `Polyline` with
//! `NodesPerElement="2"`) and `Geometry` (`XY`) refer to `/grids/<grid>/…`, its
//! `Attribute`s to `/steps/<k>/<grid>/<field>` (`Scalar`, `Vector`, `Tensor`;
//! `Center` `Node` or `Cell`). Datasets are named `NAME.h5:/path` with the bare
//! file name, i.e. relative to the `.xdmf`, so the pair can be moved
//! together. Without steps the file is a single spatial collection of the
//! meshes. ParaView 5.11 opens it with the "XDMF Reader" and with
//! "Xdmf3ReaderS"/"Xdmf3ReaderT" (checked with pvpython: same time steps,
//! arrays, components and values); `OpenDataFile` picks Xdmf3ReaderS, which
//! does not keep the block names, the other two do.

use std::collections::hash_map::DefaultHasher;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::fs;
use std::hash::{Hash, Hasher};
use std::io::{self, Write as _};
use std::ops::Range;
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use hdf5::plist::FileAccessBuilder;

/// Cells of a grid: point indices (0-based) of linear triangles or of 2-node
/// segments.
#[derive(Debug, Clone, PartialEq, Hash)]
pub enum Topology {
    Triangle(Vec<[u32; 3]>),
    Segment(Vec<[u32; 2]>),
}

/// Where a field lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Center {
    /// One entry per point.
    Node,
    /// One entry per cell.
    Cell,
}

/// What one entry of a field is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// 1 value per entry.
    Scalar,
    /// 2 values per entry (x, y); written with 3 components, z = 0, for
    /// ParaView.
    Vector,
    /// 6 values per entry: xx yy zz xy yz xz (a symmetric tensor); written
    /// with 9 components (see the module documentation).
    Tensor,
}

/// One field: `values` holds the entries one after the other, each with the
/// number of values of its [`Kind`].
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    pub name: String,
    pub center: Center,
    pub kind: Kind,
    pub values: Vec<f64>,
}

/// A mesh: 2D points and cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub name: String,
    pub points: Vec<[f64; 2]>,
    pub topology: Topology,
}

/// Fields of one grid at one time step.
#[derive(Debug, Clone, PartialEq)]
pub struct GridFields {
    pub grid: String,
    pub fields: Vec<Field>,
}

/// One time step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The NNDD iteration number.
    pub time: f64,
    pub grids: Vec<GridFields>,
}

/// Everything [`write_results`] writes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Results {
    pub grids: Vec<Grid>,
    pub steps: Vec<Step>,
    /// File-level scalar attributes (attributes of the HDF5 root group).
    pub attributes: Vec<(String, f64)>,
}

/// The rows of one grid this rank writes: a contiguous range of the grid's
/// points and one of its cells (in the grid's own numbering). Ranges of
/// different ranks must not overlap; together they cover the grid (ranks with
/// nothing to write for a grid give empty ranges).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Share {
    pub points: Range<usize>,
    pub cells: Range<usize>,
}

impl Share {
    /// All of `grid` (what one process writing everything holds).
    pub fn whole(grid: &Grid) -> Share {
        Share {
            points: 0..grid.points.len(),
            cells: 0..grid.topology.cell_count(),
        }
    }

    /// The rows of a field with this center.
    fn rows(&self, center: Center) -> Range<usize> {
        match center {
            Center::Node => self.points.clone(),
            Center::Cell => self.cells.clone(),
        }
    }
}

/// Errors of this module; every variant but [`OutputError::OtherRank`] names
/// the path concerned.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output location given with `-nndd_output` cannot be written.
    #[error("-nndd_output {}: cannot {action} {}: {source}", .prefix.display(), .path.display())]
    NotWritable {
        prefix: PathBuf,
        path: PathBuf,
        action: &'static str,
        source: io::Error,
    },
    /// The output prefix cannot name files (no file name, `:` in it, not UTF-8).
    #[error("-nndd_output {}: not a usable output prefix: {reason}", .path.display())]
    BadPrefix { path: PathBuf, reason: String },
    /// The results are inconsistent; nothing was written.
    #[error("{}: invalid results, nothing written: {reason}", .path.display())]
    Invalid { path: PathBuf, reason: String },
    /// A file-system operation failed.
    #[error("{}: cannot {action}: {source}", .path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
        source: io::Error,
    },
    /// The HDF5 library reported an error.
    #[error("{}: HDF5 error while {action}: {source}", .path.display())]
    Hdf5 {
        path: PathBuf,
        action: String,
        source: hdf5::Error,
    },
    /// Another rank of a collective write failed with this message (which
    /// names the path); this rank stopped at the same point.
    #[error("{message} (reported by rank {rank})")]
    OtherRank { rank: usize, message: String },
}

impl Topology {
    fn cell_count(&self) -> usize {
        match self {
            Topology::Triangle(c) => c.len(),
            Topology::Segment(c) => c.len(),
        }
    }

    fn nodes_per_cell(&self) -> usize {
        match self {
            Topology::Triangle(_) => 3,
            Topology::Segment(_) => 2,
        }
    }

    fn xdmf_type(&self) -> &'static str {
        match self {
            Topology::Triangle(_) => "Triangle",
            Topology::Segment(_) => "Polyline",
        }
    }

    /// Point indices of cells `rows`, cell after cell.
    fn flat_rows(&self, rows: Range<usize>) -> Vec<i64> {
        match self {
            Topology::Triangle(c) => c[rows].iter().flatten().map(|&i| i64::from(i)).collect(),
            Topology::Segment(c) => c[rows].iter().flatten().map(|&i| i64::from(i)).collect(),
        }
    }

    fn max_index(&self) -> Option<u32> {
        match self {
            Topology::Triangle(c) => c.iter().flatten().copied().max(),
            Topology::Segment(c) => c.iter().flatten().copied().max(),
        }
    }
}

impl Kind {
    /// Values per entry in [`Field::values`].
    fn given(self) -> usize {
        match self {
            Kind::Scalar => 1,
            Kind::Vector => 2,
            Kind::Tensor => 6,
        }
    }

    /// Components per entry in the file.
    fn stored(self) -> usize {
        match self {
            Kind::Scalar => 1,
            Kind::Vector => 3,
            Kind::Tensor => 9,
        }
    }

    fn xdmf_type(self) -> &'static str {
        match self {
            Kind::Scalar => "Scalar",
            Kind::Vector => "Vector",
            Kind::Tensor => "Tensor",
        }
    }
}

impl Center {
    fn xdmf_name(self) -> &'static str {
        match self {
            Center::Node => "Node",
            Center::Cell => "Cell",
        }
    }
}

impl Field {
    /// Entries `rows` as stored in the file (vectors padded with z = 0,
    /// tensors expanded to 3×3 row by row); nothing for no rows (the values
    /// may then be empty).
    fn stored_rows(&self, rows: Range<usize>) -> Vec<f64> {
        if rows.is_empty() {
            return Vec::new();
        }
        let given = self.kind.given();
        let values = &self.values[rows.start * given..rows.end * given];
        match self.kind {
            Kind::Vector => values
                .chunks_exact(2)
                .flat_map(|v| [v[0], v[1], 0.0])
                .collect(),
            Kind::Tensor => values
                .chunks_exact(6)
                .flat_map(|t| [t[0], t[3], t[5], t[3], t[1], t[4], t[5], t[4], t[2]])
                .collect(),
            Kind::Scalar => values.to_vec(),
        }
    }

    /// Dataset shape in the file for `entries` entries.
    fn stored_shape(&self, entries: usize) -> Vec<usize> {
        match self.kind {
            Kind::Scalar => vec![entries],
            k => vec![entries, k.stored()],
        }
    }
}

/// `PREFIX` + `.ext` (a prefix may contain dots: never replace an extension).
pub fn with_ext(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    s.into()
}

/// Check early (before any solve) that PREFIX's directory exists or can be
/// created and that files can be written there: create and remove a probe
/// file. The error names the option `-nndd_output` and the path.
pub fn check_writable(prefix: &Path) -> Result<(), OutputError> {
    let name = prefix_name(prefix)?;
    let dir = parent_dir(prefix);
    let not_writable = |path: &Path, action, source| OutputError::NotWritable {
        prefix: prefix.to_path_buf(),
        path: path.to_path_buf(),
        action,
        source,
    };
    fs::create_dir_all(&dir).map_err(|e| not_writable(&dir, "create directory", e))?;
    for ext in ["h5", "xdmf", "json"] {
        let target = with_suffix(prefix, ext);
        if target.is_dir() {
            let e = io::Error::other("it is a directory");
            return Err(not_writable(&target, "replace", e));
        }
    }
    let probe = dir.join(format!(".{name}.probe.{}", unique_suffix()));
    let result = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .and_then(|mut f| f.write_all(b"nndd probe\n"));
    if let Err(e) = result {
        let _ = fs::remove_file(&probe);
        return Err(not_writable(&probe, "create a file", e));
    }
    fs::remove_file(&probe).map_err(|e| not_writable(&probe, "remove probe file", e))
}

/// Write PREFIX.h5 and PREFIX.xdmf (atomically: write to temporaries in the
/// same directory, rename at the end; on any error remove the temporaries so
/// no partial file remains). One process, no MPI.
pub fn write_results(prefix: &Path, results: &Results) -> Result<(), OutputError> {
    let shares: Vec<Share> = results.grids.iter().map(Share::whole).collect();
    write_on(&Alone, prefix, results, &shares)
}

/// Collective over `comm` (every rank calls it with Results of identical
/// structure: same grids with the same full geometry — points and topology
/// are known on every rank —, same steps, same field names/kinds/centers in
/// the same order, same attributes). Field `values` are either full length
/// (all entries of the grid, in the grid's numbering) on ranks whose share of
/// that grid is non-empty, or may be empty on ranks whose share is empty
/// (precisely: where this rank's rows of the field's center are empty).
/// `shares[g]` is this rank's share of `results.grids[g]`. Each rank writes
/// its hyperslabs (points, cells and every field dataset of that grid at
/// every step) with collective transfer (H5FD_MPIO_COLLECTIVE); rank 0 writes
/// the XDMF. Same file layout, atomicity and error contract as
/// [`write_results`]: if any rank finds an error, every rank returns an error
/// and no file is created (see the module documentation).
pub fn write_results_parallel<C: mpi::traits::Communicator>(
    comm: &C,
    prefix: &Path,
    results: &Results,
    shares: &[Share],
) -> Result<(), OutputError> {
    write_on(&Team(comm), prefix, results, shares)
}

/// Atomic write of a small text file (temporary + rename), used for
/// PREFIX.json.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = TempFile::for_target(path)?;
    write_synced(&tmp.path, bytes, path)?;
    tmp.commit(path)?;
    sync_dir(&parent_dir(path));
    Ok(())
}

/// The processes writing one file together, and what they need from each
/// other. Every method but `rank` is collective: all ranks call it at the
/// same point.
trait Writers {
    fn rank(&self) -> usize;
    /// The lowest rank whose `failed` is true, on every rank.
    fn first_failed(&self, failed: bool) -> Option<usize>;
    /// `root`'s `bytes`, on every rank.
    fn broadcast(&self, root: usize, bytes: Vec<u8>) -> Vec<u8>;
    /// Every rank's `values` (the same number on every rank), rank after rank.
    fn all_gather(&self, values: &[u64]) -> Vec<u64>;
    /// Sets the file driver.
    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder;
    /// The data transfer property list (`None`: HDF5's default).
    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>>;
}

/// One process: [`write_results`].
struct Alone;

impl Writers for Alone {
    fn rank(&self) -> usize {
        0
    }

    fn first_failed(&self, failed: bool) -> Option<usize> {
        failed.then_some(0)
    }

    fn broadcast(&self, _root: usize, bytes: Vec<u8>) -> Vec<u8> {
        bytes
    }

    fn all_gather(&self, values: &[u64]) -> Vec<u64> {
        values.to_vec()
    }

    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder {
        fapl
    }

    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>> {
        Ok(None)
    }
}

/// The ranks of a communicator: [`write_results_parallel`].
struct Team<'c, C>(&'c C);

impl<C: mpi::traits::Communicator> Writers for Team<'_, C> {
    fn rank(&self) -> usize {
        self.0.rank() as usize
    }

    fn first_failed(&self, failed: bool) -> Option<usize> {
        use mpi::collective::SystemOperation;
        use mpi::traits::CommunicatorCollectives as _;
        let size = self.0.size();
        let mine = if failed { self.0.rank() } else { size };
        let mut first = size;
        self.0
            .all_reduce_into(&mine, &mut first, SystemOperation::min());
        (first < size).then_some(first as usize)
    }

    fn broadcast(&self, root: usize, mut bytes: Vec<u8>) -> Vec<u8> {
        use mpi::traits::Root as _;
        let root = self.0.process_at_rank(root as mpi::Rank);
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        bytes.resize(len as usize, 0);
        if len > 0 {
            root.broadcast_into(&mut bytes[..]);
        }
        bytes
    }

    fn all_gather(&self, values: &[u64]) -> Vec<u64> {
        use mpi::traits::CommunicatorCollectives as _;
        let mut all = vec![0; values.len() * self.0.size() as usize];
        self.0.all_gather_into(values, &mut all[..]);
        all
    }

    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder {
        fapl.mpio(self.0.as_raw(), None)
    }

    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>> {
        collective_transfer().map(Some)
    }
}

/// `local` on every rank if no rank failed; otherwise an error on every rank:
/// its own, or [`OutputError::OtherRank`] with the message of the first rank
/// that failed. All ranks call it at the same point.
fn agree<W: Writers, T>(w: &W, local: Result<T, OutputError>) -> Result<T, OutputError> {
    let Some(first) = w.first_failed(local.is_err()) else {
        return local;
    };
    let message = match &local {
        Err(e) if w.rank() == first => e.to_string(),
        _ => String::new(),
    };
    let message = String::from_utf8_lossy(&w.broadcast(first, message.into_bytes())).into_owned();
    match local {
        Err(e) => Err(e),
        Ok(_) => Err(OutputError::OtherRank {
            rank: first,
            message,
        }),
    }
}

/// [`write_results`] and [`write_results_parallel`]: validate (and agree),
/// then write.
fn write_on<W: Writers>(
    w: &W,
    prefix: &Path,
    results: &Results,
    shares: &[Share],
) -> Result<(), OutputError> {
    let h5_path = with_suffix(prefix, "h5");
    let xdmf_path = with_suffix(prefix, "xdmf");
    let checked =
        prefix_name(prefix).and_then(|name| validate(results, shares, &h5_path).map(|()| name));
    let name = agree(w, checked)?;
    check_team(w, results, shares).map_err(|reason| OutputError::Invalid {
        path: h5_path.clone(),
        reason,
    })?;
    let xdmf = if w.rank() == 0 {
        xdmf_text(results, &format!("{name}.h5"))
    } else {
        String::new()
    };
    commit_pair(
        w,
        &h5_path,
        |tmp| write_h5(w, tmp, &h5_path, results, shares),
        &xdmf_path,
        xdmf.as_bytes(),
    )
}

/// Writes the `.h5` through `write_h5` (on every rank) and the `.xdmf` bytes
/// (rank 0) to temporaries, then rank 0 renames both into place (`.h5`
/// first). Temporaries are removed on any error.
fn commit_pair<W: Writers>(
    w: &W,
    h5_path: &Path,
    write_h5: impl FnOnce(&Path) -> Result<(), OutputError>,
    xdmf_path: &Path,
    xdmf: &[u8],
) -> Result<(), OutputError> {
    // Rank 0 checks the targets and picks the temporary name; all learn it.
    let picked = if w.rank() == 0 {
        h5_temporary(h5_path, xdmf_path).map(Some)
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
        Some(tmp) => rename_pair(tmp, h5_path, xdmf_path, xdmf),
        None => Ok(()),
    };
    agree(w, renamed)
}

/// The temporary for `h5_path`, once neither target is a directory.
fn h5_temporary(h5_path: &Path, xdmf_path: &Path) -> Result<TempFile, OutputError> {
    for target in [h5_path, xdmf_path] {
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
fn rename_pair(
    h5_tmp: TempFile,
    h5_path: &Path,
    xdmf_path: &Path,
    xdmf: &[u8],
) -> Result<(), OutputError> {
    fs::File::open(&h5_tmp.path)
        .and_then(|f| f.sync_all())
        .map_err(|e| OutputError::Io {
            path: h5_path.to_path_buf(),
            action: "sync the temporary HDF5 file",
            source: e,
        })?;
    let xdmf_tmp = TempFile::for_target(xdmf_path)?;
    write_synced(&xdmf_tmp.path, xdmf, xdmf_path)?;
    h5_tmp.commit(h5_path)?;
    xdmf_tmp.commit(xdmf_path)?;
    sync_dir(&parent_dir(h5_path));
    Ok(())
}

/// A temporary file next to its target, removed on drop unless committed.
struct TempFile {
    path: PathBuf,
}

impl TempFile {
    fn for_target(target: &Path) -> Result<TempFile, OutputError> {
        let name = target.file_name().ok_or_else(|| OutputError::BadPrefix {
            path: target.to_path_buf(),
            reason: "no file name".into(),
        })?;
        let mut tmp_name = OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".tmp.{}", unique_suffix()));
        Ok(TempFile {
            path: parent_dir(target).join(tmp_name),
        })
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

fn unique_suffix() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    format!("{}.{n}.{nanos}", std::process::id())
}

/// The directory of `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// `PREFIX.ext`, appending (a dot in PREFIX is kept).
fn with_suffix(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_os_string();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// The file-name part of PREFIX, checked usable in XDMF references.
fn prefix_name(prefix: &Path) -> Result<String, OutputError> {
    let bad = |reason: &str| OutputError::BadPrefix {
        path: prefix.to_path_buf(),
        reason: reason.to_string(),
    };
    let raw = prefix.as_os_str().to_string_lossy();
    if raw.ends_with('/') {
        return Err(bad(
            "it names a directory; give a directory and a file-name prefix, e.g. results/run1",
        ));
    }
    let name = prefix
        .file_name()
        .ok_or_else(|| bad("no file name; give e.g. results/run1"))?;
    let name = name
        .to_str()
        .ok_or_else(|| bad("the file name is not valid UTF-8"))?;
    if name.contains(':') {
        return Err(bad(
            "the file name contains ':', which XDMF cannot reference",
        ));
    }
    Ok(name.to_string())
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
}

/// All checks of one rank's results and shares, before anything is created.
fn validate(results: &Results, shares: &[Share], path: &Path) -> Result<(), OutputError> {
    let invalid = |reason: String| OutputError::Invalid {
        path: path.to_path_buf(),
        reason,
    };
    let name_rule = "non-empty, ASCII letters, digits, '_', '-', '.', not starting with '.'";
    if shares.len() != results.grids.len() {
        return Err(invalid(format!(
            "{} shares for {} grids",
            shares.len(),
            results.grids.len()
        )));
    }
    for (i, (g, share)) in results.grids.iter().zip(shares).enumerate() {
        if !valid_name(&g.name) {
            return Err(invalid(format!(
                "grid name {:?}: must be {name_rule}",
                g.name
            )));
        }
        if results.grids[..i].iter().any(|o| o.name == g.name) {
            return Err(invalid(format!("grid name {:?} is used twice", g.name)));
        }
        if let Some(max) = g.topology.max_index() {
            if max as usize >= g.points.len() {
                return Err(invalid(format!(
                    "grid {:?}: cell refers to point {max}, but it has {} points",
                    g.name,
                    g.points.len()
                )));
            }
        }
        let totals = [
            (&share.points, g.points.len(), "points"),
            (&share.cells, g.topology.cell_count(), "cells"),
        ];
        for (rows, total, what) in totals {
            if rows.start > rows.end || rows.end > total {
                return Err(invalid(format!(
                    "grid {:?}: share of {what} {rows:?} is not within 0..{total}",
                    g.name
                )));
            }
        }
    }
    for (i, (name, _)) in results.attributes.iter().enumerate() {
        if name.is_empty() || name.contains('\0') {
            return Err(invalid(format!(
                "attribute name {name:?}: empty or contains NUL"
            )));
        }
        if results.attributes[..i].iter().any(|(o, _)| o == name) {
            return Err(invalid(format!("attribute name {name:?} is used twice")));
        }
    }
    let mut previous: Option<f64> = None;
    for (k, step) in results.steps.iter().enumerate() {
        if !step.time.is_finite() {
            return Err(invalid(format!(
                "step {k}: time {} is not finite",
                step.time
            )));
        }
        if let Some(p) = previous {
            if step.time <= p {
                return Err(invalid(format!(
                    "step {k}: time {} does not increase (previous step: {p})",
                    step.time
                )));
            }
        }
        previous = Some(step.time);
        for (j, gf) in step.grids.iter().enumerate() {
            let gi = grid_index(results, &gf.grid)
                .ok_or_else(|| invalid(format!("step {k}: unknown grid {:?}", gf.grid)))?;
            let grid = &results.grids[gi];
            if step.grids[..j].iter().any(|o| o.grid == gf.grid) {
                return Err(invalid(format!(
                    "step {k}: grid {:?} listed twice",
                    gf.grid
                )));
            }
            for (f, field) in gf.fields.iter().enumerate() {
                let at = format!("step {k}, grid {:?}, field {:?}", gf.grid, field.name);
                if !valid_name(&field.name) {
                    return Err(invalid(format!("{at}: name must be {name_rule}")));
                }
                if gf.fields[..f].iter().any(|o| o.name == field.name) {
                    return Err(invalid(format!("{at}: name used twice")));
                }
                let (entries, what) = match field.center {
                    Center::Node => (grid.points.len(), "points"),
                    Center::Cell => (grid.topology.cell_count(), "cells"),
                };
                let expected = entries.checked_mul(field.kind.given());
                let absent = field.values.is_empty() && shares[gi].rows(field.center).is_empty();
                if expected != Some(field.values.len()) && !absent {
                    return Err(invalid(format!(
                        "{at}: {} values, expected {entries} {what} x {} ({:?})",
                        field.values.len(),
                        field.kind.given(),
                        field.kind
                    )));
                }
            }
        }
    }
    Ok(())
}

fn h5err(target: &Path, action: String) -> impl FnOnce(hdf5::Error) -> OutputError {
    let path = target.to_path_buf();
    move |source| OutputError::Hdf5 {
        path,
        action,
        source,
    }
}

/// Checks, identically on every rank, that all ranks hold results of the
/// same structure and that their shares tile every grid.
fn check_team<W: Writers>(w: &W, results: &Results, shares: &[Share]) -> Result<(), String> {
    let hashes = w.all_gather(&[structure_hash(results)]);
    if let Some(r) = hashes.iter().position(|&h| h != hashes[0]) {
        return Err(format!(
            "rank {r} holds results of another structure than rank 0 \
             (grids, geometry, steps, field names/kinds/centers or attributes differ)"
        ));
    }
    if shares.is_empty() {
        return Ok(());
    }
    let mine: Vec<u64> = shares
        .iter()
        .flat_map(|s| [s.points.start, s.points.end, s.cells.start, s.cells.end])
        .map(|v| v as u64)
        .collect();
    let all = w.all_gather(&mine);
    for (gi, g) in results.grids.iter().enumerate() {
        let totals = [
            (0, g.points.len(), "points"),
            (2, g.topology.cell_count(), "cells"),
        ];
        for (at, total, what) in totals {
            let mut ranges: Vec<(usize, Range<usize>)> = all
                .chunks_exact(mine.len())
                .map(|r| r[4 * gi + at] as usize..r[4 * gi + at + 1] as usize)
                .enumerate()
                .filter(|(_, rows)| !rows.is_empty())
                .collect();
            ranges.sort_by_key(|(_, rows)| rows.start);
            let mut next = 0;
            for (_, rows) in &ranges {
                if rows.start != next {
                    break;
                }
                next = rows.end;
            }
            if next != total || ranges.iter().any(|(_, rows)| rows.end > total) {
                let listed: Vec<String> = ranges
                    .iter()
                    .map(|(r, rows)| format!("rank {r}: {rows:?}"))
                    .collect();
                return Err(format!(
                    "grid {:?}: the ranks' shares of its {what} ({}) do not cover 0..{total} exactly once",
                    g.name,
                    listed.join(", ")
                ));
            }
        }
    }
    Ok(())
}

/// A hash of what must be identical on every rank: grids (with geometry),
/// steps (times, grids, field names, centers, kinds), attributes.
fn structure_hash(results: &Results) -> u64 {
    let mut h = DefaultHasher::new();
    results.grids.len().hash(&mut h);
    for g in &results.grids {
        g.name.hash(&mut h);
        g.points.len().hash(&mut h);
        for p in &g.points {
            p.map(f64::to_bits).hash(&mut h);
        }
        g.topology.hash(&mut h);
    }
    results.steps.len().hash(&mut h);
    for step in &results.steps {
        step.time.to_bits().hash(&mut h);
        step.grids.len().hash(&mut h);
        for gf in &step.grids {
            gf.grid.hash(&mut h);
            gf.fields.len().hash(&mut h);
            for f in &gf.fields {
                (&f.name, f.center, f.kind).hash(&mut h);
            }
        }
    }
    results.attributes.len().hash(&mut h);
    for (name, value) in &results.attributes {
        (name, value.to_bits()).hash(&mut h);
    }
    h.finish()
}

/// Writes the HDF5 file at `tmp` (created, must not exist; on every rank of
/// `w`). Errors name `target`.
fn write_h5<W: Writers>(
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
    let file = agree(w, created)?;
    let out = H5Out {
        w,
        target,
        xfer: xfer.as_ref().map_or(ffi::H5P_DEFAULT, |p| p.id()),
    };
    // All object handles of `fill_h5` are dropped when it returns; `close`
    // then reports flush errors. On an error every rank returns at the same
    // point and drops (closes) the file.
    fill_h5(&out, &file, results, shares)?;
    agree(
        w,
        file.close()
            .map_err(h5err(target, "closing the file".into())),
    )
}

/// Writing an HDF5 file on the ranks of `w`: every step that can fail is
/// agreed on.
struct H5Out<'a, W> {
    w: &'a W,
    target: &'a Path,
    /// Data transfer property list.
    xfer: ffi::Hid,
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
        let attr = self.agreed(loc.new_attr::<f64>().create(name), || {
            format!("creating attribute {name:?} of {at}")
        })?;
        self.agreed(attr.write_scalar(&value), || {
            format!("writing attribute {name:?} of {at}")
        })
    }

    /// Creates dataset `name` of `shape` (contiguous) and writes `data`, its
    /// rows `rows` (first dimension) from this rank.
    fn dataset<T: hdf5::H5Type>(
        &self,
        parent: &hdf5::Group,
        name: &str,
        shape: &[usize],
        rows: Range<usize>,
        data: &[T],
    ) -> Result<(), OutputError> {
        let path = format!("{}/{name}", parent.name().trim_end_matches('/'));
        let created = parent
            .new_dataset::<T>()
            .no_chunk()
            .shape(shape.to_vec())
            .create(name);
        let ds = self.agreed(created, || format!("creating dataset {path}"))?;
        if shape.iter().product::<usize>() == 0 {
            return Ok(()); // nothing to write on any rank
        }
        let selected = self.agreed(RowSelection::new(&ds, rows, data.len()), || {
            format!("selecting rows of dataset {path}")
        })?;
        self.agreed(selected.write(&ds, data, self.xfer), || {
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
    let grids = out.group(file, "grids")?;
    for (g, share) in results.grids.iter().zip(shares) {
        let group = out.group(&grids, &g.name)?;
        let rows = share.points.clone();
        let points: Vec<f64> = g.points[rows.clone()].iter().flatten().copied().collect();
        out.dataset(&group, "points", &[g.points.len(), 2], rows, &points)?;
        let rows = share.cells.clone();
        let cells = g.topology.flat_rows(rows.clone());
        let shape = [g.topology.cell_count(), g.topology.nodes_per_cell()];
        out.dataset(&group, "cells", &shape, rows, &cells)?;
    }
    let steps = out.group(file, "steps")?;
    for (k, step) in results.steps.iter().enumerate() {
        let sg = out.group(&steps, &k.to_string())?;
        out.attribute(&sg, &format!("/steps/{k}"), "time", step.time)?;
        for gf in &step.grids {
            // Validated: the grid exists.
            let gi = grid_index(results, &gf.grid);
            let grid = gi.map(|i| &results.grids[i]);
            let share = gi.map(|i| shares[i].clone()).unwrap_or_default();
            let gg = out.group(&sg, &gf.grid)?;
            for field in &gf.fields {
                let shape = field.stored_shape(entries(grid, field.center));
                let rows = share.rows(field.center);
                let data = field.stored_rows(rows.clone());
                out.dataset(&gg, &field.name, &shape, rows, &data)?;
            }
        }
    }
    Ok(())
}

/// The few HDF5 C functions used directly: the `hdf5` crate writes with the
/// default transfer property list (independent I/O in parallel) and skips
/// empty selections, while a collective write needs a collective transfer
/// list and every rank in `H5Dwrite`. They come from the libhdf5 the crate
/// links (HDF5 1.10 or later: `hid_t` is 64-bit).
mod ffi {
    use std::ffi::{c_int, c_void};

    pub type Hid = i64;
    pub type Herr = c_int;
    pub type Hsize = u64;

    pub const H5P_DEFAULT: Hid = 0;
    /// `H5S_SELECT_SET` of `H5S_seloper_t`.
    pub const H5S_SELECT_SET: c_int = 0;
    /// `H5FD_MPIO_COLLECTIVE` of `H5FD_mpio_xfer_t`.
    pub const H5FD_MPIO_COLLECTIVE: c_int = 1;

    extern "C" {
        pub fn H5Pcreate(cls_id: Hid) -> Hid;
        pub fn H5Pset_dxpl_mpio(dxpl_id: Hid, xfer_mode: c_int) -> Herr;
        pub fn H5Sselect_none(space_id: Hid) -> Herr;
        pub fn H5Sselect_hyperslab(
            space_id: Hid,
            op: c_int,
            start: *const Hsize,
            stride: *const Hsize,
            count: *const Hsize,
            block: *const Hsize,
        ) -> Herr;
        pub fn H5Dwrite(
            dset_id: Hid,
            mem_type_id: Hid,
            mem_space_id: Hid,
            file_space_id: Hid,
            dxpl_id: Hid,
            buf: *const c_void,
        ) -> Herr;
    }
}

/// The error of a failed HDF5 C call: the library's error stack.
fn h5_error() -> hdf5::Error {
    hdf5::Error::query().unwrap_or_else(|e| e)
}

fn h5check(code: ffi::Herr) -> hdf5::Result<()> {
    if code < 0 {
        Err(h5_error())
    } else {
        Ok(())
    }
}

/// A data transfer property list asking for collective MPI-IO.
fn collective_transfer() -> hdf5::Result<hdf5::PropertyList> {
    hdf5::sync::sync(|| {
        // SAFETY: plain HDF5 calls on a property list this function owns.
        unsafe {
            let id = ffi::H5Pcreate(*hdf5::globals::H5P_DATASET_XFER);
            if id < 0 {
                return Err(h5_error());
            }
            let plist: hdf5::PropertyList = hdf5::from_id(id)?;
            h5check(ffi::H5Pset_dxpl_mpio(plist.id(), ffi::H5FD_MPIO_COLLECTIVE))?;
            Ok(plist)
        }
    })
}

/// This rank's rows of a dataset: the file selection and the memory space
/// (none for no rows: the empty file selection serves as both).
struct RowSelection {
    file: hdf5::Dataspace,
    memory: Option<hdf5::Dataspace>,
}

impl RowSelection {
    /// Rows `rows` (first dimension, all of the others) of `ds`, to be
    /// written from `len` values.
    fn new(ds: &hdf5::Dataset, rows: Range<usize>, len: usize) -> hdf5::Result<RowSelection> {
        let file = ds.space()?;
        let mut count: Vec<usize> = file.shape();
        if count.is_empty() || rows.end > count[0] {
            return Err(format!("rows {rows:?} outside shape {count:?}").into());
        }
        count[0] = rows.len();
        if count.iter().product::<usize>() != len {
            return Err(format!("{len} values for {count:?} entries").into());
        }
        if rows.is_empty() {
            // SAFETY: `file` is a dataspace this function owns.
            h5check(hdf5::sync::sync(|| unsafe {
                ffi::H5Sselect_none(file.id())
            }))?;
            return Ok(RowSelection { file, memory: None });
        }
        let memory = hdf5::Dataspace::try_new(count.clone())?;
        let mut start = vec![0 as ffi::Hsize; count.len()];
        start[0] = rows.start as ffi::Hsize;
        let count: Vec<ffi::Hsize> = count.iter().map(|&c| c as ffi::Hsize).collect();
        // SAFETY: `start` and `count` have the rank of `file`; null stride
        // and block mean 1.
        h5check(hdf5::sync::sync(|| unsafe {
            ffi::H5Sselect_hyperslab(
                file.id(),
                ffi::H5S_SELECT_SET,
                start.as_ptr(),
                std::ptr::null(),
                count.as_ptr(),
                std::ptr::null(),
            )
        }))?;
        Ok(RowSelection {
            file,
            memory: Some(memory),
        })
    }

    /// `H5Dwrite` of `data` (as many values as selected) with transfer list
    /// `xfer`: collective when `xfer` says so, so every rank calls it.
    fn write<T: hdf5::H5Type>(
        &self,
        ds: &hdf5::Dataset,
        data: &[T],
        xfer: ffi::Hid,
    ) -> hdf5::Result<()> {
        let dtype = hdf5::Datatype::from_type::<T>()?;
        let memory = self.memory.as_ref().unwrap_or(&self.file);
        // SAFETY: `data` holds exactly the selected number of `T`s (checked
        // in `new`), laid out as the memory space says; the ids are alive.
        h5check(hdf5::sync::sync(|| unsafe {
            ffi::H5Dwrite(
                ds.id(),
                dtype.id(),
                memory.id(),
                self.file.id(),
                xfer,
                data.as_ptr().cast(),
            )
        }))
    }
}

/// Index of the grid called `name` (validated grids: it exists).
fn grid_index(results: &Results, name: &str) -> Option<usize> {
    results.grids.iter().position(|g| g.name == name)
}

fn entries(grid: Option<&Grid>, center: Center) -> usize {
    match (grid, center) {
        (Some(g), Center::Node) => g.points.len(),
        (Some(g), Center::Cell) => g.topology.cell_count(),
        (None, _) => 0,
    }
}

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// One `DataItem` referring to `h5_name:path`.
fn data_item(
    out: &mut String,
    indent: &str,
    dims: &[usize],
    float: bool,
    h5_name: &str,
    path: &str,
) {
    let dims: Vec<String> = dims.iter().map(|d| d.to_string()).collect();
    let (number_type, precision) = if float { ("Float", 8) } else { ("Int", 8) };
    let _ = writeln!(
        out,
        "{indent}<DataItem Dimensions=\"{}\" NumberType=\"{number_type}\" Precision=\"{precision}\" Format=\"HDF\">{}:{}</DataItem>",
        dims.join(" "),
        xml_escape(h5_name),
        xml_escape(path)
    );
}

/// Topology + geometry of one grid.
fn grid_mesh(out: &mut String, indent: &str, g: &Grid, h5_name: &str) {
    let m = g.topology.cell_count();
    let npc = g.topology.nodes_per_cell();
    let _ = writeln!(
        out,
        "{indent}<Topology TopologyType=\"{}\" NumberOfElements=\"{m}\" NodesPerElement=\"{npc}\">",
        g.topology.xdmf_type()
    );
    let inner = format!("{indent}  ");
    data_item(
        out,
        &inner,
        &[m, npc],
        false,
        h5_name,
        &format!("/grids/{}/cells", g.name),
    );
    let _ = writeln!(out, "{indent}</Topology>");
    let _ = writeln!(out, "{indent}<Geometry GeometryType=\"XY\">");
    let n = g.points.len();
    data_item(
        out,
        &inner,
        &[n, 2],
        true,
        h5_name,
        &format!("/grids/{}/points", g.name),
    );
    let _ = writeln!(out, "{indent}</Geometry>");
}

/// The XDMF text; `h5_name` is the bare file name of the HDF5 file.
fn xdmf_text(results: &Results, h5_name: &str) -> String {
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str("<Xdmf Version=\"3.0\">\n  <Domain>\n");
    if results.steps.is_empty() {
        out.push_str(
            "    <Grid Name=\"meshes\" GridType=\"Collection\" CollectionType=\"Spatial\">\n",
        );
        for g in &results.grids {
            let _ = writeln!(
                out,
                "      <Grid Name=\"{}\" GridType=\"Uniform\">",
                xml_escape(&g.name)
            );
            grid_mesh(&mut out, "        ", g, h5_name);
            out.push_str("      </Grid>\n");
        }
        out.push_str("    </Grid>\n");
    } else {
        out.push_str(
            "    <Grid Name=\"nndd\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
        );
        for (k, step) in results.steps.iter().enumerate() {
            let _ = writeln!(
                out,
                "      <Grid Name=\"step_{k}\" GridType=\"Collection\" CollectionType=\"Spatial\">"
            );
            let _ = writeln!(out, "        <Time Value=\"{}\"/>", step.time);
            for g in &results.grids {
                let _ = writeln!(
                    out,
                    "        <Grid Name=\"{}\" GridType=\"Uniform\">",
                    xml_escape(&g.name)
                );
                grid_mesh(&mut out, "          ", g, h5_name);
                let fields = step
                    .grids
                    .iter()
                    .filter(|gf| gf.grid == g.name)
                    .flat_map(|gf| &gf.fields);
                for field in fields {
                    let _ = writeln!(
                        out,
                        "          <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"{}\">",
                        xml_escape(&field.name),
                        field.kind.xdmf_type(),
                        field.center.xdmf_name()
                    );
                    let shape = field.stored_shape(entries(Some(g), field.center));
                    let path = format!("/steps/{k}/{}/{}", g.name, field.name);
                    data_item(&mut out, "            ", &shape, true, h5_name, &path);
                    out.push_str("          </Attribute>\n");
                }
                out.push_str("        </Grid>\n");
            }
            out.push_str("      </Grid>\n");
        }
        out.push_str("    </Grid>\n");
    }
    out.push_str("  </Domain>\n</Xdmf>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty directory unique to this process and test.
    struct TestDir(PathBuf);

    impl TestDir {
        fn new(test: &str) -> TestDir {
            let dir =
                std::env::temp_dir().join(format!("nndd-output-{}-{test}", std::process::id()));
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).expect("create test dir");
            TestDir(dir)
        }

        fn entries(&self) -> Vec<String> {
            let mut v: Vec<String> = fs::read_dir(&self.0)
                .expect("read test dir")
                .map(|e| {
                    e.expect("dir entry")
                        .file_name()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect();
            v.sort();
            v
        }
    }

    impl Drop for TestDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    /// Distinct, non-round values: value `i` of a field tagged `tag`.
    fn vals(tag: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| tag + 0.1 * i as f64 + 1.0 / 3.0).collect()
    }

    fn field(name: &str, center: Center, kind: Kind, tag: f64, entries: usize) -> Field {
        Field {
            name: name.into(),
            center,
            kind,
            values: vals(tag, entries * kind.given()),
        }
    }

    fn sample() -> Results {
        let lower = Grid {
            name: "body1".into(),
            points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            topology: Topology::Triangle(vec![[0, 1, 2], [0, 2, 3]]),
        };
        let upper = Grid {
            name: "body2".into(),
            points: vec![[0.0, 1.0], [1.0, 1.0], [2.0, 1.0], [0.5, 2.0], [1.5, 2.0]],
            topology: Topology::Triangle(vec![[0, 1, 3], [1, 4, 3], [1, 2, 4]]),
        };
        let contact = Grid {
            name: "contact".into(),
            points: vec![[0.0, 1.0], [0.5, 1.0], [1.0, 1.0]],
            topology: Topology::Segment(vec![[0, 1], [1, 2]]),
        };
        let steps = (0..2)
            .map(|k| {
                let t = 10.0 * (k as f64 + 1.0);
                Step {
                    time: k as f64 + 1.0,
                    grids: vec![
                        GridFields {
                            grid: "body1".into(),
                            fields: vec![
                                field("u", Center::Node, Kind::Vector, t + 1.0, 4),
                                field("sigma", Center::Cell, Kind::Tensor, t + 2.0, 2),
                                field("eta", Center::Cell, Kind::Scalar, t + 3.0, 2),
                            ],
                        },
                        GridFields {
                            grid: "body2".into(),
                            fields: vec![
                                field("u", Center::Node, Kind::Vector, t + 4.0, 5),
                                field("sigma", Center::Cell, Kind::Tensor, t + 5.0, 3),
                                field("eta", Center::Cell, Kind::Scalar, t + 6.0, 3),
                            ],
                        },
                        GridFields {
                            grid: "contact".into(),
                            fields: vec![
                                field("lambda", Center::Node, Kind::Scalar, t + 7.0, 3),
                                field("gap", Center::Cell, Kind::Scalar, t + 8.0, 2),
                            ],
                        },
                    ],
                }
            })
            .collect();
        Results {
            grids: vec![lower, upper, contact],
            steps,
            attributes: vec![("nranks".into(), 2.0), ("error_bound".into(), 0.125)],
        }
    }

    fn read(file: &hdf5::File, path: &str) -> (Vec<usize>, Vec<f64>) {
        let ds = file.dataset(path).unwrap_or_else(|e| panic!("{path}: {e}"));
        (ds.shape(), ds.read_raw::<f64>().expect("read f64"))
    }

    /// (file part, dataset path, dims) of every DataItem in the XDMF text.
    fn data_items(xdmf: &str) -> Vec<(String, String, Vec<usize>)> {
        let mut items = Vec::new();
        let mut rest = xdmf;
        while let Some(start) = rest.find("<DataItem ") {
            let after = &rest[start..];
            let tag_end = after.find('>').expect("DataItem tag end");
            let tag = &after[..tag_end];
            let dims_at = tag.find("Dimensions=\"").expect("Dimensions") + 12;
            let dims_len = tag[dims_at..].find('"').expect("Dimensions end");
            let dims = tag[dims_at..dims_at + dims_len]
                .split_whitespace()
                .map(|d| d.parse().expect("dimension"))
                .collect();
            let body_end = after.find("</DataItem>").expect("DataItem end");
            let body = after[tag_end + 1..body_end].trim();
            let (file, path) = body.split_once(':').expect("file:path");
            items.push((file.to_string(), path.to_string(), dims));
            rest = &after[body_end..];
        }
        items
    }

    #[test]
    fn writes_and_reads_back() {
        let dir = TestDir::new("roundtrip");
        let prefix = dir.0.join("run.1");
        let results = sample();
        check_writable(&prefix).expect("writable");
        write_results(&prefix, &results).expect("write");
        // Overwriting an existing pair works too.
        write_results(&prefix, &results).expect("rewrite");
        assert_eq!(dir.entries(), vec!["run.1.h5", "run.1.xdmf"]);

        let file = hdf5::File::open(dir.0.join("run.1.h5")).expect("open h5");
        let mut names = file.attr_names().expect("attr names");
        names.sort();
        assert_eq!(names, vec!["error_bound", "nranks"]);
        for (name, value) in &results.attributes {
            let got: f64 = file.attr(name).unwrap().read_scalar().unwrap();
            assert_eq!(got, *value, "attribute {name}");
        }
        for g in &results.grids {
            let (shape, points) = read(&file, &format!("grids/{}/points", g.name));
            assert_eq!(shape, vec![g.points.len(), 2]);
            assert_eq!(
                points,
                g.points.iter().flatten().copied().collect::<Vec<_>>()
            );
            let ds = file.dataset(&format!("grids/{}/cells", g.name)).unwrap();
            let cells: Vec<i64> = ds.read_raw().unwrap();
            let (expected, npc): (Vec<i64>, usize) = match &g.topology {
                Topology::Triangle(c) => (c.iter().flatten().map(|&i| i as i64).collect(), 3),
                Topology::Segment(c) => (c.iter().flatten().map(|&i| i as i64).collect(), 2),
            };
            assert_eq!(ds.shape(), vec![expected.len() / npc, npc]);
            assert_eq!(cells, expected);
        }
        let mut step_names = file.group("steps").unwrap().member_names().unwrap();
        step_names.sort();
        assert_eq!(step_names, vec!["0", "1"]);
        for (k, step) in results.steps.iter().enumerate() {
            let group = file.group(&format!("steps/{k}")).unwrap();
            let time: f64 = group.attr("time").unwrap().read_scalar().unwrap();
            assert_eq!(time, step.time);
            for gf in &step.grids {
                let grid = results.grids.iter().find(|g| g.name == gf.grid).unwrap();
                for f in &gf.fields {
                    let (shape, data) = read(&file, &format!("steps/{k}/{}/{}", gf.grid, f.name));
                    let n = match f.center {
                        Center::Node => grid.points.len(),
                        Center::Cell => grid.topology.cell_count(),
                    };
                    match f.kind {
                        Kind::Scalar => {
                            assert_eq!(shape, vec![n]);
                            assert_eq!(data, f.values);
                        }
                        Kind::Tensor => {
                            assert_eq!(shape, vec![n, 9]);
                            for i in 0..n {
                                let g = &f.values[6 * i..6 * i + 6];
                                let (xx, yy, zz, xy, yz, xz) = (g[0], g[1], g[2], g[3], g[4], g[5]);
                                let full = [xx, xy, xz, xy, yy, yz, xz, yz, zz];
                                assert_eq!(&data[9 * i..9 * i + 9], &full[..], "entry {i}");
                            }
                        }
                        Kind::Vector => {
                            assert_eq!(shape, vec![n, 3]);
                            for i in 0..n {
                                assert_eq!(data[3 * i], f.values[2 * i]);
                                assert_eq!(data[3 * i + 1], f.values[2 * i + 1]);
                                assert_eq!(data[3 * i + 2], 0.0);
                            }
                        }
                    }
                }
            }
        }

        let xdmf = fs::read_to_string(dir.0.join("run.1.xdmf")).expect("read xdmf");
        let items = data_items(&xdmf);
        // Per step and grid: cells + points; plus 8 fields per step.
        assert_eq!(items.len(), 2 * (3 * 2 + 8));
        for (file_part, path, dims) in &items {
            assert_eq!(file_part, "run.1.h5", "relative file name");
            let ds = file
                .dataset(path)
                .unwrap_or_else(|e| panic!("XDMF refers to {path}, not in h5: {e}"));
            assert_eq!(&ds.shape(), dims, "dims of {path}");
        }
        assert_eq!(xdmf.matches("<Time Value=\"1\"/>").count(), 1);
        assert_eq!(xdmf.matches("<Time Value=\"2\"/>").count(), 1);
        assert_eq!(xdmf.matches("TopologyType=\"Triangle\"").count(), 4);
        assert_eq!(xdmf.matches("TopologyType=\"Polyline\"").count(), 2);
        assert_eq!(xdmf.matches("AttributeType=\"Tensor\"").count(), 4);
        assert_eq!(xdmf.matches("AttributeType=\"Vector\"").count(), 4);
        assert_eq!(xdmf.matches("AttributeType=\"Scalar\"").count(), 8);
        assert_eq!(xdmf.matches("Center=\"Cell\"").count(), 10);
    }

    #[test]
    fn meshes_only_without_steps() {
        let dir = TestDir::new("nosteps");
        let prefix = dir.0.join("mesh");
        let mut results = sample();
        results.steps.clear();
        write_results(&prefix, &results).expect("write");
        let xdmf = fs::read_to_string(dir.0.join("mesh.xdmf")).unwrap();
        assert!(!xdmf.contains("Temporal"));
        let file = hdf5::File::open(dir.0.join("mesh.h5")).unwrap();
        let items = data_items(&xdmf);
        assert_eq!(items.len(), 6);
        for (_, path, dims) in &items {
            assert_eq!(&file.dataset(path).unwrap().shape(), dims);
        }
    }

    #[test]
    fn unwritable_location_fails_and_leaves_nothing() {
        let dir = TestDir::new("unwritable");
        let blocker = dir.0.join("blocker");
        fs::write(&blocker, b"a regular file").unwrap();
        let prefix = blocker.join("sub").join("run");

        let err = check_writable(&prefix).expect_err("parent is a regular file");
        let msg = err.to_string();
        assert!(msg.contains("-nndd_output"), "{msg}");
        assert!(msg.contains(&prefix.display().to_string()), "{msg}");

        let err = write_results(&prefix, &sample()).expect_err("write under a file");
        assert!(
            err.to_string().contains(&blocker.display().to_string()),
            "{err}"
        );
        let err = write_atomic(&blocker.join("run.json"), b"{}").expect_err("json under a file");
        assert!(err.to_string().contains("run.json"), "{err}");

        assert_eq!(dir.entries(), vec!["blocker"]);
        assert_eq!(fs::read(&blocker).unwrap(), b"a regular file");
    }

    #[test]
    fn check_writable_creates_directory_and_leaves_no_probe() {
        let dir = TestDir::new("checkdir");
        let prefix = dir.0.join("a").join("b").join("run");
        check_writable(&prefix).expect("writable");
        assert!(dir.0.join("a/b").is_dir());
        assert_eq!(fs::read_dir(dir.0.join("a/b")).unwrap().count(), 0);
        // A directory where PREFIX.h5 should go is reported early.
        fs::create_dir(dir.0.join("a/b/run.h5")).unwrap();
        let err = check_writable(&prefix).expect_err("run.h5 is a directory");
        assert!(err.to_string().contains("run.h5"), "{err}");
        assert!(matches!(
            check_writable(Path::new("/")),
            Err(OutputError::BadPrefix { .. })
        ));
    }

    fn assert_invalid(results: &Results, needle: &str) {
        let dir = TestDir::new(&format!("invalid-{}", needle.replace(' ', "_")));
        let prefix = dir.0.join("run");
        match write_results(&prefix, results) {
            Err(OutputError::Invalid { path, reason }) => {
                assert_eq!(path, dir.0.join("run.h5"));
                assert!(reason.contains(needle), "{reason:?} lacks {needle:?}");
            }
            other => panic!("expected Invalid({needle}), got {other:?}"),
        }
        assert!(dir.entries().is_empty(), "{:?}", dir.entries());
    }

    #[test]
    fn invalid_results_fail_and_leave_nothing() {
        let mut r = sample();
        r.steps[1].grids[0].fields[1].values.pop();
        assert_invalid(&r, "11 values, expected 2 cells x 6");

        let mut r = sample();
        r.steps[0].grids[2].fields[0].values.push(1.0);
        assert_invalid(&r, "4 values, expected 3 points x 1");

        let mut r = sample();
        r.steps[1].grids[1].grid = "body3".into();
        assert_invalid(&r, "unknown grid");

        let mut r = sample();
        r.grids[0].topology = Topology::Triangle(vec![[0, 1, 4]]);
        assert_invalid(&r, "refers to point 4");

        let mut r = sample();
        r.steps[1].time = 1.0;
        assert_invalid(&r, "does not increase");

        let mut r = sample();
        r.steps[0].grids[0].fields[0].name = "u/x".into();
        assert_invalid(&r, "name must be");

        let mut r = sample();
        r.grids[2].name = "body1".into();
        assert_invalid(&r, "used twice");
    }

    #[test]
    fn failed_write_keeps_previous_results() {
        let dir = TestDir::new("keep");
        let prefix = dir.0.join("run");
        write_results(&prefix, &sample()).expect("write");
        let h5 = fs::read(dir.0.join("run.h5")).unwrap();
        let xdmf = fs::read(dir.0.join("run.xdmf")).unwrap();
        let mut bad = sample();
        bad.steps[0].grids[0].fields[0].values.clear();
        assert!(write_results(&prefix, &bad).is_err());
        assert_eq!(dir.entries(), vec!["run.h5", "run.xdmf"]);
        assert_eq!(fs::read(dir.0.join("run.h5")).unwrap(), h5);
        assert_eq!(fs::read(dir.0.join("run.xdmf")).unwrap(), xdmf);
    }

    #[test]
    fn error_after_temporary_is_written_removes_it() {
        let dir = TestDir::new("midway");
        let h5 = dir.0.join("run.h5");
        let xdmf = dir.0.join("run.xdmf");
        let result = commit_pair(
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
            &xdmf,
            b"<Xdmf/>",
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
