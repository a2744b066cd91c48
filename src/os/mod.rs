//! Layer `os`: what the run asks of the operating system and the C library (through `libc`),
//! not of PETSc: the signals that ask a run to stop, and the other dispositions it sets
//! ([`signals`]); the process's peak memory and giving freed heap back ([`memory`]).
//!
//! May use: nothing of this crate (the bottom layer).

pub mod memory;
pub mod signals;
