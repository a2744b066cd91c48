//! What each rank keeps of the bodies' meshes once the ranks are laid out: the body of its
//! group and any body it estimates part of, the others released to their outlines
//! ([`release_unread_meshes`]); then, once the bodies are partitioned, each mesh cut to the
//! part the rank reads ([`keep_read_parts`]; where world rank 0 builds the bodies, it cuts
//! every rank's part alike, `app::input`). docs/scaling.md, "Memory per rank".

use std::rc::Rc;

use super::options::Settings;
use crate::estimate::estimator::Estimator;
use crate::parallel::layout::Layout;
use crate::parallel::partition::Partition;
use crate::problem::{self, BodyProblem, ContactDiscretisation};

/// Each body's problem as this rank keeps it through the run: whole where a phase on this
/// rank reads the body's mesh (the body of the rank's group, a body some of whose elements
/// are estimated outside its group, every body of a mortar run that estimates), else with
/// its mesh released ([`BodyProblem::released`]: its outline, O(√N), and its counts), so
/// that a rank holds one body's mesh where it used to hold both.
pub(super) fn release_unread_meshes(
    problems: [Rc<BodyProblem>; 2],
    settings: &Settings,
    layout: &Layout,
) -> [Rc<BodyProblem>; 2] {
    let pair = [&*problems[0], &*problems[1]];
    if reads_whole_meshes(settings, mortar(pair)) {
        return problems;
    }
    let sizes = pair.map(|p| p.num_elements());
    let outside = crate::estimate::share::estimated_outside_group(sizes, layout);
    problems.map(|p| {
        let estimated_here = settings.estimate.enabled && outside[p.alpha - 1];
        match layout.owns(p.alpha) || estimated_here {
            true => p,
            false => Rc::new(p.released()),
        }
    })
}

/// Whether a rank that holds a body's mesh reads it whole through the run (`mortar`: the
/// bodies are coupled by mortar), where it built the bodies itself (`-nndd_mesh_input
/// every_rank`): a mortar run's estimates map both bodies' meshes onto their matched ones
/// (under `root` world rank 0 alone does, `app::input::deal_matched`). (An adaptive run's size
/// view covers the whole meshes on world rank 0 alone, which builds them again from the
/// cycle's file, `cycles::whole_bodies_on_root`.)
pub(super) fn reads_whole_meshes(settings: &Settings, mortar: bool) -> bool {
    mortar && settings.estimate.enabled
}

/// Whether the bodies `problems` are coupled by mortar.
pub(super) fn mortar(problems: [&BodyProblem; 2]) -> bool {
    problem::discretisation(problems) == ContactDiscretisation::Mortar
}

/// Each body's problem with its mesh, where it is listed (a Gmsh body's), cut to the part this
/// rank reads once the bodies are partitioned, before they are set up ([`BodyProblem::part`];
/// docs/scaling.md, "Memory per rank"): its elements of the partition and its nodes (its
/// rows), its block of the output's cells and nodes, Γc's nodes and the elements its estimates
/// read ([`Estimator::elements_read`]; collective: the estimator's shares, its overlaps, are
/// made here rather than at the first estimate). A body estimated whole on the rank, a
/// built-in body (its grid's formula holds nothing), a part of most of the mesh and a mortar
/// run that estimates ([`reads_whole_meshes`]) keep theirs.
pub(super) fn keep_read_parts(
    problems: [Rc<BodyProblem>; 2],
    settings: &Settings,
    layout: &Layout,
    partitions: &[Option<Partition>; 2],
    estimator: &mut Option<Estimator>,
) -> [Rc<BodyProblem>; 2] {
    // (a built-in body's mesh is its grid's formula: nothing to cut; the condition is the same
    // on every rank, as the estimator's shares are made collectively)
    let pair = [&*problems[0], &*problems[1]];
    if settings.problem.mesh.is_none() || reads_whole_meshes(settings, mortar(pair)) {
        return problems;
    }
    let estimated = estimator.as_ref().map(|e| e.elements_read());
    let parts = [0, 1].map(|k| {
        let elements = match &estimated {
            Some(read) => read[k].clone()?,
            None => Vec::new(),
        };
        read_part(&problems[k], layout, partitions[k].as_ref(), elements)
    });
    let [p1, p2] = problems;
    let [q1, q2] = parts;
    let held = [q1.unwrap_or(p1), q2.unwrap_or(p2)];
    if let Some(e) = estimator {
        e.hold(&held);
    }
    held
}

/// Body α's problem `p` with its mesh cut to the part this rank reads (`None` where its mesh is
/// not listed, or the part would be most of it: a part holds 4 B more per entry than the
/// whole): the `elements` given, its elements of `partition` and its nodes (its rows), its
/// block of the output's cells and nodes, and Γc's nodes ([`BodyProblem::part`]).
pub(super) fn read_part(
    p: &BodyProblem,
    layout: &Layout,
    partition: Option<&Partition>,
    elements: Vec<u32>,
) -> Option<Rc<BodyProblem>> {
    let (cells, nodes) = (
        layout.block(p.alpha, p.num_elements()),
        layout.block(p.alpha, p.num_nodes()),
    );
    read_part_in(p, cells, nodes, partition, elements)
}

/// [`read_part`] for the rank whose blocks of the output's cells and nodes are `cells` and
/// `nodes` (world rank 0 cuts every rank's part, `input::deal_parts`).
pub(super) fn read_part_in(
    p: &BodyProblem,
    cells: std::ops::Range<usize>,
    nodes: std::ops::Range<usize>,
    partition: Option<&Partition>,
    mut elements: Vec<u32>,
) -> Option<Rc<BodyProblem>> {
    if !p.holds_listed_mesh() {
        return None;
    }
    if let Some(part) = partition {
        elements.extend_from_slice(&part.elements);
    }
    elements.extend(cells.map(crate::fem::mesh::element_u32));
    elements.sort_unstable();
    elements.dedup();
    let rows = partition.into_iter().flat_map(Partition::owned_mesh_nodes);
    let contact = p.contact_nodes.iter().chain(&p.contact_candidates).copied();
    let nodes: Vec<u32> = nodes.chain(rows).chain(contact).map(|n| n as u32).collect();
    // (16 B per triangle and 20 per point held, against 12 and 16 whole)
    (4 * elements.len() < 3 * p.num_elements()).then(|| Rc::new(p.part(&elements, &nodes)))
}

/// The elements of the bodies' meshes this rank holds once they are built: both bodies'
/// where it built them, none of a built-in body's (its grid's formula), its part where
/// world rank 0 built them (`input::deal_parts` counts those).
pub(super) fn input_mesh_elements(problems: &[Rc<BodyProblem>; 2]) -> usize {
    (problems.iter())
        .filter(|p| p.holds_listed_mesh())
        .map(|p| p.num_elements())
        .sum()
}
