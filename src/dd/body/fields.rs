//! A solve's field where it is wanted: whole on every rank of the group (the reported
//! iterate), or on an estimating rank at the nodes of its overlap of the body alone (the
//! estimates' re-solves, held on their owners until then), gathered from the rows' owners
//! (docs/scaling.md, "Memory per rank").

use super::{Body, BodyError};
use crate::petsc::{self, Gather, Vector};

/// Where a solve's field is wanted on each rank of the group.
#[derive(Clone, Copy, Debug)]
pub enum FieldAt<'a> {
    /// Whole, in mesh dofs.
    Whole,
    /// At these mesh nodes alone, their two dofs each in that order (an estimating rank's
    /// overlap of the body): no whole vector on any rank.
    Nodes(&'a [usize]),
}

/// Solutions of one system held on their owners (each rank its rows, PETSc order), with the
/// prescribed values of their solve ([`Body::neumann_solve_many`]).
pub struct Solved {
    pub(super) columns: Vec<Vec<f64>>,
    pub(super) fixed: Vec<(usize, f64)>,
}

impl Body {
    /// The solutions `solved` gathered at `at` (collective over the group).
    pub fn fields_at(&self, solved: Solved, at: FieldAt) -> Result<Vec<Vec<f64>>, BodyError> {
        let Solved { columns, fixed } = solved;
        columns
            .into_iter()
            .map(|x| {
                self.x.borrow_mut().copy_from(&x)?;
                self.solution_at(&fixed, at)
            })
            .collect()
    }

    /// The last solution, whole (mesh order, global components), with the exact prescribed
    /// values (the solve returns them to round-off).
    pub(super) fn solution(&self, fixed: &[(usize, f64)]) -> Result<Vec<f64>, BodyError> {
        let mut u = self.gather_whole(&self.x.borrow())?;
        for &(dof, v) in fixed {
            u[dof] = v;
        }
        self.frames.to_global(&mut u);
        Ok(u)
    }

    /// The last solution at `at` ([`Body::solution`] where it is whole; else the two dofs of
    /// each of its nodes, gathered from their owners alone).
    pub(super) fn solution_at(
        &self,
        fixed: &[(usize, f64)],
        at: FieldAt,
    ) -> Result<Vec<f64>, BodyError> {
        let FieldAt::Nodes(nodes) = at else {
            return self.solution(fixed);
        };
        let dofs = || nodes.iter().flat_map(|&n| [2 * n, 2 * n + 1]);
        let x = self.x.borrow();
        let mut u = match self.partition.size {
            // One rank: PETSc's order is the mesh's.
            1 => {
                let whole = x.to_vec()?;
                dofs().map(|d| whole[d]).collect()
            }
            _ => {
                let rows: Vec<petsc::Int> = dofs().map(|d| self.partition.row(d)).collect();
                Gather::new(&x, &rows)?.gather(&x)?
            }
        };
        // The prescribed values exact, then global components, node by node.
        let mut position: Vec<(usize, usize)> =
            nodes.iter().enumerate().map(|(i, &n)| (n, i)).collect();
        position.sort_unstable();
        for &(dof, v) in fixed {
            if let Ok(p) = position.binary_search_by_key(&(dof / 2), |&(n, _)| n) {
                u[2 * position[p].1 + dof % 2] = v;
            }
        }
        for (i, &n) in nodes.iter().enumerate() {
            self.frames.node_to_global(n, &mut u[2 * i..2 * i + 2]);
        }
        Ok(u)
    }

    /// The whole vector `v` (mesh order) on every rank of the group. The scatter is made for
    /// the call and freed after it: held, its index set, target vector and buffers would weigh
    /// about 40 bytes per dof of the body on every rank (docs/scaling.md, "Memory per rank").
    fn gather_whole(&self, v: &Vector) -> Result<Vec<f64>, BodyError> {
        if self.partition.size == 1 {
            // One rank: PETSc's order is the mesh's.
            return Ok(v.to_vec()?);
        }
        let mut whole = Gather::new(v, &self.partition.rows_in_mesh_order())?;
        Ok(whole.gather(v)?)
    }
}
