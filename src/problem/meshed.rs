//! A problem the user meshed in Gmsh (`-nndd_mesh FILE.msh`): the physical surfaces `body1`
//! (Ω¹, below) and `body2` (Ω², above), boundary conditions on named physical curves, and the
//! contact interface Γc from two named curves, one per body, whose nodes are paired along the
//! normal of body 1's side; each pair's initial gap g₀ ≥ 0 comes from the geometry.
//!
//! Today body 1's contact side must be straight with outward normal (0, 1) (body 1 below,
//! as in `docs/method.md`): the normal dof of a Γc node is its u_y and Γc is ordered by x.
//! Body 2's side may have any shape (e.g. Hertz's cylinder) as long as each of its nodes lies
//! straight above one node of body 1's side.

use std::collections::{BTreeMap, BTreeSet};
use std::rc::Rc;

use super::{BodyProblem, NeumannEdge};
use crate::fem::gmsh::{GmshBody, GmshError, GmshMesh};
use crate::fem::Material;

/// The physical surface names of the two bodies.
pub const BODY_NAMES: [&str; 2] = ["body1", "body2"];

/// Conditions on one named physical curve (plain data, from the `-nndd_bc_NAME_…` options).
#[derive(Clone, Debug, Default)]
pub struct CurveCondition {
    pub curve: String,
    /// Prescribed displacement components (x, y), either or both.
    pub u: [Option<f64>; 2],
    /// A traction, linear along the curve from its first point (`[0]`) to its last (`[1]`).
    pub traction: Option<[[f64; 2]; 2]>,
}

/// The user's meshed problem (plain data, filled from the options by `app`).
#[derive(Clone, Debug)]
pub struct MeshSpec {
    /// The parsed file (read once, when the options are read).
    pub gmsh: Rc<GmshMesh>,
    pub conditions: Vec<CurveCondition>,
    /// Γc: body 1's curve and body 2's curve.
    pub contact: [String; 2],
}

/// What is wrong with a meshed problem: one line, naming the option.
#[derive(Debug, thiserror::Error)]
pub enum MeshedError {
    #[error("-nndd_mesh: {0}")]
    Mesh(#[from] GmshError),
    #[error("{option}: {message}")]
    Option { option: String, message: String },
}

fn opt_err(option: &str, message: String) -> MeshedError {
    MeshedError::Option {
        option: option.to_string(),
        message,
    }
}

/// The nodes of a curve as one chain from its first point to its last (the orientation of
/// its Gmsh line elements).
pub fn chain(edges: &[[usize; 2]], curve: &str, option: &str) -> Result<Vec<usize>, MeshedError> {
    let mut next: BTreeMap<usize, usize> = BTreeMap::new();
    let mut has_prev: BTreeSet<usize> = BTreeSet::new();
    for &[a, b] in edges {
        if next.insert(a, b).is_some() || !has_prev.insert(b) {
            return Err(opt_err(
                option,
                format!("the curve '{curve}' branches or is traversed twice (use one open curve)"),
            ));
        }
    }
    let starts: Vec<usize> = next
        .keys()
        .copied()
        .filter(|a| !has_prev.contains(a))
        .collect();
    if starts.len() != 1 {
        return Err(opt_err(
            option,
            format!(
                "the curve '{curve}' is closed or in several pieces ({} starts); use one open curve",
                starts.len()
            ),
        ));
    }
    let mut nodes = vec![starts[0]];
    while let Some(&b) = next.get(nodes.last().expect("non-empty")) {
        nodes.push(b);
    }
    if nodes.len() != edges.len() + 1 {
        return Err(opt_err(
            option,
            format!("the curve '{curve}' is not one chain"),
        ));
    }
    Ok(nodes)
}

/// Both bodies of a meshed problem.
pub fn build(spec: &MeshSpec, materials: [Material; 2]) -> Result<[BodyProblem; 2], MeshedError> {
    let bodies: Vec<GmshBody> = BODY_NAMES
        .iter()
        .map(|n| spec.gmsh.body(n))
        .collect::<Result<_, _>>()?;
    // Every curve named by an option must lie on a body.
    for c in &spec.conditions {
        if !bodies.iter().any(|b| b.curves.contains_key(&c.curve)) {
            return Err(opt_err(
                &format!("-nndd_bc_{}_*", c.curve),
                format!(
                    "no physical curve '{}' on body1 or body2 (physical curves: {})",
                    c.curve,
                    spec.gmsh.group_names(1)
                ),
            ));
        }
    }
    let (sides, gap) = pair_interface(spec, &bodies)?;
    let body = |k: usize| -> Result<BodyProblem, MeshedError> {
        let alpha = k + 1;
        let (dirichlet, neumann) = conditions(spec, &bodies[k], alpha)?;
        check_rigid_motions(&bodies[k], &dirichlet, alpha)?;
        Ok(BodyProblem {
            alpha,
            mesh: bodies[k].mesh.clone(),
            material: materials[k],
            dirichlet,
            neumann,
            contact_nodes: sides[k].clone(),
            gap: gap.clone(),
        })
    };
    Ok([body(0)?, body(1)?])
}

/// Dirichlet dofs and Neumann edges of body `alpha` from the curve conditions.
#[allow(clippy::type_complexity)]
fn conditions(
    spec: &MeshSpec,
    body: &GmshBody,
    alpha: usize,
) -> Result<(Vec<(usize, f64)>, Vec<NeumannEdge>), MeshedError> {
    let mut fixed: BTreeMap<usize, (f64, String)> = BTreeMap::new();
    let mut neumann = Vec::new();
    for c in &spec.conditions {
        let Some(edges) = body.curves.get(&c.curve) else {
            continue;
        };
        let option = |comp: &str| format!("-nndd_bc_{}_{comp}", c.curve);
        let nodes = chain(edges, &c.curve, &option("*"))?;
        for (k, value) in c.u.iter().enumerate() {
            let Some(v) = *value else { continue };
            let name = option(["ux", "uy"][k]);
            for &n in &nodes {
                let d = 2 * n + k;
                if let Some((w, other)) = fixed.get(&d) {
                    if (w - v).abs() > 1e-14 * (w.abs() + v.abs()) {
                        return Err(opt_err(
                            &name,
                            format!(
                                "conflicts with {other} at the node ({:.6e}, {:.6e}) of body {alpha} ({v:e} vs {w:e})",
                                body.mesh.points[n][0], body.mesh.points[n][1]
                            ),
                        ));
                    }
                }
                fixed.insert(d, (v, name.clone()));
            }
        }
        if let Some([t0, t1]) = c.traction {
            // Linear in the arc length from the curve's first point to its last.
            let pts: Vec<[f64; 2]> = nodes.iter().map(|&n| body.mesh.points[n]).collect();
            let mut s = vec![0.0; pts.len()];
            for i in 1..pts.len() {
                s[i] = s[i - 1] + (pts[i][0] - pts[i - 1][0]).hypot(pts[i][1] - pts[i - 1][1]);
            }
            let len = s[pts.len() - 1];
            let t = |i: usize| {
                let r = s[i] / len;
                [t0[0] + r * (t1[0] - t0[0]), t0[1] + r * (t1[1] - t0[1])]
            };
            for i in 0..nodes.len() - 1 {
                let tr = [t(i), t(i + 1)];
                if tr != [[0.0; 2]; 2] {
                    neumann.push(NeumannEdge {
                        nodes: [nodes[i], nodes[i + 1]],
                        traction: tr,
                    });
                }
            }
        }
    }
    Ok((
        fixed.into_iter().map(|(d, (v, _))| (d, v)).collect(),
        neumann,
    ))
}

/// A body's prescribed dofs must remove its three rigid motions (two translations and the
/// rotation): the rigid modes restricted to the prescribed dofs have rank 3.
fn check_rigid_motions(
    body: &GmshBody,
    dirichlet: &[(usize, f64)],
    alpha: usize,
) -> Result<(), MeshedError> {
    let pts = &body.mesh.points;
    let n = pts.len() as f64;
    let c = pts
        .iter()
        .fold([0.0; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let scale = body.mesh.size[0]
        .max(body.mesh.size[1])
        .max(f64::MIN_POSITIVE);
    // Gram matrix of the modes (1,0), (0,1), (−y, x) on the prescribed dofs.
    let mut g = [[0.0f64; 3]; 3];
    for &(d, _) in dirichlet {
        let p = pts[d / 2];
        let r = [(p[0] - c[0]) / scale, (p[1] - c[1]) / scale];
        let row = if d % 2 == 0 {
            [1.0, 0.0, -r[1]]
        } else {
            [0.0, 1.0, r[0]]
        };
        for i in 0..3 {
            for j in 0..3 {
                g[i][j] += row[i] * row[j];
            }
        }
    }
    let det = g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1])
        - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0])
        + g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0]);
    let trace = g[0][0] + g[1][1] + g[2][2];
    // (No prescribed dof at all gives trace = det = 0: refused too.)
    if det.is_nan() || det <= 1e-10 * trace.powi(3) {
        return Err(opt_err(
            "-nndd_bc_*",
            format!(
                "body {alpha} can move as a rigid body: prescribe displacements (-nndd_bc_NAME_ux, -nndd_bc_NAME_uy) that fix both translations and the rotation"
            ),
        ));
    }
    Ok(())
}

/// Pair the contact curves: every node of body 1's side with the node of body 2's side
/// straight above it. Returns both bodies' node lists in pair order (by x) and g₀ of each
/// pair.
fn pair_interface(
    spec: &MeshSpec,
    bodies: &[GmshBody],
) -> Result<([Vec<usize>; 2], Vec<f64>), MeshedError> {
    const OPT: &str = "-nndd_contact";
    let mut sides = Vec::new();
    for (k, name) in spec.contact.iter().enumerate() {
        let edges = bodies[k].curves.get(name).ok_or_else(|| {
            opt_err(
                OPT,
                format!(
                    "no physical curve '{name}' on body{} (its curves: {})",
                    k + 1,
                    bodies[k]
                        .curves
                        .keys()
                        .cloned()
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })?;
        let mut nodes = chain(edges, name, OPT)?;
        let pts = &bodies[k].mesh.points;
        nodes.sort_by(|&a, &b| pts[a][0].total_cmp(&pts[b][0]));
        sides.push(nodes);
    }
    let (p1, p2) = (&bodies[0].mesh.points, &bodies[1].mesh.points);
    let (s1, s2) = (&sides[0], &sides[1]);
    let x_len = p1[s1[s1.len() - 1]][0] - p1[s1[0]][0];
    let tol = 1e-8 * x_len.abs().max(f64::MIN_POSITIVE);
    // Body 1's side: straight, horizontal, body 1 below it.
    let y0 = p1[s1[0]][1];
    for &n in s1 {
        if (p1[n][1] - y0).abs() > tol {
            return Err(opt_err(
                OPT,
                format!(
                    "body 1's contact curve '{}' must be a straight horizontal segment (normal (0, 1)); its node ({:.6e}, {:.6e}) is off y = {y0:e}",
                    spec.contact[0], p1[n][0], p1[n][1]
                ),
            ));
        }
    }
    if bodies[0].mesh.points.iter().any(|p| p[1] > y0 + tol) {
        return Err(opt_err(
            OPT,
            format!(
                "body 1 must lie below its contact curve '{}' (outward normal (0, 1))",
                spec.contact[0]
            ),
        ));
    }
    // Pair by x: nearest node of the other side, both ways.
    let nearest = |x: f64, side: &[usize], pts: &[[f64; 2]]| {
        side.iter()
            .map(|&n| (n, (pts[n][0] - x).abs()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("non-empty side")
    };
    for (side, pts, other, opts, k) in [(s1, p1, s2, p2, 1), (s2, p2, s1, p1, 2)] {
        for &n in side.iter() {
            let (m, d) = nearest(pts[n][0], other, opts);
            if d > tol {
                return Err(opt_err(
                    OPT,
                    format!(
                        "the node ({:.6e}, {:.6e}) of body {k}'s contact curve has no partner on the other body's curve; the nearest, ({:.6e}, {:.6e}), is {d:.3e} away in x",
                        pts[n][0], pts[n][1], opts[m][0], opts[m][1]
                    ),
                ));
            }
        }
    }
    if s1.len() != s2.len() {
        return Err(opt_err(
            OPT,
            format!(
                "the contact curves have {} and {} nodes; every node needs exactly one partner",
                s1.len(),
                s2.len()
            ),
        ));
    }
    let mut gap = Vec::with_capacity(s1.len());
    for (&a, &b) in s1.iter().zip(s2) {
        let g = p2[b][1] - p1[a][1];
        if g < -tol {
            return Err(opt_err(
                OPT,
                format!(
                    "the bodies overlap at x = {:.6e}: body 2's node is {:.3e} below body 1's (initial gap must be >= 0)",
                    p1[a][0], -g
                ),
            ));
        }
        gap.push(g.max(0.0));
    }
    Ok(([s1.clone(), s2.clone()], gap))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_orders_a_curve_from_its_start() {
        let edges = [[5, 2], [1, 5], [2, 7]];
        assert_eq!(chain(&edges, "c", "-o").unwrap(), vec![1, 5, 2, 7]);
        assert!(chain(&[[1, 2], [2, 1]], "c", "-o").is_err(), "closed");
        assert!(chain(&[[1, 2], [3, 4]], "c", "-o").is_err(), "two pieces");
    }
}
