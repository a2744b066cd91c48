//! K^α, stored once: for a body held by Γ_D, as the Neumann system's matrix
//! K_N = P K P + d (I − P) (P removes the Γ_D rows and columns, d the mean diagonal), which its
//! factorisation's KSP holds, and the coupling B = K − P K P (the entries of K in a Γ_D row or
//! column, a boundary's worth); K u = K_N (P u) + B u. A body held only by contact keeps K.
//! One copy of K on each rank's rows instead of K and K_N (docs/scaling.md, "Memory per rank").

use std::collections::HashMap;

use crate::fem::{element_dofs, element_stiffness};
use crate::parallel::layout::OwnComm;
use crate::parallel::partition::Partition;
use crate::petsc::{self, Matrix, PetscError};
use crate::problem::{BodyProblem, Frames};

/// How K^α is held (see the module's doc).
pub(super) enum Stiffness {
    /// K itself (nothing eliminated: a body held only by contact).
    Whole(Matrix),
    /// K_N is the Neumann system's operator; `coupling` is B.
    Split { coupling: Matrix },
}

/// What [`assemble`] makes: the matrix to factor (K_N) or K, B where split, the mean diagonal
/// d, ‖K‖∞ (an upper bound, ‖K_N‖∞ + ‖B‖∞, where split: a scale for backward errors), and the
/// nonzeros of the matrix to factor (over the group; Γ_D's rows and columns kept in K_N's
/// pattern, so K's).
pub(super) struct Assembled {
    pub matrix: Matrix,
    pub nonzeros: f64,
    pub coupling: Option<Matrix>,
    pub diag: f64,
    pub norm_inf: f64,
}

/// Assemble K^α from this rank's elements (rows of other ranks travel at assembly), with the
/// exact preallocation of this rank's rows ([`NodeLists`]: no rank reads the elements of the
/// others); with `eliminate`, as K_N and B (the Γ_D rows and columns of K_N zero but kept in
/// its pattern, d on their diagonal: the same matrix as K with MatZeroRowsColumns applied),
/// else K. Collective over the body's group.
pub(super) fn assemble(
    problem: &BodyProblem,
    frames: &Frames,
    comm: &OwnComm,
    part: &Partition,
    eliminate: bool,
) -> Result<Assembled, PetscError> {
    let mesh = problem.mesh();
    // Whether each dof is on Γ_D (one bit per dof, for the time of the assembly).
    let words = if eliminate {
        mesh.num_dofs().div_ceil(64)
    } else {
        0
    };
    let mut fixed = vec![0u64; words];
    for &(dof, _) in problem.dirichlet.iter().filter(|_| eliminate) {
        fixed[dof / 64] |= 1 << (dof % 64);
    }
    let is_fixed = |d: usize| eliminate && fixed[d / 64] & (1 << (d % 64)) != 0;
    let touches = |t: &[usize; 3]| element_dofs(t).iter().any(|&d| is_fixed(d));
    let own = || {
        part.elements
            .iter()
            .map(|&e| mesh.triangles.get(e as usize))
    };
    // Node neighbours of the owned nodes (K's pattern), and through the elements with a Γ_D
    // dof (B's).
    let owned = part.owned_nodes();
    let mut lists = NodeLists::new(owned.clone(), Lists::EveryNode);
    let mut coupled = NodeLists::new(owned, Lists::FewNodes);
    for t in own() {
        lists.add_element(part, &t);
        if eliminate && touches(&t) {
            coupled.add_element(part, &t);
        }
    }
    lists.complete(part, comm);
    let mut k = preallocate(comm, part, |i| lists.of(i))?;
    drop(lists);
    let mut b = match eliminate {
        true => {
            coupled.complete(part, comm);
            Some(preallocate(comm, part, |i| coupled.of(i))?)
        }
        false => None,
    };
    drop(coupled);
    let mut diag_sum = 0.0;
    let (mut vals, mut bvals) = ([0.0; 36], [0.0; 36]);
    for e in part.elements.iter().map(|&e| e as usize) {
        let t = mesh.triangles.get(e);
        let mut ke = element_stiffness(&mesh.triangle_points(e), &problem.material);
        frames.rotate_element(&t, &mut ke);
        let dofs = element_dofs(&t);
        let rows = dofs.map(|d| part.row(d));
        let touch = touches(&t);
        for r in 0..6 {
            diag_sum += ke[r][r];
            for c in 0..6 {
                let in_b = touch && (is_fixed(dofs[r]) || is_fixed(dofs[c]));
                vals[6 * r + c] = if in_b { 0.0 } else { ke[r][c] };
                bvals[6 * r + c] = if in_b { ke[r][c] } else { 0.0 };
            }
        }
        k.add_values(&rows, &rows, &vals)?;
        if let (Some(b), true) = (b.as_mut(), touch) {
            b.add_values(&rows, &rows, &bvals)?;
        }
    }
    let mut total = [diag_sum];
    comm.sum(&mut total);
    let diag = total[0] / mesh.num_dofs() as f64;
    let eliminated = problem.dirichlet.iter().filter(|_| eliminate).map(|d| d.0);
    for row in owned_rows(part, eliminated) {
        k.add_values(&[row], &[row], &[diag])?;
    }
    k.assemble()?;
    let nonzeros = k.exact_nonzeros()?;
    let mut norm_inf = k.norm_inf()?;
    if let Some(b) = b.as_mut() {
        b.assemble_general()?;
        b.exact_nonzeros()?;
        norm_inf += b.norm_inf()?;
    }
    Ok(Assembled {
        matrix: k,
        nonzeros,
        coupling: b,
        diag,
        norm_inf,
    })
}

/// The PETSc nodes that each owned node shares an element with (itself included), from this
/// rank's elements alone: the lists of the nodes of other ranks that they touch (the part's
/// boundary) are sent to those nodes' owners ([`NodeLists::complete`]), so that no rank reads
/// the elements of the others.
struct NodeLists {
    owned: std::ops::Range<usize>,
    /// Indexed by owned node − `owned.start` ([`Lists::EveryNode`]), or by owned node in
    /// `sparse` ([`Lists::FewNodes`]).
    dense: Vec<Vec<u32>>,
    sparse: HashMap<usize, Vec<u32>>,
    /// The lists of other ranks' nodes, until sent.
    others: HashMap<u32, Vec<u32>>,
}

/// Which owned nodes have a list: every one (K's pattern), or few (B's: those near Γ_D).
#[derive(Clone, Copy, PartialEq)]
enum Lists {
    EveryNode,
    FewNodes,
}

impl NodeLists {
    fn new(owned: std::ops::Range<usize>, lists: Lists) -> NodeLists {
        let dense = match lists {
            Lists::EveryNode => owned.len(),
            Lists::FewNodes => 0,
        };
        NodeLists {
            dense: vec![Vec::new(); dense],
            owned,
            sparse: HashMap::new(),
            others: HashMap::new(),
        }
    }

    fn list(&mut self, p: u32) -> &mut Vec<u32> {
        let p = p as usize;
        match (self.owned.contains(&p), self.dense.is_empty()) {
            (false, _) => self.others.entry(p as u32).or_default(),
            (true, false) => &mut self.dense[p - self.owned.start],
            (true, true) => self.sparse.entry(p).or_default(),
        }
    }

    fn merge(&mut self, p: u32, nodes: &[u32]) {
        let list = self.list(p);
        for &q in nodes {
            if !list.contains(&q) {
                list.push(q);
            }
        }
    }

    fn add_element(&mut self, part: &Partition, t: &[usize; 3]) {
        let nodes = t.map(|a| part.petsc_node[a]);
        for &p in &nodes {
            self.merge(p, &nodes);
        }
    }

    /// Send the lists of other ranks' nodes to their owners, and merge those received
    /// (collective over the group).
    fn complete(&mut self, part: &Partition, comm: &OwnComm) {
        if part.size == 1 {
            return;
        }
        let mut send = vec![Vec::new(); part.size];
        for (p, list) in std::mem::take(&mut self.others) {
            let to = &mut send[part.owner_of_petsc_node(p as usize)];
            to.extend([p, list.len() as u32]);
            to.extend(list);
        }
        for buf in comm.exchange(&send) {
            let mut at = 0;
            while at < buf.len() {
                let (p, n) = (buf[at], buf[at + 1] as usize);
                self.merge(p, &buf[at + 2..at + 2 + n]);
                at += 2 + n;
            }
        }
    }

    /// The list of owned node `owned.start + i` (after [`NodeLists::complete`]).
    fn of(&self, i: usize) -> &[u32] {
        match self.dense.is_empty() {
            false => &self.dense[i],
            true => self
                .sparse
                .get(&(self.owned.start + i))
                .map_or(&[][..], |l| &l[..]),
        }
    }
}

/// An AIJ matrix on this rank's rows whose owned node i couples to the PETSc nodes
/// `neighbours(i)` (both dofs of each). Collective.
fn preallocate<'a>(
    comm: &OwnComm,
    part: &Partition,
    neighbours: impl Fn(usize) -> &'a [u32],
) -> Result<Matrix, PetscError> {
    let owned = part.owned_nodes();
    let (mut d_nnz, mut o_nnz) = (Vec::new(), Vec::new());
    for i in 0..owned.len() {
        let list = neighbours(i);
        let d = 2 * list
            .iter()
            .filter(|&&p| owned.contains(&(p as usize)))
            .count();
        let o = 2 * list.len() - d;
        for _ in 0..2 {
            d_nnz.push(d as petsc::Int);
            o_nnz.push(o as petsc::Int);
        }
    }
    Matrix::preallocated(comm.petsc(), part.local_rows(), &d_nnz, &o_nnz)
}

/// The PETSc rows of `dofs` that this rank owns (each once).
pub(super) fn owned_rows(part: &Partition, dofs: impl Iterator<Item = usize>) -> Vec<petsc::Int> {
    let mut rows: Vec<petsc::Int> = dofs
        .filter(|&d| part.owns_dof(d))
        .map(|d| part.row(d))
        .collect();
    rows.sort_unstable();
    rows.dedup();
    rows
}

/// The rigid-body modes of 2D elasticity (two translations and the rotation about the
/// centroid), in the nodal frames, orthonormalised: this rank's rows, in PETSc order (the
/// near null space of GAMG). The centroid and the Gram–Schmidt products are sums over the
/// group: no rank forms a whole vector. Collective over the body's group.
pub(super) fn rigid_modes(
    problem: &BodyProblem,
    frames: &Frames,
    part: &Partition,
    comm: &OwnComm,
) -> Vec<Vec<f64>> {
    let pts = &problem.mesh().points;
    let nodes: Vec<usize> = part.owned_mesh_nodes().collect();
    let mut sums = [0.0, 0.0, nodes.len() as f64];
    for &i in &nodes {
        let p = pts.get(i);
        sums[0] += p[0];
        sums[1] += p[1];
    }
    comm.sum(&mut sums);
    let c = [sums[0] / sums[2], sums[1] / sums[2]];
    let mode = |k: usize| -> Vec<f64> {
        nodes
            .iter()
            .flat_map(|&i| {
                let p = pts.get(i);
                let v = match k {
                    0 => [1.0, 0.0],
                    1 => [0.0, 1.0],
                    _ => [c[1] - p[1], p[0] - c[0]],
                };
                // Rᵀ v in a rotated frame (`Frames::to_local`).
                match frames.normal(i) {
                    Some(n) => [n[1] * v[0] - n[0] * v[1], n[0] * v[0] + n[1] * v[1]],
                    None => v,
                }
            })
            .collect()
    };
    let dot = |a: &[f64], b: &[f64]| {
        let mut d = [a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>()];
        comm.sum(&mut d);
        d[0]
    };
    let mut modes: Vec<Vec<f64>> = Vec::with_capacity(3);
    for k in 0..3 {
        let mut v = mode(k);
        for done in &modes {
            let d = dot(&v, done);
            v.iter_mut().zip(done).for_each(|(a, b)| *a -= d * b);
        }
        let norm = dot(&v, &v).sqrt();
        v.iter_mut().for_each(|a| *a /= norm);
        modes.push(v);
    }
    modes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::mesh::Mesh;

    /// Each rank's lists from its own elements, completed by the lists the other ranks send
    /// for its nodes (what `NodeLists::complete` exchanges), are the node pairs that share an
    /// element anywhere in the mesh.
    #[test]
    fn own_elements_and_the_lists_sent_give_every_node_pair_of_the_mesh() {
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 0.7], 9, 6);
        for size in [1, 2, 3, 5] {
            let parts: Vec<Partition> = (0..size)
                .map(|r| Partition::new(&mesh, 1, r, size).unwrap())
                .collect();
            let mut lists: Vec<NodeLists> = parts
                .iter()
                .map(|p| {
                    let lists = match size {
                        3 => Lists::FewNodes,
                        _ => Lists::EveryNode,
                    };
                    let mut l = NodeLists::new(p.owned_nodes(), lists);
                    for &e in &p.elements {
                        l.add_element(p, &mesh.triangles.get(e as usize));
                    }
                    l
                })
                .collect();
            let sent: Vec<(u32, Vec<u32>)> = lists
                .iter_mut()
                .flat_map(|l| std::mem::take(&mut l.others))
                .collect();
            assert_eq!(sent.is_empty(), size == 1);
            for (p, list) in sent {
                let owner = parts[0].owner_of_petsc_node(p as usize);
                lists[owner].merge(p, &list);
            }
            let petsc = &parts[0].petsc_node;
            for (part, l) in parts.iter().zip(&lists) {
                for i in 0..part.owned_nodes().len() {
                    let p = (part.owned_nodes().start + i) as u32;
                    let mut want: Vec<u32> = mesh
                        .triangles
                        .iter()
                        .map(|t| t.map(|a| petsc[a]))
                        .filter(|t| t.contains(&p))
                        .flatten()
                        .collect();
                    want.sort_unstable();
                    want.dedup();
                    let mut got = l.of(i).to_vec();
                    got.sort_unstable();
                    assert_eq!(got, want, "{size} ranks, PETSc node {p}");
                }
            }
        }
    }
}
