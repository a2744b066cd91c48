//! Shared helpers of the integration tests: run the `nndd` binary under mpirun (a process
//! initialises PETSc once, so every run is its own process) and read its results back.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

pub mod patch;

#[path = "../../jobs/hertz_fit.rs"]
pub mod hertz_fit;

#[path = "../../jobs/extrapolate.rs"]
pub mod extrapolate;

/// Hertz with the bodies meshed on their own (its .geo takes `level` and `ratio`) and its options.
pub const HERTZ_NM_GEO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/hertz-nonmatching/hertz-nonmatching.geo"
);
pub const HERTZ_NM_OPTS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/hertz-nonmatching/hertz-nonmatching.opts"
);
/// The pin in its hole (its .geo takes `level`, `ratio`, `arc`, `clearance`) and its options.
pub const PIN_HOLE_GEO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/pin-hole/pin-hole.geo"
);
pub const PIN_HOLE_OPTS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/pin-hole/pin-hole.opts"
);

/// Node to node on curves meshed on their own (the default `auto` couples them by mortar):
/// the tests of the curves made to match.
pub const NODE_TO_NODE: [&str; 2] = ["-nndd_contact_discretisation", "node_to_node"];

/// The materials of the Hertz examples (block, cylinder): (E, ν).
pub const HERTZ_MATERIALS: [(f64, f64); 2] = [(7e10, 0.33), (2.1e11, 0.3)];

/// Those materials as options: aluminium body 1, steel body 2.
pub const ALUMINIUM_ON_STEEL: [&str; 8] = [
    "-nndd_body1_E",
    "7e10",
    "-nndd_body1_nu",
    "0.33",
    "-nndd_body2_E",
    "2.1e11",
    "-nndd_body2_nu",
    "0.3",
];

/// Hertz's solution fitted to a Hertz example's run at `prefix` (the cylinder of radius 1 m):
/// its contact half-width, peak pressure and profile against the run's Γc results.
pub fn hertz_fit_of(prefix: &Path) -> hertz_fit::HertzFit {
    let pts = points(prefix, "contact");
    let x: Vec<f64> = pts.chunks(2).map(|p| p[0]).collect();
    let active: Vec<bool> = field(prefix, "contact", "active")
        .iter()
        .map(|&a| a > 0.5)
        .collect();
    hertz_fit::fit(
        &x,
        &field(prefix, "contact", "normal_force"),
        &field(prefix, "contact", "pressure"),
        &active,
        1.0,
        HERTZ_MATERIALS,
    )
}

/// `paper` at n = 16 solved to a tolerance tight enough that two solution paths agree to 1e-10.
pub const PAPER_16_TIGHT: [&str; 6] = [
    "-nndd_problem",
    "paper",
    "-nndd_n",
    "16",
    "-nndd_tol",
    "1e-11",
];

/// A fresh, empty directory for one test's output.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nndd-test-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The command `mpirun -n np nndd args…` (oversubscribed when np exceeds the cores), with a
/// directory of its own for OpenMPI's files (`orte_tmpdir_base`): the tests of a file run at
/// once, and two mpiruns that share OpenMPI's default (`/tmp/ompi.HOST.UID`) race, one removing
/// it while the other starts in it ("A call to mkdir was unable to create the desired
/// directory", orte_init fails).
pub fn mpirun_command(np: usize, args: &[&str]) -> Command {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static RUNS: AtomicUsize = AtomicUsize::new(0);
    let files = std::env::temp_dir()
        .join(format!("nndd-test-ompi-{}", std::process::id()))
        .join(RUNS.fetch_add(1, Ordering::Relaxed).to_string());
    std::fs::create_dir_all(&files).expect("a directory for OpenMPI's files");
    let mut cmd = Command::new("mpirun");
    cmd.args([
        "-n",
        &np.to_string(),
        "--oversubscribe",
        "--bind-to",
        "none",
    ])
    .arg(env!("CARGO_BIN_EXE_nndd"))
    .args(args)
    .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
    .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
    .env("OMPI_MCA_orte_tmpdir_base", &files);
    cmd
}

/// Run `mpirun -n np nndd args…` to completion.
pub fn mpirun(np: usize, args: &[&str]) -> Output {
    mpirun_command(np, args).output().expect("mpirun runs")
}

/// Run and require success; returns the parsed JSON summary of `prefix`.
pub fn solve(np: usize, prefix: &Path, args: &[&str]) -> serde_json::Value {
    let p = prefix.to_str().unwrap();
    let mut all = vec!["-nndd_output", p];
    all.extend_from_slice(args);
    let out = mpirun(np, &all);
    assert!(
        out.status.success(),
        "nndd {:?} failed ({}):\n{}\n{}",
        all,
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    json(prefix)
}

pub fn json(prefix: &Path) -> serde_json::Value {
    let text =
        std::fs::read_to_string(format!("{}.json", prefix.display())).expect("summary exists");
    serde_json::from_str(&text).expect("summary is JSON")
}

/// The options of examples/paper/paper.opts for a Gmsh mesh of `paper`: its contact curves
/// and boundary conditions, the top lowered by `u_top`.
pub fn paper_mesh_args(msh: &Path, contact: &str, u_top: &str) -> Vec<String> {
    [
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_contact",
        contact,
        "-nndd_bc_bottom_ux",
        "0",
        "-nndd_bc_bottom_uy",
        "0",
        "-nndd_bc_top_ux",
        "0",
        "-nndd_bc_top_uy",
        u_top,
        "-nndd_bc_right2_traction",
        "0,1e7",
        "-nndd_bc_right2_traction_end",
        "0,0",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// A dataset of `PREFIX.h5`, flattened.
pub fn h5(prefix: &Path, dataset: &str) -> Vec<f64> {
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).expect("h5 opens");
    let d = f
        .dataset(dataset)
        .unwrap_or_else(|e| panic!("{dataset}: {e}"));
    d.read_raw::<f64>().unwrap()
}

/// A body's rows of the `bodies` grid (points, cells), and the grid's number of cells.
type BodyRows = ([std::ops::Range<usize>; 2], usize);

/// The HDF5 grid of `grid` and, for `body1` and `body2`, that body's rows of the `bodies`
/// grid (from the file's attributes `bodyN_points`, `bodyN_cells`).
fn grid_rows(prefix: &Path, grid: &str) -> (String, Option<BodyRows>) {
    let Some(alpha) = grid
        .strip_prefix("body")
        .and_then(|a| a.parse::<usize>().ok())
    else {
        return (grid.to_string(), None);
    };
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).expect("h5 opens");
    let count = |what: &str, a: usize| -> usize {
        let v: f64 = f
            .attr(&format!("body{a}_{what}"))
            .unwrap()
            .read_scalar()
            .unwrap();
        v as usize
    };
    let range = |what: &str| {
        let first = count(what, 1);
        match alpha {
            1 => 0..first,
            _ => first..first + count(what, 2),
        }
    };
    let cells = count("cells", 1) + count("cells", 2);
    (
        "bodies".into(),
        Some(([range("points"), range("cells")], cells)),
    )
}

/// Field `field` of `grid` at step `k` of the file (`None`: the last step, the reported
/// iterate), flattened: `grid` is `contact`, `bodies`, or `body1` / `body2` (that body's rows).
pub fn field_at(prefix: &Path, k: Option<usize>, grid: &str, field: &str) -> Vec<f64> {
    let (name, rows) = grid_rows(prefix, grid);
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).expect("h5 opens");
    let group = f
        .group(&format!("Function/{name}/{field}"))
        .unwrap_or_else(|e| panic!("{grid}/{field}: {e}"));
    let mut steps = group.member_names().unwrap();
    steps.sort_by(|a, b| {
        let t = |s: &str| s.replace('_', ".").parse::<f64>().unwrap();
        t(a).total_cmp(&t(b))
    });
    let step = k
        .map_or(steps.last(), |k| steps.get(k))
        .expect("the step exists");
    let d = group.dataset(step).unwrap();
    let values = d.read_raw::<f64>().unwrap();
    match rows {
        None => values,
        Some(([points, cells], cell_count)) => {
            let per = d.shape().get(1).copied().unwrap_or(1);
            // The bodies' one point field is the displacement (docs/output.md); the counts
            // alone cannot tell when the grid has as many cells as points.
            let r = if field != "displacement" && d.shape()[0] == cell_count {
                cells
            } else {
                points
            };
            values[per * r.start..per * r.end].to_vec()
        }
    }
}

/// Field `field` of `grid` (see [`field_at`]) at the reported iterate.
pub fn field(prefix: &Path, grid: &str, field: &str) -> Vec<f64> {
    field_at(prefix, None, grid, field)
}

/// The cells of `grid` (see [`field_at`]): point indices, of the body's own points for `body1`
/// and `body2`.
pub fn cells(prefix: &Path, grid: &str) -> Vec<i64> {
    let (name, rows) = grid_rows(prefix, grid);
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).expect("h5 opens");
    let d = f.dataset(&format!("Mesh/{name}/topology")).unwrap();
    let all = d.read_raw::<i64>().unwrap();
    let per = d.shape()[1];
    match rows {
        None => all,
        Some(([p, c], _)) => {
            let start = p.start as i64;
            all[per * c.start..per * c.end]
                .iter()
                .map(|i| i - start)
                .collect()
        }
    }
}

/// Each body's node count in the summary `j`.
pub fn body_nodes(j: &serde_json::Value) -> [usize; 2] {
    let dofs: [usize; 2] = serde_json::from_value(j["body_dofs"].clone()).unwrap();
    dofs.map(|d| d / 2)
}

/// `key` of the last estimate in the summary `j`.
pub fn last_estimate(j: &serde_json::Value, key: &str) -> f64 {
    let e = j["estimates"].as_array().expect("estimates");
    f(e.last().expect("an estimate"), key)
}

/// The nodes on the outline of body `grid` (`body1` or `body2`) in the result file at
/// `prefix`: those of the sides of one of its cells alone.
pub fn outline_nodes(prefix: &Path, grid: &str) -> usize {
    let mut sides: std::collections::HashMap<[i64; 2], usize> = Default::default();
    for t in cells(prefix, grid).chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *sides.entry([a.min(b), a.max(b)]).or_default() += 1;
        }
    }
    let mut nodes: Vec<i64> = (sides.iter())
        .filter(|(_, &n)| n == 1)
        .flat_map(|(s, _)| *s)
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    nodes.len()
}

/// The points of `grid` (see [`field_at`]), x and y of each.
pub fn points(prefix: &Path, grid: &str) -> Vec<f64> {
    let (name, rows) = grid_rows(prefix, grid);
    let all = h5(prefix, &format!("/Mesh/{name}/geometry"));
    match rows {
        None => all,
        Some(([p, _], _)) => all[2 * p.start..2 * p.end].to_vec(),
    }
}

/// Maximum of |a − b| over max |b|.
pub fn rel_max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

pub fn f(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in summary"))
}

/// Run `args` (output into a fresh directory) and require a failure: exit `code` (any non-zero
/// exit when `None`), exactly one `nndd: error` line, containing each of `needles`, no panic,
/// backtrace or PETSc traceback, and no file left under the output directory. Returns the line.
pub fn fails_with(np: usize, args: &[&str], code: Option<i32>, needles: &[&str]) -> String {
    let key = format!("{np} {}", args.join(" "));
    let hash = key.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let dir = scratch(&format!("fails-{hash:x}"));
    let prefix = dir.join("out/run");
    let mut all = vec!["-nndd_output", prefix.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = mpirun(np, &all);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    match code {
        Some(c) => assert_eq!(
            out.status.code(),
            Some(c),
            "{args:?} on {np}:\n{stdout}\n{stderr}"
        ),
        None => assert!(!out.status.success(), "{args:?} was accepted:\n{stdout}"),
    }
    let ours: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("nndd: error"))
        .collect();
    assert_eq!(ours.len(), 1, "{args:?} on {np}: one error line:\n{stderr}");
    for n in needles {
        assert!(
            ours[0].contains(n),
            "{args:?} on {np}: no '{n}' in {}",
            ours[0]
        );
    }
    for bad in [
        "panicked",
        "backtrace",
        "RUST_BACKTRACE",
        "PETSC ERROR",
        "internal error",
    ] {
        assert!(
            !stderr.contains(bad) && !stdout.contains(bad),
            "{args:?}: '{bad}' in\n{stderr}"
        );
    }
    let left = walk(&dir);
    assert!(left.is_empty(), "{args:?} left files behind: {left:?}");
    std::fs::remove_dir_all(&dir).ok();
    ours[0].to_string()
}

/// Bad input at `paper` n = 4 (or on the Gmsh mesh `args` name): [`fails_with`] any non-zero
/// exit, the line `nndd: error: …` naming `option`.
pub fn refused(np: usize, args: &[&str], option: &str) {
    let mut all = if args.contains(&"-nndd_mesh") {
        vec![]
    } else {
        vec!["-nndd_n", "4"]
    };
    all.extend_from_slice(args);
    let line = fails_with(np, &all, None, &[option]);
    assert!(line.starts_with("nndd: error: "), "{line}");
}

pub fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// `gmsh -2 -format msh41 -setnumber level LEVEL GEO -o DIR/STEM-LEVEL.msh` (Gmsh is installed
/// by jobs/setup); the mesh file's path.
pub fn gmsh_level(geo: &str, dir: &Path, stem: &str, level: u32) -> PathBuf {
    let out = dir.join(format!("{stem}-{level}.msh"));
    gmsh(geo, &[("level", &level.to_string())], &[], &out);
    out
}

/// `gmsh -2 -format msh41 [-setnumber NAME VALUE …] [EXTRA …] GEO -o OUT`; must succeed.
pub fn gmsh(geo: &str, numbers: &[(&str, &str)], extra: &[&str], out: &Path) {
    let mut cmd = Command::new("gmsh");
    cmd.args(["-2", "-format", "msh41", "-v", "1"]);
    for (k, v) in numbers {
        cmd.args(["-setnumber", k, v]);
    }
    let st = cmd
        .args(extra)
        .arg(geo)
        .arg("-o")
        .arg(out)
        .output()
        .expect("gmsh runs (jobs/setup installs it)");
    assert!(
        st.status.success(),
        "gmsh: {}",
        String::from_utf8_lossy(&st.stderr)
    );
}

/// Solve the options file `opts` on the Gmsh mesh `msh`, output at `prefix` (options after the
/// file override it); the run must succeed. Its summary.
pub fn solve_meshed(
    np: usize,
    opts: &str,
    msh: &Path,
    prefix: &Path,
    extra: &[&str],
) -> serde_json::Value {
    let mut args = vec![
        "-options_file",
        opts,
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_output",
        prefix.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = mpirun(np, &args);
    assert!(
        out.status.success(),
        "nndd {args:?} ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    json(prefix)
}

/// A job that ended: its exit code (or the signal that ended it), how long it took from
/// [`wait_within`]'s start, and its output.
pub struct Ended {
    pub code: Option<i32>,
    pub signal: Option<i32>,
    pub seconds: f64,
    pub stdout: String,
    pub stderr: String,
}

/// Kill a job's whole process group (mpirun and the ranks; the job was spawned with
/// `process_group(0)`).
pub fn kill_group(child: &Child) {
    // SAFETY: kill(2) on our own child's process group.
    unsafe {
        libc::kill(-(child.id() as i32), libc::SIGKILL);
    }
}

/// Wait for `child` at most `limit`, else kill its process group and fail the test as a hang.
/// The pipes it still has are drained on threads (a full pipe would block the job).
pub fn wait_within(mut child: Child, limit: Duration, what: &str) -> Ended {
    use std::os::unix::process::ExitStatusExt as _;
    let t0 = Instant::now();
    let drain = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut p) = pipe {
                p.read_to_string(&mut s).ok();
            }
            s
        })
    };
    let t_out = drain(child.stdout.take().map(|p| Box::new(p) as _));
    let t_err = drain(child.stderr.take().map(|p| Box::new(p) as _));
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return Ended {
                code: status.code(),
                signal: status.signal(),
                seconds: t0.elapsed().as_secs_f64(),
                stdout: t_out.join().unwrap(),
                stderr: t_err.join().unwrap(),
            };
        }
        if t0.elapsed() > limit {
            kill_group(&child);
            let _ = child.wait();
            panic!(
                "{what}: still running after {:.0} s (a hang); killed. stderr so far:\n{}",
                limit.as_secs_f64(),
                t_err.join().unwrap()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// examples/paper: `paper` drawn in Gmsh (its level `n`).
pub const PAPER_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.geo");

/// The options of `paper` drawn in Gmsh, n = 32 (2048 elements per body), its mesh in `dir`.
pub fn paper_drawn_in_gmsh(dir: &std::path::Path) -> Vec<String> {
    paper_drawn_in_gmsh_at(dir, 32)
}

/// The options of `paper` drawn in Gmsh at level `n` (2 n² elements per body), its mesh in
/// `dir`.
pub fn paper_drawn_in_gmsh_at(dir: &std::path::Path, n: usize) -> Vec<String> {
    let msh = dir.join(format!("paper-{n}.msh"));
    gmsh(PAPER_GEO, &[("n", &n.to_string())], &[], &msh);
    paper_mesh_args(&msh, "contact1,contact2", "-1e-4")
}

/// Every dataset and attribute of a result file, by path.
pub fn h5_contents(prefix: &std::path::Path) -> Vec<(String, Vec<f64>)> {
    fn walk(g: &hdf5::Group, path: &str, out: &mut Vec<(String, Vec<f64>)>) {
        for a in g.attr_names().unwrap() {
            // The text attributes describe the run (its options differ): their names only.
            let v: Vec<f64> = g
                .attr(&a)
                .unwrap()
                .read_scalar::<f64>()
                .into_iter()
                .collect();
            out.push((format!("{path}@{a}"), v));
        }
        for name in g.member_names().unwrap() {
            let p = format!("{path}/{name}");
            if let Ok(sub) = g.group(&name) {
                walk(&sub, &p, out);
            } else {
                let d = g.dataset(&name).unwrap();
                let v: Vec<f64> = match d.read_raw::<f64>() {
                    Ok(v) => v,
                    Err(_) => d
                        .read_raw::<i64>()
                        .unwrap()
                        .iter()
                        .map(|&x| x as f64)
                        .collect(),
                };
                out.push((format!("{p} {:?}", d.shape()), v));
            }
        }
    }
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).unwrap();
    let mut out = Vec::new();
    walk(&f, "", &mut out);
    out
}

/// Both bodies' displacements of two runs agree to 1e-10 (relative, largest entry).
pub fn same_displacements(one: &std::path::Path, other: &std::path::Path, what: &str) {
    for body in ["body1", "body2"] {
        let d = rel_max_diff(
            &field(other, body, "displacement"),
            &field(one, body, "displacement"),
        );
        assert!(d < 1e-10, "{body}: {what} differ by {d:e}");
    }
}

/// Two runs' result files hold the same datasets and attributes (their names and shapes), the
/// meshes and the attributes value for value, every field to `tol` of its largest entry
/// (η^NNDD's maps, at the solves' round-off where the iterate converged, of η^glo's); the
/// number of datasets and attributes.
pub fn same_results(a: &Path, b: &Path, tol: f64, what: &str) -> usize {
    let (a, b) = (h5_contents(a), h5_contents(b));
    let names = |c: &[(String, Vec<f64>)]| c.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&a),
        names(&b),
        "{what}: the same datasets, shapes and attributes"
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name.contains('@') || name.contains("/Mesh/") {
            assert!(x == y, "{what}: {name}: geometry and attributes differ");
            continue;
        }
        let scale_of = name.replace("eta_nndd", "eta_glo");
        let scale_of = &a.iter().find(|c| c.0 == scale_of).unwrap().1;
        let scale = scale_of.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        let d = x
            .iter()
            .zip(y)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
            / scale;
        assert!(d < tol, "{what}: {name}: differs by {d:e}");
    }
    a.len()
}

/// `mpirun -n np nndd args…` in its own process group, its output piped.
pub fn spawn(np: usize, args: &[&str]) -> Child {
    use std::os::unix::process::CommandExt as _;
    mpirun_command(np, args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .process_group(0)
        .spawn()
        .expect("mpirun starts")
}
