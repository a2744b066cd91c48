//! Which MPI ranks own which body, and the interface exchanges between the bodies.
//!
//! `-n 1`: both bodies on rank 0. `-n 2`: rank 0 owns Ω¹, rank 1 owns Ω², so the two step-1
//! problems (and the two Neumann problems) run at the same time. Each body lives on its own
//! communicator (a split of the world), so that a body can later span a group of ranks.

use mpi::topology::{Color, Communicator, SimpleCommunicator};
use mpi::traits::*;

use crate::petsc::{comm_from_rsmpi, Comm};

#[derive(Debug, thiserror::Error)]
pub enum LayoutError {
    #[error(
        "mpirun -n: nndd runs on 1 rank (both bodies) or 2 ranks (one per body) (got {0} ranks)"
    )]
    RankCount(i32),
}

pub struct Layout {
    pub world: SimpleCommunicator,
    pub rank: i32,
    pub size: i32,
    /// World rank of each body's root.
    roots: [i32; 2],
    /// This rank's body communicator (one group per body; with one rank, both bodies on it).
    group: SimpleCommunicator,
}

impl Layout {
    pub fn new(world: SimpleCommunicator) -> Result<Layout, LayoutError> {
        let (rank, size) = (world.rank(), world.size());
        let roots = match size {
            1 => [0, 0],
            2 => [0, 1],
            n => return Err(LayoutError::RankCount(n)),
        };
        let color = if size == 1 { 0 } else { rank };
        let group = world
            .split_by_color(Color::with_value(color))
            .expect("every rank has a colour");
        Ok(Layout {
            world,
            rank,
            size,
            roots,
            group,
        })
    }

    /// Does this rank take part in body `alpha`'s work?
    pub fn owns(&self, alpha: usize) -> bool {
        self.size == 1 || self.rank == self.roots[alpha - 1]
    }

    /// The communicator of the body group this rank belongs to.
    pub fn body_comm(&self) -> Comm {
        comm_from_rsmpi(self.group.as_raw())
    }

    pub fn is_root(&self) -> bool {
        self.rank == 0
    }

    /// Broadcast `data` (sized alike on every rank) from body `alpha`'s root to all ranks.
    pub fn share(&self, alpha: usize, data: &mut [f64]) {
        if self.size > 1 {
            self.world
                .process_at_rank(self.roots[alpha - 1])
                .broadcast_into(data);
        }
    }

    /// Broadcast a length then the vector from body `alpha`'s root.
    pub fn share_vec(&self, alpha: usize, data: &mut Vec<f64>) {
        if self.size > 1 {
            let mut n = data.len() as u64;
            self.world
                .process_at_rank(self.roots[alpha - 1])
                .broadcast_into(&mut n);
            data.resize(n as usize, 0.0);
            self.world
                .process_at_rank(self.roots[alpha - 1])
                .broadcast_into(&mut data[..]);
        }
    }

    /// Broadcast a flag from world rank 0 (one decision for all ranks).
    pub fn agree(&self, flag: bool) -> bool {
        let mut v = flag as u8;
        if self.size > 1 {
            self.world.process_at_rank(0).broadcast_into(&mut v);
        }
        v != 0
    }

    /// Broadcast a small code from world rank 0.
    pub fn agree_code(&self, code: u8) -> u8 {
        let mut v = code;
        if self.size > 1 {
            self.world.process_at_rank(0).broadcast_into(&mut v);
        }
        v
    }

    /// Sum over ranks.
    pub fn sum(&self, x: f64) -> f64 {
        let mut out = x;
        if self.size > 1 {
            self.world
                .all_reduce_into(&x, &mut out, mpi::collective::SystemOperation::sum());
        }
        out
    }

    /// Maximum over ranks.
    pub fn max(&self, x: f64) -> f64 {
        let mut out = x;
        if self.size > 1 {
            self.world
                .all_reduce_into(&x, &mut out, mpi::collective::SystemOperation::max());
        }
        out
    }
}
