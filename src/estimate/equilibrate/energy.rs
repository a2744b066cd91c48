//! Complementary energy Σ_E ‖σ̂ − σ̃_h‖²_{K⁻¹,E} and the `Recovery::Star` star choice: the
//! star null-space parameters minimising it (sparse SPD system, Jacobi-preconditioned
//! conjugate gradients).

use super::eet::Stars;
use super::johnson_mercier::{apply_operator, eval, midpoint_values, midpoints, ShapeCache};
use super::sizes::{NC, NT};
use super::topology::{is_owned, Topology};
use crate::fem::geometry::{local_frame, triangle_area};
use crate::fem::mesh::Mesh;
use crate::fem::Material;

pub(super) fn compliance(material: &Material) -> [[f64; 3]; 3] {
    let (e, nu) = (material.young, material.poisson);
    let k = (1.0 + nu) / e;
    [
        [k * (1.0 - nu), -k * nu, 0.0],
        [-k * nu, k * (1.0 - nu), 0.0],
        [0.0, 0.0, 2.0 * k],
    ]
}

/// Σ_E ‖σ̂ − σ̃_E‖²_{K⁻¹,E} over the owned elements (all without restriction).
pub(super) fn total_energy(
    mesh: &Mesh,
    material: &Material,
    coef: &[[f64; NC]],
    sig: &[[f64; 3]],
    owned: Option<&[bool]>,
) -> f64 {
    let cm = compliance(material);
    let mut sum = 0.0;
    for e in (0..coef.len()).filter(|&e| is_owned(owned, e)) {
        let p = mesh.triangle_points(e);
        let (_, _, q) = local_frame(&p);
        let w = triangle_area(&p) / 9.0;
        for a in 0..3 {
            for pt in midpoints(&q, a) {
                let s = eval(&coef[e], a, pt);
                let d = [s[0] - sig[e][0], s[1] - sig[e][1], s[2] - sig[e][2]];
                sum += w * quad(&cm, &d, &d);
            }
        }
    }
    sum
}

pub(super) fn quad(cm: &[[f64; 3]; 3], a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let mut s = 0.0;
    for r in 0..3 {
        for c in 0..3 {
            s += a[r] * cm[r][c] * b[c];
        }
    }
    s
}

pub(super) struct EnergyContext<'a> {
    pub(super) mesh: &'a Mesh,
    pub(super) material: &'a Material,
    pub(super) topo: &'a Topology,
    pub(super) stars: &'a Stars,
    pub(super) sig: &'a [[f64; 3]],
    pub(super) coef: &'a [[f64; NC]],
    pub(super) shape_of: &'a [usize],
}

impl EnergyContext<'_> {
    /// Minimise Σ_E ‖σ̂(θ) − σ̃_E‖² over the star null-space parameters θ: assemble the SPD
    /// Hessian H and gradient g (σ̂ is affine in θ) and solve H θ = −g by Jacobi-PCG.
    pub(super) fn minimise(
        &self,
        cache: &mut ShapeCache,
        max_iterations: usize,
        tolerance: f64,
    ) -> (Vec<f64>, usize) {
        let mesh = self.mesh;
        let nn = mesh.num_nodes();
        let stars = self.stars;
        // Parameter numbering: by star 2 i + k, then null-vector index.
        let mut pptr = vec![0usize; 2 * nn + 1];
        for s in 0..2 * nn {
            pptr[s + 1] = pptr[s] + stars.op_of(s).nnull;
        }
        let np = pptr[2 * nn];
        // Sparsity: parameters of stars at neighbouring vertices.
        let nb = mesh.node_neighbours();
        let mut row_ptr = vec![0usize; np + 1];
        let mut cols: Vec<usize> = Vec::new();
        for s in 0..2 * nn {
            for p in pptr[s]..pptr[s + 1] {
                for &j in &nb[s / 2] {
                    cols.extend(pptr[2 * j]..pptr[2 * j + 2]);
                }
                row_ptr[p + 1] = cols.len();
            }
        }
        let mut vals = vec![0.0; cols.len()];
        let mut grad = vec![0.0; np];
        let cm = compliance(self.material);
        let mut plist: Vec<usize> = Vec::new();
        let mut dts: Vec<[f64; NT]> = Vec::new();
        let mut pv: Vec<[[f64; 3]; 9]> = Vec::new();
        for e in 0..mesh.triangles.len() {
            let tri = mesh.triangles.get(e);
            let pts = mesh.triangle_points(e);
            let (_, _, q) = local_frame(&pts);
            let w = triangle_area(&pts) / 9.0;
            plist.clear();
            dts.clear();
            for &i in &tri {
                for k in 0..2 {
                    let s = 2 * i + k;
                    let op = stars.op_of(s);
                    let cs = stars.cols(s);
                    for jn in 0..op.nnull {
                        let nu = &op.null[jn * cs.len()..(jn + 1) * cs.len()];
                        let mut dt = [0.0; NT];
                        for (c, &g) in cs.iter().enumerate() {
                            let g = g as usize;
                            let Some(l) = self.topo.edges_of(e).iter().position(|&x| x == g) else {
                                continue;
                            };
                            let len = self.topo.edge_len[g];
                            let sg = self.topo.sign(e, g);
                            let pos_i = if tri[l] == i { 0 } else { 1 };
                            dt[4 * l + 2 * pos_i + k] += sg * 4.0 / len * nu[c];
                            dt[4 * l + 2 * (1 - pos_i) + k] -= sg * 2.0 / len * nu[c];
                        }
                        plist.push(pptr[s] + jn);
                        dts.push(dt);
                    }
                }
            }
            if plist.is_empty() {
                continue;
            }
            let gop = cache.operator(self.shape_of[e], &q);
            pv.clear();
            // Point values at the 9 quadrature points: the current σ̂ − σ̃, then each
            // parameter direction.
            let mut x0 = self.coef[e];
            for a in 0..3 {
                for r in 0..3 {
                    x0[9 * a + 3 * r] -= self.sig[e][r];
                }
            }
            let values = |x: &[f64; NC]| midpoint_values(&q, x);
            pv.push(values(&x0));
            for dt in &dts {
                pv.push(values(&apply_operator(gop, dt)));
            }
            let inner = |u: &[[f64; 3]; 9], v: &[[f64; 3]; 9]| -> f64 {
                w * (0..9).map(|m| quad(&cm, &u[m], &v[m])).sum::<f64>()
            };
            for (ia, &pa) in plist.iter().enumerate() {
                grad[pa] += inner(&pv[ia + 1], &pv[0]);
                let row = &cols[row_ptr[pa]..row_ptr[pa + 1]];
                for (ib, &pb) in plist.iter().enumerate() {
                    let pos = row.binary_search(&pb).expect("pattern holds the element");
                    vals[row_ptr[pa] + pos] += inner(&pv[ia + 1], &pv[ib + 1]);
                }
            }
        }
        // Solve H θ = −g.
        let matvec = |x: &[f64], y: &mut [f64]| {
            for r in 0..np {
                y[r] = (row_ptr[r]..row_ptr[r + 1])
                    .map(|k| vals[k] * x[cols[k]])
                    .sum();
            }
        };
        let diag: Vec<f64> = (0..np)
            .map(|r| {
                let k = row_ptr[r] + cols[row_ptr[r]..row_ptr[r + 1]].binary_search(&r).unwrap();
                vals[k]
            })
            .collect();
        let mut theta = vec![0.0; np];
        let mut res: Vec<f64> = grad.iter().map(|g| -g).collect();
        let r0 = norm(&res);
        if r0 == 0.0 {
            return (theta, 0);
        }
        let mut z: Vec<f64> = res.iter().zip(&diag).map(|(r, d)| r / d).collect();
        let mut p = z.clone();
        let mut hp = vec![0.0; np];
        let mut rz = dotv(&res, &z);
        let mut its = 0;
        while its < max_iterations && norm(&res) > tolerance * r0 {
            matvec(&p, &mut hp);
            let alpha = rz / dotv(&p, &hp);
            for i in 0..np {
                theta[i] += alpha * p[i];
                res[i] -= alpha * hp[i];
            }
            for i in 0..np {
                z[i] = res[i] / diag[i];
            }
            let rz_new = dotv(&res, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..np {
                p[i] = z[i] + beta * p[i];
            }
            its += 1;
        }
        (theta, its)
    }
}

pub(super) fn dotv(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(super) fn norm(a: &[f64]) -> f64 {
    dotv(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::equilibrate::johnson_mercier::traction;
    use crate::estimate::equilibrate::testutil::*;
    use crate::estimate::equilibrate::{equilibrate_with, Boundary, Recovery};
    use crate::fem;

    /// P1 interpolation of a coarse structured field onto a nested finer mesh.
    fn interpolate(coarse: &Mesh, uc: &[f64], fine: &Mesh) -> Vec<f64> {
        let r = fine.nx / coarse.nx;
        let mut out = vec![0.0; fine.num_dofs()];
        for jj in 0..=fine.ny {
            for ii in 0..=fine.nx {
                let i = (ii / r).min(coarse.nx - 1);
                let j = (jj / r).min(coarse.ny - 1);
                let s = (ii - i * r) as f64 / r as f64;
                let t = (jj - j * r) as f64 / r as f64;
                let (a, b) = (coarse.node(i, j), coarse.node(i + 1, j));
                let (c, d) = (coarse.node(i, j + 1), coarse.node(i + 1, j + 1));
                let n = fine.node(ii, jj);
                for k in 0..2 {
                    let v = |m: usize| uc[2 * m + k];
                    out[2 * n + k] = if t <= s {
                        v(a) + s * (v(b) - v(a)) + t * (v(d) - v(b))
                    } else {
                        v(a) + t * (v(c) - v(a)) + s * (v(d) - v(c))
                    };
                }
            }
        }
        out
    }

    /// Energy-norm effectivities η/e for the star choices [averaged, minimum energy] and
    /// patch relaxation with 1, 3 and 10 sweeps.
    fn effectivities(mesh: &Mesh, bd: &Boundary, u: &[f64], e: f64) -> Vec<f64> {
        let mut choices = vec![Recovery::Eet, Recovery::star()];
        choices.extend([1, 3, 10].map(|sweeps| Recovery::PatchClassic { sweeps }));
        let mut out = Vec::new();
        for choice in choices {
            let eq = equilibrate_with(mesh, &STEEL, u, bd, choice).unwrap();
            assert_admissible(&eq.residuals(mesh, bd), 1e-10);
            let eta2: f64 = eq.cre_map(mesh, &STEEL, u).iter().sum();
            assert!(
                eta2.sqrt() >= e,
                "{choice:?}: η = {} < e = {e}",
                eta2.sqrt()
            );
            out.push(eta2.sqrt() / e);
        }
        // What theory guarantees: the star minimum and any relaxation sweep lower η below the
        // averaged choice, and every further sweep lowers it.
        let le = |a: f64, b: f64| a <= b * (1.0 + 1e-12);
        assert!(le(out[1], out[0]) && le(out[2], out[0]), "{out:?}");
        assert!(le(out[3], out[2]) && le(out[4], out[3]), "{out:?}");
        out
    }

    #[test]
    fn prager_synge_bound_and_effectivity() {
        println!("   n  fine  e_ref        eff: averaged  star-min  patch×1  patch×3  patch×10");
        for (n, r) in [(2, 8), (4, 8), (8, 8), (16, 4)] {
            let (mc, bc) = block(n);
            let uc = fe_solve(&mc, &bc);
            let (mf, bf) = block(n * r);
            let uf = fe_solve(&mf, &bf);
            let iu = interpolate(&mc, &uc, &mf);
            let err: Vec<f64> = uf.iter().zip(&iu).map(|(a, b)| a - b).collect();
            let kf = fem::assemble_stiffness(&mf, &STEEL);
            let e_ref = dotv(&err, &kf.matvec(&err)).sqrt();
            let eff = effectivities(&mc, &bc, &uc, e_ref);
            println!(
                "{n:4} {:5}  {e_ref:.5e}       {:.4}    {:.4}    {:.4}   {:.4}   {:.4}",
                n * r,
                eff[0],
                eff[1],
                eff[2],
                eff[3],
                eff[4]
            );
            assert!(
                eff[3] < 1.25,
                "patch relaxation (3 sweeps): effectivity {}",
                eff[3]
            );
        }
    }

    /// A smooth problem with a known exact solution: the linear, divergence-free stress
    /// σ = (1e7 (y − ½), 5e6 (x − ½) − 3e6 y, 3e6 x) on the unit square, its (linear) tractions
    /// on all four sides, three pinned dofs. The exact energy error of u_h is
    /// ‖σ − σ_h‖_{K⁻¹} (quadratic integrand, exact quadrature), so η / e is the exact
    /// effectivity.
    #[test]
    fn smooth_problem_effectivity() {
        let sigma = |x: [f64; 2]| {
            [
                1e7 * (x[1] - 0.5),
                5e6 * (x[0] - 0.5) - 3e6 * x[1],
                3e6 * x[0],
            ]
        };
        println!("   n  e_exact      eff: averaged  star-min  patch×1  patch×3  patch×10");
        for n in [2, 4, 8, 16, 32] {
            let (mesh, mut bd) = patch(n, [0.0; 3]);
            for be in &mut bd.edges {
                let [a, b] = be.nodes;
                let (pa, pb) = (mesh.points.get(a), mesh.points.get(b));
                let tv = [pb[0] - pa[0], pb[1] - pa[1]];
                let len = tv[0].hypot(tv[1]);
                // Outward normal: the edge lies on the boundary of the unit square.
                let mid = [0.5 * (pa[0] + pb[0]) - 0.5, 0.5 * (pa[1] + pb[1]) - 0.5];
                let mut nrm = [tv[1] / len, -tv[0] / len];
                if nrm[0] * mid[0] + nrm[1] * mid[1] < 0.0 {
                    nrm = [-nrm[0], -nrm[1]];
                }
                let (ta, tb) = (traction(&sigma(pa), nrm), traction(&sigma(pb), nrm));
                be.comps = [known(ta[0], tb[0]), known(ta[1], tb[1])];
            }
            let u = fe_solve(&mesh, &bd);
            let mut e2 = 0.0;
            for e in 0..mesh.triangles.len() {
                let p = mesh.triangle_points(e);
                let sh = fem::element_stress(&mesh, e, &STEEL, &u);
                for a in 0..3 {
                    let b = (a + 1) % 3;
                    let m = [0.5 * (p[a][0] + p[b][0]), 0.5 * (p[a][1] + p[b][1])];
                    let s = sigma(m);
                    let d = [s[0] - sh[0], s[1] - sh[1], s[2] - sh[2]];
                    e2 += 2.0 * STEEL.compliance_energy(&d) * triangle_area(&p) / 3.0;
                }
            }
            let eff = effectivities(&mesh, &bd, &u, e2.sqrt());
            println!(
                "{n:4}  {:.5e}       {:.4}    {:.4}    {:.4}   {:.4}   {:.4}",
                e2.sqrt(),
                eff[0],
                eff[1],
                eff[2],
                eff[3],
                eff[4]
            );
            assert!(
                eff[3] < 1.2,
                "patch relaxation (3 sweeps): effectivity {}",
                eff[3]
            );
        }
    }
}
