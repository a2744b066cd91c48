//! What a run reports: the JSON summary's content, the closing lines on rank 0, the timings
//! and memory over ranks.

use super::options::Settings;
use super::solve::Solution;
use super::PostProcessed;
use crate::dd::friction::{FrictionLaw, PairState};
use crate::dd::nndd::{Iterate, Relaxation};
use crate::estimate::equilibrate::Residuals;
use crate::estimate::EstimateRecord;
use crate::io::fields;
use crate::io::monitor::{self, sci};
use crate::io::output::Results;
use crate::io::summary::{
    ContactCurves, ContactZone, EquilibriumResiduals, EstimateEntry, EstimateMeaning,
    FrictionZones, MeshProblem, Summary, Timings,
};
use crate::os::memory;
use crate::parallel::layout::Layout;
use crate::problem::{BodyProblem, ContactDiscretisation, GcTrace};

#[allow(clippy::too_many_arguments)]
/// What the run measured at its end, for the summary: the result files' content, the timings
/// (maxima over the ranks) and each rank's peak memory (MiB).
pub struct Measured<'a> {
    pub results: &'a Results,
    pub timings: Timings,
    pub peaks: &'a [f64],
    /// The elements of the meshes each rank holds ([`held_mesh_elements_per_rank`]).
    pub held_elements: &'a [usize],
    /// The nodes of the reported displacement each rank holds ([`held_field_nodes_per_rank`]).
    pub held_nodes: &'a [usize],
    /// The nodes of the reference solution's fields each rank held, where it was solved.
    pub held_reference: Option<&'a [usize]>,
    /// The elements of the fine meshes each rank held for the reference solution.
    pub held_reference_elements: Option<&'a [usize]>,
    /// The most nodes of an estimated iterate's fields each rank held, where it estimated.
    pub held_estimate: Option<&'a [usize]>,
    /// The elements of a Gmsh problem's meshes each rank held in the input.
    pub input_elements: Option<&'a [usize]>,
    /// The points of a Gmsh problem's parsed file each rank held.
    pub input_points: Option<&'a [usize]>,
    /// Each rank's peak memory (MiB) at the end of the input.
    pub input_peaks: &'a [f64],
    /// Each rank's resident file-backed memory (MiB) at the end ([`file_backed_memory_per_rank`]).
    pub file_backed: &'a [f64],
    /// The elements of a mortar run's estimates' matched meshes each rank held.
    pub matched_elements: Option<&'a [usize]>,
    /// The elements of the fine meshes each rank held in the reference solution's input.
    pub reference_input_elements: Option<&'a [usize]>,
    /// Each rank's peak memory (MiB) once the reference solution's fine bodies were built.
    pub reference_input_peaks: Option<&'a [f64]>,
}

pub fn summarise(
    settings: &Settings,
    [body1, body2]: [&BodyProblem; 2],
    layout: &Layout,
    sol: &Solution,
    post: &PostProcessed,
    measured: Measured,
) -> Summary {
    let PostProcessed {
        energy,
        energy_norm,
        ref solvers,
        logged_flops,
        reference_iterations,
        reference_held_nodes: _,
        reference_held_elements: _,
        reference_input_elements: _,
        reference_input_peak_mib: _,
        estimate_held_nodes: _,
        matched_mesh_elements: _,
        input_mesh_elements: _,
        input_file_points: _,
        input_peak_memory_mib: _,
    } = *post;
    let Measured {
        results,
        timings,
        peaks,
        held_elements,
        held_nodes,
        held_reference,
        held_reference_elements,
        held_estimate,
        input_elements,
        input_points,
        input_peaks,
        file_backed,
        reference_input_elements,
        matched_elements,
        reference_input_peaks,
    } = measured;
    // Γc's pairs at the nodes of its pair side (body 1, or the non-mortar body).
    let side = [body1, body2][crate::problem::pair_side([body1, body2])];
    let discretisation = crate::problem::discretisation([body1, body2]);
    let mortar = discretisation == ContactDiscretisation::Mortar;
    let contact = contact_of([body1, body2], &sol.last, settings.friction);
    let paths = &settings.output.paths;
    let builtin = settings.problem.mesh.is_none();
    let matched = settings.problem.mesh.as_ref().map(|m| &*m.matched);
    let residuals = (!sol.estimates.is_empty()).then(|| {
        let r = worst_residuals(&sol.estimates);
        EquilibriumResiduals {
            divergence: r.divergence,
            internal_jump: r.internal_jump,
            element_jump: r.element_jump,
            boundary: r.boundary,
            point_reaction: r.point_reaction,
        }
    });
    Summary {
        problem: settings.problem.kind.name().into(),
        n: builtin.then_some(settings.problem.n),
        grids: builtin
            .then(|| [0, 1].map(|k| [settings.problem.grids[k].0, settings.problem.grids[k].1])),
        mesh: settings.problem.mesh.as_ref().map(|m| MeshProblem {
            file: m.gmsh.path.clone(),
            geometry_parameters: m.geo_set.iter().cloned().collect(),
            bodies: crate::problem::meshed::BODY_NAMES,
            contact: m.contact.clone(),
            conditions: m.conditions.clone(),
        }),
        dofs: settings.problem.dofs(),
        ranks: layout.size,
        solver: settings.solver.name().into(),
        theta: match settings.nndd.relaxation {
            Relaxation::Fixed(theta) => Some(theta),
            Relaxation::Auto => None,
        },
        theta_auto: settings.nndd.relaxation == Relaxation::Auto,
        dirichlet_body: settings.nndd.dirichlet_body,
        tol: settings.nndd.tol,
        max_it: settings.nndd.max_it,
        young: settings.problem.materials.map(|m| m.young),
        poisson: settings.problem.materials.map(|m| m.poisson),
        u_d: builtin.then_some(settings.problem.u_d),
        f_max: builtin.then_some(settings.problem.f_max),
        converged: sol.converged,
        status: sol.status.clone(),
        stop_reason: sol.stop_reason.into(),
        iterations: sol.iterations,
        history: sol.history.clone(),
        potential_energy: energy,
        energy_norm,
        contact_force: contact.detail.normal_force,
        contact_zone: contact.zone,
        active_nodes: contact.active,
        contact_nodes: contact.nodes,
        contact: contact.detail.clone(),
        contact_curves: ContactCurves {
            names: super::contact_curves(settings),
            nodes: [body1, body2].map(|b| b.contact_candidates.len()),
            pairs: side.pairs(),
            discretisation: discretisation.name(),
            non_mortar: mortar.then_some(side.alpha),
            coupling_seconds: [body1, body2].iter().find_map(|b| match &b.trace {
                GcTrace::Mortar(c) => Some(c.seconds),
                GcTrace::Nodes => None,
            }),
            inserted: matched.map_or([0; 2], |m| m.inserted),
            moved: matched.map_or([0; 2], |m| m.moved),
            max_penetration: sol.penetration.clone().unwrap_or_default(),
        },
        schur_source: solvers.each_ref().map(|s| s.schur_source.to_string()),
        dirichlet_step: sol.dirichlet_step.into(),
        neumann_step: solvers.each_ref().map(|s| s.neumann_step.to_string()),
        factorisation_flops: solvers.each_ref().map(|s| s.factorisation_flops),
        freed_matrix_copy_mib: solvers.each_ref().map(|s| s.freed_copy_mib),
        stiffness_nonzeros: solvers.each_ref().map(|s| s.nonzeros),
        body_setup_seconds: solvers.each_ref().map(|s| s.setup_seconds),
        body_dofs: [body1.num_dofs(), body2.num_dofs()],
        logged_flops,
        qp_kkt_residual: sol.last.qp_kkt,
        estimates: sol.estimates.iter().map(summary_estimate).collect(),
        equilibrium_residuals: residuals,
        reference_factor: Some(settings.estimate.reference_factor).filter(|&r| r > 0),
        reference_iterations,
        timings,
        peak_memory_mib: peaks.iter().cloned().fold(0.0, f64::max),
        peak_memory_mib_per_rank: peaks.to_vec(),
        file_backed_memory_mib_per_rank: file_backed.to_vec(),
        held_mesh_elements_per_rank: held_elements.to_vec(),
        held_displacement_nodes_per_rank: held_nodes.to_vec(),
        held_reference_displacement_nodes_per_rank: held_reference.map(<[usize]>::to_vec),
        held_reference_mesh_elements_per_rank: held_reference_elements.map(<[usize]>::to_vec),
        held_estimate_displacement_nodes_per_rank: held_estimate.map(<[usize]>::to_vec),
        held_matched_mesh_elements_per_rank: matched_elements.map(<[usize]>::to_vec),
        input_mesh_elements_per_rank: input_elements.map(<[usize]>::to_vec),
        input_file_points_per_rank: input_points.map(<[usize]>::to_vec),
        input_peak_memory_mib_per_rank: input_peaks.to_vec(),
        reference_input_mesh_elements_per_rank: reference_input_elements.map(<[usize]>::to_vec),
        reference_input_peak_memory_mib_per_rank: reference_input_peaks.map(<[f64]>::to_vec),
        body_ranks: layout.group_sizes,
        h5: paths.h5().display().to_string(),
        xdmf: paths.xdmf().display().to_string(),
        xdmf_contact: paths.contact_xdmf().display().to_string(),
        xdmf_final: paths.final_xdmf().display().to_string(),
        fields: fields::describe(results),
        estimate_meaning: (!sol.estimates.is_empty()).then(|| {
            if mortar {
                EstimateMeaning::mortar()
            } else {
                EstimateMeaning::default()
            }
        }),
        warnings: (settings.memory_warning.iter())
            .chain(&settings.warnings)
            .chain(&sol.warnings)
            .cloned()
            .collect(),
        solution_check: sol.check,
    }
}

fn summary_estimate(e: &EstimateRecord) -> EstimateEntry {
    EstimateEntry {
        iteration: e.iteration,
        eta_glo: e.eta_glo,
        eta_fe: e.eta_fe,
        eta_nndd: e.eta_nndd,
        eta_ratio: e.eta_ratio,
        eta_glo_correction: e.correction,
        e_ref: e.e_ref,
        effectivity: e.effectivity,
    }
}

/// The closing line (and the warning of a run that did not converge), on rank 0.
pub fn report(settings: &Settings, summary: &Summary, sol: &Solution) {
    println!(
        "nndd: {} ({} dofs, {} rank(s), {}): {} after {} iterations; energy {} J/m, contact force {} N/m, zone {}; {:.2} s; wrote {}{{.h5,.xdmf,-contact.xdmf,-final.xdmf,.json}}",
        match &settings.problem.mesh {
            Some(spec) => format!("mesh {}", spec.gmsh.path),
            None => format!("{} n = {}", summary.problem, summary.n.unwrap_or_default()),
        },
        summary.dofs,
        summary.ranks,
        summary.solver,
        summary.status,
        summary.iterations,
        sci(summary.potential_energy, 10),
        sci(summary.contact_force, 6),
        summary.contact_zone.map_or("none".to_string(), |z| format!("[{}, {}]", sci(z[0], 5), sci(z[1], 5))),
        summary.timings.total,
        settings.output.paths.prefix().display()
    );
    if let Some(f) = &summary.contact.friction {
        println!(
            "nndd: friction {}: tangential force {} N/m, {} pairs stick, {} slip, peak shear {} Pa, largest slip {} m",
            f.friction,
            sci(f.tangential_force, 6),
            f.stick_nodes,
            f.slip_nodes,
            sci(f.peak_shear, 5),
            sci(f.max_slip, 4)
        );
    }
    if let Some(e) = sol.estimates.last() {
        println!(
            "nndd: estimates at iteration {}: {}",
            e.iteration,
            monitor::estimate_text(e).trim_start()
        );
    }
    if sol.interrupted {
        crate::io::monitor::say(format_args!(
            "nndd: interrupted by a signal after {} iterations; continue with -nndd_restart {}",
            sol.iterations,
            settings.output.paths.checkpoint().display()
        ));
    } else if !sol.requested {
        let (last, balance) = sol
            .history
            .last()
            .map_or((f64::NAN, f64::NAN), |r| (r.lambda_change, r.force_balance));
        crate::io::monitor::say(format_args!(
            "nndd: warning: the NNDD {} after {} iterations (dlambda/lambda {} for -nndd_tol {}, force balance {} for -nndd_force_tol {}); {}",
            match sol.status.as_str() {
                "diverged" => "diverged",
                "stagnated" => "stagnated",
                _ => "reached -nndd_max_it",
            },
            sol.iterations,
            sci(last, 3),
            sci(settings.nndd.tol, 1),
            sci(balance, 3),
            sci(settings.nndd.force_tol, 1),
            if !(last.is_finite() && balance.is_finite()) {
                // Not a relaxation too large: the numbers left double precision.
                "the iterate is not finite: the data's magnitudes overflow double precision (a load, traction or displacement of order 1e150 or more makes the energy overflow) or a body's solve failed; check the input's units and sizes".to_string()
            } else {
                match settings.nndd.relaxation {
                    Relaxation::Auto => {
                        "try a small fixed -nndd_theta (now auto; e.g. 0.01)".to_string()
                    }
                    Relaxation::Fixed(theta) => format!("try a smaller -nndd_theta (now {theta})"),
                }
            }
        ));
    }
}

/// Peak memory of every rank (MiB), on every rank.
pub fn peak_memory_per_rank(layout: &Layout) -> Vec<f64> {
    per_rank(layout, memory::peak_memory() / (1024.0 * 1024.0))
}

/// Each rank's resident file-backed memory (MiB) now, by world rank (collective): its shared
/// libraries' pages ([`memory::resident_file_backed`]).
pub fn file_backed_memory_per_rank(layout: &Layout) -> Vec<f64> {
    per_rank(layout, memory::resident_file_backed() / (1024.0 * 1024.0))
}

/// Each rank's peak resident memory (MiB) at the end of the input ([`PostProcessed`]), by
/// world rank (collective).
pub fn input_peak_memory_per_rank(layout: &Layout, post: &PostProcessed) -> Vec<f64> {
    per_rank(layout, post.input_peak_memory_mib)
}

/// Each rank's peak memory (MiB) once the reference solution's fine bodies were built, by
/// world rank, where it was solved (collective: it is solved on every rank or on none).
pub fn reference_input_peak_memory_per_rank(
    layout: &Layout,
    post: &PostProcessed,
) -> Option<Vec<f64>> {
    (post.reference_input_peak_mib).map(|mine| per_rank(layout, mine))
}

/// Every rank's `mine`, by world rank, on every rank (collective).
fn per_rank<T: mpi::datatype::Equivalence + Copy + Default>(layout: &Layout, mine: T) -> Vec<T> {
    use mpi::traits::*;
    let mut all = vec![T::default(); layout.size as usize];
    layout.world.all_gather_into(&mine, &mut all[..]);
    all
}

/// The elements of the bodies' meshes each rank holds through the run, by world rank (a
/// body's whole where the rank keeps its mesh, the part it reads where it keeps that, none
/// where it released it; collective).
pub fn held_mesh_elements_per_rank(layout: &Layout, problems: [&BodyProblem; 2]) -> Vec<usize> {
    let mine: u64 = (problems.iter())
        .filter(|p| p.holds_mesh())
        .map(|p| p.mesh().triangles.held_len() as u64)
        .sum();
    counts_per_rank(layout, mine)
}

/// The nodes at which each rank holds the reported iterate's displacement, both bodies', by
/// world rank (a body's every node where it holds it whole; collective).
pub fn held_field_nodes_per_rank(layout: &Layout, sol: &Solution) -> Vec<usize> {
    let mine: u64 = sol.last.u.iter().map(|u| (u.len() / 2) as u64).sum();
    counts_per_rank(layout, mine)
}

/// This rank's count `mine` and every other's, by world rank (collective).
pub fn counts_per_rank(layout: &Layout, mine: u64) -> Vec<usize> {
    per_rank(layout, mine)
        .into_iter()
        .map(|n| n as usize)
        .collect()
}

/// Each phase's time: the maximum over ranks.
pub fn max_over_ranks(layout: &Layout, t: &mut Timings) {
    for x in [
        &mut t.input,
        &mut t.assembly,
        &mut t.factorisation,
        &mut t.dirichlet_step,
        &mut t.contact_step,
        &mut t.neumann_step,
        &mut t.exchange,
        &mut t.monolithic,
        &mut t.estimation,
        &mut t.reference,
        &mut t.estimation_parts.traction_qp,
        &mut t.estimation_parts.resolves,
        &mut t.estimation_parts.recovery,
        &mut t.estimation_parts.element_sums,
        &mut t.estimation_parts.e_ref,
        &mut t.estimation_parts.reduction,
    ] {
        *x = layout.max(*x);
    }
}

/// The quantities of the summary that come from the reported iterate's Γc.
struct Contact {
    /// [x_min, x_max] of the pairs in contact.
    zone: Option<[f64; 2]>,
    active: usize,
    nodes: usize,
    /// The zone along Γc, its peak pressure and the total normal force.
    detail: ContactZone,
}

fn contact_of(problems: [&BodyProblem; 2], last: &Iterate, law: FrictionLaw) -> Contact {
    let p1 = problems[crate::problem::pair_side(problems)];
    let m = last.active.len();
    let x = p1.contact_x();
    let on: Vec<usize> = (0..m).filter(|&k| last.active[k]).collect();
    let zone = (!on.is_empty()).then(|| {
        let xs = on.iter().map(|&k| x[k]);
        [
            xs.clone().fold(f64::INFINITY, f64::min),
            xs.fold(f64::NEG_INFINITY, f64::max),
        ]
    });
    let mut arc = vec![0.0; m];
    for k in 1..m {
        arc[k] = arc[k - 1] + p1.contact_lengths[k - 1];
    }
    let point = |k: usize| p1.boundary_point(p1.contact_nodes[k]);
    // The lumped nodal pressure, as the output's `pressure`.
    let share = crate::problem::pair_shares(problems);
    let force = last.contact_forces();
    let ends = on.first().zip(on.last()).map(|(&a, &b)| (a, b));
    let peak = (0..m)
        .map(|k| (force[k] / share[k], k))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    Contact {
        zone,
        active: on.len(),
        nodes: m,
        detail: ContactZone {
            zone: ends.map(|(a, b)| [arc[a], arc[b]]),
            zone_ends: ends.map(|(a, b)| [point(a), point(b)]),
            zone_length: ends.map_or(0.0, |(a, b)| arc[b] - arc[a]),
            peak_pressure: peak.map_or(0.0, |p| p.0),
            peak_pressure_at: peak.filter(|p| p.0 > 0.0).map(|p| point(p.1)),
            normal_force: force.iter().sum(),
            friction: friction_zones(last, law, &arc, &share, point),
        },
    }
}

/// The stick and slip zones of a frictional iterate (`None` without friction).
fn friction_zones(
    last: &Iterate,
    law: FrictionLaw,
    arc: &[f64],
    share: &[f64],
    point: impl Fn(usize) -> [f64; 2],
) -> Option<FrictionZones> {
    let t = last.tangential.as_ref()?;
    let states = t.states(&last.active);
    let runs = |want: PairState| {
        let mut zones = Vec::new();
        let mut start = None;
        for k in 0..=states.len() {
            let on = states.get(k) == Some(&want);
            match (on, start) {
                (true, None) => start = Some(k),
                (false, Some(a)) => {
                    zones.push([arc[a], arc[k - 1]]);
                    start = None;
                }
                _ => {}
            }
        }
        zones
    };
    let force = last.tangential_contact_forces();
    let peak = (0..force.len())
        .map(|k| (force[k].abs() / share[k], k))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let count = |want| states.iter().filter(|&&s| s == want).count();
    Some(FrictionZones {
        friction: law.name().into(),
        stick_zone: runs(PairState::Stick),
        slip_zone: runs(PairState::Slip),
        stick_nodes: count(PairState::Stick),
        slip_nodes: count(PairState::Slip),
        tangential_force: force.iter().sum(),
        peak_shear: peak.map_or(0.0, |p| p.0),
        peak_shear_at: peak.filter(|p| p.0 > 0.0).map(|p| point(p.1)),
        max_slip: t
            .slip()
            .iter()
            .zip(&states)
            .filter(|(_, s)| **s == PairState::Slip)
            .fold(0.0, |m, (v, _)| m.max(v.abs())),
    })
}

/// The largest equilibrium residuals of the recovered stresses over the run's estimates.
pub(super) fn worst_residuals(estimates: &[EstimateRecord]) -> Residuals {
    (estimates.iter()).fold(Residuals::default(), |w, e| w.worst(e.residuals))
}
