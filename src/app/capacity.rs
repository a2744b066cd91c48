//! Whether a run fits in the memory of its nodes, checked before any mesh is built: the
//! subdomain factorisations of the mesh n and, with `-nndd_reference_factor r`, of the
//! reference mesh r·n (both held at once while the reference is solved). A run that would not
//! fit is refused with its estimated memory, instead of swapping or being killed part-way.
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
//! takes above the groups' growth, faster than dofs · log dofs from n = 1024 to 1448. The available memory is the sum over the run's nodes of `MemAvailable`
//! (`/proc/meminfo`), or of the cgroup's limit less its usage where that is lower (a Slurm
//! job's `--mem`). A run the model refuses may still fit where it overestimates (by up to a
//! third on the measured runs with factored bodies, 1.9 × with CG + GAMG's): `-nndd_memory_check warn` runs it with a warning
//! ([`MemoryCheck`]).

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

/// The memory this node offers: `MemAvailable`, or the cgroup's room if lower (bytes).
fn node_available() -> f64 {
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
    bytes
}

/// The memory the run's nodes offer (bytes), summed over the nodes (collective).
fn available(world: &SimpleCommunicator) -> f64 {
    let node = world.split_shared(world.rank());
    let mine = if node.rank() == 0 {
        node_available()
    } else {
        0.0
    };
    let mut total = 0.0;
    world.all_reduce_into(&mine, &mut total, SystemOperation::sum());
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

/// Refuses a run whose meshes would not fit (collective; the same answer on every rank), or
/// under [`MemoryCheck::Warn`] returns the same line as a warning.
pub fn check(
    settings: &Settings,
    world: &SimpleCommunicator,
) -> Result<Option<String>, SettingsError> {
    verdict(shortfall(settings, world), settings.memory_check)
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

/// Why the run's meshes would not fit in its nodes' memory, or `None` where they fit
/// (collective).
fn shortfall(settings: &Settings, world: &SimpleCommunicator) -> Option<SettingsError> {
    let ranks = world.size() as usize;
    let dofs = settings.problem.dofs();
    let base = estimate(ranks, dofs, None);
    let r = settings.estimate.reference_factor;
    let fine = (r > 0).then(|| fine_dofs(settings, r));
    let need = estimate(ranks, dofs, fine);
    let have = available(world);
    if need <= have {
        return None;
    }
    let gib = |b: f64| format!("{:.1} GiB", b / GIB);
    Some(match fine {
        Some(reference_dofs) if base <= have => {
            // The largest factor that fits, for the message.
            let fits = (1..r)
                .rev()
                .find(|&f| estimate(ranks, dofs, Some(fine_dofs(settings, f))) <= have);
            SettingsError::Named {
                option: format!("-nndd_reference_factor {r}"),
                message: format!(
                    "the reference solution on mesh {} ({reference_dofs} dofs) needs about {} (estimated; the run's nodes have {} available); {}",
                    settings.problem.n * r,
                    gib(need),
                    gib(have),
                    match fits {
                        Some(f) => format!("use a factor of at most {f}, or more nodes"),
                        None => "run on more nodes, or without -nndd_reference_factor".into(),
                    }
                ),
            }
        }
        _ => SettingsError::Named {
            option: match &settings.problem.mesh {
                Some(spec) => format!("-nndd_mesh {}", spec.gmsh.path),
                None => format!("-nndd_n {}", settings.problem.n),
            },
            message: format!(
                "the mesh ({dofs} dofs) needs about {} (estimated; the run's nodes have {} available); use a coarser mesh or more nodes",
                gib(base),
                gib(have)
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
