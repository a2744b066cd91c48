//! Guaranteed a posteriori error estimates of an NNDD iterate (paper §4, method.md §3):
//! the global estimator η^glo (22) and the indicators η^FE (23) and η^NNDD (24), each a sum of
//! element contributions, computed by the ranks that own the elements.
//!
//! At iteration p, with û^α = u^α_p (step 1's fields: û¹_n = λ_p, û²_n ≥ λ_p on Γc):
//! - η^glo² = Σ_α ‖σ̂^α − Kε(u^α_p)‖²_{K⁻¹} + 2∫_Γc t̂^c (λ_p − u²_{p,n}), with t̂^c the
//!   admissible contact traction closest to ½(t¹_h − t²_h) and σ̂^α the strictly equilibrated
//!   stresses recovered from the Neumann re-solves ũ^α_h (data t̂¹ = t̂^c, t̂² = −t̂^c);
//! - η^FE² the same for the step-p problem at fixed λ_p: body 1 equilibrates σ(u¹_p) itself
//!   with its Γc reaction density M_Γ⁻¹T¹_p, body 2 uses t̂^c_p ≤ 0 closest to −t²_h;
//! - η^NNDD, the CRE of the discrete global problem (whose contact constraint and forces are
//!   nodal): with the nodal contact forces μ̂ = max(½(T²_p − T¹_p), 0) ≥ 0 on the contact set
//!   (0 off it) and the Neumann
//!   re-solves ũ^α_d (Γc forces ∓μ̂), η^NNDD² = Σ_α ‖Kε(ũ^α_d − u^α_p)‖²_{K⁻¹} +
//!   2 μ̂ᵀ(u²_{p,n} − λ_p). It vanishes exactly at the discrete solution (T¹ = −T², and
//!   complementarity). method.md §3.3 builds it from the P1 density t̂^c of η^glo instead;
//!   that variant (`NnddVariant::Density`) does not vanish as the NNDD converges, because the
//!   density M_Γ⁻¹T of the converged nodal forces changes sign near the end of the contact
//!   zone and its projection on t̂ ≤ 0 alters the loads (see tests/estimates.rs).
//!
//! Norms follow the paper: ‖σ‖²_{K⁻¹} = ∫ σ:K⁻¹:σ, ‖u‖²_E = ∫ Kε(u):ε(u) (no ½).

pub mod equilibrate;
pub mod overlap;

use std::collections::HashMap;

use crate::dd::body::{Body, BodyError};
use crate::estimate::equilibrate::{
    equilibrate_restricted, equilibrate_with, vertex_colours, Boundary, BoundaryEdge,
    EdgeComponent, EquilibratedStress, EquilibrationError, Residuals, StarChoice,
};
use crate::estimate::overlap::Overlap;
use crate::fem::mesh::Mesh;
use crate::fem::{element_dofs, element_stiffness, element_stress};
use crate::problem::{interface_mass, BodyProblem};
use crate::qp::dense::SymMatrix;
use crate::qp::{solve_nonneg_qp, QpError, QpSettings};

#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error("admissible contact traction: {0}")]
    Qp(#[from] QpError),
    #[error("body {alpha}: equilibrated stress: {source}")]
    Equilibration {
        alpha: usize,
        source: EquilibrationError,
    },
    #[error("reference mesh {fine} is not a refinement of mesh {coarse}")]
    NotNested { coarse: String, fine: String },
}

/// The contact interface Γc seen as a 1D P1 space: its mass matrix M_Γ and integrals.
pub struct Interface {
    pub x: Vec<f64>,
    diag: Vec<f64>,
    upper: Vec<f64>,
}

impl Interface {
    pub fn new(x: Vec<f64>) -> Interface {
        let (diag, upper) = interface_mass(&x);
        Interface { x, diag, upper }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Nodal forces M_Γ t of a P1 density t.
    pub fn forces(&self, t: &[f64]) -> Vec<f64> {
        let m = self.len();
        (0..m)
            .map(|i| {
                let mut f = self.diag[i] * t[i];
                if i > 0 {
                    f += self.upper[i - 1] * t[i - 1];
                }
                if i + 1 < m {
                    f += self.upper[i] * t[i + 1];
                }
                f
            })
            .collect()
    }

    /// The density t = M_Γ⁻¹ T carrying the nodal forces T (tridiagonal solve).
    pub fn density(&self, forces: &[f64]) -> Vec<f64> {
        let m = self.len();
        let mut c = vec![0.0; m];
        let mut d = forces.to_vec();
        let mut b = self.diag.clone();
        for i in 1..m {
            let w = self.upper[i - 1] / b[i - 1];
            b[i] -= w * self.upper[i - 1];
            d[i] -= w * d[i - 1];
        }
        for i in (0..m).rev() {
            let next = if i + 1 < m {
                self.upper[i] * c[i + 1]
            } else {
                0.0
            };
            c[i] = (d[i] - next) / b[i];
        }
        c
    }

    fn mass(&self) -> SymMatrix {
        let m = self.len();
        let mut a = SymMatrix::new(m);
        for i in 0..m {
            a.set(i, i, self.diag[i]);
            if i + 1 < m {
                a.set(i, i + 1, self.upper[i]);
                a.set(i + 1, i, self.upper[i]);
            }
        }
        a
    }

    /// ∫ a b on each segment [k, k+1] (exact for P1 a, b).
    pub fn segment_products(&self, a: &[f64], b: &[f64]) -> Vec<f64> {
        (0..self.len().saturating_sub(1))
            .map(|k| {
                let h = (self.x[k + 1] - self.x[k]).abs();
                h / 6.0
                    * (2.0 * a[k] * b[k]
                        + a[k] * b[k + 1]
                        + a[k + 1] * b[k]
                        + 2.0 * a[k + 1] * b[k + 1])
            })
            .collect()
    }

    /// The admissible contact traction (method.md §3.2): the P1 density t̂ ≤ 0 at every node
    /// (hence on every edge) closest in L²(Γc) to the density g = M_Γ⁻¹G of the nodal forces
    /// G = `target`. ‖t̂ − g‖²_M = t̂ᵀMt̂ − 2t̂ᵀG + const, so with x = −t̂ ≥ 0 the QP is
    /// min ½ xᵀM_Γx + xᵀG (Clarabel, polished).
    pub fn admissible_traction(
        &self,
        target: &[f64],
        qp: &QpSettings,
    ) -> Result<Vec<f64>, QpError> {
        let sol = solve_nonneg_qp(&self.mass(), target, qp)?;
        Ok(sol.x.iter().map(|v| -v).collect())
    }
}

/// Squared element contributions of one body at one iteration.
#[derive(Clone, Debug, Default)]
pub struct BodyEstimate {
    pub glo: Vec<f64>,
    pub fe: Vec<f64>,
    pub nndd: Vec<f64>,
    /// Equilibrium residuals of the recovered stresses (largest of the two recoveries).
    pub residuals: Residuals,
}

impl BodyEstimate {
    pub fn totals(&self) -> [f64; 3] {
        [
            self.glo.iter().sum(),
            self.fe.iter().sum(),
            self.nndd.iter().sum(),
        ]
    }
}

/// Which reference problem η^NNDD is measured against (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NnddVariant {
    /// The discrete global problem, nodal contact forces (vanishes at convergence).
    Discrete,
    /// method.md §3.3 as written: the P1 density t̂^c of η^glo.
    Density,
}

/// What the estimates of iteration p need beyond the bodies: λ_p, the Γc densities t̂^c (for
/// η^glo, η^NNDD) and t̂^c_p (for η^FE), and T¹_p.
pub struct IterationData<'a> {
    pub lambda: &'a [f64],
    pub t_glo: &'a [f64],
    pub t_fe: &'a [f64],
    pub reaction1: &'a [f64],
    /// Nodal contact forces μ̂ ≥ 0 on body 2 (for the discrete η^NNDD).
    pub mu_hat: &'a [f64],
    pub nndd_variant: NnddVariant,
    pub recovery: StarChoice,
}

/// Where a rank's recovery runs: the whole body mesh (the body on one rank), or the rank's
/// own elements with enough rings of neighbours that the recovered σ̂ on its own elements is
/// exactly the whole-mesh one ([`Overlap`]).
pub enum View<'a> {
    Whole,
    Overlap(&'a Overlap),
}

impl View<'_> {
    fn equilibrate(
        &self,
        p: &BodyProblem,
        u: &[f64],
        gc: &[f64],
        choice: StarChoice,
    ) -> Result<(EquilibratedStress, Residuals), EstimateError> {
        let b = boundary(p, gc);
        let err = |source| EstimateError::Equilibration {
            alpha: p.alpha,
            source,
        };
        match self {
            View::Whole => {
                let s = equilibrate_with(&p.mesh, &p.material, u, &b, choice).map_err(err)?;
                let r = s.residuals(&p.mesh, &b);
                Ok((s, r))
            }
            View::Overlap(o) => {
                let b = o.restrict_boundary(&b);
                let restriction = o.restriction();
                let s = equilibrate_restricted(
                    &o.mesh,
                    &p.material,
                    &o.restrict_dofs(u),
                    &b,
                    choice,
                    Some(&restriction),
                )
                .map_err(err)?;
                let r = s.residuals_restricted(&o.mesh, &b, Some(&o.owned));
                Ok((s, r))
            }
        }
    }

    /// The mesh the recovered stress lives on, and the (index there, body element) pairs this
    /// rank estimates.
    fn kept<'b>(&'b self, body: &'b Body) -> (&'b Mesh, Vec<(usize, usize)>) {
        match self {
            View::Whole => (
                &body.problem.mesh,
                (0..body.problem.mesh.triangles.len())
                    .map(|e| (e, e))
                    .collect(),
            ),
            View::Overlap(o) => (
                &o.mesh,
                o.elements
                    .iter()
                    .enumerate()
                    .filter(|&(l, _)| o.owned[l])
                    .map(|(l, &e)| (l, e))
                    .collect(),
            ),
        }
    }
}

/// Element contributions of body α at iteration p on this rank's elements (zero elsewhere);
/// `u_p` is u^α_p (whole, on every rank of the body's group).
pub fn estimate_body(
    body: &Body,
    u_p: &[f64],
    iface: &Interface,
    data: &IterationData,
    view: &View,
) -> Result<BodyEstimate, EstimateError> {
    let p = &body.problem;
    let alpha = p.alpha;
    let mesh = &p.mesh;
    let ne = mesh.triangles.len();
    let (sub, kept) = view.kept(body);
    let sigma_p: Vec<[f64; 3]> = kept
        .iter()
        .map(|&(_, e)| element_stress(mesh, e, &p.material, u_p))
        .collect();

    // η^glo and η^NNDD: the Neumann re-solve with Γc data t̂^α, and its equilibration.
    let sign = if alpha == 1 { 1.0 } else { -1.0 };
    let t_alpha: Vec<f64> = data.t_glo.iter().map(|t| sign * t).collect();
    let u_tilde = body.neumann_solve(&iface.forces(&t_alpha), true)?;
    let (s_glo, mut res) = view.equilibrate(p, &u_tilde, &t_alpha, data.recovery)?;
    let mut est = BodyEstimate {
        glo: vec![0.0; ne],
        fe: vec![0.0; ne],
        nndd: vec![0.0; ne],
        ..Default::default()
    };
    // η^NNDD: the discretely equilibrated field of the discrete problem (nodal forces ∓μ̂),
    // or method.md's ũ^α_h of η^glo.
    let u_d = match data.nndd_variant {
        NnddVariant::Discrete => {
            let f: Vec<f64> = data.mu_hat.iter().map(|m| -sign * m).collect();
            body.neumann_solve(&f, true)?
        }
        NnddVariant::Density => u_tilde.clone(),
    };
    for (&(l, e), &sig) in kept.iter().zip(&sigma_p) {
        est.glo[e] = s_glo.cre_squared(sub, l, sig, &p.material);
        let ke = element_stiffness(&mesh.triangle_points(e), &p.material);
        let dofs = element_dofs(&mesh.triangles[e]);
        let d: Vec<f64> = dofs.iter().map(|&i| u_d[i] - u_p[i]).collect();
        est.nndd[e] = (0..6)
            .map(|r| d[r] * (0..6).map(|c| ke[r][c] * d[c]).sum::<f64>())
            .sum();
    }
    drop(s_glo);

    // η^FE: the step-p problem at fixed λ_p.
    let (s_fe, r_fe) = if alpha == 1 {
        // Body 1: σ(u¹_p) is FE-equilibrated with its Γc reaction density M⁻¹T¹_p.
        let t = iface.density(data.reaction1);
        view.equilibrate(p, u_p, &t, data.recovery)?
    } else {
        let t2: Vec<f64> = data.t_fe.iter().map(|t| -t).collect();
        let u_fe = body.neumann_solve(&iface.forces(&t2), true)?;
        view.equilibrate(p, &u_fe, &t2, data.recovery)?
    };
    res = worst(res, r_fe);
    for (&(l, e), &sig) in kept.iter().zip(&sigma_p) {
        est.fe[e] = s_fe.cre_squared(sub, l, sig, &p.material);
    }

    // Contact terms 2∫ t̂ (λ_p − u²_n) ≥ 0, on the body-2 elements along Γc (their owners).
    if alpha == 2 {
        let u2n: Vec<f64> = p.contact_normal_dofs().iter().map(|&d| u_p[d]).collect();
        let gap: Vec<f64> = data.lambda.iter().zip(&u2n).map(|(l, u)| l - u).collect();
        let c_glo = iface.segment_products(data.t_glo, &gap);
        let c_fe = iface.segment_products(data.t_fe, &gap);
        let edges = edge_elements(mesh);
        let m = gap.len();
        for k in 0..c_glo.len() {
            let (a, b) = (p.contact_nodes[k], p.contact_nodes[k + 1]);
            let e = edges[&(a.min(b), a.max(b))];
            if !body.partition.owns_element(e) {
                continue;
            }
            est.glo[e] += 2.0 * c_glo[k];
            est.fe[e] += 2.0 * c_fe[k];
            est.nndd[e] += match data.nndd_variant {
                NnddVariant::Density => 2.0 * c_glo[k],
                // 2 μ̂_i (u²_n − λ)_i per node, half to each adjacent segment's element.
                NnddVariant::Discrete => [k, k + 1]
                    .iter()
                    .map(|&i| {
                        let w = if i == 0 || i == m - 1 { 1.0 } else { 0.5 };
                        -2.0 * w * data.mu_hat[i] * gap[i]
                    })
                    .sum::<f64>(),
            };
        }
    }
    est.residuals = res;
    Ok(est)
}

fn worst(a: Residuals, b: Residuals) -> Residuals {
    Residuals {
        divergence: a.divergence.max(b.divergence),
        internal_jump: a.internal_jump.max(b.internal_jump),
        element_jump: a.element_jump.max(b.element_jump),
        boundary: a.boundary.max(b.boundary),
        point_reaction: a.point_reaction.max(b.point_reaction),
    }
}

/// The element of each boundary edge (sorted node pair).
fn edge_elements(mesh: &Mesh) -> HashMap<(usize, usize), usize> {
    let mut map = HashMap::new();
    for (e, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            map.entry((a.min(b), a.max(b))).or_insert(e);
        }
    }
    map
}

/// The traction data of body α for the equilibration: Γ_N data, Γc normal density `gc`
/// (tangential 0, frictionless), traction free elsewhere; components under Dirichlet
/// conditions on both ends of an edge are free.
pub fn boundary(p: &BodyProblem, gc: &[f64]) -> Boundary {
    let mesh = &p.mesh;
    let mut constrained = vec![false; mesh.num_dofs()];
    for &(d, _) in &p.dirichlet {
        constrained[d] = true;
    }
    let mut known: HashMap<(usize, usize), [[f64; 2]; 2]> = HashMap::new();
    for e in &p.neumann {
        let [a, b] = e.nodes;
        // traction[node][component] → per component, values at (a, b)
        known.insert(
            (a, b),
            [
                [e.traction[0][0], e.traction[1][0]],
                [e.traction[0][1], e.traction[1][1]],
            ],
        );
    }
    for k in 0..p.contact_nodes.len().saturating_sub(1) {
        let (a, b) = (p.contact_nodes[k], p.contact_nodes[k + 1]);
        known.insert((a, b), [[0.0, 0.0], [gc[k], gc[k + 1]]]);
    }
    let (nx, ny) = (mesh.nx, mesh.ny);
    let mut sides: Vec<[usize; 2]> = Vec::new();
    for i in 0..nx {
        sides.push([mesh.node(i, 0), mesh.node(i + 1, 0)]);
        sides.push([mesh.node(i, ny), mesh.node(i + 1, ny)]);
    }
    for j in 0..ny {
        sides.push([mesh.node(0, j), mesh.node(0, j + 1)]);
        sides.push([mesh.node(nx, j), mesh.node(nx, j + 1)]);
    }
    let edges = sides
        .into_iter()
        .map(|[a, b]| {
            let values = known.get(&(a, b)).copied();
            let comps = [0, 1].map(|k| {
                if constrained[2 * a + k] && constrained[2 * b + k] {
                    EdgeComponent::Free
                } else {
                    EdgeComponent::Known(values.map_or([0.0, 0.0], |v| v[k]))
                }
            });
            BoundaryEdge {
                nodes: [a, b],
                comps,
            }
        })
        .collect();
    Boundary { edges, constrained }
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

/// The reference solution of (26): the same problem on the nested mesh r·n, solved by the
/// NNDD to tol 1e−8, on the ranks owning each body.
pub struct Reference {
    pub factor: usize,
    /// Fine bodies (for their stiffness) and u_ref^α, on the owners.
    pub bodies: [Option<Body>; 2],
    pub u: [Vec<f64>; 2],
    pub iterations: usize,
}

/// The estimates of one iteration: totals (on every rank) and element maps η_E (on the ranks
/// of each body's group,
/// for output; η² = Σ_E η_E²).
#[derive(Clone, Debug)]
pub struct EstimateRecord {
    pub iteration: usize,
    pub eta_glo: f64,
    pub eta_fe: f64,
    pub eta_nndd: f64,
    /// (η^FE² + η^NNDD²) / η^glo², the paper's relation (25).
    pub eta_ratio: f64,
    pub e_ref: Option<f64>,
    pub effectivity: Option<f64>,
    pub residuals: Residuals,
    /// Per body: [η^glo_E, η^FE_E, η^NNDD_E] (on the body's ranks, empty elsewhere).
    pub maps: [[Vec<f64>; 3]; 2],
    /// The iterate, with u^α_p gathered on rank 0 (for output), and t̂^c.
    pub iterate: crate::dd::nndd::Iterate,
    pub t_hat: Vec<f64>,
}

/// Computes the estimates of NNDD iterates (collective over all ranks).
pub struct Estimator<'a> {
    pub iface: Interface,
    pub qp: QpSettings,
    pub recovery: StarChoice,
    pub nndd_variant: NnddVariant,
    pub layout: &'a crate::parallel::layout::Layout,
    pub reference: Option<Reference>,
    /// Per body, this rank's overlapping element set (built at the first estimate; `None`:
    /// the body is on one rank and the recovery runs on its whole mesh).
    pub overlaps: [std::cell::OnceCell<Option<Overlap>>; 2],
}

/// The nodal contact forces μ̂ ≥ 0 of the discrete η^NNDD: max(½(T² − T¹), 0) on the contact
/// set, 0 where body 2 is off the obstacle (any μ̂ ≥ 0 is admissible; this one is exact at the
/// discrete solution in both terms).
fn nodal_contact_forces(it: &crate::dd::nndd::Iterate) -> Vec<f64> {
    (0..it.lambda.len())
        .map(|i| {
            if it.active[i] {
                (0.5 * (it.forces[1][i] - it.forces[0][i])).max(0.0)
            } else {
                0.0
            }
        })
        .collect()
}

impl Estimator<'_> {
    /// This rank's overlapping element set of `body`: its own elements and as many rings as
    /// the recovery needs to be exact there.
    fn overlap(&self, body: &Body) -> Option<Overlap> {
        let part = &body.partition;
        (part.size > 1).then(|| {
            let mesh = &body.problem.mesh;
            let colours = vertex_colours(mesh);
            let count = crate::estimate::overlap::colour_count(&colours);
            let own: Vec<bool> = (0..mesh.triangles.len())
                .map(|e| part.owns_element(e))
                .collect();
            Overlap::new(
                mesh,
                &own,
                Overlap::rings_for(self.recovery, count),
                &colours,
            )
        })
    }

    /// η^NNDD alone, discrete variant, without any stress recovery: per body one Neumann
    /// re-solve and (ũ − u_p)ᵀK(ũ − u_p), plus the nodal contact pairing. The same number as
    /// [`Estimator::estimate`] gives, at the cost of two back-solves: what the balanced stopping
    /// rule checks at every iteration.
    pub fn eta_nndd(
        &self,
        bodies: [Option<&Body>; 2],
        it: &crate::dd::nndd::Iterate,
    ) -> Result<f64, EstimateError> {
        let mu_hat = nodal_contact_forces(it);
        let mut sum = 0.0;
        for (k, body) in bodies.iter().enumerate() {
            if let Some(b) = body {
                let sign = if k == 0 { 1.0 } else { -1.0 };
                let f: Vec<f64> = mu_hat.iter().map(|m| -sign * m).collect();
                let u_d = b.neumann_solve(&f, true)?;
                let d: Vec<f64> = u_d.iter().zip(&it.u[k]).map(|(a, b)| a - b).collect();
                let kd = b.apply_k(&d)?;
                if !b.is_root() {
                    continue; // the same numbers on every rank of the group: count them once
                }
                sum += d.iter().zip(&kd).map(|(a, b)| a * b).sum::<f64>();
                if k == 1 {
                    let u2n = b.normal_trace(&it.u[1]);
                    sum += (0..mu_hat.len())
                        .map(|i| 2.0 * mu_hat[i] * (u2n[i] - it.lambda[i]))
                        .sum::<f64>();
                }
            }
        }
        Ok(self.layout.sum(sum).max(0.0).sqrt())
    }

    /// η^glo, η^FE, η^NNDD (and e_ref, γ with a reference) of the iterate `it`.
    pub fn estimate(
        &self,
        bodies: [Option<&Body>; 2],
        it: &crate::dd::nndd::Iterate,
    ) -> Result<EstimateRecord, EstimateError> {
        let layout = self.layout;
        // The admissible Γc tractions (the same small QPs on every rank).
        let target: Vec<f64> = it.forces[0]
            .iter()
            .zip(&it.forces[1])
            .map(|(a, b)| 0.5 * (a - b))
            .collect();
        let t_glo = self.iface.admissible_traction(&target, &self.qp)?;
        let minus_t2: Vec<f64> = it.forces[1].iter().map(|t| -t).collect();
        let t_fe = self.iface.admissible_traction(&minus_t2, &self.qp)?;
        let mu_hat = nodal_contact_forces(it);
        let data = IterationData {
            lambda: &it.lambda,
            t_glo: &t_glo,
            t_fe: &t_fe,
            reaction1: &it.forces[0],
            mu_hat: &mu_hat,
            nndd_variant: self.nndd_variant,
            recovery: self.recovery,
        };
        let mut sums = [0.0; 3];
        let mut res = Residuals::default();
        let mut maps: [[Vec<f64>; 3]; 2] = Default::default();
        let mut e_ref2 = 0.0;
        for (k, body) in bodies.iter().enumerate() {
            if let Some(b) = body {
                let overlap = self.overlaps[k].get_or_init(|| self.overlap(b));
                let view = overlap.as_ref().map_or(View::Whole, View::Overlap);
                let est = estimate_body(b, &it.u[k], &self.iface, &data, &view)?;
                let t = est.totals();
                for c in 0..3 {
                    sums[c] += t[c];
                }
                res = worst(res, est.residuals);
                maps[k] = [&est.glo, &est.fe, &est.nndd]
                    .map(|v| v.iter().map(|x| x.max(0.0).sqrt()).collect());
                for map in maps[k].iter_mut() {
                    layout.group_sum(map); // each element from its owner
                }
                if let Some(r) = &self.reference {
                    let fine = r.bodies[k]
                        .as_ref()
                        .expect("reference body on the same ranks");
                    let iu = interpolate_nested(&b.problem.mesh, &fine.problem.mesh, &it.u[k])?;
                    let d: Vec<f64> = r.u[k].iter().zip(&iu).map(|(a, b)| a - b).collect();
                    let kd = fine.apply_k(&d)?;
                    if b.is_root() {
                        e_ref2 += d.iter().zip(&kd).map(|(a, b)| a * b).sum::<f64>();
                    }
                }
            }
        }
        let [glo, fe, nndd] = sums.map(|s| layout.sum(s));
        let e_ref = self
            .reference
            .as_ref()
            .map(|_| layout.sum(e_ref2).max(0.0).sqrt());
        let res = Residuals {
            divergence: layout.max(res.divergence),
            internal_jump: layout.max(res.internal_jump),
            element_jump: layout.max(res.element_jump),
            boundary: layout.max(res.boundary),
            point_reaction: layout.max(res.point_reaction),
        };
        let iterate = it.clone();
        let eta_glo = glo.max(0.0).sqrt();
        Ok(EstimateRecord {
            iteration: it.iteration,
            eta_glo,
            eta_fe: fe.max(0.0).sqrt(),
            eta_nndd: nndd.max(0.0).sqrt(),
            eta_ratio: if glo > 0.0 {
                (fe + nndd) / glo
            } else {
                f64::NAN
            },
            e_ref,
            effectivity: e_ref.map(|e| eta_glo / e),
            residuals: res,
            maps,
            iterate,
            t_hat: t_glo,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_mass_and_density_are_inverse() {
        let iface = Interface::new(vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let t = vec![-1.0, -2.0, 0.5, -3.0, 0.0];
        let back = iface.density(&iface.forces(&t));
        for (a, b) in t.iter().zip(&back) {
            assert!((a - b).abs() < 1e-14);
        }
        // ∫ 1 = 1 and ∫ x·1 = 1/2 through the segment products.
        let ones = vec![1.0; 5];
        let s: f64 = iface.segment_products(&ones, &ones).iter().sum();
        assert!((s - 1.0).abs() < 1e-15);
        let s: f64 = iface.segment_products(&iface.x, &ones).iter().sum();
        assert!((s - 0.5).abs() < 1e-15);
    }

    #[test]
    fn admissible_traction_is_the_clipped_projection() {
        let iface = Interface::new(vec![0.0, 0.5, 1.0]);
        // A target density that is already ≤ 0 is returned exactly.
        let t = vec![-3.0, -1.0, -2.0];
        let got = iface
            .admissible_traction(&iface.forces(&t), &QpSettings::default())
            .unwrap();
        for (a, b) in t.iter().zip(&got) {
            assert!((a - b).abs() < 1e-12 * 3.0, "{got:?}");
        }
        // A positive (tensile) target gives 0.
        let got = iface
            .admissible_traction(&[1.0, 1.0, 1.0], &QpSettings::default())
            .unwrap();
        assert!(got.iter().all(|&v| v == 0.0), "{got:?}");
    }

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
