//! P1 plane-strain finite elements: element matrices, stresses, loads and CSR assembly.

use crate::fem::mesh::Mesh;

/// Isotropic linear elasticity in plane strain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Young's modulus E (Pa).
    pub young: f64,
    /// Poisson's ratio ν.
    pub poisson: f64,
}

impl Material {
    /// The plane-strain modulus E/(1 − ν²): the stiffness of the body under a normal load on
    /// its boundary (which body takes the NNDD's Dirichlet step).
    pub fn plane_strain_modulus(&self) -> f64 {
        self.young / (1.0 - self.poisson * self.poisson)
    }

    /// Hooke's matrix K (Voigt: xx, yy, xy with engineering shear strain).
    pub fn hooke(&self) -> [[f64; 3]; 3] {
        let (e, nu) = (self.young, self.poisson);
        let c = e / ((1.0 + nu) * (1.0 - 2.0 * nu));
        [
            [c * (1.0 - nu), c * nu, 0.0],
            [c * nu, c * (1.0 - nu), 0.0],
            [0.0, 0.0, c * (1.0 - 2.0 * nu) / 2.0],
        ]
    }

    /// Out-of-plane stress σ_zz = ν (σ_xx + σ_yy) of plane strain.
    pub fn sigma_zz(&self, s: &[f64; 3]) -> f64 {
        self.poisson * (s[0] + s[1])
    }

    /// Complementary energy density ½ σ : K⁻¹ σ for an in-plane stress (Voigt), plane strain.
    pub fn compliance_energy(&self, s: &[f64; 3]) -> f64 {
        let (e, nu) = (self.young, self.poisson);
        // Plane-strain compliance: ε = ((1+ν)/E) [ (1-ν)σxx - ν σyy, (1-ν)σyy - ν σxx, 2 σxy ].
        let k = (1.0 + nu) / e;
        let exx = k * ((1.0 - nu) * s[0] - nu * s[1]);
        let eyy = k * ((1.0 - nu) * s[1] - nu * s[0]);
        let gxy = 2.0 * k * s[2];
        0.5 * (s[0] * exx + s[1] * eyy + s[2] * gxy)
    }
}

/// The strain–displacement matrix B (3 × 6) of a P1 triangle and its area.
pub fn strain_displacement(p: &[[f64; 2]; 3]) -> ([[f64; 6]; 3], f64) {
    let det = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
    let area = 0.5 * det;
    let mut b = [[0.0; 6]; 3];
    for a in 0..3 {
        let (j, k) = ((a + 1) % 3, (a + 2) % 3);
        let dx = (p[j][1] - p[k][1]) / det; // ∂φ_a/∂x
        let dy = (p[k][0] - p[j][0]) / det; // ∂φ_a/∂y
        b[0][2 * a] = dx;
        b[1][2 * a + 1] = dy;
        b[2][2 * a] = dy;
        b[2][2 * a + 1] = dx;
    }
    (b, area)
}

/// Element stiffness A Bᵀ K B (6 × 6, dofs x0 y0 x1 y1 x2 y2).
pub fn element_stiffness(p: &[[f64; 2]; 3], mat: &Material) -> [[f64; 6]; 6] {
    let (b, area) = strain_displacement(p);
    let d = mat.hooke();
    let mut db = [[0.0; 6]; 3];
    for r in 0..3 {
        for c in 0..6 {
            db[r][c] = (0..3).map(|k| d[r][k] * b[k][c]).sum();
        }
    }
    let mut ke = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in 0..6 {
            ke[r][c] = area * (0..3).map(|k| b[k][r] * db[k][c]).sum::<f64>();
        }
    }
    ke
}

/// dᵀ K_E d of an element stiffness K_E and element dofs d.
pub fn element_energy(ke: &[[f64; 6]; 6], d: &[f64; 6]) -> f64 {
    (0..6)
        .map(|r| d[r] * (0..6).map(|c| ke[r][c] * d[c]).sum::<f64>())
        .sum()
}

/// a(u, u) = Σ_E u_Eᵀ K_E u_E of a displacement `u` on `mesh` (the square of its energy norm).
pub fn energy_squared(mesh: &Mesh, mat: &Material, u: &[f64]) -> f64 {
    energy_squared_on(mesh, mat, 0..mesh.triangles.len(), |i| u[i])
}

/// Σ_E u_Eᵀ K_E u_E over the triangles `elements` of `mesh`, dof i of u being `u(i)` (a part of
/// [`energy_squared`], of a field not held as a vector: a difference of two).
pub fn energy_squared_on(
    mesh: &Mesh,
    mat: &Material,
    elements: impl Iterator<Item = usize>,
    u: impl Fn(usize) -> f64,
) -> f64 {
    elements
        .map(|e| {
            let ke = element_stiffness(&mesh.triangle_points(e), mat);
            element_energy(&ke, &element_dofs(&mesh.triangles.get(e)).map(&u))
        })
        .sum()
}

/// Element dofs of a triangle.
pub fn element_dofs(t: &[usize; 3]) -> [usize; 6] {
    [
        2 * t[0],
        2 * t[0] + 1,
        2 * t[1],
        2 * t[1] + 1,
        2 * t[2],
        2 * t[2] + 1,
    ]
}

/// Constant stress K ε(u) (Voigt xx, yy, xy) in triangle `e` for the nodal field `u`.
pub fn element_stress(mesh: &Mesh, e: usize, mat: &Material, u: &[f64]) -> [f64; 3] {
    element_stress_with(mesh, e, mat, |d| u[d])
}

/// [`element_stress`] from the displacement's value `u(dof)` at each dof of the element.
pub fn element_stress_with(
    mesh: &Mesh,
    e: usize,
    mat: &Material,
    u: impl Fn(usize) -> f64,
) -> [f64; 3] {
    let (b, _) = strain_displacement(&mesh.triangle_points(e));
    let dofs = element_dofs(&mesh.triangles.get(e));
    let mut eps = [0.0; 3];
    for r in 0..3 {
        eps[r] = (0..6).map(|c| b[r][c] * u(dofs[c])).sum();
    }
    let d = mat.hooke();
    [0, 1, 2].map(|r| (0..3).map(|k| d[r][k] * eps[k]).sum())
}

/// Consistent nodal forces of a traction that is linear along the edge [a, b]
/// (values `ta` at a, `tb` at b): exact integration, f_a = L/6 (2 t_a + t_b).
pub fn edge_load(pa: [f64; 2], pb: [f64; 2], ta: [f64; 2], tb: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let l = ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2)).sqrt();
    let fa = [0, 1].map(|k| l / 6.0 * (2.0 * ta[k] + tb[k]));
    let fb = [0, 1].map(|k| l / 6.0 * (ta[k] + 2.0 * tb[k]));
    (fa, fb)
}

/// A square sparse matrix in compressed rows (PETSc's 32-bit indices).
#[derive(Clone, Debug)]
pub struct Csr {
    pub row_ptr: Vec<i32>,
    pub cols: Vec<i32>,
    pub vals: Vec<f64>,
}

impl Csr {
    pub fn rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// y = A x.
    pub fn matvec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.rows())
            .map(|r| {
                let (s, e) = (self.row_ptr[r] as usize, self.row_ptr[r + 1] as usize);
                (s..e)
                    .map(|k| self.vals[k] * x[self.cols[k] as usize])
                    .sum()
            })
            .collect()
    }

    /// Mean of the diagonal (the scale used for eliminated Dirichlet rows).
    pub fn diag_mean(&self) -> f64 {
        let mut s = 0.0;
        for r in 0..self.rows() {
            let (a, b) = (self.row_ptr[r] as usize, self.row_ptr[r + 1] as usize);
            s += (a..b)
                .filter(|&k| self.cols[k] as usize == r)
                .map(|k| self.vals[k])
                .sum::<f64>();
        }
        s / self.rows() as f64
    }
}

/// Assemble the global stiffness of a mesh (all dofs, no boundary conditions).
pub fn assemble_stiffness(mesh: &Mesh, mat: &Material) -> Csr {
    let nb = mesh.node_neighbours();
    let ndof = mesh.num_dofs();
    let mut row_ptr = Vec::with_capacity(ndof + 1);
    row_ptr.push(0i32);
    let mut cols = Vec::new();
    for (node, list) in nb.iter().enumerate() {
        for _comp in 0..2 {
            for &m in list {
                cols.push((2 * m) as i32);
                cols.push((2 * m + 1) as i32);
            }
            row_ptr.push(cols.len() as i32);
        }
        let _ = node;
    }
    let mut vals = vec![0.0; cols.len()];
    for e in 0..mesh.triangles.len() {
        let ke = element_stiffness(&mesh.triangle_points(e), mat);
        let dofs = element_dofs(&mesh.triangles.get(e));
        for r in 0..6 {
            let row = dofs[r];
            let (s, t) = (row_ptr[row] as usize, row_ptr[row + 1] as usize);
            let slice = &cols[s..t];
            for c in 0..6 {
                let k = slice
                    .binary_search(&(dofs[c] as i32))
                    .expect("pattern holds the element");
                vals[s + k] += ke[r][c];
            }
        }
    }
    Csr {
        row_ptr,
        cols,
        vals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEEL: Material = Material {
        young: 210e9,
        poisson: 0.27,
    };

    /// A uniform strain ε_xx = s on a 2 × 1 rectangle: a(u, u) = |Ω| C₁₁ s²; a rigid motion
    /// has none.
    #[test]
    fn energy_of_a_uniform_strain_by_hand() {
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 4, 3);
        let s = 1e-3;
        let mut u = vec![0.0; mesh.num_dofs()];
        for (i, p) in mesh.points.iter().enumerate() {
            u[2 * i] = s * p[0];
        }
        let want = 2.0 * STEEL.hooke()[0][0] * s * s;
        let got = energy_squared(&mesh, &STEEL, &u);
        assert!((got - want).abs() < 1e-12 * want, "{got} against {want}");
        let rigid: Vec<f64> = mesh
            .points
            .iter()
            .flat_map(|p| [3e-3 - 1e-3 * p[1], 1e-3 + 1e-3 * p[0]])
            .collect();
        assert!(energy_squared(&mesh, &STEEL, &rigid) < 1e-12 * want);
    }

    #[test]
    fn plane_strain_modulus_by_hand() {
        // 210e9 / (1 − 0.27²) = 210e9 / 0.9271.
        let e = STEEL.plane_strain_modulus();
        assert!((e - 2.2651278179268686e11).abs() < 1e-15 * e, "{e}");
    }

    #[test]
    fn stiffness_of_unit_right_triangle_by_hand() {
        // Triangle (0,0), (1,0), (0,1) with E = 1, ν = 0: K = diag(1, 1, 1/2), area 1/2.
        // B rows: εxx = [-1 0 1 0 0 0], εyy = [0 -1 0 0 0 1], γxy = [-1 -1 0 1 1 0].
        // K_e = ½ (B_xxᵀB_xx + B_yyᵀB_yy + ½ B_xyᵀB_xy).
        let m = Material {
            young: 1.0,
            poisson: 0.0,
        };
        let ke = element_stiffness(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &m);
        let expect = [
            [0.75, 0.25, -0.5, -0.25, -0.25, 0.0],
            [0.25, 0.75, 0.0, -0.25, -0.25, -0.5],
            [-0.5, 0.0, 0.5, 0.0, 0.0, 0.0],
            [-0.25, -0.25, 0.0, 0.25, 0.25, 0.0],
            [-0.25, -0.25, 0.0, 0.25, 0.25, 0.0],
            [0.0, -0.5, 0.0, 0.0, 0.0, 0.5],
        ];
        for r in 0..6 {
            for c in 0..6 {
                assert!(
                    (ke[r][c] - expect[r][c]).abs() < 1e-15,
                    "K[{r}][{c}] = {}",
                    ke[r][c]
                );
            }
        }
    }

    #[test]
    fn rigid_modes_are_in_the_kernel() {
        let p = [[0.1, 0.2], [0.9, 0.3], [0.4, 1.1]];
        let ke = element_stiffness(&p, &STEEL);
        let modes: [[f64; 6]; 3] = [
            [1.0, 0.0, 1.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
            [-p[0][1], p[0][0], -p[1][1], p[1][0], -p[2][1], p[2][0]],
        ];
        for m in &modes {
            for row in &ke {
                let f: f64 = row.iter().zip(m).map(|(k, v)| k * v).sum();
                assert!(f.abs() < 1e-4, "rigid mode force {f}"); // entries ~1e11
            }
        }
    }

    #[test]
    fn plane_strain_hooke_and_compliance_are_inverse() {
        let s = [3.0e6, -1.2e7, 4.0e5];
        let d = STEEL.hooke();
        // ε from compliance energy gradient: check ½σ:ε with ε = K⁻¹σ by solving Kε = σ.
        let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
        let exx = (d[1][1] * s[0] - d[0][1] * s[1]) / det;
        let eyy = (d[0][0] * s[1] - d[1][0] * s[0]) / det;
        let gxy = s[2] / d[2][2];
        let w = 0.5 * (s[0] * exx + s[1] * eyy + s[2] * gxy);
        assert!((STEEL.compliance_energy(&s) - w).abs() < 1e-12 * w.abs());
    }

    #[test]
    fn assembled_patch_reproduces_linear_field_forces() {
        // K u for a uniform strain field: interior rows vanish (P1 patch test).
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], 4, 4);
        let k = assemble_stiffness(&mesh, &STEEL);
        let u: Vec<f64> = mesh
            .points
            .iter()
            .flat_map(|p| [1e-4 * p[0] + 2e-5 * p[1], -3e-5 * p[1]])
            .collect();
        let f = k.matvec(&u);
        let scale = k.diag_mean() * 1e-4;
        for j in 1..4 {
            for i in 1..4 {
                let n = mesh.node(i, j);
                assert!(f[2 * n].abs() < 1e-12 * scale && f[2 * n + 1].abs() < 1e-12 * scale);
            }
        }
        let sum: f64 = k.vals.iter().sum::<f64>();
        assert!(
            sum.abs() < 1e-6 * k.diag_mean(),
            "rows of a free stiffness sum to rigid forces 0"
        );
    }

    #[test]
    fn linear_edge_load_is_exact() {
        // t = (0, 1 - s) on an edge of length 2: total force 1, moment about a: ∫ s(1 - s/2)...
        let (fa, fb) = edge_load([0.0, 0.0], [0.0, 2.0], [0.0, 1.0], [0.0, 0.0]);
        assert!((fa[1] + fb[1] - 1.0).abs() < 1e-15);
        assert!((fa[1] - 2.0 / 3.0).abs() < 1e-15 && (fb[1] - 1.0 / 3.0).abs() < 1e-15);
    }
}
