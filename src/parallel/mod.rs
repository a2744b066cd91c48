//! Layer `parallel`: how the MPI ranks share the work. [`layout`]: the two rank groups (one
//! per body), their communicators and the interface exchanges between them; [`partition`]: a
//! body's mesh split over its group by METIS, and the PETSc row numbering.
//!
//! May use: `qp`, `fem`, `petsc`.

pub mod layout;
pub mod partition;
