//! Evaluation of an [`EquilibratedStress`] (point values, coefficients, CRE) and its
//! equilibrium check ([`Residuals`]).

use super::boundary::Boundary;
use super::eet::{edge_conditions, element_tractions, Bc, EdgeConditions};
use super::energy::quad;
use super::johnson_mercier::{apply_operator, eval, midpoints, traction, ShapeCache};
use super::sizes::{NC, NONE};
use super::topology::{is_owned, owned_vertices, Topology};
use crate::fem::geometry::{barycentric, local_frame, triangle_area, unit};
use crate::fem::mesh::Mesh;
use crate::fem::{self, Material};

/// Equilibrium check of an [`EquilibratedStress`]; every entry is relative to max |σ̂| (the
/// boundary entry to max(|σ̂|, |g|); the star entries to the largest element nodal force).
#[derive(Clone, Copy, Debug, Default)]
pub struct Residuals {
    /// max |div σ̂| × element diameter, over every sub-triangle.
    pub divergence: f64,
    /// Traction jumps across the 3 internal edges of every element (at their end points).
    pub internal_jump: f64,
    /// Traction jumps across every inter-element edge (at its end points).
    pub element_jump: f64,
    /// σ̂n − g on every Known boundary component (at the end points).
    pub boundary: f64,
    /// Largest least-squares residual of a point-constraint star (a constrained dof whose
    /// star has no free edge component): the point reaction, relative.
    pub point_reaction: f64,
}

/// The largest relative equilibrium residual under which the recovered stresses count as
/// admissible: round-off on well-shaped meshes is below 1e−9 (docs/results.md); a triangle
/// near the relative area 1e−4 the mesh checks accept (`fem::checks::MIN_QUALITY`) on the
/// boundary leaves 1e−5 to 1e−4 (`tests/estimates.rs`).
pub const ADMISSIBLE: f64 = 1e-6;

impl Residuals {
    /// The largest of the field residuals (divergence, jumps, boundary) and the point
    /// reaction.
    pub fn max(&self) -> f64 {
        self.divergence
            .max(self.internal_jump)
            .max(self.element_jump)
            .max(self.boundary)
            .max(self.point_reaction)
    }

    /// The larger of each residual of `self` and `other`.
    pub fn worst(self, other: Residuals) -> Residuals {
        Residuals {
            divergence: self.divergence.max(other.divergence),
            internal_jump: self.internal_jump.max(other.internal_jump),
            element_jump: self.element_jump.max(other.element_jump),
            boundary: self.boundary.max(other.boundary),
            point_reaction: self.point_reaction.max(other.point_reaction),
        }
    }

    /// The warning that the recovered stresses are not admissible to round-off (above
    /// [`ADMISSIBLE`]): η^glo then bounds the error only up to that defect.
    pub fn warning(&self) -> Option<String> {
        let r = self.max();
        (r > ADMISSIBLE).then(|| {
            format!(
                "the estimates' recovered stresses are equilibrated to {r:.1e} only (their largest relative equilibrium residual, the summary's equilibrium_residuals; round-off is below 1e-9 on well-shaped meshes, {ADMISSIBLE:e} is accepted): eta_glo bounds the error only up to that defect. Triangles near the relative area 1e-4 the mesh checks accept cause it, on the boundary most: remesh them"
            )
        })
    }
}

/// Figures of the construction.
#[derive(Clone, Copy, Debug, Default)]
pub struct EquilibrationStats {
    /// Number of star free parameters (null-space directions of the star problems).
    pub star_parameters: usize,
    /// Distinct triangle shapes met (cached local operators).
    pub shapes: usize,
    /// Conjugate-gradient iterations of `Recovery::Star` (0 otherwise).
    pub cg_iterations: usize,
    /// Σ_E ‖σ̂ − σ̃_h‖²_{K⁻¹} with the averaged-traction choice (NaN with `Recovery::Patch`,
    /// which does not build that field).
    pub energy_averaged: f64,
    /// The same after the minimisation (= `energy_averaged` for `Recovery::Eet`).
    pub energy_final: f64,
    /// Distinct vertex-patch operators of `Recovery::PatchClassic` (0 otherwise).
    pub patch_patterns: usize,
    /// Largest residual of the star problems at unconstrained dofs, relative to the largest
    /// element nodal force: the FE equilibrium defect of the input (round-off for an
    /// FE-equilibrated ũ). A large value means the input was not FE-equilibrated and σ̂ is
    /// not admissible (which `Residuals::element_jump`/`boundary` then show too).
    pub fe_equilibrium: f64,
}

/// The equilibrated stress: per element, the JM coefficients (3 sub-triangles × (xx, yy, xy)
/// × (1, ξ, η)) in the local frame ξ = (x − barycentre) / diameter. Sub-triangle a is
/// (barycentre, p_a, p_{a+1}) of the element's vertices p.
#[derive(Clone, Debug)]
pub struct EquilibratedStress {
    pub(super) coef: Vec<[f64; NC]>,
    /// Per constrained star (vertex, relative least-squares residual): the point reactions.
    pub(super) reactions: Vec<(usize, f64)>,
    pub(super) stats: EquilibrationStats,
    /// The equilibrium check made by the construction (on the owned elements).
    pub(super) checked: Residuals,
}

/// ∫_E (σ̂ − τ) : K⁻¹ : (σ̂ − τ) of the JM field `coef` of element e and a constant stress τ
/// (Voigt), plane-strain compliance: exact quadrature (quadratic integrand per
/// sub-triangle, edge-midpoint rule).
pub fn element_cre(
    mesh: &Mesh,
    e: usize,
    coef: &[f64; NC],
    tau: [f64; 3],
    material: &Material,
) -> f64 {
    element_cre_varying(mesh, e, coef, &|_| tau, material)
}

/// [`element_cre`] with a stress τ(x) linear in the point x (still exact).
pub fn element_cre_varying(
    mesh: &Mesh,
    e: usize,
    coef: &[f64; NC],
    tau: &dyn Fn([f64; 2]) -> [f64; 3],
    material: &Material,
) -> f64 {
    let p = mesh.triangle_points(e);
    let (c, h, qv) = local_frame(&p);
    let area = triangle_area(&p);
    let mut sum = 0.0;
    for a in 0..3 {
        for pt in midpoints(&qv, a) {
            let s = eval(coef, a, pt);
            let t = tau([c[0] + h * pt[0], c[1] + h * pt[1]]);
            let dlt = [s[0] - t[0], s[1] - t[1], s[2] - t[2]];
            sum += 2.0 * material.compliance_energy(&dlt);
        }
    }
    sum * area / 9.0
}

/// Of one element's JM field `x` (local vertices `qv`): max |σ̂| at the sub-triangles'
/// vertices, the largest divergence and the largest traction jump across the three internal
/// edges (at their ends; exact for the linear fields).
fn field_checks(x: &[f64; NC], qv: &[[f64; 2]; 3]) -> [f64; 3] {
    let (mut smax, mut div, mut jin): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for a in 0..3 {
        for pt in [[0.0, 0.0], qv[a], qv[(a + 1) % 3]] {
            for v in eval(x, a, pt) {
                smax = smax.max(v.abs());
            }
        }
        let o = 9 * a;
        div = div.max((x[o + 1] + x[o + 8]).abs());
        div = div.max((x[o + 7] + x[o + 5]).abs());
        // Internal edge from the barycentre to q_a, between sub-triangles a−1 and a.
        let n = unit([qv[a][1], -qv[a][0]]);
        for pt in [[0.0, 0.0], qv[a]] {
            let t1 = traction(&eval(x, a, pt), n);
            let t0 = traction(&eval(x, (a + 2) % 3, pt), n);
            jin = jin.max((t1[0] - t0[0]).abs()).max((t1[1] - t0[1]).abs());
        }
    }
    [smax, div, jin]
}

/// The data of the final pass over the elements ([`final_pass`]).
pub(super) struct FinalPass<'a> {
    pub(super) mesh: &'a Mesh,
    pub(super) topo: &'a Topology,
    pub(super) bc: &'a EdgeConditions,
    /// The edge tractions the fields are built from.
    pub(super) trac: &'a [[[f64; 2]; 2]],
    pub(super) shape_of: &'a [usize],
    /// The FE stresses σ̃ and the compliance (for the complementary energy).
    pub(super) sig: &'a [[f64; 3]],
    pub(super) cm: [[f64; 3]; 3],
    pub(super) owned: Option<&'a [bool]>,
}

impl FinalPass<'_> {
    /// Every element's JM field from its edge tractions, handed to `out` (the caller stores
    /// it or uses it at once: the estimator keeps no coefficients), with, over
    /// the owned elements, the complementary energy Σ_E ‖σ̂ − σ̃_E‖²_{K⁻¹,E} and the
    /// equilibrium check (relative to max |σ̂|; boundary terms to max(|σ̂|, |g|); the point
    /// reactions are the caller's): divergence and internal traction jumps of each field,
    /// and at both ends of each of its edges the defect of its traction σ̂ n against the
    /// edge traction it was built from (which the element across the edge shares, so the
    /// inter-element jump is at most twice the largest defect, `element_jump`) or against
    /// the boundary data.
    pub(super) fn run(
        &self,
        cache: &mut ShapeCache,
        mut out: impl FnMut(usize, &[f64; NC]),
    ) -> (f64, Residuals) {
        let (mesh, topo) = (self.mesh, self.topo);
        let mut energy = 0.0;
        let (mut smax, mut div, mut jin, mut side, mut jb, mut gmax) =
            (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for e in 0..mesh.triangles.len() {
            let p = mesh.triangle_points(e);
            let (c, h, qv) = local_frame(&p);
            let t = element_tractions(topo, self.trac, mesh, e);
            let x = apply_operator(cache.operator(self.shape_of[e], &qv), &t);
            if is_owned(self.owned, e) {
                let w = triangle_area(&p) / 9.0;
                let sig = self.sig[e];
                for a in 0..3 {
                    for pt in midpoints(&qv, a) {
                        let s = eval(&x, a, pt);
                        let d = [s[0] - sig[0], s[1] - sig[1], s[2] - sig[2]];
                        energy += w * quad(&self.cm, &d, &d);
                    }
                }
                let [m, d, j] = field_checks(&x, &qv);
                (smax, div, jin) = (smax.max(m), div.max(d), jin.max(j));
                // Edge l is the outer edge of sub-triangle l.
                for l in 0..3 {
                    let g = topo.edges_of(e)[l];
                    let n = topo.normal(mesh, g);
                    let interior = topo.elems(g)[1] != NONE;
                    for (end, node) in topo.nodes(g).into_iter().enumerate() {
                        let xp = mesh.points.get(node);
                        let tr =
                            traction(&eval(&x, l, [(xp[0] - c[0]) / h, (xp[1] - c[1]) / h]), n);
                        for k in 0..2 {
                            if interior {
                                side = side.max((tr[k] - self.trac[g][end][k]).abs());
                            } else if let Bc::Known(v) = self.bc[g][k] {
                                gmax = gmax.max(v[end].abs());
                                jb = jb.max((tr[k] - v[end]).abs());
                            }
                        }
                    }
                }
            }
            out(e, &x);
        }
        let smax = if smax > 0.0 { smax } else { 1.0 };
        let residuals = Residuals {
            divergence: div / smax,
            internal_jump: jin / smax,
            element_jump: 2.0 * side / smax,
            boundary: jb / gmax.max(smax),
            point_reaction: 0.0,
        };
        (energy, residuals)
    }
}

impl EquilibratedStress {
    /// σ̂ (Voigt xx, yy, xy) at a point of element e (evaluated with the polynomial of the
    /// sub-triangle containing it; points outside the element use the nearest sub-triangle's
    /// polynomial).
    pub fn stress_at(&self, mesh: &Mesh, e: usize, x: [f64; 2]) -> [f64; 3] {
        let p = mesh.triangle_points(e);
        let (c, h, _) = local_frame(&p);
        let lam = barycentric(&p, x);
        // Sub-triangle a = (barycentre, p_a, p_{a+1}) is where λ_{a+2} is the smallest.
        let mut a = 0;
        let mut lmin = lam[2];
        for b in 1..3 {
            if lam[(b + 2) % 3] < lmin {
                lmin = lam[(b + 2) % 3];
                a = b;
            }
        }
        eval(&self.coef[e], a, [(x[0] - c[0]) / h, (x[1] - c[1]) / h])
    }

    /// σ̂ in sub-triangle `sub` (0..3, the one on the element's edge `sub`) at point x.
    pub fn sub_stress_at(&self, mesh: &Mesh, e: usize, sub: usize, x: [f64; 2]) -> [f64; 3] {
        let (c, h, _) = local_frame(&mesh.triangle_points(e));
        eval(&self.coef[e], sub, [(x[0] - c[0]) / h, (x[1] - c[1]) / h])
    }

    /// The 27 JM coefficients of element e (sub-triangle a, component r, monomial m at
    /// 9a + 3r + m; monomials 1, ξ, η with ξ = (x − barycentre)/diameter).
    pub fn coefficients(&self, e: usize) -> &[f64; NC] {
        &self.coef[e]
    }

    /// ∫_E (σ̂ − τ) : K⁻¹ : (σ̂ − τ) for a constant stress τ (Voigt), plane-strain compliance:
    /// exact quadrature (quadratic integrand per sub-triangle, edge-midpoint rule).
    pub fn cre_squared(&self, mesh: &Mesh, e: usize, tau: [f64; 3], material: &Material) -> f64 {
        element_cre(mesh, e, &self.coef[e], tau, material)
    }

    /// Per element ∫_E (σ̂ − Kε(u)) : K⁻¹ : (σ̂ − Kε(u)): the CRE map of the pair (u, σ̂).
    pub fn cre_map(&self, mesh: &Mesh, material: &Material, u: &[f64]) -> Vec<f64> {
        (0..mesh.triangles.len())
            .map(|e| self.cre_squared(mesh, e, fem::element_stress(mesh, e, material, u), material))
            .collect()
    }

    /// The equilibrium check the construction made with its own topology and boundary
    /// codes: [`Self::residuals_restricted`] with its restriction's owned elements.
    pub fn checked_residuals(&self) -> Residuals {
        self.checked
    }

    /// Figures of the construction (star parameters, shapes, energies).
    pub fn stats(&self) -> EquilibrationStats {
        self.stats
    }

    /// Equilibrium check, relative to max |σ̂| (boundary terms to max(|σ̂|, |g|)).
    /// Every term is evaluated at the end points of the edges concerned, which is exact for
    /// the linear tractions (and the divergence is constant per sub-triangle).
    pub fn residuals(&self, mesh: &Mesh, boundary: &Boundary) -> Residuals {
        self.residuals_restricted(mesh, boundary, None)
    }

    /// [`Self::residuals`] restricted to the owned elements of a sub-mesh (see
    /// [`Restriction`](super::Restriction); None: every element): divergence, internal
    /// jumps and max |σ̂| over the owned elements; inter-element jumps over the edges with
    /// both elements in the mesh and at least one owned; boundary data over the boundary
    /// edges of owned elements (with at least one ring of overlap these are real boundary
    /// edges, never the artificial boundary of the sub-mesh); point reactions of the
    /// constrained stars at vertices of owned elements. The maximum over the ranks bounds
    /// the full-mesh check (each rank's scale is at most the full-mesh one).
    ///
    /// Panics if `owned` does not have one entry per element.
    pub fn residuals_restricted(
        &self,
        mesh: &Mesh,
        boundary: &Boundary,
        owned: Option<&[bool]>,
    ) -> Residuals {
        if let Some(o) = owned {
            assert_eq!(
                o.len(),
                mesh.triangles.len(),
                "`owned`: one entry per element"
            );
        }
        let Ok(topo) = Topology::new(mesh) else {
            return Residuals {
                divergence: f64::INFINITY,
                ..Residuals::default()
            };
        };
        let Ok(bc) = edge_conditions(&topo, boundary) else {
            return Residuals {
                boundary: f64::INFINITY,
                ..Residuals::default()
            };
        };
        self.residuals_with(mesh, &topo, &bc, owned)
    }

    /// [`Self::residuals_restricted`] with the mesh's topology and boundary codes at hand
    /// (the construction's own, `equilibrate_restricted`).
    pub(super) fn residuals_with(
        &self,
        mesh: &Mesh,
        topo: &Topology,
        bc: &EdgeConditions,
        owned: Option<&[bool]>,
    ) -> Residuals {
        let own = |e: usize| is_owned(owned, e);
        let vertex_owned = owned_vertices(mesh, owned);
        let point_reaction = self
            .reactions
            .iter()
            .filter(|&&(i, _)| vertex_owned.as_ref().is_none_or(|v| v[i]))
            .fold(0.0f64, |m, &(_, r)| m.max(r));
        let mut res = Residuals {
            point_reaction,
            ..Residuals::default()
        };
        let nt = mesh.triangles.len();
        // Every element's local frame, once (the edge checks evaluate both sides).
        let frames: Vec<([f64; 2], f64, [[f64; 2]; 3])> = (0..nt)
            .map(|e| local_frame(&mesh.triangle_points(e)))
            .collect();
        let edge_stress = |e: usize, g: usize, x: [f64; 2]| -> [f64; 3] {
            let (c, h, _) = frames[e];
            let sub = topo.local_edge(e, g);
            eval(&self.coef[e], sub, [(x[0] - c[0]) / h, (x[1] - c[1]) / h])
        };
        let mut smax: f64 = 0.0;
        let (mut div, mut jin): (f64, f64) = (0.0, 0.0);
        for e in (0..nt).filter(|&e| own(e)) {
            let [m, d, j] = field_checks(&self.coef[e], &frames[e].2);
            (smax, div, jin) = (smax.max(m), div.max(d), jin.max(j));
        }
        let smax = if smax > 0.0 { smax } else { 1.0 };
        res.divergence = div / smax;
        res.internal_jump = jin / smax;
        // Inter-element jumps.
        let mut jel: f64 = 0.0;
        for g in 0..topo.num_edges() {
            let [e0, e1] = topo.elems(g);
            if e1 == NONE || !(own(e0) || own(e1)) {
                continue;
            }
            let n = topo.normal(mesh, g);
            for node in topo.nodes(g) {
                let x = mesh.points.get(node);
                let t0 = traction(&edge_stress(e0, g, x), n);
                let t1 = traction(&edge_stress(e1, g, x), n);
                jel = jel.max((t1[0] - t0[0]).abs()).max((t1[1] - t0[1]).abs());
            }
        }
        res.element_jump = jel / smax;
        // Boundary data.
        let mut gmax = smax;
        let mut jb: f64 = 0.0;
        for g in 0..topo.num_edges() {
            let e0 = topo.elems(g)[0];
            if topo.elems(g)[1] != NONE || !own(e0) {
                continue;
            }
            let n = topo.normal(mesh, g);
            for (end, node) in topo.nodes(g).into_iter().enumerate() {
                let t = traction(&edge_stress(e0, g, mesh.points.get(node)), n);
                for k in 0..2 {
                    if let Bc::Known(v) = bc[g][k] {
                        gmax = gmax.max(v[end].abs());
                        jb = jb.max((t[k] - v[end]).abs());
                    }
                }
            }
        }
        res.boundary = jb / gmax;
        res
    }
}

#[cfg(test)]
mod tests {
    use crate::estimate::equilibrate::equilibrate;
    use crate::estimate::equilibrate::testutil::*;

    #[test]
    fn restricted_residuals_only_see_owned_elements() {
        // A load on top only, reacted by the three pinned dofs: large point reactions.
        let n = 4;
        let (mesh, mut bd) = patch(n, [0.0, -1e7, 0.0]);
        let top = mesh.top_nodes();
        bd.edges
            .retain(|be| top.contains(&be.nodes[0]) && top.contains(&be.nodes[1]));
        let u = fe_solve(&mesh, &bd);
        let eq = equilibrate(&mesh, &STEEL, &u, &bd).unwrap();
        let full = eq.residuals(&mesh, &bd);
        println!("unbalanced: {full:?}");
        assert!(full.point_reaction > 1e-3);
        // The elements touching a pin are not self-equilibrated (the point reaction is spread
        // over them); "away": the elements sharing no vertex with them, whose neighbours
        // across an edge are therefore exact.
        let pins = [mesh.node(0, 0), mesh.node(n, 0)];
        let mut near_pin = vec![false; mesh.num_nodes()];
        for t in mesh
            .triangles
            .iter()
            .filter(|t| t.iter().any(|v| pins.contains(v)))
        {
            t.iter().for_each(|&v| near_pin[v] = true);
        }
        let away: Vec<bool> = mesh
            .triangles
            .iter()
            .map(|t| !t.iter().any(|&v| near_pin[v]))
            .collect();
        let r = eq.residuals_restricted(&mesh, &bd, Some(&away));
        assert_eq!(r.point_reaction, 0.0, "{r:?}");
        assert_admissible(&r, 1e-10);
        let near: Vec<bool> = away.iter().map(|a| !a).collect();
        let r = eq.residuals_restricted(&mesh, &bd, Some(&near));
        assert!(r.point_reaction > 1e-3, "{r:?}");
        let none = vec![false; mesh.triangles.len()];
        assert_eq!(eq.residuals_restricted(&mesh, &bd, Some(&none)).max(), 0.0);
    }
}
