//! Unit tests of the construction; their helpers are shared with `overlap.rs` (`fe_solve`,
//! `block_rect`, `STEEL`).

pub(crate) use super::testutil::{block_rect, fe_solve, STEEL};

use super::sizes::{CAPACITY, MAX_PATCHES, MAX_SHAPES};
use super::testutil::*;
use super::*;
use crate::fem::geometry::triangle_area;
use crate::fem::{self, Material, Mesh};

#[test]
fn patch_test_reproduces_uniform_stress() {
    let s = [3e6, -1e7, 2e6];
    let (mesh, bd) = patch(5, s);
    let u = fe_solve(&mesh, &bd);
    for choice in CHOICES {
        let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        let r = eq.residuals(&mesh, &bd);
        println!("patch {choice:?}: {r:?}");
        assert_admissible(&r, 1e-10);
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        let mut worst: f64 = 0.0;
        let mut cre = 0.0;
        let mut energy = 0.0;
        for e in 0..mesh.triangles.len() {
            let p = mesh.triangle_points(e);
            let c = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            ];
            let mut probes = vec![c];
            for a in 0..3 {
                probes.push(p[a]);
                probes.push([0.5 * (p[a][0] + c[0]), 0.5 * (p[a][1] + c[1])]);
            }
            for x in probes {
                let sh = eq.stress_at(&mesh, e, x);
                for r in 0..3 {
                    worst = worst.max((sh[r] - s[r]).abs() / 1e7);
                }
            }
            let sfe = fem::element_stress(&mesh, e, &STEEL, &u);
            cre += eq.cre_squared(&mesh, e, sfe, &STEEL);
            energy += 2.0 * STEEL.compliance_energy(&s) * triangle_area(&p);
        }
        println!(
            "patch: max |σ̂ − σ|/|σ| = {worst:.2e}, cre²/energy = {:.2e}",
            cre / energy
        );
        assert!(
            worst < 1e-10,
            "σ̂ differs from the uniform stress by {worst:e}"
        );
        assert!(cre < 1e-20 * energy, "cre² = {cre:e} vs energy {energy:e}");
    }
}

#[test]
fn block_is_exactly_equilibrated() {
    let (mesh, bd) = block(6);
    let u = fe_solve(&mesh, &bd);
    for choice in CHOICES {
        let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        let r = eq.residuals(&mesh, &bd);
        println!("block 6x6 {choice:?}: {r:?}, {:?}", eq.stats());
        assert_admissible(&r, 1e-10);
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        // The cre map sums to the total and is non-negative.
        let map = eq.cre_map(&mesh, &STEEL, &u);
        assert!(map.iter().all(|&v| v >= 0.0));
        let total: f64 = map.iter().sum();
        assert!((total - eq.stats().energy_final).abs() < 1e-10 * total);
    }
}

#[test]
fn distorted_mesh_is_exactly_equilibrated() {
    // Every triangle a different shape (no cache sharing), boundary kept straight.
    let (mesh, bd) = distorted_block(6, 7);
    let u = fe_solve(&mesh, &bd);
    for choice in CHOICES {
        let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        let r = eq.residuals(&mesh, &bd);
        println!("distorted {choice:?}: {r:?} {:?}", eq.stats());
        assert!(eq.stats().shapes > 50);
        assert_admissible(&r, 1e-10);
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
    }
}

#[test]
fn rollers_give_exact_uniaxial_stress() {
    let n = 4;
    let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], n, n);
    let p = 1.3e7;
    let mut constrained = vec![false; mesh.num_dofs()];
    let mut edges = Vec::new();
    let bottom = mesh.bottom_nodes();
    for &b in &bottom {
        constrained[2 * b + 1] = true;
    }
    constrained[2 * mesh.node(0, 0)] = true;
    for w in bottom.windows(2) {
        edges.push(BoundaryEdge {
            nodes: [w[0], w[1]],
            comps: [known(0.0, 0.0), EdgeComponent::Free],
        });
    }
    for w in mesh.top_nodes().windows(2) {
        edges.push(BoundaryEdge {
            nodes: [w[0], w[1]],
            comps: [known(0.0, 0.0), known(-p, -p)],
        });
    }
    let bd = Boundary { edges, constrained };
    let u = fe_solve(&mesh, &bd);
    let eq = equilibrate(&mesh, &STEEL, &u, &bd).unwrap();
    let r = eq.residuals(&mesh, &bd);
    println!("rollers: {r:?}");
    assert_admissible(&r, 1e-10);
    assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
    let mut worst: f64 = 0.0;
    for e in 0..mesh.triangles.len() {
        let pts = mesh.triangle_points(e);
        for x in pts {
            for sub in 0..3 {
                let s = eq.sub_stress_at(&mesh, e, sub, x);
                worst = worst.max(s[0].abs().max((s[1] + p).abs()).max(s[2].abs()) / p);
            }
        }
    }
    println!("rollers: max |σ̂ − σ|/p = {worst:.2e}");
    assert!(worst < 1e-10);
}

/// `block(4)` with its centre node moved (so its patches are not all alike) and its FE
/// solution.
fn skewed_block() -> (Mesh, Boundary, Vec<f64>) {
    let (mut mesh, bd) = block(4);
    let centre = mesh.node(2, 2);
    let c = mesh.points.get(centre);
    mesh.points.set(centre, [c[0] + 0.03, c[1]]);
    let u = fe_solve(&mesh, &bd);
    (mesh, bd, u)
}

#[test]
fn uncached_paths_agree_with_cached() {
    let (mesh, bd, u) = skewed_block();
    let choice = Recovery::PatchClassic { sweeps: 2 };
    let cached = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
    CAPACITY.with(|c| c.set((3, 2)));
    let uncached = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
    CAPACITY.with(|c| c.set((MAX_SHAPES, MAX_PATCHES)));
    assert_eq!(uncached.stats().shapes, 3);
    assert_eq!(uncached.stats().patch_patterns, 2);
    assert_admissible(&uncached.residuals(&mesh, &bd), 1e-10);
    let smax = (0..mesh.triangles.len())
        .flat_map(|e| cached.coefficients(e).to_vec())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for e in 0..mesh.triangles.len() {
        for (a, b) in cached.coefficients(e).iter().zip(uncached.coefficients(e)) {
            assert!((a - b).abs() < 1e-10 * smax);
        }
    }
}

#[test]
fn kept_operators_give_the_same_stress_and_grow_no_more() {
    let (mesh, bd, u) = skewed_block();
    let v: Vec<f64> = u
        .iter()
        .enumerate()
        .map(|(i, x)| x * (1.0 + 0.1 * (i % 3) as f64))
        .collect();
    let choice = Recovery::PatchClassic { sweeps: 2 };
    let mut ops = OperatorCache::default();
    let with = |w: &[f64], ops: &mut OperatorCache| {
        equilibrate_restricted(&mesh, &STEEL, w, &bd, choice, None, Some(ops), None).unwrap()
    };
    let first = with(&u, &mut ops);
    let filled = ops.len();
    assert!(filled.0 > 0 && filled.1 > 0, "{filled:?}");
    // Another field on the same mesh: the same operators, reused, and the same σ̂ as a
    // recovery with fresh ones, bit for bit.
    let second = with(&v, &mut ops);
    assert_eq!(ops.len(), filled);
    let fresh = equilibrate_with(&mesh, &STEEL, &v, &bd, choice).unwrap();
    let fresh_u = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
    for e in 0..mesh.triangles.len() {
        assert_eq!(second.coefficients(e), fresh.coefficients(e));
        assert_eq!(first.coefficients(e), fresh_u.coefficients(e));
    }
    // Another material: the operators are rebuilt for it.
    let soft = Material {
        young: STEEL.young / 3.0,
        poisson: 0.4,
    };
    let third =
        equilibrate_restricted(&mesh, &soft, &v, &bd, choice, None, Some(&mut ops), None).unwrap();
    let fresh_soft = equilibrate_with(&mesh, &soft, &v, &bd, choice).unwrap();
    for e in 0..mesh.triangles.len() {
        assert_eq!(third.coefficients(e), fresh_soft.coefficients(e));
    }
}

/// The planned recovery past the caches' capacities: the same stress as with room for every
/// pattern, the patterns past the capacity not kept (their operators held by index for the
/// plan alone), and a plan built again holding no more operators than the first.
#[test]
fn planned_recovery_past_the_capacity_keeps_no_more_patterns_and_grows_no_more() {
    let (mesh, bd, u) = skewed_block();
    let choice = Recovery::Patch {
        sweeps: 2,
        warm_sweeps: 0,
    };
    let mut ops = OperatorCache::default();
    let with = |ops: &mut OperatorCache| {
        equilibrate_restricted(&mesh, &STEEL, &u, &bd, choice, None, Some(ops), None).unwrap()
    };
    let cached = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
    CAPACITY.with(|c| c.set((3, 2)));
    let first = with(&mut ops);
    let held = ops.len();
    ops.plan = None;
    let again = with(&mut ops);
    let after = ops.len();
    CAPACITY.with(|c| c.set((MAX_SHAPES, MAX_PATCHES)));
    assert_eq!(ops.patch_map.len(), 2, "the patterns within the capacity");
    assert!(held.1 > 2, "every patch's operator for the plan: {held:?}");
    assert_eq!(after, held, "a plan built again holds no more operators");
    assert_admissible(&first.residuals(&mesh, &bd), 1e-10);
    let smax = (0..mesh.triangles.len())
        .flat_map(|e| cached.coefficients(e).to_vec())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for e in 0..mesh.triangles.len() {
        for (x, y) in [&first, &again]
            .map(|s| s.coefficients(e))
            .iter()
            .zip([cached.coefficients(e), cached.coefficients(e)])
        {
            for (a, b) in x.iter().zip(y) {
                assert!((a - b).abs() < 1e-10 * smax, "element {e}: {a} against {b}");
            }
        }
    }
}
