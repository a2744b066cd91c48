//! Which MPI ranks own which body, and the interface exchanges between the bodies.
//!
//! `-n 1`: both bodies on rank 0. `-n N`, N ≥ 2: the ranks split into two groups, one per body
//! (sized by the bodies' factorisation work, or `-nndd_body1_ranks`), so the two bodies' setups
//! and their steps run at the same time; each body lives on its group's communicator,
//! partitioned over it by METIS (`partition.rs`). Interface data (λ, the Γc forces, the contact
//! set) are small: each group's root broadcasts them to every rank.

use std::ops::Range;

use mpi::topology::{Color, Communicator, SimpleCommunicator};
use mpi::traits::*;

use crate::parallel::wait::politely;
use crate::petsc::{comm_from_rsmpi, Comm};

/// A duplicated communicator ([`Layout::own_body_comm`]), freed when dropped: its owner drops
/// it after the PETSc objects on it.
pub struct OwnComm(SimpleCommunicator);

impl OwnComm {
    /// The communicator, for PETSc.
    pub fn petsc(&self) -> Comm {
        comm_from_rsmpi(self.0.as_raw())
    }

    /// Personalised exchange over the communicator: `send[r]` goes to its rank r; returns,
    /// per rank r, what r sent here (collective).
    pub fn exchange<T: Equivalence + Copy + Default>(&self, send: &[Vec<T>]) -> Vec<Vec<T>> {
        exchange_on(&self.0, send)
    }

    /// Sum `data` element-wise over the communicator's ranks (in place; collective).
    pub fn sum(&self, data: &mut [f64]) {
        if self.0.size() > 1 {
            let send = data.to_vec();
            self.0
                .all_reduce_into(&send[..], data, mpi::collective::SystemOperation::sum());
        }
    }

    /// The largest of `x` over the communicator's ranks (collective).
    pub fn max(&self, x: f64) -> f64 {
        let mut out = x;
        if self.0.size() > 1 {
            self.0
                .all_reduce_into(&x, &mut out, mpi::collective::SystemOperation::max());
        }
        out
    }
}

#[derive(Debug, thiserror::Error)]
pub enum LayoutError {
    #[error("-nndd_body1_ranks: accepted 1 .. {max} on {size} ranks (body 2 needs at least one), got {got}")]
    Body1Ranks { size: i32, max: i32, got: usize },
    #[error("-nndd_recovery star: solves one global problem per body, so each body must be on one rank (body ranks {ranks:?}); use -nndd_recovery patch or eet")]
    GlobalRecovery { ranks: [usize; 2] },
    #[error("mpirun -n: body {alpha} has {nodes} nodes for {ranks} ranks; use at most {max} ranks for it (a finer mesh, fewer ranks, or -nndd_body1_ranks)")]
    TooManyRanks {
        alpha: usize,
        nodes: usize,
        ranks: usize,
        max: usize,
    },
}

/// The growth of a sparse direct factorisation's work with the dofs of a 2D mesh under a
/// nested-dissection ordering (George 1973: O(N^1.5) flops): what sizes the body groups.
pub const FACTOR_WORK_EXPONENT: f64 = 1.5;

pub struct Layout {
    pub world: SimpleCommunicator,
    pub rank: i32,
    pub size: i32,
    /// World rank of each body's root (the first rank of its group).
    roots: [i32; 2],
    /// Number of ranks of each body's group.
    pub group_sizes: [usize; 2],
    /// This rank's body communicator (one group per body; with one rank, both bodies on it).
    group: SimpleCommunicator,
}

impl Layout {
    /// Split the world into two groups: world ranks 0 .. n₁ for body 1 and n₁ .. N for body 2,
    /// n₁ = `body1_ranks` if given, else in proportion to the bodies' factorisation work,
    /// which dominates a run and grows as dofs^1.5 in 2D ([`FACTOR_WORK_EXPONENT`]; at least
    /// one rank each). With one rank both bodies share it.
    pub fn new(
        world: SimpleCommunicator,
        body1_ranks: usize,
        dofs: [usize; 2],
    ) -> Result<Layout, LayoutError> {
        let (rank, size) = (world.rank(), world.size());
        let n1 = if size == 1 {
            if body1_ranks > 1 {
                return Err(LayoutError::Body1Ranks {
                    size,
                    max: 1,
                    got: body1_ranks,
                });
            }
            1
        } else if body1_ranks > 0 {
            if body1_ranks >= size as usize {
                return Err(LayoutError::Body1Ranks {
                    size,
                    max: size - 1,
                    got: body1_ranks,
                });
            }
            body1_ranks
        } else {
            let work = dofs.map(|d| (d as f64).powf(FACTOR_WORK_EXPONENT));
            let share = size as f64 * (work[0] / (work[0] + work[1]));
            (share.round() as usize).clamp(1, size as usize - 1)
        };
        let (roots, group_sizes) = if size == 1 {
            ([0, 0], [1, 1])
        } else {
            ([0, n1 as i32], [n1, size as usize - n1])
        };
        // At least MIN_NODES nodes per rank, so that METIS gives every rank a part (a body
        // on one rank is not partitioned).
        const MIN_NODES: usize = 16;
        for alpha in [1, 2] {
            let (nodes, ranks) = (dofs[alpha - 1] / 2, group_sizes[alpha - 1]);
            if ranks > 1 && nodes < MIN_NODES * ranks {
                return Err(LayoutError::TooManyRanks {
                    alpha,
                    nodes,
                    ranks,
                    max: (nodes / MIN_NODES).max(1),
                });
            }
        }
        let color = if size > 1 && rank >= n1 as i32 { 1 } else { 0 };
        let group = world
            .split_by_color(Color::with_value(color))
            .expect("every rank has a colour");
        Ok(Layout {
            world,
            rank,
            size,
            roots,
            group_sizes,
            group,
        })
    }

    /// This rank's position in its body group.
    pub fn group_rank(&self) -> usize {
        self.group.rank() as usize
    }

    /// Number of ranks of this rank's body group.
    pub fn group_size(&self) -> usize {
        self.group.size() as usize
    }

    /// Sum `data` element-wise over the ranks of this rank's body group (in place).
    pub fn group_sum(&self, data: &mut [f64]) {
        if self.group.size() > 1 {
            let send = data.to_vec();
            self.group
                .all_reduce_into(&send[..], data, mpi::collective::SystemOperation::sum());
        }
    }

    /// Personalised exchange over all ranks (`world`) or over this rank's body group:
    /// `send[r]` goes to rank r of that communicator; returns, per rank r, what r sent here
    /// (collective over that communicator).
    pub fn exchange<T: Equivalence + Copy + Default>(
        &self,
        world: bool,
        send: &[Vec<T>],
    ) -> Vec<Vec<T>> {
        if world {
            exchange_on(&self.world, send)
        } else {
            exchange_on(&self.group, send)
        }
    }

    /// Broadcast `data` (sized alike on every rank) from the first rank of this rank's body
    /// group to the group.
    pub fn group_broadcast(&self, data: &mut [u32]) {
        if self.group.size() > 1 {
            let root = self.group.process_at_rank(0);
            mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, data)));
        }
    }

    /// Sum `data` element-wise over all ranks (in place).
    pub fn world_sum(&self, data: &mut [f64]) {
        if self.size > 1 {
            let send = data.to_vec();
            self.world
                .all_reduce_into(&send[..], data, mpi::collective::SystemOperation::sum());
        }
    }

    /// The world ranks of body `alpha`'s group.
    pub fn group_ranks(&self, alpha: usize) -> std::ops::Range<usize> {
        let first = self.roots[alpha - 1] as usize;
        first..first + self.group_sizes[alpha - 1]
    }

    /// Does this rank take part in body `alpha`'s work?
    pub fn owns(&self, alpha: usize) -> bool {
        let first = self.roots[alpha - 1];
        self.size == 1 || (first..first + self.group_sizes[alpha - 1] as i32).contains(&self.rank)
    }

    /// A communicator of one body's own, a duplicate of its group's (collective over the
    /// group). Each body's PETSc objects live on their own communicator, so two bodies on one
    /// rank, or the reference problem's bodies beside the run's, never share a solver's
    /// per-communicator state: PETSc 3.18 keeps one SuperLU_DIST process grid per
    /// communicator and frees it twice when two factorisations shared it (heap corruption).
    pub fn own_body_comm(&self) -> OwnComm {
        OwnComm(self.group.duplicate())
    }

    pub fn is_root(&self) -> bool {
        self.rank == 0
    }

    /// Broadcast `data` (sized alike on every rank) from body `alpha`'s root to all ranks
    /// (waiting [`politely`] for the root, which may still be computing).
    pub fn share(&self, alpha: usize, data: &mut [f64]) {
        if self.size > 1 {
            let root = self.world.process_at_rank(self.roots[alpha - 1]);
            mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, data)));
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

    /// The end of an NNDD iteration: world rank 0's stop `code` and whether any rank was
    /// `interrupted`, on every rank (one reduction).
    pub fn agree_stop(&self, code: u8, interrupted: bool) -> (u8, bool) {
        let mine = [
            if self.world.rank() == 0 { code } else { 0 },
            interrupted as u8,
        ];
        let mut out = mine;
        if self.size > 1 {
            mpi::request::scope(|scope| {
                politely(self.world.immediate_all_reduce_into(
                    scope,
                    &mine[..],
                    &mut out[..],
                    mpi::collective::SystemOperation::max(),
                ))
            });
        }
        (out[0], out[1] != 0)
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

    /// This rank's block of `len` items of body `alpha` (its points, its elements): the
    /// group's ranks split 0 .. len evenly and in order ([`block_of`]). What a rank writes of
    /// the body and where the body's element estimates are held; empty outside the group.
    pub fn block(&self, alpha: usize, len: usize) -> Range<usize> {
        match self.owns(alpha) {
            true => block_of(len, self.group_rank(), self.group_sizes[alpha - 1]),
            false => 0..0,
        }
    }

    /// The world rank whose [`Layout::block`] of body `alpha`'s `len` items holds item `i`.
    pub fn block_owner(&self, alpha: usize, len: usize, i: usize) -> usize {
        self.group_ranks(alpha).start + block_owner_of(len, self.group_sizes[alpha - 1], i)
    }
}

/// Block `part` of `parts` of the items 0 .. len: len·part/parts .. len·(part + 1)/parts.
pub fn block_of(len: usize, part: usize, parts: usize) -> Range<usize> {
    len * part / parts..len * (part + 1) / parts
}

/// The block of [`block_of`] that holds item `i` < `len`: the last part whose block starts
/// at or before i, ⌈(i + 1)·parts / len⌉ − 1.
fn block_owner_of(len: usize, parts: usize, i: usize) -> usize {
    debug_assert!(i < len, "item {i} of {len}");
    (((i as u64 + 1) * parts as u64 - 1) / len as u64) as usize
}

/// [`Layout::exchange`] on the communicator `comm`.
fn exchange_on<T: Equivalence + Copy + Default>(
    comm: &SimpleCommunicator,
    send: &[Vec<T>],
) -> Vec<Vec<T>> {
    use mpi::datatype::{Partition, PartitionMut};
    let size = comm.size() as usize;
    assert_eq!(send.len(), size, "one send buffer per rank");
    let counts: Vec<i32> = send.iter().map(|v| v.len() as i32).collect();
    let mut recv_counts = vec![0i32; size];
    comm.all_to_all_into(&counts[..], &mut recv_counts[..]);
    let displs = |c: &[i32]| -> Vec<i32> {
        c.iter()
            .scan(0, |acc, &n| {
                let d = *acc;
                *acc += n;
                Some(d)
            })
            .collect()
    };
    let flat: Vec<T> = buffer(send.iter().map(Vec::len).sum(), |b| {
        send.iter().for_each(|v| b.extend_from_slice(v))
    });
    let total = recv_counts.iter().sum::<i32>() as usize;
    let mut recv: Vec<T> = buffer(total, |b| b.resize(total, T::default()));
    let (sd, rd) = (displs(&counts), displs(&recv_counts));
    comm.all_to_all_varcount_into(
        &Partition::new(&flat[..], &counts[..], &sd[..]),
        &mut PartitionMut::new(&mut recv[..], &recv_counts[..], &rd[..]),
    );
    (0..size)
        .map(|r| recv[rd[r] as usize..(rd[r] + recv_counts[r]) as usize].to_vec())
        .collect()
}

/// A buffer of `len` entries filled by `fill`, allocated even when empty: an empty `Vec`'s
/// pointer is its alignment, which for a byte type is `MPI_IN_PLACE`'s value in OpenMPI (1), and
/// an `MPI_Alltoallv` given it as both buffers fails with MPI_ERR_ARG on that rank alone (the
/// others then wait for it).
fn buffer<T>(len: usize, fill: impl FnOnce(&mut Vec<T>)) -> Vec<T> {
    let mut b = Vec::with_capacity(len.max(1));
    fill(&mut b);
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_exchange_buffer_is_not_mpi_in_place() {
        let empty = Vec::<u8>::new();
        assert_eq!(empty.as_ptr() as usize, 1, "an empty Vec's pointer");
        let send: Vec<Vec<u8>> = vec![Vec::new(); 3];
        let flat: Vec<u8> = buffer(0, |b| send.iter().for_each(|v| b.extend_from_slice(v)));
        let recv: Vec<u8> = buffer(0, |b| b.extend(std::iter::empty::<u8>()));
        assert!(flat.is_empty() && recv.is_empty());
        assert!(flat.as_ptr() as usize > 1 && recv.as_ptr() as usize > 1);
        assert_ne!(flat.as_ptr(), recv.as_ptr());
    }

    #[test]
    fn each_item_has_one_block_and_its_owner_finds_it() {
        for (len, parts) in [
            (1, 1),
            (10, 3),
            (7, 7),
            (5, 8),
            (1000, 16),
            (2_101_250, 511),
        ] {
            let mut next = 0;
            for part in 0..parts {
                let b = block_of(len, part, parts);
                assert_eq!(
                    b.start, next,
                    "blocks of {len} over {parts} follow each other"
                );
                for i in b.clone() {
                    assert_eq!(
                        block_owner_of(len, parts, i),
                        part,
                        "item {i} of {len}/{parts}"
                    );
                }
                next = b.end;
            }
            assert_eq!(next, len, "the blocks of {len} over {parts} cover it");
        }
    }
}
