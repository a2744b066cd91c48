//! What world rank 0 makes, on every rank: the parsed Gmsh file and its facts
//! (`problem::settings`, `problem::parsed`), the outlines of the bodies it builds
//! (`app::input`), sent as bytes once, the other ranks waiting without taking a core.

use crate::parallel::wait::politely;
use mpi::traits::{Communicator, Root};

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
            root.broadcast_into(&mut bytes[..]);
        }
        return made;
    }
    // The other ranks wait for rank 0 without taking a core from it.
    mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, &mut head[..])));
    if head[0] == 0 {
        return Err(format!("{file}: world rank 0 could not read it"));
    }
    let mut bytes = vec![0u8; head[1] as usize];
    root.broadcast_into(&mut bytes[..]);
    Ok(bytes)
}
