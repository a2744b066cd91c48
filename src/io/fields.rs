//! What the result files hold: the meshes of both bodies and of Γc, and per step the fields of
//! an iterate (displacements, stresses, Γc quantities) with the estimates' element maps. Built
//! here from the solver's and the estimator's data, written by [`super::output`].

use crate::dd::nndd::Iterate;
use crate::estimate::{EstimateRecord, Interface};
use crate::fem::{self, Material, Mesh};
use crate::io::output::{Center, Field, Grid, GridFields, Kind, Results, Share, Step, Topology};
use crate::io::summary::FieldInfo;
use crate::parallel::layout::Layout;
use crate::problem::BodyProblem;

/// The HDF5/XDMF content: the meshes and one step per entry of `steps` (an iterate, with its
/// estimates when it was estimated).
/// Body α's fields are filled on the ranks of its group (`have`), empty elsewhere; the
/// geometry and the Γc fields are known everywhere.
pub fn results(
    problems: [&BodyProblem; 2],
    steps: &[(&Iterate, Option<&EstimateRecord>)],
    have: [bool; 2],
    attributes: Vec<(String, f64)>,
) -> Results {
    let iface = Interface::new(problems[0].contact_lengths.clone());
    let m = iface.len();
    let mut grids: Vec<Grid> = problems
        .iter()
        .map(|p| Grid {
            name: format!("body{}", p.alpha),
            points: p.mesh.points.clone(),
            topology: Topology::Triangle(
                p.mesh
                    .triangles
                    .iter()
                    .map(|t| t.map(|v| v as u32))
                    .collect(),
            ),
        })
        .collect();
    grids.push(Grid {
        name: "contact".into(),
        // Γc at body 1's side (its nodes, in pair order).
        points: problems[0]
            .contact_nodes
            .iter()
            .map(|&n| problems[0].mesh.points[n])
            .collect(),
        topology: Topology::Segment(
            (0..m.saturating_sub(1) as u32)
                .map(|i| [i, i + 1])
                .collect(),
        ),
    });
    let step = |it: &Iterate, est: Option<&EstimateRecord>| {
        let mut grids = Vec::new();
        for (k, p) in problems.iter().enumerate() {
            let mut fields = body_fields(&p.mesh, &p.material, &it.u[k], have[k]);
            if let Some(e) = est {
                for (name, map) in ["eta_glo", "eta_fe", "eta_nndd"].iter().zip(&e.maps[k]) {
                    fields.push(Field {
                        name: name.to_string(),
                        center: Center::Cell,
                        kind: Kind::Scalar,
                        values: if have[k] { map.clone() } else { Vec::new() },
                    });
                }
            }
            grids.push(GridFields {
                grid: format!("body{}", p.alpha),
                fields,
            });
        }
        // The gap g₀ + u²_n − u¹_n = g₀ + u²_n − λ (step 1 puts u¹_n at λ exactly); u²_n is
        // shared by body 2.
        let u2n = &it.trace2;
        let lumped = iface.forces(&vec![1.0; m]);
        let scalar = |name: &str, values: Vec<f64>| Field {
            name: name.into(),
            center: Center::Node,
            kind: Kind::Scalar,
            values,
        };
        let mut fields = vec![
            scalar("lambda", it.lambda.clone()),
            scalar("normal_force", it.forces[1].clone()),
            scalar(
                "pressure",
                (0..m).map(|i| it.forces[1][i] / lumped[i]).collect(),
            ),
            scalar(
                "gap",
                (0..m)
                    .map(|i| problems[0].gap[i] + u2n[i] - it.lambda[i])
                    .collect(),
            ),
            scalar(
                "active",
                it.active.iter().map(|&a| a as u8 as f64).collect(),
            ),
            // The contact direction of each pair (body 1's outward normal).
            Field {
                name: "normal".into(),
                center: Center::Node,
                kind: Kind::Vector,
                values: problems[0].contact_normals.concat(),
            },
        ];
        if let Some(e) = est {
            fields.push(scalar("t_hat", e.t_hat.clone()));
        }
        grids.push(GridFields {
            grid: "contact".into(),
            fields,
        });
        Step {
            time: it.iteration as f64,
            grids,
        }
    };
    Results {
        grids,
        steps: steps.iter().map(|&(it, est)| step(it, est)).collect(),
        attributes,
    }
}

/// Displacement (node vector), stress (cell tensor, plane strain σ_zz) and von Mises stress.
/// Empty values unless `have` (the ranks of the body's group).
fn body_fields(mesh: &Mesh, mat: &Material, u: &[f64], have: bool) -> Vec<Field> {
    let s = if have {
        fem::stresses(mesh, mat, u)
    } else {
        Vec::new()
    };
    let mut tensor = Vec::with_capacity(6 * s.len());
    let mut mises = Vec::with_capacity(s.len());
    for si in &s {
        let zz = mat.sigma_zz(si);
        tensor.extend_from_slice(&[si[0], si[1], zz, si[2], 0.0, 0.0]);
        let (a, b, c) = (si[0] - si[1], si[1] - zz, zz - si[0]);
        mises.push((0.5 * (a * a + b * b + c * c) + 3.0 * si[2] * si[2]).sqrt());
    }
    vec![
        Field {
            name: "displacement".into(),
            center: Center::Node,
            kind: Kind::Vector,
            values: if have { u.to_vec() } else { Vec::new() },
        },
        Field {
            name: "stress".into(),
            center: Center::Cell,
            kind: Kind::Tensor,
            values: tensor,
        },
        Field {
            name: "von_mises".into(),
            center: Center::Cell,
            kind: Kind::Scalar,
            values: mises,
        },
    ]
}

/// The rows of each grid this rank writes: a body's points and cells split evenly over its
/// group's ranks (which all hold its fields); the Γc grid by rank 0.
pub fn shares(layout: &Layout, results: &Results) -> Vec<Share> {
    results
        .grids
        .iter()
        .map(|g| {
            let alpha = match g.name.as_str() {
                "body1" => 1,
                "body2" => 2,
                _ => 0,
            };
            let (mine, k, parts) = if alpha == 0 {
                (layout.is_root(), 0, 1)
            } else {
                (
                    layout.owns(alpha),
                    layout.group_rank(),
                    layout.group_sizes[alpha - 1],
                )
            };
            let block = |len: usize| {
                if mine {
                    len * k / parts..len * (k + 1) / parts
                } else {
                    0..0
                }
            };
            let cells = match &g.topology {
                Topology::Triangle(t) => t.len(),
                Topology::Segment(t) => t.len(),
            };
            Share {
                points: block(g.points.len()),
                cells: block(cells),
            }
        })
        .collect()
}

/// The JSON description of the fields of the last step (dataset paths of `PREFIX.h5`).
pub fn describe(results: &Results) -> Vec<FieldInfo> {
    let k = results.steps.len().saturating_sub(1);
    let mut out = Vec::new();
    if let Some(step) = results.steps.last() {
        for g in &step.grids {
            for f in &g.fields {
                out.push(FieldInfo {
                    grid: g.grid.clone(),
                    name: f.name.clone(),
                    center: if matches!(f.center, Center::Node) {
                        "node"
                    } else {
                        "cell"
                    },
                    // Columns as stored (vectors padded to 3, tensors as full 3 × 3).
                    components: match f.kind {
                        Kind::Scalar => 1,
                        Kind::Vector => 3,
                        Kind::Tensor => 9,
                    },
                    dataset: format!("/steps/{k}/{}/{}", g.grid, f.name),
                });
            }
        }
    }
    out
}
