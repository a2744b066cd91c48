//! Layer `fem`: the finite-element basics every other layer builds on: triangle meshes
//! ([`mesh`]; [`gmsh`] reads them from Gmsh MSH 4.1 files, [`geo`] has the gmsh program mesh a
//! `.geo` geometry; [`checks`] finds flat, folded
//! and overlapping triangles), triangle geometry ([`geometry`]: area, barycentric
//! coordinates, local frame) and P1 plane-strain elasticity ([`elasticity`]: element
//! stiffness, stresses, edge loads, CSR assembly).
//!
//! May use: `petsc`, `os` (today it uses nothing of the crate).

pub mod checks;
pub mod elasticity;
pub mod geo;
pub mod geometry;
pub mod gmsh;
pub mod mesh;

pub use elasticity::{
    assemble_stiffness, edge_load, element_dofs, element_energy, element_stiffness, element_stress,
    element_stress_with, energy_squared_on, strain_displacement, Csr, Material,
};
pub use mesh::Mesh;
