//! The construction itself: σ̂ on a mesh or on an overlapping sub-mesh (FE stresses and nodal
//! forces, (a) the star problems, (b) the JM fields, then the chosen lowering of the energy).

use super::eet::{edge_conditions, edge_tractions, known_moment, Bc, Stars};
use super::energy::{compliance, total_energy, EnergyContext};
use super::johnson_mercier::{jm_fields, local_frame, traction};
use super::plan::{fingerprint, Plan, Warm};
use super::relaxation::Relaxation;
use super::topology::{is_owned, owned_vertices, sweep_key, vertex_colours, Topology};
use super::{
    Boundary, EquilibratedStress, EquilibrationError, EquilibrationStats, OperatorCache, Residuals,
    Restriction, StarChoice, NC, NONE,
};
use crate::fem::mesh::Mesh;
use crate::fem::{self, Material};

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
/// other counts are those of the sub-mesh. `MinimumEnergy` (a global solve) is refused
/// with a restriction ([`EquilibrationError::RestrictedMinimumEnergy`]).
pub fn equilibrate_restricted(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
    choice: StarChoice,
    restriction: Option<&Restriction>,
    operators: Option<&mut OperatorCache>,
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
        if matches!(choice, StarChoice::MinimumEnergy { .. }) {
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
    let ne = topo.edge_nodes.len();

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
        let n = topo.edge_normal[g];
        let [e0, e1] = topo.edge_elems[g];
        let mut s = sig[e0];
        if e1 != NONE {
            for r in 0..3 {
                s[r] = 0.5 * (s[r] + sig[e1][r]);
            }
        }
        edge_ref[g] = traction(&s, n);
    }
    // Known moments (for the force scale).
    for g in (0..ne).filter(|&g| is_owned(owned, topo.edge_elems[g][0])) {
        for k in 0..2 {
            if let Bc::Known(v) = bc[g][k] {
                for end in 0..2 {
                    force_scale = force_scale.max(known_moment(topo.edge_len[g], v, end).abs());
                }
            }
        }
    }
    let force_scale = if force_scale > 0.0 { force_scale } else { 1.0 };

    // (a) Star problems.
    let mut stars = Stars::default();
    let mut moments = vec![[[0.0; 2]; 2]; ne]; // [edge][end][k], unknown components only
    let mut reactions: Vec<(usize, f64)> = Vec::new();
    let mut fe_equilibrium: f64 = 0.0;
    let mut star_edges: Vec<usize> = Vec::new();
    let mut cols: Vec<usize> = Vec::new();
    let mut key: Vec<i16> = Vec::new();
    let mut q: Vec<f64> = Vec::new();
    let mut bbar: Vec<f64> = Vec::new();
    let mut r: Vec<f64> = Vec::new();
    stars.cols_ptr.push(0);
    for i in 0..nn {
        let elems = topo.vertex_elements(i);
        star_edges.clear();
        for &(e, a) in elems {
            for l in [a, (a + 2) % 3] {
                let g = topo.elem_edges[e][l];
                if !star_edges.contains(&g) {
                    star_edges.push(g);
                }
            }
        }
        for k in 0..2 {
            cols.clear();
            cols.extend(
                star_edges
                    .iter()
                    .copied()
                    .filter(|&g| !matches!(bc[g][k], Bc::Known(_))),
            );
            let (nr, nc) = (elems.len(), cols.len());
            key.clear();
            key.push(nr as i16);
            key.push(nc as i16);
            key.resize(2 + nr * nc, 0);
            q.clear();
            for (row, &(e, a)) in elems.iter().enumerate() {
                let mut rhs = force[e][2 * a + k];
                for l in [a, (a + 2) % 3] {
                    let g = topo.elem_edges[e][l];
                    let s = topo.sign(e, g);
                    match bc[g][k] {
                        Bc::Known(v) => {
                            let end = topo.end_of(g, i);
                            rhs -= s * known_moment(topo.edge_len[g], v, end);
                        }
                        _ => {
                            let c = cols.iter().position(|&x| x == g).unwrap();
                            key[2 + row * nc + c] += s as i16;
                        }
                    }
                }
                q.push(rhs);
            }
            let op = stars.op(&key);
            let star_op = &stars.ops[op];
            // b = b̄ + A⁺ (Q − A b̄).
            bbar.clear();
            bbar.extend(
                cols.iter()
                    .map(|&g| 0.5 * topo.edge_len[g] * edge_ref[g][k]),
            );
            r.clear();
            for row in 0..nr {
                let ab: f64 = (0..nc)
                    .map(|c| key[2 + row * nc + c] as f64 * bbar[c])
                    .sum();
                r.push(q[row] - ab);
            }
            let mut worst: f64 = 0.0;
            for c in 0..nc {
                let corr: f64 = (0..nr).map(|row| star_op.pinv[c * nr + row] * r[row]).sum();
                bbar[c] += corr;
            }
            for row in 0..nr {
                let ab: f64 = (0..nc)
                    .map(|c| key[2 + row * nc + c] as f64 * bbar[c])
                    .sum();
                worst = worst.max((ab - q[row]).abs());
            }
            for (c, &g) in cols.iter().enumerate() {
                moments[g][topo.end_of(g, i)][k] = bbar[c];
            }
            if boundary.constrained[2 * i + k] {
                reactions.push((i, worst / force_scale));
            } else if vertex_owned.as_ref().is_none_or(|v| v[i]) {
                fe_equilibrium = fe_equilibrium.max(worst / force_scale);
            }
            stars.star_op.push(op);
            stars.cols.extend_from_slice(&cols);
            stars.cols_ptr.push(stars.cols.len());
        }
    }
    let star_parameters: usize = stars.star_op.iter().map(|&o| stars.ops[o].nnull).sum();
    // Per-element and per-edge data of the star problems only, freed before the fields.
    drop((force, edge_ref));

    // (b) JM fields.
    let planned = matches!(choice, StarChoice::PatchTraction { .. });
    let mut cache = std::mem::take(&mut operators.shapes);
    let mut shape_of = vec![NONE; nt];
    // `PatchTraction` builds the fields once, at the end, after its sweeps' data is freed.
    let mut coef = if planned {
        Vec::new()
    } else {
        vec![[0.0; NC]; nt]
    };
    let mut trac = edge_tractions(&topo, &bc, &moments);
    if planned {
        // Only `MinimumEnergy` needs the star problems and the moments again.
        (stars, moments) = (Stars::default(), Vec::new());
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
    // The averaged-traction field and its energy (`PatchTraction` only builds the final
    // field).
    let energy_averaged = if planned {
        f64::NAN
    } else {
        jm_fields(mesh, &topo, &trac, &mut cache, &shape_of, &mut coef);
        total_energy(mesh, material, &coef, &sig, owned)
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

    if let StarChoice::MinimumEnergy {
        max_iterations,
        tolerance,
    } = choice
    {
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
                let star_op = &stars.ops[stars.star_op[s]];
                let cs = &stars.cols[stars.cols_ptr[s]..stars.cols_ptr[s + 1]];
                for j in 0..star_op.nnull {
                    let nu = &star_op.null[j * cs.len()..(j + 1) * cs.len()];
                    for (c, &g) in cs.iter().enumerate() {
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
    let (sweeps, warm) = match choice {
        StarChoice::PatchRelaxation { sweeps } => (sweeps, None),
        StarChoice::PatchTraction {
            sweeps,
            warm_sweeps,
        } => (sweeps, Some(warm_sweeps)),
        _ => (0, None),
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
                    _ => Plan::new(&mut relax, &mut cache, &order(), fp),
                };
                let a = plan.loads(mesh, &mut cache, &shape_of, &sig, &relax.cm, &relax.ops);
                let flat = trac.as_flattened_mut().as_flattened_mut();
                let start = flat.to_vec();
                // Warm: from the change of the previous recovery with this cache (if any,
                // on this sub-mesh with these boundary codes), `warm_sweeps` sweeps.
                let warm =
                    warm_sweeps > 0 && operators.warm.take().is_some_and(|w| w.apply(fp, flat));
                plan.sweep(
                    &relax.ops,
                    &a,
                    flat,
                    if warm { warm_sweeps } else { sweeps },
                );
                if warm_sweeps > 0 {
                    operators.warm = Some(Warm::new(fp, flat, start));
                }
                stats.patch_patterns = plan.patterns;
                operators.plan = Some(plan);
            }
        }
        operators.patch_map = relax.map;
        operators.patch_ops = relax.ops;
        operators.hhat = relax.hhat;
        // Rebuild σ̂ from the edge tractions (no drift of the incremental updates).
        if coef.is_empty() {
            coef = vec![[0.0; NC]; nt];
        }
        jm_fields(mesh, &topo, &trac, &mut cache, &shape_of, &mut coef);
        stats.energy_final = total_energy(mesh, material, &coef, &sig, owned);
    }
    stats.shapes = cache.ops.len();
    operators.shapes = cache;
    let mut stress = EquilibratedStress {
        coef,
        reactions,
        stats,
        checked: Residuals::default(),
    };
    // The equilibrium check on the owned elements, with this mesh's topology and codes.
    stress.checked = stress.residuals_with(mesh, &topo, &bc, owned);
    operators.topology = Some((mesh_fp, topo));
    Ok(stress)
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
            vertex_key: &keys,
            owned: &owned,
        };
        let restricted = |choice, r: &Restriction| {
            equilibrate_restricted(&mesh, &STEEL, &u, &bd, choice, Some(r), None)
        };
        assert!(matches!(
            restricted(StarChoice::minimum_energy(), &all),
            Err(EquilibrationError::RestrictedMinimumEnergy)
        ));
        let short = Restriction {
            vertex_key: &keys[1..],
            ..all
        };
        assert!(matches!(
            restricted(StarChoice::AveragedTraction, &short),
            Err(EquilibrationError::RestrictionLength {
                what: "vertex_key",
                ..
            })
        ));
        // Everything owned with the full-mesh keys: the unrestricted computation, bitwise.
        for choice in [
            StarChoice::AveragedTraction,
            StarChoice::PatchRelaxation { sweeps: 2 },
        ] {
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
            assert_eq!(format!("{ra:?}"), format!("{:?}", b.checked_residuals()));
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
