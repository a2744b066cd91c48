//! The MPI communicators handed to PETSc.

use super::ffi;

/// An MPI communicator handed to PETSc. Made only from valid communicators
/// ([`Petsc::comm_world`](super::Petsc::comm_world), [`comm_from_rsmpi`]), so passing it on
/// is safe.
#[derive(Clone, Copy, Debug)]
pub struct Comm(pub(super) ffi::MPI_Comm);

/// Convert an rsmpi raw communicator into PETSc's `MPI_Comm` (both are OpenMPI's
/// `ompi_communicator_t *`; the two bindings only name the type differently).
pub fn comm_from_rsmpi(raw: mpi::ffi::MPI_Comm) -> Comm {
    Comm(raw.0 as ffi::MPI_Comm)
}
