//! Capability: the result files open as they are in the tools users have. ParaView's default
//! reader (pvpython under xvfb-run) and meshio read `paper`'s results from their own folder,
//! and ParaView's time slider steps through an adaptive run's cycles, each its own mesh;
//! the XDMF follows DOLFINx's `XDMFFile` layout (read here from its text: no DOLFINx needed).
//! ParaView, xvfb and meshio come from `jobs/setup`.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

/// `paper` n = 8 on 2 ranks with estimates every 2 iterations: several steps, the last the
/// reported iterate.
fn paper_with_steps(dir: &Path) -> (std::path::PathBuf, u64) {
    let p = dir.join("paper");
    let args = [
        "-nndd_n",
        "8",
        "-nndd_theta",
        "0.25",
        "-nndd_estimate_every",
        "2",
    ];
    let j = solve(2, &p, &args);
    (p, j["iterations"].as_u64().unwrap())
}

/// Runs `cmd`, requires exit 0, returns its stdout.
fn run_ok(mut cmd: Command, what: &str) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start ({e}); run jobs/setup"));
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{what}: {}\n{text}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// `xvfb-run -a -n N pvpython tests/viewers/SCRIPT ARGS…`, required to pass every check; its
/// stdout. Each call starts its search for a free X display at its own N: two tests that start
/// xvfb-run -a at once may both take :99, and the one whose Xvfb lost renders on the other's,
/// gone when that test ends ("bad X server connection", SIGABRT, after the checks that need
/// no rendering printed "ok"). A run that ends without a failed check (no "FAIL") is made
/// once more.
fn pvpython(script: &str, args: &[&std::ffi::OsStr]) -> String {
    static CALLS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/viewers")
        .join(script);
    let attempt = || {
        let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let start = 100 + (std::process::id() % 100) * 40 + call;
        let mut cmd = Command::new("xvfb-run");
        cmd.args(["-a", "-n", &start.to_string()])
            .args(["-s", "-screen 0 800x600x24", "pvpython"])
            .arg(&script)
            .args(args);
        cmd.output()
            .expect("xvfb-run starts (jobs/setup installs it)")
    };
    let mut out = attempt();
    let text = |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).into_owned();
    if !out.status.success() && !text(&out).contains("FAIL") {
        out = attempt();
    }
    let stdout = text(&out);
    assert!(
        out.status.success() && !stdout.contains("FAIL"),
        "pvpython: {}\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn paraview_default_reader_shows_the_fields() {
    let dir = scratch("viewers-paraview");
    let (_, its) = paper_with_steps(&dir);
    let png = dir.join("eta_fe.png");
    let its = its.to_string();
    let stdout = pvpython(
        "paraview_check.py",
        &[
            dir.as_os_str(),
            "paper".as_ref(),
            its.as_ref(),
            png.as_os_str(),
        ],
    );
    // (every check ran: the script stops at the first failure)
    assert!(
        stdout.contains("ok   its eta_fe is the last step's"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn meshio_reads_every_step_of_every_function() {
    let dir = scratch("viewers-meshio");
    let (p, its) = paper_with_steps(&dir);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/viewers/meshio_check.py");
    // Debian's python3 (with python3-meshio and python3-h5py), whatever python3 is first on PATH.
    let mut cmd = Command::new("/usr/bin/python3");
    cmd.arg(script).arg(&p).arg(its.to_string());
    let stdout = run_ok(cmd, "meshio");
    assert!(!stdout.contains("FAIL"), "{stdout}");
    assert!(
        stdout.contains("fields read, every step of every function"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The text between `<tag` … `</tag>` or `/>` of every `tag` element.
fn elements<'a>(xml: &'a str, tag: &str) -> Vec<&'a str> {
    let open = format!("<{tag}");
    let mut out = Vec::new();
    let mut rest = xml;
    while let Some(i) = rest.find(&open) {
        let after = &rest[i..];
        let close = format!("</{tag}>");
        let end = match (after.find(&close), after.find("/>")) {
            (Some(_), Some(s)) if s < after.find('>').unwrap_or(0) + 1 => s + 2,
            (Some(c), _) => c + close.len(),
            (None, Some(s)) => s + 2,
            (None, None) => after.len(),
        };
        out.push(&after[..end]);
        rest = &after[open.len()..];
    }
    out
}

#[test]
fn xdmf_follows_dolfinx_layout() {
    let dir = scratch("viewers-layout");
    let (p, its) = paper_with_steps(&dir);
    let file = hdf5::File::open(format!("{}.h5", p.display())).unwrap();
    for (name, grid) in [("paper.xdmf", "bodies"), ("paper-contact.xdmf", "contact")] {
        let xml = std::fs::read_to_string(dir.join(name)).unwrap();
        // The mesh first: a Uniform grid named after it, Topology and Geometry in /Mesh/<grid>.
        let grids = elements(&xml, "Grid");
        assert!(
            grids[0].starts_with(&format!("<Grid Name=\"{grid}\" GridType=\"Uniform\">")),
            "{name}: {}",
            grids[0]
        );
        assert!(grids[0].contains(&format!("paper.h5:/Mesh/{grid}/topology<")));
        assert!(grids[0].contains(&format!("paper.h5:/Mesh/{grid}/geometry<")));
        // Then one temporal collection whose grids include that mesh and carry /Function data.
        assert_eq!(
            xml.matches("CollectionType=\"Temporal\"").count(),
            1,
            "{name}"
        );
        let steps: Vec<&str> = grids[2..].to_vec();
        let times: Vec<u64> = elements(&xml, "Time")
            .iter()
            .map(|t| t.split('"').nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(steps.len(), times.len(), "{name}");
        assert_eq!(
            *times.last().unwrap(),
            its,
            "{name}: the last step is the reported iterate"
        );
        assert!(times.windows(2).all(|w| w[0] < w[1]), "{name}: {times:?}");
        let include = "<xi:include xpointer=\"xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/*[self::Topology or self::Geometry])\"/>";
        for s in &steps {
            assert!(s.contains(include), "{name}: {s}");
            assert!(
                !s.contains("<Topology"),
                "{name}: the mesh is included, not repeated"
            );
        }
        // Every DataItem: the HDF5 file by its bare name, a dataset under /Mesh or /Function
        // with the shape given.
        for item in elements(&xml, "DataItem") {
            let body = item.split('>').nth(1).unwrap().split('<').next().unwrap();
            let (h5, path) = body.split_once(':').unwrap();
            assert_eq!(h5, "paper.h5", "{name}");
            assert!(
                path.starts_with("/Mesh/") || path.starts_with("/Function/"),
                "{path}"
            );
            let dims: Vec<usize> = item
                .split("Dimensions=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap()
                .split(' ')
                .map(|d| d.parse().unwrap())
                .collect();
            assert_eq!(file.dataset(path).unwrap().shape(), dims, "{name}: {path}");
        }
    }
    // The run's description as attributes of the file.
    let text = |a: &str| -> String {
        let v: hdf5::types::VarLenUnicode = file.attr(a).unwrap().read_scalar().unwrap();
        v.as_str().to_string()
    };
    assert_eq!(
        text("program"),
        format!("nndd {}", env!("CARGO_PKG_VERSION"))
    );
    assert!(
        text("options").contains("-nndd_estimate_every 2"),
        "{}",
        text("options")
    );
    assert_eq!(text("problem"), "paper");
    std::fs::remove_dir_all(&dir).ok();
}

/// An adaptive run's cycles (`paper.geo`, n = 8, ε = 4 %, 1 rank): ParaView's default reader
/// steps through them, each cycle its own mesh with its fields, and opens the last alone.
#[test]
fn paraview_steps_through_an_adaptive_runs_cycles() {
    let dir = scratch("viewers-cycles");
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.geo");
    let mut args = paper_mesh_args(Path::new(geo), "contact1,contact2", "-1e-4");
    args.extend(["-nndd_geo_set", "n=8", "-nndd_adapt_tol", "0.04"].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let j = solve(1, &dir.join("paper"), &args);
    let cells: Vec<String> = j["cycles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["elements"].to_string())
        .collect();
    assert!(cells.len() >= 2, "{cells:?}");
    let cells = cells.join(",");
    let stdout = pvpython(
        "paraview_cycles.py",
        &[dir.as_os_str(), "paper".as_ref(), cells.as_ref()],
    );
    println!("{stdout}");
    assert!(
        stdout.contains("-final.xdmf: the last cycle alone"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
