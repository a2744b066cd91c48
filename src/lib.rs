//! nndd: two-body frictionless contact by the Neumann–Neumann domain decomposition of
//! Gallimard, Choi & Sassi (2013), with one home per concept:
//! `mesh` (structured meshes), `fem` (P1 plane strain), `problem` (the benchmarks),
//! `body` (a subdomain's PETSc systems), `contact` (the contact step QP), `dirichlet` (the Dirichlet step), `nndd` (the loop),
//! `monolithic` (the global QP), `equilibrate` + `estimate` (the error estimates), `qp` + `dense` (Clarabel and dense algebra),
//! `layout` (ranks and exchanges), `output` + `summary` (files), `app` (the run).

pub mod app;
pub mod body;
pub mod contact;
pub mod dense;
pub mod dirichlet;
pub mod equilibrate;
pub mod estimate;
pub mod fem;
pub mod layout;
pub mod log;
pub mod mesh;
pub mod monolithic;
pub mod nndd;
pub mod output;
pub mod overlap;
pub mod partition;
pub mod petsc;
pub mod problem;
pub mod qp;
pub mod settings;
pub mod summary;
#[cfg(test)]
mod testutil;
