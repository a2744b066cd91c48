//! Result files: `PREFIX.h5` (HDF5, the data) + the XDMF 3 files that describe it to
//! ParaView, meshio and DOLFINx (`PREFIX.xdmf`, `PREFIX-<grid>.xdmf`, `PREFIX-final.xdmf`), written
//! whole or not at all, and [`write_atomic`] for small text files such as `PREFIX.json`.
//!
//! # Processes
//!
//! [`write_results_parallel`] is collective over an MPI communicator and
//! writes one `PREFIX.h5` whatever the number of ranks. Every rank passes
//! [`Results`] of the same structure (the same grids with the same point and cell counts,
//! the same steps, field names, kinds and centers, the same attributes; checked with a hash)
//! and, per grid, a [`Share`]: the contiguous rows of points and of cells it writes. The
//! ranks' shares tile each grid (checked); a rank gives a grid's points and cells, and a
//! field's values, for every entry of the grid, or for its share's rows alone (so that no
//! rank need hold a grid or a step's fields whole), or none where its share is empty.
//! All ranks open the file with the MPI-IO driver (`H5Pset_fapl_mpio`),
//! create every group, attribute and dataset together in the same order
//! (creation is collective in parallel HDF5; datasets are contiguous), and
//! write their hyperslab of every dataset (points, cells, each field at each
//! step) in one collective transfer (`H5FD_MPIO_COLLECTIVE`) per dataset,
//! ranks without rows taking part with an empty selection. Rank 0 alone
//! writes the `.xdmf` files and renames the files. The result is the same, dataset
//! by dataset and attribute by attribute, as the one-process file.
//!
//! [`write_results`] is the same code on one process: each grid is one share,
//! the file uses HDF5's default (serial) driver, and no MPI call is made (MPI
//! need not be initialised).
//!
//! # Atomicity
//!
//! [`write_results`] first validates the whole [`Results`] (nothing is
//! created when that fails), then writes every file to hidden temporaries in
//! the destination directory (`.NAME.h5.tmp.*`, `.NAME.xdmf.tmp.*`, …),
//! syncs them, and renames the `.h5` into place and then the `.xdmf` files. On any
//! error the temporaries are removed, so no partial file remains and
//! previously written results are untouched. The `.xdmf` files are renamed last, so
//! an `.xdmf` that names `PREFIX.h5` never appears before that file is
//! complete (when results are overwritten, the old `.xdmf` sits beside the new
//! `.h5` between the renames). The destination directory is not created by the writers: call
//! [`check_writable`] first (it creates it).
//!
//! Parallel files are created in two walks: every group, attribute and dataset first
//! (contiguous datasets get their space at creation), then rank 0 reserves the file's extent
//! on disk (`posix_fallocate` to the end of the last dataset), then the datasets are written;
//! so a full disk or the file-size limit fails the reservation, before HDF5 writes anything.
//! A file that fails after its creation is left open, never closed, and
//! [`file_left_open`] says so: the process must then end without `MPI_Finalize` (where HDF5
//! would close it, flushing into the failed file again).
//!
//! [`write_results_parallel`] keeps the same contract. Every rank validates
//! its `Results` and shares before anything is created; rank 0 picks the
//! temporary name and broadcasts it; the temporary is closed collectively,
//! then rank 0 syncs it, writes the `.xdmf` temporaries and renames them all. The
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
//! # HDF5 layout (the contract for users and tests; docs/output.md for nndd's fields)
//!
//! All floating-point data are little-endian `f64`; connectivity is `i64`
//! (0-based point indices).
//!
//! | path | shape | content |
//! | --- | --- | --- |
//! | `/` attributes | scalar `f64` or text each | [`Results::attributes`], [`Results::text`] |
//! | `/Mesh/<grid>/geometry` | N×2 `f64` | x, y of each point |
//! | `/Mesh/<grid>/topology` | M×3 `i64` (triangles) or M×2 `i64` (segments) | point indices of each cell |
//! | `/Mesh/<grid>/<field>` | see below | a field of [`Grid::fields`] (the same at every step) |
//! | `/Function/<grid>/<field>/<t>` | see below | a field of one grid at the step of time t ([`function_path`]) |
//!
//! Field datasets, with n = N (points, [`Center::Node`]) or M (cells,
//! [`Center::Cell`]):
//!
//! | [`Kind`] | values given | dataset shape |
//! | --- | --- | --- |
//! | `Scalar` | n | n (one-dimensional) |
//! | `Vector` | n×2 (x, y per entry) | n×3, z column = 0 |
//! | `Tensor` | n×6 (xx yy zz xy yz xz per entry) | n×6 as given (XDMF `Tensor6`) |
//!
//! ParaView 5.11's default XDMF reader (Xdmf3ReaderS) passes a `Tensor6` through to VTK in
//! this order and names its components XX YY ZZ XY YZ XZ (checked with pvpython); meshio
//! reads an n×6 array. Times must be finite and strictly increasing (each step is a distinct
//! time step in ParaView, and names its datasets).
//!
//! # XDMF
//!
//! One mesh per file, in the layout of DOLFINx's `XDMFFile` and meshio's time series: the
//! first grid's in `PREFIX.xdmf`, every other grid's in `PREFIX-<grid>.xdmf` (so no grid may be
//! called `final`), and the first grid at the last step alone in `PREFIX-final.xdmf`. A file
//! holds a `Uniform` grid with the `Topology` (`Triangle`, or `Polyline` with
//! `NodesPerElement="2"`) and `Geometry` (`XY`), then a temporal collection: per step a
//! `Uniform` grid that includes them (`xi:include` of the first `Uniform` grid's topology and
//! geometry), its `Time`, and an `Attribute` per field (the grid's constant fields, then the
//! step's). `PREFIX-final.xdmf` is a single `Uniform` grid with its attributes (no time). Without
//! steps a file holds the mesh alone. Datasets are named `NAME.h5:/path` with the bare file
//! name, i.e. relative to the `.xdmf`, so the files can be moved together.
//!
//! One mesh per file because of the readers: ParaView's Xdmf3ReaderS reads the grids of a file
//! as pieces of one dataset (no names), and draws every piece in one solid colour when the
//! pieces do not carry the same fields; meshio's `TimeSeriesReader` reads one mesh and one
//! collection per file. So `tests/viewers.rs` opens the files with ParaView's default reader
//! and with meshio.
//!
//! # Files
//!
//! - `validate`: the checks of the results, shares and PREFIX made before
//!   anything is created.
//! - `team`: the processes writing together (one, or the ranks of a
//!   communicator), their agreement on success and the check of their shares.
//! - `paths`: every file name, made from PREFIX ([`OutputPaths`]).
//! - `atomic`: writing to temporaries and renaming them into place.
//! - `h5`: the HDF5 file.
//! - `collective`: the HDF5 C calls of a collective write (hdf5-metno-sys): the collective
//!   transfer list and a rank's rows of a dataset.
//! - `xdmf`: the XDMF text.

mod atomic;
mod collective;
mod h5;
pub mod paths;
mod team;
#[cfg(test)]
mod testutil;
mod validate;
mod xdmf;

use std::fs;
use std::io::{self, Write as _};
use std::ops::Range;
use std::path::{Path, PathBuf};

use atomic::commit_files;
pub use atomic::write_atomic;
pub use h5::file_left_open;
use h5::write_h5;
pub use paths::OutputPaths;
use team::{agree, check_team, Alone, Team, Writers};
use validate::{prefix_name, validate};
pub use xdmf::collection_of_singles;

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
    /// 6 values per entry: xx yy zz xy yz xz (a symmetric tensor), written as they are
    /// (XDMF `Tensor6`).
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

/// A mesh: 2D points and cells, with the fields that are the same at every step (stored
/// once, beside the mesh, and given at every step).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub name: String,
    /// How many points and cells the grid has.
    pub extent: Extent,
    /// The points: all of them, or this rank's share's rows alone (as a field's values).
    pub points: Vec<[f64; 2]>,
    /// The cells, by point indices in the grid's numbering: all of them, or this rank's
    /// share's rows alone.
    pub topology: Topology,
    pub fields: Vec<Field>,
}

/// The point and cell counts of a grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Extent {
    pub points: usize,
    pub cells: usize,
}

impl Grid {
    /// A grid given whole: its extent is that of `points` and `topology`.
    pub fn whole(
        name: &str,
        points: Vec<[f64; 2]>,
        topology: Topology,
        fields: Vec<Field>,
    ) -> Grid {
        let extent = Extent {
            points: points.len(),
            cells: topology.cell_count(),
        };
        Grid {
            name: name.into(),
            extent,
            points,
            topology,
            fields,
        }
    }

    /// Points `rows` as stored (x, y after each other), from the points held: all of them
    /// or `rows` alone.
    fn stored_points(&self, rows: Range<usize>) -> Vec<f64> {
        let held = match self.points.len() == self.extent.points {
            true => &self.points[rows],
            false => &self.points[..],
        };
        held.iter().flatten().copied().collect()
    }

    /// The point indices of cells `rows`, cell after cell, from the cells held: all of them
    /// or `rows` alone.
    fn stored_cells(&self, rows: Range<usize>) -> Vec<i64> {
        match self.topology.cell_count() == self.extent.cells {
            true => self.topology.flat_rows(rows),
            false => self.topology.flat_rows(0..self.topology.cell_count()),
        }
    }
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

impl Step {
    /// The fields of grid `grid` at this step.
    pub fn fields_of<'a>(&'a self, grid: &'a str) -> impl Iterator<Item = &'a Field> + 'a {
        self.grids
            .iter()
            .filter(move |gf| gf.grid == grid)
            .flat_map(|gf| &gf.fields)
    }
}

/// Everything [`write_results`] writes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Results {
    pub grids: Vec<Grid>,
    pub steps: Vec<Step>,
    /// File-level scalar attributes (attributes of the HDF5 root group).
    pub attributes: Vec<(String, f64)>,
    /// File-level text attributes (attributes of the HDF5 root group).
    pub text: Vec<(String, String)>,
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
            points: 0..grid.extent.points,
            cells: 0..grid.extent.cells,
        }
    }

    /// The rows of a field with this center.
    pub fn rows(&self, center: Center) -> Range<usize> {
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
    /// A file-system operation failed (writes go to temporaries: the file of that name, if
    /// any, is untouched).
    #[error("{}: cannot {action}: {source}; any previous file of that name is untouched", .path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
        source: io::Error,
    },
    /// The HDF5 library reported an error.
    #[error("{}: HDF5 error while {action}: {source}; any previous file of that name is untouched", .path.display())]
    Hdf5 {
        path: PathBuf,
        action: String,
        source: hdf5::Error,
    },
    #[error(transparent)]
    Fault(#[from] crate::parallel::fault::InjectedFault),
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
    pub fn given(self) -> usize {
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
            Kind::Tensor => 6,
        }
    }

    fn xdmf_type(self) -> &'static str {
        match self {
            Kind::Scalar => "Scalar",
            Kind::Vector => "Vector",
            Kind::Tensor => "Tensor6",
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
    /// Entries `rows` as stored in the file (vectors padded with z = 0), from values given
    /// for each of the grid's `entries`, or for `rows` alone; nothing for no rows (the values
    /// may then be empty).
    fn stored_rows(&self, rows: Range<usize>, entries: usize) -> Vec<f64> {
        if rows.is_empty() {
            return Vec::new();
        }
        let given = self.kind.given();
        let values = match self.values.len() == entries * given {
            true => &self.values[rows.start * given..rows.end * given],
            false => &self.values[..],
        };
        match self.kind {
            Kind::Vector => values
                .chunks_exact(2)
                .flat_map(|v| [v[0], v[1], 0.0])
                .collect(),
            Kind::Tensor | Kind::Scalar => values.to_vec(),
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

/// Index of the grid called `name` (validated grids: it exists).
fn grid_index(results: &Results, name: &str) -> Option<usize> {
    results.grids.iter().position(|g| g.name == name)
}

fn entries(grid: Option<&Grid>, center: Center) -> usize {
    match (grid, center) {
        (Some(g), Center::Node) => g.extent.points,
        (Some(g), Center::Cell) => g.extent.cells,
        (None, _) => 0,
    }
}

/// Check early (before any solve) that PREFIX's directory exists or can be
/// created and that files can be written there: create and remove a probe
/// file. The error names the option `-nndd_output` and the path.
pub fn check_writable(prefix: &Path) -> Result<(), OutputError> {
    let name = prefix_name(prefix)?;
    let paths = OutputPaths::new(prefix);
    let dir = paths.dir();
    let not_writable = |path: &Path, action, source| OutputError::NotWritable {
        prefix: prefix.to_path_buf(),
        path: path.to_path_buf(),
        action,
        source,
    };
    directory_not_a_file(prefix, &dir)?;
    fs::create_dir_all(&dir).map_err(|e| not_writable(&dir, "create directory", e))?;
    for target in [paths.h5(), paths.xdmf(), paths.json()] {
        if target.is_dir() {
            let e = io::Error::other("it is a directory");
            return Err(not_writable(&target, "replace", e));
        }
    }
    let probe = paths.probe(&name);
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

/// `Ok` unless `dir`, PREFIX's directory, or a directory above it is a file (where creating
/// it would say only "File exists").
fn directory_not_a_file(prefix: &Path, dir: &Path) -> Result<(), OutputError> {
    let not_dir = |a: &&Path| fs::metadata(a).is_ok_and(|m| !m.is_dir());
    let Some(file) = dir.ancestors().find(not_dir) else {
        return Ok(());
    };
    let within = match file == dir {
        true => String::new(),
        false => format!(" is inside {}, which", file.display()),
    };
    Err(OutputError::BadPrefix {
        path: prefix.to_path_buf(),
        reason: format!(
            "its directory {}{within} is a file, not a directory",
            dir.display()
        ),
    })
}

/// Write PREFIX.h5 and PREFIX.xdmf (atomically: write to temporaries in the
/// same directory, rename at the end; on any error remove the temporaries so
/// no partial file remains). One process, no MPI.
pub fn write_results(prefix: &Path, results: &Results) -> Result<(), OutputError> {
    let shares: Vec<Share> = results.grids.iter().map(Share::whole).collect();
    write_on(&Alone, prefix, results, &shares)
}

/// Collective over `comm` (every rank calls it with Results of identical
/// structure: same grids with the same extents, same steps, same field
/// names/kinds/centers in the same order, same attributes). A grid's points and
/// cells, and field `values`, are either full length (all entries of the grid,
/// in the grid's numbering), or exactly this rank's rows (its share, in order),
/// or empty where those rows are empty.
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

/// The HDF5 path of field `field` of grid `grid` at the step of time `time` (DOLFINx's
/// `/Function/<name>/<time>`).
pub(crate) fn function_path(grid: &str, field: &str, time: f64) -> String {
    format!("/Function/{grid}/{field}/{}", time_key(time))
}

/// A step's dataset name: its time, `.` written `_` (41 → `41`, 2.5 → `2_5`).
fn time_key(time: f64) -> String {
    time.to_string().replace('.', "_")
}

/// The XDMF files of `results` next to `PREFIX.h5` (file name `h5_name`): the first grid's
/// series in `PREFIX.xdmf`, each other grid's in `PREFIX-<grid>.xdmf`, and the first grid at
/// the last step alone in `PREFIX-final.xdmf`.
fn xdmf_files(paths: &OutputPaths, results: &Results, h5_name: &str) -> Vec<(PathBuf, String)> {
    let mut files = Vec::new();
    for (i, g) in results.grids.iter().enumerate() {
        let path = if i == 0 {
            paths.xdmf()
        } else {
            paths.grid_xdmf(&g.name)
        };
        files.push((path, xdmf::series_text(results, g, h5_name)));
    }
    if let (Some(g), Some(last)) = (results.grids.first(), results.steps.last()) {
        let text = xdmf::single_text(g, last, h5_name);
        files.push((paths.final_xdmf(), text));
    }
    files
}

/// [`write_results`] and [`write_results_parallel`]: validate (and agree),
/// then write.
fn write_on<W: Writers>(
    w: &W,
    prefix: &Path,
    results: &Results,
    shares: &[Share],
) -> Result<(), OutputError> {
    let paths = OutputPaths::new(prefix);
    let h5_path = paths.h5();
    let checked =
        prefix_name(prefix).and_then(|name| validate(results, shares, &h5_path).map(|()| name));
    let name = agree(w, checked)?;
    check_team(w, results, shares).map_err(|reason| OutputError::Invalid {
        path: h5_path.clone(),
        reason,
    })?;
    let mut xdmfs = xdmf_files(&paths, results, &format!("{name}.h5"));
    if w.rank() != 0 {
        xdmfs.iter_mut().for_each(|(_, text)| text.clear());
    }
    commit_files(
        w,
        &h5_path,
        |tmp| write_h5(w, tmp, &h5_path, results, shares),
        &xdmfs,
    )
}

#[cfg(test)]
mod tests {
    use super::testutil::{data_items, read, sample, TestDir};
    use super::*;

    #[test]
    fn writes_and_reads_back() {
        let dir = TestDir::new("roundtrip");
        let prefix = dir.0.join("run.1");
        let results = sample();
        check_writable(&prefix).expect("writable");
        write_results(&prefix, &results).expect("write");
        // Overwriting existing files works too.
        write_results(&prefix, &results).expect("rewrite");
        let files = [
            "run.1-contact.xdmf",
            "run.1-final.xdmf",
            "run.1.h5",
            "run.1.xdmf",
        ];
        assert_eq!(dir.entries(), files);

        let file = hdf5::File::open(dir.0.join("run.1.h5")).expect("open h5");
        let mut names = file.attr_names().expect("attr names");
        names.sort();
        assert_eq!(names, vec!["error_bound", "nranks", "program"]);
        for (name, value) in &results.attributes {
            let got: f64 = file.attr(name).unwrap().read_scalar().unwrap();
            assert_eq!(got, *value, "attribute {name}");
        }
        let program: hdf5::types::VarLenUnicode =
            file.attr("program").unwrap().read_scalar().unwrap();
        assert_eq!(program.as_str(), "nndd test");
        for g in &results.grids {
            let (shape, points) = read(&file, &format!("Mesh/{}/geometry", g.name));
            assert_eq!(shape, vec![g.points.len(), 2]);
            assert_eq!(
                points,
                g.points.iter().flatten().copied().collect::<Vec<_>>()
            );
            let ds = file.dataset(&format!("Mesh/{}/topology", g.name)).unwrap();
            let cells: Vec<i64> = ds.read_raw().unwrap();
            let (expected, npc): (Vec<i64>, usize) = match &g.topology {
                Topology::Triangle(c) => (c.iter().flatten().map(|&i| i as i64).collect(), 3),
                Topology::Segment(c) => (c.iter().flatten().map(|&i| i as i64).collect(), 2),
            };
            assert_eq!(ds.shape(), vec![expected.len() / npc, npc]);
            assert_eq!(cells, expected);
            for f in &g.fields {
                let (_, data) = read(&file, &format!("Mesh/{}/{}", g.name, f.name));
                assert_eq!(data, f.values);
            }
        }
        let steps = file
            .group("Function/bodies/u")
            .unwrap()
            .member_names()
            .unwrap();
        assert_eq!(steps, vec!["1", "2"]);
        for step in &results.steps {
            for gf in &step.grids {
                let grid = results.grids.iter().find(|g| g.name == gf.grid).unwrap();
                for f in &gf.fields {
                    let (shape, data) = read(&file, &function_path(&gf.grid, &f.name, step.time));
                    let n = match f.center {
                        Center::Node => grid.points.len(),
                        Center::Cell => grid.topology.cell_count(),
                    };
                    match f.kind {
                        Kind::Scalar => assert_eq!(shape, vec![n]),
                        Kind::Tensor => assert_eq!(shape, vec![n, 6]),
                        Kind::Vector => assert_eq!(shape, vec![n, 3]),
                    }
                    if f.kind == Kind::Vector {
                        for i in 0..n {
                            assert_eq!(data[3 * i], f.values[2 * i]);
                            assert_eq!(data[3 * i + 1], f.values[2 * i + 1]);
                            assert_eq!(data[3 * i + 2], 0.0);
                        }
                    } else {
                        assert_eq!(data, f.values);
                    }
                }
            }
        }

        // Every DataItem names a dataset of run.1.h5, by its bare name, with its shape.
        let text = |name: &str| fs::read_to_string(dir.0.join(name)).expect("read xdmf");
        for name in files.iter().filter(|n| n.ends_with(".xdmf")) {
            for (file_part, path, dims) in &data_items(&text(name)) {
                assert_eq!(file_part, "run.1.h5", "relative file name");
                let ds = file
                    .dataset(path)
                    .unwrap_or_else(|e| panic!("{name} refers to {path}, not in h5: {e}"));
                assert_eq!(&ds.shape(), dims, "dims of {path}");
            }
        }
        // The series: the mesh, then a temporal collection including it, a step per time.
        let series = text("run.1.xdmf");
        assert_eq!(
            series
                .matches("<Grid Name=\"bodies\" GridType=\"Uniform\">")
                .count(),
            3
        );
        assert_eq!(series.matches("CollectionType=\"Temporal\"").count(), 1);
        assert_eq!(series.matches("<xi:include").count(), 2);
        assert_eq!(series.matches("<Time Value=").count(), 2);
        assert_eq!(series.matches("TopologyType=\"Triangle\"").count(), 1);
        assert_eq!(series.matches("AttributeType=\"Tensor6\"").count(), 2);
        // `body`, constant, at both steps, from the mesh group.
        assert_eq!(series.matches("run.1.h5:/Mesh/bodies/body<").count(), 2);
        let contact = text("run.1-contact.xdmf");
        assert_eq!(contact.matches("TopologyType=\"Polyline\"").count(), 1);
        assert_eq!(contact.matches("<Time Value=").count(), 2);
        // The last step alone: one grid, no time.
        let last = text("run.1-final.xdmf");
        assert!(!last.contains("<Time") && !last.contains("Collection"));
        assert_eq!(last.matches("<Attribute ").count(), 4);
        assert!(last.contains("run.1.h5:/Function/bodies/eta/2<"));
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
}
