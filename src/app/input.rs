//! A Gmsh problem's bodies built once (`-nndd_mesh_input root`, the default on several ranks):
//! world rank 0 builds both bodies' problems ([`build_on_root`]) and sends every other rank
//! their outlines, Γc and conditions; once the ranks are laid out it partitions each body over
//! its group and sends every rank its partition, each body's problem cut to the part the rank
//! reads and, where the run estimates, the rank's shares of the estimates (its overlaps, made
//! from the whole meshes on rank 0: `estimate::share::SharePlan`) ([`deal_parts`]): what
//! `app::parts::keep_read_parts` leaves a rank that built the bodies itself, so the run goes on
//! alike. No rank but world rank 0 builds or holds a whole body (docs/scaling.md, "Memory per
//! rank"; the summary's `input_mesh_elements_per_rank`).
//!
//! The reference solution's fine bodies (`-nndd_reference_factor`) are built on world rank 0
//! and dealt alike: rank 0 refines the file (`reference::solve_reference`; a mortar run's
//! estimates' matched meshes, with their initial gaps). A mortar run's bodies are sent with
//! their coupling, and where it estimates, its estimates' matched meshes and each rank's part
//! of the maps between the two ([`deal_matched`]); an adaptive run's cycles each so (rank 0
//! remeshes, and builds the whole meshes again for the size view,
//! `cycles::whole_bodies_on_root`).

use std::rc::Rc;

use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use super::options::Settings;
use super::{agreed, AppError};
use crate::estimate::estimator::{contact_elements, elements_read_by, Estimator};
use crate::estimate::mortar::MortarMaps;
use crate::estimate::reference::coarse_elements_under;
use crate::estimate::share::{estimated_outside_group, Seed, SharePlan};
use crate::fem::mesh::element_u32;
use crate::fem::wire::{Reader, Writer};
use crate::parallel::fault::{self, Agreement, Phase};
use crate::parallel::layout::{block_of, Layout};
use crate::parallel::partition::Partition;
use crate::parallel::root;
use crate::problem::parsed::MeshInput;
use crate::problem::transfer::GapField;
use crate::problem::{self, BodyProblem};

/// Whether this run builds its bodies on world rank 0 alone: a Gmsh problem on several ranks
/// under `-nndd_mesh_input root`. Its reference solution's fine bodies are built on world rank
/// 0 alike (`reference::solve_reference`), and a mortar run's estimates' matched meshes
/// ([`deal_matched`]).
pub(super) fn on_root(settings: &Settings, ranks: i32) -> bool {
    settings.problem.mesh.is_some() && ranks > 1 && settings.problem.input == MeshInput::Root
}

/// Both bodies' problems: whole on world rank 0, which builds them (a mortar run's estimates'
/// matched problems, and their reference's, with the initial gaps `gaps`); on every other rank
/// released to their outlines, Γc and conditions ([`BodyProblem::released`]), as rank 0 sends
/// them (collective; the ranks agree on rank 0's build).
pub(super) fn build_on_root(
    settings: &Settings,
    gaps: Option<&GapField>,
    agreement: &Agreement,
    world: &SimpleCommunicator,
) -> Result<[Rc<BodyProblem>; 2], AppError> {
    let built = match world.rank() == 0 {
        true => problem::build(&settings.problem).map(|p| {
            Some(match gaps {
                Some(g) => g.apply(p),
                None => p,
            })
        }),
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
            w.bytes(&b.released().to_bytes());
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

/// What a rank works with once the ranks are laid out ([`deal_parts`]).
pub(super) struct Dealt {
    /// The body of the rank's group.
    pub alpha: usize,
    /// The rank's partition of it.
    pub partition: Partition,
    /// Each body's problem cut to the part the rank reads, or whole where that part would be
    /// most of it.
    pub problems: [Rc<BodyProblem>; 2],
    /// Where the run estimates: the rank's shares of the bodies' estimates, before their halos
    /// are made ([`Estimator::take_shares`](crate::estimate::estimator::Estimator::take_shares)).
    pub seeds: Option<[Seed; 2]>,
}

impl Dealt {
    /// The partitions and the problems this rank holds, the estimator's shares made from the
    /// seeds world rank 0 sent (collective).
    pub(super) fn hold(
        self,
        estimator: &mut Option<Estimator>,
    ) -> ([Option<Partition>; 2], [Rc<BodyProblem>; 2]) {
        let mut partitions = [None, None];
        partitions[self.alpha - 1] = Some(self.partition);
        // (a mortar run's estimator holds its matched problems, dealt on their own)
        if let (Some(e), Some(seeds)) = (estimator, self.seeds) {
            e.take_shares(seeds);
            e.hold(&self.problems);
        }
        (partitions, self.problems)
    }

    /// The elements of the meshes this rank holds.
    fn held_elements(&self) -> usize {
        (self.problems.iter())
            .filter(|p| p.holds_mesh())
            .map(|p| p.mesh().triangles.held_len())
            .sum()
    }

    /// The bytes world rank 0 sends.
    fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.int(self.alpha);
        self.partition.write(&mut w);
        for p in &self.problems {
            w.bytes(&p.to_bytes());
        }
        match &self.seeds {
            None => w.u8(0),
            Some(seeds) => {
                w.u8(1);
                seeds.iter().for_each(|s| s.write(&mut w));
            }
        }
        w.0
    }

    /// What [`Dealt::to_bytes`] wrote.
    fn from_bytes(bytes: &[u8]) -> Option<Dealt> {
        let mut r = Reader::new(bytes);
        let alpha = r.int()?;
        let partition = Partition::read(&mut r)?;
        let mut problem = |body| {
            let p = BodyProblem::from_bytes(r.bytes()?)?;
            (p.alpha == body).then(|| Rc::new(p))
        };
        let problems = [problem(1)?, problem(2)?];
        let seeds = match r.u8()? {
            0 => None,
            1 => Some([Seed::read(&mut r)?, Seed::read(&mut r)?]),
            _ => return None,
        };
        let dealt = Dealt {
            alpha,
            partition,
            problems,
            seeds,
        };
        r.is_done().then_some(dealt)
    }
}

/// What each rank works with once the ranks are laid out ([`Dealt`]): world rank 0 partitions
/// each body over its group ([`Partition::dealt`]: the partitions the groups would make) and
/// sends every rank its partition, each body's problem cut to the part the rank reads and,
/// where the run estimates, its shares of the estimates ([`dealt_to`]). Also the elements of the
/// meshes this rank held in the input (world rank 0: both bodies'). Collective; the ranks
/// agree on the partitions.
pub(super) fn deal_parts(
    problems: [Rc<BodyProblem>; 2],
    settings: &Settings,
    layout: &Layout,
    agreement: &Agreement,
) -> Result<(Dealt, usize), AppError> {
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
        Some(partitions) => send_parts(&problems, partitions, settings, layout),
        None => Dealt::from_bytes(&root::receive_from_root(&layout.world)),
    };
    let mine = mine
        .filter(|d| layout.owns(d.alpha))
        .ok_or_else(|| damaged("this rank's part of the bodies"));
    let mine = agreed(agreement, mine)?;
    let input_elements = match layout.is_root() {
        true => problems.iter().map(|p| p.num_elements()).sum(),
        false => mine.held_elements(),
    };
    Ok((mine, input_elements))
}

/// On world rank 0: every other rank sent what it works with ([`dealt_to`]); rank 0's own
/// returned.
fn send_parts(
    problems: &[Rc<BodyProblem>; 2],
    partitions: [Vec<Partition>; 2],
    settings: &Settings,
    layout: &Layout,
) -> Option<Dealt> {
    let sizes = problems.each_ref().map(|p| p.num_elements());
    let crosses = estimated_outside_group(sizes, layout);
    let (how, recovery) = (settings.problem.partitioner, settings.estimate.recovery);
    let plan = |k: usize| {
        let mesh = Some(problems[k].mesh());
        SharePlan::new(k + 1, mesh, sizes, layout, how, crosses[k], recovery)
    };
    // (a mortar run's estimates and its reference are on its matched meshes, [`deal_matched`])
    let mortar = super::parts::mortar([&problems[0], &problems[1]]);
    let estimated = settings.estimate.enabled && !mortar;
    let plans = estimated.then(|| [plan(0), plan(1)]);
    let gc = problems.each_ref().map(|p| match plans {
        Some(_) => contact_elements(p),
        None => Vec::new(),
    });
    let reference = if mortar {
        0
    } else {
        settings.estimate.reference_factor
    };
    let mut own = None;
    for (k, parts) in partitions.into_iter().enumerate() {
        let ranks = layout.group_ranks(k + 1);
        for (g, partition) in parts.into_iter().enumerate() {
            let to = (ranks.start + g, k + 1);
            let dealt = dealt_to(to, partition, problems, (&plans, &gc), reference, layout);
            if ranks.start + g == 0 {
                own = Some(dealt);
                continue;
            }
            let bytes = dealt.to_bytes();
            drop(dealt);
            root::send_to(&layout.world, (ranks.start + g) as i32, &bytes);
        }
    }
    own
}

/// What world rank `rank` of body `alpha`'s group works with, its `partition` of the body
/// given: each body's problem cut to the part the rank reads (what `app::parts::release_unread_meshes`
/// and `app::parts::keep_read_parts` leave a rank that built the bodies itself,
/// [`super::parts::read_part_in`]) and its shares of the estimates where the run estimates (`plans`;
/// `gc`: each body's Γc elements, which they read; with the reference solution of factor `r`,
/// none where 0).
fn dealt_to(
    (rank, alpha): (usize, usize),
    partition: Partition,
    problems: &[Rc<BodyProblem>; 2],
    (plans, gc): (&Option<[SharePlan; 2]>, &[Vec<u32>; 2]),
    r: usize,
    layout: &Layout,
) -> Dealt {
    let seeds = plans
        .as_ref()
        .map(|p| [0, 1].map(|k| p[k].seed(rank, layout)));
    let held = [0, 1].map(|k| {
        let p = &problems[k];
        let ranks = layout.group_ranks(k + 1);
        let in_group = k + 1 == alpha;
        // (outside its group, a body is read where some of its elements are estimated outside
        // the group, else released: `app::parts::release_unread_meshes`)
        if !in_group && !plans.as_ref().is_some_and(|p| p[k].crosses()) {
            return Rc::new(p.released());
        }
        let block = |n| match in_group {
            true => block_of(n, rank - ranks.start, ranks.len()),
            false => 0..0,
        };
        // (e_ref's transfer to the rank's block of the fine elements reads the coarse ones
        // under it, `Estimator::elements_read`)
        let under = coarse_elements_under(block(r * r * p.num_elements()), r * r);
        let read = match &seeds {
            Some(seeds) => elements_read_by(seeds[k].elements_read(), &gc[k]).map(|mut read| {
                read.extend(under.clone().map(element_u32));
                read
            }),
            None => Some(Vec::new()),
        };
        let [cells, nodes] = [p.num_elements(), p.num_nodes()].map(block);
        let partition = in_group.then_some(&partition);
        let part =
            read.and_then(|read| super::parts::read_part_in(p, cells, nodes, partition, read));
        part.unwrap_or_else(|| p.clone())
    });
    Dealt {
        alpha,
        partition,
        problems: held,
        seeds,
    }
}

/// The initial gaps of a mortar run's estimates' matched problems ([`GapField`]), made on world
/// rank 0 from the run's whole problems `whole` it built, on every rank (collective).
pub(super) fn gaps_from_root(whole: Option<&[Rc<BodyProblem>; 2]>) -> Result<GapField, AppError> {
    let bytes = root::bytes_from_root("the estimates' initial gaps", || {
        let run = whole.ok_or_else(|| "world rank 0 holds no whole bodies".to_string())?;
        let mut w = Writer::default();
        GapField::new([&run[0], &run[1]]).write(&mut w);
        Ok(w.0)
    });
    let bytes = bytes.map_err(AppError::Input)?;
    let mut r = Reader::new(&bytes);
    (GapField::read(&mut r).filter(|_| r.is_done()))
        .ok_or_else(|| damaged("the estimates' initial gaps"))
}

/// A mortar run's estimates' `matched` problems (docs/method.md §7, "The estimates") built on
/// world rank 0 alone, with the initial gaps `gaps`: rank 0 matched the curves of the file it
/// read ([`crate::problem::ProblemSettings::for_estimates`]), builds the matched problems and
/// the maps between the run's whole problems `whole` (its own, kept whole until here) and
/// them, and sends every rank its part of the maps ([`MortarMaps::part`]) and what it works
/// with of the matched problems, its shares of their estimates included ([`deal_parts`]): no
/// rank but world rank 0 holds a whole mesh. Collective; the ranks agree on rank 0's maps.
pub(super) fn deal_matched(
    matched: &Settings,
    whole: Option<&[Rc<BodyProblem>; 2]>,
    gaps: &GapField,
    layout: &Layout,
    agreement: &Agreement,
) -> Result<(Dealt, MortarMaps), AppError> {
    let built = build_on_root(matched, Some(gaps), agreement, &layout.world)?;
    let maps = match (layout.is_root(), whole) {
        (true, Some(run)) => MortarMaps::new(run, &built)
            .map(Some)
            .map_err(AppError::from),
        (true, None) => Err(damaged("the run's bodies")),
        (false, _) => Ok(None),
    };
    let mine = match agreed(agreement, maps)? {
        Some(maps) => Some(send_maps(&maps, &built, layout)),
        None => {
            let bytes = root::receive_from_root(&layout.world);
            let mut r = Reader::new(&bytes);
            MortarMaps::read(&mut r).filter(|_| r.is_done())
        }
    };
    let mine = mine.ok_or_else(|| damaged("this rank's part of the estimates' maps"));
    let mine = agreed(agreement, mine)?;
    let (dealt, _) = deal_parts(built, matched, layout, agreement)?;
    Ok((dealt, mine))
}

/// On world rank 0: every other rank sent its part of the whole `maps` ([`MortarMaps::part`],
/// `matched` the whole matched problems); rank 0's own returned.
fn send_maps(maps: &MortarMaps, matched: &[Rc<BodyProblem>; 2], layout: &Layout) -> MortarMaps {
    let mut own = None;
    for alpha in [1, 2] {
        let ranks = layout.group_ranks(alpha);
        for rank in ranks.clone() {
            let part = maps.part(matched, (rank, alpha), ranks.clone());
            if rank == 0 {
                own = Some(part);
                continue;
            }
            let mut w = Writer::default();
            part.write(&mut w);
            drop(part);
            root::send_to(&layout.world, rank as i32, &w.0);
        }
    }
    own.expect("world rank 0 is in body 1's group")
}
