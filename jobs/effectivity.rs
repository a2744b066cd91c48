//! The effectivity η^glo/e_ref of the converged NNDD at reference factors r = 2, 4, 6, 8, and
//! against the true error extrapolated from r = 4, 6, 8 (e_ref(r)² = e∞² − K r^(−q), q fitted),
//! on the examples: `paper` (n = 16), the punch, Hertz with matched curves and meshed on their
//! own at size ratios 1.5, 4 and 10, the pin in a groove, the pin in its hole (matched and
//! meshed 2:3), and the curves meshed on their own again under the mortar discretisation
//! (Hertz at 1.5, 4, 10 and 1/10, the pin 2:3). Level 1 meshes, 2 ranks, tol 1e−8, θ auto.
//!
//! Run: `jobs/effectivity` → a table on stdout and in `results/effectivity/table.txt`.

#[path = "extrapolate.rs"]
mod extrapolate;
#[path = "runner.rs"]
mod runner;

use extrapolate::extrapolate;
use runner::num;
use std::path::Path;

/// A case: its name, options file, mesh (.geo and its Gmsh numbers; none: a built-in problem)
/// and extra options.
struct Case {
    name: &'static str,
    opts: &'static str,
    geo: Option<(&'static str, &'static [(&'static str, &'static str)])>,
    extra: &'static [&'static str],
}

/// Node to node on curves meshed on their own (the default couples them by mortar).
const NODE_TO_NODE: [&str; 2] = ["-nndd_contact_discretisation", "node_to_node"];

/// The mortar discretisation's options.
const MORTAR: [&str; 2] = ["-nndd_contact_discretisation", "mortar"];

const CASES: &[Case] = &[
    Case {
        name: "paper n=16",
        opts: "petsc-options/paper.opts",
        geo: None,
        extra: &["-nndd_theta", "auto", "-nndd_estimate_every", "0"],
    },
    Case {
        name: "punch",
        opts: "examples/punch/punch.opts",
        geo: Some(("examples/punch/punch.geo", &[("level", "1")])),
        extra: &[],
    },
    Case {
        name: "hertz matched",
        opts: "examples/hertz/hertz.opts",
        geo: Some(("examples/hertz/hertz.geo", &[("level", "1")])),
        extra: &[],
    },
    Case {
        name: "hertz 1:1.5",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "1.5")],
        )),
        extra: &NODE_TO_NODE,
    },
    Case {
        name: "hertz 1:4",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "4")],
        )),
        extra: &NODE_TO_NODE,
    },
    Case {
        name: "hertz 1:10",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "10")],
        )),
        extra: &NODE_TO_NODE,
    },
    Case {
        name: "pin in a groove",
        opts: "examples/pin/pin.opts",
        geo: Some(("examples/pin/pin.geo", &[("level", "1")])),
        extra: &[],
    },
    Case {
        name: "pin in hole",
        opts: "examples/pin-hole/pin-hole.opts",
        geo: Some(("examples/pin-hole/pin-hole.geo", &[("level", "1")])),
        extra: &[],
    },
    Case {
        name: "pin in hole 2:3",
        opts: "examples/pin-hole/pin-hole.opts",
        geo: Some((
            "examples/pin-hole/pin-hole.geo",
            &[("level", "1"), ("ratio", "1.5")],
        )),
        extra: &NODE_TO_NODE,
    },
    Case {
        name: "hertz 1:1.5 mortar",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "1.5")],
        )),
        extra: &MORTAR,
    },
    Case {
        name: "hertz 1:4 mortar",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "4")],
        )),
        extra: &MORTAR,
    },
    Case {
        name: "hertz 1:10 mortar",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "10")],
        )),
        extra: &MORTAR,
    },
    Case {
        name: "hertz 10:1 mortar",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: Some((
            "examples/hertz-nonmatching/hertz-nonmatching.geo",
            &[("level", "1"), ("ratio", "0.1")],
        )),
        extra: &MORTAR,
    },
    Case {
        name: "pin in hole 2:3 mortar",
        opts: "examples/pin-hole/pin-hole.opts",
        geo: Some((
            "examples/pin-hole/pin-hole.geo",
            &[("level", "1"), ("ratio", "1.5")],
        )),
        extra: &MORTAR,
    },
];

const FACTORS: [usize; 4] = [2, 4, 6, 8];

fn main() {
    let dir = Path::new("results/effectivity");
    std::fs::create_dir_all(dir).expect("results/effectivity");
    let mut table = String::from(
        "case              iter  eta_glo      eff(r=2)  eff(4)  eff(6)  eff(8)   e_inf        q     eff(e_inf)  max_residual\n",
    );
    print!("{table}");
    for case in CASES {
        let tag = case.name.replace([' ', ':', '='], "_");
        let msh = dir.join(format!("{tag}.msh"));
        let mut args: Vec<String> = case.extra.iter().map(|s| s.to_string()).collect();
        if let Some((geo, numbers)) = case.geo {
            let mut cmd = std::process::Command::new("gmsh");
            cmd.args(["-2", "-format", "msh41", "-v", "1"]);
            for (k, v) in numbers {
                cmd.args(["-setnumber", k, v]);
            }
            let st = cmd
                .arg(geo)
                .arg("-o")
                .arg(&msh)
                .status()
                .expect("gmsh runs");
            assert!(st.success(), "gmsh failed on {geo}");
            args.extend(["-nndd_mesh".into(), msh.display().to_string()]);
        }
        args.push("-nndd_estimate".into());
        let (mut eta, mut iters, mut res) = (0.0, 0.0, 0.0_f64);
        let mut e_ref = Vec::new();
        for r in FACTORS {
            let mut a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
            let rs = r.to_string();
            a.extend(["-nndd_reference_factor", &rs]);
            let prefix = dir.join(format!("{tag}-r{r}"));
            match runner::try_run(2, case.opts, &[], &prefix, &a) {
                Ok((j, _)) => {
                    let last = j["estimates"]
                        .as_array()
                        .and_then(|v| v.last())
                        .cloned()
                        .unwrap_or_default();
                    eta = num(&last, "eta_glo");
                    e_ref.push(num(&last, "e_ref"));
                    iters = num(&j, "iterations");
                    let rs = &j["equilibrium_residuals"];
                    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
                        res = res.max(num(rs, key));
                    }
                }
                Err(e) => {
                    eprintln!("{}: r = {r}: {e}", case.name);
                    e_ref.push(f64::NAN);
                }
            }
        }
        let eff: Vec<String> = e_ref.iter().map(|e| format!("{:.4}", eta / e)).collect();
        let (q, e_inf) = extrapolate([4.0, 6.0, 8.0], [e_ref[1], e_ref[2], e_ref[3]])
            .unwrap_or((f64::NAN, f64::NAN));
        let line = format!(
            "{:<17} {:>4}  {:<12.6e} {:>8}  {:>6}  {:>6}  {:>6}   {:<12.6e} {:<5.2} {:>10.4}  {:.1e}\n",
            case.name,
            iters,
            eta,
            eff[0],
            eff[1],
            eff[2],
            eff[3],
            e_inf,
            q,
            eta / e_inf,
            res
        );
        print!("{line}");
        table.push_str(&line);
    }
    let note = "(level 1 meshes, 2 ranks, tol 1e-8, theta auto; eff(r) = eta_glo / e_ref on the mesh refined r times; e_inf: e_ref(r)^2 = e_inf^2 - K r^-q through r = 4, 6, 8; max_residual: the admissible stresses' largest relative equilibrium residual)\n";
    print!("{note}");
    table.push_str(note);
    std::fs::write(dir.join("table.txt"), &table).expect("table");
}
