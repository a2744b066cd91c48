//! The reference solution of (26) and the exact transfer of a coarse P1 field to it (for
//! e_ref and the effectivity).

use super::EstimateError;
use crate::dd::body::Body;
use crate::fem::mesh::Mesh;

/// The reference solution of (26): the same problem on the nested mesh r·n, solved by the
/// NNDD to tol 1e−8, on the ranks owning each body.
pub struct Reference {
    pub factor: usize,
    /// Fine bodies (for their stiffness) and u_ref^α, on the owners.
    pub bodies: [Option<Body>; 2],
    pub u: [Vec<f64>; 2],
    pub iterations: usize,
}

/// P1 interpolation of a field on `coarse` onto the nested mesh `fine` (same rectangle, grid
/// refined by an integer factor, diagonals alike): exact for nested P1 spaces.
pub fn interpolate_nested(
    coarse: &Mesh,
    fine: &Mesh,
    u: &[f64],
) -> Result<Vec<f64>, EstimateError> {
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
}
