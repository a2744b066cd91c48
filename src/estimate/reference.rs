//! The reference solution of (26), each rank holding its part of it ([`ReferencePart`]), and
//! the exact transfer of a coarse P1 field to the nested mesh (for e_ref and the
//! effectivity).

use std::ops::Range;

use super::error::EstimateError;
use crate::fem::mesh::Mesh;
use crate::fem::Material;
use crate::fem::{energy_squared_on, Dofs};

/// The reference solution of (26): the same problem on the nested mesh r·n, solved by the
/// NNDD to tol 1e−8, on the ranks owning each body. e_ref is a sum over the fine elements:
/// each rank of a body's group keeps only its block of them and u_ref on their nodes, which
/// the fine body held its fields at (with its output block, Γc and the outline,
/// `Body::keep_fields_at`: no whole fine field on a group of several ranks), and the fine
/// bodies and their factorisations are freed once it is solved.
pub struct Reference {
    pub factor: usize,
    /// This rank's part of each body's reference solution (`None` outside the body's group).
    pub parts: [Option<ReferencePart>; 2],
    pub iterations: usize,
    /// The nodes at which this rank held the fine bodies' solution (both bodies' counts).
    pub held_nodes: usize,
    /// The elements of the fine bodies' meshes this rank held through their set-up and solve
    /// (a Gmsh body's part, `app::parts::read_part`; a built-in body's grid, whole, holds nothing).
    pub held_elements: usize,
    /// The elements of the fine bodies' meshes this rank held in the input: both bodies'
    /// where it built them (world rank 0 alone under `-nndd_mesh_input root`), else the part
    /// it was sent.
    pub input_elements: usize,
    /// This rank's peak resident memory (MiB) once the fine bodies were built and cut to its
    /// parts, before their set-up (what building them on the rank costs it).
    pub input_peak_mib: f64,
}

impl Reference {
    /// This rank's part of body α's (α = `k + 1`; `None` outside the body's group).
    pub fn part(&self, k: usize) -> Option<&ReferencePart> {
        self.parts[k].as_ref()
    }

    /// This rank's part of ‖u_ref^α − I u^α‖²_E, body α = `k + 1`, `u` the coarse field on
    /// `coarse` ([`ReferencePart::error_squared`]): the parts of a body's group add up to it.
    pub fn error_squared_part(
        &self,
        k: usize,
        coarse: &Mesh,
        u: &(impl Dofs + ?Sized),
    ) -> Result<f64, EstimateError> {
        self.part(k)
            .expect("the reference solution's part on the body's ranks")
            .error_squared(coarse, u)
    }
}

/// A rank's part of body α's reference solution: a block of the fine mesh's elements
/// (`Layout::block`, consecutive element numbers: on a structured mesh a band of rows), as a
/// sub-mesh, and u_ref^α on its nodes. Nothing of it is as long as the fine body, and the
/// coarse field it reads is the one at the coarse nodes under its block
/// ([`ReferencePart::coarse_nodes`]).
pub struct ReferencePart {
    material: Material,
    /// What the transfer from the coarse mesh reads of the whole fine mesh.
    fine: FineMesh,
    /// The fine elements of the block.
    elements: Range<usize>,
    /// The block's elements, their nodes numbered 0.. in the order of `nodes`.
    mesh: Mesh,
    /// The fine mesh's node of each of the block's nodes.
    nodes: Vec<usize>,
    /// u_ref^α on the block's nodes (empty until [`ReferencePart::set_solution`]).
    u: Vec<f64>,
}

/// The whole fine mesh's grid (a structured mesh: `nx > 0`) and its element count.
#[derive(Clone, Copy)]
struct FineMesh {
    nx: usize,
    ny: usize,
    origin: [f64; 2],
    size: [f64; 2],
    elements: usize,
}

impl FineMesh {
    fn of(mesh: &Mesh) -> FineMesh {
        FineMesh {
            nx: mesh.nx,
            ny: mesh.ny,
            origin: mesh.origin,
            size: mesh.size,
            elements: mesh.triangles.len(),
        }
    }
}

/// The elements of a coarse mesh under its fine elements `fine`, each coarse triangle split
/// into `r2` consecutive fine ones ([`ReferencePart::coarse_elements`]; world rank 0 adds
/// them to the coarse part it sends a rank under `-nndd_mesh_input root`).
pub fn coarse_elements_under(fine: Range<usize>, r2: usize) -> Range<usize> {
    match fine.is_empty() {
        true => 0..0,
        false => fine.start / r2..(fine.end - 1) / r2 + 1,
    }
}

impl ReferencePart {
    /// The part on the fine mesh's elements `elements` of the fine problem (`fine`, of
    /// `material`), before it is solved: its nodes are those at which the fine bodies keep
    /// their fields on this rank.
    pub fn new(fine: &Mesh, material: Material, elements: Range<usize>) -> ReferencePart {
        let (mesh, nodes) = fine.sub_mesh(elements.clone());
        ReferencePart {
            material,
            fine: FineMesh::of(fine),
            elements,
            mesh,
            nodes,
            u: Vec::new(),
        }
    }

    /// u_ref^α on the part's nodes, from the fine body's solution `u_ref` (held at them at
    /// least).
    pub fn set_solution(&mut self, u_ref: &(impl Dofs + ?Sized)) {
        self.u = (self.nodes.iter())
            .flat_map(|&v| [u_ref[2 * v], u_ref[2 * v + 1]])
            .collect();
    }

    /// The fine elements this part holds.
    pub fn elements(&self) -> Range<usize> {
        self.elements.clone()
    }

    /// The elements of the coarse mesh of `coarse_elements` triangles that the transfer to
    /// this part reads ([`ReferencePart::coarse_nodes`]): a Gmsh mesh's triangle t was split
    /// into the fine ones r² t … r² (t + 1) − 1; a grid's, those under the part's by the
    /// same count.
    pub fn coarse_elements(&self, coarse_elements: usize) -> Range<usize> {
        let r2 = (self.fine.elements / coarse_elements.max(1)).max(1);
        coarse_elements_under(self.elements(), r2)
    }

    /// The fine nodes this part holds.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// The nodes of `coarse` whose values the transfer to this part reads, ascending: the
    /// corners of the coarse elements under the block.
    pub fn coarse_nodes(&self, coarse: &Mesh) -> Result<Vec<usize>, EstimateError> {
        let mut read = Vec::new();
        self.stencils(coarse, |_, s| read.extend(s.map(|(n, _)| n)))?;
        read.sort_unstable();
        read.dedup();
        Ok(read)
    }

    /// ‖u_ref^α − I u^α‖²_E over this part's fine elements (26): the sum of d_Eᵀ K_E d_E,
    /// I the exact P1 transfer of the coarse field `u` on `coarse` (held at
    /// [`ReferencePart::coarse_nodes`] at least) to the block's nodes.
    pub fn error_squared(
        &self,
        coarse: &Mesh,
        u: &(impl Dofs + ?Sized),
    ) -> Result<f64, EstimateError> {
        let iu = transfer(
            coarse,
            &self.fine,
            &self.mesh,
            &self.nodes,
            self.elements.start,
            u,
        )?;
        Ok(energy_squared_on(
            &self.mesh,
            &self.material,
            0..self.mesh.triangles.len(),
            |i| self.u[i] - iu[i],
        ))
    }

    /// [`stencils`] of the part's nodes.
    fn stencils(
        &self,
        coarse: &Mesh,
        visit: impl FnMut(usize, Stencil),
    ) -> Result<(), EstimateError> {
        let first = self.elements.start;
        stencils(coarse, &self.fine, &self.mesh, &self.nodes, first, visit)
    }
}

/// P1 interpolation of a field on `coarse` onto the nested mesh `fine`: exact for nested P1
/// spaces. Structured meshes: the same rectangle, the grid refined by an integer factor,
/// diagonals alike. Unstructured meshes (Gmsh, refined by `GmshMesh::refined`): the r²
/// triangles of coarse triangle t are fine triangles r² t … r² (t + 1) − 1.
pub fn interpolate_nested(
    coarse: &Mesh,
    fine: &Mesh,
    u: &[f64],
) -> Result<Vec<f64>, EstimateError> {
    let nodes: Vec<usize> = (0..fine.num_nodes()).collect();
    transfer(coarse, &FineMesh::of(fine), fine, &nodes, 0, u)
}

/// A fine node's value in the coarse P1 field: three coarse nodes and their weights.
type Stencil = [(usize, f64); 3];

/// [`interpolate_nested`] onto a part of the fine mesh: `part` its elements `first ..` (their
/// nodes numbered in the part), `nodes` the fine node of each of the part's nodes; `u` is read
/// at the stencils' coarse nodes alone.
fn transfer(
    coarse: &Mesh,
    fine: &FineMesh,
    part: &Mesh,
    nodes: &[usize],
    first: usize,
    u: &(impl Dofs + ?Sized),
) -> Result<Vec<f64>, EstimateError> {
    let mut out = vec![0.0; 2 * nodes.len()];
    stencils(coarse, fine, part, nodes, first, |l, s| {
        for k in 0..2 {
            out[2 * l + k] = s.iter().map(|&(n, w)| w * u[2 * n + k]).sum();
        }
    })?;
    Ok(out)
}

/// Each node `l` of the part ([`transfer`]'s arguments) with its [`Stencil`], given to
/// `visit(l, stencil)` (a node of several of the part's elements maybe more than once, alike).
fn stencils(
    coarse: &Mesh,
    fine: &FineMesh,
    part: &Mesh,
    nodes: &[usize],
    first: usize,
    visit: impl FnMut(usize, Stencil),
) -> Result<(), EstimateError> {
    if coarse.is_structured() && fine.nx > 0 && fine.ny > 0 {
        stencils_grid(coarse, fine, nodes, visit)
    } else {
        stencils_split(coarse, fine, part, first, visit)
    }
}

/// [`stencils`] between structured grids: each fine node from the corners of its coarse
/// rectangle's triangle.
fn stencils_grid(
    coarse: &Mesh,
    fine: &FineMesh,
    nodes: &[usize],
    mut visit: impl FnMut(usize, Stencil),
) -> Result<(), EstimateError> {
    let nested = fine.nx.is_multiple_of(coarse.nx)
        && fine.ny.is_multiple_of(coarse.ny)
        && fine.nx / coarse.nx == fine.ny / coarse.ny
        && fine.origin == coarse.origin
        && fine.size == coarse.size;
    if !nested {
        return Err(EstimateError::NotNested {
            coarse: format!("{}x{}", coarse.nx, coarse.ny),
            fine: format!("{}x{}", fine.nx, fine.ny),
        });
    }
    let r = fine.nx / coarse.nx;
    for (l, &n) in nodes.iter().enumerate() {
        let (if_, jf) = (n % (fine.nx + 1), n / (fine.nx + 1));
        let (i, j) = ((if_ / r).min(coarse.nx - 1), (jf / r).min(coarse.ny - 1));
        let xi = (if_ - i * r) as f64 / r as f64;
        let eta = (jf - j * r) as f64 / r as f64;
        let (a, b, c, d) = (
            coarse.node(i, j),
            coarse.node(i + 1, j),
            coarse.node(i, j + 1),
            coarse.node(i + 1, j + 1),
        );
        // Triangles (a, b, d) below the diagonal (ξ ≥ η) and (a, d, c) above it.
        visit(
            l,
            if xi >= eta {
                [(a, 1.0 - xi), (b, xi - eta), (d, eta)]
            } else {
                [(a, 1.0 - eta), (d, xi), (c, eta - xi)]
            },
        );
    }
    Ok(())
}

/// [`stencils`] for a mesh whose triangles were each split into r² (in order): every fine
/// node is evaluated by its barycentric coordinates in its coarse triangle, which must
/// contain it.
fn stencils_split(
    coarse: &Mesh,
    fine: &FineMesh,
    part: &Mesh,
    first: usize,
    mut visit: impl FnMut(usize, Stencil),
) -> Result<(), EstimateError> {
    let not_nested = || EstimateError::NotNested {
        coarse: format!("of {} triangles", coarse.triangles.len()),
        fine: format!("of {} triangles", fine.elements),
    };
    let (nc, nf) = (coarse.triangles.len(), fine.elements);
    let r2 = nf / nc.max(1);
    let r = (r2 as f64).sqrt().round() as usize;
    if nc == 0 || r * r != r2 || r2 * nc != nf {
        return Err(not_nested());
    }
    for (l, t) in part.triangles.iter().enumerate() {
        let c = (first + l) / r2;
        let q = coarse.triangle_points(c);
        let nodes = coarse.triangles.get(c);
        let det =
            (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
        for n in t {
            let p = part.points.get(n);
            let l1 = ((p[0] - q[0][0]) * (q[2][1] - q[0][1])
                - (q[2][0] - q[0][0]) * (p[1] - q[0][1]))
                / det;
            let l2 = ((q[1][0] - q[0][0]) * (p[1] - q[0][1])
                - (p[0] - q[0][0]) * (q[1][1] - q[0][1]))
                / det;
            let l = [1.0 - l1 - l2, l1, l2];
            if l.iter().any(|&w| !(-1e-9..=1.0 + 1e-9).contains(&w)) {
                return Err(not_nested());
            }
            visit(n, [0, 1, 2].map(|v| (nodes[v], l[v])));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::order::ElementOrder;

    #[test]
    fn nested_interpolation_is_exact_for_p1() {
        let coarse = Mesh::structured([0.0, 1.0], [1.0, 1.0], 3, 2);
        let fine = Mesh::structured([0.0, 1.0], [1.0, 1.0], 12, 8);
        // A P1 field on the coarse mesh: nodal values of a non-linear function.
        let u: Vec<f64> = coarse
            .points
            .iter()
            .flat_map(|p| [p[0] * p[0] + p[1], (3.0 * p[0]).sin() * p[1]])
            .collect();
        let v = interpolate_nested(&coarse, &fine, &u).unwrap();
        // Check at fine nodes against barycentric evaluation in the containing coarse triangle.
        for (n, p) in fine.points.iter().enumerate() {
            let mut found = false;
            for (e, t) in coarse.triangles.iter().enumerate() {
                let q = coarse.triangle_points(e);
                let det = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1])
                    - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
                let l1 = ((p[0] - q[0][0]) * (q[2][1] - q[0][1])
                    - (q[2][0] - q[0][0]) * (p[1] - q[0][1]))
                    / det;
                let l2 = ((q[1][0] - q[0][0]) * (p[1] - q[0][1])
                    - (p[0] - q[0][0]) * (q[1][1] - q[0][1]))
                    / det;
                let l0 = 1.0 - l1 - l2;
                if l0 >= -1e-12 && l1 >= -1e-12 && l2 >= -1e-12 {
                    for k in 0..2 {
                        let want =
                            l0 * u[2 * t[0] + k] + l1 * u[2 * t[1] + k] + l2 * u[2 * t[2] + k];
                        assert!((v[2 * n + k] - want).abs() < 1e-13, "node {n}");
                    }
                    found = true;
                    break;
                }
            }
            assert!(found);
        }
        assert!(
            interpolate_nested(&coarse, &Mesh::structured([0.0, 1.0], [1.0, 1.0], 5, 4), &u)
                .is_err()
        );
    }

    /// A quadrilateral in two triangles (one clockwise), the surface "body1" of a Gmsh mesh.
    fn quad() -> crate::fem::gmsh::GmshMesh {
        crate::fem::gmsh::GmshMesh {
            path: "quad".into(),
            points: vec![[0.0, 0.0], [1.0, 0.1], [1.2, 0.9], [0.1, 1.0]],
            triangles: vec![([0, 1, 2], vec![1]), ([0, 3, 2], vec![1])].into(),
            triangle_tags: Default::default(),
            lines: Default::default(),
            names: [((2, 1), "body1".to_string())].into_iter().collect(),
            nesting: None,
        }
    }

    /// A field on `mesh` that no P1 field of a coarser mesh is.
    fn wavy(mesh: &Mesh) -> Vec<f64> {
        let f = |p: [f64; 2]| [(4.0 * p[0]).sin() * p[1], p[0] * p[1] * p[1] - 0.3 * p[0]];
        mesh.points.iter().flat_map(f).collect()
    }

    /// e_ref² on the whole fine mesh, against which the parts are checked.
    fn whole_error(coarse: &Mesh, fine: &Mesh, u_ref: &[f64], u: &[f64]) -> f64 {
        let iu = interpolate_nested(coarse, fine, u).unwrap();
        energy_squared_on(fine, &MATERIAL, 0..fine.triangles.len(), |i| {
            u_ref[i] - iu[i]
        })
    }

    const MATERIAL: Material = Material {
        young: 2.0e5,
        poisson: 0.3,
    };

    /// The parts on `parts` blocks of the fine elements add up to the whole mesh's e_ref², and
    /// each holds its block's elements and no more nodes than `max_nodes(block)`.
    fn check_parts(coarse: &Mesh, fine: &Mesh, parts: usize, max_nodes: impl Fn(usize) -> usize) {
        let (u, u_ref) = (wavy(coarse), wavy(fine));
        let whole = whole_error(coarse, fine, &u_ref, &u);
        assert!(
            whole > 1e-6,
            "a field the coarse mesh does not hold: {whole}"
        );
        let ne = fine.triangles.len();
        let mut sum = 0.0;
        for part in 0..parts {
            let block = crate::parallel::layout::block_of(ne, part, parts);
            let mut p = ReferencePart::new(fine, MATERIAL, block.clone());
            p.set_solution(&u_ref[..]);
            assert_eq!(p.elements(), block);
            assert!(
                p.nodes().len() <= max_nodes(block.len()),
                "part {part}: {} nodes",
                p.nodes().len()
            );
            // The coarse field held at the nodes the part reads alone (the rest NaN).
            let read = p.coarse_nodes(coarse).unwrap();
            let mut at = vec![f64::NAN; u.len()];
            for &n in &read {
                at[2 * n..2 * n + 2].copy_from_slice(&u[2 * n..2 * n + 2]);
            }
            // (a band of a structured mesh reads some of the coarse rows)
            let band = coarse.is_structured() && parts > 1;
            assert!(!band || read.len() < coarse.num_nodes(), "{read:?}");
            sum += p.error_squared(coarse, &at[..]).unwrap();
        }
        assert!(
            (sum - whole).abs() <= 1e-12 * whole,
            "{sum} against {whole}"
        );
    }

    #[test]
    fn the_parts_of_the_reference_add_up_to_the_whole_error() {
        // Structured: a block of 2·nx·k elements spans k + 1 rows of nx + 1 nodes (and one
        // more row where it starts or ends inside a row).
        let coarse = Mesh::structured([0.0, 1.0], [1.0, 1.0], 4, 3);
        let fine = Mesh::structured([0.0, 1.0], [1.0, 1.0], 16, 12);
        check_parts(&coarse, &fine, 3, |ne| (ne / 32 + 3) * 17);
        check_parts(&coarse, &fine, 1, |_| fine.num_nodes());
        // Split (a Gmsh mesh refined, in either order): at most three nodes per element.
        let gm = quad();
        for order in [ElementOrder::File, ElementOrder::Bands] {
            let coarse = gm.body("body1", order).unwrap().mesh;
            let fine = gm.refined(4).body("body1", order).unwrap().mesh;
            check_parts(&coarse, &fine, 3, |ne| 3 * ne);
            check_parts(&coarse, &fine, 5, |ne| 3 * ne);
        }
    }

    #[test]
    fn split_interpolation_is_exact_for_p1_on_unstructured_meshes() {
        for order in [ElementOrder::File, ElementOrder::Bands] {
            split_interpolation_is_exact_in(order);
        }
    }

    fn split_interpolation_is_exact_in(order: ElementOrder) {
        // A quadrilateral in two triangles (one clockwise), refined 4x through the Gmsh path.
        let gm = quad();
        let coarse = gm.body("body1", order).unwrap().mesh;
        let fine = gm.refined(4).body("body1", order).unwrap().mesh;
        // A linear field is reproduced at every fine node; the coarse nodes keep their values.
        let lin = |p: [f64; 2]| [2.0 * p[0] - 3.0 * p[1] + 0.5, p[0] + 4.0 * p[1]];
        let u: Vec<f64> = coarse.points.iter().flat_map(lin).collect();
        let v = interpolate_nested(&coarse, &fine, &u).unwrap();
        for (n, p) in fine.points.iter().enumerate() {
            let want = lin(p);
            for k in 0..2 {
                assert!((v[2 * n + k] - want[k]).abs() < 1e-13, "node {n}");
            }
        }
        let w: Vec<f64> = (0..8).map(|i| (i * i) as f64).collect();
        let vw = interpolate_nested(&coarse, &fine, &w).unwrap();
        for (c, q) in coarse.points.iter().enumerate() {
            let n = (fine.points.iter())
                .position(|p| p == q)
                .expect("a coarse node");
            assert_eq!(&vw[2 * n..2 * n + 2], &w[2 * c..2 * c + 2], "node {c}");
        }
        // A mesh that is not the split of the coarse one is refused.
        let other = gm.refined(3).body("body1", order).unwrap().mesh;
        let mut moved = other.clone();
        moved.points = moved.points.iter().map(|p| [p[0] + 0.5, p[1]]).collect();
        assert!(interpolate_nested(&coarse, &moved, &u).is_err());
    }
}
