//! The construction itself, [`equilibrate_restricted`]: σ̂ on a mesh or on an overlapping
//! sub-mesh, phase by phase (method.md §3.2, the module documentation of `equilibrate`):
//! the FE stresses and element nodal forces, (a) the star problems (the EET edge moments),
//! (b) the edge tractions and the Johnson–Mercier operators (with the averaged-traction
//! fields of the recoveries that update them), the lowering of the energy ([`Recovery`]: the
//! star minimisation, the patch sweeps on the fields or planned on the edge tractions), and
//! (c) the final pass that builds every element's field from its edge tractions.

use super::boundary::Boundary;
use super::cache::OperatorCache;
use super::eet::{
    edge_conditions, edge_tractions, known_moment, Bc, EdgeConditions, StarSystem, Stars,
};
use super::energy::{compliance, total_energy, EnergyContext};
use super::error::EquilibrationError;
use super::johnson_mercier::{jm_fields, traction, ShapeCache};
use super::plan::{Plan, Warm};
use super::recovery::Recovery;
use super::relaxation::Relaxation;
use super::restriction::Restriction;
use super::sizes::{capacities, NC, NONE};
use super::stress::{EquilibratedStress, EquilibrationStats, FinalPass, Residuals};
use super::topology::{is_owned, owned_vertices, sweep_key, vertex_colours, Topology};
use crate::fem::geometry::local_frame;
use crate::fem::mesh::Mesh;
use crate::fem::{self, Material};

/// The receiver of every element's field (element, its 27 JM coefficients).
pub type FieldVisitor<'a> = &'a mut dyn FnMut(usize, &[f64; NC]);

/// Per edge, end and component: edge moments or edge-traction values (oriented to the plus
/// element).
type EdgeValues = Vec<[[f64; 2]; 2]>;

/// Build σ̂ on a mesh or, with a [`Restriction`], on an overlapping sub-mesh of a larger
/// mesh (`overlap::Overlap`: `u` and `boundary` restricted to it).
///
/// Without restriction: the sweep keys are [`sweep_key`] of [`vertex_colours`]`(mesh)` and the
/// vertex index, and every element is owned. With a restriction, σ̂ equals the full-mesh
/// field (to round-off) on every owned element whose neighbourhood of
/// `Overlap::rings_for(recovery, colours)` rings is in the sub-mesh; elsewhere it is
/// meaningless (the artificial boundary of the sub-mesh is treated as traction free). The
/// statistics `fe_equilibrium`, `energy_averaged` and `energy_final` are then measured on
/// the owned elements only (the energies sum over the ranks to the full-mesh ones); the
/// other counts are those of the sub-mesh. A recovery that is not local (`Recovery::Star`, a
/// global solve) is refused with a restriction
/// ([`EquilibrationError::RestrictedMinimumEnergy`]).
///
/// With `visit`, every element's field (its 27 JM coefficients) is handed to it once, in
/// element order, and not stored (the returned stress then has no coefficients: it gives
/// the statistics, the reactions and the construction's equilibrium check only).
#[allow(clippy::too_many_arguments)]
pub fn equilibrate_restricted(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
    recovery: Recovery,
    restriction: Option<&Restriction>,
    operators: Option<&mut OperatorCache>,
    visit: Option<FieldVisitor>,
) -> Result<EquilibratedStress, EquilibrationError> {
    // The local operators: the caller's (kept across calls) or this call's own.
    let mut own = OperatorCache::default();
    let operators = operators.unwrap_or(&mut own).for_material(material);
    check_input(mesh, u, boundary, recovery, restriction)?;
    // The mesh: its topology and edge conditions.
    let r = Recovering::new(mesh, material, boundary, recovery, restriction, operators)?;
    // The FE side: stresses σ̃_h, element nodal forces R_E and their scale.
    let fe = r.fe_forces(u);
    // (a) The star problems: the EET edge moments closest to the averaged FE tractions.
    let edge_ref = r.reference_tractions(&fe.sig);
    let stars = r.star_structure(operators);
    let star = r.star_problems(&stars, fe.force, edge_ref, &boundary.constrained, fe.scale);
    // (b) The edge tractions F̂ and the JM operators, the averaged-traction fields.
    let (mut cache, mut field, moments) = r.jm_operators(operators, fe.sig, star.moments)?;
    let energy_averaged = r.averaged_fields(&mut cache, &mut field);
    // The lowering of the energy: the star minimisation, the patch sweeps.
    let params = star.parameters;
    let cg_iterations = r.minimise_star_energy(&mut cache, &stars, moments, params, &mut field);
    let patch_patterns = r.relax_patches(operators, &mut cache, &mut field);
    // (c) The final pass: every element's field from its edge tractions, checked.
    let (coef, energy, mut checked) = r.final_pass(&mut cache, field, visit);
    checked.point_reaction = r.owned_reaction(&star.reactions);
    let stats = EquilibrationStats {
        star_parameters: star.parameters,
        shapes: cache.ops.len(),
        cg_iterations,
        // `Eet`: the final field is the averaged-traction one.
        energy_averaged: if recovery.ends_at_averaged() {
            energy
        } else {
            energy_averaged
        },
        energy_final: energy,
        patch_patterns,
        fe_equilibrium: star.fe_equilibrium,
    };
    r.keep(operators, cache, stars);
    Ok(EquilibratedStress {
        coef,
        reactions: star.reactions,
        stats,
        checked,
    })
}

/// Build σ̂ with the averaged-traction star choice (method.md §3.2 (a), (b)).
///
/// `u` is the FE-equilibrated displacement (length `mesh.num_dofs()`).
pub fn equilibrate(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
) -> Result<EquilibratedStress, EquilibrationError> {
    equilibrate_with(mesh, material, u, boundary, Recovery::Eet)
}

/// Build σ̂ with a given choice of the star free parameters (on the whole mesh).
pub fn equilibrate_with(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
    recovery: Recovery,
) -> Result<EquilibratedStress, EquilibrationError> {
    equilibrate_restricted(mesh, material, u, boundary, recovery, None, None, None)
}

/// The input checked: the displacement's and the constraints' lengths, and with a restriction
/// its lengths and a local recovery.
fn check_input(
    mesh: &Mesh,
    u: &[f64],
    boundary: &Boundary,
    recovery: Recovery,
    restriction: Option<&Restriction>,
) -> Result<(), EquilibrationError> {
    let ndof = mesh.num_dofs();
    let nt = mesh.triangles.len();
    let nn = mesh.num_nodes();
    use EquilibrationError as Error;
    check_len(u.len(), ndof, |expected, found| Error::DisplacementLength {
        expected,
        found,
    })?;
    let found = boundary.constrained.len();
    check_len(found, ndof, |expected, found| Error::ConstrainedLength {
        expected,
        found,
    })?;
    if let Some(r) = restriction {
        if !recovery.is_local() {
            return Err(Error::RestrictedMinimumEnergy);
        }
        for (what, len, expected) in [
            ("vertex_key", r.vertex_key.len(), nn),
            ("owned", r.owned.len(), nt),
        ] {
            check_len(len, expected, |expected, found| Error::RestrictionLength {
                what,
                expected,
                found,
            })?;
        }
    }
    Ok(())
}

/// Err(error(expected, found)) if the lengths differ.
fn check_len(
    found: usize,
    expected: usize,
    error: impl FnOnce(usize, usize) -> EquilibrationError,
) -> Result<(), EquilibrationError> {
    if found == expected {
        Ok(())
    } else {
        Err(error(expected, found))
    }
}

/// A recovery under way: what every phase reads (the mesh, its topology and edge
/// conditions, the recovery, the restriction's owned elements).
struct Recovering<'a> {
    mesh: &'a Mesh,
    material: &'a Material,
    recovery: Recovery,
    restriction: Option<&'a Restriction<'a>>,
    /// Per element: owned (its result kept); none without restriction (all are).
    owned: Option<&'a [bool]>,
    /// Per vertex: a vertex of an owned element; none without restriction (all are).
    vertex_owned: Option<Vec<bool>>,
    mesh_fingerprint: u64,
    topo: Topology,
    bc: EdgeConditions,
    /// Of the mesh, the boundary codes and the sweep keys: the star structure and the plan
    /// are kept for it (`plan::fingerprint`).
    fingerprint: u64,
}

/// The FE stresses σ̃_h = K ε(ũ) and the element nodal forces R_E = ∫_E σ̃ : ε(φ_a e_k) per
/// element, and the force scale of the relative FE-equilibrium defect and point reactions.
struct FeForces {
    sig: Vec<[f64; 3]>,
    force: Vec<[f64; 6]>,
    scale: f64,
}

/// The solution of the star problems.
struct StarSolution {
    /// Per edge, end and component: the edge moments b (unknown components only).
    moments: EdgeValues,
    /// Per constrained star (vertex, relative least-squares residual): the point reactions.
    reactions: Vec<(usize, f64)>,
    /// The largest relative residual at the unconstrained owned dofs.
    fe_equilibrium: f64,
    /// Number of star free parameters (null-space directions of the star problems).
    parameters: usize,
}

/// The recovered field as the phases leave it.
struct Field {
    /// σ̃_h per element (the FE side of the complementary energy).
    sig: Vec<[f64; 3]>,
    /// The edge tractions F̂.
    trac: EdgeValues,
    /// Per element: its Johnson–Mercier operator in the shape cache.
    shape_of: Vec<usize>,
    /// The JM coefficients, kept up to date by the recoveries that update the fields
    /// ([`Recovery::updates_fields`]); empty for the others.
    coef: Vec<[f64; NC]>,
}

impl<'a> Recovering<'a> {
    /// The topology of the mesh (kept in the cache from the previous recovery, or built) and
    /// its edge conditions.
    fn new(
        mesh: &'a Mesh,
        material: &'a Material,
        boundary: &Boundary,
        recovery: Recovery,
        restriction: Option<&'a Restriction<'a>>,
        operators: &mut OperatorCache,
    ) -> Result<Recovering<'a>, EquilibrationError> {
        let owned = restriction.map(|r| r.owned);
        let vertex_owned = owned_vertices(mesh, owned);
        let mesh_fingerprint = mesh.fingerprint();
        let topo = match operators.topology.take() {
            Some((fp, t)) if fp == mesh_fingerprint => t,
            _ => Topology::new(mesh)?,
        };
        let bc = edge_conditions(&topo, boundary)?;
        let fingerprint =
            super::plan::fingerprint(mesh_fingerprint, &bc, restriction.map(|r| r.vertex_key));
        Ok(Recovering {
            mesh,
            material,
            recovery,
            restriction,
            owned,
            vertex_owned,
            mesh_fingerprint,
            topo,
            bc,
            fingerprint,
        })
    }

    /// FE stresses and element nodal forces R_E = ∫_E σ̃ : ε(φ_a e_k); the force scale (of
    /// the relative FE-equilibrium defect and point reactions) over the owned elements: their
    /// largest nodal force or known edge moment.
    fn fe_forces(&self, u: &[f64]) -> FeForces {
        let (mesh, topo, owned) = (self.mesh, &self.topo, self.owned);
        let nt = mesh.triangles.len();
        let d = self.material.hooke();
        let mut sig = vec![[0.0; 3]; nt];
        let mut force = vec![[0.0; 6]; nt];
        let mut force_scale: f64 = 0.0;
        for e in 0..nt {
            let (b, area) = fem::strain_displacement(&mesh.triangle_points(e));
            let dofs = fem::element_dofs(&mesh.triangles.get(e));
            let mut eps = [0.0; 3];
            for r in 0..3 {
                eps[r] = (0..6).map(|c| b[r][c] * u[dofs[c]]).sum();
            }
            let s: [f64; 3] = [0, 1, 2].map(|r| (0..3).map(|k| d[r][k] * eps[k]).sum());
            for c in 0..6 {
                force[e][c] = area * (0..3).map(|r| b[r][c] * s[r]).sum::<f64>();
            }
            if is_owned(owned, e) {
                force_scale = force_scale.max(force[e].iter().fold(0.0, |m, f| m.max(f.abs())));
            }
            sig[e] = s;
        }
        // Known moments (for the force scale).
        for g in (0..topo.num_edges()).filter(|&g| is_owned(owned, topo.elems(g)[0])) {
            for k in 0..2 {
                if let Bc::Known(v) = self.bc[g][k] {
                    for end in 0..2 {
                        let moment = known_moment(topo.edge_len[g], v, end);
                        force_scale = force_scale.max(moment.abs());
                    }
                }
            }
        }
        let scale = if force_scale > 0.0 { force_scale } else { 1.0 };
        FeForces { sig, force, scale }
    }

    /// The reference tractions of the star least squares, per edge (oriented to the plus
    /// element): the averaged FE traction ½(σ̃_E + σ̃_E') n, σ̃_E n on the boundary (method.md
    /// §3.2 (a)).
    fn reference_tractions(&self, sig: &[[f64; 3]]) -> Vec<[f64; 2]> {
        let topo = &self.topo;
        let mut edge_ref = vec![[0.0; 2]; topo.num_edges()];
        for g in 0..topo.num_edges() {
            let n = topo.normal(self.mesh, g);
            let [e0, e1] = topo.elems(g);
            let mut s = sig[e0];
            if e1 != NONE {
                for r in 0..3 {
                    s[r] = 0.5 * (s[r] + sig[e1][r]);
                }
            }
            edge_ref[g] = traction(&s, n);
        }
        edge_ref
    }

    /// The star problems' structure: kept in the cache for this mesh, these boundary codes
    /// and sweep keys, or built.
    fn star_structure(&self, operators: &mut OperatorCache) -> Stars {
        match operators.stars.take() {
            Some(s) if s.fingerprint == self.fingerprint => s,
            _ => Stars::new(&self.topo, &self.bc, self.fingerprint),
        }
    }

    /// (a) The star problems (method.md §3.2 (a)): for every vertex i and direction k, the
    /// edge moments b closest to the reference moments b̄ (of `edge_ref`) among the
    /// solutions of A b = Q, b = b̄ + A⁺ (Q − A b̄); the residual is the point reaction at a
    /// constrained dof, the FE-equilibrium defect elsewhere (relative to `scale`). The nodal
    /// forces and the reference tractions are dropped after them.
    fn star_problems(
        &self,
        stars: &Stars,
        force: Vec<[f64; 6]>,
        edge_ref: Vec<[f64; 2]>,
        constrained: &[bool],
        scale: f64,
    ) -> StarSolution {
        let topo = &self.topo;
        let nn = self.mesh.num_nodes();
        let mut sol = StarSolution {
            moments: vec![[[0.0; 2]; 2]; topo.num_edges()], // unknown components only
            reactions: Vec::new(),
            fe_equilibrium: 0.0,
            parameters: 0,
        };
        let mut system = StarSystem::default();
        for s in 0..2 * nn {
            let (i, k) = (s / 2, s % 2);
            system.assemble(topo, &self.bc, stars, &force, s);
            let worst = system.solve(topo, stars, &edge_ref, s);
            for (c, &g) in stars.cols(s).iter().enumerate() {
                sol.moments[g as usize][topo.end_of(g as usize, i)][k] = system.b[c];
            }
            if constrained[2 * i + k] {
                sol.reactions.push((i, worst / scale));
            } else if self.vertex_owned.as_ref().is_none_or(|v| v[i]) {
                sol.fe_equilibrium = sol.fe_equilibrium.max(worst / scale);
            }
        }
        sol.parameters = (0..2 * nn).map(|s| stars.op_of(s).nnull).sum();
        drop((force, edge_ref));
        sol
    }

    /// (b) The linear edge tractions F̂ from the edge moments (the inverse edge mass matrix;
    /// prescribed data on the Known boundary components), and the Johnson–Mercier operator of
    /// every element's shape (method.md §3.2 (b)) in the shape cache, lent by the operator
    /// cache (given back on failure: a singular local problem). The field the lowering
    /// starts from (its coefficients allocated for the recoveries that update them), and the
    /// moments again for `Star` only, which moves them (else they are freed here).
    fn jm_operators(
        &self,
        operators: &mut OperatorCache,
        sig: Vec<[f64; 3]>,
        moments: EdgeValues,
    ) -> Result<(ShapeCache, Field, Option<EdgeValues>), EquilibrationError> {
        let mut cache = std::mem::take(&mut operators.shapes);
        cache.set_capacity(capacities(self.recovery).0);
        let nt = self.mesh.triangles.len();
        let mut shape_of = vec![NONE; nt];
        let coef = if self.recovery.updates_fields() {
            vec![[0.0; NC]; nt]
        } else {
            Vec::new()
        };
        let trac = edge_tractions(&self.topo, &self.bc, &moments);
        // Only `Star` moves the moments again: freed here for the others.
        let moments = self.recovery.star_minimisation().map(|_| moments);
        for e in 0..nt {
            let (_, _, qv) = local_frame(&self.mesh.triangle_points(e));
            match cache.index(&qv) {
                Some(i) => shape_of[e] = i,
                None => {
                    operators.shapes = cache;
                    return Err(EquilibrationError::SingularLocalProblem { element: e });
                }
            }
        }
        let field = Field {
            sig,
            trac,
            shape_of,
            coef,
        };
        Ok((cache, field, moments))
    }

    /// (b) The averaged-traction JM fields and their energy, of the recoveries that update
    /// the fields as they go (`PatchClassic`, `Star`); the others build fields only in the
    /// final pass (which gives the averaged energy of `Eet`; `Patch` never has it: NaN).
    fn averaged_fields(&self, cache: &mut ShapeCache, field: &mut Field) -> f64 {
        if !self.recovery.updates_fields() {
            return f64::NAN;
        }
        let mesh = self.mesh;
        jm_fields(
            mesh,
            &self.topo,
            &field.trac,
            cache,
            &field.shape_of,
            &mut field.coef,
        );
        total_energy(mesh, self.material, &field.coef, &field.sig, self.owned)
    }

    /// `Star`: the star parameters that minimise the complementary energy (Jacobi-PCG,
    /// `EnergyContext::minimise`; method.md §3.2 (a), "or better, by minimising the
    /// resulting complementary energy"), the moments moved along the star null spaces and
    /// the field rebuilt; the CG iterations (0 for the other recoveries, or without free
    /// parameters).
    fn minimise_star_energy(
        &self,
        cache: &mut ShapeCache,
        stars: &Stars,
        moments: Option<EdgeValues>,
        parameters: usize,
        field: &mut Field,
    ) -> usize {
        let (Some((max_iterations, tolerance)), Some(mut moments)) =
            (self.recovery.star_minimisation(), moments)
        else {
            return 0;
        };
        if parameters == 0 {
            return 0;
        }
        let nn = self.mesh.num_nodes();
        let topo = &self.topo;
        let ctx = EnergyContext {
            mesh: self.mesh,
            material: self.material,
            topo,
            stars,
            sig: &field.sig,
            coef: &field.coef,
            shape_of: &field.shape_of,
        };
        let (theta, its) = ctx.minimise(cache, max_iterations, tolerance);
        // Move the moments along the null-space directions and rebuild σ̂.
        let mut p = 0;
        for s in 0..2 * nn {
            let (i, k) = (s / 2, s % 2);
            let star_op = stars.op_of(s);
            let cs = stars.cols(s);
            for j in 0..star_op.nnull {
                let nu = &star_op.null[j * cs.len()..(j + 1) * cs.len()];
                for (c, &g) in cs.iter().enumerate() {
                    let g = g as usize;
                    moments[g][topo.end_of(g, i)][k] += theta[p] * nu[c];
                }
                p += 1;
            }
        }
        field.trac = edge_tractions(topo, &self.bc, &moments);
        let mesh = self.mesh;
        jm_fields(
            mesh,
            topo,
            &field.trac,
            cache,
            &field.shape_of,
            &mut field.coef,
        );
        its
    }

    /// The patch sweeps (method.md §3.2: "patch-wise minimisation of complementary energy"):
    /// on the JM fields (`PatchClassic`) or planned on the edge tractions (`Patch`), with the
    /// patch operators lent by the operator cache; the number of distinct patch patterns
    /// (0 without sweeps).
    fn relax_patches(
        &self,
        operators: &mut OperatorCache,
        cache: &mut ShapeCache,
        field: &mut Field,
    ) -> usize {
        let planned = self.recovery.planned_sweeps();
        let field_sweeps = self.recovery.field_sweeps();
        if planned.is_none() && field_sweeps == 0 {
            return 0;
        }
        let mut relax = Relaxation {
            mesh: self.mesh,
            topo: &self.topo,
            bc: &self.bc,
            sig: &field.sig,
            shape_of: &field.shape_of,
            cm: compliance(self.material),
            map: std::mem::take(&mut operators.patch_map),
            ops: std::mem::take(&mut operators.patch_ops),
            capacity: capacities(self.recovery).1,
            vertex_op: vec![NONE; self.mesh.num_nodes()],
            hhat: std::mem::take(&mut operators.hhat),
        };
        let patterns = match planned {
            Some((_, warm_sweeps)) => {
                self.sweep_planned(&mut relax, operators, cache, &mut field.trac, warm_sweeps)
            }
            None => {
                let (trac, coef) = (&mut field.trac, &mut field.coef);
                self.sweep_fields(&mut relax, cache, trac, coef, field_sweeps)
            }
        };
        operators.patch_map = relax.map;
        operators.patch_ops = relax.ops;
        operators.hhat = relax.hhat;
        patterns
    }

    /// The vertices in sweep order: by increasing sweep key (colour, then global index; the
    /// restriction's keys on a sub-mesh).
    fn sweep_order(&self) -> Vec<usize> {
        let nn = self.mesh.num_nodes();
        let full_keys: Vec<u64>;
        let keys = match self.restriction {
            Some(r) => r.vertex_key,
            None => {
                let colours = vertex_colours(self.mesh);
                full_keys = (0..nn).map(|i| sweep_key(colours[i], i)).collect();
                &full_keys
            }
        };
        let mut order: Vec<usize> = (0..nn).collect();
        order.sort_unstable_by_key(|&i| keys[i]);
        order
    }

    /// `PatchClassic`: multicolour symmetric Gauss–Seidel on the fields, vertices by
    /// increasing sweep key in the even sweeps, decreasing in the odd ones (the steps of one
    /// colour touch disjoint data, see `Relaxation::step`); the patch patterns.
    fn sweep_fields(
        &self,
        relax: &mut Relaxation,
        cache: &mut ShapeCache,
        trac: &mut [[[f64; 2]; 2]],
        coef: &mut [[f64; NC]],
        sweeps: usize,
    ) -> usize {
        let nn = self.mesh.num_nodes();
        let order = self.sweep_order();
        for sweep in 0..sweeps {
            let forward = sweep % 2 == 0;
            for v in 0..nn {
                let i = order[if forward { v } else { nn - 1 - v }];
                relax.step(cache, i, trac, coef);
            }
        }
        relax.ops.len()
    }

    /// `Patch`: the same sweeps on the edge tractions with the per-mesh plan (kept in the
    /// cache, or built: the element Hessians then freed), started warm from the change δ of
    /// the previous recovery with this cache if it applies here (`warm_sweeps` sweeps), else
    /// cold; the sweeps' changes added to δ (from zero when cold) for the next one. The
    /// restriction's exchange runs between two sweeps. The plan's patch patterns.
    fn sweep_planned(
        &self,
        relax: &mut Relaxation,
        operators: &mut OperatorCache,
        cache: &mut ShapeCache,
        trac: &mut [[[f64; 2]; 2]],
        warm_sweeps: usize,
    ) -> usize {
        let fp = self.fingerprint;
        let plan = match operators.plan.take() {
            Some(p) if p.fingerprint() == fp => p,
            _ => {
                // (the operators past the cache's patterns were the old plan's alone)
                relax.ops.truncate(relax.capacity);
                let plan = Plan::new(relax, cache, &self.sweep_order(), fp);
                // The element Hessians only build patch operators, and the plan's are all
                // built: on unstructured meshes (a Hessian per element) they were 1152 bytes
                // per element for nothing.
                relax.hhat = Default::default();
                plan
            }
        };
        let a = plan.loads(
            self.mesh,
            cache,
            relax.shape_of,
            relax.sig,
            &relax.cm,
            &relax.ops,
        );
        let flat = trac.as_flattened_mut().as_flattened_mut();
        let mut warm = operators
            .warm
            .take()
            .filter(|w| warm_sweeps > 0 && w.apply(fp, flat));
        let sweeps = self.recovery.sweeps_made(warm.is_some());
        if warm_sweeps > 0 && warm.is_none() {
            warm = Some(Warm::zero(fp, flat.len()));
        }
        let change = warm.as_mut().map_or(&mut [][..], |w| w.delta_mut());
        let between = self.restriction.and_then(|r| r.between_sweeps);
        plan.sweep(&self.topo, &relax.ops, &a, flat, change, sweeps, between);
        if warm_sweeps > 0 {
            operators.warm = warm;
        }
        let patterns = plan.patterns;
        operators.plan = Some(plan);
        patterns
    }

    /// (c) The final pass: σ̂ rebuilt from the edge tractions (no drift of the incremental
    /// updates), its energy and the equilibrium check on the owned elements; the fields
    /// stored, or handed to `visit` and dropped. (coefficients, energy, check).
    fn final_pass(
        &self,
        cache: &mut ShapeCache,
        field: Field,
        visit: Option<FieldVisitor>,
    ) -> (Vec<[f64; NC]>, f64, Residuals) {
        let Field {
            sig,
            trac,
            shape_of,
            mut coef,
        } = field;
        let pass = FinalPass {
            mesh: self.mesh,
            topo: &self.topo,
            bc: &self.bc,
            trac: &trac,
            shape_of: &shape_of,
            sig: &sig,
            cm: compliance(self.material),
            owned: self.owned,
        };
        let (energy, checked) = match visit {
            Some(f) => {
                coef = Vec::new();
                pass.run(cache, f)
            }
            None => {
                coef.resize(self.mesh.triangles.len(), [0.0; NC]);
                pass.run(cache, |e, x| coef[e] = *x)
            }
        };
        (coef, energy, checked)
    }

    /// The largest point reaction at a vertex of an owned element.
    fn owned_reaction(&self, reactions: &[(usize, f64)]) -> f64 {
        reactions
            .iter()
            .filter(|&&(i, _)| self.vertex_owned.as_ref().is_none_or(|v| v[i]))
            .fold(0.0f64, |m, &(_, r)| m.max(r))
    }

    /// The topology, the star structure and the shape cache kept for the next recovery.
    fn keep(self, operators: &mut OperatorCache, cache: ShapeCache, stars: Stars) {
        operators.shapes = cache;
        operators.topology = Some((self.mesh_fingerprint, self.topo));
        operators.stars = Some(stars);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::equilibrate::testutil::*;
    use crate::estimate::equilibrate::{
        equilibrate, equilibrate_with, BoundaryEdge, EdgeComponent,
    };

    #[test]
    fn restriction_input_and_trivial_restriction() {
        let (mesh, bd) = block(4);
        let u = fe_solve(&mesh, &bd);
        let colours = vertex_colours(&mesh);
        let keys: Vec<u64> = colours
            .iter()
            .enumerate()
            .map(|(i, &c)| sweep_key(c, i))
            .collect();
        let owned = vec![true; mesh.triangles.len()];
        let all = Restriction {
            between_sweeps: None,
            vertex_key: &keys,
            owned: &owned,
        };
        let restricted = |choice, r: &Restriction| {
            equilibrate_restricted(&mesh, &STEEL, &u, &bd, choice, Some(r), None, None)
        };
        assert!(matches!(
            restricted(Recovery::star(), &all),
            Err(EquilibrationError::RestrictedMinimumEnergy)
        ));
        let short = Restriction {
            between_sweeps: None,
            vertex_key: &keys[1..],
            ..all
        };
        assert!(matches!(
            restricted(Recovery::Eet, &short),
            Err(EquilibrationError::RestrictionLength {
                what: "vertex_key",
                ..
            })
        ));
        // Everything owned with the full-mesh keys: the unrestricted computation, bitwise.
        for choice in [Recovery::Eet, Recovery::PatchClassic { sweeps: 2 }] {
            let a = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
            let b = restricted(choice, &all).unwrap();
            for e in 0..mesh.triangles.len() {
                assert_eq!(a.coefficients(e), b.coefficients(e));
            }
            assert_eq!(a.stats().energy_final, b.stats().energy_final);
            let (ra, rb) = (
                a.residuals(&mesh, &bd),
                b.residuals_restricted(&mesh, &bd, Some(&owned)),
            );
            assert_eq!(format!("{ra:?}"), format!("{rb:?}"));
            // The construction's own check (from the final pass) measures the same terms,
            // but the inter-element jump as twice the largest defect of a side against the
            // shared edge traction: a bound of the two-sided jump measured above.
            let c = b.checked_residuals();
            let same = |r: &crate::estimate::equilibrate::Residuals| {
                [r.divergence, r.internal_jump, r.boundary, r.point_reaction]
            };
            assert_eq!(same(&ra), same(&c), "{ra:?} vs {c:?}");
            assert!(
                ra.element_jump <= c.element_jump * (1.0 + 1e-12) && c.element_jump < 1e-13,
                "{ra:?} vs {c:?}"
            );
        }
    }

    #[test]
    fn rejects_bad_input() {
        let (mesh, mut bd) = block(2);
        let u = vec![0.0; mesh.num_dofs()];
        assert!(matches!(
            equilibrate(&mesh, &STEEL, &u[1..], &bd),
            Err(EquilibrationError::DisplacementLength { .. })
        ));
        bd.edges.push(BoundaryEdge {
            nodes: [0, 4],
            comps: [EdgeComponent::Free; 2],
        });
        assert!(matches!(
            equilibrate(&mesh, &STEEL, &u, &bd),
            Err(EquilibrationError::NotABoundaryEdge { .. })
        ));
    }
}
