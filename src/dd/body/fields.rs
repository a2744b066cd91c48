//! A solve's field where it is wanted: an iterate's on each rank of the group at the nodes it
//! reads ([`Body::keep_fields_at`]), or on an estimating rank at the nodes of its overlap of
//! the body alone (the estimates'
//! re-solves, held on their owners until then, and the iterate's field,
//! [`Body::displacement_at`]), gathered from the rows' owners (docs/scaling.md, "Memory per
//! rank").

use std::ops::Range;
use std::sync::Arc;

use super::{Body, BodyError};
use crate::dd::displacement::Displacement;
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

/// Where a rank keeps a body's fields ([`Body::keep_fields_at`]).
pub(super) struct FieldNodes {
    /// The mesh nodes, ascending.
    nodes: Arc<[u32]>,
    /// Among them, the rank's block of the body's nodes (the group's blocks tile the body).
    block: Range<usize>,
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

    /// Keep this body's fields on this rank ([`Body::field`]) at its `block` of the body's
    /// nodes (its points of the output; the group's blocks tile the body in rank order), the
    /// mesh nodes `extra` (its output cells' nodes), Γc's and the outline's alone, rather
    /// than whole: what the output, the energies and the penetration check read; the checks
    /// gather the rank's rows from the blocks ([`Body::rows_of`]) and the estimates what their
    /// recoveries read ([`Body::displacement_at`]). Whole on a group of one rank, which owns
    /// every node. Not collective.
    pub fn keep_fields_at(&self, block: Range<usize>, extra: impl IntoIterator<Item = usize>) {
        let p = &self.problem;
        let mut nodes: Vec<u32> = (block.clone())
            .chain(p.contact_nodes.iter().copied())
            .chain(p.outline().nodes().iter().copied())
            .chain(extra)
            .map(|n| u32::try_from(n).expect("a mesh node fits 32 bits"))
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        // (on several ranks held at nodes on every rank alike, even where they are all the
        // body's: whether a field is whole decides which collectives gather from it)
        *self.field_nodes.borrow_mut() = (self.partition.size > 1).then(|| FieldNodes {
            nodes: nodes.into(),
            block,
        });
    }

    /// The mesh nodes at which this rank keeps the body's fields ([`Body::keep_fields_at`]),
    /// ascending; `None`: whole.
    pub fn kept_nodes(&self) -> Option<Arc<[u32]>> {
        (self.field_nodes.borrow().as_ref()).map(|f| Arc::clone(&f.nodes))
    }

    /// The body's field `u` (held on this rank as [`Body::keep_fields_at`] says) gathered at
    /// `at` from the ranks whose blocks hold it: whole, or at the nodes `at` names and Γc's
    /// (an estimating rank's overlap of the body, whose contact terms read Γc). Collective
    /// over the group.
    pub fn displacement_at(
        &self,
        u: &Displacement,
        at: FieldAt,
    ) -> Result<Displacement, BodyError> {
        let n = self.problem.num_nodes();
        match at {
            FieldAt::Whole => {
                let rows: Vec<petsc::Int> = (0..2 * n as petsc::Int).collect();
                Ok(Displacement::whole(self.gather_from_blocks(u, &rows)?))
            }
            FieldAt::Nodes(view) => {
                let nodes: Vec<u32> = (self.problem.with_contact_nodes(view).into_iter())
                    .map(|n| n as u32)
                    .collect();
                let rows: Vec<petsc::Int> = (nodes.iter())
                    .flat_map(|&n| [0, 1].map(|c| (2 * n + c) as petsc::Int))
                    .collect();
                let values = self.gather_from_blocks(u, &rows)?;
                Ok(Displacement::at_nodes(nodes.into(), values))
            }
        }
    }

    /// The body's field `u` at this rank's rows, in PETSc order and global components: from
    /// `u` where it is whole, else gathered from the ranks whose blocks hold them (collective
    /// over the group where `u` is held at nodes).
    pub(super) fn rows_of(&self, u: &Displacement) -> Result<Vec<f64>, BodyError> {
        let dofs = self.owned_dofs();
        if u.as_whole().is_some() {
            return Ok(dofs.into_iter().map(|d| u[d]).collect());
        }
        let rows: Vec<petsc::Int> = dofs.into_iter().map(|d| d as petsc::Int).collect();
        self.gather_from_blocks(u, &rows)
    }

    /// The mesh dofs `rows` of the field `u`, held at nodes on every rank of the group with
    /// each rank's block among them: the blocks laid out as a PETSc vector in mesh order, one
    /// block per rank, and gathered from (collective over the group).
    fn gather_from_blocks(
        &self,
        u: &Displacement,
        rows: &[petsc::Int],
    ) -> Result<Vec<f64>, BodyError> {
        let block = match &*self.field_nodes.borrow() {
            Some(f) => f.block.clone(),
            None => 0..self.problem.num_nodes(),
        };
        let mine: Vec<f64> = block.flat_map(|n| [u[2 * n], u[2 * n + 1]]).collect();
        let mut blocks = Vector::new(self.comm, mine.len())?;
        blocks.copy_from(&mine)?;
        Ok(Gather::new(&blocks, rows)?.gather(&blocks)?)
    }

    /// The last solution as a field of the body on this rank: whole, or at the nodes
    /// [`Body::keep_fields_at`] gave, gathered from their owners alone (collective).
    pub(super) fn field(&self, fixed: &[(usize, f64)]) -> Result<Displacement, BodyError> {
        match self.kept_nodes() {
            None => Ok(Displacement::whole(self.solution(fixed)?)),
            Some(nodes) => {
                let at: Vec<usize> = nodes.iter().map(|&n| n as usize).collect();
                let values = self.solution_at(fixed, FieldAt::Nodes(&at))?;
                Ok(Displacement::at_nodes(Arc::clone(&nodes), values))
            }
        }
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
