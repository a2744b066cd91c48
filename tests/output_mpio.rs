//! Capability: the collective HDF5 writer `output::write_results_parallel` writes, on any
//! rank count, the file the one-process `write_results` writes, and fails on every rank,
//! leaving no file, where it must.
//!
//! A plain program (`harness = false`): `cargo test --test output_mpio` runs it without MPI,
//! and it runs itself under `mpirun -n N` for N = 1 … 4 (each run must succeed within two
//! minutes). Under mpirun (`mpirun --oversubscribe -n 3 target/release/deps/output_mpio-… DIR`)
//! it is the check itself:
//!
//! Every rank builds the same deterministic results (two triangle grids of a few hundred
//! points, one segment grid, two steps with scalar, vector and tensor fields on nodes and on
//! cells), takes a contiguous share of each grid (grid 0 over all ranks, unevenly; grid 1 over
//! the first half of the ranks; grid 2 on the last rank only; the other ranks have empty shares,
//! and the odd ones among them also drop their field values there), and writes `DIR/nN/par`
//! collectively, twice (the second write replaces the first). Rank 0 then writes the same
//! results with the one-process `write_results` to `DIR/nN/ser` and compares the two files
//! group by group, dataset by dataset (shape, type, layout, bits) and attribute by attribute,
//! and the two XDMF texts. Then the error paths: an unwritable prefix, invalid results on one
//! rank only, shares that leave a gap or overlap, results of another structure on one rank; each
//! must fail on every rank, without hanging, and leave no file (and a failed overwrite leaves
//! the previous pair untouched).
//!
//! Prints `output_mpio: N ranks, D datasets identical` and exits non-zero on any difference.

use std::fs;
use std::path::{Path, PathBuf};

use mpi::collective::SystemOperation;
use mpi::traits::*;
use nndd::io::output::{
    write_results, write_results_parallel, Center, Field, Grid, GridFields, Kind, OutputError,
    Results, Share, Step, Topology,
};

fn main() {
    if std::env::var_os("OMPI_COMM_WORLD_SIZE").is_none() {
        launch();
        return;
    }
    let universe = mpi::initialize().expect("MPI initialisation");
    let world = universe.world();
    let Some(dir) = std::env::args().nth(1).map(PathBuf::from) else {
        if world.rank() == 0 {
            eprintln!("usage: mpirun -n N output_mpio DIR");
        }
        drop(universe);
        std::process::exit(2);
    };
    let dir = dir.join(format!("n{}", world.size()));
    let failures = run(&world, &dir);
    if world.rank() == 0 {
        for f in &failures {
            eprintln!("output_mpio: FAILED: {f}");
        }
    }
    let mine = i32::from(!failures.is_empty());
    let mut any = 0;
    world.all_reduce_into(&mine, &mut any, SystemOperation::max());
    drop(universe);
    std::process::exit(any);
}

/// Run this program under `mpirun -n N` for N = 1 … 4 into a scratch directory; exit non-zero
/// on the first run that fails or takes more than two minutes.
fn launch() {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let exe = std::env::current_exe().expect("the test's own path");
    let dir = std::env::temp_dir().join(format!("nndd-test-output-mpio-{}", std::process::id()));
    let mut failed = false;
    for n in 1..=4 {
        let mut child = Command::new("mpirun")
            .args(["-n", &n.to_string(), "--oversubscribe", "--bind-to", "none"])
            .arg(&exe)
            .arg(&dir)
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
            .stdout(Stdio::inherit())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("mpirun runs (jobs/setup installs OpenMPI)");
        let t = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().expect("mpirun's status") {
                break Some(s);
            }
            if t.elapsed() > Duration::from_secs(120) {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        match status {
            Some(s) if s.success() => println!("output_mpio: mpirun -n {n}: ok"),
            Some(s) => {
                eprintln!("output_mpio: mpirun -n {n}: FAILED ({s})");
                failed = true;
            }
            None => {
                eprintln!("output_mpio: mpirun -n {n}: FAILED (no end within 120 s)");
                failed = true;
            }
        }
    }
    let _ = fs::remove_dir_all(&dir);
    std::process::exit(i32::from(failed));
}

/// Everything, on every rank; the failures found (rank 0 gathers what it can see).
fn run<C: Communicator>(world: &C, dir: &Path) -> Vec<String> {
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let mut failures = Vec::new();
    if rank == 0 {
        let _ = fs::remove_dir_all(dir);
        fs::create_dir_all(dir).expect("create the output directory");
    }
    world.barrier();

    let full = sample();
    let shares = shares_of(&full, rank, size);
    let mine = local_view(&full, &shares, rank);

    // The collective write (twice: the second replaces the first) against the serial one.
    let mut datasets = 0;
    match write_and_compare(world, dir, "par", "ser", &full, &mine, &shares) {
        Ok(d) => datasets += d,
        Err(f) => failures.extend(f),
    }
    // Datasets without any element (a grid without cells): created by all, written by none.
    let (probe, probe_shares) = empty_cells(rank, size);
    match write_and_compare(
        world,
        dir,
        "empty-par",
        "empty-ser",
        &probe,
        &probe,
        &probe_shares,
    ) {
        Ok(d) => datasets += d,
        Err(f) => failures.extend(f),
    }
    if rank == 0 {
        // The comparison itself: one value changed in the last bit must be seen.
        let mut alt = full.clone();
        let v = &mut alt.steps[1].grids[1].fields[3].values[5];
        *v = f64::from_bits(v.to_bits() ^ 1);
        let alt_prefix = dir.join("alt");
        match write_results(&alt_prefix, &alt) {
            Ok(()) => {
                if compare_files(&dir.join("ser.h5"), &dir.join("alt.h5")).is_ok() {
                    failures.push("the comparison missed a changed value".into());
                }
                for name in entries(dir).iter().filter(|n| n.starts_with("alt")) {
                    let _ = fs::remove_file(dir.join(name));
                }
            }
            Err(e) => failures.push(format!("serial write of alt: {e}")),
        }
        // The first grid's series, the other grids' series and the first grid's last step.
        let mut expected: Vec<String> = ["empty-par", "empty-ser", "par", "ser"]
            .iter()
            .flat_map(|p| {
                let others: &[&str] = if p.starts_with("empty") {
                    &[]
                } else {
                    &["body2", "contact"]
                };
                [
                    format!("{p}.h5"),
                    format!("{p}.xdmf"),
                    format!("{p}-final.xdmf"),
                ]
                .into_iter()
                .chain(others.iter().map(move |g| format!("{p}-{g}.xdmf")))
            })
            .collect();
        expected.sort();
        if entries(dir) != expected {
            failures.push(format!(
                "{}: {:?}, expected {expected:?}",
                dir.display(),
                entries(dir)
            ));
        }
    }
    world.barrier();
    failures.extend(error_paths(world, dir, &full, &shares));
    if rank == 0 && failures.is_empty() {
        println!("output_mpio: {size} ranks, {datasets} datasets identical");
        println!("output_mpio: error paths fail on every rank and leave no file");
    }
    failures
}

/// Writes `mine` collectively to `DIR/par` twice, then (rank 0) `full` serially to `DIR/ser`,
/// and compares the two HDF5 files and the two XDMF texts: the number of datasets compared,
/// or the failures.
fn write_and_compare<C: Communicator>(
    world: &C,
    dir: &Path,
    par: &str,
    ser: &str,
    full: &Results,
    mine: &Results,
    shares: &[Share],
) -> Result<usize, Vec<String>> {
    let rank = world.rank();
    let mut failures = Vec::new();
    for pass in 0..2 {
        if let Err(e) = write_results_parallel(world, &dir.join(par), mine, shares) {
            failures.push(format!("rank {rank}: parallel write {pass} of {par}: {e}"));
        }
    }
    let mut datasets = 0;
    if failures.is_empty() && rank == 0 {
        match write_results(&dir.join(ser), full) {
            Ok(()) => match compare_files(
                &dir.join(format!("{par}.h5")),
                &dir.join(format!("{ser}.h5")),
            ) {
                Ok(d) => datasets = d,
                Err(diffs) => failures.extend(diffs),
            },
            Err(e) => failures.push(format!("serial write of {ser}: {e}")),
        }
        let read =
            |name: &str| fs::read_to_string(dir.join(format!("{name}.xdmf"))).unwrap_or_default();
        for part in ["", "-body2", "-contact", "-final"] {
            let (xp, xs) = (read(&format!("{par}{part}")), read(&format!("{ser}{part}")));
            if xp != xs.replace(&format!("{ser}.h5"), &format!("{par}.h5")) {
                failures.push(format!(
                    "{par}{part}.xdmf and {ser}{part}.xdmf differ (beyond the file name)"
                ));
            }
        }
        if read(par).is_empty() {
            failures.push(format!("{par}.xdmf is missing"));
        }
    }
    world.barrier();
    if failures.is_empty() {
        Ok(datasets)
    } else {
        Err(failures)
    }
}

/// A grid with points but no cells (so its cells and cell fields have no element), its
/// points spread over all ranks.
fn empty_cells(rank: usize, size: usize) -> (Results, Vec<Share>) {
    let grid = Grid::whole(
        "probe",
        (0..7).map(|i| [i as f64 / 3.0, 0.5]).collect(),
        Topology::Segment(Vec::new()),
        Vec::new(),
    );
    let results = Results {
        steps: vec![Step {
            time: 0.5,
            grids: vec![GridFields {
                grid: "probe".into(),
                fields: vec![
                    field("value", Center::Node, Kind::Vector, 1.0, 7),
                    field("jump", Center::Cell, Kind::Tensor, 2.0, 0),
                ],
            }],
        }],
        grids: vec![grid],
        attributes: Vec::new(),
        text: Vec::new(),
    };
    let shares = vec![Share {
        points: split(7, rank, size),
        cells: 0..0,
    }];
    (results, shares)
}

/// Each failing write must fail on every rank and leave the directory as it was.
fn error_paths<C: Communicator>(
    world: &C,
    dir: &Path,
    full: &Results,
    shares: &[Share],
) -> Vec<String> {
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let mut failures = Vec::new();
    if rank == 0 {
        fs::write(dir.join("blocker"), b"a regular file").expect("write blocker");
    }
    world.barrier();
    let before = entries(dir);
    let par_h5 = fs::read(dir.join("par.h5")).unwrap_or_default();
    let mine = local_view(full, shares, rank);

    let mut cases: Vec<(&str, PathBuf, Results, Vec<Share>)> = Vec::new();
    cases.push((
        "unwritable prefix",
        dir.join("blocker").join("sub").join("run"),
        mine.clone(),
        shares.to_vec(),
    ));
    let mut bad = mine.clone();
    if rank == size - 1 {
        // Grid 2 lives on the last rank: a value too few there.
        bad.steps[1].grids[2].fields[0].values.pop();
    }
    cases.push((
        "invalid results on the last rank",
        dir.join("bad"),
        bad.clone(),
        shares.to_vec(),
    ));
    // The same, overwriting the existing pair: it must stay as it was.
    cases.push((
        "invalid results, over an existing pair",
        dir.join("par"),
        bad,
        shares.to_vec(),
    ));
    let (mut gap, mut gapped) = (shares.to_vec(), mine.clone());
    if rank == 0 {
        gap[0].points.start = 1;
        // (rank 0 holds its share's points alone: the first is no longer its)
        gapped.grids[0].points.remove(0);
    }
    cases.push(("a gap in the shares", dir.join("gap"), gapped, gap));
    if size > 1 {
        let mut overlap = shares.to_vec();
        if rank == 1 {
            overlap[0].cells.start -= 1;
        }
        cases.push((
            "overlapping shares",
            dir.join("overlap"),
            mine.clone(),
            overlap,
        ));
        let mut other = mine.clone();
        if rank == size - 1 {
            other.attributes[0].1 += 1.0;
        }
        cases.push((
            "another structure on the last rank",
            dir.join("other"),
            other,
            shares.to_vec(),
        ));
    }

    for (what, prefix, results, shares) in &cases {
        let outcome = write_results_parallel(world, prefix, results, shares);
        let message = match &outcome {
            Ok(()) => {
                failures.push(format!("rank {rank}: {what}: the write succeeded"));
                String::new()
            }
            Err(e) => e.to_string(),
        };
        if rank == 0 {
            println!("output_mpio: {what}: rank 0: {message}");
        }
        if rank == size - 1 && size > 1 {
            if let Err(e @ OutputError::OtherRank { .. }) | Err(e @ OutputError::Invalid { .. }) =
                &outcome
            {
                println!("output_mpio: {what}: rank {rank}: {e}");
            }
        }
        world.barrier();
        if rank == 0 && entries(dir) != before {
            failures.push(format!("{what}: {:?}, expected {before:?}", entries(dir)));
        }
        if rank == 0 && fs::read(dir.join("par.h5")).unwrap_or_default() != par_h5 {
            failures.push(format!("{what}: par.h5 changed"));
        }
        world.barrier();
    }
    failures
}

/// Two triangle grids of a few hundred points, one segment grid, two steps.
fn sample() -> Results {
    let body1 = triangles("body1", 14, 16, 0.0, 0.0);
    let body2 = triangles("body2", 18, 12, 0.1, 1.0);
    let contact = Grid::whole(
        "contact",
        (0..41)
            .map(|i| [i as f64 / 40.0 + 1.0 / 7.0, 1.0])
            .collect(),
        Topology::Segment((0..40).map(|i| [i, i + 1]).collect()),
        Vec::new(),
    );
    let grids = vec![body1, body2, contact];
    let steps = (0..2)
        .map(|k| {
            let t = 100.0 * (k as f64 + 1.0);
            let fields_of = |g: &Grid, tag: f64| -> Vec<Field> {
                let (n, m) = (g.points.len(), cells(g));
                if matches!(g.topology, Topology::Segment(_)) {
                    return vec![
                        field("lambda", Center::Node, Kind::Scalar, tag + 1.0, n),
                        field("normal", Center::Node, Kind::Vector, tag + 2.0, n),
                        field("gap", Center::Cell, Kind::Scalar, tag + 3.0, m),
                    ];
                }
                vec![
                    field("u", Center::Node, Kind::Vector, tag + 1.0, n),
                    field("phi", Center::Node, Kind::Scalar, tag + 2.0, n),
                    field("strain", Center::Node, Kind::Tensor, tag + 3.0, n),
                    field("stress", Center::Cell, Kind::Tensor, tag + 4.0, m),
                    field("von_mises", Center::Cell, Kind::Scalar, tag + 5.0, m),
                    field("flux", Center::Cell, Kind::Vector, tag + 6.0, m),
                ]
            };
            Step {
                time: k as f64 + 1.0,
                grids: grids
                    .iter()
                    .enumerate()
                    .map(|(i, g)| GridFields {
                        grid: g.name.clone(),
                        fields: fields_of(g, t + 10.0 * i as f64),
                    })
                    .collect(),
            }
        })
        .collect();
    Results {
        grids,
        steps,
        attributes: vec![
            ("theta".into(), 0.25),
            ("tol".into(), 1e-8),
            ("iterations".into(), 17.0),
        ],
        text: vec![("program".into(), "output_mpio".into())],
    }
}

/// An nx × ny grid of squares split into two triangles, slightly distorted.
fn triangles(name: &str, nx: u32, ny: u32, x0: f64, y0: f64) -> Grid {
    let mut points = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (f64::from(i) / f64::from(nx), f64::from(j) / f64::from(ny));
            points.push([
                x0 + x + 0.01 * (3.0 * y).sin(),
                y0 + y + 0.01 * (5.0 * x).cos(),
            ]);
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let mut cells = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            cells.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            cells.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    // A constant cell field (written once, beside the mesh).
    let fields = vec![field(
        "region",
        Center::Cell,
        Kind::Scalar,
        0.5,
        cells.len(),
    )];
    Grid::whole(name, points, Topology::Triangle(cells), fields)
}

fn cells(g: &Grid) -> usize {
    match &g.topology {
        Topology::Triangle(c) => c.len(),
        Topology::Segment(c) => c.len(),
    }
}

fn field(name: &str, center: Center, kind: Kind, tag: f64, entries: usize) -> Field {
    let given = match kind {
        Kind::Scalar => 1,
        Kind::Vector => 2,
        Kind::Tensor => 6,
    };
    let values = (0..entries * given)
        .map(|i| tag + 1e-3 * i as f64 + ((i * 7919) % 101) as f64 / 3.0)
        .collect();
    Field {
        name: name.into(),
        center,
        kind,
        values,
    }
}

/// Rows `[n·a/b, n·(a+1)/b)` with weights: rank r of `ranks` gets a part ∝ r + 1.
fn split(n: usize, r: usize, ranks: usize) -> std::ops::Range<usize> {
    let total = ranks * (ranks + 1) / 2;
    let before = r * (r + 1) / 2;
    n * before / total..n * (before + r + 1) / total
}

/// Grid 0 over all ranks (unevenly), grid 1 over the first half, grid 2 on the last rank.
fn shares_of(results: &Results, rank: usize, size: usize) -> Vec<Share> {
    let half = size.div_ceil(2);
    results
        .grids
        .iter()
        .enumerate()
        .map(|(g, grid)| {
            let (n, m) = (grid.points.len(), cells(grid));
            match g {
                0 => Share {
                    points: split(n, rank, size),
                    cells: split(m, rank, size),
                },
                1 if rank < half => Share {
                    points: split(n, rank, half),
                    cells: split(m, rank, half),
                },
                2 if rank == size - 1 => Share::whole(grid),
                _ => Share::default(),
            }
        })
        .collect()
}

/// What a rank holds: the full results, but even ranks hold each grid's points and cells
/// of their share alone, and odd ranks drop the field values of the grids they have no share
/// of.
fn local_view(full: &Results, shares: &[Share], rank: usize) -> Results {
    let mut mine = full.clone();
    if rank.is_multiple_of(2) {
        for (g, share) in mine.grids.iter_mut().zip(shares) {
            g.points = g.points[share.points.clone()].to_vec();
            g.topology = match &g.topology {
                Topology::Triangle(c) => Topology::Triangle(c[share.cells.clone()].to_vec()),
                Topology::Segment(c) => Topology::Segment(c[share.cells.clone()].to_vec()),
            };
        }
    }
    if rank % 2 == 1 {
        for (g, share) in mine.grids.iter_mut().zip(shares) {
            if share.points.is_empty() && share.cells.is_empty() {
                g.fields.iter_mut().for_each(|f| f.values.clear());
            }
        }
        for step in &mut mine.steps {
            for (gf, share) in step.grids.iter_mut().zip(shares) {
                if share.points.is_empty() && share.cells.is_empty() {
                    for f in &mut gf.fields {
                        f.values.clear();
                    }
                }
            }
        }
    }
    mine
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Compares two HDF5 files; the number of datasets, or the differences.
fn compare_files(a: &Path, b: &Path) -> Result<usize, Vec<String>> {
    let open = |p: &Path| hdf5::File::open(p).map_err(|e| vec![format!("{}: {e}", p.display())]);
    let (fa, fb) = (open(a)?, open(b)?);
    let mut diffs = Vec::new();
    let mut count = 0;
    compare_group(&fa, &fb, &mut count, &mut diffs);
    if diffs.is_empty() {
        Ok(count)
    } else {
        Err(diffs)
    }
}

fn compare_group(a: &hdf5::Group, b: &hdf5::Group, count: &mut usize, diffs: &mut Vec<String>) {
    let at = a.name();
    compare_attributes(a, b, &at, diffs);
    let names = |g: &hdf5::Group| -> (Vec<String>, Vec<String>) {
        let mut groups: Vec<String> = g
            .groups()
            .unwrap_or_default()
            .iter()
            .map(|x| x.name())
            .collect();
        let mut sets: Vec<String> = g
            .datasets()
            .unwrap_or_default()
            .iter()
            .map(|x| x.name())
            .collect();
        groups.sort();
        sets.sort();
        (groups, sets)
    };
    let ((ga, da), (gb, db)) = (names(a), names(b));
    if ga != gb || da != db {
        diffs.push(format!("{at}: members {ga:?} {da:?} vs {gb:?} {db:?}"));
        return;
    }
    for path in &ga {
        match (a.group(path), b.group(path)) {
            (Ok(x), Ok(y)) => compare_group(&x, &y, count, diffs),
            _ => diffs.push(format!("{path}: cannot open the group")),
        }
    }
    for path in &da {
        *count += 1;
        match (a.dataset(path), b.dataset(path)) {
            (Ok(x), Ok(y)) => {
                if let Err(d) = compare_dataset(&x, &y) {
                    diffs.push(format!("{path}: {d}"));
                }
                compare_attributes(&x, &y, path, diffs);
            }
            _ => diffs.push(format!("{path}: cannot open the dataset")),
        }
    }
}

fn compare_attributes(a: &hdf5::Location, b: &hdf5::Location, at: &str, diffs: &mut Vec<String>) {
    let names = |l: &hdf5::Location| {
        let mut v = l.attr_names().unwrap_or_default();
        v.sort();
        v
    };
    let (na, nb) = (names(a), names(b));
    if na != nb {
        diffs.push(format!("{at}: attributes {na:?} vs {nb:?}"));
        return;
    }
    for name in &na {
        let read = |l: &hdf5::Location| {
            let attr = l.attr(name).map_err(|e| e.to_string())?;
            let dtype = attr
                .dtype()
                .and_then(|t| t.to_descriptor())
                .map_err(|e| e.to_string())?;
            // A number by its bits, a text as it is.
            let value = match attr.read_scalar::<f64>() {
                Ok(v) => v.to_bits().to_string(),
                Err(_) => attr
                    .read_scalar::<hdf5::types::VarLenUnicode>()
                    .map_err(|e| e.to_string())?
                    .to_string(),
            };
            Ok::<_, String>((attr.shape(), format!("{dtype:?}"), value))
        };
        let (x, y) = (read(a), read(b));
        if x.is_err() || x != y {
            diffs.push(format!("{at} attribute {name}: {x:?} vs {y:?}"));
        }
    }
}

fn compare_dataset(a: &hdf5::Dataset, b: &hdf5::Dataset) -> Result<(), String> {
    let describe = |d: &hdf5::Dataset| {
        let dtype = d
            .dtype()
            .and_then(|t| t.to_descriptor())
            .map_err(|e| e.to_string())?;
        Ok::<_, String>((d.shape(), dtype, format!("{:?}", d.layout())))
    };
    let (da, db) = (describe(a)?, describe(b)?);
    if da != db {
        return Err(format!("{da:?} vs {db:?}"));
    }
    let size: usize = da.0.iter().product();
    if size > 0 && da.2 != "Contiguous" {
        return Err(format!("layout {}, expected contiguous", da.2));
    }
    let bits = |d: &hdf5::Dataset| -> Result<Vec<u64>, String> {
        use hdf5::types::{FloatSize, IntSize, TypeDescriptor};
        match da.1 {
            TypeDescriptor::Float(FloatSize::U8) => d
                .read_raw::<f64>()
                .map(|v| v.iter().map(|x| x.to_bits()).collect()),
            TypeDescriptor::Integer(IntSize::U8) => d
                .read_raw::<i64>()
                .map(|v| v.iter().map(|&x| x as u64).collect()),
            ref other => return Err(format!("unexpected type {other:?}")),
        }
        .map_err(|e| e.to_string())
    };
    let (va, vb) = (bits(a)?, bits(b)?);
    if va.len() != size {
        return Err(format!("{} values read for shape {:?}", va.len(), da.0));
    }
    match va.iter().zip(&vb).position(|(x, y)| x != y) {
        Some(i) => Err(format!(
            "value {i} differs: {:e} vs {:e}",
            f64::from_bits(va[i]),
            f64::from_bits(vb[i])
        )),
        None => Ok(()),
    }
}
