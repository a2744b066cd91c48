//! A problem the user meshed in Gmsh (`-nndd_mesh FILE.msh`): the physical surfaces `body1`
//! (Ω¹, below) and `body2` (Ω², above), boundary conditions on named physical curves, and the
//! contact interface Γc from two named curves, one per body, whose nodes are paired along the
//! normal of body 1's side where they overlap (curves meshed on their own are made to match
//! first, [`super::conform`]); each pair's initial gap g₀ ≥ 0 comes from the geometry.
//!
//! Both sides may be curved. The contact direction of a pair is body 1's outward normal at its
//! node (the mean of its two segments' normals); body 2's partner must lie on that normal line,
//! and g₀ is its distance along it. Where body 1's side is horizontal with body 1 below (as in
//! `docs/method.md`) the normal is (0, 1) and nothing is rotated; elsewhere the pair's nodes
//! get rotated nodal frames ([`super::Frames`]). On a curved side the Γc traction that carries
//! the nodal forces T_k n_k is normal only up to O(h²κ) (docs/method.md §5).

use std::collections::{BTreeMap, BTreeSet};
use std::rc::Rc;

pub use super::curves::{chain, MeshedError};
use super::curves::{
    closed_loop, facing, node_normals, opt_err, oriented_side, unit_or_up, Pairing,
};
use super::sound::{check_pieces, overlap, shared_triangles};
use super::{BodyProblem, ContactDiscretisation, GcTrace, NeumannEdge, Support};
use crate::fem::checks;
use crate::fem::gmsh::{GmshBody, GmshError};
use crate::fem::order::ElementOrder;
use crate::fem::Material;

pub use super::parsed::BODY_NAMES;

/// Conditions on one named physical curve (plain data, from the `-nndd_bc_NAME_…` options).
#[derive(Clone, Debug, Default, serde::Serialize)]
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
    /// The parsed file (read once, on world rank 0, when the options are read; sent to the
    /// other ranks where they build the bodies; its mesh released once the bodies are built
    /// where no later phase reads it).
    pub gmsh: super::parsed::ParsedFile,
    pub conditions: Vec<CurveCondition>,
    /// Γc: body 1's curve and body 2's curve.
    pub contact: [String; 2],
    /// How they meet (`-nndd_contact_discretisation`, resolved).
    pub discretisation: ContactDiscretisation,
    /// What the user asked for.
    pub choice: super::DiscretisationChoice,
    /// What mortar's initial gap is measured to (`-nndd_mortar_gap`).
    pub gap: super::mortar::GapGeometry,
    /// A `.geo` file's parameters (`-nndd_geo_set`; empty for a mesh file).
    pub geo_set: Vec<(String, f64)>,
    /// `Some(r)`: the mesh is the user's refined r times (the reference solution): its Γc
    /// keeps the user's pairing, each coarse pair's children paired in order, and the contact
    /// direction at a new node is the user's mesh's normal field there (docs/method.md §5).
    pub nested: Option<usize>,
    /// The order of each body's triangles and nodes (`-nndd_mesh_order`).
    pub order: ElementOrder,
    /// What [`super::conform`] did to make the contact curves match (nothing on matching
    /// meshes).
    pub matched: Rc<super::matched::Matched>,
}

impl MeshSpec {
    /// The first of the contact curves that closes on itself (a whole circle), if any.
    pub fn closed_contact(&self) -> Result<Option<&str>, MeshedError> {
        let gmsh = self.gmsh.mesh()?;
        let closed = self
            .contact
            .iter()
            .find(|name| super::curves::is_closed(gmsh, name));
        Ok(closed.map(String::as_str))
    }
}

/// A degenerate triangle at a node that the matching of the contact curves inserted or moved
/// ([`super::conform`]) is nndd's doing, not the user's mesh's: say so, and what to change.
fn made_by_matching(spec: &MeshSpec, e: GmshError) -> MeshedError {
    if let GmshError::Degenerate { triangle, .. } = &e {
        let (corners, quality) = (&triangle.corners, triangle.quality);
        if let Some(p) = corners
            .iter()
            .find(|p| spec.matched.made.contains(&super::matched::point_key(**p)))
        {
            return opt_err(
                "-nndd_contact",
                format!(
                    "the contact curves '{}' and '{}' are meshed on their own, and making them match put a node at ({:.6e}, {:.6e}) so near another that its triangle ({:.6e}, {:.6e}), ({:.6e}, {:.6e}), ({:.6e}, {:.6e}) is degenerate (relative area {quality:.3e}, below {:e}); give the two curves the same points near there, or sizes that differ by more",
                    spec.contact[0],
                    spec.contact[1],
                    p[0],
                    p[1],
                    corners[0][0],
                    corners[0][1],
                    corners[1][0],
                    corners[1][1],
                    corners[2][0],
                    corners[2][1],
                    checks::MIN_QUALITY
                ),
            );
        }
    }
    e.into()
}

/// Both bodies of a meshed problem.
pub fn build(spec: &MeshSpec, materials: [Material; 2]) -> Result<[BodyProblem; 2], MeshedError> {
    let gmsh = spec.gmsh.mesh()?;
    shared_triangles(gmsh, BODY_NAMES)?;
    let bodies: Vec<GmshBody> = BODY_NAMES
        .iter()
        .map(|n| {
            gmsh.body(n, spec.order)
                .map_err(|e| made_by_matching(spec, e))
        })
        .collect::<Result<_, _>>()?;
    overlap(gmsh, &bodies)?;
    // Every curve named by an option must lie on a body.
    for c in &spec.conditions {
        if !bodies.iter().any(|b| b.curves.contains_key(&c.curve)) {
            return Err(opt_err(
                &format!("-nndd_bc_{}_*", c.curve),
                format!(
                    "no physical curve '{}' on body1 or body2 (physical curves: {})",
                    c.curve,
                    gmsh.group_names(1)
                ),
            ));
        }
    }
    // (under mortar, the body whose trace is the coupling's: the mortar side)
    let (pairing, coupling) = match spec.discretisation {
        ContactDiscretisation::NodeToNode => (pair_interface(spec, &bodies)?, None),
        ContactDiscretisation::Mortar => {
            let (p, c, side) = super::coupled::mortar_interface(&spec.contact, &bodies, spec.gap)?;
            (p, Some((Rc::new(c), 1 - side)))
        }
    };
    let body = |k: usize| -> Result<BodyProblem, MeshedError> {
        let alpha = k + 1;
        let (dirichlet, neumann) = conditions(spec, &bodies[k], alpha)?;
        // (under mortar, body 2 meets each pair mostly at its row's heaviest node)
        let contact = (&pairing.nearest[k][..], &pairing.normals[..]);
        let support = check_pieces(gmsh, &bodies[k], &dirichlet, contact, alpha)?;
        let trace = match &coupling {
            Some((c, mortar)) if *mortar == k => GcTrace::Mortar(c.clone()),
            _ => GcTrace::Nodes,
        };
        // A rotated frame's dofs are not x and y: no prescribed component there.
        let framed = if trace == GcTrace::Nodes {
            &pairing.sides[k][..]
        } else {
            &[]
        };
        for (&node, n) in framed.iter().zip(&pairing.normals) {
            if *n != super::UP && dirichlet.iter().any(|&(d, _)| d / 2 == node) {
                let p = bodies[k].mesh.points.get(node);
                // The option that prescribes it.
                let option = spec
                    .conditions
                    .iter()
                    .find_map(|c| {
                        let edges = bodies[k].curves.get(&c.curve)?;
                        let on = edges.iter().any(|e| e.contains(&node));
                        let comp = c.u.iter().position(|u| u.is_some())?;
                        on.then(|| format!("-nndd_bc_{}_{}", c.curve, ["ux", "uy"][comp]))
                    })
                    .unwrap_or_else(|| "-nndd_bc_*".into());
                return Err(opt_err(
                    &option,
                    format!(
                        "a displacement is prescribed at the contact node ({:.6e}, {:.6e}) of body {alpha}, where the contact normal ({:.4}, {:.4}) is not (0, 1); prescribe none on Γc there",
                        p[0], p[1], n[0], n[1]
                    ),
                ));
            }
        }
        Ok(BodyProblem {
            alpha,
            mesh: super::BodyMesh::Whole(bodies[k].mesh.clone()),
            outline: Default::default(),
            fingerprint: Default::default(),
            material: materials[k],
            dirichlet,
            neumann,
            contact_nodes: pairing.sides[k].clone(),
            trace,
            contact_candidates: pairing.candidates[k].clone(),
            candidate_normals: pairing.candidate_normals[k].clone(),
            gap: pairing.gap.clone(),
            contact_normals: pairing.normals.clone(),
            contact_lengths: pairing.lengths.clone(),
            support,
        })
    };
    let bodies = [body(0)?, body(1)?];
    if bodies.iter().all(|b| b.support == Support::Contact) {
        return Err(opt_err(
            "-nndd_bc_*",
            "neither body is held by its prescribed displacements: both can move together as a rigid body; prescribe displacements on one body that fix both translations and the rotation".into(),
        ));
    }
    Ok(bodies)
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
        on_boundary(body, alpha, edges, &c.curve, &option("*"))?;
        let nodes = condition_chain(edges, c, &option("traction_end"))?;
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
                                body.mesh.points.get(n)[0], body.mesh.points.get(n)[1]
                            ),
                        ));
                    }
                }
                fixed.insert(d, (v, name.clone()));
            }
        }
        if let Some([t0, t1]) = c.traction {
            // Linear in the arc length from the curve's first point to its last.
            let pts: Vec<[f64; 2]> = nodes.iter().map(|&n| body.mesh.points.get(n)).collect();
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

/// A condition acts on the body's boundary: a curve with an edge inside body `alpha` (an
/// internal line of the .geo, or a curve of the other body's that touches this one) is
/// refused, naming the first such edge (a load there would be taken as a point load inside).
fn on_boundary(
    body: &GmshBody,
    alpha: usize,
    edges: &[[usize; 2]],
    curve: &str,
    option: &str,
) -> Result<(), MeshedError> {
    let boundary: BTreeSet<[usize; 2]> = body
        .mesh
        .boundary_edges()
        .into_iter()
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    match edges
        .iter()
        .find(|&&[a, b]| !boundary.contains(&[a.min(b), a.max(b)]))
    {
        None => Ok(()),
        Some(&[a, b]) => {
            let (pa, pb) = (body.mesh.points.get(a), body.mesh.points.get(b));
            Err(opt_err(
                option,
                format!(
                    "the curve '{curve}' is not on body {alpha}'s boundary: its edge ({:.6e}, {:.6e})–({:.6e}, {:.6e}) lies inside the body (a condition acts on the boundary only)",
                    pa[0], pa[1], pb[0], pb[1]
                ),
            ))
        }
    }
}

/// The nodes of a condition's curve in order: [`chain`] for an open curve; for a closed one (a
/// bore) the loop from its lowest node back to it, which carries displacements and a constant
/// traction, but not a linear one (it has no first and last point).
fn condition_chain(
    edges: &[[usize; 2]],
    c: &CurveCondition,
    option_end: &str,
) -> Result<Vec<usize>, MeshedError> {
    let closed = closed_loop(edges);
    let Some(nodes) = closed else {
        return chain(edges, &c.curve, &format!("-nndd_bc_{}_*", c.curve));
    };
    if let Some([t0, t1]) = c.traction {
        if t0 != t1 {
            return Err(opt_err(
                option_end,
                format!(
                    "the curve '{}' is closed: a traction linear from its first point to its last needs an open curve; give a constant traction (no _traction_end)",
                    c.curve
                ),
            ));
        }
    }
    Ok(nodes)
}

/// The contact directions along body 1's curve `chain` of a mesh refined r times
/// (`spec.nested`): at the user's nodes (every r-th, from the first) the user's mesh's, i.e.
/// `fine`'s there (the mean of the two coarse segments' normals, or an inserted node's own);
/// at a new node a fraction t along a coarse segment, the normalised interpolation
/// (1 − t) n_k + t n_{k+1} of its ends' — the normal field of the problem nndd solves
/// (docs/method.md §5). With the fine segments' own normals instead, the reference would
/// solve a polygon whose corners lock the sliding the coarse problem allows.
fn refined_normals(
    chain: &[usize],
    r: usize,
    fine: &[[f64; 2]],
) -> Result<Vec<[f64; 2]>, MeshedError> {
    if r == 0 || !(chain.len() - 1).is_multiple_of(r) {
        return Err(opt_err(
            "-nndd_reference_factor",
            format!(
                "the refined contact curve has {} segments, not a multiple of {r}",
                chain.len() - 1
            ),
        ));
    }
    Ok((0..chain.len())
        .map(|i| {
            let (c, j) = (i / r, i % r);
            if j == 0 {
                return fine[i];
            }
            let (a, b) = (fine[c * r], fine[(c + 1) * r]);
            let t = j as f64 / r as f64;
            unit_or_up([(1.0 - t) * a[0] + t * b[0], (1.0 - t) * a[1] + t * b[1]])
        })
        .collect())
}

/// Pair the contact curves: every node of body 1's side with the node of body 2's side on
/// its normal line (within 1e−8 of the curve's length), the nearer one if several, or with
/// the node next to it that the matching left as it is (a mortar run's matched meshes,
/// `conform::NEAR`). After
/// [`super::conform`] the curves match wherever they overlap: Γc is the run of body 1's nodes
/// that have a partner, which must be one piece, and their partners must be the nodes of one
/// piece of body 2's curve in order; the nodes beyond stay candidates only. g₀ is the distance
/// along the normal (≥ 0). A refined mesh (`spec.nested`) keeps the pairing of the mesh it
/// refines: the pieces between the end pairs are paired in their order, as the coarse pairs'
/// children.
fn pair_interface(spec: &MeshSpec, bodies: &[GmshBody]) -> Result<Pairing, MeshedError> {
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
        sides.push(chain(edges, name, OPT)?);
    }
    let (chain1, segments) = oriented_side(&bodies[0], sides[0].clone(), &spec.contact[0])?;
    let (p1, p2) = (&bodies[0].mesh.points, &bodies[1].mesh.points);
    // Body 1's contact direction: the mean of its segments' normals, or where a node was
    // inserted to match body 2's, the normal field it was projected along.
    let mut all_normals = node_normals(&segments);
    for (k, &a) in chain1.iter().enumerate() {
        if let Some(n) = spec
            .matched
            .normals
            .get(&super::matched::point_key(p1.get(a)))
        {
            all_normals[k] = *n;
        }
    }
    if let Some(r) = spec.nested {
        all_normals = refined_normals(&chain1, r, &all_normals)?;
    }
    let curve1: Vec<[f64; 2]> = chain1.iter().map(|&n| p1.get(n)).collect();
    let tol = 1e-8
        * super::segment_lengths(&curve1)
            .iter()
            .sum::<f64>()
            .max(f64::MIN_POSITIVE);
    // Offset of body 2's node b from body 1's node k: (along τ, along n).
    let offset = |k: usize, b: usize| {
        let (a, n) = (curve1[k], all_normals[k]);
        let d = [p2.get(b)[0] - a[0], p2.get(b)[1] - a[1]];
        if n == super::UP {
            (d[0], d[1])
        } else {
            (n[1] * d[0] - n[0] * d[1], n[0] * d[0] + n[1] * d[1])
        }
    };
    // Each normal line's partner: the nearest node on the line, or the node next to it that
    // the matching left as it is (`conform::NEAR`).
    let key = super::matched::point_key;
    let near = |k: usize, b: usize| {
        (spec.matched.near.get(&key(curve1[k]))).is_some_and(|&n| n == key(p2.get(b)))
    };
    let partner: Vec<Option<usize>> = (0..chain1.len())
        .map(|k| {
            sides[1]
                .iter()
                .copied()
                .filter(|&b| offset(k, b).0.abs() <= tol || near(k, b))
                .min_by(|&x, &y| offset(k, x).1.abs().total_cmp(&offset(k, y).1.abs()))
        })
        .collect();
    let (Some(first), Some(last)) = (
        partner.iter().position(Option::is_some),
        partner.iter().rposition(Option::is_some),
    ) else {
        return Err(opt_err(
            OPT,
            format!(
                "the curves '{}' and '{}' cannot face each other: no node of either lies on the other's side of the normal lines of body 1's curve",
                spec.contact[0], spec.contact[1]
            ),
        ));
    };
    let at = |b: usize| sides[1].iter().position(|&x| x == b).expect("on the chain");
    let (j0, j1) = (
        at(partner[first].expect("paired")),
        at(partner[last].expect("paired")),
    );
    // Body 2's piece from the partner of body 1's first paired node to that of its last.
    let piece2: Vec<usize> = if j0 <= j1 {
        sides[1][j0..=j1].to_vec()
    } else {
        sides[1][j1..=j0].iter().rev().copied().collect()
    };
    let s1 = chain1[first..=last].to_vec();
    let s2: Vec<usize> = if spec.nested.is_some() {
        piece2
    } else {
        let mut s2 = Vec::with_capacity(s1.len());
        for k in first..=last {
            let Some(b) = partner[k] else {
                // The node of body 2's curve nearest to the line, for the message.
                let (b, (t, _)) = sides[1]
                    .iter()
                    .map(|&b| (b, offset(k, b)))
                    .min_by(|x, y| x.1 .0.abs().total_cmp(&y.1 .0.abs()))
                    .expect("non-empty side");
                let n = all_normals[k];
                return Err(opt_err(
                    OPT,
                    format!(
                        "the node ({:.6e}, {:.6e}) of body 1's contact curve has no partner on its normal ({:.4}, {:.4}); the nearest node of body 2's curve, ({:.6e}, {:.6e}), is {:.3e} off that line",
                        curve1[k][0], curve1[k][1], n[0], n[1], p2.get(b)[0], p2.get(b)[1], t.abs()
                    ),
                ));
            };
            s2.push(b);
        }
        let paired: BTreeSet<usize> = s2.iter().copied().collect();
        if paired.len() != s2.len() {
            return Err(opt_err(
                OPT,
                "two nodes of body 1's contact curve share one partner on body 2's curve".into(),
            ));
        }
        if let Some(&b) = piece2.iter().find(|b| !paired.contains(b)) {
            let (k, (t, _)) = (0..chain1.len())
                .map(|k| (k, offset(k, b)))
                .min_by(|x, y| x.1 .0.abs().total_cmp(&y.1 .0.abs()))
                .expect("non-empty side");
            return Err(opt_err(
                OPT,
                format!(
                    "the node ({:.6e}, {:.6e}) of body 2's contact curve has no partner on body 1's curve; the nearest normal line, of ({:.6e}, {:.6e}), is {:.3e} away",
                    p2.get(b)[0], p2.get(b)[1], curve1[k][0], curve1[k][1], t.abs()
                ),
            ));
        }
        if s2 != piece2 {
            return Err(opt_err(
                OPT,
                "the partners of body 1's contact nodes are not in the order of body 2's curve (the curves cross?)".into(),
            ));
        }
        s2
    };
    if s1.len() != s2.len() {
        return Err(opt_err(
            OPT,
            format!(
                "the paired pieces of the contact curves have {} and {} nodes; every node needs exactly one partner",
                s1.len(),
                s2.len()
            ),
        ));
    }
    let normals = all_normals[first..=last].to_vec();
    let side1 = curve1[first..=last].to_vec();
    let lengths = super::segment_lengths(&side1);
    // (facing first: curves whose normals point the same way are named as such)
    let normals2 = facing(
        &spec.contact,
        &bodies[1],
        &sides[1],
        &side1,
        &s2,
        &normals,
        p2,
    )?;
    let mut gap = Vec::with_capacity(s1.len());
    for (i, &b) in s2.iter().enumerate() {
        let g = offset(first + i, b).1;
        if g < -tol {
            // Bodies that overlap were refused by the mesh checks ([`overlap`]) before: a
            // partner behind body 1's curve is on the far side of it, the curves back to back.
            let n = normals[i];
            return Err(opt_err(
                OPT,
                format!(
                    "the curves '{}' and '{}' face away from each other: body 2's node ({:.6e}, {:.6e}) is {:.3e} behind body 1's node ({:.6e}, {:.6e}) along its outward normal ({:.4}, {:.4}); name the curves that face each other across the gap (the initial gap must be >= 0)",
                    spec.contact[0], spec.contact[1], p2.get(b)[0], p2.get(b)[1], -g, side1[i][0], side1[i][1], n[0], n[1]
                ),
            ));
        }
        gap.push(g.max(0.0));
    }
    Ok(Pairing {
        nearest: [s1.clone(), s2.clone()],
        sides: [s1, s2],
        candidates: [chain1, sides[1].clone()],
        candidate_normals: [all_normals.clone(), normals2],
        gap,
        normals,
        lengths,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A degenerate triangle at a node the matching placed is reported as the matching's, on
    /// -nndd_contact, with its corners; one at the user's nodes stays the mesh's error.
    #[test]
    fn a_degenerate_triangle_at_a_matched_node_is_the_matchings() {
        let corners = [[0.0, 0.0], [1.0, 0.0], [0.5, 1e-9]];
        let mut matched = super::super::matched::Matched::default();
        matched
            .made
            .insert(super::super::matched::point_key(corners[2]));
        let spec = MeshSpec {
            gmsh: super::super::parsed::ParsedFile::new(Default::default()),
            conditions: Vec::new(),
            contact: ["top1".into(), "bottom2".into()],
            discretisation: ContactDiscretisation::NodeToNode,
            choice: super::super::DiscretisationChoice::Auto,
            gap: Default::default(),
            geo_set: Vec::new(),
            nested: None,
            order: Default::default(),
            matched: Rc::new(matched),
        };
        let degenerate = |corners: [[f64; 2]; 3]| GmshError::Degenerate {
            path: "m.msh".into(),
            triangle: Box::new(crate::fem::gmsh::DegenerateTriangle {
                body: "body2".into(),
                element: "element 7".into(),
                corners,
                quality: 2e-9,
            }),
        };
        let e = made_by_matching(&spec, degenerate(corners)).to_string();
        assert!(
            e.starts_with("-nndd_contact: the contact curves 'top1' and 'bottom2' are meshed on their own, and making them match put a node at (5.000000e-1, 1.000000e-9)"),
            "{e}"
        );
        assert!(e.contains("relative area 2.000e-9"), "{e}");
        let mine = [[0.0, 0.0], [1.0, 0.0], [0.5, 2e-9]];
        let e = made_by_matching(&spec, degenerate(mine)).to_string();
        assert!(
            e.contains("'body2' has a degenerate triangle, element 7"),
            "{e}"
        );
    }

    #[test]
    fn chain_orders_a_curve_from_its_start() {
        let edges = [[5, 2], [1, 5], [2, 7]];
        assert_eq!(chain(&edges, "c", "-o").unwrap(), vec![1, 5, 2, 7]);
        assert!(chain(&[[1, 2], [2, 1]], "c", "-o").is_err(), "closed");
        assert!(chain(&[[1, 2], [3, 4]], "c", "-o").is_err(), "two pieces");
    }

    #[test]
    fn a_closed_curve_is_one_loop_from_its_lowest_node() {
        let square = [[4, 2], [2, 7], [7, 9], [9, 4]];
        assert_eq!(closed_loop(&square), Some(vec![2, 7, 9, 4, 2]));
        // Open, two loops, a branch: not one loop.
        assert_eq!(closed_loop(&[[1, 2], [2, 3]]), None);
        assert_eq!(
            closed_loop(&[[1, 2], [2, 3], [3, 1], [4, 5], [5, 6], [6, 4]]),
            None
        );
        assert_eq!(closed_loop(&[[1, 2], [1, 3], [3, 1]]), None);
    }
}
