//! The reference solution of (26) and the exact transfer of a coarse P1 field to it (for
//! e_ref and the effectivity).

use std::rc::Rc;

use super::error::EstimateError;
use crate::fem::energy_squared_on;
use crate::fem::mesh::Mesh;
use crate::problem::BodyProblem;

/// The reference solution of (26): the same problem on the nested mesh r·n, solved by the
/// NNDD to tol 1e−8, on the ranks owning each body. Its bodies' factorisations are freed once
/// it is solved: e_ref needs only the fine problems and u_ref (element sums).
pub struct Reference {
    pub factor: usize,
    /// The fine problems, on the ranks of each body's group (`None` elsewhere).
    pub problems: [Option<Rc<BodyProblem>>; 2],
    /// u_ref^α, on the ranks of each body's group.
    pub u: [Vec<f64>; 2],
    pub iterations: usize,
}

impl Reference {
    /// This rank's part of ‖u_ref^α − I u^α‖²_E, body α = `k + 1` (I: the exact P1 transfer
    /// to the fine mesh, [`interpolate_nested`]): the sum of d_Eᵀ K_E d_E over the fine
    /// elements E ≡ `part` (mod `parts`), so that the parts of a body's group add up to it
    /// (the sum of (26) over the group, element by element, each counted once).
    pub fn error_squared_part(
        &self,
        k: usize,
        coarse: &Mesh,
        u: &[f64],
        part: usize,
        parts: usize,
    ) -> Result<f64, EstimateError> {
        let fine = self.problems[k]
            .as_ref()
            .expect("the reference problem on the body's ranks");
        let iu = interpolate_nested(coarse, &fine.mesh, u)?;
        let u_ref = &self.u[k];
        let elements = (part..fine.mesh.triangles.len()).step_by(parts.max(1));
        Ok(energy_squared_on(
            &fine.mesh,
            &fine.material,
            elements,
            |i| u_ref[i] - iu[i],
        ))
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
    if !(coarse.is_structured() && fine.is_structured()) {
        return interpolate_split(coarse, fine, u);
    }
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
    let mut out = vec![0.0; fine.num_dofs()];
    for jf in 0..=fine.ny {
        for if_ in 0..=fine.nx {
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
            let w = if xi >= eta {
                [(a, 1.0 - xi), (b, xi - eta), (d, eta)]
            } else {
                [(a, 1.0 - eta), (d, xi), (c, eta - xi)]
            };
            let n = fine.node(if_, jf);
            for k in 0..2 {
                out[2 * n + k] = w.iter().map(|&(node, wt)| wt * u[2 * node + k]).sum();
            }
        }
    }
    Ok(out)
}

/// [`interpolate_nested`] for a mesh whose triangles were each split into r² (in order):
/// every fine node is evaluated by its barycentric coordinates in its coarse triangle, which
/// must contain it.
fn interpolate_split(coarse: &Mesh, fine: &Mesh, u: &[f64]) -> Result<Vec<f64>, EstimateError> {
    let not_nested = || EstimateError::NotNested {
        coarse: format!("of {} triangles", coarse.triangles.len()),
        fine: format!("of {} triangles", fine.triangles.len()),
    };
    let (nc, nf) = (coarse.triangles.len(), fine.triangles.len());
    let r2 = nf / nc.max(1);
    let r = (r2 as f64).sqrt().round() as usize;
    if nc == 0 || r * r != r2 || r2 * nc != nf {
        return Err(not_nested());
    }
    let mut out = vec![0.0; fine.num_dofs()];
    for (f, t) in fine.triangles.iter().enumerate() {
        let c = f / r2;
        let q = coarse.triangle_points(c);
        let nodes = coarse.triangles.get(c);
        let det =
            (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
        for n in t {
            let p = fine.points[n];
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
            for k in 0..2 {
                out[2 * n + k] = (0..3).map(|v| l[v] * u[2 * nodes[v] + k]).sum();
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn split_interpolation_is_exact_for_p1_on_unstructured_meshes() {
        // A quadrilateral in two triangles (one clockwise), refined 4x through the Gmsh path.
        let points = vec![[0.0, 0.0], [1.0, 0.1], [1.2, 0.9], [0.1, 1.0]];
        let gm = crate::fem::gmsh::GmshMesh {
            path: "quad".into(),
            points,
            triangles: vec![([0, 1, 2], vec![1]), ([0, 3, 2], vec![1])],
            triangle_tags: vec![],
            lines: vec![],
            names: [((2, 1), "body1".to_string())].into_iter().collect(),
        };
        let coarse = gm.body("body1").unwrap().mesh;
        let fine = gm.refined(4).body("body1").unwrap().mesh;
        // A linear field is reproduced at every fine node; the coarse nodes keep their values.
        let lin = |p: [f64; 2]| [2.0 * p[0] - 3.0 * p[1] + 0.5, p[0] + 4.0 * p[1]];
        let u: Vec<f64> = coarse.points.iter().flat_map(|&p| lin(p)).collect();
        let v = interpolate_nested(&coarse, &fine, &u).unwrap();
        for (n, &p) in fine.points.iter().enumerate() {
            let want = lin(p);
            for k in 0..2 {
                assert!((v[2 * n + k] - want[k]).abs() < 1e-13, "node {n}");
            }
        }
        let w: Vec<f64> = (0..8).map(|i| (i * i) as f64).collect();
        let vw = interpolate_nested(&coarse, &fine, &w).unwrap();
        assert_eq!(&vw[..8], &w[..]);
        // A mesh that is not the split of the coarse one is refused.
        let other = gm.refined(3).body("body1").unwrap().mesh;
        let mut moved = other.clone();
        moved.points.iter_mut().for_each(|p| p[0] += 0.5);
        assert!(interpolate_nested(&coarse, &moved, &u).is_err());
    }
}
