//! An adaptive run (`-nndd_adapt_tol ε`, docs/method.md §8), as deal.II's step-42 `run()`
//! over cycles: solve on this cycle's meshes (the NNDD to its tolerance, or by the balanced
//! rule, and the estimates (22)–(24) of its answer), stop once η^glo ≤ ε ‖u_h‖_E, else size the next meshes from the
//! element contributions to η^FE and remesh both bodies with Gmsh from their `.geo`; the next
//! cycle starts from this cycle's λ carried over to its Γc.
//!
//! Output: each cycle's files under `PREFIX-cycleK` (as a single run's, and the size view
//! `PREFIX-cycleK.size.pos` that made the next mesh), then `PREFIX.xdmf` (the cycles as a time
//! series, each its own mesh with its fields), `PREFIX-final.xdmf` (the last cycle alone) and
//! `PREFIX.json` (the last cycle's summary with `adapt` and `cycles`).

use std::rc::Rc;
use std::time::Instant;

use mpi::topology::SimpleCommunicator;

use super::adapt::{self, AdaptSettings, Prediction};
use super::options::Settings;
use super::{agreed, capacity, say_warnings, solve_cycle, AppError, Cycle, Outcome, Start};
use crate::io::output::{self, OutputPaths};
use crate::parallel::fault::Agreement;
use crate::petsc::log::Stages;
use crate::problem::BodyProblem;

/// One cycle, as the summary's `cycles` lists it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CycleRecord {
    pub cycle: usize,
    pub dofs: usize,
    pub elements: usize,
    pub iterations: usize,
    pub stop_reason: String,
    pub eta_glo: f64,
    pub eta_fe: f64,
    pub eta_nndd: f64,
    /// ‖u_h‖_E of the reported iterate.
    pub energy_norm: f64,
    /// η^glo / ‖u_h‖_E.
    pub relative_error: f64,
    pub e_ref: Option<f64>,
    pub effectivity: Option<f64>,
    /// The cycle's wall time: its solve and output, and the next mesh's making.
    pub seconds: f64,
    /// The size field, the remeshing and the transfer of λ (s; 0 on the last cycle).
    pub remesh_seconds: f64,
    /// `remesh_seconds / seconds`.
    pub remesh_share: f64,
    /// What the sizes for the next mesh predicted (none on the last cycle).
    pub next_mesh: Option<Prediction>,
}

impl CycleRecord {
    /// The record of the solved `c`; `None` where the solve gave no estimate of its answer.
    fn of(cycle: usize, c: &Cycle) -> Option<CycleRecord> {
        let sol = &c.solution;
        let est = sol.estimates.last()?;
        (est.iteration == sol.last.iteration).then_some(())?;
        Some(CycleRecord {
            cycle,
            dofs: c.problems.iter().map(|p| p.num_dofs()).sum(),
            elements: c.problems.iter().map(|p| p.num_elements()).sum(),
            iterations: sol.iterations,
            stop_reason: sol.stop_reason.to_string(),
            eta_glo: est.eta_glo,
            eta_fe: est.eta_fe,
            eta_nndd: est.eta_nndd,
            energy_norm: c.energy_norm,
            relative_error: est.eta_glo / c.energy_norm,
            e_ref: est.e_ref,
            effectivity: est.effectivity,
            seconds: c.seconds,
            remesh_seconds: 0.0,
            remesh_share: 0.0,
            next_mesh: None,
        })
    }
}

/// How the cycles ended.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// η^glo ≤ ε ‖u_h‖_E.
    Reached,
    /// `-nndd_adapt_max_cycles` cycles without it.
    MaxCycles,
    /// A cycle's solve did not end as asked (its own exit says why).
    SolveStopped,
    /// The next meshes would not fit in the nodes' memory (`app::capacity`; the summary's
    /// `adapt.memory` says by how much).
    MemoryLimit,
}

/// The cycles of an adaptive run (collective); the exit: 0 reached, 3 not reached in
/// `-nndd_adapt_max_cycles` cycles, or before the next meshes would not fit in the nodes'
/// memory (or a cycle's NNDD not converged), 4 interrupted.
pub fn run(
    world: &SimpleCommunicator,
    settings: &Settings,
    adapt: &AdaptSettings,
    stages: &Stages,
    agreement: &Agreement,
) -> Result<Outcome, AppError> {
    let base = settings.output.paths.clone();
    let mut settings = settings.clone();
    let mut start = Start::default();
    let mut records: Vec<CycleRecord> = Vec::new();
    for cycle in 1..=adapt.max_cycles {
        // Solve and estimate on this cycle's meshes (PREFIX-cycleK.*).
        settings.output.paths = cycle_paths(&base, cycle);
        let solved = solve_cycle(
            world,
            settings.clone(),
            stages,
            agreement,
            start,
            Instant::now(),
        )?;
        let Some(mut record) = CycleRecord::of(cycle, &solved) else {
            // (interrupted, or not converged before an estimate: the cycle's files say so)
            let verdict = Verdict::SolveStopped;
            finish(&solved, &base, &records, cycle, adapt, verdict, None)?;
            return Ok(solved.outcome);
        };
        let reached = record.relative_error <= adapt.tol;
        let solved_as_asked = matches!(solved.outcome, Outcome::Solved);
        if reached || !solved_as_asked || cycle == adapt.max_cycles {
            announce(&solved, &record, adapt);
            records.push(record);
            let verdict = match (reached, solved_as_asked) {
                (_, false) => Verdict::SolveStopped,
                (true, true) => Verdict::Reached,
                (false, true) => Verdict::MaxCycles,
            };
            finish(&solved, &base, &records, cycle, adapt, verdict, None)?;
            return Ok(match verdict {
                Verdict::Reached => Outcome::Solved,
                Verdict::MaxCycles | Verdict::MemoryLimit => Outcome::Unreached,
                Verdict::SolveStopped => solved.outcome,
            });
        }
        // The next meshes: the sizes η^FE asks for, both bodies remeshed by Gmsh.
        let t_adapt = Instant::now();
        let (spec, prediction) = next_meshes(&solved, &record, adapt, &base, cycle, agreement)?;
        settings.problem.mesh = Some(spec);
        start = Start {
            lambda: Some(solved.solution.last.whole_interface()),
            from: adapt::pair_points([&solved.problems[0], &solved.problems[1]]),
            dirichlet_body: solved.settings.nndd.dirichlet_body,
        };
        record.remesh_seconds = solved.layout.max(t_adapt.elapsed().as_secs_f64());
        record.seconds += record.remesh_seconds;
        record.remesh_share = record.remesh_seconds / record.seconds;
        record.next_mesh = Some(prediction);
        announce(&solved, &record, adapt);
        records.push(record);
        // The next meshes must fit in the nodes' memory, as the first had to (`app::capacity`:
        // a later cycle may be many times larger); else the cycles end with this one's answer.
        match capacity::check(&settings, world, capacity::Meshes::Cycle(cycle + 1)) {
            Ok(warning) => {
                say_warnings(solved.layout.is_root(), warning.as_slice());
                settings.memory_warning = warning;
            }
            Err(refused) => {
                let (verdict, why) = (Verdict::MemoryLimit, refused.to_string());
                finish(&solved, &base, &records, cycle, adapt, verdict, Some(&why))?;
                return Ok(Outcome::Unreached);
            }
        }
    }
    unreachable!("the last cycle returns")
}

/// `PREFIX-cycleK`.
fn cycle_paths(base: &OutputPaths, cycle: usize) -> OutputPaths {
    let mut prefix = base.prefix().as_os_str().to_owned();
    prefix.push(format!("-cycle{cycle}"));
    OutputPaths::new(prefix)
}

/// The next cycle's problem: the size view from η^FE's element maps (rank 0, written beside
/// the cycle's files), both bodies remeshed by Gmsh (rank 0, [`adapt::remesh`]).
fn next_meshes(
    solved: &Cycle,
    record: &CycleRecord,
    adapt: &AdaptSettings,
    base: &OutputPaths,
    cycle: usize,
    agreement: &Agreement,
) -> Result<(crate::problem::meshed::MeshSpec, Prediction), AppError> {
    let layout = &solved.layout;
    let problems = [&*solved.problems[0], &*solved.problems[1]];
    let est = solved
        .solution
        .estimates
        .last()
        .expect("a record has its estimate");
    let maps = [est.maps[0][1].as_slice(), est.maps[1][1].as_slice()];
    let elements = problems.map(|p| p.num_elements());
    let eta_fe = adapt::eta_fe_on_root(layout, maps, est.map_first, elements);
    // The η^FE that makes η^glo meet ε ‖u_h‖_E if η^glo / η^FE stays as it is, with room.
    let target =
        adapt::AIM * adapt.tol * record.energy_norm * (record.eta_fe / record.eta_glo).min(1.0);
    let view = cycle_paths(base, cycle).with_ext("size.pos");
    let written = match layout.is_root() {
        true => whole_bodies_on_root(solved).and_then(|whole| {
            let whole = [&*whole[0], &*whole[1]];
            adapt::write_size_field(adapt, whole, &eta_fe, target, &view)
                .map(Some)
                .map_err(|e| AppError::Adapt(format!("{}: {e}", view.display())))
        }),
        false => Ok(None),
    };
    let prediction = agreed(agreement, written)?;
    let spec = solved
        .settings
        .problem
        .mesh
        .as_ref()
        .expect("an adaptive run has its geometry");
    let spec = adapt::remesh(spec, &view, cycle + 1).map_err(AppError::Adapt)?;
    // Every rank needs the prediction only for the record: rank 0's is the one written.
    let prediction = prediction.unwrap_or(Prediction {
        elements: 0.0,
        target,
        eta_fe: None,
    });
    Ok((spec, prediction))
}

/// On world rank 0, the cycle's bodies with their whole meshes, which the size view covers:
/// the solved ones where it held them whole, else built again from the cycle's file, which
/// rank 0 keeps (the ranks hold their parts through the solve, `app::parts::keep_read_parts`, and
/// under `-nndd_mesh_input root` no other rank holds the file; a build gives the same meshes).
fn whole_bodies_on_root(solved: &Cycle) -> Result<[Rc<BodyProblem>; 2], AppError> {
    match solved.problems.iter().all(|p| p.holds_listed_mesh()) {
        true => Ok(solved.problems.clone()),
        false => Ok(crate::problem::build(&solved.settings.problem)?),
    }
}

/// The cycle's line (rank 0).
fn announce(solved: &Cycle, r: &CycleRecord, adapt: &AdaptSettings) {
    if !solved.layout.is_root() {
        return;
    }
    let next = match &r.next_mesh {
        Some(p) => format!(
            "; next mesh {:.0} elements predicted, remeshed in {:.2} s ({:.1} %)",
            p.elements,
            r.remesh_seconds,
            100.0 * r.remesh_share
        ),
        None => String::new(),
    };
    crate::io::monitor::say(format_args!(
        "nndd: cycle {}: {} dofs, {} elements, {} iterations ({}), eta_glo {:.4e} = {:.3} % of ||u_h||_E (tol {} %), eta_FE {:.4e}, eta_NNDD {:.4e}, {:.2} s{next}",
        r.cycle,
        r.dofs,
        r.elements,
        r.iterations,
        r.stop_reason,
        r.eta_glo,
        100.0 * r.relative_error,
        100.0 * adapt.tol,
        r.eta_fe,
        r.eta_nndd,
        r.seconds
    ));
}

/// The run's own files (rank 0; the ranks agree on their write): PREFIX.xdmf (the cycles),
/// PREFIX-final.xdmf (the last), PREFIX.json (the last cycle's summary with `adapt` and
/// `cycles`), and the closing line; `memory`: why the next meshes were refused
/// ([`Verdict::MemoryLimit`]).
fn finish(
    last: &Cycle,
    base: &OutputPaths,
    records: &[CycleRecord],
    cycles: usize,
    adapt: &AdaptSettings,
    verdict: Verdict,
    memory: Option<&str>,
) -> Result<(), AppError> {
    let layout = &last.layout;
    let written = match layout.is_root() {
        true => write_run_files(base, records, cycles, adapt, verdict, memory),
        false => Ok(()),
    };
    let agreed_written = layout.agree(written.is_ok());
    written?;
    if !agreed_written {
        return Err(AppError::ReportedElsewhere { code: 2 });
    }
    if layout.is_root() {
        let path: Vec<String> = records
            .iter()
            .map(|r| format!("{:.3} %", 100.0 * r.relative_error))
            .collect();
        let how = match verdict {
            Verdict::Reached => "reached",
            Verdict::MaxCycles => "not reached",
            Verdict::SolveStopped => "not reached (a cycle's solve stopped)",
            Verdict::MemoryLimit => "not reached (the next meshes would not fit)",
        };
        let why = memory.map_or(String::new(), |m| format!("; {m}"));
        crate::io::monitor::say(format_args!(
            "nndd: -nndd_adapt_tol {} ({} %) {how} in {} cycle(s): eta_glo/||u_h||_E {}; results {} (cycles), {}{why}",
            adapt.tol,
            100.0 * adapt.tol,
            records.len(),
            path.join(", "),
            base.xdmf().display(),
            base.final_xdmf().display()
        ));
    }
    Ok(())
}

fn write_run_files(
    base: &OutputPaths,
    records: &[CycleRecord],
    count: usize,
    adapt: &AdaptSettings,
    verdict: Verdict,
    memory: Option<&str>,
) -> Result<(), AppError> {
    let fail =
        |what: &std::path::Path, e: String| AppError::Adapt(format!("{}: {e}", what.display()));
    let mut singles = Vec::new();
    for cycle in 1..=count {
        let path = cycle_paths(base, cycle).final_xdmf();
        let text = std::fs::read_to_string(&path).map_err(|e| fail(&path, e.to_string()))?;
        singles.push((cycle as f64, text));
    }
    let series = output::collection_of_singles(&singles)
        .ok_or_else(|| fail(&base.xdmf(), "a cycle's grid is not a single grid".into()))?;
    output::write_atomic(&base.xdmf(), series.as_bytes())?;
    let last = &singles[singles.len() - 1].1;
    output::write_atomic(&base.final_xdmf(), last.as_bytes())?;
    let json_path = cycle_paths(base, count).json();
    let text = std::fs::read_to_string(&json_path).map_err(|e| fail(&json_path, e.to_string()))?;
    let mut summary: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| fail(&json_path, e.to_string()))?;
    let strategy = match adapt.strategy {
        crate::estimate::size_field::Strategy::Optimal { order } => {
            serde_json::json!({"name": "optimal", "order": order})
        }
        crate::estimate::size_field::Strategy::Dorfler { fraction } => {
            serde_json::json!({"name": "dorfler", "fraction": fraction})
        }
    };
    summary["adapt"] = serde_json::json!({
        "tol": adapt.tol,
        "max_cycles": adapt.max_cycles,
        "strategy": strategy,
        "aim": adapt::AIM,
        "limits": {"refine": adapt.limits.refine, "coarsen": adapt.limits.coarsen},
        "verdict": verdict,
        "cycles_run": count,
        "memory": memory,
    });
    summary["cycles"] = serde_json::to_value(records).map_err(|e| AppError::Json(e.to_string()))?;
    let json = serde_json::to_string_pretty(&summary).map_err(|e| AppError::Json(e.to_string()))?;
    output::write_atomic(&base.json(), json.as_bytes())?;
    Ok(())
}
