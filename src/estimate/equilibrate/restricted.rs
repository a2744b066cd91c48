//! The construction itself: σ̂ on a mesh or on an overlapping sub-mesh (FE stresses and nodal
//! forces, (a) the star problems, (b) the JM fields, then the chosen lowering of the energy).

use super::boundary::Boundary;
use super::cache::OperatorCache;
use super::eet::{edge_conditions, edge_tractions, known_moment, Bc, Stars};
use super::energy::{compliance, total_energy, EnergyContext};
use super::error::EquilibrationError;
use super::johnson_mercier::{jm_fields, local_frame, traction};
use super::plan::{fingerprint, Plan, Warm};
use super::recovery::Recovery;
use super::relaxation::Relaxation;
use super::restriction::Restriction;
use super::sizes::{NC, NONE};
use super::stress::{EquilibratedStress, EquilibrationStats, FinalPass};
use super::topology::{is_owned, owned_vertices, sweep_key, vertex_colours, Topology};
use crate::fem::mesh::Mesh;
use crate::fem::{self, Material};

/// The receiver of every element's field (element, its 27 JM coefficients).
pub type FieldVisitor<'a> = &'a mut dyn FnMut(usize, &[f64; NC]);

/// Build σ̂ on a mesh or, with a [`Restriction`], on an overlapping sub-mesh of a larger
/// mesh (`overlap::Overlap`: `u` and `boundary` restricted to it).
///
/// Without restriction: the sweep keys are [`sweep_key`] of [`vertex_colours`]`(mesh)` and the
/// vertex index, and every element is owned. With a restriction, σ̂ equals the full-mesh
/// field (to round-off) on every owned element whose neighbourhood of
/// `Overlap::rings_for(choice, colours)` rings is in the sub-mesh; elsewhere it is
/// meaningless (the artificial boundary of the sub-mesh is treated as traction free). The
/// statistics `fe_equilibrium`, `energy_averaged` and `energy_final` are then measured on
/// the owned elements only (the energies sum over the ranks to the full-mesh ones); the
/// other counts are those of the sub-mesh. `Recovery::Star` (a global solve) is refused
/// with a restriction ([`EquilibrationError::RestrictedMinimumEnergy`]).
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
    choice: Recovery,
    restriction: Option<&Restriction>,
    operators: Option<&mut OperatorCache>,
    visit: Option<FieldVisitor>,
) -> Result<EquilibratedStress, EquilibrationError> {
    // The local operators: the caller's (kept across calls) or this call's own.
    let mut own = OperatorCache::default();
    let operators = operators.unwrap_or(&mut own).for_material(material);
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
        if !choice.is_local() {
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
    let owned = restriction.map(|r| r.owned);
    let vertex_owned = owned_vertices(mesh, owned);
    // The topology of this mesh: kept in the cache from the previous recovery, or built.
    let mesh_fp = mesh.fingerprint();
    let topo = match operators.topology.take() {
        Some((fp, t)) if fp == mesh_fp => t,
        _ => Topology::new(mesh)?,
    };
    let bc = edge_conditions(&topo, boundary)?;
    let ne = topo.num_edges();

    // FE stresses and element nodal forces R_E = ∫_E σ̃ : ε(φ_a e_k); the force scale (of
    // the relative FE-equilibrium defect and point reactions) over the owned elements.
    let d = material.hooke();
    let mut sig = vec![[0.0; 3]; nt];
    let mut force = vec![[0.0; 6]; nt];
    let mut force_scale: f64 = 0.0;
    for e in 0..nt {
        let (b, area) = fem::strain_displacement(&mesh.triangle_points(e));
        let dofs = fem::element_dofs(&mesh.triangles[e]);
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
    // Reference tractions (oriented to the plus element) for the star least squares.
    let mut edge_ref = vec![[0.0; 2]; ne];
    for g in 0..ne {
        let n = topo.normal(mesh, g);
        let [e0, e1] = topo.elems(g);
        let mut s = sig[e0];
        if e1 != NONE {
            for r in 0..3 {
                s[r] = 0.5 * (s[r] + sig[e1][r]);
            }
        }
        edge_ref[g] = traction(&s, n);
    }
    // Known moments (for the force scale).
    for g in (0..ne).filter(|&g| is_owned(owned, topo.elems(g)[0])) {
        for k in 0..2 {
            if let Bc::Known(v) = bc[g][k] {
                for end in 0..2 {
                    force_scale = force_scale.max(known_moment(topo.edge_len[g], v, end).abs());
                }
            }
        }
    }
    let force_scale = if force_scale > 0.0 { force_scale } else { 1.0 };

    // (a) Star problems: the structure (kept in the cache for this mesh and these boundary
    // codes), then b = b̄ + A⁺ (Q − A b̄) star by star.
    let fp = fingerprint(mesh_fp, &bc, restriction.map(|r| r.vertex_key));
    let stars = match operators.stars.take() {
        Some(s) if s.fingerprint == fp => s,
        _ => Stars::new(&topo, &bc, fp),
    };
    let mut moments = vec![[[0.0; 2]; 2]; ne]; // [edge][end][k], unknown components only
    let mut reactions: Vec<(usize, f64)> = Vec::new();
    let mut fe_equilibrium: f64 = 0.0;
    let mut q: Vec<f64> = Vec::new();
    let mut rows: Vec<[(usize, f64); 2]> = Vec::new();
    let mut bbar: Vec<f64> = Vec::new();
    let mut r: Vec<f64> = Vec::new();
    for s in 0..2 * nn {
        let (i, k) = (s / 2, s % 2);
        let elems = topo.vertex_elements(i);
        let cols = stars.cols(s);
        let row_cols = stars.row_cols(&topo, s);
        let nr = elems.len();
        // Per row: A's (column, sign) pairs, and Q.
        rows.clear();
        q.clear();
        for ((e, a), rc) in elems.iter().zip(row_cols) {
            let mut rhs = force[e][2 * a + k];
            let mut entries = [(0usize, 0.0); 2];
            for (j, l) in [a, (a + 2) % 3].into_iter().enumerate() {
                let g = topo.edges_of(e)[l];
                let sign = topo.sign(e, g);
                if let Bc::Known(v) = bc[g][k] {
                    let end = topo.end_of(g, i);
                    rhs -= sign * known_moment(topo.edge_len[g], v, end);
                } else {
                    entries[j] = (rc[j] as usize, sign);
                }
            }
            rows.push(entries);
            q.push(rhs);
        }
        let star_op = stars.op_of(s);
        bbar.clear();
        bbar.extend(
            cols.iter()
                .map(|&g| 0.5 * topo.edge_len[g as usize] * edge_ref[g as usize][k]),
        );
        // (A b)_row − Q_row; a zero sign marks a known component (no column).
        let residual = |b: &[f64], row: usize| -> f64 {
            let term = |(c, s): (usize, f64)| if s != 0.0 { s * b[c] } else { 0.0 };
            let [x, y] = rows[row];
            term(x) + term(y) - q[row]
        };
        r.clear();
        r.extend((0..nr).map(|row| -residual(&bbar, row)));
        for c in 0..cols.len() {
            let corr: f64 = (0..nr).map(|row| star_op.pinv[c * nr + row] * r[row]).sum();
            bbar[c] += corr;
        }
        let worst = (0..nr).fold(0.0f64, |w, row| w.max(residual(&bbar, row).abs()));
        for (c, &g) in cols.iter().enumerate() {
            moments[g as usize][topo.end_of(g as usize, i)][k] = bbar[c];
        }
        if boundary.constrained[2 * i + k] {
            reactions.push((i, worst / force_scale));
        } else if vertex_owned.as_ref().is_none_or(|v| v[i]) {
            fe_equilibrium = fe_equilibrium.max(worst / force_scale);
        }
    }
    let star_parameters: usize = (0..2 * nn).map(|s| stars.op_of(s).nnull).sum();
    // Per-element and per-edge data of the star problems only, freed before the fields.
    drop((force, edge_ref));

    // (b) JM fields.
    let planned = choice.planned_sweeps().is_some();
    let mut cache = std::mem::take(&mut operators.shapes);
    let mut shape_of = vec![NONE; nt];
    // `Recovery::PatchClassic` and `Recovery::Star` update the fields as they go; the others build
    // them once, in the final pass.
    let incremental = choice.updates_fields();
    let mut coef = if incremental {
        vec![[0.0; NC]; nt]
    } else {
        Vec::new()
    };
    let mut trac = edge_tractions(&topo, &bc, &moments);
    if choice.star_minimisation().is_none() {
        // Only `Recovery::Star` needs the moments again.
        moments = Vec::new();
    }
    for e in 0..nt {
        let (_, _, qv) = local_frame(&mesh.triangle_points(e));
        match cache.index(&qv) {
            Some(i) => shape_of[e] = i,
            None => {
                operators.shapes = cache;
                return Err(EquilibrationError::SingularLocalProblem { element: e });
            }
        }
    }
    // The averaged-traction field and its energy (of the incremental choices; the final
    // pass gives it for `Recovery::Eet`; `Recovery::Patch` only builds the final field).
    let energy_averaged = if incremental {
        jm_fields(mesh, &topo, &trac, &mut cache, &shape_of, &mut coef);
        total_energy(mesh, material, &coef, &sig, owned)
    } else {
        f64::NAN
    };
    let mut stats = EquilibrationStats {
        star_parameters,
        shapes: cache.ops.len(),
        cg_iterations: 0,
        energy_averaged,
        energy_final: energy_averaged,
        patch_patterns: 0,
        fe_equilibrium,
    };

    if let Some((max_iterations, tolerance)) = choice.star_minimisation() {
        if star_parameters > 0 {
            let ctx = EnergyContext {
                mesh,
                material,
                topo: &topo,
                stars: &stars,
                sig: &sig,
                coef: &coef,
                shape_of: &shape_of,
            };
            let (theta, its) = ctx.minimise(&mut cache, max_iterations, tolerance);
            stats.cg_iterations = its;
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
            trac = edge_tractions(&topo, &bc, &moments);
            jm_fields(mesh, &topo, &trac, &mut cache, &shape_of, &mut coef);
            stats.energy_final = total_energy(mesh, material, &coef, &sig, owned);
        }
    }
    let (sweeps, warm) = match choice.planned_sweeps() {
        Some((sweeps, warm_sweeps)) => (sweeps, Some(warm_sweeps)),
        None => (choice.field_sweeps(), None),
    };
    if sweeps > 0 || planned {
        let mut relax = Relaxation {
            mesh,
            topo: &topo,
            bc: &bc,
            sig: &sig,
            shape_of: &shape_of,
            cm: compliance(material),
            map: std::mem::take(&mut operators.patch_map),
            ops: std::mem::take(&mut operators.patch_ops),
            vertex_op: vec![NONE; nn],
            hhat: std::mem::take(&mut operators.hhat),
        };
        // Multicolour symmetric Gauss–Seidel: vertices by increasing sweep key (colour, then
        // global index) in the even sweeps, decreasing in the odd ones. The steps of one
        // colour touch disjoint data (see `Relaxation::step`).
        let order = || -> Vec<usize> {
            let full_keys: Vec<u64>;
            let keys = match restriction {
                Some(r) => r.vertex_key,
                None => {
                    let colours = vertex_colours(mesh);
                    full_keys = (0..nn).map(|i| sweep_key(colours[i], i)).collect();
                    &full_keys
                }
            };
            let mut order: Vec<usize> = (0..nn).collect();
            order.sort_unstable_by_key(|&i| keys[i]);
            order
        };
        match warm {
            None => {
                let order = order();
                for sweep in 0..sweeps {
                    let forward = sweep % 2 == 0;
                    for v in 0..nn {
                        let i = order[if forward { v } else { nn - 1 - v }];
                        relax.step(&mut cache, i, &mut trac, &mut coef);
                    }
                }
                stats.patch_patterns = relax.ops.len();
            }
            Some(warm_sweeps) => {
                let fp = fingerprint(mesh_fp, &bc, restriction.map(|r| r.vertex_key));
                let plan = match operators.plan.take() {
                    Some(p) if p.fingerprint() == fp => p,
                    _ => {
                        let plan = Plan::new(&mut relax, &mut cache, &order(), fp);
                        // The element Hessians only build patch operators, and the plan's
                        // are all built: on unstructured meshes (a Hessian per element)
                        // they were 1152 bytes per element for nothing.
                        relax.hhat = Default::default();
                        plan
                    }
                };
                let a = plan.loads(mesh, &mut cache, &shape_of, &sig, &relax.cm, &relax.ops);
                let flat = trac.as_flattened_mut().as_flattened_mut();
                // Warm: from the change δ of the previous recovery with this cache (if any,
                // on this sub-mesh with these boundary codes), `warm_sweeps` sweeps; the
                // sweeps' changes added to δ (from zero when cold) for the next one.
                let mut warm = operators
                    .warm
                    .take()
                    .filter(|w| warm_sweeps > 0 && w.apply(fp, flat));
                let sweeps = choice.sweeps_made(warm.is_some());
                if warm_sweeps > 0 && warm.is_none() {
                    warm = Some(Warm::zero(fp, flat.len()));
                }
                let change = warm.as_mut().map_or(&mut [][..], |w| w.delta_mut());
                let between = restriction.and_then(|r| r.between_sweeps);
                plan.sweep(&topo, &relax.ops, &a, flat, change, sweeps, between);
                if warm_sweeps > 0 {
                    operators.warm = warm;
                }
                stats.patch_patterns = plan.patterns;
                operators.plan = Some(plan);
            }
        }
        operators.patch_map = relax.map;
        operators.patch_ops = relax.ops;
        operators.hhat = relax.hhat;
    }
    // (c) The final pass: σ̂ rebuilt from the edge tractions (no drift of the incremental
    // updates), its energy and the equilibrium check on the owned elements; the fields
    // stored, or handed to `visit` and dropped.
    let pass = FinalPass {
        mesh,
        topo: &topo,
        bc: &bc,
        trac: &trac,
        shape_of: &shape_of,
        sig: &sig,
        cm: compliance(material),
        owned,
    };
    let (energy, mut checked) = match visit {
        Some(f) => {
            coef = Vec::new();
            pass.run(&mut cache, f)
        }
        None => {
            coef.resize(nt, [0.0; NC]);
            pass.run(&mut cache, |e, x| coef[e] = *x)
        }
    };
    stats.energy_final = energy;
    if choice.ends_at_averaged() {
        stats.energy_averaged = energy; // `Recovery::Eet`: the final field is that one
    }
    checked.point_reaction = reactions
        .iter()
        .filter(|&&(i, _)| vertex_owned.as_ref().is_none_or(|v| v[i]))
        .fold(0.0f64, |m, &(_, r)| m.max(r));
    stats.shapes = cache.ops.len();
    operators.shapes = cache;
    let stress = EquilibratedStress {
        coef,
        reactions,
        stats,
        checked,
    };
    operators.topology = Some((mesh_fp, topo));
    operators.stars = Some(stars);
    Ok(stress)
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
    choice: Recovery,
) -> Result<EquilibratedStress, EquilibrationError> {
    equilibrate_restricted(mesh, material, u, boundary, choice, None, None, None)
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
