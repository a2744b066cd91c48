//! A Gmsh problem's bodies built once (`-nndd_mesh_input root`, the default on several ranks):
//! world rank 0 builds both bodies' problems ([`build_on_root`]) and sends every other rank
//! their outlines, Γc and conditions; once the ranks are laid out it partitions each body over
//! its group and sends every rank of the group the body's problem cut to the part that rank
//! reads, with its partition ([`deal_parts`]): what `app::keep_read_parts` leaves a rank that
//! built the bodies itself, so the run goes on alike. No rank but world rank 0 builds or holds
//! a whole body (docs/scaling.md, "Memory per rank"; the summary's
//! `input_mesh_elements_per_rank`).
//!
//! A run whose later phases read the whole meshes on every rank (its estimates' overlaps, the
//! reference solution's refinement, the mortar discretisation, an adaptive run's remeshing)
//! builds them on every rank instead ([`on_root`]).

use std::ops::Range;
use std::rc::Rc;

use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use super::options::Settings;
use super::{agreed, AppError};
use crate::fem::wire::{Reader, Writer};
use crate::parallel::fault::{self, Agreement, Phase};
use crate::parallel::layout::{block_of, Layout};
use crate::parallel::partition::Partition;
use crate::parallel::root;
use crate::parallel::wait::politely;
use crate::problem::parsed::MeshInput;
use crate::problem::{self, BodyProblem, ContactDiscretisation};

/// Whether this run builds its bodies on world rank 0 alone: a Gmsh problem on several ranks
/// under `-nndd_mesh_input root`, coupled node to node, that neither estimates nor reads the
/// parsed file after the build (`Settings::reads_mesh_after_build`).
pub(super) fn on_root(settings: &Settings, ranks: i32) -> bool {
    let Some(spec) = &settings.problem.mesh else {
        return false;
    };
    ranks > 1
        && settings.problem.input == MeshInput::Root
        && spec.discretisation == ContactDiscretisation::NodeToNode
        && !settings.estimate.enabled
        && !settings.reads_mesh_after_build()
}

/// Both bodies' problems: whole on world rank 0, which builds them; on every other rank
/// released to their outlines, Γc and conditions ([`BodyProblem::released`]), as rank 0 sends
/// them (collective; the ranks agree on rank 0's build).
pub(super) fn build_on_root(
    settings: &Settings,
    agreement: &Agreement,
    world: &SimpleCommunicator,
) -> Result<[Rc<BodyProblem>; 2], AppError> {
    let built = match world.rank() == 0 {
        true => problem::build(&settings.problem).map(Some),
        false => Ok(None),
    };
    let built = built.map_err(AppError::from).and_then(|p| {
        fault::check(Phase::Mesh)?;
        Ok(p)
    });
    let built = agreed(agreement, built)?;
    // (the fingerprint made from the whole mesh here, for the restart points' identity)
    let outlines = built.as_ref().map(|p| {
        let mut w = Writer::default();
        for b in p {
            b.mesh_fingerprint();
            w.bytes(&b.released().to_bytes().unwrap_or_default());
        }
        w.0
    });
    let bytes = root::bytes_from_root("the bodies' outlines", || {
        outlines.ok_or_else(|| "world rank 0 built no bodies".to_string())
    });
    let problems = match (built, bytes) {
        (Some(problems), _) => Ok(problems),
        (None, Ok(bytes)) => released_pair(&bytes),
        (None, Err(e)) => Err(AppError::Input(e)),
    };
    agreed(agreement, problems)
}

/// The two released problems [`build_on_root`]'s bytes hold.
fn released_pair(bytes: &[u8]) -> Result<[Rc<BodyProblem>; 2], AppError> {
    let mut r = Reader::new(bytes);
    let mut read = || BodyProblem::from_bytes(r.bytes()?).map(Rc::new);
    match (read(), read(), r.is_done()) {
        (Some(p1), Some(p2), true) => Ok([p1, p2]),
        _ => Err(damaged("the bodies' outlines")),
    }
}

/// The error of bytes from world rank 0 that do not read back.
fn damaged(what: &str) -> AppError {
    AppError::Input(format!(
        "-nndd_mesh_input root: {what} sent by world rank 0 do not read back (use -nndd_mesh_input every_rank)"
    ))
}

/// The problems and the partitions each rank works with once the ranks are laid out: world
/// rank 0 partitions each body over its group ([`Partition::dealt`]: the partitions the groups
/// would make) and sends every rank of the group its partition and the body's problem cut to
/// the part the rank reads ([`part_for`]); the other body released. Also the elements of the
/// meshes this rank held in the input (world rank 0: both bodies'). Collective; the ranks
/// agree on the partitions.
#[allow(clippy::type_complexity)]
pub(super) fn deal_parts(
    problems: [Rc<BodyProblem>; 2],
    settings: &Settings,
    layout: &Layout,
    agreement: &Agreement,
) -> Result<([Rc<BodyProblem>; 2], [Option<Partition>; 2], usize), AppError> {
    let how = settings.problem.partitioner;
    let dealt = match layout.is_root() {
        true => {
            let deal = |alpha: usize| {
                let size = layout.group_sizes[alpha - 1];
                Partition::dealt(problems[alpha - 1].mesh(), alpha, size, how)
            };
            deal(1).and_then(|d1| Ok(Some([d1, deal(2)?])))
        }
        false => Ok(None),
    };
    let dealt = agreed(agreement, dealt.map_err(AppError::from))?;
    let mine = match dealt {
        Some(partitions) => send_parts(&problems, partitions, layout),
        None => receive_part(layout),
    };
    let (alpha, problem, partition) = agreed(agreement, mine)?;
    let input_elements = match layout.is_root() {
        true => problems.iter().map(|p| p.num_elements()).sum(),
        false => problem.mesh().triangles.held_len(),
    };
    let mut held = problems.map(|p| Rc::new(p.released()));
    held[alpha - 1] = problem;
    let mut partitions = [None, None];
    partitions[alpha - 1] = Some(partition);
    Ok((held, partitions, input_elements))
}

/// On world rank 0: every other rank of each body's group sent its partition and its part
/// of the body (a part that cannot be written, a mortar body's, sent empty: the rank refuses
/// it); rank 0's own of body 1 returned.
fn send_parts(
    problems: &[Rc<BodyProblem>; 2],
    partitions: [Vec<Partition>; 2],
    layout: &Layout,
) -> Result<(usize, Rc<BodyProblem>, Partition), AppError> {
    let mut own = None;
    let mut unwritten = false;
    for (k, parts) in partitions.into_iter().enumerate() {
        let p = &problems[k];
        let ranks = layout.group_ranks(k + 1);
        for (g, partition) in parts.into_iter().enumerate() {
            let blocks = [p.num_elements(), p.num_nodes()].map(|n| block_of(n, g, ranks.len()));
            let part = part_for(p, &partition, blocks);
            let world_rank = ranks.start + g;
            if world_rank == 0 {
                own = Some((k + 1, part, partition));
                continue;
            }
            let mut w = Writer::default();
            w.int(k + 1);
            partition.write(&mut w);
            let bytes = part.to_bytes();
            unwritten |= bytes.is_none();
            w.0.extend_from_slice(&bytes.unwrap_or_default());
            drop(part);
            send(&layout.world, world_rank as i32, &w.0);
        }
    }
    match (own, unwritten) {
        (Some(own), false) => Ok(own),
        _ => Err(damaged("the bodies' parts")),
    }
}

/// On a rank other than world rank 0: its body, its part of it and its partition, as rank 0
/// sent them.
fn receive_part(layout: &Layout) -> Result<(usize, Rc<BodyProblem>, Partition), AppError> {
    let bytes = receive(&layout.world);
    let mut r = Reader::new(&bytes);
    let alpha = r.int().filter(|&a| layout.owns(a));
    let partition = Partition::read(&mut r);
    let problem = BodyProblem::from_bytes(r.rest());
    match (alpha, partition, problem) {
        (Some(alpha), Some(partition), Some(problem)) if problem.alpha == alpha => {
            Ok((alpha, Rc::new(problem), partition))
        }
        _ => Err(damaged("this rank's part of its body")),
    }
}

/// Body `p`'s problem cut to the part the rank of `partition` reads, its blocks of the
/// output's `[cells, nodes]` given ([`super::read_part_in`]: what `keep_read_parts` keeps on
/// that rank), or whole where that part would be most of it.
fn part_for(
    p: &Rc<BodyProblem>,
    partition: &Partition,
    blocks: [Range<usize>; 2],
) -> Rc<BodyProblem> {
    let [cells, nodes] = blocks;
    super::read_part_in(p, cells, nodes, Some(partition), Vec::new()).unwrap_or_else(|| p.clone())
}

/// The most bytes one message carries (MPI counts them in an `int`).
const CHUNK: usize = 1 << 30;

/// Sends `bytes` to world rank `to`: their length, then them, in messages of at most
/// [`CHUNK`] bytes.
fn send(world: &SimpleCommunicator, to: i32, bytes: &[u8]) {
    let dest = world.process_at_rank(to);
    dest.send(&(bytes.len() as u64));
    for chunk in bytes.chunks(CHUNK) {
        dest.send(chunk);
    }
}

/// What world rank 0 [`send`]s this rank (waiting for it without taking a core from rank 0).
fn receive(world: &SimpleCommunicator) -> Vec<u8> {
    let root = world.process_at_rank(0);
    let mut len = 0u64;
    mpi::request::scope(|scope| politely(root.immediate_receive_into(scope, &mut len)));
    let mut bytes = vec![0u8; len as usize];
    for chunk in bytes.chunks_mut(CHUNK) {
        root.receive_into(chunk);
    }
    bytes
}
