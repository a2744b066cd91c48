//! K^α, stored once: for a body held by Γ_D, as the Neumann system's matrix
//! K_N = P K P + d (I − P) (P removes the Γ_D rows and columns, d the mean diagonal), which its
//! factorisation's KSP holds, and the coupling B = K − P K P (the entries of K in a Γ_D row or
//! column, a boundary's worth); K u = K_N (P u) + B u. A body held only by contact keeps K.
//! One copy of K on each rank's rows instead of K and K_N (docs/scaling.md, "Memory per rank").

use std::collections::HashMap;

use crate::fem::{element_dofs, element_stiffness};
use crate::parallel::partition::Partition;
use crate::petsc::{self, Comm, Gather, Matrix, PetscError, Vector};
use crate::problem::{BodyProblem, Frames};

/// How K^α is held (see the module's doc).
pub(super) enum Stiffness {
    /// K itself (nothing eliminated: a body held only by contact).
    Whole(Matrix),
    /// K_N is the Neumann system's operator; `coupling` is B.
    Split { coupling: Matrix },
}

/// What [`assemble`] makes: the matrix to factor (K_N) or K, B where split, the mean diagonal
/// d, and ‖K‖∞ (an upper bound, ‖K_N‖∞ + ‖B‖∞, where split: a scale for backward errors).
pub(super) struct Assembled {
    pub matrix: Matrix,
    pub coupling: Option<Matrix>,
    pub diag: f64,
    pub norm_inf: f64,
}

/// Assemble K^α from this rank's elements (rows of other ranks travel at assembly), with the
/// exact preallocation of this rank's rows; with `eliminate`, as K_N and B (the Γ_D rows and
/// columns of K_N zero but kept in its pattern, d on their diagonal: the same matrix as K
/// with MatZeroRowsColumns applied), else K.
pub(super) fn assemble(
    problem: &BodyProblem,
    frames: &Frames,
    comm: Comm,
    part: &Partition,
    eliminate: bool,
) -> Result<Assembled, PetscError> {
    let mesh = &problem.mesh;
    // Whether each dof is on Γ_D (one byte per dof, for the time of the assembly).
    let mut fixed = vec![false; if eliminate { mesh.num_dofs() } else { 0 }];
    for &(dof, _) in problem.dirichlet.iter().filter(|_| eliminate) {
        fixed[dof] = true;
    }
    let is_fixed = |d: usize| eliminate && fixed[d];
    let touches = |t: &[usize; 3]| element_dofs(t).iter().any(|&d| is_fixed(d));
    // Node neighbours (sharing an element) of the owned nodes; through elements with a Γ_D
    // dof too (B's pattern).
    let owned = part.owned_nodes();
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); owned.len()];
    let mut coupled: HashMap<usize, Vec<u32>> = HashMap::new();
    for t in &mesh.triangles {
        let touch = touches(&t);
        for a in t {
            let pa = part.petsc_node[a] as usize;
            if owned.contains(&pa) {
                for b in t {
                    let pb = part.petsc_node[b];
                    let list = &mut neighbours[pa - owned.start];
                    if !list.contains(&pb) {
                        list.push(pb);
                    }
                    if touch {
                        let list = coupled.entry(pa - owned.start).or_default();
                        if !list.contains(&pb) {
                            list.push(pb);
                        }
                    }
                }
            }
        }
    }
    let mut k = preallocate(comm, part, |i| &neighbours[i])?;
    drop(neighbours);
    let mut b = match eliminate {
        true => Some(preallocate(comm, part, |i| {
            coupled.get(&i).map_or(&[][..], |l| &l[..])
        })?),
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
    // Σ over the group of the diagonal sums (through a PETSc vector of one entry per rank).
    let mut partial = Vector::new(comm, 1)?;
    partial.copy_from(&[diag_sum])?;
    let every: Vec<petsc::Int> = (0..part.size as petsc::Int).collect();
    let total: f64 = Gather::new(&partial, &every)?
        .gather(&partial)?
        .iter()
        .sum();
    let diag = total / mesh.num_dofs() as f64;
    let eliminated = problem.dirichlet.iter().filter(|_| eliminate).map(|d| d.0);
    for row in owned_rows(part, eliminated) {
        k.add_values(&[row], &[row], &[diag])?;
    }
    k.assemble()?;
    let mut norm_inf = k.norm_inf()?;
    if let Some(b) = b.as_mut() {
        b.assemble_general()?;
        norm_inf += b.norm_inf()?;
    }
    Ok(Assembled {
        matrix: k,
        coupling: b,
        diag,
        norm_inf,
    })
}

/// An AIJ matrix on this rank's rows whose owned node i couples to the PETSc nodes
/// `neighbours(i)` (both dofs of each).
fn preallocate<'a>(
    comm: Comm,
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
    Matrix::preallocated(comm, part.local_rows(), &d_nnz, &o_nnz)
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
/// centroid), in the nodal frames, orthonormalised: this rank's parts, in PETSc order (the
/// near null space of GAMG).
pub(super) fn rigid_modes(
    problem: &BodyProblem,
    frames: &Frames,
    part: &Partition,
) -> Vec<Vec<f64>> {
    let pts = &problem.mesh.points;
    let n = pts.len() as f64;
    let c = pts
        .iter()
        .fold([0.0; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let mut modes: Vec<Vec<f64>> = vec![
        pts.iter().flat_map(|_| [1.0, 0.0]).collect(),
        pts.iter().flat_map(|_| [0.0, 1.0]).collect(),
        pts.iter()
            .flat_map(|p| [c[1] - p[1], p[0] - c[0]])
            .collect(),
    ];
    // Gram–Schmidt, on the whole vectors (every rank holds them: the same result everywhere).
    for i in 0..modes.len() {
        frames.to_local(&mut modes[i]);
        for j in 0..i {
            let d: f64 = modes[i].iter().zip(&modes[j]).map(|(a, b)| a * b).sum();
            let (done, rest) = modes.split_at_mut(i);
            for (a, b) in rest[0].iter_mut().zip(&done[j]) {
                *a -= d * b;
            }
        }
        let norm = modes[i].iter().map(|a| a * a).sum::<f64>().sqrt();
        modes[i].iter_mut().for_each(|a| *a /= norm);
    }
    modes.iter().map(|m| part.local_part(m)).collect()
}
