//! The estimator: η^glo, η^FE, η^NNDD of an NNDD iterate (paper (22)–(24)), and e_ref
//! against the reference solution (26), collective over all ranks (the module docs of
//! [`crate::estimate`] give the estimates).

use std::cell::{Cell, OnceCell, RefCell};
use std::ops::Range;
use std::rc::Rc;

use crate::dd::body::Body;
use crate::dd::displacement::Displacement;
use crate::dd::nndd::Iterate;
use crate::estimate::cre::{BodyEstimate, ElementWork};
use crate::estimate::equilibrate::{OperatorCache, Recovery, Residuals};
use crate::estimate::iteration::{body_fields, body_resolves, BodyFields, IterationData, Reaction};
use crate::estimate::mortar::MortarEstimates;
use crate::estimate::share::{estimated_outside_group, Seed, Share, SharePlan};
use crate::fem::mesh::element_u32;
use crate::parallel::held;
use crate::parallel::layout::Layout;
use crate::parallel::partition::Partitioner;
use crate::petsc::LogStage;
use crate::problem::BodyProblem;
use crate::qp::QpSettings;

use crate::dd::friction::{FrictionLaw, Tangential};
use crate::estimate::error::EstimateError;
use crate::estimate::friction::{self, FrictionData};
use crate::estimate::parts::{Part, Parts};
use crate::estimate::polygon;
use crate::estimate::reference::Reference;
use crate::estimate::settings::{EstimateSettings, NnddVariant};
use crate::estimate::traction::Interface;

mod recover;
pub(crate) use recover::{InParts, ReactionOf};

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
    /// ‖δ‖_E of η^glo's correction of û (docs/method.md §5), included in `eta_glo`.
    pub correction: f64,
    pub e_ref: Option<f64>,
    pub effectivity: Option<f64>,
    pub residuals: Residuals,
    /// Per body: [η^glo_E, η^FE_E, η^NNDD_E] on the rank's block of the body's elements
    /// ([`Layout::block`]: each element's values on one rank of the body's group, none on the
    /// others), from the body's element `map_first[k]` on.
    pub maps: [[Vec<f64>; 3]; 2],
    pub map_first: [usize; 2],
    /// The iterate, with u^α_p on body α's ranks (whole while the record is the newest, then
    /// at the nodes of the rank's rows of the output, [`EstimateRecord::keep_rows`]), and t̂^c.
    pub iterate: Iterate,
    /// The pair side's displacement at its Γc nodes (x, y per pair; empty on the ranks
    /// without that body's field) once the record is kept for the output, its iterate's
    /// displacement no longer holding them; `None` before.
    pub contact_displacement: Option<Vec<f64>>,
    pub t_hat: Vec<f64>,
}

impl EstimateRecord {
    /// η_E of map `j` (0: η^glo, 1: η^FE, 2: η^NNDD) at body k + 1's element `e`; 0 where
    /// this rank holds no value for it.
    pub fn eta_at(&self, k: usize, j: usize, e: usize) -> f64 {
        held::value_at(&self.maps[k][j], self.map_first[k], e)
    }

    /// Keep what this rank writes of the record in the output alone (`io::fields::kept_rows`):
    /// each body's maps on its elements `cells[k]`, its displacement at its nodes `nodes[k]`,
    /// and the pair side's displacement at Γc (`contact` of the bodies' displacements, taken
    /// before they are cut), rather than the whole bodies' for every estimated step. A
    /// record kept already is left as it is.
    pub fn keep_rows(
        &mut self,
        cells: &[Range<usize>; 2],
        nodes: &[Vec<usize>; 2],
        contact: impl FnOnce(&[Displacement; 2]) -> Vec<f64>,
    ) {
        if self.contact_displacement.is_some() {
            return;
        }
        self.contact_displacement = Some(contact(&self.iterate.u));
        for k in 0..2 {
            let first = self.map_first[k];
            for m in self.maps[k].iter_mut().filter(|m| !m.is_empty()) {
                *m = held::keep(m, first, &cells[k]);
            }
            self.map_first[k] = cells[k].start.max(first);
            let u = &mut self.iterate.u[k];
            if !u.is_empty() {
                *u = u.keep(&nodes[k]);
            }
        }
    }
}

/// Computes the estimates of NNDD iterates (collective over all ranks).
pub struct Estimator<'a> {
    iface: Interface,
    qp: QpSettings,
    recovery: Recovery,
    /// `-nndd_recovery_warm_change`: the largest relative change of a body's displacement
    /// for which a recovery starts warm ([`crate::estimate::view::View::prepare`]).
    warm_change: f64,
    nndd_variant: NnddVariant,
    layout: &'a Layout,
    reference: Option<Reference>,
    /// The two bodies' problems (every rank has both: any rank may estimate elements of
    /// either, [`crate::estimate::share`]).
    problems: [Rc<BodyProblem>; 2],
    /// Per body, this rank's share of the element work (built at the first estimate).
    shares: [OnceCell<Share>; 2],
    /// The time of each part of the estimates.
    parts: Parts,
    /// Per body, the recovery's local operators on this rank, kept across estimates.
    operators: [RefCell<OperatorCache>; 2],
    /// [`Estimator::eta_nndd_without_fields`], agreed over the ranks at its first use.
    cheap_nndd: OnceCell<bool>,
    /// The estimate in progress recovers η^glo cold ([`Estimator::estimate_cold`]).
    cold: Cell<bool>,
    /// The most nodes at which this rank held an estimate's u^α_p (a mortar run's: carried
    /// to the matched meshes too), both bodies' counts.
    held_nodes: Cell<usize>,
    /// A mortar run's: its iterates carried to the matched meshes `problems` are
    /// ([`MortarEstimates`]).
    mortar: Option<MortarEstimates>,
    /// The friction law (`-nndd_friction`; its estimates need a straight Γc).
    friction: FrictionLaw,
    /// How the bodies are dealt over their groups (`-nndd_partition`): in index blocks, a
    /// body estimated on its group alone is estimated in those blocks too.
    partitioner: Partitioner,
}

/// The free heap (bytes) from which an estimate gives the memory back between its two
/// recoveries ([`crate::os::memory::release_free_memory`]): large meshes only.
const TRIM_BYTES: usize = 64 << 20;

/// The nodal contact forces μ̂ ≥ 0 of the discrete η^NNDD: max(½(T² − T¹), 0) on the contact
/// set, 0 where body 2 is off the obstacle (any μ̂ ≥ 0 is admissible; this one is exact at the
/// discrete solution in both terms).
fn nodal_contact_forces(it: &Iterate) -> Vec<f64> {
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

/// The elements of a body that an estimating rank reads, its share's recoveries reading
/// `recovered` (`None`: every element, [`Share::elements_read`]): those, with the body's Γc
/// elements `gc` ([`contact_elements`]), which its contact terms read, where it recovers some.
pub(crate) fn elements_read_by(recovered: Option<Vec<u32>>, gc: &[u32]) -> Option<Vec<u32>> {
    let mut read = recovered?;
    if !read.is_empty() {
        read.extend_from_slice(gc);
    }
    Some(read)
}

/// The elements of body `p` along Γc (one per segment; O(N) on the held mesh).
pub(crate) fn contact_elements(p: &BodyProblem) -> Vec<u32> {
    let gc = p.mesh().chain_elements(&p.contact_nodes);
    gc.into_iter().flatten().map(element_u32).collect()
}

/// The jumps û²_k − û¹_k (x, y) of the iterate at the Γc pairs, on every rank (collective over
/// all ranks: each body's first rank contributes its trace).
fn contact_jumps(layout: &Layout, bodies: [Option<&Body>; 2], it: &Iterate) -> Vec<[f64; 2]> {
    let m = it.lambda.len();
    let mut sum = vec![0.0; 2 * m];
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body.filter(|b| b.is_root()) {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            for (i, &node) in b.problem.contact_nodes.iter().enumerate() {
                sum[2 * i] += sign * it.u[k][2 * node];
                sum[2 * i + 1] += sign * it.u[k][2 * node + 1];
            }
        }
    }
    layout.world_sum(&mut sum);
    sum.chunks(2).map(|c| [c[0], c[1]]).collect()
}

impl<'a> Estimator<'a> {
    /// The estimator of a run on `layout` as `settings` ask, the admissible tractions' QPs
    /// solved with `qp`, with the `reference` solution of (26) if any; its parts timed in the
    /// `-log_view` stages `stages` (`Stages::estimation_parts`) if given. Its caches (the
    /// elements' owners and shares, the recovery's operators) are made at the first estimate.
    pub fn new(
        settings: &EstimateSettings,
        qp: &QpSettings,
        layout: &'a Layout,
        problems: &[Rc<BodyProblem>; 2],
        reference: Option<Reference>,
        stages: Option<[LogStage; 6]>,
    ) -> Estimator<'a> {
        Estimator {
            iface: Interface::new(problems[0].contact_lengths.clone()),
            qp: qp.clone(),
            recovery: settings.recovery,
            warm_change: settings.warm_change,
            nndd_variant: settings.nndd_variant,
            layout,
            reference,
            problems: problems.clone(),
            shares: Default::default(),
            parts: Parts::new(stages),
            operators: Default::default(),
            cheap_nndd: Default::default(),
            cold: Default::default(),
            held_nodes: Default::default(),
            mortar: None,
            friction: FrictionLaw::Frictionless,
            partitioner: Partitioner::default(),
        }
    }

    /// The estimator of a run whose bodies are dealt over their groups by `how`
    /// (`-nndd_partition`): with index blocks, a body estimated on its group alone is
    /// estimated in the same blocks, so that a rank's estimates read its block and the rings
    /// of neighbours its recoveries need ([`crate::estimate::share::block_owners`]).
    pub fn with_partitioner(mut self, how: Partitioner) -> Estimator<'a> {
        self.partitioner = how;
        self
    }

    /// The estimator of a run with friction `law` (docs/method.md §9).
    pub fn with_friction(mut self, law: FrictionLaw) -> Estimator<'a> {
        self.friction = law;
        self
    }

    /// The tangential data of the estimates of a frictional iterate (straight Γc): the
    /// admissible tangential densities of η^glo (from ½(T¹_t − T²_t)) and of η^FE (from −T²_t)
    /// clipped to their bounds, the jumps ŵ_t, λ_t, body 1's reaction and the discrete
    /// η^NNDD's nodal forces.
    fn friction_data(
        &self,
        t: &Tangential,
        t_glo: &[f64],
        t_fe: &[f64],
        mu_hat: &[f64],
        jumps: &[[f64; 2]],
    ) -> FrictionData {
        let n = self.problems[0].contact_normals[0];
        let tau = [n[1], -n[0]];
        let target: Vec<f64> = t.forces[0]
            .iter()
            .zip(&t.forces[1])
            .map(|(a, b)| 0.5 * (a - b))
            .collect();
        let glo_bound = friction::density_bound(self.friction, t_glo);
        let minus_t2: Vec<f64> = t.forces[1].iter().map(|v| -v).collect();
        let fe_bound = friction::density_bound(self.friction, t_fe);
        let shares = crate::problem::pair_shares([&self.problems[0], &self.problems[1]]);
        let (mu_t, mu_bound) = friction::nodal_forces(self.friction, t, &shares, mu_hat);
        FrictionData {
            tau,
            glo_t: friction::clip(&self.iface.density(&target), &glo_bound),
            glo_bound,
            // ŵ_t = û¹_t − û²_t, the jumps being û² − û¹.
            glo_w: jumps
                .iter()
                .map(|j| -(j[0] * tau[0] + j[1] * tau[1]))
                .collect(),
            fe_t: friction::clip(&self.iface.density(&minus_t2), &fe_bound),
            fe_bound,
            lambda_t: t.trace1.clone(),
            reaction1: t.forces[0].clone(),
            mu_t,
            mu_bound,
        }
    }

    /// The estimator of a mortar run: `problems` (given to [`Estimator::new`], and the
    /// reference's) are the matched ones of `mortar`, the iterates the run's.
    pub fn with_mortar(mut self, mortar: MortarEstimates) -> Estimator<'a> {
        self.mortar = Some(mortar);
        self
    }

    /// The iterations of the reference solution's NNDD (none without one).
    pub fn reference_iterations(&self) -> Option<usize> {
        self.reference.as_ref().map(|r| r.iterations)
    }

    /// The most nodes at which this rank held an estimate's iterate u^α_p (both bodies'
    /// counts; what its recoveries read, or the iterate's own field where that is whole; a
    /// mortar run's carried to the matched meshes too).
    pub fn held_nodes(&self) -> usize {
        self.held_nodes.get()
    }

    /// The elements of a mortar run's estimates' matched meshes this rank holds (both bodies':
    /// its parts where world rank 0 dealt them, `app::input::deal_matched`); `None` for any
    /// other run.
    pub fn matched_mesh_elements(&self) -> Option<usize> {
        self.mortar.as_ref()?;
        let held = (self.problems.iter()).filter(|p| p.holds_mesh());
        Some(held.map(|p| p.mesh().triangles.held_len()).sum())
    }

    /// The nodes at which this rank held the reference solution's fields (none without one).
    pub fn reference_held_nodes(&self) -> Option<usize> {
        self.reference.as_ref().map(|r| r.held_nodes)
    }

    /// This rank's peak memory (MiB) once the reference solution's fine bodies were built,
    /// where it was solved ([`Reference::input_peak_mib`]).
    pub fn reference_input_peak_mib(&self) -> Option<f64> {
        self.reference.as_ref().map(|r| r.input_peak_mib)
    }

    /// The elements of the fine meshes this rank held in the reference solution's input,
    /// where it was solved ([`Reference::input_elements`]).
    pub fn reference_input_elements(&self) -> Option<usize> {
        self.reference.as_ref().map(|r| r.input_elements)
    }

    /// The elements of the fine meshes this rank held for the reference solution, where it
    /// was solved ([`Reference::held_elements`]).
    pub fn reference_held_elements(&self) -> Option<usize> {
        self.reference.as_ref().map(|r| r.held_elements)
    }

    /// The run's two problems, whose elements the records' η maps and whose dofs their
    /// iterates' displacements are on (a mortar run's own, not the matched meshes its
    /// estimates are made on).
    pub fn run_problems(&self) -> [&BodyProblem; 2] {
        let problems = self.mortar.as_ref().map_or(&self.problems, |m| &m.problems);
        [&problems[0], &problems[1]]
    }

    /// Seconds spent in each part of the estimates on this rank, in [`Part`]'s order.
    pub fn part_seconds(&self) -> [f64; 6] {
        self.parts.seconds()
    }

    /// Whether [`Estimator::eta_nndd`] can do without the fields of the iterate (every body
    /// has its interface operators); the same answer on every rank.
    pub fn eta_nndd_without_fields(&self, bodies: [Option<&Body>; 2]) -> bool {
        *self.cheap_nndd.get_or_init(|| {
            let missing = bodies.iter().flatten().any(|b| !b.has_condensed());
            self.layout.max(missing as u8 as f64) == 0.0
        })
    }

    /// η^NNDD alone, discrete variant, without any stress recovery: what the balanced
    /// stopping rule checks at every iteration, the same number as [`Estimator::estimate`]
    /// gives. Per body, ũ − u_p solves the Neumann system with loads on the Γc normal dofs
    /// only: the re-solve's nodal forces ∓μ̂ less the iterate's Γc forces T^α_p (u¹_p, the
    /// Dirichlet step's solution, is the Neumann solution with its reaction T¹_p). So
    /// (ũ − u_p)ᵀK(ũ − u_p) = Δᵀ D^α Δ, Δ = ∓μ̂ − T^α_p, with the body's Delassus operator
    /// D^α = (S^α)⁻¹ (m × m, on its first rank): no back-solve. A body without its interface
    /// operators makes the Neumann re-solve and (ũ − u_p)ᵀK(ũ − u_p) instead.
    /// Plus the nodal contact pairing of body 2, 2 Σ μ̂_i |u²_n − λ + g₀|_i, when body 2's field
    /// is formed; it is zero anyway node to node (μ̂ vanishes off the contact set, and on it the
    /// contact step puts u²_n = λ − g₀ exactly; under the mortar operators to the contact
    /// step's tolerance, [`MortarEstimates::nndd_maps`]), so the check needs the Γc forces only when every body
    /// has its S^α ([`Estimator::eta_nndd_without_fields`]).
    pub fn eta_nndd(&self, bodies: [Option<&Body>; 2], it: &Iterate) -> Result<f64, EstimateError> {
        let mu_hat = nodal_contact_forces(it);
        let mut sum = 0.0;
        for (k, body) in bodies.iter().enumerate() {
            if let Some(b) = body {
                let sign = if k == 0 { 1.0 } else { -1.0 };
                let f: Vec<f64> = mu_hat.iter().map(|m| -sign * m).collect();
                let energy = match (b.has_condensed(), b.condensed()) {
                    (true, None) => 0.0, // another rank of the group holds D^α
                    (true, Some(c)) => self.parts.run(Part::ElementSums, || {
                        let delta: Vec<f64> =
                            f.iter().zip(&it.forces[k]).map(|(a, t)| a - t).collect();
                        let mut x = vec![0.0; delta.len()];
                        c.delassus.matvec(&delta, &mut x);
                        delta.iter().zip(&x).map(|(a, b)| a * b).sum::<f64>()
                    }),
                    (false, _) => {
                        // (held where the iterate's field is: no whole vector)
                        let u_d = self
                            .parts
                            .run(Part::Resolves, || b.neumann_field(&f, true))?;
                        let d = it.u[k].subtracted_from(&u_d);
                        self.parts.run(Part::ElementSums, || b.quadratic(&d))?
                    }
                };
                if !b.is_root() {
                    continue; // counted once per group
                }
                sum += energy;
                if k == 1 && !it.u[1].is_empty() {
                    let u2n = b.normal_trace(&it.u[1]);
                    let obstacle = b.problem.obstacle(&it.lambda);
                    sum += (0..mu_hat.len())
                        .map(|i| 2.0 * mu_hat[i] * (u2n[i] - obstacle[i]).abs())
                        .sum::<f64>();
                }
            }
        }
        Ok(self
            .parts
            .run(Part::Reduction, || self.layout.sum(sum))
            .max(0.0)
            .sqrt())
    }

    /// η^glo, η^FE, η^NNDD (and e_ref, γ with a reference) of the iterate `it`.
    pub fn estimate(
        &self,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
    ) -> Result<EstimateRecord, EstimateError> {
        self.run(bodies, it, false)
    }

    /// [`Estimator::estimate`] with its η^glo recovery started cold, whatever the estimates
    /// before (its η^FE recovery may start from that one, as in any estimate):
    /// the bound of an iterate that does not depend on which iterates were estimated before it
    /// (the warm start of `-nndd_recovery_warm_change` changes the recovered stress, and η^glo
    /// by up to a few per cent: `paper` n = 16, 2.9514 warm against 3.0217 cold).
    pub fn estimate_cold(
        &self,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
    ) -> Result<EstimateRecord, EstimateError> {
        self.cold.set(true);
        let rec = self.run(bodies, it, false);
        self.cold.set(false);
        rec
    }

    /// [`Estimator::estimate_cold`] in two parts: the re-solves now (with the bodies), the
    /// rest by [`Estimator::finish_cold`] once the caller has freed the bodies'
    /// factorisations; a mortar run's estimate (which needs its bodies to the end) is made
    /// whole here.
    pub fn resolve_cold(
        &self,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
    ) -> Result<InParts, EstimateError> {
        if self.mortar.is_some() {
            return Ok(InParts::Done(Box::new(self.estimate_cold(bodies, it)?)));
        }
        let resolved = self.resolve(bodies, it, false, ReactionOf::Own, None)?;
        Ok(InParts::Resolved(Box::new(resolved)))
    }

    /// The rest of [`Estimator::resolve_cold`]'s estimate of an iterate whose fields are `u`
    /// (collective; no body needed).
    pub fn finish_cold(
        &self,
        parts: InParts,
        u: &[Displacement; 2],
    ) -> Result<EstimateRecord, EstimateError> {
        match parts {
            InParts::Done(rec) => Ok(*rec),
            InParts::Resolved(r) => {
                self.cold.set(true);
                let rec = self.recover(*r, u);
                self.cold.set(false);
                rec
            }
        }
    }

    /// Whether an estimate may start its recoveries from an earlier one's (so that it may
    /// differ from [`Estimator::estimate_cold`]).
    pub fn starts_warm(&self) -> bool {
        self.warm_change > 0.0 && self.recovery.starts_warm()
    }

    /// η^FE alone of the iterate `it` (one recovery per body, and body 2's re-solve): what
    /// the balanced stopping rule compares η^NNDD with at its first check.
    pub fn eta_fe(&self, bodies: [Option<&Body>; 2], it: &Iterate) -> Result<f64, EstimateError> {
        Ok(self.run(bodies, it, true)?.eta_fe)
    }

    /// The elements of each body this rank's estimates read (collective: the shares are made
    /// here where not yet, [`Estimator::shares`]): `None` where they read every one (the
    /// rank estimates the whole body), else its overlap's with the Γc elements its contact
    /// terms read, and the coarse elements under its part of e_ref's fine ones.
    pub(crate) fn elements_read(&self) -> [Option<Vec<u32>>; 2] {
        let shares = self.shares(self.crosses());
        [0, 1].map(|k| {
            let p = &self.problems[k];
            let recovered = shares[k].elements_read()?;
            let mut read = match recovered.is_empty() {
                true => recovered,
                false => elements_read_by(Some(recovered), &contact_elements(p))?,
            };
            if let Some(part) = self.reference.as_ref().and_then(|r| r.part(k)) {
                read.extend(part.coarse_elements(p.num_elements()).map(element_u32));
            }
            Some(read)
        })
    }

    /// Makes this rank's shares of the bodies' estimates from `seeds`, world rank 0's plan of
    /// them (`-nndd_mesh_input root`), rather than from the bodies' whole meshes at the first
    /// estimate (collective, as [`Estimator::shares`]).
    pub(crate) fn take_shares(&self, seeds: [Seed; 2]) {
        let crosses = self.crosses();
        for (k, seed) in seeds.into_iter().enumerate() {
            let share = self
                .parts
                .run(Part::Recovery, || seed.share(crosses[k], self.layout));
            if self.shares[k].set(share).is_err() {
                panic!("the shares of body {} were made already", k + 1);
            }
        }
    }

    /// Reads `problems` from now on: the run's, each body's mesh cut to the part this rank
    /// reads ([`Estimator::elements_read`]).
    pub(crate) fn hold(&mut self, problems: &[Rc<BodyProblem>; 2]) {
        self.problems = problems.clone();
    }

    /// Per body, whether some of its elements are estimated outside its group (those ranks
    /// then gather its fields from the group's blocks), from the element counts alone
    /// ([`crate::estimate::share::estimating_ranks`]).
    fn crosses(&self) -> [bool; 2] {
        let sizes = self.problems.each_ref().map(|p| p.num_elements());
        estimated_outside_group(sizes, self.layout)
    }

    /// Whether a stop signal arrived on any rank (`Err(Stopped)` on every rank then): one
    /// reduction over all ranks, at points every rank passes in the same order. Between the
    /// estimate's parts, so that a signal during an estimate of the NNDD loop is acted on
    /// before the next part rather than after the whole estimate.
    fn stop_point(&self) -> Result<(), EstimateError> {
        let mine = crate::os::signals::stop_requested() as u8 as f64;
        // (an agreement over the ranks: part of the reductions, with its waits)
        if self.parts.run(Part::Reduction, || self.layout.max(mine)) > 0.0 {
            return Err(EstimateError::Stopped);
        }
        Ok(())
    }

    /// The estimates of `it`; with `fe_only`, η^FE alone (the other totals are zero, and
    /// there is no e_ref).
    fn run(
        &self,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
        fe_only: bool,
    ) -> Result<EstimateRecord, EstimateError> {
        match &self.mortar {
            None => {
                let resolved = self.resolve(bodies, it, fe_only, ReactionOf::Own, None)?;
                self.recover(resolved, &it.u)
            }
            Some(m) => self.run_mortar(m, bodies, it, fe_only),
        }
    }

    /// [`Estimator::run`] of a mortar run (docs/method.md §7, "The estimates"): η^glo and η^FE
    /// of the iterate carried to the matched meshes, plus ‖δ_n‖ (combined as §5 combines the
    /// bubbles: (1 + θ)Q + (1 + 1/θ)‖δ_n‖² with θ = ‖δ_n‖/√Q, i.e. (√Q + ‖δ_n‖)²), their maps
    /// summed onto the run's elements; η^NNDD the mortar-discrete one.
    fn run_mortar(
        &self,
        m: &MortarEstimates,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
        fe_only: bool,
    ) -> Result<EstimateRecord, EstimateError> {
        let carried = self.parts.run(Part::Reduction, || {
            m.carry(self.layout, bodies, &self.problems, &self.iface, it)
        })?;
        let held: usize = carried.iterate.u.iter().map(|u| u.len() / 2).sum();
        self.held_nodes.set(self.held_nodes.get().max(held));
        let resolved = self.resolve(
            m.bodies(),
            &carried.iterate,
            fe_only,
            ReactionOf::Resolved,
            Some(carried.u_plain.clone()),
        )?;
        let mut rec = self.recover(resolved, &carried.iterate.u)?;
        let q = rec.eta_glo * rec.eta_glo;
        let lift2 = (carried.lift_elements.iter().flatten())
            .map(|(_, l)| l)
            .sum::<f64>();
        let theta = if lift2 > 0.0 && q > 0.0 {
            (lift2 / q).sqrt()
        } else {
            0.0
        };
        for (k, maps) in rec.maps.iter_mut().enumerate() {
            if bodies[k].is_some() {
                let first = &mut rec.map_first[k];
                let lift = &carried.lift_elements[k];
                *first = self.parts.run(Part::Reduction, || {
                    onto_run_elements(self.layout, m, k, (maps, *first), theta, lift)
                });
            }
        }
        if !fe_only {
            rec.eta_glo += lift2.sqrt();
            rec.correction += lift2.sqrt();
            let mu_hat = nodal_contact_forces(it);
            let (maps, total) = self.parts.run(Part::Resolves, || {
                m.nndd_maps(self.layout, bodies, it, &mu_hat)
            })?;
            for (k, map) in maps.into_iter().enumerate() {
                if bodies[k].is_some() {
                    rec.maps[k][2] = map.iter().map(|v| v.max(0.0).sqrt()).collect();
                }
            }
            rec.eta_nndd = total.max(0.0).sqrt();
        }
        let glo2 = rec.eta_glo * rec.eta_glo;
        rec.eta_ratio = if glo2 > 0.0 {
            (rec.eta_fe * rec.eta_fe + rec.eta_nndd * rec.eta_nndd) / glo2
        } else {
            f64::NAN
        };
        rec.effectivity = rec.e_ref.map(|e| rec.eta_glo / e);
        rec.iterate = it.clone();
        rec.t_hat = m.at_pairs(&rec.t_hat);
        Ok(rec)
    }
}

/// A mortar run's η^glo and η^FE maps of body `k`'s matched mesh (`maps.0[0..2]`, this rank's
/// block of its elements from element `maps.1` on) onto the run's elements: squared, η^glo's
/// times (1 + θ) plus (1 + 1/θ) times the lift's energy `lift` on the elements it moves where
/// θ > 0 ([`Estimator::run_mortar`]), sent to the ranks whose blocks of the run's elements
/// hold their parents and summed there ([`held::add_to_blocks`]); η^NNDD's map zero until
/// [`MortarEstimates::nndd_maps`] fills it. Returns the first run element of this rank's
/// block (collective over the body's group).
fn onto_run_elements(
    layout: &Layout,
    m: &MortarEstimates,
    k: usize,
    (maps, first): (&mut [Vec<f64>; 3], usize),
    theta: f64,
    lift: &[(usize, f64)],
) -> usize {
    let mine = first..first + maps[0].len();
    let squares = |map: &[f64]| map.iter().map(|v| v * v).collect::<Vec<f64>>();
    let (mut glo, fe) = (squares(&maps[0]), squares(&maps[1]));
    if theta > 0.0 {
        glo.iter_mut().for_each(|v| *v *= 1.0 + theta);
        for &(e, l) in lift.iter().filter(|(e, _)| mine.contains(e)) {
            glo[e - first] += (1.0 + 1.0 / theta) * l;
        }
    }
    let parents: Vec<u32> = mine.map(|e| element_u32(m.parent(k, e))).collect();
    let ([glo, fe], start) =
        held::add_to_blocks(layout, k + 1, m.run_elements(k), &parents, [&glo, &fe]);
    let roots = |map: Vec<f64>| map.into_iter().map(f64::sqrt).collect::<Vec<f64>>();
    let zeros = vec![0.0; glo.len()];
    *maps = [roots(glo), roots(fe), zeros];
    start
}
