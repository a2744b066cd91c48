//! The checks of a problem meshed in Gmsh before anything is solved: every triangle in one
//! body, bodies that do not overlap, and each body held against every rigid motion, by its
//! prescribed displacements or, pressed onto the other, by the contact ([`super::meshed`]).

use super::curves::{opt_err, MeshedError};
use super::Support;
use crate::fem::checks::{self, Overlap};
use crate::fem::gmsh::{GmshBody, GmshError, GmshMesh};
use crate::fem::mesh::Points;

fn invalid(gmsh: &GmshMesh, reason: String) -> MeshedError {
    MeshedError::Mesh(GmshError::Invalid {
        path: gmsh.path.clone(),
        reason,
    })
}

/// No element may be in both bodies (a surface in both physical groups). (Two elements on the
/// same three nodes, one in each body, are found by [`overlap`].)
pub(super) fn shared_triangles(gmsh: &GmshMesh, bodies: [&str; 2]) -> Result<(), MeshedError> {
    let tags = bodies.map(|n| gmsh.tag(2, n));
    let [Some(t1), Some(t2)] = tags else {
        return Ok(()); // (cutting the bodies out names the missing surface)
    };
    match gmsh
        .triangles
        .iter()
        .position(|(_, phys)| phys.contains(&t1) && phys.contains(&t2))
    {
        Some(i) => Err(invalid(
            gmsh,
            format!(
                "{} is in both body1 and body2 (its surface is in both physical groups?)",
                gmsh.describe(i)
            ),
        )),
        None => Ok(()),
    }
}

/// The bodies may touch but not overlap ([`checks::overlap`]).
pub(super) fn overlap(gmsh: &GmshMesh, bodies: &[GmshBody]) -> Result<(), MeshedError> {
    let Some(o) = checks::overlap([&bodies[0].mesh, &bodies[1].mesh]) else {
        return Ok(());
    };
    let pt = |p: [f64; 2]| format!("({:.6e}, {:.6e})", p[0], p[1]);
    let reason = match o {
        Overlap::Node {
            body,
            node,
            element,
        } => format!(
            "the bodies overlap: body {}'s node {} is inside body {}'s {}",
            body + 1,
            pt(bodies[body].mesh.points.get(node)),
            2 - body,
            gmsh.describe(bodies[1 - body].elements[element])
        ),
        Overlap::Triangle {
            body,
            inner,
            element,
        } if same_points(
            bodies[body].mesh.triangle_points(inner),
            bodies[1 - body].mesh.triangle_points(element),
        ) =>
        {
            let (e1, e2) = match body {
                0 => (inner, element),
                _ => (element, inner),
            };
            format!(
                "a triangle is in both body1 and body2: {} of body1 and element {} of body2",
                gmsh.describe(bodies[0].elements[e1]),
                gmsh.element_tag(bodies[1].elements[e2])
            )
        }
        Overlap::Triangle {
            body,
            inner,
            element,
        } => format!(
            "the bodies overlap: body {}'s element {} is inside body {}'s {}",
            body + 1,
            gmsh.element_tag(bodies[body].elements[inner]),
            2 - body,
            gmsh.describe(bodies[1 - body].elements[element])
        ),
        Overlap::Edges { edges: [e, f] } => {
            let (p, q) = (&bodies[0].mesh.points, &bodies[1].mesh.points);
            format!(
                "the bodies overlap: body 1's boundary edge {}–{} crosses body 2's {}–{}",
                pt(p.get(e[0])),
                pt(p.get(e[1])),
                pt(q.get(f[0])),
                pt(q.get(f[1]))
            )
        }
    };
    Err(invalid(gmsh, reason))
}

/// Whether two triangles have the same three vertices (in any order).
fn same_points(a: [[f64; 2]; 3], b: [[f64; 2]; 3]) -> bool {
    a.iter().all(|p| b.contains(p))
}

/// Every piece of a body ([`checks::pieces`]) must be held: a body in one piece by its
/// prescribed displacements ([`Support::Conditions`]) or, where they leave a rigid motion free
/// that Γc's normal directions fix (`contact`: its Γc nodes and the contact directions), by
/// the contact ([`Support::Contact`]); each piece of a body in several pieces on its own nodes.
pub(super) fn check_pieces(
    gmsh: &GmshMesh,
    body: &GmshBody,
    dirichlet: &[(usize, f64)],
    contact: (&[usize], &[[f64; 2]]),
    alpha: usize,
) -> Result<Support, MeshedError> {
    let mesh = &body.mesh;
    let (count, piece) = checks::pieces(mesh);
    if count == 1 {
        let prescribed = dirichlet_rows(&mesh.points, dirichlet);
        if rigid_motions_fixed(prescribed.clone()) {
            return Ok(Support::Conditions);
        }
        let (nodes, normals) = contact;
        let held = nodes
            .iter()
            .zip(normals)
            .map(|(&a, &n)| (mesh.points.get(a), n));
        if rigid_motions_fixed(prescribed.chain(held)) {
            return Ok(Support::Contact);
        }
        return Err(opt_err(
            "-nndd_bc_*",
            format!(
                "body {alpha} can move as a rigid body, even pressed onto the other body along its contact curve: prescribe displacements (-nndd_bc_NAME_ux, -nndd_bc_NAME_uy) that fix, with the contact, both translations and the rotation"
            ),
        ));
    }
    // Each piece's nodes, and the prescribed dofs on them.
    let mut nodes: Vec<Vec<usize>> = vec![Vec::new(); count];
    let mut seen = vec![usize::MAX; mesh.points.len()];
    for (e, t) in mesh.triangles.iter().enumerate() {
        for a in t {
            if seen[a] != piece[e] {
                seen[a] = piece[e];
                nodes[piece[e]].push(a);
            }
        }
    }
    let mut fixed: Vec<Vec<(usize, f64)>> = vec![Vec::new(); mesh.points.len()];
    for &d in dirichlet {
        fixed[d.0 / 2].push(d);
    }
    for (k, list) in nodes.iter().enumerate() {
        let mut local = Vec::new();
        let mut pts = Points::default();
        for (i, &a) in list.iter().enumerate() {
            pts.push(mesh.points.get(a));
            local.extend(fixed[a].iter().map(|&(d, v)| (2 * i + d % 2, v)));
        }
        if !rigid_motions_fixed(dirichlet_rows(&pts, &local)) {
            let e = piece
                .iter()
                .position(|&p| p == k)
                .expect("a piece has a triangle");
            let t = mesh.triangle_points(e);
            let c = [
                (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                (t[0][1] + t[1][1] + t[2][1]) / 3.0,
            ];
            let what = if local.is_empty() {
                "has no Dirichlet condition"
            } else {
                "has Dirichlet conditions that do not fix both translations and the rotation"
            };
            return Err(invalid(
                gmsh,
                format!(
                    "body {alpha} is in {count} pieces and its piece around ({:.6e}, {:.6e}) ({} triangles, element {} among them) {what}: it can move as a rigid body; prescribe displacements on a curve of it or join it to the body",
                    c[0],
                    c[1],
                    piece.iter().filter(|&&p| p == k).count(),
                    gmsh.element_tag(body.elements[e])
                ),
            ));
        }
    }
    Ok(Support::Conditions)
}

/// The prescribed dofs (`2 node + component`, of `pts`) as (point, direction) rows.
fn dirichlet_rows<'a>(
    pts: &'a Points,
    dirichlet: &'a [(usize, f64)],
) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + Clone + 'a {
    dirichlet.iter().map(|&(d, _)| {
        let dir = if d % 2 == 0 { [1.0, 0.0] } else { [0.0, 1.0] };
        (pts.get(d / 2), dir)
    })
}

/// Whether displacements held along `rows` (a point and a unit direction each: a prescribed
/// component, or a Γc node's contact direction) remove the three rigid motions (two
/// translations and the rotation): the rigid modes' components along them have rank 3.
fn rigid_motions_fixed(rows: impl Iterator<Item = ([f64; 2], [f64; 2])> + Clone) -> bool {
    let n = rows.clone().count().max(1) as f64;
    let c = rows
        .clone()
        .fold([0.0; 2], |a, (p, _)| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (p, _) in rows.clone() {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let scale = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f64::MIN_POSITIVE);
    // Gram matrix of the modes (1,0), (0,1), (−y, x) along the rows.
    let mut g = [[0.0f64; 3]; 3];
    for (p, d) in rows {
        let r = [(p[0] - c[0]) / scale, (p[1] - c[1]) / scale];
        let row = [d[0], d[1], -r[1] * d[0] + r[0] * d[1]];
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
    !(det.is_nan() || det <= 1e-10 * trace.powi(3))
}
