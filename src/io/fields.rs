//! What the result files hold: the meshes of both bodies and of Γc, and per step the fields of
//! an iterate (displacements, stresses, Γc quantities) with the estimates' element maps. Built
//! here from the solver's and the estimator's data, written by [`super::output`].

use std::ops::Range;

use crate::dd::displacement::Displacement;
use crate::dd::nndd::Iterate;
use crate::estimate::{EstimateRecord, Interface};
use crate::fem::{self, Mesh};
use crate::io::output::{
    function_path, Center, Extent, Field, Grid, GridFields, Kind, Results, Share, Step, Topology,
};
use crate::io::summary::FieldInfo;
use crate::parallel::layout::Layout;
use crate::problem::BodyProblem;

/// The HDF5/XDMF content: the two bodies as one grid `bodies` (body 1's points and
/// triangles, then body 2's, with the constant cell field `body` = 1 or 2), Γc as the grid
/// `contact`, and one step per entry of `steps` (an iterate, with its estimates when it was
/// estimated).
/// The `bodies` grid, and its fields at every step, are given for this rank's rows of it alone
/// (`shares[0]`, [`shares`]: rows of the bodies of its group, whose fields it has), so that no
/// rank holds the grid or any step's fields whole; the Γc grid and its fields (O(√N)) are
/// known everywhere.
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
    let rows = [&r1, &r2];
    let mine = &shares[0];
    let grids = vec![
        bodies_grid(problems, rows, mine),
        // Γc at its pair side (its nodes, in pair order).
        Grid::whole(
            "contact",
            (problems[side].contact_nodes.iter())
                .map(|&n| problems[side].boundary_point(n))
                .collect(),
            Topology::Segment(contact_segments(problems)),
            Vec::new(),
        ),
    ];
    let step = |it: &Iterate, est: Option<&EstimateRecord>| {
        let mut fields = body_fields(problems, rows, mine, [&it.u[0], &it.u[1]]);
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
        let displacement = match est.and_then(|e| e.contact_displacement.as_ref()) {
            Some(kept) => kept.clone(),
            None => contact_displacement(problems, &it.u),
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

/// The `bodies` grid at this rank's rows `mine` alone: its points, its triangles (by point
/// indices of the whole grid: body 2's after body 1's) and the constant cell field `body`.
fn bodies_grid(problems: [&BodyProblem; 2], rows: [&Share; 2], mine: &Share) -> Grid {
    let points = on_share(rows, mine, Center::Node, 2, |k, n, out| {
        out.extend(problems[k].mesh().points.get(n))
    });
    let mut triangles = Vec::with_capacity(mine.cells.len());
    let body = on_share(rows, mine, Center::Cell, 1, |k, e, out| {
        let offset = rows[k].points.start;
        triangles.push(
            problems[k]
                .mesh()
                .triangles
                .get(e)
                .map(|v| (v + offset) as u32),
        );
        out.push((k + 1) as f64);
    });
    Grid {
        name: "bodies".into(),
        extent: Extent {
            points: rows[1].points.end,
            cells: rows[1].cells.end,
        },
        points: points.chunks_exact(2).map(|p| [p[0], p[1]]).collect(),
        topology: Topology::Triangle(triangles),
        fields: vec![Field {
            name: "body".into(),
            center: Center::Cell,
            kind: Kind::Scalar,
            values: body,
        }],
    }
}

/// Each body's rows of the `bodies` grid: body 1's points and cells, then body 2's.
pub fn body_rows(problems: [&BodyProblem; 2]) -> [Share; 2] {
    grid_rows(problems.map(|p| [p.num_nodes(), p.num_elements()]))
}

/// [`body_rows`] of bodies of `sizes`, each its nodes and its elements.
fn grid_rows(sizes: [[usize; 2]; 2]) -> [Share; 2] {
    let [[n1, m1], [n2, m2]] = sizes;
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
/// at this rank's rows `mine` of the `bodies` grid, from the fields `u` of the bodies.
fn body_fields(
    problems: [&BodyProblem; 2],
    rows: [&Share; 2],
    mine: &Share,
    u: [&Displacement; 2],
) -> Vec<Field> {
    // (0 where this rank holds none of the body's field)
    let at = |k: usize, dof: usize| u[k].get(dof).unwrap_or(0.0);
    let stress = |k: usize, e: usize| {
        let p = problems[k];
        (!u[k].is_empty()).then(|| fem::element_stress_with(p.mesh(), e, &p.material, |d| at(k, d)))
    };
    let displacement = on_share(rows, mine, Center::Node, 2, |k, n, out| {
        out.extend([0, 1].map(|c| at(k, 2 * n + c)))
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

/// This rank's block of the rows `r` of body k + 1 ([`Layout::block`]).
fn block(layout: &Layout, k: usize, r: &std::ops::Range<usize>) -> std::ops::Range<usize> {
    let b = layout.block(k + 1, r.len());
    r.start + b.start..r.start + b.end
}

/// What a rank keeps of an estimated step for the output ([`kept_rows`]), per body in its
/// own numbering: the elements whose rows of the `bodies` grid it writes ([`shares`]), and the
/// nodes whose displacement those rows read (its points and those elements' nodes,
/// ascending).
pub struct KeptRows {
    pub cells: [Range<usize>; 2],
    pub nodes: [Vec<usize>; 2],
}

/// This rank's [`KeptRows`]: all of a body on a rank that holds both, its block on a rank of
/// its group, none elsewhere.
pub fn kept_rows(layout: &Layout, problems: [&BodyProblem; 2]) -> KeptRows {
    let mine = shares(layout, problems).swap_remove(0);
    let sizes = problems.map(|p| [p.num_nodes(), p.num_elements()]);
    kept_on(
        &mine,
        sizes,
        problems.map(|p| p.holds_mesh().then(|| p.mesh())),
    )
}

/// The [`KeptRows`] of the rows `mine` of the `bodies` grid of bodies of `sizes` (nodes,
/// elements), from the meshes of those whose cells it writes (`None` where the rank does
/// not hold a body's mesh: it writes none of its rows).
fn kept_on(mine: &Share, sizes: [[usize; 2]; 2], meshes: [Option<&Mesh>; 2]) -> KeptRows {
    let rows = grid_rows(sizes);
    let local = |r: &Range<usize>, body: &Range<usize>| {
        let (lo, hi) = (r.start.max(body.start), r.end.min(body.end));
        match lo < hi {
            true => lo - body.start..hi - body.start,
            false => 0..0,
        }
    };
    let cells = [0, 1].map(|k| local(&mine.cells, &rows[k].cells));
    let nodes = [0, 1].map(|k| {
        let points = local(&mine.points, &rows[k].points);
        let mesh = || meshes[k].expect("a rank holds the mesh of the bodies it writes");
        let mut nodes: Vec<usize> = (cells[k].clone())
            .flat_map(|e| mesh().triangles.get(e))
            .chain(points)
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    });
    KeptRows { cells, nodes }
}

/// The pair side's displacement at its Γc nodes, x and y per pair, from the bodies' fields
/// `u` (empty where this rank does not have that body's).
pub fn contact_displacement(problems: [&BodyProblem; 2], u: &[Displacement; 2]) -> Vec<f64> {
    let side = crate::problem::pair_side(problems);
    match u[side].is_empty() {
        true => Vec::new(),
        false => (problems[side].contact_nodes.iter())
            .flat_map(|&n| [u[side][2 * n], u[side][2 * n + 1]])
            .collect(),
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// What a rank keeps of a step holds every node of its cells and its points, and on a
    /// structured mesh no more than its block's rows of nodes and one more.
    #[test]
    fn kept_rows_hold_the_nodes_of_the_rows_written() {
        let (nx, ny) = (8, 6);
        let meshes = [
            Mesh::structured([0.0, 0.0], [1.0, 1.0], nx, ny),
            Mesh::structured([0.0, 1.0], [1.0, 1.0], nx, ny),
        ];
        let sizes = meshes
            .each_ref()
            .map(|m| [m.num_nodes(), m.triangles.len()]);
        let [r1, r2] = grid_rows(sizes);
        // Body 2's second of three blocks, as its group's middle rank writes it.
        let third = |r: &Range<usize>| r.start + r.len() / 3..r.start + 2 * r.len() / 3;
        let mine = Share {
            points: third(&r2.points),
            cells: third(&r2.cells),
        };
        // (body 1's mesh not held: none of its rows is written)
        let kept = kept_on(&mine, sizes, [None, Some(&meshes[1])]);
        assert_eq!(kept.cells[0], 0..0);
        assert!(kept.nodes[0].is_empty());
        let cells = &kept.cells[1];
        assert_eq!(cells.len(), mine.cells.len());
        assert_eq!(cells.start, mine.cells.start - r1.cells.end);
        let nodes = &kept.nodes[1];
        assert!(
            nodes.windows(2).all(|w| w[0] < w[1]),
            "ascending, once each"
        );
        let mut read: Vec<usize> = (cells.clone())
            .flat_map(|e| meshes[1].triangles.get(e))
            .chain(mine.points.clone().map(|p| p - r1.points.end))
            .collect();
        read.sort_unstable();
        read.dedup();
        assert_eq!(nodes, &read);
        let rows_of_nodes = cells.len().div_ceil(2 * nx) + 1;
        assert!(nodes.len() <= (nx + 1) * (rows_of_nodes + 1), "{nodes:?}");
        assert!(nodes.len() < meshes[1].num_nodes() / 2, "{nodes:?}");
        // A rank holding both bodies keeps them whole.
        let all = Share {
            points: 0..r2.points.end,
            cells: 0..r2.cells.end,
        };
        let kept = kept_on(&all, sizes, [Some(&meshes[0]), Some(&meshes[1])]);
        assert_eq!(kept.cells, [0..r1.cells.end, 0..r2.cells.len()]);
        assert_eq!(
            kept.nodes,
            [0, 1].map(|k| (0..meshes[k].num_nodes()).collect::<Vec<_>>())
        );
    }
}
