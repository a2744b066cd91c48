//! Layer `fem`: the finite-element basics every other layer builds on: triangle meshes
//! ([`mesh`]; [`gmsh`] reads them from Gmsh MSH 4.1 files, [`geo`] has the gmsh program mesh a
//! `.geo` geometry; [`checks`] finds flat, folded and overlapping triangles; [`order`] orders
//! triangles so that blocks of them lie together), triangle geometry ([`geometry`]: area,
//! barycentric coordinates, local frame) and P1 plane-strain elasticity ([`elasticity`]:
//! element stiffness, stresses, edge loads, CSR assembly); [`wire`]: plain data as bytes, for
//! what one rank builds and sends the others.
//!
//! May use: `petsc`, `os` (today it uses nothing of the crate).

pub mod checks;
pub mod elasticity;
pub mod geo;
pub mod geometry;
pub mod gmsh;
pub mod mesh;
pub mod order;
pub mod wire;

pub use elasticity::{
    assemble_stiffness, edge_load, element_dofs, element_energy, element_stiffness, element_stress,
    element_stress_with, energy_squared_on, strain_displacement, Csr, Material,
};
pub use mesh::Mesh;

/// Values indexed by mesh dof (2 n + c for node n, component c): a whole vector, or a field a
/// rank holds at some nodes alone (`dd::displacement::Displacement`).
pub trait Dofs: std::ops::Index<usize, Output = f64> {}

impl<T: std::ops::Index<usize, Output = f64> + ?Sized> Dofs for T {}

/// [`Dofs`] that can be written.
pub trait DofsMut: Dofs + std::ops::IndexMut<usize> {}

impl<T: std::ops::IndexMut<usize, Output = f64> + ?Sized> DofsMut for T {}
