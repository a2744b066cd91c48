//! Whether a run fits in the memory of its nodes, checked before any mesh is built and, in an
//! adaptive run, before each cycle's meshes are built ([`Meshes`]): the subdomain
//! factorisations of the mesh n and, with `-nndd_reference_factor r`, of the reference mesh
//! r·n (both held at once while the reference is solved). A run that would not fit is refused
//! with its estimated memory, instead of swapping or being killed part-way; an adaptive run
//! whose next meshes would not fit ends with the cycles it solved (`app::cycles`).
//!
//! The estimate is a model of the measured peaks, fitted to `jobs/bench-memory-ranks` (`paper`
//! with one estimate on 2, 4 and 8 ranks at n = 512 and 1024) and `jobs/bench-input
//! --estimate` (the same drawn in Gmsh), and checked against `jobs/bench-memory` (n = 64 … 512
//! on 2 ranks, factored or iterative bodies, with and without the reference solution): per
//! rank a fixed part (MPI, PETSc, the program) and `PER_RANK_DOF` bytes per dof of the meshes
//! (what every rank of a body's group holds of the whole body: MUMPS's arrays over its whole
//! elimination tree, the partition's node numbering), and per dof of each mesh
//! `PER_DOF_LOG · log2(dofs)` bytes over all ranks (MUMPS's fill of a 2D mesh grows as
//! dofs · log dofs in nested-dissection order; GAMG's hierarchy costs less), which the fit
//! takes above the groups' growth, faster than dofs · log dofs from n = 1024 to 1448.
//!
//! The available memory is the sum over the run's nodes of `MemAvailable` (`/proc/meminfo`),
//! or of the cgroup's limit less its usage where that is lower (a Slurm job's `--mem`), plus
//! what the run's ranks there hold resident already (the model counts them: their start-up, a
//! cycle's state), and at most `-nndd_memory_limit` per node where it is given. A run the
//! model refuses may still fit where it overestimates (by up to a third on the measured runs
//! with factored bodies, 1.9 × with CG + GAMG's): `-nndd_memory_check warn` runs it with a
//! warning ([`MemoryCheck`]).

use mpi::collective::SystemOperation;
use mpi::topology::{Communicator as _, SimpleCommunicator};
use mpi::traits::*;

use super::options::{MemoryCheck, Settings, SettingsError};

/// Bytes per rank that do not depend on the mesh (MPI, PETSc, the program).
const PER_RANK: f64 = 45.0 * MIB;
/// Bytes per dof and per log2(dofs) of a mesh.
const PER_DOF_LOG: f64 = 104.0;
/// Bytes per dof of the meshes on every rank: MUMPS's tree arrays, about 42 B per dof of the
/// rank's body on every rank of its group (21 per dof of both bodies of equal size), and the
/// partition's node numbering, 2 B per dof of the body (docs/scaling.md, "Memory per rank").
const PER_RANK_DOF: f64 = 24.0;
const MIB: f64 = 1024.0 * 1024.0;
const GIB: f64 = 1024.0 * MIB;

/// The estimated bytes of a mesh of `dofs` dofs.
fn mesh_bytes(dofs: usize) -> f64 {
    let n = dofs.max(2) as f64;
    PER_DOF_LOG * n * n.log2()
}

/// The memory this node offers the run (bytes): `MemAvailable`, or the cgroup's room if lower,
/// plus `held`, what the run's ranks on the node already hold resident (the model counts
/// their start-up and, in an adaptive run, what a cycle keeps); at most `limit` where given
/// (`-nndd_memory_limit`).
fn node_available(held: f64, limit: Option<f64>) -> f64 {
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let kib = |key: &str| {
        meminfo
            .lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
    };
    let mut bytes = kib("MemAvailable:").map_or(f64::INFINITY, |k| k * 1024.0);
    let read = |f: &str| std::fs::read_to_string(format!("/sys/fs/cgroup/{f}")).ok();
    if let (Some(max), Some(current)) = (read("memory.max"), read("memory.current")) {
        if let (Ok(max), Ok(current)) = (max.trim().parse::<f64>(), current.trim().parse::<f64>()) {
            bytes = bytes.min(max - current);
        }
    }
    (bytes + held).min(limit.unwrap_or(f64::INFINITY))
}

/// The memory the run's nodes offer it (bytes), summed over the nodes (collective): each
/// node's [`node_available`], with what its ranks hold now.
fn available(world: &SimpleCommunicator, limit: Option<f64>) -> f64 {
    let node = world.split_shared(world.rank());
    let mine = crate::os::memory::resident();
    let mut held = 0.0;
    node.all_reduce_into(&mine, &mut held, SystemOperation::sum());
    let offered = match node.rank() {
        0 => node_available(held, limit),
        _ => 0.0,
    };
    let mut total = 0.0;
    world.all_reduce_into(&offered, &mut total, SystemOperation::sum());
    total
}

/// The dofs of the reference mesh r·n: exact for the built-in problems, r² times the mesh's
/// for a Gmsh mesh (its uniform refinement, not built here).
fn fine_dofs(settings: &Settings, r: usize) -> usize {
    match &settings.problem.mesh {
        // (a built-in problem refines without a file: never an error)
        None => settings.problem.refined(r).map_or(0, |fine| fine.dofs()),
        Some(_) => settings.problem.dofs() * r * r,
    }
}

/// The estimated bytes of a run on `ranks` ranks: the mesh of `dofs` dofs and the reference
/// mesh of `reference` dofs, both problems held together, their factorisations one after the
/// other (the reference is solved and freed before the run's own bodies are set up).
pub fn estimate(ranks: usize, dofs: usize, reference: Option<usize>) -> f64 {
    let all_dofs = (dofs + reference.unwrap_or(0)) as f64;
    (PER_RANK + PER_RANK_DOF * all_dofs) * ranks as f64
        + mesh_bytes(dofs).max(reference.map_or(0.0, mesh_bytes))
}

/// The meshes a size check is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Meshes {
    /// The run's given meshes (before any is built).
    Given,
    /// An adaptive run's meshes for cycle k (remeshed, not yet built).
    Cycle(usize),
}

/// Refuses a run whose `meshes` would not fit (collective; the same answer on every rank), or
/// under [`MemoryCheck::Warn`] returns the same line as a warning.
pub fn check(
    settings: &Settings,
    world: &SimpleCommunicator,
    meshes: Meshes,
) -> Result<Option<String>, SettingsError> {
    verdict(shortfall(settings, world, meshes), settings.memory_check)
}

/// What `mode` makes of the model's `short`fall: the error, a warning, or nothing.
fn verdict(
    short: Option<SettingsError>,
    mode: MemoryCheck,
) -> Result<Option<String>, SettingsError> {
    match (short, mode) {
        (None, _) => Ok(None),
        (Some(SettingsError::Named { option, message }), MemoryCheck::Refuse) => {
            Err(SettingsError::Named {
                option,
                message: format!("{message} (or -nndd_memory_check warn)"),
            })
        }
        (Some(e), MemoryCheck::Refuse) => Err(e),
        (Some(e), MemoryCheck::Warn) => {
            Ok(Some(format!("{e}; run anyway (-nndd_memory_check warn)")))
        }
    }
}

/// `bytes` in GiB to a tenth, or in MiB below 1 GiB.
fn size(bytes: f64) -> String {
    match bytes >= GIB {
        true => format!("{:.1} GiB", bytes / GIB),
        false => format!("{:.0} MiB", bytes / MIB),
    }
}

/// Why the run's `meshes` would not fit in its nodes' memory, or `None` where they fit
/// (collective).
fn shortfall(
    settings: &Settings,
    world: &SimpleCommunicator,
    meshes: Meshes,
) -> Option<SettingsError> {
    let ranks = world.size() as usize;
    let dofs = settings.problem.dofs();
    let base = estimate(ranks, dofs, None);
    let r = settings.estimate.reference_factor;
    let fine = (r > 0).then(|| fine_dofs(settings, r));
    let need = estimate(ranks, dofs, fine);
    let have = available(world, settings.memory_limit);
    if need <= have {
        return None;
    }
    let mut room = format!("{} available", size(have));
    let mut more = vec!["more nodes".to_string()];
    if let Some(limit) = settings.memory_limit {
        room.push_str(" under -nndd_memory_limit");
        more.push(format!(
            "a larger -nndd_memory_limit ({:.0} MiB per node given)",
            limit / MIB
        ));
    }
    let (what, verb) = match meshes {
        Meshes::Cycle(k) => (format!("cycle {k}'s meshes ({dofs} dofs)"), "need"),
        Meshes::Given => (format!("the mesh ({dofs} dofs)"), "needs"),
    };
    Some(match fine {
        Some(reference_dofs) if base <= have => {
            // The largest factor that fits, for the message.
            let fits = (1..r)
                .rev()
                .find(|&f| estimate(ranks, dofs, Some(fine_dofs(settings, f))) <= have);
            let on = match (meshes, &settings.problem.mesh) {
                (Meshes::Cycle(k), _) => format!("cycle {k}'s meshes refined {r} times"),
                (Meshes::Given, Some(_)) => format!("the mesh refined {r} times"),
                (Meshes::Given, None) => format!("mesh {}", settings.problem.n * r),
            };
            SettingsError::Named {
                option: format!("-nndd_reference_factor {r}"),
                message: format!(
                    "the reference solution on {on} ({reference_dofs} dofs) needs about {} (estimated; the run's nodes have {room}); {}",
                    size(need),
                    match fits {
                        Some(f) => format!("use a factor of at most {f}, or {}", more.join(" or ")),
                        None => format!("use {}, or no -nndd_reference_factor", more.join(" or ")),
                    }
                ),
            }
        }
        _ => SettingsError::Named {
            option: match (&settings.problem.mesh, &settings.adapt, meshes) {
                (_, Some(adapt), Meshes::Cycle(_)) => format!("-nndd_adapt_tol {}", adapt.tol),
                (Some(spec), _, _) => format!("-nndd_mesh {}", spec.gmsh.path),
                (None, _, _) => format!("-nndd_n {}", settings.problem.n),
            },
            message: format!(
                "{what} {verb} about {} (estimated; the run's nodes have {room}); use {}",
                size(base),
                {
                    let first = match meshes {
                        Meshes::Cycle(_) => "a larger tolerance",
                        Meshes::Given => "a coarser mesh",
                    };
                    let mut all = vec![first.to_string()];
                    all.extend(more);
                    let last = all.pop().expect("two or more");
                    format!("{} or {last}", all.join(", "))
                },
            ),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_grows_faster_than_its_dofs() {
        let (small, large) = (mesh_bytes(1 << 16), mesh_bytes(1 << 20));
        // 16 times the dofs, log2 from 16 to 20: 20 times the bytes.
        assert!((large / small - 20.0).abs() < 1e-9, "{}", large / small);
        // paper n = 512 with one estimate (1 052 676 dofs) peaks at 1711 MiB summed over
        // 2 ranks, 2072 over 4 and 2505 over 8; n = 1024 (4 202 500) at 7338 over 2 and
        // 9285 over 8 (jobs/bench-memory-ranks); drawn in Gmsh, n = 512 at 1717 over 2 and
        // 2582 over 8, n = 1024 at 7314 over 2 and 9265 over 8 (jobs/bench-input --estimate),
        // n = 1448 (8 398 404) at 18 986 over 8 (`mpirun -n 8 nndd -options_file
        // examples/paper/paper.opts -nndd_mesh paper-1448.msh -nndd_estimate
        // -nndd_estimate_every 0`); n = 1448 at 16 080 and n = 1600 (10 252 804) at 20 737
        // over 2 (docs/scaling.md, "Memory per rank"): the model is above each, by at most a
        // third.
        for (ranks, dofs, peak) in [
            (2, 1_052_676, 1711.0),
            (4, 1_052_676, 2072.0),
            (8, 1_052_676, 2505.0),
            (2, 4_202_500, 7338.0),
            (8, 4_202_500, 9285.0),
            (2, 1_052_676, 1717.0),
            (8, 1_052_676, 2582.0),
            (2, 4_202_500, 7314.0),
            (8, 4_202_500, 9265.0),
            (2, 8_398_404, 16080.0),
            (2, 10_252_804, 20737.0),
            (8, 8_398_404, 18986.0),
        ] {
            let model = estimate(ranks, dofs, None) / MIB;
            assert!(
                (peak..1.34 * peak).contains(&model),
                "{ranks} ranks, {dofs} dofs: {model}"
            );
        }
    }

    #[test]
    fn the_reference_and_the_run_are_factored_one_after_the_other() {
        // paper n = 256 with -nndd_reference_factor 2 and one estimate (264 196 + 1 052 676
        // dofs) peaks at 1713 MiB summed over 2 ranks and 2493 over 8; n = 512 with it
        // (1 052 676 + 4 202 500) at 7341 over 2 (`mpirun -n P nndd -options_file
        // petsc-options/paper.opts -nndd_n N -nndd_reference_factor 2 -nndd_estimate
        // -nndd_estimate_every 0`): the model is above each, by at most a third.
        for (ranks, dofs, fine, peak) in [
            (2, 264_196, 1_052_676, 1713.0),
            (8, 264_196, 1_052_676, 2493.0),
            (2, 1_052_676, 4_202_500, 7341.0),
        ] {
            let model = estimate(ranks, dofs, Some(fine)) / MIB;
            assert!(
                (peak..1.34 * peak).contains(&model),
                "{ranks} ranks: {model}"
            );
        }
        // The fine factorisation alone, not both.
        let (run, reference) = (
            estimate(2, 264_196, None),
            estimate(2, 264_196, Some(1_052_676)),
        );
        let held = (PER_RANK_DOF * 1_052_676.0 * 2.0 + mesh_bytes(1_052_676)) - mesh_bytes(264_196);
        assert!(
            (reference - run - held).abs() < 1.0,
            "{}",
            reference - run - held
        );
    }

    #[test]
    fn a_shortfall_is_refused_or_warned_of_as_asked() {
        let short = || {
            Some(SettingsError::Named {
                option: "-nndd_n 1600".into(),
                message: "the mesh (10252804 dofs) needs about 23.9 GiB".into(),
            })
        };
        let e = verdict(short(), MemoryCheck::Refuse).unwrap_err();
        assert_eq!(
            e.to_string(),
            "-nndd_n 1600: the mesh (10252804 dofs) needs about 23.9 GiB (or -nndd_memory_check warn)"
        );
        let w = verdict(short(), MemoryCheck::Warn).unwrap().unwrap();
        assert_eq!(
            w,
            "-nndd_n 1600: the mesh (10252804 dofs) needs about 23.9 GiB; run anyway (-nndd_memory_check warn)"
        );
        for mode in [MemoryCheck::Refuse, MemoryCheck::Warn] {
            assert!(verdict(None, mode).unwrap().is_none());
        }
    }
}
