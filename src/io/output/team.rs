//! The processes writing one file together: one process ([`Alone`]) or the
//! ranks of a communicator ([`Team`]); their agreement on success after every
//! step that can fail, and the check that they hold the same results and
//! shares that tile every grid.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::ops::Range;

use hdf5::plist::FileAccessBuilder;

use super::collective::collective_transfer;
use super::{OutputError, Results, Share};

/// The processes writing one file together, and what they need from each
/// other. Every method but `rank` is collective: all ranks call it at the
/// same point.
pub(super) trait Writers {
    fn rank(&self) -> usize;
    /// The lowest rank whose `failed` is true, on every rank.
    fn first_failed(&self, failed: bool) -> Option<usize>;
    /// `root`'s `bytes`, on every rank.
    fn broadcast(&self, root: usize, bytes: Vec<u8>) -> Vec<u8>;
    /// Every rank's `values` (the same number on every rank), rank after rank.
    fn all_gather(&self, values: &[u64]) -> Vec<u64>;
    /// Sets the file driver.
    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder;
    /// The data transfer property list (`None`: HDF5's default).
    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>>;
}

/// One process: [`write_results`](super::write_results).
pub(super) struct Alone;

impl Writers for Alone {
    fn rank(&self) -> usize {
        0
    }

    fn first_failed(&self, failed: bool) -> Option<usize> {
        failed.then_some(0)
    }

    fn broadcast(&self, _root: usize, bytes: Vec<u8>) -> Vec<u8> {
        bytes
    }

    fn all_gather(&self, values: &[u64]) -> Vec<u64> {
        values.to_vec()
    }

    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder {
        fapl
    }

    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>> {
        Ok(None)
    }
}

/// The ranks of a communicator:
/// [`write_results_parallel`](super::write_results_parallel).
pub(super) struct Team<'c, C>(pub(super) &'c C);

impl<C: mpi::traits::Communicator> Writers for Team<'_, C> {
    fn rank(&self) -> usize {
        self.0.rank() as usize
    }

    fn first_failed(&self, failed: bool) -> Option<usize> {
        // A rank that failed waits a few seconds: the others may be stuck in a collective
        // HDF5 call that its failure left them in; then it ends the job.
        crate::parallel::fault::first_failed(self.0, failed, || {
            crate::io::monitor::say(format_args!(
                "nndd: error (rank {}): writing the results failed on this rank and the other ranks do not answer; ending the job",
                self.0.rank()
            ));
            self.0.abort(2)
        })
    }

    fn broadcast(&self, root: usize, mut bytes: Vec<u8>) -> Vec<u8> {
        use mpi::traits::Root as _;
        let root = self.0.process_at_rank(root as mpi::Rank);
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        bytes.resize(len as usize, 0);
        if len > 0 {
            root.broadcast_into(&mut bytes[..]);
        }
        bytes
    }

    fn all_gather(&self, values: &[u64]) -> Vec<u64> {
        use mpi::traits::CommunicatorCollectives as _;
        let mut all = vec![0; values.len() * self.0.size() as usize];
        self.0.all_gather_into(values, &mut all[..]);
        all
    }

    fn file_access<'p>(&self, fapl: &'p mut FileAccessBuilder) -> &'p mut FileAccessBuilder {
        fapl.mpio(self.0.as_raw(), None)
    }

    fn transfer(&self) -> hdf5::Result<Option<hdf5::PropertyList>> {
        collective_transfer().map(Some)
    }
}

/// `local` on every rank if no rank failed; otherwise an error on every rank:
/// its own, or [`OutputError::OtherRank`] with the message of the first rank
/// that failed. All ranks call it at the same point.
pub(super) fn agree<W: Writers, T>(w: &W, local: Result<T, OutputError>) -> Result<T, OutputError> {
    let Some(first) = w.first_failed(local.is_err()) else {
        return local;
    };
    let message = match &local {
        Err(e) if w.rank() == first => e.to_string(),
        _ => String::new(),
    };
    let message = String::from_utf8_lossy(&w.broadcast(first, message.into_bytes())).into_owned();
    match local {
        Err(e) => Err(e),
        Ok(_) => Err(OutputError::OtherRank {
            rank: first,
            message,
        }),
    }
}

/// Checks, identically on every rank, that all ranks hold results of the
/// same structure and that their shares tile every grid.
pub(super) fn check_team<W: Writers>(
    w: &W,
    results: &Results,
    shares: &[Share],
) -> Result<(), String> {
    let hashes = w.all_gather(&[structure_hash(results)]);
    if let Some(r) = hashes.iter().position(|&h| h != hashes[0]) {
        return Err(format!(
            "rank {r} holds results of another structure than rank 0 \
             (grids, their extents, steps, field names/kinds/centers or attributes differ)"
        ));
    }
    if shares.is_empty() {
        return Ok(());
    }
    let mine: Vec<u64> = shares
        .iter()
        .flat_map(|s| [s.points.start, s.points.end, s.cells.start, s.cells.end])
        .map(|v| v as u64)
        .collect();
    let all = w.all_gather(&mine);
    for (gi, g) in results.grids.iter().enumerate() {
        let totals = [(0, g.extent.points, "points"), (2, g.extent.cells, "cells")];
        for (at, total, what) in totals {
            let mut ranges: Vec<(usize, Range<usize>)> = all
                .chunks_exact(mine.len())
                .map(|r| r[4 * gi + at] as usize..r[4 * gi + at + 1] as usize)
                .enumerate()
                .filter(|(_, rows)| !rows.is_empty())
                .collect();
            ranges.sort_by_key(|(_, rows)| rows.start);
            let mut next = 0;
            for (_, rows) in &ranges {
                if rows.start != next {
                    break;
                }
                next = rows.end;
            }
            if next != total || ranges.iter().any(|(_, rows)| rows.end > total) {
                let listed: Vec<String> = ranges
                    .iter()
                    .map(|(r, rows)| format!("rank {r}: {rows:?}"))
                    .collect();
                return Err(format!(
                    "grid {:?}: the ranks' shares of its {what} ({}) do not cover 0..{total} exactly once",
                    g.name,
                    listed.join(", ")
                ));
            }
        }
    }
    Ok(())
}

/// A hash of what must be identical on every rank: grids (names, extents, cell kinds),
/// steps (times, grids, field names, centers, kinds), attributes.
fn structure_hash(results: &Results) -> u64 {
    let mut h = DefaultHasher::new();
    results.grids.len().hash(&mut h);
    for g in &results.grids {
        g.name.hash(&mut h);
        g.extent.hash(&mut h);
        g.topology.nodes_per_cell().hash(&mut h);
        for f in &g.fields {
            (&f.name, f.center, f.kind).hash(&mut h);
        }
    }
    results.steps.len().hash(&mut h);
    for step in &results.steps {
        step.time.to_bits().hash(&mut h);
        step.grids.len().hash(&mut h);
        for gf in &step.grids {
            gf.grid.hash(&mut h);
            gf.fields.len().hash(&mut h);
            for f in &gf.fields {
                (&f.name, f.center, f.kind).hash(&mut h);
            }
        }
    }
    results.attributes.len().hash(&mut h);
    for (name, value) in &results.attributes {
        (name, value.to_bits()).hash(&mut h);
    }
    results.text.hash(&mut h);
    h.finish()
}
