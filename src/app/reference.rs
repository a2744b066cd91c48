//! The reference solution of (26) (`-nndd_reference_factor r`): the problem on the nested mesh
//! r·n, solved by the NNDD on the run's ranks before the run's own bodies are set up, each
//! rank keeping its block of the fine elements and u_ref on their nodes for e_ref
//! ([`crate::estimate::Reference`]).

use std::rc::Rc;
use std::time::Instant;

use super::options::Settings;
use super::relaxed::{relaxed_warnings, Factored};
use super::solve::{owned, partitions, setup_bodies, solve_nndd};
use super::{input, AppError, LONG_PHASE_DOFS};
use crate::dd::nndd::{NnddSettings, Relaxation};
use crate::estimate::{Reference, ReferencePart};
use crate::io::summary::Timings;
use crate::os::signals::{self, StopPhase};
use crate::parallel::fault::Agreement;
use crate::parallel::layout::Layout;
use crate::parallel::partition::Partition;
use crate::petsc::log::Stages;
use crate::problem::{self, BodyProblem, ProblemKind};

/// The reference solution of (26): the nested mesh r·n (r = `-nndd_reference_factor`, not 0),
/// NNDD to tol 1e−8 (a mortar run's: on its estimates' matched meshes refined, with the
/// initial gaps `gaps`); collective, the ranks agreeing on its input (`agreement`).
pub fn solve_reference(
    settings: &Settings,
    layout: &Layout,
    stages: &Stages,
    timings: &mut Timings,
    gaps: Option<&crate::problem::transfer::GapField>,
    warnings: &mut Vec<String>,
    agreement: &Agreement,
) -> Result<Result<Reference, String>, AppError> {
    let r = settings.estimate.reference_factor;
    let t = Instant::now();
    // A stop signal ends the reference solve at once (nothing of it is worth keeping).
    let before = signals::enter(StopPhase::Reference);
    let mut fine = settings.refined(r)?;
    // (the refined file's facts, where world rank 0 alone holds the file and refined it)
    let world = &layout.world;
    let file = fine.problem.parsed_file_mut();
    (file.map_or(Ok(()), |f| f.share_facts(world))).map_err(AppError::Input)?;
    if layout.is_root() && (settings.output.monitor || fine.problem.dofs() >= LONG_PHASE_DOFS) {
        // Word before the long phase: the reference mesh has r² times the dofs.
        println!(
            "nndd: solving the reference solution of e_ref on {} ({} dofs, -nndd_reference_factor {r})",
            reference_mesh(&fine, r),
            fine.problem.dofs(),
        );
    }
    let mut scratch = Timings::default();
    // All of it in the reference stage of -log_view.
    let stages = &stages.all_in_reference();
    let _s = stages.reference.enter();
    let FineParts {
        problems,
        cut,
        input_elements,
    } = fine_parts(&mut fine, layout, gaps, agreement)?;
    let input_peak_mib = crate::os::memory::peak_memory() / (1024.0 * 1024.0);
    let held = problems.each_ref().map(Option::as_ref);
    let held_elements = (held.iter().flatten())
        .map(|p| p.mesh().triangles.held_len())
        .sum();
    let bodies = setup_bodies(&fine, held, cut, layout, stages, &mut scratch)?;
    warnings.extend(relaxed_warnings(&bodies, layout, Factored::Reference));
    // Each rank's block of the fine elements, at whose nodes the fine fields are kept.
    let mut parts = [0, 1].map(|k| {
        let p = problems[k].as_ref()?;
        let elements = layout.block(k + 1, p.num_elements());
        Some(ReferencePart::new(p.mesh(), p.material, elements))
    });
    for (k, (b, part)) in bodies.iter().zip(&parts).enumerate() {
        if let (Some(b), Some(part), Some(p)) = (b, part, &problems[k]) {
            let block = layout.block(k + 1, p.num_nodes());
            b.keep_fields_at(block, part.nodes().iter().copied());
        }
    }
    drop(problems);
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let mesh = reference_mesh(&fine, r);
    // θ auto first; where it does not converge, the run's own fixed θ, then a small fixed θ
    // with room for its iterations (the factorisations are kept: only Γc iterations repeat).
    let mut tried = Vec::new();
    let mut sol = None;
    for nndd in reference_relaxations(&settings.nndd, &fine.nndd) {
        let attempt = Settings {
            nndd,
            ..fine.clone()
        };
        let s = super::end_job_on_local_failure(solve_nndd(
            &attempt,
            layout,
            refs,
            None,
            stages,
            &mut scratch,
            None,
        ))?;
        tried.push(format!(
            "{} after {} iterations with -nndd_theta {}",
            s.status,
            s.iterations,
            attempt.nndd.relaxation.text()
        ));
        let converged = s.converged;
        sol = Some(s);
        if converged {
            break;
        }
    }
    let sol = sol.expect("at least one relaxation is tried");
    drop(_s);
    signals::enter(before);
    timings.reference = t.elapsed().as_secs_f64();
    if layout.is_root() && settings.output.monitor {
        println!(
            "nndd: reference solution on {mesh} ({} dofs): {}, {:.2} s",
            fine.problem.dofs(),
            tried.join("; "),
            timings.reference
        );
    }
    if !sol.converged {
        return Ok(Err(format!(
            "the reference solution on {mesh} ({} dofs) did not converge ({}): e_ref and the effectivity are not reported",
            fine.problem.dofs(),
            tried.join("; ")
        )));
    }
    // The fine factorisations and fields freed here: e_ref needs each rank's block of the
    // fine elements and u_ref on their nodes only.
    drop(bodies);
    let iterations = sol.iterations;
    let held_nodes = sol.last.u.iter().map(|u| u.len() / 2).sum();
    for (part, u) in parts.iter_mut().zip(&sol.last.u) {
        if let Some(part) = part {
            part.set_solution(u);
        }
    }
    drop(sol);
    crate::os::memory::release_free_memory(0);
    Ok(Ok(Reference {
        factor: r,
        parts,
        iterations,
        held_nodes,
        held_elements,
        input_elements,
        input_peak_mib,
    }))
}

/// The reference's fine problems as this rank holds them ([`fine_parts`]).
struct FineParts {
    /// Each body's this rank's group works on, cut to the part the rank reads.
    problems: [Option<Rc<BodyProblem>>; 2],
    /// The rank's partition of its group's body.
    cut: [Option<Partition>; 2],
    /// The fine elements this rank held in the input: both bodies' where it built them,
    /// else the part it was sent.
    input_elements: usize,
}

/// The reference's fine problem of each body this rank's group works on, cut to the part the
/// rank reads (a Gmsh body's: its partition, its block of the fine elements, whose nodes
/// e_ref's transfer reads, and Γc), and its partition: built on world rank 0 and dealt
/// (`-nndd_mesh_input root`, [`input::on_root`]), else built on every rank; a mortar run's
/// with its `gaps`. The fine problem of a body this rank does not work on is freed before the
/// factorisations (the NNDD reads the bodies alone), and the refined file once the bodies are
/// built.
fn fine_parts(
    fine: &mut Settings,
    layout: &Layout,
    gaps: Option<&crate::problem::transfer::GapField>,
    agreement: &Agreement,
) -> Result<FineParts, AppError> {
    if input::on_root(fine, layout.size) {
        let built = input::build_on_root(fine, gaps, agreement, &layout.world)?;
        fine.release_mesh_unread_later();
        let (dealt, input_elements) = input::deal_parts(built, fine, layout, agreement)?;
        let k = dealt.alpha - 1;
        let mut problems = [None, None];
        problems[k] = Some(dealt.problems[k].clone());
        let mut cut = [None, None];
        cut[k] = Some(dealt.partition);
        return Ok(FineParts {
            problems,
            cut,
            input_elements,
        });
    }
    let mut both = problem::build(&fine.problem)?;
    fine.release_mesh_unread_later();
    if let Some(g) = gaps {
        both = g.apply(both);
    }
    let input_elements = both.iter().map(|p| p.num_elements()).sum();
    let problems = owned(&both, layout).map(Option::<&Rc<BodyProblem>>::cloned);
    drop(both);
    let how = fine.problem.partitioner;
    let cut = partitions(problems.each_ref().map(Option::as_ref), layout, how)?;
    let problems = problems.map(|p| {
        let p = p?;
        let part = super::parts::read_part(&p, layout, cut[p.alpha - 1].as_ref(), Vec::new());
        Some(part.unwrap_or(p))
    });
    Ok(FineParts {
        problems,
        cut,
        input_elements,
    })
}

/// The reference mesh in words: the built-in problems' level, or the user's mesh refined.
fn reference_mesh(fine: &Settings, r: usize) -> String {
    match fine.problem.kind {
        ProblemKind::Mesh => format!("the mesh refined {r} times"),
        _ => format!("mesh {}", fine.problem.n),
    }
}

/// The relaxations the reference solve tries in turn: its own (θ auto), the run's fixed θ if
/// the run has one, and θ = [`REFERENCE_FALLBACK_THETA`] with room for its iterations.
fn reference_relaxations(run: &NnddSettings, reference: &NnddSettings) -> Vec<NnddSettings> {
    let mut list = vec![reference.clone()];
    if let Relaxation::Fixed(theta) = run.relaxation {
        list.push(NnddSettings {
            relaxation: Relaxation::Fixed(theta),
            max_it: reference.max_it.max(run.max_it),
            ..reference.clone()
        });
    }
    list.push(NnddSettings {
        relaxation: Relaxation::Fixed(REFERENCE_FALLBACK_THETA),
        max_it: reference.max_it.max(REFERENCE_FALLBACK_MAX_IT),
        ..reference.clone()
    });
    list
}

/// The last fixed θ the reference solve tries, and its iteration limit: small enough to
/// converge where θ auto does not (the cases needed 639–1177 iterations at 0.01).
pub const REFERENCE_FALLBACK_THETA: f64 = 0.01;
pub const REFERENCE_FALLBACK_MAX_IT: usize = 5000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_tries_auto_then_the_runs_theta_then_a_small_one() {
        let reference = NnddSettings {
            relaxation: Relaxation::Auto,
            ..NnddSettings::default()
        };
        let thetas = |run: &NnddSettings| -> Vec<String> {
            reference_relaxations(run, &reference)
                .iter()
                .map(|s| s.relaxation.text())
                .collect()
        };
        let fixed = NnddSettings::default();
        assert_eq!(thetas(&fixed), ["auto", "0.25", "0.01"]);
        assert_eq!(thetas(&reference), ["auto", "0.01"]);
        let last = reference_relaxations(&fixed, &reference).pop().unwrap();
        assert_eq!(last.max_it, REFERENCE_FALLBACK_MAX_IT.max(reference.max_it));
        assert_eq!(last.tol, reference.tol);
    }
}
