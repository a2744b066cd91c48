//! The adaptive run's settings (`-nndd_adapt_…`) and the steps between two cycles
//! (docs/method.md §8): the new sizes from the element estimates, the bodies remeshed by Gmsh
//! from their `.geo`, and λ carried over to the new Γc.

use mpi::traits::Communicator;
use std::path::{Path, PathBuf};

use crate::estimate::size_field::{self, Limits, Strategy};
use crate::fem::geo;
use crate::parallel::held;
use crate::parallel::layout::Layout;
use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::{self, OptionsBlock};
use crate::problem::meshed::MeshSpec;
use crate::problem::{BodyProblem, ContactDiscretisation, ProblemKind, ProblemSettings};

/// What an adaptive run aims at and how its meshes are chosen (plain data).
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptSettings {
    /// ε: the cycles end once η^glo ≤ ε ‖u_h‖_E.
    pub tol: f64,
    /// The most cycles (solves) before the run ends unreached (exit 3).
    pub max_cycles: usize,
    /// How the new sizes are chosen.
    pub strategy: Strategy,
    /// The bounds of one cycle's size change.
    pub limits: Limits,
}

/// What the size field aims the next mesh's η^FE at, as a fraction of ε ‖u_h‖_E: room for
/// η^NNDD (the balanced rule's κ η^FE) and the correction in η^glo, and for a prediction that
/// is a model of the error, not the error.
pub const AIM: f64 = 0.8;

/// κ of the balanced rule in an adaptive run that asks for it (`-nndd_stop balanced`;
/// `-nndd_stop_ratio`'s default there): the element maps of η^FE must be the mesh's error, and
/// an early iterate's carry algebraic error (Hertz level 1, mortar: η^FE 726 at κ = 0.1, 343
/// at κ = 0.01 and converged). The default rule is `tol`, then one estimate: the NNDD's
/// iterations cost little next to an estimate (Hertz, ε = 1 %, cycle 3, 327 k dofs: `tol`
/// 8 iterations and one estimate, 11.7 s; `balanced` 5 iterations and 3 estimates, 19.8 s).
pub const STOP_RATIO: &str = "0.01";

/// The contact discretisation of an adaptive run (`-nndd_contact_discretisation`'s default
/// there): node to node, the remeshed curves made to match. Measured on Hertz
/// (examples/hertz-nonmatching, ε = 2 %, r = 2): node to node reaches it in 3 cycles at
/// effectivities 1.23, 1.19, 1.31; mortar's estimates, on matched meshes that insert each
/// curve's nodes into the other, grow 1.30, 1.72, 2.25 as the curves' sizes come alike (their
/// nodes come close: slivers), and its NNDD stagnated at cycle 4.
pub const DISCRETISATION: &str = "node_to_node";

/// Under the mortar discretisation, how much coarser than asked the next mesh's pair side
/// (the non-mortar curve) is made along Γc.
pub const MORTAR_COARSER: f64 = 1.5;

/// `-nndd_adapt_tol`.
const TOL: Bounds<f64> = Bounds {
    accepted: "in (0, 1) (a relative error: eta_glo <= tol ||u_h||_E)",
    holds: |x| x > 0.0 && x < 1.0,
};

/// `-nndd_adapt_max_cycles`.
const CYCLES: Bounds<i64> = Bounds {
    accepted: "an integer in [1, 100]",
    holds: |k| (1..=100).contains(&k),
};

/// `-nndd_adapt_fraction`.
const FRACTION: Bounds<f64> = Bounds {
    accepted: "in (0, 1]",
    holds: |x| x > 0.0 && x <= 1.0,
};

/// The options of an adaptive run, all but `-nndd_adapt_tol` only with it.
const NEEDS_TOL: [&str; 3] = [
    "-nndd_adapt_max_cycles",
    "-nndd_adapt_strategy",
    "-nndd_adapt_fraction",
];

#[derive(Clone, Copy)]
enum StrategyName {
    Optimal,
    Dorfler,
}

impl AdaptSettings {
    /// Read, register (for `-help`) and validate the adaptive run's options: `None` without
    /// `-nndd_adapt_tol` (one solve on the given mesh).
    pub fn from_options(o: &mut OptionsBlock) -> Result<Option<AdaptSettings>, SettingsError> {
        let (tol, given) = o.real_in(
            "-nndd_adapt_tol",
            "Adapt the meshes until eta_glo <= tol ||u_h||_E, tol in (0, 1): each cycle the NNDD, the estimates of its answer, and both bodies remeshed by gmsh from -nndd_mesh FILE.geo with the sizes eta_FE asks for (default: off, one solve)",
            0.0,
            Bounds::FINITE,
        )?;
        let (max_cycles, _) = o.int_in(
            "-nndd_adapt_max_cycles",
            "The most cycles of -nndd_adapt_tol; a run that has not reached it then ends with exit code 3",
            8,
            CYCLES,
        )?;
        let name = o.choice(
            "-nndd_adapt_strategy",
            "How -nndd_adapt_tol chooses the next mesh: optimal (each element's size from its share of eta_FE, the error equidistributed at the target: Ladeveze-Pelle's optimal mesh), dorfler (halve the elements carrying -nndd_adapt_fraction of eta_FE^2)",
            &[
                ("optimal", StrategyName::Optimal),
                ("dorfler", StrategyName::Dorfler),
            ],
        )?;
        let (fraction, _) = o.real_in(
            "-nndd_adapt_fraction",
            "The fraction of eta_FE^2 that -nndd_adapt_strategy dorfler refines, in (0, 1]",
            0.5,
            FRACTION,
        )?;
        if !given {
            if let Some(other) = NEEDS_TOL.iter().find(|n| petsc::option_present(n)) {
                return Err(SettingsError::named(
                    other,
                    "applies to an adaptive run only: give -nndd_adapt_tol too",
                ));
            }
            return Ok(None);
        }
        if !(TOL.holds)(tol) {
            return Err(SettingsError::out_of_range(
                "-nndd_adapt_tol",
                TOL.accepted,
                tol,
            ));
        }
        let strategy = match name {
            StrategyName::Optimal => Strategy::Optimal { order: 1.0 },
            StrategyName::Dorfler => Strategy::Dorfler { fraction },
        };
        Ok(Some(AdaptSettings {
            tol,
            max_cycles,
            strategy,
            limits: Limits::default(),
        }))
    }

    /// An adaptive run remeshes the bodies from their Gmsh geometry: `-nndd_mesh FILE.geo`.
    pub fn check_problem(&self, problem: &ProblemSettings) -> Result<(), SettingsError> {
        let why = match (&problem.mesh, problem.kind) {
            (Some(spec), ProblemKind::Mesh) if geo::is_geo(Path::new(&spec.gmsh.path)) => {
                return Ok(())
            }
            (Some(spec), _) => format!(
                "remeshes the bodies from their geometry, and {} is a mesh: give the .geo file it was meshed from as -nndd_mesh FILE.geo",
                spec.gmsh.path
            ),
            (None, kind) => format!(
                "remeshes the bodies from a Gmsh geometry: give it as -nndd_mesh FILE.geo (the built-in {} problem's is examples/{}/{}.geo)",
                kind.name(),
                kind.name(),
                kind.name()
            ),
        };
        Err(SettingsError::named("-nndd_adapt_tol", why))
    }
}

/// The η^FE element maps of both bodies on world rank 0 (empty elsewhere), from each rank's
/// block of its body's ([`Layout::block`]): `maps[k]`, η^FE_E on this rank's block of body
/// k + 1's elements from element `first[k]` on.
pub fn eta_fe_on_root(
    layout: &Layout,
    maps: [&[f64]; 2],
    first: [usize; 2],
    elements: [usize; 2],
) -> [Vec<f64>; 2] {
    [0, 1].map(|k| held::whole_on_root(layout, k + 1, elements[k], maps[k], first[k]))
}

/// What the new sizes predict, for the cycle's record.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Prediction {
    /// The new mesh's element count Σ_E r_E^(−2).
    pub elements: f64,
    /// The η^FE the sizes aim at (absolute).
    pub target: f64,
    /// The predicted η^FE of the new mesh (the optimal criterion; none for Dörfler).
    pub eta_fe: Option<f64>,
}

/// The sizes η^FE asks for on both bodies (`eta_fe[k]` per element of body k), aiming at
/// `target`, written as Gmsh's background view `view` (rank 0).
pub fn write_size_field(
    settings: &AdaptSettings,
    problems: [&BodyProblem; 2],
    eta_fe: &[Vec<f64>; 2],
    target: f64,
    view: &Path,
) -> std::io::Result<Prediction> {
    let mut points: Vec<[f64; 2]> = Vec::new();
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    let mut squares = Vec::new();
    let mut sizes = Vec::new();
    for (p, eta) in problems.iter().zip(eta_fe) {
        let offset = points.len();
        points.extend(p.mesh().points.iter());
        for (e, t) in p.mesh().triangles.iter().enumerate() {
            triangles.push(t.map(|v| v + offset));
            sizes.push(size_field::triangle_size(p.mesh().triangle_points(e)));
            squares.push(eta.get(e).map_or(0.0, |v| v * v));
        }
    }
    let field =
        size_field::size_field(&squares, &sizes, target, settings.strategy, settings.limits);
    let mut nodal = size_field::nodal_sizes(points.len(), &triangles, &field.sizes);
    // Mortar: the pair side's curve kept the coarser, so that it stays the side whose nodes
    // carry the constraints (a finer one makes its trace rank-deficient).
    if crate::problem::discretisation(problems) == ContactDiscretisation::Mortar {
        let side = crate::problem::pair_side(problems);
        let offset = if side == 0 {
            0
        } else {
            problems[0].num_nodes()
        };
        for &n in &problems[side].contact_candidates {
            nodal[offset + n] *= MORTAR_COARSER;
        }
    }
    skirt(&mut points, &mut triangles, &mut nodal);
    geo::write_background(view, &points, &triangles, &nodal)?;
    Ok(Prediction {
        elements: field.elements,
        target,
        eta_fe: field.error,
    })
}

/// Each boundary edge (a, b) of the mesh gets a triangle outside it, (a, b, a + b − c) with c
/// the edge's inner vertex, carrying the sizes of a and b and c's: the geometry's curved
/// boundaries bulge beyond the old mesh's chords, and Gmsh finds no size in the background
/// view there (it then meshes the curve with the largest size, a chord across the arc).
fn skirt(points: &mut Vec<[f64; 2]>, triangles: &mut Vec<[usize; 3]>, nodal: &mut Vec<f64>) {
    let mut count: std::collections::HashMap<(usize, usize), (usize, usize)> =
        std::collections::HashMap::new();
    for t in triangles.iter() {
        for e in 0..3 {
            let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
            let entry = count.entry((a.min(b), a.max(b))).or_insert((0, c));
            entry.0 += 1;
        }
    }
    let mut boundary: Vec<((usize, usize), usize)> = count
        .into_iter()
        .filter(|(_, (n, _))| *n == 1)
        .map(|(k, (_, c))| (k, c))
        .collect();
    boundary.sort_unstable();
    for ((a, b), c) in boundary {
        let (pa, pb, pc) = (points[a], points[b], points[c]);
        points.push([pa[0] + pb[0] - pc[0], pa[1] + pb[1] - pc[1]]);
        nodal.push(nodal[c]);
        triangles.push([a, b, points.len() - 1]);
    }
}

/// The next cycle's problem: both bodies meshed again by Gmsh from `spec`'s geometry with the
/// sizes of the background view `view`, on world rank 0, which keeps the new file and tells the
/// other ranks its facts (a cycle that builds its bodies on every rank sends them the file,
/// `ParsedFile::share`). The `.geo` file sees `nndd_cycle` set to the cycle's number (it may
/// drop structured-mesh constraints, `Transfinite`, that a size field cannot move:
/// examples/paper/paper.geo does). Collective.
pub fn remesh(spec: &MeshSpec, view: &Path, cycle: usize) -> Result<MeshSpec, String> {
    let path = PathBuf::from(&spec.gmsh.path);
    let mut parameters = spec.geo_set.clone();
    parameters.retain(|(n, _)| n != "nndd_cycle");
    parameters.push(("nndd_cycle".into(), cycle as f64));
    match mpi::topology::SimpleCommunicator::world().rank() == 0 {
        true => match geo::remesh(&path, &parameters, view) {
            Ok(gmsh) => spec.remeshed(Some(gmsh)),
            Err(e) => {
                // (the others learn of it from the facts rank 0 cannot send)
                let _ = spec.remeshed(None);
                Err(e.to_string())
            }
        },
        false => spec.remeshed(None),
    }
}

/// λ carried over to new pairs: the old λ (at the points `from`, along Γc in pair order) at
/// each point of `to`, linear along the nearest segment of the old Γc (the nearest end beyond
/// it). A start for the NNDD, not an answer: the next cycle's iterations make it one.
pub fn carry_over(from: &[[f64; 2]], lambda: &[f64], to: &[[f64; 2]]) -> Vec<f64> {
    if from.len() < 2 || from.len() != lambda.len() {
        return vec![lambda.first().copied().unwrap_or(0.0); to.len()];
    }
    to.iter()
        .map(|&x| {
            let mut best = (f64::INFINITY, 0.0);
            for k in 0..from.len() - 1 {
                let (a, b) = (from[k], from[k + 1]);
                let d = [b[0] - a[0], b[1] - a[1]];
                let len2 = d[0] * d[0] + d[1] * d[1];
                let t = match len2 > 0.0 {
                    true => (((x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0),
                    false => 0.0,
                };
                let p = [a[0] + t * d[0], a[1] + t * d[1]];
                let dist = (x[0] - p[0]).hypot(x[1] - p[1]);
                if dist < best.0 {
                    best = (dist, (1.0 - t) * lambda[k] + t * lambda[k + 1]);
                }
            }
            best.1
        })
        .collect()
}

/// The points of Γc's pairs, in pair order (the pair side's nodes).
pub fn pair_points(problems: [&BodyProblem; 2]) -> Vec<[f64; 2]> {
    let p = problems[crate::problem::pair_side(problems)];
    p.contact_nodes
        .iter()
        .map(|&n| p.boundary_point(n))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The skirt covers a curved boundary's bulge beyond the chords: each boundary edge of a
    /// square's two triangles gets the triangle mirrored across it, with its inner vertex's
    /// size; the inner edge gets none.
    #[test]
    fn the_view_gets_a_skirt_round_its_boundary() {
        let mut points = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let mut triangles = vec![[0, 1, 2], [0, 2, 3]];
        let mut nodal = vec![1.0, 2.0, 3.0, 4.0];
        skirt(&mut points, &mut triangles, &mut nodal);
        assert_eq!(triangles.len(), 2 + 4);
        assert_eq!(points.len(), 4 + 4);
        // The bottom edge (0, 1): its inner vertex 2 mirrored to (0, −1), size 3.
        let k = 2 + triangles[2..]
            .iter()
            .position(|t| t[..2] == [0, 1])
            .expect("the bottom's");
        assert_eq!(points[triangles[k][2]], [0.0, -1.0]);
        assert_eq!(nodal[triangles[k][2]], 3.0);
        // A point just below the bottom edge (an arc's bulge) lies in that triangle.
        let c = triangles[k].map(|v| points[v]);
        let inside = |p: [f64; 2]| {
            let d = |a: [f64; 2], b: [f64; 2]| {
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let s = [d(c[0], c[1]), d(c[1], c[2]), d(c[2], c[0])];
            s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
        };
        assert!(inside([0.5, -0.01]));
    }

    #[test]
    fn lambda_is_carried_over_linearly_along_the_old_interface() {
        let from = [[0.0, 1.0], [0.5, 1.0], [1.0, 1.0]];
        let lambda = [0.0, 1.0, 4.0];
        let to = [[0.25, 1.0], [0.75, 1.0 + 1e-9], [1.2, 1.0], [-0.1, 1.0]];
        let got = carry_over(&from, &lambda, &to);
        let want = [0.5, 2.5, 4.0, 0.0];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-8, "{got:?}");
        }
    }
}
