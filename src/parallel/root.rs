//! What world rank 0 makes, on every rank: the parsed Gmsh file and its facts
//! (`problem::settings`, `problem::parsed`), the outlines of the bodies it builds
//! (`app::input`), sent as bytes once, the other ranks waiting without taking a core; and what
//! it makes for one rank, its parts (`app::input`, [`send_to`]). Messages go in chunks of at
//! most [`CHUNK`] bytes.

use crate::parallel::wait::politely;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, Destination, Root, Source};

/// The most bytes one message carries (MPI counts them in an `int`).
pub const CHUNK: usize = 1 << 30;

/// The bytes `make` gives on world rank 0 (called there alone), on every rank; an error there
/// reaches every rank (the others' message names `file`). Collective over the world.
pub fn bytes_from_root(
    file: &str,
    make: impl FnOnce() -> Result<Vec<u8>, String>,
) -> Result<Vec<u8>, String> {
    let world = mpi::topology::SimpleCommunicator::world();
    if world.size() == 1 {
        return make();
    }
    let root = world.process_at_rank(0);
    // [made, length], then the bytes.
    let mut head = [0u64; 2];
    if world.rank() == 0 {
        let mut made = make();
        head = [
            made.is_ok() as u64,
            made.as_ref().map_or(0, |b| b.len() as u64),
        ];
        // (a non-blocking broadcast matches only non-blocking ones on the other ranks)
        mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, &mut head[..])));
        if let Ok(bytes) = &mut made {
            bytes.chunks_mut(CHUNK).for_each(|c| root.broadcast_into(c));
        }
        return made;
    }
    // The other ranks wait for rank 0 without taking a core from it.
    mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, &mut head[..])));
    if head[0] == 0 {
        return Err(format!("{file}: world rank 0 could not read it"));
    }
    let mut bytes = vec![0u8; head[1] as usize];
    bytes.chunks_mut(CHUNK).for_each(|c| root.broadcast_into(c));
    Ok(bytes)
}

/// Sends `bytes` to world rank `to`: their length, then them (the rank takes them with
/// [`receive_from_root`]).
pub fn send_to(world: &SimpleCommunicator, to: i32, bytes: &[u8]) {
    let dest = world.process_at_rank(to);
    dest.send(&(bytes.len() as u64));
    for chunk in bytes.chunks(CHUNK) {
        dest.send(chunk);
    }
}

/// What world rank 0 [`send_to`]s this rank (waiting for it without taking a core from rank 0).
pub fn receive_from_root(world: &SimpleCommunicator) -> Vec<u8> {
    let root = world.process_at_rank(0);
    let mut len = 0u64;
    mpi::request::scope(|scope| politely(root.immediate_receive_into(scope, &mut len)));
    let mut bytes = vec![0u8; len as usize];
    for chunk in bytes.chunks_mut(CHUNK) {
        root.receive_into(chunk);
    }
    bytes
}
