//! The estimates of a mortar run (docs/method.md §7, "The estimates"). Its iterate lives on the
//! user's meshes, coupled by the mortar operators; the admissible pair of η^glo lives on the
//! matched meshes of [`crate::problem::ProblemSettings::for_estimates`] (each curve's nodes
//! inserted into the other, nothing moved), whose continuous problem is §6's on the user's
//! polygons. [`MortarEstimates::carry`] takes the iterate there:
//! - u^α_p exactly (P1 on the user's mesh is P1 on the matched one), then û² = u²_p + δ_n: the
//!   mortar constraint holds in the mean over each non-mortar segment, not at every pair, so
//!   the nodes of a pair with a negative gap G_k = d_k·n_k are moved apart by −G_k along n_k,
//!   shared by the bodies in inverse proportion to their nodal stiffness there
//!   ([`lift_shares`]; δ_n, a P1 field on the Γc nodes); η^glo then bounds ‖u − û‖ and
//!   ‖u − u_p‖ ≤ ‖u − û‖ + ‖δ_n‖_E, so ‖δ_n‖_E is added to it;
//! - the Γc forces T^α of each body as the target of the admissible traction: the consistent
//!   P1 density of the mortar forces along the non-mortar chain, at the matched pairs (body
//!   1's η^FE re-solves with its own, [`crate::estimate::iteration::Reaction::Resolved`]).
//!
//! η^NNDD is the mortar-discrete one ([`MortarEstimates::nndd_maps`]): with the mortar
//! operators, so that it vanishes at the mortar problem's solution.

use std::collections::{BTreeSet, HashMap};
use std::rc::Rc;

use super::cre::energy;
use super::error::EstimateError;
use super::traction::Interface;
use crate::dd::body::{Body, FieldAt, GcForces};
use crate::dd::displacement::Displacement;
use crate::dd::nndd::Iterate;
use crate::fem::mesh::element_u32;
use crate::fem::wire::{Reader, Writer};
use crate::fem::{element_dofs, element_stiffness};
use crate::parallel::layout::{block_of, Layout};
use crate::problem::transfer::{place, Transfer};
use crate::problem::{pair_side, BodyProblem};

/// What a mortar run's estimates keep: the matched problems' bodies and the maps onto them.
pub struct MortarEstimates {
    /// The run's own problems (mortar).
    pub problems: [Rc<BodyProblem>; 2],
    /// The matched problems' bodies (factored, on the same groups as the run's).
    pub bodies: [Option<Body>; 2],
    maps: MortarMaps,
    /// The mortar problem's Γc (the non-mortar chain's pairs).
    chain: Interface,
}

/// The maps between a mortar run's meshes and its estimates' matched ones, made from the whole
/// meshes ([`MortarMaps::new`]) and held whole or as the part a rank reads
/// ([`MortarMaps::part`]: world rank 0 sends each rank its part under `-nndd_mesh_input root`).
#[derive(Clone, Debug)]
pub struct MortarMaps {
    transfers: [Transfer; 2],
    /// The non-mortar (pair) side: 0 or 1.
    side: usize,
    /// Each matched pair's place on the non-mortar chain: (segment k, fraction t).
    places: Vec<(usize, f64)>,
    /// The matched pair of each non-mortar pair (its node is one of the matched side's).
    matched_pair: Vec<Option<usize>>,
    /// What the lift δ_n reads of each body's matched mesh at Γc ([`LiftData`]).
    lift: [LiftData; 2],
}

/// What the lift δ_n reads of a body's matched mesh, all of it at Γc's nodes
/// ([`lift_shares`], [`lift_energy`]).
#[derive(Clone, Debug, Default)]
struct LiftData {
    /// a_k = nᵀK_kk n at each pair's node: its stiffness along the pair's normal.
    stiffness: Vec<f64>,
    /// Whether the pair's node has a displacement component along its normal prescribed.
    held: Vec<bool>,
    /// The elements with a vertex on Γc: (element, each vertex's pair, its stiffness).
    elements: Vec<LiftElement>,
}

/// An element with a vertex on Γc ([`LiftData`]).
type LiftElement = (usize, [Option<usize>; 3], [[f64; 6]; 6]);

/// A mortar iterate on the matched meshes.
pub struct Carried {
    /// The iterate with û² = u²_p + δ_n (its trace and gaps with it).
    pub iterate: Iterate,
    /// u^α_p on the matched meshes, without δ_n (for e_ref).
    pub u_plain: [Displacement; 2],
    /// ‖δ_n‖²_E on the elements of each body's matched mesh that it moves (element, value):
    /// those at Γc's nodes (zero on the others).
    pub lift_elements: [Vec<(usize, f64)>; 2],
}

impl MortarMaps {
    /// The maps between the run's `problems` and the `matched` ones, both whole.
    pub fn new(
        problems: &[Rc<BodyProblem>; 2],
        matched: &[Rc<BodyProblem>; 2],
    ) -> Result<MortarMaps, crate::problem::meshed::MeshedError> {
        let side = pair_side([&problems[0], &problems[1]]);
        let transfers = [
            Transfer::new(&problems[0], &matched[0])?,
            Transfer::new(&problems[1], &matched[1])?,
        ];
        let nm = &problems[side];
        let pts: Vec<[f64; 2]> = nm
            .contact_nodes
            .iter()
            .map(|&n| nm.mesh().points.get(n))
            .collect();
        let ms = &matched[side];
        let places = ms
            .contact_nodes
            .iter()
            .map(|&n| place(&pts, ms.mesh().points.get(n)))
            .collect();
        let fine_of = transfers[side].fine_node_of();
        let index: HashMap<usize, usize> = ms
            .contact_nodes
            .iter()
            .enumerate()
            .map(|(i, &n)| (n, i))
            .collect();
        let matched_pair = nm
            .contact_nodes
            .iter()
            .map(|n| fine_of.get(n).and_then(|f| index.get(f).copied()))
            .collect();
        Ok(MortarMaps {
            transfers,
            side,
            places,
            matched_pair,
            lift: [0, 1].map(|k| LiftData::new(&matched[k])),
        })
    }

    /// The part world rank `rank` of body α's group (α = `alpha`, the group's ranks `ranks`)
    /// reads of these whole maps, `matched` the whole matched problems: its body's transfer at
    /// the matched nodes its fields are kept at (its block of them, Γc and the outline,
    /// `Body::keep_fields_at`) and its block of the matched elements, whose maps it sums onto
    /// their parents (whole on a group of one rank); the other body's, none.
    pub fn part(
        &self,
        matched: &[Rc<BodyProblem>; 2],
        (rank, alpha): (usize, usize),
        ranks: std::ops::Range<usize>,
    ) -> MortarMaps {
        let transfers = [0, 1].map(|k| {
            let whole = &self.transfers[k];
            if k + 1 != alpha {
                return whole.restricted(&[], &[]);
            }
            if ranks.len() == 1 {
                return whole.clone();
            }
            let p = &matched[k];
            let block = |n| block_of(n, rank - ranks.start, ranks.len());
            let mut nodes: Vec<u32> = (block(p.num_nodes()).chain(p.contact_nodes.iter().copied()))
                .chain(p.outline().nodes().iter().copied())
                .map(element_u32)
                .collect();
            nodes.sort_unstable();
            nodes.dedup();
            let elements: Vec<u32> = block(p.num_elements()).map(element_u32).collect();
            whole.restricted(&nodes, &elements)
        });
        MortarMaps {
            transfers,
            ..self.clone()
        }
    }

    /// The maps as bytes ([`MortarMaps::read`] reads them back).
    pub fn write(&self, w: &mut Writer) {
        self.transfers.iter().for_each(|t| t.write(w));
        w.int(self.side);
        w.list(&self.places, |w, &(k, t)| {
            w.int(k);
            w.f64(t);
        });
        w.list(&self.matched_pair, |w, i| w.int(i.map_or(0, |i| i + 1)));
        self.lift.iter().for_each(|l| l.write(w));
    }

    /// What [`MortarMaps::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<MortarMaps> {
        let transfers = [Transfer::read(r)?, Transfer::read(r)?];
        let side = r.int().filter(|&s| s < 2)?;
        let places = r.list(16, |r| Some((r.int()?, r.f64()?)))?;
        let matched_pair = r.list(8, |r| Some(r.int()?.checked_sub(1)))?;
        let lift = [LiftData::read(r)?, LiftData::read(r)?];
        Some(MortarMaps {
            transfers,
            side,
            places,
            matched_pair,
            lift,
        })
    }
}

impl MortarEstimates {
    /// The estimates of a mortar run: its `problems` (whole, or this rank's parts), the
    /// `maps` onto the matched ones, whose bodies `bodies` this rank owns.
    pub fn new(
        problems: [Rc<BodyProblem>; 2],
        maps: MortarMaps,
        bodies: [Option<Body>; 2],
    ) -> MortarEstimates {
        MortarEstimates {
            chain: Interface::new(problems[maps.side].contact_lengths.clone()),
            problems,
            bodies,
            maps,
        }
    }

    /// The matched bodies, as the estimator takes them.
    pub fn bodies(&self) -> [Option<&Body>; 2] {
        [self.bodies[0].as_ref(), self.bodies[1].as_ref()]
    }

    /// The run's element that element `e` of body `k`'s matched mesh lies in, and the number
    /// of the run's elements of body `k`.
    pub fn parent(&self, k: usize, e: usize) -> usize {
        self.maps.transfers[k].parent(e)
    }

    /// The number of the run's elements of body `k` (the parents of its matched mesh's).
    pub fn run_elements(&self, k: usize) -> usize {
        self.maps.transfers[k].coarse_elements()
    }

    /// A P1 density of the matched Γc at the run's pairs (0 where a pair has no matched one).
    pub fn at_pairs(&self, density: &[f64]) -> Vec<f64> {
        self.maps
            .matched_pair
            .iter()
            .map(|i| i.map_or(0.0, |i| density[i]))
            .collect()
    }

    /// The run's field `u` of body `k` (its body `run`) on the matched mesh, held where the
    /// matched body `matched` keeps its fields ([`Body::kept_nodes`]): interpolated from the
    /// run's field gathered at the nodes it reads alone ([`Transfer::stencil_nodes`];
    /// collective over the body's group).
    fn carried_field(
        &self,
        k: usize,
        run: &Body,
        matched: &Body,
        u: &Displacement,
    ) -> Result<Displacement, EstimateError> {
        let t = &self.maps.transfers[k];
        let Some(nodes) = matched.kept_nodes() else {
            let whole = match u.as_whole() {
                Some(_) => std::borrow::Cow::Borrowed(u),
                None => std::borrow::Cow::Owned(run.displacement_at(u, FieldAt::Whole)?),
            };
            return Ok(Displacement::whole(t.interpolate(whole.whole_values())));
        };
        let from = run.displacement_at(u, FieldAt::Nodes(&t.stencil_nodes(&nodes)))?;
        let values = t.interpolate_at(&from, &nodes);
        Ok(Displacement::at_nodes(nodes, values))
    }

    /// The mortar iterate `it` of the run's bodies `run` on the `matched` problems (module
    /// docs), held as the matched bodies keep their fields; collective over all ranks.
    pub fn carry(
        &self,
        layout: &Layout,
        run: [Option<&Body>; 2],
        matched: &[Rc<BodyProblem>; 2],
        iface: &Interface,
        it: &Iterate,
    ) -> Result<Carried, EstimateError> {
        let mut u_plain: [Displacement; 2] = Default::default();
        for k in 0..2 {
            if let (Some(r), Some(b), false) = (run[k], &self.bodies[k], it.u[k].is_empty()) {
                u_plain[k] = self.carried_field(k, r, b, &it.u[k])?;
            }
        }
        let m = matched[0].pairs();
        // Each body's displacement at the pairs, from its first rank.
        let mut at = vec![0.0; 4 * m];
        for (k, body) in self.bodies.iter().enumerate() {
            if body.as_ref().is_some_and(|b| b.is_root()) {
                for (i, &n) in matched[k].contact_nodes.iter().enumerate() {
                    at[4 * i + 2 * k] = u_plain[k][2 * n];
                    at[4 * i + 2 * k + 1] = u_plain[k][2 * n + 1];
                }
            }
        }
        layout.world_sum(&mut at);
        let normals = &matched[0].contact_normals;
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        let u1 = |i: usize| [at[4 * i], at[4 * i + 1]];
        let u2 = |i: usize| [at[4 * i + 2], at[4 * i + 3]];
        let lambda: Vec<f64> = (0..m).map(|i| dot(normals[i], u1(i))).collect();
        let gap = |i: usize| matched[0].gap[i] + dot(normals[i], u2(i)) - lambda[i];
        let lift: Vec<f64> = (0..m).map(|i| (-gap(i)).max(0.0)).collect();
        let shares = lift_shares(&self.maps.lift, &lift);
        let lambda: Vec<f64> = (0..m).map(|i| lambda[i] - shares[0][i]).collect();
        let trace2: Vec<f64> = (0..m)
            .map(|i| dot(normals[i], u2(i)) + shares[1][i])
            .collect();
        let mut u = u_plain.clone();
        for (k, uk) in u.iter_mut().enumerate().filter(|(_, uk)| !uk.is_empty()) {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            for (i, &n) in matched[k].contact_nodes.iter().enumerate() {
                uk[2 * n] += sign * shares[k][i] * normals[i][0];
                uk[2 * n + 1] += sign * shares[k][i] * normals[i][1];
            }
        }
        let forces = [0, 1].map(|a| {
            let s = self.chain.density(&it.forces[a]);
            let v: Vec<f64> = (self.maps.places)
                .iter()
                .map(|&(k, t)| match s.get(k + 1) {
                    Some(next) => (1.0 - t) * s[k] + t * next,
                    None => s.get(k).copied().unwrap_or(0.0),
                })
                .collect();
            iface.forces(&v)
        });
        let active = forces[1].iter().map(|&f| f > 0.0).collect();
        let iterate = Iterate {
            interface: lambda.clone(),
            lambda,
            u,
            forces,
            contact_body: it.contact_body,
            trace2,
            active,
            qp_kkt: it.qp_kkt,
            iteration: it.iteration,
            friction_bounds: Vec::new(),
            tangential: None,
        };
        Ok(Carried {
            iterate,
            u_plain,
            lift_elements: [0, 1].map(|k| lift_energy(&self.maps.lift[k], &matched[k], &shares[k])),
        })
    }

    /// The mortar-discrete η^NNDD, element by element (squares) on each body's ranks, and its
    /// total (on every rank): with μ̂ the iterate's nodal contact forces `mu_hat`, the Neumann
    /// re-solves ũ^α_d with Γc forces ∓μ̂ on the run's bodies (the mortar operators), the
    /// element energies of ũ^α_d − u^α_p, plus 2 μ̂_j |u²_n − λ + g₀|_j on the non-mortar side's
    /// Γc elements (half to each segment at a pair): node to node the contact step makes that
    /// gap exactly zero where μ̂ > 0, under the mortar operators only to the contact step's
    /// tolerance, of either sign (the absolute value keeps η^NNDD ≥ 0; it still vanishes at
    /// the solution). Each rank of a body's group computes its block of the body's elements
    /// ([`Layout::block`]), the fields gathered at their nodes alone. Collective over all
    /// ranks.
    pub fn nndd_maps(
        &self,
        layout: &Layout,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
        mu_hat: &[f64],
    ) -> Result<([Vec<f64>; 2], f64), EstimateError> {
        let mut maps: [Vec<f64>; 2] = Default::default();
        let mut total = 0.0;
        for (k, body) in bodies.iter().enumerate() {
            let Some(b) = body else { continue };
            let p = &self.problems[k];
            let mesh = p.mesh();
            let block = layout.block(k + 1, p.num_elements());
            let sign = if k == 0 { 1.0 } else { -1.0 };
            let f: Vec<f64> = mu_hat.iter().map(|m| -sign * m).collect();
            let mut nodes: Vec<usize> = block.clone().flat_map(|e| mesh.triangles.get(e)).collect();
            nodes.sort_unstable();
            nodes.dedup();
            let at = FieldAt::Nodes(&nodes);
            // (the re-solve gathered from its rows' owners at the block's nodes alone)
            let solved = b.neumann_solve_many(&[GcForces::Normal(f)])?;
            let u_d = b.fields_at(solved, at)?.pop().expect("ũ_d");
            let u_d = Displacement::at_nodes(nodes.iter().map(|&n| n as u32).collect(), u_d);
            let u_p = b.displacement_at(&it.u[k], at)?;
            let mut map: Vec<f64> = (block.clone())
                .map(|e| {
                    let ke = element_stiffness(&mesh.triangle_points(e), &p.material);
                    let dofs = element_dofs(&mesh.triangles.get(e));
                    let d: [f64; 6] = std::array::from_fn(|r| u_d[dofs[r]] - u_p[dofs[r]]);
                    energy(&ke, &d)
                })
                .collect();
            if k == self.maps.side {
                let obstacle = p.obstacle(&it.lambda);
                let nodes = &p.contact_nodes;
                let elements = mesh.chain_elements(nodes);
                let m = nodes.len();
                for i in 0..m {
                    let term = 2.0 * mu_hat[i] * (it.trace2[i] - obstacle[i]).abs();
                    let segs: Vec<usize> = [i.checked_sub(1), (i + 1 < m).then_some(i)]
                        .into_iter()
                        .flatten()
                        .collect();
                    for &s in &segs {
                        if let Some(e) = elements[s].filter(|e| block.contains(e)) {
                            map[e - block.start] += term / segs.len() as f64;
                        }
                    }
                }
            }
            total += map.iter().sum::<f64>();
            maps[k] = map;
        }
        Ok((maps, layout.sum(total)))
    }
}

/// The lift −G_k > 0 of each pair shared by the bodies: body α's part ∝ 1/a^α_k, a^α_k =
/// nᵀK^α_kk n its nodal stiffness along the normal (the split that minimises Σ_α a^α x_α²
/// with x₁ + x₂ = −G_k: the least energy, up to the nodes' coupling); all of it on the other
/// body where one's node has a displacement component along n prescribed (û keeps Γ_D's
/// values; where both have, the data fix the pair and nothing is moved). `data`: each body's
/// [`LiftData`].
fn lift_shares(data: &[LiftData; 2], lift: &[f64]) -> [Vec<f64>; 2] {
    let m = lift.len();
    let part = |k: usize| -> Vec<f64> {
        (0..m)
            .map(|i| {
                if lift[i] == 0.0 || data[k].held[i] {
                    return 0.0;
                }
                if data[1 - k].held[i] {
                    return lift[i];
                }
                let (a, b) = (data[k].stiffness[i], data[1 - k].stiffness[i]);
                lift[i] * b / (a + b)
            })
            .collect()
    };
    [part(0), part(1)]
}

impl LiftData {
    /// What the lift reads of the (whole) matched problem `p`.
    fn new(p: &BodyProblem) -> LiftData {
        let m = p.contact_nodes.len();
        let at: HashMap<usize, usize> = (p.contact_nodes.iter().enumerate())
            .map(|(i, &n)| (n, i))
            .collect();
        let mut stiffness = vec![0.0; m];
        let mut elements = Vec::new();
        let mesh = p.mesh();
        for e in 0..p.num_elements() {
            let t = mesh.triangles.get(e);
            let pairs = t.map(|n| at.get(&n).copied());
            if pairs.iter().all(Option::is_none) {
                continue;
            }
            let ke = element_stiffness(&mesh.triangle_points(e), &p.material);
            for (j, i) in pairs.iter().enumerate() {
                if let Some(&i) = i.as_ref() {
                    let v = p.contact_normals[i];
                    stiffness[i] += (0..2)
                        .map(|r| {
                            v[r] * (0..2).map(|c| ke[2 * j + r][2 * j + c] * v[c]).sum::<f64>()
                        })
                        .sum::<f64>();
                }
            }
            elements.push((e, pairs, ke));
        }
        let fixed: BTreeSet<usize> = p.dirichlet.iter().map(|&(dof, _)| dof).collect();
        let held = (p.contact_nodes.iter().zip(&p.contact_normals))
            .map(|(&n, normal)| (0..2).any(|c| normal[c] != 0.0 && fixed.contains(&(2 * n + c))))
            .collect();
        LiftData {
            stiffness,
            held,
            elements,
        }
    }

    fn write(&self, w: &mut Writer) {
        w.f64s(&self.stiffness);
        w.list(&self.held, |w, &h| w.u8(h as u8));
        w.list(&self.elements, |w, (e, pairs, ke)| {
            w.int(*e);
            pairs.iter().for_each(|i| w.int(i.map_or(0, |i| i + 1)));
            ke.iter().for_each(|row| row.iter().for_each(|&v| w.f64(v)));
        });
    }

    fn read(r: &mut Reader) -> Option<LiftData> {
        let stiffness = r.f64s()?;
        let held = r.list(1, |r| Some(r.u8()? != 0))?;
        let elements = r.list(8 * 40, |r| {
            let e = r.int()?;
            let mut pairs = [None; 3];
            for p in pairs.iter_mut() {
                *p = r.int()?.checked_sub(1);
            }
            let mut ke = [[0.0; 6]; 6];
            for v in ke.iter_mut().flatten() {
                *v = r.f64()?;
            }
            Some((e, pairs, ke))
        })?;
        (held.len() == stiffness.len()).then_some(LiftData {
            stiffness,
            held,
            elements,
        })
    }
}

/// ‖δ_n‖²_E on the elements of the lift `lift` (along the pairs' normals of the matched
/// problem `p`, `data` its [`LiftData`]) at a body's matched Γc nodes that it moves:
/// (element, value).
fn lift_energy(data: &LiftData, p: &BodyProblem, lift: &[f64]) -> Vec<(usize, f64)> {
    let delta = |i: Option<usize>, c: usize| {
        i.filter(|&i| lift[i] != 0.0)
            .map_or(0.0, |i| lift[i] * p.contact_normals[i][c])
    };
    (data.elements.iter())
        .filter(|(_, pairs, _)| pairs.iter().any(|i| i.is_some_and(|i| lift[i] != 0.0)))
        .map(|(e, pairs, ke)| {
            let d: [f64; 6] = std::array::from_fn(|r| delta(pairs[r / 2], r % 2));
            (*e, energy(ke, &d))
        })
        .collect()
}
