//! Γc of a Gmsh problem under the mortar discretisation (`-nndd_contact_discretisation
//! mortar`, docs/method.md §6): the two contact curves as meshed, no node inserted into
//! either. The coarser curve is the non-mortar side: its nodes that the other curve covers are
//! Γc's pairs, with their contact directions (the nodal normals of §5) and weighted gaps; the
//! other body meets each at a point of its curve ([`Coupling`]).

use std::collections::BTreeSet;

use super::curves::{
    chain_normals, contact_chain, facing, opt_err, oriented_side, MeshedError, Pairing,
};
use super::mortar::{Coupling, CurveNodes, Ends, GapGeometry};
use crate::fem::gmsh::GmshBody;

const OPT: &str = "-nndd_contact";

/// One curve as the non-mortar side: its oriented chain, outward nodal normals, points and its
/// coupling with the other curve.
struct Side {
    chain: Vec<usize>,
    outward: Vec<[f64; 2]>,
    points: Vec<[f64; 2]>,
    coupling: Coupling,
}

/// The non-mortar body (0 or 1), Γc's pairs at its covered nodes (the other's side: the nodes
/// the pairs' rows use, along its curve in the pairs' direction) and the coupling, with the
/// pairs' contact directions n pointing from body 1 to body 2 (u²_n − u¹_n ≥ −g).
///
/// The non-mortar side is the coarser curve where they overlap: of the two couplings, the one
/// with fewer pairs (body 1's on a tie). The other body's trace on its nodes must follow them
/// one by one (a row of full rank, so that the contact step on that body has one multiplier
/// per pair), which a curve with fewer nodes there cannot.
pub(super) fn mortar_interface(
    contact: &[String; 2],
    bodies: &[GmshBody],
    geometry: GapGeometry,
) -> Result<(Pairing, Coupling, usize), MeshedError> {
    let curve = |k: usize| -> Result<(Vec<usize>, Ends), MeshedError> {
        let name = &contact[k];
        let edges = bodies[k].curves.get(name).ok_or_else(|| {
            let known: Vec<String> = bodies[k].curves.keys().cloned().collect();
            opt_err(
                OPT,
                format!(
                    "no physical curve '{name}' on body{} (its curves: {})",
                    k + 1,
                    known.join(", ")
                ),
            )
        })?;
        contact_chain(edges, name, OPT)
    };
    let (c0, c1) = (curve(0)?, curve(1)?);
    let ends = [c0.1, c1.1];
    let chains = [c0.0, c1.0];
    // The coupling with body k's curve as the non-mortar side: that curve with body k on its
    // right, its outward nodal normals and points.
    let couple_from = |k: usize, nodes: Vec<usize>| -> Result<Side, MeshedError> {
        let (chain_s, segments) = oriented_side(&bodies[k], nodes, &contact[k])?;
        let outward = chain_normals(&segments, ends[k]);
        let ps = &bodies[k].mesh.points;
        let points: Vec<[f64; 2]> = chain_s.iter().map(|&n| ps.get(n)).collect();
        let po = &bodies[1 - k].mesh.points;
        let points_o: Vec<[f64; 2]> = chains[1 - k].iter().map(|&n| po.get(n)).collect();
        let coupling = Coupling::new(
            &CurveNodes {
                ids: &chain_s,
                points: &points,
                normals: &outward,
                ends: ends[k],
            },
            &CurveNodes {
                ids: &chains[1 - k],
                points: &points_o,
                normals: &[],
                ends: ends[1 - k],
            },
            geometry,
        );
        Ok(Side {
            chain: chain_s,
            outward,
            points,
            coupling,
        })
    };
    // A closed non-mortar curve is cut where Γc's pairs begin: after the stretch the other
    // curve does not cover, or, covered all round, after its node of the largest gap.
    let couple = |k: usize| -> Result<Side, MeshedError> {
        let side = couple_from(k, chains[k].clone())?;
        if ends[k] == Ends::Open || side.coupling.is_empty() {
            return Ok(side);
        }
        let loop_nodes = &side.chain[..side.chain.len() - 1];
        let covered: BTreeSet<usize> = side.coupling.nodes.iter().copied().collect();
        let n = loop_nodes.len();
        let start = (0..n)
            .find(|&p| {
                covered.contains(&loop_nodes[p]) && !covered.contains(&loop_nodes[(p + n - 1) % n])
            })
            .unwrap_or_else(|| {
                let widest = (0..side.coupling.len())
                    .max_by(|&a, &b| side.coupling.gap[a].total_cmp(&side.coupling.gap[b]))
                    .unwrap_or(0);
                let at = loop_nodes
                    .iter()
                    .position(|&x| x == side.coupling.nodes[widest])
                    .unwrap_or(0);
                (at + 1) % n
            });
        if start == 0 {
            return Ok(side);
        }
        let mut cut: Vec<usize> = loop_nodes[start..].to_vec();
        cut.extend_from_slice(&loop_nodes[..=start]);
        couple_from(k, cut)
    };
    // The side with fewer pairs where the curves overlap (body 1's on a tie).
    let both = [couple(0)?, couple(1)?];
    let pairs = both.each_ref().map(|s| s.coupling.len());
    let side = usize::from(pairs[1] > 0 && (pairs[0] == 0 || pairs[1] < pairs[0]));
    let other = 1 - side;
    let [first_try, second_try] = both;
    let (chosen, unused) = if side == 0 {
        (first_try, second_try)
    } else {
        (second_try, first_try)
    };
    let Side {
        chain: chain_s,
        outward,
        points: points_s,
        mut coupling,
    } = chosen;
    coupling.seconds += unused.coupling.seconds;
    let po = &bodies[other].mesh.points;
    let [c1, c2] = contact;
    let Some(first) = coupling
        .nodes
        .first()
        .and_then(|n| chain_s.iter().position(|x| x == n))
    else {
        return Err(opt_err(
            OPT,
            format!("the curves '{c1}' and '{c2}' cannot face each other: no normal line of either meets the other"),
        ));
    };
    let m = coupling.len();
    if chain_s.get(first..first + m) != Some(&coupling.nodes[..]) {
        return Err(opt_err(
            OPT,
            format!("the curves '{c1}' and '{c2}' cover each other in several pieces along their normal lines; name curves that face each other along one stretch"),
        ));
    }
    // Each pair's heaviest node of the other body, and the nodes the rows use along its curve
    // in the pairs' direction (so that the first and last are at Γc's ends).
    let nearest: Vec<usize> = coupling
        .rows
        .iter()
        .map(|row| {
            row.iter()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .map_or(chains[other][0], |&(k, _)| k)
        })
        .collect();
    let at = |n: usize| {
        chains[other]
            .iter()
            .position(|&x| x == n)
            .expect("on the curve")
    };
    let used: BTreeSet<usize> = coupling
        .rows
        .iter()
        .flat_map(|row| row.iter().map(|&(k, _)| at(k)))
        .collect();
    let mut side_o: Vec<usize> = used.into_iter().map(|i| chains[other][i]).collect();
    if at(nearest[0]) > at(nearest[m - 1]) {
        side_o.reverse();
    }
    let side_points = points_s[first..first + m].to_vec();
    // (a closed side covered all round: Γc closes from its last pair to its first)
    if ends[side] == Ends::Closed && m + 1 == points_s.len() {
        let (a, b) = (points_s[m - 1], points_s[m]);
        coupling.closing = Some((b[0] - a[0]).hypot(b[1] - a[1]));
    }
    // (the other body's outward normals must oppose the side's)
    let outward_o = facing(
        contact,
        &bodies[other],
        &chains[other],
        &side_points,
        &nearest,
        &coupling.normals,
        po,
    )?;
    if side == 1 {
        // The pairs' direction is body 1's outward one.
        for n in &mut coupling.normals {
            *n = [-n[0], -n[1]];
        }
    }
    let mut sides = [Vec::new(), Vec::new()];
    let mut near = [Vec::new(), Vec::new()];
    let mut candidates = [Vec::new(), Vec::new()];
    let mut candidate_normals = [Vec::new(), Vec::new()];
    (sides[side], sides[other]) = (coupling.nodes.clone(), side_o);
    (near[side], near[other]) = (coupling.nodes.clone(), nearest);
    (candidates[side], candidates[other]) = (chain_s, chains[other].clone());
    (candidate_normals[side], candidate_normals[other]) = (outward, outward_o);
    let pairing = Pairing {
        sides,
        nearest: near,
        candidates,
        candidate_normals,
        gap: coupling.gap.clone(),
        normals: coupling.normals.clone(),
        lengths: super::segment_lengths(&side_points),
    };
    Ok((pairing, coupling, side))
}
