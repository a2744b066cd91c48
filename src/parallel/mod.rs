//! Layer `parallel`: how the MPI ranks share the work. [`layout`]: the two rank groups (one
//! per body), their communicators and the interface exchanges between them; [`partition`]: a
//! body's mesh split over its group by METIS, and the PETSc row numbering; [`fault`]: how the
//! ranks agree that a phase failed, and the test-only injection of a failure; [`wait`]:
//! waiting for other ranks without taking their core; [`held`]: a rank's part of a vector
//! indexed like the whole; [`root`]: what world rank 0 makes, sent to every rank.
//!
//! May use: `qp`, `fem`, `petsc`, `os`.

pub mod fault;
pub mod held;
pub mod layout;
pub mod partition;
pub mod root;
pub mod wait;
