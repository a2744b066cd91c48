//! The steps of one solve from the setup on ([`Run`]): the bodies, the estimator, the NNDD or
//! the monolithic check, the contact's check, the post-processing and the output.

use super::relaxed::{relaxed_warnings, Factored};
use super::*;

/// What the steps of a run from the setup on work with.
pub(super) struct Run<'a> {
    settings: &'a Settings,
    layout: &'a Layout,
    /// The bodies' problems: as built, then each Gmsh body's mesh cut to the part the rank
    /// reads ([`super::parts::keep_read_parts`]).
    problems: [Rc<BodyProblem>; 2],
    stages: &'a Stages,
    agreement: &'a Agreement,
}

/// What post-processing gives the summary.
pub(crate) struct PostProcessed {
    /// The potential energy of the reported iterate, both bodies (J/m).
    pub(crate) energy: f64,
    /// ‖u_h‖_E of the reported iterate, both bodies.
    pub(crate) energy_norm: f64,
    pub(crate) solvers: [solve::BodySolver; 2],
    pub(crate) logged_flops: f64,
    pub(crate) reference_iterations: Option<usize>,
    /// The nodes at which this rank held the reference solution's fields.
    pub(crate) reference_held_nodes: Option<usize>,
    /// The elements of the fine meshes this rank held for the reference solution.
    pub(crate) reference_held_elements: Option<usize>,
    /// The elements of the fine meshes this rank held in the reference solution's input.
    pub(crate) reference_input_elements: Option<usize>,
    /// This rank's peak memory (MiB) once the reference solution's fine bodies were built.
    pub(crate) reference_input_peak_mib: Option<f64>,
    /// The most nodes at which this rank held an estimated iterate's fields.
    pub(crate) estimate_held_nodes: Option<usize>,
    /// The elements of a mortar run's estimates' matched meshes this rank held.
    pub(crate) matched_mesh_elements: Option<usize>,
    /// The elements of a Gmsh problem's meshes this rank held in the input: both bodies'
    /// where it built them, else the part it was sent (`app::input`).
    pub(crate) input_mesh_elements: Option<usize>,
    /// The points of a Gmsh problem's parsed file this rank held (all on world rank 0,
    /// which read it, and on a rank it was sent to).
    pub(crate) input_file_points: Option<usize>,
    /// This rank's peak resident memory (MiB) once the bodies' problems were built (or sent)
    /// and laid out, before their set-up.
    pub(crate) input_peak_memory_mib: f64,
}

impl<'a> Run<'a> {
    pub(super) fn new(
        settings: &'a Settings,
        layout: &'a Layout,
        problems: &[Rc<BodyProblem>; 2],
        stages: &'a Stages,
        agreement: &'a Agreement,
    ) -> Run<'a> {
        Run {
            settings,
            layout,
            problems: problems.clone(),
            stages,
            agreement,
        }
    }

    /// Each body's partition over its group, on the ranks of the group; the ranks agree.
    pub(super) fn partitions(&self) -> Result<[Option<Partition>; 2], AppError> {
        let how = self.settings.problem.partitioner;
        let parts = solve::partitions(solve::owned(&self.problems, self.layout), self.layout, how);
        agreed(self.agreement, parts)
    }

    /// Each rank's bodies on their `partitions` (assembly, factorisation); the ranks agree.
    /// Each rank keeps the bodies' fields at the nodes it reads alone: its rows of the output
    /// (its block of the body's nodes and its cells' nodes), Γc and the outline
    /// ([`Body::keep_fields_at`]; the checks gather its rows, the estimates their overlaps,
    /// e_ref the coarse nodes under its block of the fine elements and a mortar run's estimates
    /// the nodes under its part of the matched meshes from the blocks).
    /// A factorisation made again with a larger relaxation is a warning, added to `warnings`.
    pub(super) fn set_up_bodies(
        &self,
        partitions: [Option<Partition>; 2],
        timings: &mut Timings,
        warnings: &mut Vec<String>,
    ) -> Result<[Option<Body>; 2], AppError> {
        let (settings, problems, layout) = (self.settings, &self.problems, self.layout);
        let owned = solve::owned(problems, layout);
        let bodies = solve::setup_bodies(settings, owned, partitions, layout, self.stages, timings);
        let bodies = agreed(self.agreement, bodies)?;
        warnings.extend(relaxed_warnings(&bodies, layout, Factored::Run));
        let kept = crate::io::fields::kept_rows(layout, [&*problems[0], &*problems[1]]);
        for (k, (b, nodes)) in bodies.iter().zip(kept.nodes).enumerate() {
            if let Some(b) = b {
                b.keep_fields_at(layout.block(k + 1, problems[k].num_nodes()), nodes);
            }
        }
        Ok(bodies)
    }

    /// With `-nndd_monitor`: the problem, its size, the ranks and the steps' bodies, and the
    /// time to here.
    pub(super) fn announce_setup(&self, t_start: Instant) {
        let (settings, layout) = (self.settings, self.layout);
        if !(settings.output.monitor && layout.is_root()) {
            return;
        }
        let problem = match &settings.problem.mesh {
            Some(spec) => format!("mesh {}", spec.gmsh.path),
            None => format!(
                "{} n = {}",
                settings.problem.kind.name(),
                settings.problem.n
            ),
        };
        let roles = match (settings.solver, settings.nndd.dirichlet_body) {
            (SolverKind::Nndd, 1) => ", Dirichlet step on body 1, contact step on body 2",
            (SolverKind::Nndd, _) => ", Dirichlet step on body 2, contact step on body 1",
            _ => "",
        };
        let dofs: usize = self.problems.iter().map(|p| p.num_dofs()).sum();
        println!(
            "nndd: {problem}, {dofs} dofs, {} rank(s){roles}: setup {:.3} s",
            layout.size,
            t_start.elapsed().as_secs_f64()
        );
    }

    /// The estimator when the run estimates, with the reference solution of (26) when asked
    /// (one that does not converge is a warning, added to `warnings`: no e_ref then, as is a
    /// factorisation made again with a larger relaxation). A mortar
    /// run's estimates and reference work on the matched meshes of
    /// [`crate::problem::ProblemSettings::for_estimates`], their bodies set up here: built on
    /// every rank, or on world rank 0 alone and dealt where it built the run's bodies, `whole`
    /// there ([`input::deal_matched`]).
    pub(super) fn estimator(
        &self,
        whole: Option<[Rc<BodyProblem>; 2]>,
        timings: &mut Timings,
        warnings: &mut Vec<String>,
    ) -> Result<Option<Estimator<'a>>, AppError> {
        let (settings, layout) = (self.settings, self.layout);
        let matched = match settings.estimate.enabled {
            true => settings.problem.for_estimates()?,
            false => None,
        };
        let mut matched = matched.map(|problem| Settings {
            problem,
            ..settings.clone()
        });
        // (where world rank 0 alone holds the file, it matched the curves: its facts here)
        if let Some(file) = matched.as_mut().and_then(|m| m.problem.parsed_file_mut()) {
            file.share_facts(&layout.world).map_err(AppError::Input)?;
        }
        let on_root = matched.is_some() && input::on_root(settings, layout.size);
        let gaps = match (&matched, on_root) {
            (None, _) => None,
            (Some(_), false) => Some(GapField::new([&*self.problems[0], &*self.problems[1]])),
            (Some(_), true) => Some(input::gaps_from_root(whole.as_ref())?),
        };
        let dealt = match (&matched, &gaps) {
            (Some(m), Some(g)) if on_root => {
                let whole = whole.as_ref();
                Some(input::deal_matched(m, whole, g, layout, self.agreement)?)
            }
            _ => None,
        };
        drop(whole);
        let on = matched.as_ref().unwrap_or(settings);
        let reference = match settings.estimate.reference_factor {
            0 => None,
            _ => {
                let (gaps, agreement) = (gaps.as_ref(), self.agreement);
                match reference::solve_reference(
                    on,
                    layout,
                    self.stages,
                    timings,
                    gaps,
                    warnings,
                    agreement,
                )? {
                    Ok(reference) => Some(reference),
                    Err(w) => {
                        say_warnings(layout.is_root(), std::slice::from_ref(&w));
                        warnings.push(w);
                        None
                    }
                }
            }
        };
        if !settings.estimate.enabled {
            return Ok(None);
        }
        let stages = Some(self.stages.estimation_parts);
        let qp = &settings.qp;
        let (Some(matched), Some(gaps)) = (matched, gaps) else {
            let e = Estimator::new(
                &settings.estimate,
                qp,
                layout,
                &self.problems,
                reference,
                stages,
            )
            .with_friction(settings.friction)
            .with_partitioner(settings.problem.partitioner);
            return Ok(Some(e));
        };
        let (problems, partitions, maps, seeds) = match dealt {
            Some((dealt, maps)) => {
                let mut partitions = [None, None];
                partitions[dealt.alpha - 1] = Some(dealt.partition);
                (dealt.problems, Some(partitions), Ok(maps), dealt.seeds)
            }
            None => {
                let problems = gaps.apply(crate::problem::build(&matched.problem)?);
                let maps = MortarMaps::new(&self.problems, &problems).map_err(AppError::from);
                (problems, None, maps, None)
            }
        };
        let maps = agreed(self.agreement, maps)?;
        let bodies = solve::setup_matched_bodies(
            &matched,
            &problems,
            partitions,
            layout,
            self.stages,
            timings,
        );
        let bodies = agreed(self.agreement, bodies)?;
        warnings.extend(relaxed_warnings(&bodies, layout, Factored::Matched));
        let mortar = MortarEstimates::new(self.problems.clone(), maps, bodies);
        let stages = Some(self.stages.estimation_parts);
        let e = Estimator::new(&settings.estimate, qp, layout, &problems, reference, stages);
        if let Some(seeds) = seeds {
            e.take_shares(seeds);
        }
        Ok(Some(e.with_mortar(mortar)))
    }

    /// The NNDD (paper §3) with its restart points, or the monolithic check; a failure of one
    /// rank alone ends the job.
    pub(super) fn solve(
        &self,
        refs: [Option<&Body>; 2],
        estimator: Option<&Estimator>,
        timings: &mut Timings,
        restart: &Restart,
    ) -> Result<Solution, AppError> {
        let (settings, layout, stages) = (self.settings, self.layout, self.stages);
        end_job_on_local_failure(match settings.solver {
            SolverKind::Nndd => {
                let restart = Some(restart);
                solve::solve_nndd(settings, layout, refs, estimator, stages, timings, restart)
            }
            SolverKind::Monolithic => {
                solve::solve_monolithic(settings, layout, refs, estimator, stages, timings)
            }
        })
    }

    /// The contact over the whole contact curves: a zone that reaches an end of Γc where the
    /// bodies go on side by side is a warning; a penetration beyond round-off, an error.
    pub(super) fn check_contact(&self, sol: &mut Solution) -> Result<(), AppError> {
        let problems = [&*self.problems[0], &*self.problems[1]];
        if let Some(w) = dd::check::zone_reaches_open_end(problems, &sol.last) {
            say_warnings(self.layout.is_root(), std::slice::from_ref(&w));
            sol.warnings.push(w);
        }
        let penetration = dd::penetration::penetration(self.layout, problems, &sol.last);
        if let Some(what) = penetration.failure(&contact_curves(self.settings)) {
            if sol.converged {
                return Err(AppError::Penetration(what));
            }
            // An iterate that is no answer (diverged, stagnated, at -nndd_max_it): its own exit
            // says why; the overlap is said with it, not blamed on the contact curves.
            let w = format!(
                "the reported iterate, which did not converge, overlaps the other body: {what}"
            );
            say_warnings(self.layout.is_root(), std::slice::from_ref(&w));
            sol.warnings.push(w);
        }
        sol.penetration = Some(penetration);
        Ok(())
    }

    /// What needs the bodies once solved: the energy, each body's solver, `-nndd_schur_view`'s
    /// files (the flops and the estimates' parts come with [`Run::finish_estimates`]).
    pub(super) fn post_process(
        &self,
        refs: [Option<&Body>; 2],
        sol: &Solution,
    ) -> Result<PostProcessed, AppError> {
        let layout = self.layout;
        let energy = potential_energy(layout, refs, sol)?;
        let energy_norm = energy_norm(layout, &self.problems, sol);
        let solvers = solve::body_solvers(layout, refs, sol);
        if self.settings.output.schur_view {
            write_interface_operators(self.settings, layout, refs)?;
        }
        Ok(PostProcessed {
            energy,
            energy_norm,
            solvers,
            logged_flops: 0.0,
            reference_iterations: None,
            reference_held_nodes: None,
            reference_held_elements: None,
            reference_input_elements: None,
            reference_input_peak_mib: None,
            estimate_held_nodes: None,
            matched_mesh_elements: None,
            input_mesh_elements: None,
            input_file_points: None,
            input_peak_memory_mib: 0.0,
        })
    }

    /// After the bodies are freed: the reported iterate's recoveries ([`reported::finish_reported`];
    /// a failure of one rank alone ends the job), the flops, the estimates' parts; the
    /// estimator dropped, the timings made maxima over the ranks.
    pub(super) fn finish_estimates(
        &self,
        sol: &mut Solution,
        estimator: Option<Estimator>,
        post: &mut PostProcessed,
        timings: &mut Timings,
    ) -> Result<(), AppError> {
        let (settings, layout) = (self.settings, self.layout);
        let e = estimator.as_ref();
        timings.estimation += end_job_on_local_failure(reported::finish_reported(
            settings,
            layout,
            self.stages,
            e,
            sol.pending.take(),
            &sol.last,
            &mut sol.estimates,
            &mut sol.history,
        ))?;
        // The recovered stresses must be admissible to round-off for η^glo to bound the error.
        if let Some(w) = report::worst_residuals(&sol.estimates).warning() {
            say_warnings(layout.is_root(), std::slice::from_ref(&w));
            sol.warnings.push(w);
        }
        post.logged_flops = layout.sum(Petsc::logged_flops());
        post.reference_iterations = e.and_then(|e| e.reference_iterations());
        post.reference_held_nodes = e.and_then(|e| e.reference_held_nodes());
        post.reference_held_elements = e.and_then(|e| e.reference_held_elements());
        post.reference_input_elements = e.and_then(|e| e.reference_input_elements());
        post.reference_input_peak_mib = e.and_then(|e| e.reference_input_peak_mib());
        post.estimate_held_nodes = e.map(|e| e.held_nodes());
        post.matched_mesh_elements = e.and_then(|e| e.matched_mesh_elements());
        if let Some(e) = e {
            timings.estimation_parts = EstimationParts::from(e.part_seconds());
        }
        drop(estimator);
        report::max_over_ranks(layout, timings);
        Ok(())
    }

    /// PREFIX.h5 + PREFIX.xdmf (collective), then PREFIX.json and the closing report (rank 0;
    /// the ranks agree on its write).
    pub(super) fn write_output(
        &self,
        sol: &Solution,
        post: &PostProcessed,
        mut timings: Timings,
        t_start: Instant,
    ) -> Result<(), AppError> {
        let (settings, layout, problems) = (self.settings, self.layout, &self.problems);
        let t_out = Instant::now();
        let results = {
            let _s = self.stages.output.enter();
            let shares = fields::shares(layout, [&problems[0], &problems[1]]);
            let results = results_of(settings, problems, sol, &shares);
            let prefix = settings.output.paths.prefix();
            output::write_results_parallel(&layout.world, prefix, &results, &shares)?;
            results
        };
        timings.output = layout.max(t_out.elapsed().as_secs_f64());
        timings.total = t_start.elapsed().as_secs_f64();
        // The high-water marks of the whole run, the output's fields included.
        let peaks = report::peak_memory_per_rank(layout);
        let file_backed = report::file_backed_memory_per_rank(layout);
        let input_peaks = report::input_peak_memory_per_rank(layout, post);
        let reference_input_peaks = report::reference_input_peak_memory_per_rank(layout, post);
        let held_elements =
            report::held_mesh_elements_per_rank(layout, [&problems[0], &problems[1]]);
        let held_nodes = report::held_field_nodes_per_rank(layout, sol);
        let [held_reference, held_estimate, held_reference_elements, input_elements, input_points, reference_input_elements, matched_elements] =
            [
                post.reference_held_nodes,
                post.estimate_held_nodes,
                post.reference_held_elements,
                post.input_mesh_elements,
                post.input_file_points,
                post.reference_input_elements,
                post.matched_mesh_elements,
            ]
            .map(|n| n.map(|n| report::counts_per_rank(layout, n as u64)));
        let mut written = Ok(());
        if layout.is_root() {
            let measured = report::Measured {
                results: &results,
                timings,
                peaks: &peaks,
                held_elements: &held_elements,
                held_nodes: &held_nodes,
                held_reference: held_reference.as_deref(),
                held_reference_elements: held_reference_elements.as_deref(),
                held_estimate: held_estimate.as_deref(),
                input_elements: input_elements.as_deref(),
                input_points: input_points.as_deref(),
                input_peaks: &input_peaks,
                file_backed: &file_backed,
                reference_input_elements: reference_input_elements.as_deref(),
                matched_elements: matched_elements.as_deref(),
                reference_input_peaks: reference_input_peaks.as_deref(),
            };
            let problems = [&*problems[0], &*problems[1]];
            let summary = report::summarise(settings, problems, layout, sol, post, measured);
            let json = serde_json::to_string_pretty(&summary)
                .map_err(|e| AppError::Json(e.to_string()))?;
            written = output::write_atomic(&settings.output.paths.json(), json.as_bytes())
                .map_err(AppError::from);
            if written.is_ok() {
                report::report(settings, &summary, sol);
            }
        }
        agreed(self.agreement, written)?;
        if signals::stop_requested() && !sol.interrupted && layout.is_root() {
            // The output is not interrupted: a signal during it is read once the files exist.
            crate::io::monitor::say(format_args!(
                "nndd: {} arrived while the results were written; they are complete",
                signals::received_name()
            ));
        }
        Ok(())
    }
}

/// The potential energy of the reported iterate, both bodies (each counted once per group).
pub(super) fn potential_energy(
    layout: &Layout,
    refs: [Option<&Body>; 2],
    sol: &Solution,
) -> Result<f64, AppError> {
    let mut e = 0.0;
    for (k, b) in refs.iter().enumerate() {
        if let Some(b) = b {
            let energy = b.potential_energy(&sol.last.u[k])?;
            if b.is_root() {
                e += energy; // every rank of the group has it: count it once
            }
        }
    }
    Ok(layout.sum(e))
}

/// ‖u_h‖_E = (Σ_α Σ_E u_Eᵀ K_E u_E)^½ of the reported iterate, each body's elements summed on
/// the ranks of its group whose output blocks ([`Layout::block`]) hold them (every rank gets
/// it).
pub(super) fn energy_norm(layout: &Layout, problems: &[Rc<BodyProblem>; 2], sol: &Solution) -> f64 {
    let mut sum = 0.0;
    for (k, p) in problems.iter().enumerate() {
        let u = &sol.last.u[k];
        if u.is_empty() {
            continue;
        }
        let block = layout.block(k + 1, p.num_elements());
        sum += crate::fem::energy_squared_on(p.mesh(), &p.material, block, |d| u[d]);
    }
    layout.sum(sum).max(0.0).sqrt()
}

/// The result files' content: one step per estimated iteration, and the reported iterate as
/// the last step (estimated or not); the run's description as text attributes.
pub(super) fn results_of(
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
    sol: &Solution,
    shares: &[output::Share],
) -> Results {
    let mut steps: Vec<_> = sol
        .estimates
        .iter()
        .map(|e| (&e.iterate, Some(e)))
        .collect();
    if steps.last().map(|(it, _)| it.iteration) != Some(sol.last.iteration) {
        steps.push((&sol.last, None));
    }
    let mut attributes = vec![
        ("n".into(), settings.problem.n as f64),
        ("dofs".into(), settings.problem.dofs() as f64),
        ("iterations".into(), sol.iterations as f64),
    ];
    // Each body's rows of the `bodies` grid: body 1's points and cells first.
    for p in problems.iter() {
        let at = |what: &str| format!("body{}_{what}", p.alpha);
        attributes.push((at("points"), p.num_nodes() as f64));
        attributes.push((at("cells"), p.num_elements() as f64));
    }
    let mesh = settings.problem.mesh.as_ref();
    let physical_names = mesh.map_or(String::new(), |m| {
        let names = m.gmsh.names.iter();
        let listed: Vec<String> = names.map(|((d, t), n)| format!("{d} {t} {n}")).collect();
        listed.join("; ")
    });
    let text = vec![
        (
            "program".into(),
            format!("nndd {}", env!("CARGO_PKG_VERSION")),
        ),
        ("options".into(), settings.options_text.clone()),
        ("problem".into(), settings.problem.kind.name().to_string()),
        (
            "mesh_file".into(),
            mesh.map_or(String::new(), |m| m.gmsh.path.clone()),
        ),
        ("physical_names".into(), physical_names),
    ];
    let problems = [&*problems[0], &*problems[1]];
    fields::results(problems, &steps, shares, attributes, text)
}

/// `-nndd_schur_view`: each body's S^α and D^α (row-major, exact in JSON) from its first rank,
/// to `PREFIX.body<α>_schur.json` (the ranks agree on the writes).
pub(super) fn write_interface_operators(
    settings: &Settings,
    layout: &Layout,
    refs: [Option<&dd::body::Body>; 2],
) -> Result<(), AppError> {
    let mut written = Ok(());
    for (k, body) in refs.iter().enumerate() {
        let Some(c) = body.and_then(|b| b.condensed()) else {
            continue;
        };
        let view = serde_json::json!({
            "alpha": k + 1,
            "source": body.and_then(|b| b.schur_source).map(|s| s.name()),
            "m": c.schur.n(),
            "schur": c.schur.data(),
            "delassus": c.delassus.data(),
        });
        let path = settings.output.paths.schur_json(k + 1);
        written = written.and_then(|()| {
            output::write_atomic(&path, view.to_string().as_bytes()).map_err(AppError::from)
        });
    }
    let failed = layout.max(written.is_err() as u8 as f64) > 0.0;
    match (written, failed) {
        (Err(e), _) => Err(e),
        (Ok(()), true) => Err(AppError::ReportedElsewhere { code: 1 }),
        (Ok(()), false) => Ok(()),
    }
}
