//! Layer `io`: what a run writes. [`output`]: `PREFIX.h5` + `PREFIX.xdmf` for ParaView and
//! atomic writes, every file name from the prefix ([`output::OutputPaths`]); [`checkpoint`]:
//! the restart points; [`summary`]: the JSON run summary; [`monitor`]: the PETSc-style monitor
//! lines; [`settings`]: the output's options.
//!
//! May use: `estimate`, `dd`, `problem`, `parallel`, `qp`, `fem`, `petsc`, `os`.

pub mod checkpoint;
pub mod fields;
pub mod monitor;
pub mod output;
pub mod settings;
pub mod summary;
