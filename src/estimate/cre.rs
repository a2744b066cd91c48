//! The constitutive relation error of one body, element by element (paper (17), (22)–(24)):
//! the admissible stresses recovered from the FE-equilibrated re-solves on the rank's view of
//! the mesh, and the element contributions to η^glo, η^FE and η^NNDD.

use std::collections::HashMap;

use super::equilibrate::{element_cre, element_cre_varying, OperatorCache, Residuals, NC};
use super::error::EstimateError;
use super::friction;
use super::iteration::{BodyFields, IterationData, Reaction};
use super::parts::{Part, Parts};
use super::polygon::{self, Bubble, BubbleTerms, EdgeValues};
use super::settings::NnddVariant;
use super::traction::Interface;
use super::view::View;
use crate::dd::displacement::Displacement;
use crate::fem::mesh::Mesh;
use crate::fem::{element_dofs, element_stiffness, element_stress_with};
use crate::problem::BodyProblem;

/// Squared element contributions of one body at one iteration, on the elements this rank
/// estimates: `glo[s]`, `fe[s]`, `nndd[s]` are element `elements[s]`'s.
#[derive(Clone, Debug, Default)]
pub struct BodyEstimate {
    /// The body's elements this rank estimates, in increasing order.
    pub elements: Vec<u32>,
    pub glo: Vec<f64>,
    pub fe: Vec<f64>,
    pub nndd: Vec<f64>,
    /// How η^glo's element terms on this rank depend on the amplitudes of the bubbles that
    /// correct û along a curved Γc of body 2 ([`polygon::BubbleTerms`]; `glo` holds them at
    /// amplitude 0 until [`polygon::choose_amplitudes`]).
    pub bubbles: Vec<BubbleTerms>,
    /// Equilibrium residuals of the recovered stresses (largest of the two recoveries).
    pub residuals: Residuals,
}

impl BodyEstimate {
    /// Where the body's element `e` is held here (`None`: another rank estimates it).
    pub fn slot(&self, e: usize) -> Option<usize> {
        self.elements.binary_search(&(e as u32)).ok()
    }

    pub fn totals(&self) -> [f64; 3] {
        [
            self.glo.iter().sum(),
            self.fe.iter().sum(),
            self.nndd.iter().sum(),
        ]
    }
}

/// The element work of one body's estimate on this rank (the elements of its view): the η^glo
/// recovery and the η^NNDD element terms ([`ElementWork::glo`]), the η^FE recovery
/// ([`ElementWork::fe`]), the contact terms ([`ElementWork::finish`]). Each recovery is
/// [`View::prepare`]d first, by the caller, for both bodies at once.
pub struct ElementWork<'a> {
    p: &'a BodyProblem,
    fields: &'a BodyFields<'a>,
    /// u^α_p on the view ([`View::local_of`]).
    u_p: std::borrow::Cow<'a, [f64]>,
    view: &'a View<'a>,
    /// The mesh the recovery runs on, and where the estimate holds each of its elements
    /// (the slot of [`BodyEstimate::elements`]; `u32::MAX`: a ring of the overlap, not
    /// estimated here).
    sub: &'a Mesh,
    slots: Vec<u32>,
    /// η^glo's bubbles (body 2 along a curved Γc), and per element [a, b] of its
    /// [`BubbleTerms`] from the η^glo recovery.
    bubbles: HashMap<usize, ElementBubble>,
    coupling: HashMap<usize, [f64; 2]>,
    est: BodyEstimate,
}

impl<'a> ElementWork<'a> {
    pub fn new(
        p: &'a BodyProblem,
        fields: &'a BodyFields<'a>,
        view: &'a View<'a>,
    ) -> ElementWork<'a> {
        let (sub, kept) = view.kept(p.mesh());
        // (the estimated elements come in increasing order: `View::kept`)
        let elements: Vec<u32> = kept.iter().copied().filter(|&e| e != u32::MAX).collect();
        let mut next = 0;
        let slots = kept
            .iter()
            .map(|&e| match e {
                u32::MAX => u32::MAX,
                _ => {
                    next += 1;
                    next - 1
                }
            })
            .collect();
        let n = elements.len();
        ElementWork {
            p,
            fields,
            u_p: view.local_of(&fields.u_p),
            view,
            sub,
            slots,
            bubbles: HashMap::new(),
            coupling: HashMap::new(),
            est: BodyEstimate {
                elements,
                glo: vec![0.0; n],
                fe: vec![0.0; n],
                nndd: vec![0.0; n],
                ..Default::default()
            },
        }
    }

    /// The sign of body α's Γc data (body 1 takes t̂, body 2 −t̂).
    fn sign(&self) -> f64 {
        if self.p.alpha == 1 {
            1.0
        } else {
            -1.0
        }
    }

    /// The displacement the η^glo recovery starts from (ũ^α).
    pub fn glo_data(&self) -> &[f64] {
        &self.fields.u_tilde
    }

    /// The displacement the η^FE recovery starts from (u¹_p, or body 2's re-solve).
    pub fn fe_data(&self) -> &[f64] {
        if self.p.alpha == 1 && self.fields.u_fe.is_empty() {
            &self.u_p
        } else {
            &self.fields.u_fe
        }
    }

    /// The η^glo recovery (Γc data t̂^α, the re-solve ũ^α) and its element CREs, and the
    /// η^NNDD element terms ‖Kε(ũ^α_d − u_p)‖² (or docs/method.md's ũ^α_h of η^glo).
    pub fn glo(
        &mut self,
        data: &IterationData,
        operators: &mut OperatorCache,
        parts: &Parts,
    ) -> Result<(), EstimateError> {
        let (p, sub) = (self.p, self.sub);
        let sign = self.sign();
        let t_alpha: Vec<EdgeValues> = data
            .glo_edges
            .iter()
            .map(|e| e.map(|v| [sign * v[0], sign * v[1]]))
            .collect();
        let r = self.recover(Data::Glo, &t_alpha, data, operators, parts)?;
        self.est.residuals = self.est.residuals.worst(r);
        let u_d = match data.nndd_variant {
            NnddVariant::Discrete => &self.fields.u_d,
            NnddVariant::Density => &self.fields.u_tilde,
        };
        let u_p: &[f64] = &self.u_p;
        parts.run(Part::ElementSums, || {
            let nndd = &mut self.est.nndd;
            for (l, &s) in self
                .slots
                .iter()
                .enumerate()
                .filter(|(_, &s)| s != u32::MAX)
            {
                let ke = element_stiffness(&sub.triangle_points(l), &p.material);
                let dofs = element_dofs(&sub.triangles.get(l));
                let d: [f64; 6] = std::array::from_fn(|r| u_d[dofs[r]] - u_p[dofs[r]]);
                nndd[s as usize] = energy(&ke, &d);
            }
        });
        Ok(())
    }

    /// The η^FE recovery (the step-p problem at fixed λ_p) and its element CREs: body 1's
    /// σ(u¹_p) is FE-equilibrated with its Γc reaction density M⁻¹T¹_p, body 2's re-solve
    /// with −t̂^c_p.
    pub fn fe(
        &mut self,
        iface: &Interface,
        data: &IterationData,
        operators: &mut OperatorCache,
        parts: &Parts,
    ) -> Result<(), EstimateError> {
        let (mut traction, tangential) = match (self.p.alpha, data.reaction1) {
            (1, Reaction::Own(t) | Reaction::Resolved(t)) => (
                contact_traction(self.p, &iface.density(t)),
                data.friction.map(|f| iface.density(&f.reaction1)),
            ),
            _ => {
                let t: Vec<f64> = data.t_fe.iter().map(|t| -t).collect();
                (
                    contact_traction(self.p, &t),
                    data.friction.map(|f| f.fe_t.iter().map(|t| -t).collect()),
                )
            }
        };
        if let (Some(f), Some(tt)) = (data.friction, tangential) {
            for (c, t) in traction.iter_mut().zip(tt) {
                c[0] += t * f.tau[0];
                c[1] += t * f.tau[1];
            }
        }
        let edges = polygon::nodal_edges(&traction);
        let r = self.recover(Data::Fe, &edges, data, operators, parts)?;
        self.est.residuals = self.est.residuals.worst(r);
        Ok(())
    }

    /// One recovery, its element CREs into the map of `which`.
    fn recover(
        &mut self,
        which: Data,
        gc: &[EdgeValues],
        data: &IterationData,
        operators: &mut OperatorCache,
        parts: &Parts,
    ) -> Result<Residuals, EstimateError> {
        let (p, view, fields) = (self.p, self.view, self.fields);
        let u: &[f64] = match (which, p.alpha) {
            (Data::Glo, _) => &fields.u_tilde,
            (Data::Fe, 1) if fields.u_fe.is_empty() => &self.u_p,
            (Data::Fe, _) => &fields.u_fe,
        };
        if let (Data::Glo, 2) = (which, p.alpha) {
            self.bubbles = bubbles(p, data);
        }
        let none = HashMap::new();
        let bubbles = match which {
            Data::Glo => &self.bubbles,
            Data::Fe => &none,
        };
        let out = match which {
            Data::Glo => &mut self.est.glo,
            Data::Fe => &mut self.est.fe,
        };
        let mut map = CreMap {
            sub: self.sub,
            mesh: p.mesh(),
            slots: &self.slots,
            elements: &self.est.elements,
            u_p: &fields.u_p,
            material: &p.material,
            bubbles,
            coupling: &mut self.coupling,
            out,
        };
        let mut visit = |l: usize, c: &[f64; NC]| map.visit(l, c);
        parts.run(Part::Recovery, || {
            view.equilibrate(p, u, gc, data.recovery, operators, &mut visit)
        })
    }

    /// The contact terms on the body-2 elements along Γc that this rank estimates: η^glo's
    /// 2∫ p̂ G(û) ≥ 0 ([`polygon::contact_term`], û with its bubbles), η^FE's 2∫ t̂ (λ_p − g₀ −
    /// u²_n) ≥ 0; the element contributions.
    pub fn finish(
        mut self,
        iface: &Interface,
        data: &IterationData,
        parts: &Parts,
    ) -> BodyEstimate {
        let (p, mesh) = (self.p, self.p.mesh());
        if p.alpha == 2 {
            parts.run(Part::ElementSums, || {
                let u2n = p.normal_trace(&*self.fields.u_p);
                let obstacle = p.obstacle(data.lambda);
                let gap: Vec<f64> = obstacle.iter().zip(&u2n).map(|(o, u)| o - u).collect();
                // (at bubble amplitude 0: the amplitudes are chosen after the recovery)
                let c_glo: Vec<f64> = if data.fe_only {
                    Vec::new()
                } else {
                    (0..data.gaps.len())
                        .map(|k| {
                            let len = iface.lengths[k];
                            polygon::contact_term(len, data.glo_factors[k], &data.gaps[k], 0.0)
                        })
                        .collect()
                };
                let mut c_fe = iface.segment_products(data.t_fe, &gap);
                // Friction: the tangential Fenchel gaps (docs/method.md §9).
                let mut f_glo = vec![0.0; c_fe.len()];
                let mut f_nndd = vec![0.0; c_fe.len()];
                if let Some(f) = data.friction {
                    let u2t = p.tangential_trace(&*self.fields.u_p);
                    let w_fe: Vec<f64> = f.lambda_t.iter().zip(&u2t).map(|(l, u)| l - u).collect();
                    let m = w_fe.len();
                    for (k, c) in c_fe.iter_mut().enumerate() {
                        let pair = |v: &[f64]| [v[k], v[k + 1]];
                        let len = iface.lengths[k];
                        *c += 0.5
                            * friction::segment_term(
                                len,
                                pair(&f.fe_bound),
                                pair(&f.fe_t),
                                pair(&w_fe),
                            );
                        if data.fe_only {
                            continue;
                        }
                        f_glo[k] = friction::segment_term(
                            len,
                            pair(&f.glo_bound),
                            pair(&f.glo_t),
                            pair(&f.glo_w),
                        );
                        f_nndd[k] = match data.nndd_variant {
                            NnddVariant::Density => f_glo[k],
                            NnddVariant::Discrete => [k, k + 1]
                                .iter()
                                .map(|&i| {
                                    let w = if i == 0 || i == m - 1 { 1.0 } else { 0.5 };
                                    w * friction::nodal_term(f.mu_bound[i], -f.mu_t[i], w_fe[i])
                                })
                                .sum::<f64>(),
                        };
                    }
                }
                let elements = mesh.chain_elements(&p.contact_nodes);
                let m = gap.len();
                let est = &mut self.est;
                for (&e, b) in &self.bubbles {
                    if let Some(&[a, bb]) = self.coupling.get(&e) {
                        est.bubbles.push(BubbleTerms {
                            element: e,
                            a,
                            b: bb,
                            l: b.slope,
                            least: b.least,
                        });
                    }
                }
                est.bubbles.sort_by_key(|t| t.element);
                for k in 0..c_fe.len() {
                    let e = elements[k].expect("a Γc segment is an element's edge");
                    let Some(s) = est.slot(e) else {
                        continue;
                    };
                    if !data.fe_only {
                        est.glo[s] += c_glo[k] + f_glo[k];
                        est.nndd[s] += f_nndd[k];
                        est.nndd[s] += match data.nndd_variant {
                            NnddVariant::Density => c_glo[k],
                            // 2 μ̂_i (u²_n − λ)_i per node, half to each adjacent segment's
                            // element.
                            NnddVariant::Discrete => [k, k + 1]
                                .iter()
                                .map(|&i| {
                                    let w = if i == 0 || i == m - 1 { 1.0 } else { 0.5 };
                                    -2.0 * w * data.mu_hat[i] * gap[i]
                                })
                                .sum::<f64>(),
                        };
                    }
                    est.fe[s] += 2.0 * c_fe[k];
                }
            });
        }
        self.est
    }
}

/// The data of one of an estimate's two recoveries.
#[derive(Clone, Copy)]
enum Data {
    Glo,
    Fe,
}

pub(super) use crate::fem::elasticity::element_energy as energy;

/// The element CREs ‖σ̂ − Kε(u_p)‖² of the fields a recovery visits, into `out` by the slot
/// of the element this rank estimates ([`BodyEstimate::elements`]).
struct CreMap<'a> {
    sub: &'a Mesh,
    mesh: &'a Mesh,
    /// Where each element of `sub` is held in `out` (`u32::MAX`: not estimated here), and
    /// the body element of each slot.
    slots: &'a [u32],
    elements: &'a [u32],
    u_p: &'a Displacement,
    material: &'a crate::fem::Material,
    /// The unit bubbles of û's correction on body 2's elements along a curved Γc
    /// ([`polygon::Bubble`]): their CRE at amplitude c is C − 2bc + ac², C = ‖σ̂ − Kε(u_p)‖²
    /// (into `out`), a = ‖Kε(δ₁)‖², b = ∫(σ̂ − Kε(u_p)):ε(δ₁) (into `coupling`).
    bubbles: &'a HashMap<usize, ElementBubble>,
    coupling: &'a mut HashMap<usize, [f64; 2]>,
    out: &'a mut [f64],
}

impl CreMap<'_> {
    fn visit(&mut self, l: usize, coef: &[f64; NC]) {
        let s = self.slots[l];
        if s != u32::MAX {
            let s = s as usize;
            let e = self.elements[s] as usize;
            let u_p = self.u_p;
            let sigma_p = element_stress_with(self.mesh, e, self.material, |d| u_p[d]);
            let cre = element_cre(self.sub, l, coef, sigma_p, self.material);
            self.out[s] = cre;
            if let Some(b) = self.bubbles.get(&e) {
                // C − 2b c + a c² at c = ±1.
                let d = self.material.hooke();
                let at = |c: f64| {
                    let tau = |x: [f64; 2]| {
                        let eps = b.shape.strain(x);
                        std::array::from_fn(|r| {
                            sigma_p[r] + c * (0..3).map(|k| d[r][k] * eps[k]).sum::<f64>()
                        })
                    };
                    element_cre_varying(self.sub, l, coef, &tau, self.material)
                };
                let (plus, minus) = (at(1.0), at(-1.0));
                self.coupling
                    .insert(e, [0.5 * (plus + minus) - cre, 0.25 * (minus - plus)]);
            }
        }
    }
}

/// The bubble of û's correction on one body-2 element along a curved Γc: its shape δ₁ (the
/// amplitude c scales it), the contact terms' slope in c and the least admissible c.
pub struct ElementBubble {
    pub shape: Bubble,
    pub slope: f64,
    pub least: f64,
}

/// η^glo's bubbles on body 2 ([`polygon::Bubble`]), by element: on the element of each Γc
/// segment whose normals turn, the unit bubble (least amplitude the segment's); on an element
/// with two such segments (a corner), the sum of their bubbles at their least amplitudes
/// (those ≥ 0) as one shape, c ≥ 1.
fn bubbles(p: &BodyProblem, data: &IterationData) -> HashMap<usize, ElementBubble> {
    let mut segments: HashMap<usize, Vec<usize>> = HashMap::new();
    if data.gaps.iter().all(|g| !g.turns) {
        return HashMap::new();
    }
    let elements = p.mesh().chain_elements(&p.contact_nodes);
    for (k, gap) in data.gaps.iter().enumerate() {
        if gap.turns {
            segments
                .entry(elements[k].expect("a Γc segment is an element's edge"))
                .or_default()
                .push(k);
        }
    }
    let mut out = HashMap::new();
    for (e, ks) in segments {
        let t = p.mesh().triangles.get(e);
        let local = |n: usize| t.iter().position(|&v| v == n).expect("the edge's node");
        let points = p.mesh().triangle_points(e);
        let least = |k: usize| data.gaps[k].least_amplitude();
        let weight = |k: usize| {
            if ks.len() == 1 {
                1.0
            } else {
                least(k).max(0.0)
            }
        };
        if ks.iter().all(|&k| weight(k) == 0.0) {
            continue; // c = 0 keeps both segments in contact
        }
        let mut shape = Bubble {
            points,
            edges: Vec::new(),
        };
        let mut slope = 0.0;
        for &k in &ks {
            let (a, b) = (p.contact_nodes[k], p.contact_nodes[k + 1]);
            let (na, nb) = (p.contact_normals[k], p.contact_normals[k + 1]);
            shape.add_edge([local(a), local(b)], weight(k), na, nb);
            slope += weight(k) * polygon::contact_slope(p.contact_lengths[k], data.glo_factors[k]);
        }
        let least = if ks.len() == 1 { least(ks[0]) } else { 1.0 };
        out.insert(
            e,
            ElementBubble {
                shape,
                slope,
                least,
            },
        );
    }
    out
}

/// The Γc traction vector of body α (nodal values of a P1 density per unit length of body 1's
/// side) that carries exactly the FE nodal forces F_k = (M_Γ g)_k n_k of the normal density
/// `gc` = g: c = M_Γ⁻¹F component by component, i.e. c_k = g_k n_k + (M_Γ⁻¹ d)_k with
/// d_k = Σ_l (M_Γ)_kl g_l (n_k − n_l). Where the normal is the same at every pair (a straight
/// side) d = 0 and c = g n exactly (frictionless); on a curved side c has a tangential part of
/// order h²κ (docs/method.md §5).
pub fn contact_traction(p: &BodyProblem, gc: &[f64]) -> Vec<[f64; 2]> {
    traction_carrying(&p.contact_normals, &p.contact_lengths, gc)
}

/// [`contact_traction`] for the normals `n` and segment lengths of Γc.
fn traction_carrying(n: &[[f64; 2]], lengths: &[f64], gc: &[f64]) -> Vec<[f64; 2]> {
    let mut c: Vec<[f64; 2]> = gc
        .iter()
        .zip(n)
        .map(|(g, n)| [g * n[0], g * n[1]])
        .collect();
    if n.windows(2).all(|w| w[0] == w[1]) {
        return c;
    }
    let iface = super::traction::Interface::new(lengths.to_vec());
    for comp in 0..2 {
        // d = M (g n_comp) at node k with n_k factored out: (M g)_k n_k − (M (g n))_k.
        let gn: Vec<f64> = gc.iter().zip(n).map(|(g, n)| g * n[comp]).collect();
        let (mg, mgn) = (iface.forces(gc), iface.forces(&gn));
        let d: Vec<f64> = (0..gc.len()).map(|k| mg[k] * n[k][comp] - mgn[k]).collect();
        for (ck, dk) in c.iter_mut().zip(iface.density(&d)) {
            ck[comp] += dk;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Γc on a circular arc of radius 1 and half-angle 1 in m segments, its radial normals,
    /// and the traction carrying the normal density g(θ) = −cos(θ)².
    fn arc_traction(m: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<f64>) {
        let th: Vec<f64> = (0..=m).map(|i| -1.0 + 2.0 * i as f64 / m as f64).collect();
        let n: Vec<[f64; 2]> = th.iter().map(|t| [-t.sin(), t.cos()]).collect();
        let pts: Vec<[f64; 2]> = th.iter().map(|t| [t.sin(), 1.0 - t.cos()]).collect();
        let lengths = crate::problem::segment_lengths(&pts);
        let g: Vec<f64> = th.iter().map(|t| -t.cos().powi(2)).collect();
        (traction_carrying(&n, &lengths, &g), n, lengths)
    }

    #[test]
    fn the_curved_traction_carries_the_nodal_forces_and_is_nearly_normal() {
        let mut tangential = Vec::new();
        for m in [16, 32, 64] {
            let (c, n, lengths) = arc_traction(m);
            let iface = super::super::traction::Interface::new(lengths);
            let g: Vec<f64> = (0..=m)
                .map(|i| -(-1.0 + 2.0 * i as f64 / m as f64).cos().powi(2))
                .collect();
            let mg = iface.forces(&g);
            // Its nodal forces are (M g)_k n_k, exactly.
            for comp in 0..2 {
                let ck: Vec<f64> = c.iter().map(|v| v[comp]).collect();
                let f = iface.forces(&ck);
                for k in 0..=m {
                    assert!((f[k] - mg[k] * n[k][comp]).abs() < 1e-14, "m {m}, node {k}");
                }
            }
            // Its tangential part (relative to max |g| = 1): inside Γc and at its ends.
            let tang = |v: &[f64; 2], n: &[f64; 2]| (v[0] * n[1] - v[1] * n[0]).abs();
            let inside = (m / 4..=3 * m / 4)
                .map(|k| tang(&c[k], &n[k]))
                .fold(0.0f64, f64::max);
            let all = c
                .iter()
                .zip(&n)
                .map(|(v, n)| tang(v, n))
                .fold(0.0f64, f64::max);
            tangential.push((inside, all));
        }
        // O(h²) on the middle half (0.5 % at m = 16, h = 1/8), O(h) at the two end nodes
        // (2.6 %), decaying geometrically inward (M_Γ⁻¹).
        assert!(
            tangential[0].0 < 6e-3 && tangential[0].1 < 3e-2,
            "{tangential:?}"
        );
        for w in tangential.windows(2) {
            assert!(w[1].0 < 0.3 * w[0].0, "inside: {tangential:?}");
            assert!(w[1].1 < 0.55 * w[0].1, "ends: {tangential:?}");
        }
    }

    #[test]
    fn a_straight_side_gets_exactly_the_normal_traction() {
        let n = vec![[0.6, 0.8]; 5];
        let g = [-1.0, -2.0, 0.5, -3.0, 0.0];
        let c = traction_carrying(&n, &[0.25; 4], &g);
        for (v, g) in c.iter().zip(g) {
            assert_eq!(*v, [g * 0.6, g * 0.8]);
        }
    }
}
