//! nndd: two-body frictionless contact by the Neumann–Neumann domain decomposition of
//! Gallimard, Choi & Sassi (2013), with guaranteed error bounds.
//!
//! The layers, from the run down to the FFI and the operating system; a layer uses only the
//! layers below it (`tests/layers.rs` checks it):
//!
//! | layer | what lives there |
//! | --- | --- |
//! | [`app`] | the run: options → settings, and `run()` as the algorithm |
//! | [`io`] | HDF5 + XDMF results, the JSON summary, the monitor |
//! | [`estimate`] | η^glo, η^FE, η^NNDD: admissible traction, equilibrated stresses, reference |
//! | [`dd`] | a body's systems, the Dirichlet, contact and Neumann steps, the NNDD loop, the monolithic check |
//! | [`problem`] | what is solved: bodies, materials, boundary conditions, the contact interface |
//! | [`parallel`] | rank groups and exchanges, METIS partitions |
//! | [`qp`] | the contact QP (Clarabel) and dense algebra |
//! | [`fem`] | meshes and P1 plane-strain elasticity |
//! | [`petsc`] | the only PETSc FFI: safe wrappers of PETSc, `-log_view` stages |
//! | [`os`] | the operating system through `libc`: stop signals, peak memory, freed heap given back |

pub mod app;
pub mod dd;
pub mod estimate;
pub mod fem;
pub mod io;
pub mod os;
pub mod parallel;
pub mod petsc;
pub mod problem;
pub mod qp;
#[cfg(test)]
mod testutil;
