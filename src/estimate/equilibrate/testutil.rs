//! Unit-test helpers of the equilibration tests, shared with `overlap.rs` (`fe_solve`,
//! `block_rect`, `STEEL`, re-exported as `equilibrate::tests::…`).

use super::sizes::NONE;
use super::*;
use crate::fem::{self, Material, Mesh};
use crate::qp::dense::SymMatrix;

pub(crate) const STEEL: Material = Material {
    young: 210e9,
    poisson: 0.27,
};

pub(super) const CHOICES: [Recovery; 4] = [
    Recovery::Eet,
    Recovery::star(),
    Recovery::PatchClassic { sweeps: 3 },
    Recovery::Patch {
        sweeps: 3,
        warm_sweeps: 1,
    },
];

pub(super) fn known(a: f64, b: f64) -> EdgeComponent {
    EdgeComponent::Known([a, b])
}

fn left_edges(mesh: &Mesh) -> Vec<[usize; 2]> {
    (0..mesh.ny)
        .map(|j| [mesh.node(0, j), mesh.node(0, j + 1)])
        .collect()
}

/// FE solution with u = 0 on the constrained dofs and the consistent loads of the Known
/// edge components: dense Cholesky (`dense::SymMatrix`) up to 600 unknowns, a banded
/// Cholesky beyond (the reference meshes).
pub(crate) fn fe_solve(mesh: &Mesh, boundary: &Boundary) -> Vec<f64> {
    let k = fem::assemble_stiffness(mesh, &STEEL);
    let ndof = mesh.num_dofs();
    let mut f = vec![0.0; ndof];
    for be in &boundary.edges {
        let [a, b] = be.nodes;
        let (mut ta, mut tb) = ([0.0; 2], [0.0; 2]);
        for c in 0..2 {
            if let EdgeComponent::Known(v) = be.comps[c] {
                ta[c] = v[0];
                tb[c] = v[1];
            }
        }
        let (fa, fb) = fem::edge_load(mesh.points.get(a), mesh.points.get(b), ta, tb);
        for c in 0..2 {
            f[2 * a + c] += fa[c];
            f[2 * b + c] += fb[c];
        }
    }
    let free: Vec<usize> = (0..ndof).filter(|&d| !boundary.constrained[d]).collect();
    let mut index = vec![NONE; ndof];
    for (i, &d) in free.iter().enumerate() {
        index[d] = i;
    }
    let n = free.len();
    let mut x: Vec<f64> = free.iter().map(|&d| f[d]).collect();
    let entries = |d: usize| {
        let (s, t) = (k.row_ptr[d] as usize, k.row_ptr[d + 1] as usize);
        (s..t).map(|q| (k.cols[q] as usize, k.vals[q]))
    };
    if n <= 600 {
        let mut a = SymMatrix::new(n);
        for (i, &d) in free.iter().enumerate() {
            for (c, v) in entries(d) {
                if index[c] != NONE {
                    a.set(i, index[c], v);
                }
            }
        }
        a.cholesky().unwrap().solve_in_place(&mut x);
    } else {
        let mut bw = 0;
        for (i, &d) in free.iter().enumerate() {
            for (c, _) in entries(d) {
                if index[c] != NONE && index[c] <= i {
                    bw = bw.max(i - index[c]);
                }
            }
        }
        let w = bw + 1;
        // band[i w + (j + bw − i)] = a_ij for i − bw ≤ j ≤ i.
        let mut band = vec![0.0; n * w];
        for (i, &d) in free.iter().enumerate() {
            for (c, v) in entries(d) {
                let j = index[c];
                if j != NONE && j <= i {
                    band[i * w + j + bw - i] = v;
                }
            }
        }
        for i in 0..n {
            for j in i.saturating_sub(bw)..=i {
                let k0 = i.saturating_sub(bw);
                let mut s = band[i * w + j + bw - i];
                for kk in k0..j {
                    s -= band[i * w + kk + bw - i] * band[j * w + kk + bw - j];
                }
                if j < i {
                    band[i * w + j + bw - i] = s / band[j * w + bw];
                } else {
                    assert!(s > 0.0, "banded Cholesky: pivot {i} is {s}");
                    band[i * w + bw] = s.sqrt();
                }
            }
        }
        for i in 0..n {
            let mut s = x[i];
            for kk in i.saturating_sub(bw)..i {
                s -= band[i * w + kk + bw - i] * x[kk];
            }
            x[i] = s / band[i * w + bw];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for kk in i + 1..(i + bw + 1).min(n) {
                s -= band[kk * w + i + bw - kk] * x[kk];
            }
            x[i] = s / band[i * w + bw];
        }
    }
    let mut u = vec![0.0; ndof];
    for (i, &d) in free.iter().enumerate() {
        u[d] = x[i];
    }
    u
}

/// Unit square in a uniform stress state: exact tractions on all four sides, three
/// pinned dofs (point constraints with zero reaction).
pub(super) fn patch(n: usize, s: [f64; 3]) -> (Mesh, Boundary) {
    let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], n, n);
    let t = |nx: f64, ny: f64| [s[0] * nx + s[2] * ny, s[2] * nx + s[1] * ny];
    let mut edges = Vec::new();
    let mut side = |list: Vec<[usize; 2]>, tr: [f64; 2]| {
        for nodes in list {
            edges.push(BoundaryEdge {
                nodes,
                comps: [known(tr[0], tr[0]), known(tr[1], tr[1])],
            });
        }
    };
    let pairs = |v: Vec<usize>| v.windows(2).map(|w| [w[0], w[1]]).collect::<Vec<_>>();
    side(pairs(mesh.bottom_nodes()), t(0.0, -1.0));
    side(pairs(mesh.top_nodes()), t(0.0, 1.0));
    side(mesh.right_edges(), t(1.0, 0.0));
    side(left_edges(&mesh), t(-1.0, 0.0));
    let mut constrained = vec![false; mesh.num_dofs()];
    constrained[2 * mesh.node(0, 0)] = true;
    constrained[2 * mesh.node(0, 0) + 1] = true;
    constrained[2 * mesh.node(n, 0) + 1] = true;
    (mesh, Boundary { edges, constrained })
}

/// The benchmark-like block: bottom clamped, linear normal traction on top, linear shear
/// on the right, left free.
pub(super) fn block(n: usize) -> (Mesh, Boundary) {
    block_rect(n, n)
}

/// [`block`] on an nx × ny mesh of the unit square.
pub(crate) fn block_rect(nx: usize, ny: usize) -> (Mesh, Boundary) {
    let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], nx, ny);
    let mut constrained = vec![false; mesh.num_dofs()];
    let mut edges = Vec::new();
    let bottom = mesh.bottom_nodes();
    for &b in &bottom {
        constrained[2 * b] = true;
        constrained[2 * b + 1] = true;
    }
    for w in bottom.windows(2) {
        edges.push(BoundaryEdge {
            nodes: [w[0], w[1]],
            comps: [EdgeComponent::Free, EdgeComponent::Free],
        });
    }
    let p = |x: f64| -1e7 * (1.0 + x);
    for w in mesh.top_nodes().windows(2) {
        let (xa, xb) = (mesh.points.get(w[0])[0], mesh.points.get(w[1])[0]);
        edges.push(BoundaryEdge {
            nodes: [w[1], w[0]], // reversed on purpose: values follow `nodes`
            comps: [known(0.0, 0.0), known(p(xb), p(xa))],
        });
    }
    let tau = |y: f64| 4e6 * (1.0 + 2.0 * y);
    for [a, b] in mesh.right_edges() {
        let (ya, yb) = (mesh.points.get(a)[1], mesh.points.get(b)[1]);
        edges.push(BoundaryEdge {
            nodes: [a, b],
            comps: [known(0.0, 0.0), known(tau(ya), tau(yb))],
        });
    }
    (mesh, Boundary { edges, constrained })
}

pub(super) fn assert_admissible(r: &Residuals, tol: f64) {
    assert!(r.divergence < tol, "{r:?}");
    assert!(r.internal_jump < tol, "{r:?}");
    assert!(r.element_jump < tol, "{r:?}");
    assert!(r.boundary < tol, "{r:?}");
    assert!(r.point_reaction < tol, "{r:?}");
}

/// `block(n)` with every interior node moved by up to 0.05 (random, `seed`): no two
/// triangles, and no two vertex patches, alike (the boundary stays straight).
pub(super) fn distorted_block(n: usize, seed: u64) -> (Mesh, Boundary) {
    let (mut mesh, bd) = block(n);
    let mut rng = crate::testutil::Lcg(seed);
    for j in 1..n {
        for i in 1..n {
            let k = mesh.node(i, j);
            let p = mesh.points.get(k);
            mesh.points
                .set(k, [p[0] + 0.05 * rng.next(), p[1] + 0.05 * rng.next()]);
        }
    }
    (mesh, bd)
}
