//! Capability: results files. The HDF5 file read back holds the fields the JSON summary
//! describes, with values that match the summary's numbers (recomputed independently here).

mod common;
use common::*;
use nndd::fem::mesh::Mesh;
use nndd::fem::{assemble_stiffness, Material};

#[test]
fn h5_matches_json() {
    let dir = scratch("output");
    let p = dir.join("paper");
    let j = solve(2, &p, &["-nndd_problem", "paper", "-nndd_n", "8"]);
    for key in [
        "problem",
        "n",
        "dofs",
        "ranks",
        "solver",
        "theta_auto",
        "tol",
        "converged",
        "iterations",
        "history",
        "potential_energy",
        "contact_force",
        "contact_zone",
        "timings",
    ] {
        assert!(!j[key].is_null(), "summary lacks {key}");
    }
    // θ auto (the default): θ per iteration in the history, no fixed `theta`.
    assert!(j.get("theta").is_none(), "{}", j["theta"]);
    for key in ["iteration", "lambda_change", "residual", "active", "theta"] {
        assert!(
            !j["history"][0][key].is_null(),
            "history entries lack {key}"
        );
    }
    assert_eq!(j["dofs"], 2 * 2 * 81);
    assert_eq!(
        j["history"].as_array().unwrap().len() as u64,
        j["iterations"].as_u64().unwrap()
    );
    // Every described field exists with the described shape.
    let file = hdf5::File::open(format!("{}.h5", p.display())).unwrap();
    let fields = j["fields"].as_array().unwrap();
    assert!(fields.len() >= 10);
    for fd in fields {
        let ds = file.dataset(fd["dataset"].as_str().unwrap()).unwrap();
        let shape = ds.shape();
        let comps = fd["components"].as_u64().unwrap() as usize;
        // The bodies' grid holds both bodies (81 points, 128 triangles each).
        let rows = if fd["grid"] == "contact" {
            9
        } else if fd["center"] == "node" {
            2 * 81
        } else {
            2 * 128
        };
        assert_eq!(shape.iter().product::<usize>(), rows * comps, "{fd}");
    }
    // Contact force = Σ of the Γc nodal forces; zone = extent of the active nodes.
    let force = field(&p, "contact", "normal_force");
    assert!(
        (force.iter().sum::<f64>() - f(&j, "contact_force")).abs() < 1e-9 * f(&j, "contact_force")
    );
    assert!(
        force.iter().all(|&t| t >= 0.0),
        "compressive forces only: {force:?}"
    );
    let active = field(&p, "contact", "active");
    let x: Vec<f64> = points(&p, "contact").chunks(2).map(|c| c[0]).collect();
    let xs: Vec<f64> = (0..9).filter(|&i| active[i] > 0.5).map(|i| x[i]).collect();
    assert_eq!(
        j["contact_zone"],
        serde_json::json!([xs[0], xs[xs.len() - 1]])
    );
    assert_eq!(j["active_nodes"].as_u64().unwrap() as usize, xs.len());
    // The zone reaches Γc's end x = 0, where the blocks' sides are flush (they part there):
    // no warning of contact beyond the contact curves.
    assert_eq!(xs[0], 0.0);
    assert!(
        j["warnings"].as_array().unwrap().is_empty(),
        "{}",
        j["warnings"]
    );
    // Gap: ≥ 0 everywhere, 0 on the active nodes, > 0 off them.
    let gap = field(&p, "contact", "gap");
    for i in 0..9 {
        if active[i] > 0.5 {
            assert!(gap[i].abs() < 1e-12, "gap {} at active node {i}", gap[i]);
        } else {
            assert!(gap[i] > 1e-9, "gap {} at open node {i}", gap[i]);
        }
    }
    // Potential energy recomputed from the stored displacements with our own assembly.
    let mut energy = 0.0;
    for (k, body) in ["body1", "body2"].iter().enumerate() {
        let u: Vec<f64> = field(&p, body, "displacement")
            .chunks(3)
            .flat_map(|c| [c[0], c[1]])
            .collect();
        let mesh = Mesh::structured([0.0, k as f64], [1.0, 1.0], 8, 8);
        let mat = Material {
            young: j["young"][k].as_f64().expect("young per body"),
            poisson: j["poisson"][k].as_f64().expect("poisson per body"),
        };
        let ku = assemble_stiffness(&mesh, &mat).matvec(&u);
        energy += 0.5 * u.iter().zip(&ku).map(|(a, b)| a * b).sum::<f64>();
        if k == 1 {
            // Work of F² = (0, F_max (2 − y)) on the right edge, exact for linear u and load.
            let fmax = f(&j, "f_max");
            for jj in 0..8 {
                let (a, b) = (mesh.node(8, jj), mesh.node(8, jj + 1));
                let (ya, yb) = (mesh.points.get(a)[1], mesh.points.get(b)[1]);
                let (ta, tb) = (fmax * (2.0 - ya), fmax * (2.0 - yb));
                let h = yb - ya;
                energy -= h / 6.0
                    * (2.0 * ta * u[2 * a + 1]
                        + ta * u[2 * b + 1]
                        + tb * u[2 * a + 1]
                        + 2.0 * tb * u[2 * b + 1]);
            }
        }
    }
    let e = f(&j, "potential_energy");
    assert!(
        ((energy - e) / e).abs() < 1e-12,
        "energy {energy} vs summary {e}"
    );
    // The XDMF names the h5 file relatively and the reported iterate's datasets.
    let xdmf = std::fs::read_to_string(format!("{}.xdmf", p.display())).unwrap();
    let its = j["iterations"].as_u64().unwrap();
    assert!(xdmf.contains(&format!("paper.h5:/Function/bodies/stress/{its}<")));
    std::fs::remove_dir_all(&dir).ok();
}
