//! An estimate in two parts: [`Estimator::resolve`] (the Γc data and the bodies' re-solves,
//! which need the bodies' factorisations) and [`Estimator::recover`] (the recoveries, the
//! element sums and e_ref, which need none), so that a run's last estimate can follow the
//! release of the factorisations: its peak memory is then the larger of the two phases',
//! not their sum (docs/scaling.md, "Memory per rank").

use std::borrow::Cow;

use super::*;
use crate::dd::body::{FieldAt, Solved};
use crate::dd::displacement::{self, Displacement};
use crate::estimate::polygon::{EdgeValues, SegmentGap};
use crate::estimate::view::View;

/// What body 1's Γc forces T¹_p are, for its η^FE recovery ([`Reaction`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum ReactionOf {
    /// The NNDD's own iterate's reaction.
    Own,
    /// A mortar iterate carried to the matched meshes, body 1 re-solved with them.
    Resolved,
}

impl ReactionOf {
    fn of(self, forces: &[f64]) -> Reaction<'_> {
        match self {
            ReactionOf::Own => Reaction::Own(forces),
            ReactionOf::Resolved => Reaction::Resolved(forces),
        }
    }
}

/// An estimate after [`Estimator::resolve`]: the iterate without its fields, its Γc data and
/// the bodies' re-solves (u^α_p not copied: [`Estimator::recover`] takes it from the caller).
pub struct Resolved {
    it: Iterate,
    fe_only: bool,
    reaction1: ReactionOf,
    plain: Option<[Displacement; 2]>,
    /// u^α_p at the coarse nodes this rank's part of the reference solution reads, where the
    /// iterate's field is held at other nodes ([`Estimator::reference_fields`]; `None`: e_ref
    /// reads `plain` or the iterate's field as it is).
    reference_u: [Option<Displacement>; 2],
    t_glo: Vec<f64>,
    t_fe: Vec<f64>,
    mu_hat: Vec<f64>,
    friction: Option<FrictionData>,
    glo_factors: Vec<[f64; 2]>,
    glo_edges: Vec<EdgeValues>,
    glo_forces: Vec<[f64; 2]>,
    gaps: Vec<SegmentGap>,
    fields: [BodyFields<'static>; 2],
}

impl Resolved {
    /// What the recoveries of this iterate read (its Γc data), with `est`'s settings.
    fn data<'a>(&'a self, est: &Estimator) -> IterationData<'a> {
        IterationData {
            lambda: &self.it.lambda,
            t_glo: &self.t_glo,
            glo_factors: &self.glo_factors,
            glo_edges: &self.glo_edges,
            glo_forces: &self.glo_forces,
            gaps: &self.gaps,
            t_fe: &self.t_fe,
            reaction1: self.reaction1.of(&self.it.forces[0]),
            mu_hat: &self.mu_hat,
            friction: self.friction.as_ref(),
            nndd_variant: est.nndd_variant,
            recovery: est.recovery,
            fe_only: self.fe_only,
        }
    }
}

/// A cold estimate between its parts ([`Estimator::resolve_cold`]).
pub enum InParts {
    /// Re-solved; the rest to come.
    Resolved(Box<Resolved>),
    /// Made whole (a mortar run's).
    Done(Box<EstimateRecord>),
}

impl BodyFields<'_> {
    /// These fields without the borrow of u^α_p (kept where it was made or shared here).
    fn detached(self) -> BodyFields<'static> {
        BodyFields {
            u_p: match self.u_p {
                Cow::Owned(v) => Cow::Owned(v),
                Cow::Borrowed(_) => Cow::Borrowed(&displacement::NONE),
            },
            u_tilde: self.u_tilde,
            u_d: self.u_d,
            u_fe: self.u_fe,
        }
    }
}

impl BodyFields<'static> {
    /// These fields with u^α_p borrowed from `u` where it was not kept.
    fn on(self, u: &Displacement) -> BodyFields<'_> {
        BodyFields {
            u_p: match self.u_p {
                Cow::Owned(v) => Cow::Owned(v),
                Cow::Borrowed(_) => Cow::Borrowed(u),
            },
            u_tilde: self.u_tilde,
            u_d: self.u_d,
            u_fe: self.u_fe,
        }
    }
}

impl Estimator<'_> {
    /// An estimate's first part: its Γc data and the bodies' re-solves (collective; the
    /// bodies' factorisations are used here only). `reaction1` says what body 1's Γc forces
    /// are (its η^FE data); e_ref is of the fields `plain` (u^α_p, where `it` has a mortar
    /// iterate's û^α; `None`: `it`'s own).
    pub(crate) fn resolve(
        &self,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
        fe_only: bool,
        reaction1: ReactionOf,
        plain: Option<[Displacement; 2]>,
    ) -> Result<Resolved, EstimateError> {
        crate::parallel::fault::check(crate::parallel::fault::Phase::Estimate)?;
        self.stop_point()?;
        let layout = self.layout;
        // The admissible Γc tractions (the same small QPs on every rank).
        let target: Vec<f64> = it.forces[0]
            .iter()
            .zip(&it.forces[1])
            .map(|(a, b)| 0.5 * (a - b))
            .collect();
        let minus_t2: Vec<f64> = it.forces[1].iter().map(|t| -t).collect();
        let (t_glo, t_fe) = self.parts.run(Part::TractionQp, || {
            let t_fe = self.iface.admissible_traction(&minus_t2, &self.qp)?;
            let t_glo = if fe_only {
                t_fe.clone() // unused
            } else {
                self.iface.admissible_traction(&target, &self.qp)?
            };
            Ok::<_, EstimateError>((t_glo, t_fe))
        })?;
        let mu_hat = nodal_contact_forces(it);
        let jumps = if fe_only {
            Vec::new()
        } else {
            self.parts
                .run(Part::Reduction, || contact_jumps(layout, bodies, it))
        };
        // With friction (a straight Γc): the tangential halves of the admissible tractions.
        let friction = it
            .tangential
            .as_ref()
            .filter(|_| self.friction.is_frictional())
            .map(|t| self.friction_data(t, &t_glo, &t_fe, &mu_hat, &jumps));
        // η^glo's traction parallel to the normal field, and the iterate's gap along it
        // (docs/method.md §5), plus its tangential part with friction.
        let normals = &self.problems[0].contact_normals;
        let glo_factors = polygon::factors(normals, &t_glo);
        let mut glo_edges = polygon::edge_traction(normals, &glo_factors);
        if let Some(f) = &friction {
            for (k, e) in glo_edges.iter_mut().enumerate() {
                for (end, v) in e.iter_mut().enumerate() {
                    let t = f.glo_t[k + end];
                    v[0] += t * f.tau[0];
                    v[1] += t * f.tau[1];
                }
            }
        }
        let glo_forces = polygon::nodal_forces(&self.iface.lengths, &glo_edges);
        let gaps = if fe_only {
            Vec::new()
        } else {
            polygon::segment_gaps(normals, &self.problems[0].gap, &jumps)
        };
        let mut resolved = Resolved {
            it: it.without_fields(),
            fe_only,
            reaction1,
            plain,
            reference_u: [None, None],
            t_glo,
            t_fe,
            mu_hat,
            friction,
            glo_factors,
            glo_edges,
            glo_forces,
            gaps,
            fields: Default::default(),
        };
        let data = resolved.data(self);
        let crosses = self.crosses();
        // The re-solves on each body's group, held on their owners.
        let mut solved: [Option<Solved>; 2] = [None, None];
        for (k, body) in bodies.iter().enumerate() {
            if let Some(b) = body {
                solved[k] = Some(body_resolves(b, &self.iface, &data, &self.parts)?);
            }
        }
        // Who estimates which elements (made at the first estimate, after the solves and
        // their workspace): each rank gathers the re-solves and the iterate's field where its
        // recoveries read them, on its overlap of the body. Where some of the body's elements
        // are estimated outside its group, each rank of the group gathers them at its block
        // of the body's nodes, and every rank gathers its overlap from those blocks: no whole
        // field either way.
        let views = self.shares(crosses).map(|s| s.view(layout));
        let mut fields: [BodyFields; 2] = Default::default();
        for (k, body) in bodies.iter().enumerate() {
            let block: Vec<usize> = match crosses[k] {
                true => layout.block(k + 1, self.problems[k].num_nodes()).collect(),
                false => Vec::new(),
            };
            let at = match (crosses[k], &views[k]) {
                (true, _) => FieldAt::Nodes(&block),
                (false, Some(view)) => view.field_at(),
                (false, None) => FieldAt::Nodes(&[]),
            };
            if let (Some(b), Some(s)) = (body, solved[k].take()) {
                fields[k] = body_fields(b, s, &it.u[k], &data, &self.parts, at)?;
            }
            if crosses[k] {
                let held = std::mem::take(&mut fields[k]);
                let view = views[k].as_ref();
                fields[k] = (self.parts).run(Part::Reduction, || {
                    self.fields_from_blocks(k, held, &block, view)
                });
            }
        }
        let held: usize = fields.iter().map(|f| f.u_p.len() / 2).sum();
        self.held_nodes.set(self.held_nodes.get().max(held));
        resolved.fields = fields.map(BodyFields::detached);
        if !fe_only {
            let u = resolved.plain.as_ref().unwrap_or(&it.u);
            resolved.reference_u = self.reference_fields(bodies, u)?;
        }
        Ok(resolved)
    }

    /// Body α's (α = `k + 1`) fields where some of its elements are estimated outside its
    /// group: `held` on each rank of the group at its `block` of the body's nodes (nothing
    /// elsewhere), gathered on every rank where its `view` reads them, its overlap's nodes
    /// and Γc's ([`held::from_blocks`]; collective over all ranks).
    fn fields_from_blocks(
        &self,
        k: usize,
        held: BodyFields,
        block: &[usize],
        view: Option<&View>,
    ) -> BodyFields<'static> {
        let (layout, p) = (self.layout, &self.problems[k]);
        let u_p: Vec<f64> = (block.iter())
            .flat_map(|&n| [held.u_p[2 * n], held.u_p[2 * n + 1]])
            .collect();
        // (the re-solves the estimate made, known on the group alone)
        let resolves = [&held.u_tilde, &held.u_d, &held.u_fe];
        let mut made = resolves.map(|v| (!v.is_empty()) as u8 as f64);
        layout.world_sum(&mut made);
        let nodes = match view {
            Some(View::Overlap(o, ..)) => p.with_contact_nodes(&o.nodes),
            Some(_) => p.with_contact_nodes(&[]),
            None => Vec::new(),
        };
        let blocks: Vec<&[f64]> = std::iter::once(&u_p)
            .chain(
                resolves
                    .into_iter()
                    .zip(made)
                    .filter(|(_, m)| *m > 0.0)
                    .map(|(v, _)| v),
            )
            .map(Vec::as_slice)
            .collect();
        let mut gathered =
            held::from_blocks(layout, k + 1, p.num_nodes(), &blocks, &nodes).into_iter();
        let at: std::sync::Arc<[u32]> = nodes.iter().map(|&n| n as u32).collect();
        let mut next = || Displacement::at_nodes(at.clone(), gathered.next().expect("a field"));
        let u_p = next();
        let mut local = |m: f64| match m > 0.0 {
            true => {
                let field = next();
                view.map_or(Vec::new(), |v| v.local_of(&field).into_owned())
            }
            false => Vec::new(),
        };
        BodyFields {
            u_tilde: local(made[0]),
            u_d: local(made[1]),
            u_fe: local(made[2]),
            u_p: Cow::Owned(u_p),
        }
    }

    /// The iterate's fields u^α_p `u` gathered at the coarse nodes under this rank's block of
    /// the reference solution's fine elements ([`ReferencePart::coarse_nodes`]) where its
    /// body's group holds them at other nodes: e_ref's transfer reads no whole field
    /// (collective over each body's group). `None` where there is no reference, or the field
    /// is whole.
    ///
    /// [`ReferencePart::coarse_nodes`]: crate::estimate::reference::ReferencePart::coarse_nodes
    fn reference_fields(
        &self,
        bodies: [Option<&Body>; 2],
        u: &[Displacement; 2],
    ) -> Result<[Option<Displacement>; 2], EstimateError> {
        let mut at = [None, None];
        let Some(r) = &self.reference else {
            return Ok(at);
        };
        for (k, body) in bodies.iter().enumerate() {
            let (Some(b), Some(part)) = (body, r.part(k)) else {
                continue;
            };
            if u[k].as_whole().is_none() {
                let coarse = self.problems[k].mesh();
                let nodes = (self.parts).run(Part::ReferenceError, || part.coarse_nodes(coarse))?;
                at[k] = Some(b.displacement_at(&u[k], FieldAt::Nodes(&nodes))?);
            }
        }
        Ok(at)
    }

    /// Who estimates which elements of each body, and the overlaps and halos of this rank's
    /// ([`Share`]): made at the first estimate (collective), kept for the others.
    pub(super) fn shares(&self, crosses: [bool; 2]) -> [&Share; 2] {
        let sizes = self.problems.each_ref().map(|p| p.num_elements());
        [0, 1].map(|k| {
            self.shares[k].get_or_init(|| {
                self.parts.run(Part::Recovery, || {
                    // (the estimating rank of each of the body's elements, made where the
                    // rank takes part in the body's estimates and freed with its share made:
                    // not held through the solve)
                    let takes_part = crosses[k] || self.layout.owns(k + 1);
                    let mesh = takes_part.then(|| self.problems[k].mesh());
                    let (how, recovery) = (self.partitioner, self.recovery);
                    let plan =
                        SharePlan::new(k + 1, mesh, sizes, self.layout, how, crosses[k], recovery);
                    Share::new(&plan, self.layout)
                })
            })
        })
    }

    /// An estimate's second part, after [`Estimator::resolve`] of an iterate whose fields are
    /// `u`: the recoveries, the element sums and e_ref (collective). It needs no body: a run
    /// may free the factorisations of its bodies between the two (docs/scaling.md, "Memory
    /// per rank").
    pub(crate) fn recover(
        &self,
        mut resolved: Resolved,
        u: &[Displacement; 2],
    ) -> Result<EstimateRecord, EstimateError> {
        let layout = self.layout;
        let [f1, f2] = std::mem::take(&mut resolved.fields);
        let data = resolved.data(self);
        let fe_only = resolved.fe_only;
        let plain = resolved.plain.as_ref().unwrap_or(u);
        let mut sums = [0.0; 3];
        let mut res = Residuals::default();
        let mut maps: [[Vec<f64>; 3]; 2] = Default::default();
        let mut map_first = [0; 2];
        let mut e_ref2 = 0.0;
        let crosses = self.crosses();
        self.stop_point()?;
        // The element work: each recovery prepared for both bodies before any is made (the
        // warm-start exchanges are the only collectives in it, so no rank waits for another
        // between them).
        let shares = self.shares(crosses);
        let views = shares.map(|s| s.view(layout));
        // (the re-solves are what the rank's recoveries read of them alone, `resolve`)
        let fields = [f1.on(&u[0]), f2.on(&u[1])];
        let mut works: Vec<(usize, ElementWork)> = (0..2)
            .filter_map(|k| {
                let view = views[k].as_ref()?;
                Some((k, ElementWork::new(&self.problems[k], &fields[k], view)))
            })
            .collect();
        // Before each recovery, every body's is prepared (η^FE's data when `fe`).
        let prepare = |works: &[(usize, ElementWork)], fe: bool| {
            for (k, w) in works {
                let view = views[*k].as_ref().expect("a view");
                let u = if fe { w.fe_data() } else { w.glo_data() };
                let ops = &mut self.operators[*k].borrow_mut();
                // (a negative change bound: no earlier recovery is near enough to start from;
                // a cold estimate's η^FE recovery may start from its own η^glo recovery)
                let warm_change = if self.cold.get() && !fe {
                    -1.0
                } else {
                    self.warm_change
                };
                view.prepare(&self.problems[*k], u, self.recovery, warm_change, ops);
            }
        };
        if !fe_only {
            prepare(&works, false);
            for (k, w) in works.iter_mut() {
                w.glo(&data, &mut self.operators[*k].borrow_mut(), &self.parts)?;
            }
        }
        // The η^glo recovery's temporaries back to the system before the η^FE one allocates
        // its own (the first estimate's high-water mark on large meshes: paper n = 1024 out of
        // core, 3018 / 3055 → 2921 / 2971 MiB).
        crate::os::memory::release_free_memory(TRIM_BYTES);
        self.stop_point()?;
        prepare(&works, true);
        for (k, w) in works.iter_mut() {
            w.fe(
                &self.iface,
                &data,
                &mut self.operators[*k].borrow_mut(),
                &self.parts,
            )?;
        }
        let mut done: [Option<BodyEstimate>; 2] = [None, None];
        for (k, w) in works {
            done[k] = Some(w.finish(&self.iface, &data, &self.parts));
        }
        let delta2 = self
            .parts
            .run(Part::Reduction, || bubble_amplitudes(layout, &mut done));
        for k in 0..2 {
            // (this rank is one of the body's group)
            let body = layout.owns(k + 1).then_some(());
            let mut est = done[k].take().unwrap_or_default();
            let t = est.totals();
            for c in 0..3 {
                sums[c] += t[c];
            }
            res = res.worst(est.residuals);
            for v in [&mut est.glo, &mut est.fe, &mut est.nndd]
                .into_iter()
                .flatten()
            {
                *v = v.max(0.0).sqrt();
            }
            // The element maps onto the body's ranks, each element from its estimating rank to
            // the rank whose block of the body's elements holds it (`Layout::block`).
            if crosses[k] || body.is_some() {
                let ne = self.problems[k].num_elements();
                let (map, first) = self.parts.run(Part::Reduction, || {
                    let values = [&est.glo[..], &est.fe[..], &est.nndd[..]];
                    held::to_blocks(layout, k + 1, ne, &est.elements, values, crosses[k])
                });
                if body.is_some() {
                    maps[k] = map;
                    map_first[k] = first;
                }
            }
            if let (Some(()), Some(r)) = (body, self.reference.as_ref().filter(|_| !fe_only)) {
                // (each rank of the group sums its block of the fine elements)
                let p = &self.problems[k];
                e_ref2 += self.parts.run(Part::ReferenceError, || {
                    let u = resolved.reference_u[k].as_ref().unwrap_or(&plain[k]);
                    r.error_squared_part(k, p.mesh(), u)
                })?;
            }
        }
        drop(fields);
        let (sums, e_ref, res) = self.parts.run(Part::Reduction, || {
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
            (sums.map(|s| layout.sum(s)), e_ref, res)
        });
        let [glo, fe, nndd] = sums;
        let eta_glo = glo.max(0.0).sqrt();
        // (the iterate into the record, its fields copied once the recoveries are made)
        let mut iterate = resolved.it;
        iterate.u = u.clone();
        Ok(EstimateRecord {
            iteration: iterate.iteration,
            eta_glo,
            eta_fe: fe.max(0.0).sqrt(),
            eta_nndd: nndd.max(0.0).sqrt(),
            correction: delta2.max(0.0).sqrt(),
            eta_ratio: if glo > 0.0 {
                (fe + nndd) / glo
            } else {
                f64::NAN
            },
            e_ref,
            effectivity: e_ref.map(|e| eta_glo / e),
            residuals: res,
            maps,
            map_first,
            iterate,
            contact_displacement: None,
            t_hat: resolved.t_glo,
        })
    }
}

/// The bubble amplitudes of û = u_p + δ and the bound of the answer's error,
/// (1 + θ)Q + (1 + 1/θ)Δ ≥ (‖u − û‖ + ‖δ‖)² (docs/method.md §5): each element's η^glo term of
/// the bodies' estimates `done` times (1 + θ), plus (1 + 1/θ) a c² on the elements of δ;
/// returns ‖δ‖² (collective over all ranks).
fn bubble_amplitudes(layout: &Layout, done: &mut [Option<BodyEstimate>; 2]) -> f64 {
    let q0 = layout.sum(
        done.iter()
            .flatten()
            .map(|e| e.glo.iter().sum::<f64>())
            .sum(),
    );
    let terms: Vec<polygon::BubbleTerms> = done
        .iter()
        .flatten()
        .flat_map(|e| e.bubbles.iter().copied())
        .collect();
    let sum = |mut x: [f64; 2]| {
        layout.world_sum(&mut x);
        x
    };
    let (c, [theta, _, delta2]) = polygon::choose_amplitudes(&terms, q0, &sum);
    if theta > 0.0 {
        // (`terms` lists the bodies' bubbles in this order)
        let mut chosen = c.iter();
        for est in done.iter_mut().flatten() {
            for g in est.glo.iter_mut() {
                *g *= 1.0 + theta;
            }
            for t in &est.bubbles {
                let c = *chosen.next().expect("an amplitude per bubble");
                let s = est
                    .slot(t.element)
                    .expect("a bubble on an estimated element");
                est.glo[s] += (1.0 + theta) * (t.a * c * c - 2.0 * t.b * c + t.l * c)
                    + (1.0 + 1.0 / theta) * t.a * c * c;
            }
        }
    }
    delta2
}
