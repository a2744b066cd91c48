//! Layer `dd`: the Neumann–Neumann domain decomposition (paper §3, `docs/method.md` §2).
//! [`body`]: one subdomain's PETSc systems and solves ([`schur`]: how its interface operators
//! are formed); the steps of an iteration:
//! [`dirichlet`] (step 1 on the Dirichlet body, Ω¹ in the paper, (8)–(10)), [`contact`] (step 1
//! on the other body, (11)–(14)), [`neumann`] (step 2, (15)–(16)); [`nndd`]: the loop and its
//! update of λ; [`secant`]: the self-tuning update of `-nndd_theta auto`; [`iterate`]: an
//! iterate's fields and Γc data ([`displacement`]: a field as a rank holds it); [`monolithic`]: the discrete global contact problem solved at
//! once, the check of the NNDD; [`check`]: the final check of a reported solution; [`penetration`]: that the bodies do not
//! pass through each other anywhere.
//!
//! May use: `problem`, `parallel`, `qp`, `fem`, `petsc`, `os`.

pub mod body;
pub mod check;
pub mod contact;
pub mod dirichlet;
pub mod displacement;
pub mod friction;
pub mod iterate;
mod load;
pub mod monolithic;
pub mod neumann;
pub mod nndd;
pub mod penetration;
pub mod schur;
pub mod secant;
mod stiffness;
