//! What the result files hold: the meshes of both bodies and of Γc, and per step the fields of
//! an iterate (displacements, stresses, Γc quantities) with the estimates' element maps. Built
//! here from the solver's and the estimator's data, written by [`super::output`].

use crate::dd::nndd::Iterate;
use crate::estimate::{EstimateRecord, Interface};
use crate::fem;
use crate::io::output::{
    function_path, Center, Field, Grid, GridFields, Kind, Results, Share, Step, Topology,
};
use crate::io::summary::FieldInfo;
use crate::parallel::layout::Layout;
use crate::problem::BodyProblem;

/// The HDF5/XDMF content: the two bodies as one grid `bodies` (body 1's points and
/// triangles, then body 2's, with the constant cell field `body` = 1 or 2), Γc as the grid
/// `contact`, and one step per entry of `steps` (an iterate, with its estimates when it was
/// estimated).
/// A step's fields of the `bodies` grid are given for this rank's rows of it alone
/// (`shares[0]`, [`shares`]: rows of the bodies of its group, whose fields it has), so that no
/// rank holds any step's fields whole; the geometry and the Γc fields are known everywhere.
pub fn results(
    problems: [&BodyProblem; 2],
    steps: &[(&Iterate, Option<&EstimateRecord>)],
    shares: &[Share],
    attributes: Vec<(String, f64)>,
    text: Vec<(String, String)>,
) -> Results {
    // Γc's pairs at the nodes of its pair side (body 1, or the non-mortar body).
    let side = crate::problem::pair_side(problems);
    let iface = Interface::new(problems[side].contact_lengths.clone());
    let m = iface.len();
    let [r1, r2] = body_rows(problems);
    let mut points = problems[0].mesh.points.clone();
    points.extend_from_slice(&problems[1].mesh.points);
    let offset = [0, r1.points.end];
    let triangles = problems
        .iter()
        .zip(offset)
        .flat_map(|(p, o)| {
            p.mesh
                .triangles
                .iter()
                .map(move |t| t.map(|v| (v + o) as u32))
        })
        .collect();
    let body = (r1.cells.clone().map(|_| 1.0))
        .chain(r2.cells.clone().map(|_| 2.0))
        .collect();
    let grids = vec![
        Grid {
            name: "bodies".into(),
            points,
            topology: Topology::Triangle(triangles),
            fields: vec![Field {
                name: "body".into(),
                center: Center::Cell,
                kind: Kind::Scalar,
                values: body,
            }],
        },
        Grid {
            name: "contact".into(),
            // Γc at body 1's side (its nodes, in pair order).
            points: problems[side]
                .contact_nodes
                .iter()
                .map(|&n| problems[side].mesh.points[n])
                .collect(),
            topology: Topology::Segment(contact_segments(problems)),
            fields: Vec::new(),
        },
    ];
    let rows = [&r1, &r2];
    let mine = &shares[0];
    let step = |it: &Iterate, est: Option<&EstimateRecord>| {
        let mut fields = body_fields(problems, rows, mine, &it.u);
        if let Some(e) = est {
            for (j, name) in ["eta_glo", "eta_fe", "eta_nndd"].iter().enumerate() {
                fields.push(Field {
                    name: name.to_string(),
                    center: Center::Cell,
                    kind: Kind::Scalar,
                    values: on_share(rows, mine, Center::Cell, 1, |k, e_k, out| {
                        out.push(e.eta_at(k, j, e_k))
                    }),
                });
            }
        }
        let mut grids = vec![GridFields {
            grid: "bodies".into(),
            fields,
        }];
        // The gap g₀ + u²_n − u¹_n (it.lambda is u¹_n, it.trace2 u²_n, shared by their bodies);
        // the contact forces are the contact step's multipliers.
        let u2n = &it.trace2;
        let force = it.contact_forces();
        let lumped = crate::problem::pair_shares(problems);
        let scalar = |name: &str, values: Vec<f64>| Field {
            name: name.into(),
            center: Center::Node,
            kind: Kind::Scalar,
            values,
        };
        // The pair side's displacement at its Γc nodes (known on its body's ranks, the one
        // writing Γc among them: [`shares`]).
        let u1 = &it.u[side];
        let displacement = if !u1.is_empty() {
            let nodes = &problems[side].contact_nodes;
            nodes
                .iter()
                .flat_map(|&n| [u1[2 * n], u1[2 * n + 1]])
                .collect()
        } else {
            Vec::new()
        };
        let mut fields = vec![
            scalar("lambda", it.lambda.clone()),
            scalar("normal_force", force.clone()),
            scalar("pressure", (0..m).map(|i| force[i] / lumped[i]).collect()),
            scalar(
                "gap",
                (0..m)
                    .map(|i| problems[side].gap[i] + u2n[i] - it.lambda[i])
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
                values: problems[side].contact_normals.concat(),
            },
            Field {
                name: "displacement".into(),
                center: Center::Node,
                kind: Kind::Vector,
                values: displacement,
            },
        ];
        if let Some(t) = &it.tangential {
            // Friction: body 2's tangential force, as a shear (Pa), the slip and the state.
            let tf = it.tangential_contact_forces();
            fields.push(scalar("shear", (0..m).map(|i| tf[i] / lumped[i]).collect()));
            fields.push(scalar("tangential_force", tf));
            fields.push(scalar("friction_bound", t.bounds.clone()));
            fields.push(scalar("slip", t.slip()));
            fields.push(scalar(
                "contact_state",
                t.states(&it.active).iter().map(|s| s.code()).collect(),
            ));
        }
        if let Some(e) = est {
            // −t̂: the estimate's admissible contact traction as a pressure (≥ 0).
            fields.push(scalar("pressure_hat", e.t_hat.iter().map(|t| -t).collect()));
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
        text,
    }
}

/// Each body's rows of the `bodies` grid: body 1's points and cells, then body 2's.
pub fn body_rows(problems: [&BodyProblem; 2]) -> [Share; 2] {
    let (n1, m1) = (
        problems[0].mesh.points.len(),
        problems[0].mesh.triangles.len(),
    );
    let (n2, m2) = (
        problems[1].mesh.points.len(),
        problems[1].mesh.triangles.len(),
    );
    [
        Share {
            points: 0..n1,
            cells: 0..m1,
        },
        Share {
            points: n1..n1 + n2,
            cells: m1..m1 + m2,
        },
    ]
}

/// The values of a field at this rank's rows `mine` of the `bodies` grid (in row order):
/// `value(k, i, out)` pushes the `width` values of body k + 1's entry i (its node or element);
/// entries of a body whose fields this rank does not have are zero.
fn on_share(
    rows: [&Share; 2],
    mine: &Share,
    center: Center,
    width: usize,
    mut value: impl FnMut(usize, usize, &mut Vec<f64>),
) -> Vec<f64> {
    let wanted = mine.rows(center);
    let mut out = Vec::with_capacity(width * wanted.len());
    for (k, body) in rows.iter().enumerate() {
        let body = body.rows(center);
        for r in wanted.start.max(body.start)..wanted.end.min(body.end) {
            value(k, r - body.start, &mut out);
        }
    }
    out
}

/// Displacement (node vector), stress (cell tensor, plane strain σ_zz) and von Mises stress
/// at this rank's rows `mine` of the `bodies` grid, from the fields `u` of the bodies (empty
/// where this rank does not have a body's).
fn body_fields(
    problems: [&BodyProblem; 2],
    rows: [&Share; 2],
    mine: &Share,
    u: &[Vec<f64>; 2],
) -> Vec<Field> {
    let stress = |k: usize, e: usize| {
        let p = problems[k];
        (!u[k].is_empty()).then(|| fem::element_stress(&p.mesh, e, &p.material, &u[k]))
    };
    let displacement = on_share(rows, mine, Center::Node, 2, |k, n, out| {
        out.extend([0, 1].map(|c| u[k].get(2 * n + c).copied().unwrap_or(0.0)))
    });
    let tensor = on_share(rows, mine, Center::Cell, 6, |k, e, out| {
        match stress(k, e) {
            Some(si) => {
                let zz = problems[k].material.sigma_zz(&si);
                out.extend_from_slice(&[si[0], si[1], zz, si[2], 0.0, 0.0]);
            }
            None => out.extend_from_slice(&[0.0; 6]),
        }
    });
    // (σ_zz from the tensor's third column)
    let mises = tensor
        .chunks_exact(6)
        .map(|t| {
            let (a, b, c) = (t[0] - t[1], t[1] - t[2], t[2] - t[0]);
            (0.5 * (a * a + b * b + c * c) + 3.0 * t[3] * t[3]).sqrt()
        })
        .collect();
    vec![
        Field {
            name: "displacement".into(),
            center: Center::Node,
            kind: Kind::Vector,
            values: displacement,
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

/// The segments of the Γc grid: between consecutive pairs, and from the last back to the first
/// where Γc closes on itself (a closed curve coupled all round).
fn contact_segments(problems: [&BodyProblem; 2]) -> Vec<[u32; 2]> {
    let m = problems[crate::problem::pair_side(problems)]
        .contact_nodes
        .len() as u32;
    let closes = m > 2 && crate::problem::contact_closes(problems);
    (0..m.saturating_sub(1))
        .map(|i| [i, i + 1])
        .chain(closes.then(|| [m - 1, 0]))
        .collect()
}

/// The rows of each grid this rank writes: a body's points and cells of the `bodies` grid
/// split evenly over its group's ranks (which all hold its fields; one rank holding both
/// bodies writes both); the Γc grid by rank 0.
pub fn shares(layout: &Layout, problems: [&BodyProblem; 2]) -> Vec<Share> {
    let rows = body_rows(problems);
    let bodies = if layout.owns(1) && layout.owns(2) {
        Share {
            points: 0..rows[1].points.end,
            cells: 0..rows[1].cells.end,
        }
    } else if let Some(k) = (0..2).find(|&k| layout.owns(k + 1)) {
        Share {
            points: block(layout, k, &rows[k].points),
            cells: block(layout, k, &rows[k].cells),
        }
    } else {
        Share::default()
    };
    // Γc by the first rank of its pair side's body (which has that body's displacement).
    let side = crate::problem::pair_side(problems);
    let writes = layout.group_ranks(side + 1).start == layout.rank as usize;
    let contact = match writes {
        true => Share {
            points: 0..problems[side].contact_nodes.len(),
            cells: 0..contact_segments(problems).len(),
        },
        false => Share::default(),
    };
    vec![bodies, contact]
}

/// This rank's block of the rows `r` of body k + 1 (its group's ranks split them evenly).
fn block(layout: &Layout, k: usize, r: &std::ops::Range<usize>) -> std::ops::Range<usize> {
    let (part, parts) = (layout.group_rank(), layout.group_sizes[k]);
    let len = r.len();
    r.start + len * part / parts..r.start + len * (part + 1) / parts
}

/// The elements of each body whose rows of the `bodies` grid this rank writes ([`shares`]),
/// in the body's numbering (`cells[k]`: its element count): all of a body on a rank that
/// holds both, its block on a rank of its group, none elsewhere.
pub fn cell_blocks(layout: &Layout, cells: [usize; 2]) -> [std::ops::Range<usize>; 2] {
    let both = layout.owns(1) && layout.owns(2);
    [0, 1].map(|k| match (both, layout.owns(k + 1)) {
        (true, _) => 0..cells[k],
        (false, true) => block(layout, k, &(0..cells[k])),
        (false, false) => 0..0,
    })
}

/// The JSON description of the fields of the last step (dataset paths of `PREFIX.h5`).
pub fn describe(results: &Results) -> Vec<FieldInfo> {
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
                    // Columns as stored (vectors padded to 3, tensors xx yy zz xy yz xz).
                    components: match f.kind {
                        Kind::Scalar => 1,
                        Kind::Vector => 3,
                        Kind::Tensor => 6,
                    },
                    dataset: function_path(&g.grid, &f.name, step.time),
                });
            }
        }
    }
    out
}
