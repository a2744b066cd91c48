//! EET edge tractions (Ladevèze & Leguillon): boundary codes of the edges, the edge
//! moments ↔ linear tractions, the element traction vectors, and the operators (pseudo-inverse
//! and null space) of the star problems and one star's system, solved ([`StarSystem`]).

use super::fast_map::FastMap;

use super::boundary::{Boundary, EdgeComponent};
use super::error::EquilibrationError;
use super::sizes::{NONE, NT};
use super::topology::Topology;
use crate::fem::mesh::Mesh;

/// Per edge and component: interior, prescribed (values at the edge's sorted end nodes) or
/// free.
#[derive(Clone, Copy, Debug)]
pub(super) enum Bc {
    Interior,
    Known([f64; 2]),
    Free,
}

/// The conditions of every edge: interior edges (most of them) by a 4-byte index only, the
/// boundary edges' [`Bc`] pairs stored (48 bytes each): `bc[g][k]`.
pub(super) struct EdgeConditions {
    /// Per edge: its position in `boundary`, or `u32::MAX` (interior).
    slot: Vec<u32>,
    boundary: Vec<[Bc; 2]>,
}

const INTERIOR: [Bc; 2] = [Bc::Interior; 2];

impl std::ops::Index<usize> for EdgeConditions {
    type Output = [Bc; 2];
    fn index(&self, g: usize) -> &[Bc; 2] {
        match self.slot[g] {
            u32::MAX => &INTERIOR,
            i => &self.boundary[i as usize],
        }
    }
}

impl std::ops::IndexMut<usize> for EdgeConditions {
    /// Boundary edges only (interior ones have no storage).
    fn index_mut(&mut self, g: usize) -> &mut [Bc; 2] {
        &mut self.boundary[self.slot[g] as usize]
    }
}

impl EdgeConditions {
    /// Number of edges.
    pub(super) fn len(&self) -> usize {
        self.slot.len()
    }

    /// Every edge's pair, in edge order.
    pub(super) fn iter(&self) -> impl Iterator<Item = &[Bc; 2]> + '_ {
        (0..self.len()).map(|g| &self[g])
    }
}

pub(super) fn edge_conditions(
    topo: &Topology,
    boundary: &Boundary,
) -> Result<EdgeConditions, EquilibrationError> {
    let mut bc = EdgeConditions {
        slot: Vec::with_capacity(topo.num_edges()),
        boundary: Vec::new(),
    };
    for g in 0..topo.num_edges() {
        let ee = topo.elems(g);
        if ee[1] == NONE {
            bc.slot.push(bc.boundary.len() as u32);
            bc.boundary.push([Bc::Known([0.0; 2]); 2]);
        } else {
            bc.slot.push(u32::MAX);
        }
    }
    let mut seen = vec![false; bc.len()];
    for (index, be) in boundary.edges.iter().enumerate() {
        let [a, b] = be.nodes;
        let g = match topo.edge_id(a, b) {
            Some(g) if topo.elems(g)[1] == NONE => g,
            _ => return Err(EquilibrationError::NotABoundaryEdge { index, a, b }),
        };
        if seen[g] {
            return Err(EquilibrationError::DuplicateBoundaryEdge { a, b });
        }
        seen[g] = true;
        let flip = topo.nodes(g)[0] != a;
        for k in 0..2 {
            bc[g][k] = match be.comps[k] {
                EdgeComponent::Known(v) => Bc::Known(if flip { [v[1], v[0]] } else { v }),
                EdgeComponent::Free => Bc::Free,
            };
        }
    }
    Ok(bc)
}

/// ∫_Γ g φ_end for the linear g with end values v: |Γ|/6 (2 v_end + v_other).
pub(super) fn known_moment(len: f64, v: [f64; 2], end: usize) -> f64 {
    len / 6.0 * (2.0 * v[end] + v[1 - end])
}

/// End-point values of the linear edge tractions (oriented to the plus element), per edge,
/// end and component: prescribed data, or the inverse edge mass matrix
/// (2/|Γ|) [[2, −1], [−1, 2]] applied to the moments.
pub(super) fn edge_tractions(
    topo: &Topology,
    bc: &EdgeConditions,
    moments: &[[[f64; 2]; 2]],
) -> Vec<[[f64; 2]; 2]> {
    let mut trac = vec![[[0.0; 2]; 2]; bc.len()];
    for g in 0..bc.len() {
        let f = 2.0 / topo.edge_len[g];
        for k in 0..2 {
            match bc[g][k] {
                Bc::Known(v) => {
                    trac[g][0][k] = v[0];
                    trac[g][1][k] = v[1];
                }
                _ => {
                    let (m0, m1) = (moments[g][0][k], moments[g][1][k]);
                    trac[g][0][k] = f * (2.0 * m0 - m1);
                    trac[g][1][k] = f * (2.0 * m1 - m0);
                }
            }
        }
    }
    trac
}

/// The 12 traction values F̂_E of element e: index 4 l + 2 end + k for local edge l
/// (vertices l → l+1), end 0 at vertex l and 1 at vertex l + 1, component k.
pub(super) fn element_tractions(
    topo: &Topology,
    trac: &[[[f64; 2]; 2]],
    mesh: &Mesh,
    e: usize,
) -> [f64; NT] {
    let t = mesh.triangles.get(e);
    let mut out = [0.0; NT];
    for l in 0..3 {
        let g = topo.edges_of(e)[l];
        let s = topo.sign(e, g);
        let first = topo.end_of(g, t[l]);
        for (pos, end) in [first, 1 - first].into_iter().enumerate() {
            for k in 0..2 {
                out[4 * l + 2 * pos + k] = s * trac[g][end][k];
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// Star problems.

/// Pseudo-inverse and null space of one star matrix pattern.
pub(super) struct StarOp {
    /// A⁺, cols × rows, row-major.
    pub(super) pinv: Vec<f64>,
    /// Orthonormal null-space basis of A: nnull vectors of length cols.
    pub(super) null: Vec<f64>,
    pub(super) nnull: usize,
}

/// No unknown column (a known edge component) in `Stars::row_cols`.
pub(super) const UNKNOWN_NONE: u8 = u8::MAX;

/// The star problems' structure, which depends on the mesh and the boundary codes only
/// (kept in the `OperatorCache` from one recovery to the next).
#[derive(Default)]
pub(super) struct Stars {
    map: FastMap<Vec<i16>, usize>,
    pub(super) ops: Vec<StarOp>,
    /// Per star (2 i + k): index into `ops`.
    pub(super) star_op: Vec<u32>,
    /// Per star: its unknown edges (the columns of A).
    pub(super) cols_ptr: Vec<u32>,
    pub(super) cols: Vec<u32>,
    /// Per star 2 i + k and row (the elements (e, a) around i in `Topology::vertex_elements`
    /// order), at 2 vert_ptr[i] + k rows + row: the columns of the edges l = a and a + 2 of
    /// e ([`UNKNOWN_NONE`] if that component is known); A's entry there is the edge's sign
    /// on e.
    pub(super) row_cols: Vec<[u8; 2]>,
    /// Of the mesh and boundary codes they were built for (`plan::fingerprint`).
    pub(super) fingerprint: u64,
}

impl Stars {
    /// The star structure of `topo` with the boundary codes `bc`.
    pub(super) fn new(topo: &Topology, bc: &EdgeConditions, fingerprint: u64) -> Stars {
        let nn = topo.vert_ptr.len() - 1;
        let mut stars = Stars {
            fingerprint,
            cols_ptr: vec![0],
            ..Default::default()
        };
        let mut star_edges: Vec<usize> = Vec::new();
        let mut cols: Vec<usize> = Vec::new();
        let mut key: Vec<i16> = Vec::new();
        for i in 0..nn {
            let elems = topo.vertex_elements(i);
            star_edges.clear();
            for (e, a) in elems.iter() {
                for l in [a, (a + 2) % 3] {
                    let g = topo.edges_of(e)[l];
                    if !star_edges.contains(&g) {
                        star_edges.push(g);
                    }
                }
            }
            for k in 0..2 {
                cols.clear();
                cols.extend(
                    star_edges
                        .iter()
                        .copied()
                        .filter(|&g| !matches!(bc[g][k], Bc::Known(_))),
                );
                let (nr, nc) = (elems.len(), cols.len());
                key.clear();
                key.push(nr as i16);
                key.push(nc as i16);
                key.resize(2 + nr * nc, 0);
                for (row, (e, a)) in elems.iter().enumerate() {
                    let mut rc = [UNKNOWN_NONE; 2];
                    for (j, l) in [a, (a + 2) % 3].into_iter().enumerate() {
                        let g = topo.edges_of(e)[l];
                        if !matches!(bc[g][k], Bc::Known(_)) {
                            let c = cols.iter().position(|&x| x == g).unwrap();
                            key[2 + row * nc + c] += topo.sign(e, g) as i16;
                            rc[j] = c as u8;
                        }
                    }
                    stars.row_cols.push(rc);
                }
                let op = stars.op(&key);
                stars.star_op.push(op as u32);
                stars.cols.extend(cols.iter().map(|&g| g as u32));
                stars.cols_ptr.push(stars.cols.len() as u32);
            }
        }
        stars.map = FastMap::default(); // the patterns are only looked up while building
        stars
    }

    /// The unknown edges of star `s`.
    pub(super) fn cols(&self, s: usize) -> &[u32] {
        &self.cols[self.cols_ptr[s] as usize..self.cols_ptr[s + 1] as usize]
    }

    /// The operator of star `s`.
    pub(super) fn op_of(&self, s: usize) -> &StarOp {
        &self.ops[self.star_op[s] as usize]
    }

    /// The row columns of star `s` = 2 i + k ([`Stars::row_cols`]).
    pub(super) fn row_cols(&self, topo: &Topology, s: usize) -> &[[u8; 2]] {
        let (i, k) = (s / 2, s % 2);
        let (p0, p1) = (topo.vert_ptr[i], topo.vert_ptr[i + 1]);
        let nr = p1 - p0;
        let start = 2 * p0 + k * nr;
        &self.row_cols[start..start + nr]
    }

    /// The operator of the pattern `key` = [rows, cols, entries of A row-major].
    pub(super) fn op(&mut self, key: &[i16]) -> usize {
        if let Some(&i) = self.map.get(key) {
            return i;
        }
        let (nr, nc) = (key[0] as usize, key[1] as usize);
        let a: Vec<f64> = key[2..].iter().map(|&v| v as f64).collect();
        let op = star_operator(&a, nr, nc);
        self.ops.push(op);
        self.map.insert(key.to_vec(), self.ops.len() - 1);
        self.ops.len() - 1
    }
}

/// A⁺ and null(A) of a small matrix from the eigen-decomposition of AᵀA (Jacobi).
fn star_operator(a: &[f64], nr: usize, nc: usize) -> StarOp {
    let mut ata = vec![0.0; nc * nc];
    for i in 0..nc {
        for j in 0..nc {
            ata[i * nc + j] = (0..nr).map(|r| a[r * nc + i] * a[r * nc + j]).sum();
        }
    }
    let v = sym_eigen(&mut ata, nc);
    let lam: Vec<f64> = (0..nc).map(|j| ata[j * nc + j]).collect();
    let lmax = lam.iter().fold(0.0f64, |m, &x| m.max(x.abs()));
    let tol = 1e-9 * lmax.max(1.0);
    let mut pinv = vec![0.0; nc * nr];
    let mut null = Vec::new();
    let mut nnull = 0;
    for j in 0..nc {
        if lam[j] > tol {
            // (1/λ_j) v_j (A v_j)ᵀ
            let av: Vec<f64> = (0..nr)
                .map(|r| (0..nc).map(|c| a[r * nc + c] * v[c * nc + j]).sum())
                .collect();
            for c in 0..nc {
                for r in 0..nr {
                    pinv[c * nr + r] += v[c * nc + j] * av[r] / lam[j];
                }
            }
        } else {
            null.extend((0..nc).map(|c| v[c * nc + j]));
            nnull += 1;
        }
    }
    StarOp { pinv, null, nnull }
}

/// Cyclic Jacobi eigen-decomposition of a symmetric n × n matrix (row-major). On return the
/// diagonal of `a` holds the eigenvalues; the result holds the eigenvectors as columns.
pub(super) fn sym_eigen(a: &mut [f64], n: usize) -> Vec<f64> {
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _sweep in 0..64 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for i in 0..n {
            for j in 0..n {
                if i == j {
                    diag += a[i * n + j] * a[i * n + j];
                } else {
                    off += a[i * n + j] * a[i * n + j];
                }
            }
        }
        if off <= 1e-28 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    v
}

/// One star's system A b = Q (method.md §3.2 (a)): a row per element E around vertex i,
/// Σ ±b_Γ over its two edges through i, Q_E = R_E minus the known moments of E; solved as
/// b = b̄ + A⁺ (Q − A b̄) from the reference moments b̄. The buffers are kept from star to
/// star.
#[derive(Default)]
pub(super) struct StarSystem {
    /// Per row: A's (column, sign) pairs; a zero sign marks a known component (no column).
    rows: Vec<[(usize, f64); 2]>,
    /// Per row: Q.
    q: Vec<f64>,
    /// The moments, per column: b̄, then b.
    pub(super) b: Vec<f64>,
    /// Q − A b̄.
    r: Vec<f64>,
}

impl StarSystem {
    /// A and Q of star s = 2 i + k.
    pub(super) fn assemble(
        &mut self,
        topo: &Topology,
        bc: &EdgeConditions,
        stars: &Stars,
        force: &[[f64; 6]],
        s: usize,
    ) {
        let (i, k) = (s / 2, s % 2);
        self.rows.clear();
        self.q.clear();
        let elems = topo.vertex_elements(i);
        for ((e, a), rc) in elems.iter().zip(stars.row_cols(topo, s)) {
            let mut rhs = force[e][2 * a + k];
            let mut entries = [(0usize, 0.0); 2];
            for (j, l) in [a, (a + 2) % 3].into_iter().enumerate() {
                let g = topo.edges_of(e)[l];
                let sign = topo.sign(e, g);
                if let Bc::Known(v) = bc[g][k] {
                    let end = topo.end_of(g, i);
                    rhs -= sign * known_moment(topo.edge_len[g], v, end);
                } else {
                    entries[j] = (rc[j] as usize, sign);
                }
            }
            self.rows.push(entries);
            self.q.push(rhs);
        }
    }

    /// (A b)_row − Q_row.
    fn residual(&self, row: usize) -> f64 {
        let term = |(c, s): (usize, f64)| if s != 0.0 { s * self.b[c] } else { 0.0 };
        let [x, y] = self.rows[row];
        term(x) + term(y) - self.q[row]
    }

    /// b of star s = 2 i + k from the reference tractions `edge_ref`; the largest residual
    /// |A b − Q|.
    pub(super) fn solve(
        &mut self,
        topo: &Topology,
        stars: &Stars,
        edge_ref: &[[f64; 2]],
        s: usize,
    ) -> f64 {
        let k = s % 2;
        let (cols, star_op, nr) = (stars.cols(s), stars.op_of(s), self.rows.len());
        self.b.clear();
        self.b.extend(
            cols.iter()
                .map(|&g| 0.5 * topo.edge_len[g as usize] * edge_ref[g as usize][k]),
        );
        let mut r = std::mem::take(&mut self.r);
        r.clear();
        r.extend((0..nr).map(|row| -self.residual(row)));
        for c in 0..cols.len() {
            let corr: f64 = (0..nr).map(|row| star_op.pinv[c * nr + row] * r[row]).sum();
            self.b[c] += corr;
        }
        self.r = r;
        (0..nr).fold(0.0f64, |w, row| w.max(self.residual(row).abs()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn star_operator_pseudo_inverse() {
        // A 6-cycle (interior star): rank 5, null space the constant oriented vector.
        let n = 6;
        let mut a = vec![0.0; n * n];
        for r in 0..n {
            a[r * n + r] = 1.0;
            a[r * n + (r + 1) % n] = -1.0;
        }
        let op = star_operator(&a, n, n);
        assert_eq!(op.nnull, 1);
        for c in 0..n {
            assert!((op.null[c].abs() - 1.0 / (n as f64).sqrt()).abs() < 1e-14);
        }
        // A A⁺ A = A.
        for r in 0..n {
            for c in 0..n {
                let mut s = 0.0;
                for k in 0..n {
                    let apa: f64 = (0..n).map(|m| op.pinv[k * n + m] * a[m * n + c]).sum();
                    s += a[r * n + k] * apa;
                }
                assert!((s - a[r * n + c]).abs() < 1e-13);
            }
        }
    }
}
