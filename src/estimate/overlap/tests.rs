//! The overlaps' exactness on partitions, their structure and their bytes.

use super::*;
use crate::estimate::equilibrate::tests::{block_rect, fe_solve, STEEL};
use crate::estimate::equilibrate::{
    equilibrate_restricted, equilibrate_with, vertex_colours, EquilibratedStress,
    EquilibrationError,
};
use crate::testutil::Lcg;

const PATCH3: Recovery = Recovery::PatchClassic { sweeps: 3 };

/// Largest differences of a partitioned equilibration from the full-mesh one.
#[derive(Debug, Default)]
struct Diff {
    /// |cre² − cre²_full| / cre²_full over the owned elements.
    cre: f64,
    /// max |coefficient difference| / max |coefficient| per owned element.
    coef: f64,
    /// Relative |Σ_parts Σ_owned cre² − Σ cre²| (and the same for `energy_final`).
    sum: f64,
    /// Largest restricted residual and FE-equilibrium defect of the parts.
    residual: f64,
    /// Largest sub-mesh, as a fraction of the mesh.
    coverage: f64,
}

/// Equilibrate every part (`part[e]`: part of element e) on its overlap of `rings` rings
/// and compare its owned elements with the full-mesh equilibration `full` (of `choice`).
fn partitioned(
    mesh: &Mesh,
    bd: &Boundary,
    u: &[f64],
    full: &EquilibratedStress,
    part: &[usize],
    choice: Recovery,
    rings: usize,
) -> Diff {
    let nt = mesh.triangles.len();
    let colours = vertex_colours(mesh);
    let full_cre = full.cre_map(mesh, &STEEL, u);
    let mut d = Diff::default();
    let mut times_owned = vec![0; nt];
    let (mut total, mut energy) = (0.0, 0.0);
    for p in 0..=*part.iter().max().unwrap() {
        let own: Vec<bool> = part.iter().map(|&q| q == p).collect();
        let ov = Overlap::new(mesh, &own, rings, &colours);
        let (us, bs) = (ov.restrict_dofs(u), ov.restrict_boundary(bd));
        let eq = equilibrate_restricted(
            &ov.mesh,
            &STEEL,
            &us,
            &bs,
            choice,
            Some(&ov.restriction()),
            None,
            None,
        )
        .unwrap();
        let cre = eq.cre_map(&ov.mesh, &STEEL, &us);
        for (le, &ge) in ov
            .elements
            .iter()
            .enumerate()
            .filter(|&(le, _)| ov.owned[le])
        {
            times_owned[ge] += 1;
            total += cre[le];
            d.cre = d.cre.max((cre[le] - full_cre[ge]).abs() / full_cre[ge]);
            let (a, b) = (eq.coefficients(le), full.coefficients(ge));
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = a
                .iter()
                .zip(b)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            d.coef = d.coef.max(diff / scale);
        }
        energy += eq.stats().energy_final;
        let r = eq.residuals_restricted(&ov.mesh, &bs, Some(&ov.owned));
        d.residual = d.residual.max(r.max()).max(eq.stats().fe_equilibrium);
        d.coverage = d.coverage.max(ov.elements.len() as f64 / nt as f64);
    }
    assert!(times_owned.iter().all(|&k| k == 1), "not a partition");
    let full_total: f64 = full_cre.iter().sum();
    let full_energy = full.stats().energy_final;
    d.sum =
        ((total - full_total).abs() / full_total).max((energy - full_energy).abs() / full_energy);
    d
}

fn barycentre(mesh: &Mesh, e: usize) -> [f64; 2] {
    let p = mesh.triangle_points(e);
    [0, 1].map(|c| (p[0][c] + p[1][c] + p[2][c]) / 3.0)
}

/// Three slabs with wavy interfaces (by the barycentre).
fn slabs(mesh: &Mesh) -> Vec<usize> {
    (0..mesh.triangles.len())
        .map(|e| {
            let [x, y] = barycentre(mesh, e);
            if x < 0.3 + 0.08 * (7.0 * y).sin() {
                0
            } else if x < 0.62 + 0.05 * (5.0 * y).cos() {
                1
            } else {
                2
            }
        })
        .collect()
}

/// A checkerboard of blocks of `b` × `b` cells dealt to three parts.
fn checkerboard(mesh: &Mesh, b: usize) -> Vec<usize> {
    (0..mesh.triangles.len())
        .map(|e| {
            let (i, j) = ((e / 2) % mesh.nx, (e / 2) / mesh.nx);
            (i / b + j / b) % 3
        })
        .collect()
}

fn assert_exact(d: &Diff, what: &str) {
    assert!(d.cre < 1e-10 && d.coef < 1e-10, "{what}: {d:?}");
    assert!(d.sum < 1e-12, "{what}: {d:?}");
    assert!(d.residual < 1e-10, "{what}: {d:?}");
    assert!(
        d.coverage < 1.0,
        "{what}: the overlaps cover the mesh, the test proves nothing"
    );
}

/// Exact, with round-off residuals, at `rings_for`; one ring less: the owned fields are
/// still exact (but not their neighbours, so the residual check is not meaningful);
/// measurably different with too few rings.
fn check_partition(mesh: &Mesh, bd: &Boundary, part: &[usize], sweeps: usize, name: &str) {
    let u = fe_solve(mesh, bd);
    let c = colour_count(&vertex_colours(mesh));
    let patch = Recovery::PatchClassic { sweeps };
    for (choice, too_few) in [(Recovery::Eet, 0), (patch, 1)] {
        let full = equilibrate_with(mesh, &STEEL, &u, bd, choice).unwrap();
        let rings = Overlap::rings_for(choice, c);
        let d = partitioned(mesh, bd, &u, &full, part, choice, rings);
        println!("{name} {choice:?}, {rings} rings: {d:?}");
        assert_exact(&d, &format!("{name} {choice:?}, {rings} rings"));
        let d = partitioned(mesh, bd, &u, &full, part, choice, rings - 1);
        println!("{name} {choice:?}, {} rings: {d:?}", rings - 1);
        assert!(d.cre < 1e-10 && d.coef < 1e-10 && d.sum < 1e-12, "{d:?}");
        let d = partitioned(mesh, bd, &u, &full, part, choice, too_few);
        println!("{name} {choice:?}, {too_few} rings (too few): {d:?}");
        assert!(
            d.coef > 1e-6 && d.cre > 1e-6,
            "{name} {choice:?}, {too_few} rings: {d:?}"
        );
    }
}

#[test]
fn slab_partition_is_exact() {
    let (mesh, bd) = block_rect(96, 64);
    check_partition(&mesh, &bd, &slabs(&mesh), 3, "slabs");
}

#[test]
fn checkerboard_partition_is_exact() {
    let (mesh, bd) = block_rect(96, 64);
    // Blocks of 24 × 24 cells (4 × 3, the top row partial): 4 disconnected blocks per
    // part, touching only at corners; corners where 4 blocks of 3 parts meet.
    check_partition(&mesh, &bd, &checkerboard(&mesh, 24), 3, "checkerboard");
}

#[test]
fn distorted_mesh_partition_is_exact() {
    // Every triangle a different shape: no cache sharing between congruent triangles.
    let (mut mesh, bd) = block_rect(40, 32);
    let mut rng = Lcg(11);
    for j in 1..mesh.ny {
        for i in 1..mesh.nx {
            let n = mesh.node(i, j);
            let p = mesh.points.get(n);
            let q = [
                p[0] + 0.2 / 40.0 * rng.next(),
                p[1] + 0.2 / 32.0 * rng.next(),
            ];
            mesh.points.set(n, q);
        }
    }
    check_partition(&mesh, &bd, &slabs(&mesh), 2, "distorted slabs");
}

/// A chain of `Recovery::Patch` recoveries, one cold then two warm (an estimate's η^glo
/// and η^FE recoveries, then the next estimate's η^glo one), each part on its overlap of
/// `rings_for` rings with its own cache and the warm starts refreshed from the owners
/// before each warm recovery ([`Halo::refresh`], emulated here), equals the same chain
/// on the whole mesh on the own elements; without the refresh it does not.
#[test]
fn warm_started_recovery_partition_is_exact() {
    let (mesh, bd) = block_rect(48, 32);
    let u = fe_solve(&mesh, &bd);
    let scaled = |a: f64, m: usize| -> Vec<f64> {
        u.iter()
            .enumerate()
            .map(|(i, x)| x * (1.0 + a * ((i / 7) % m) as f64))
            .collect()
    };
    let data = [u.clone(), scaled(0.05, 3), scaled(0.03, 5)];
    let colours = vertex_colours(&mesh);
    let c = colour_count(&colours);
    let choice = Recovery::Patch {
        sweeps: 2,
        warm_sweeps: 1,
    };
    let mut full_ops = OperatorCache::default();
    let full: Vec<_> = data
        .iter()
        .map(|d| {
            equilibrate_restricted(
                &mesh,
                &STEEL,
                d,
                &bd,
                choice,
                None,
                Some(&mut full_ops),
                None,
            )
            .unwrap()
        })
        .collect();
    let part = slabs(&mesh);
    let parts = *part.iter().max().unwrap() + 1;
    let rings = Overlap::rings_for(choice, c);
    assert_eq!(rings, 2 + 2 * c, "the rings of the cold recovery");
    for refresh in [true, false] {
        let ovs: Vec<Overlap> = (0..parts)
            .map(|p| {
                let own: Vec<bool> = part.iter().map(|&q| q == p).collect();
                Overlap::new(&mesh, &own, rings, &colours)
            })
            .collect();
        let mut ops: Vec<OperatorCache> = (0..parts).map(|_| Default::default()).collect();
        let mut worst: f64 = 0.0;
        for (step, d) in data.iter().enumerate() {
            if refresh && step > 0 {
                // Every element's δ from its owner's cache (what `Halo::refresh` sends).
                let mut owner_values = vec![[0.0; NT]; mesh.triangles.len()];
                for (ov, cache) in ovs.iter().zip(&mut ops) {
                    let own: Vec<usize> = (0..ov.elements.len()).filter(|&l| ov.owned[l]).collect();
                    for (&l, v) in own.iter().zip(cache.warm_values(&own).unwrap()) {
                        owner_values[ov.elements[l]] = v;
                    }
                }
                for (ov, cache) in ovs.iter().zip(&mut ops) {
                    let other: Vec<usize> =
                        (0..ov.elements.len()).filter(|&l| !ov.owned[l]).collect();
                    let values: Vec<[f64; NT]> = other
                        .iter()
                        .map(|&l| owner_values[ov.elements[l]])
                        .collect();
                    assert!(cache.set_warm_values(&other, &values));
                }
            }
            for (ov, cache) in ovs.iter().zip(&mut ops) {
                let bs = ov.restrict_boundary(&bd);
                let r = ov.restriction();
                let eq = equilibrate_restricted(
                    &ov.mesh,
                    &STEEL,
                    &ov.restrict_dofs(d),
                    &bs,
                    choice,
                    Some(&r),
                    Some(cache),
                    None,
                )
                .unwrap();
                for (le, &ge) in ov.elements.iter().enumerate().filter(|&(l, _)| ov.owned[l]) {
                    let b = full[step].coefficients(ge);
                    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    for (x, y) in eq.coefficients(le).iter().zip(b) {
                        worst = worst.max((x - y).abs() / scale);
                    }
                }
            }
        }
        println!(
            "warm chain, {rings} rings, refresh {refresh}: max coefficient difference {worst:.1e}"
        );
        if refresh {
            assert!(worst < 1e-10, "{rings} rings: {worst:e}");
        } else {
            assert!(worst > 1e-6, "{rings} rings, no refresh: {worst:e}");
        }
    }
}

/// Where exactness sets in: the differences against the ring count (3 sweeps, slabs).
#[test]
fn exactness_against_rings() {
    let (mesh, bd) = block_rect(96, 64);
    let u = fe_solve(&mesh, &bd);
    let part = slabs(&mesh);
    let c = colour_count(&vertex_colours(&mesh));
    println!("colours {c}; rings: max relative difference of cre², of the coefficients");
    let rings = Overlap::rings_for(PATCH3, c);
    let full = equilibrate_with(&mesh, &STEEL, &u, &bd, PATCH3).unwrap();
    for r in 0..=rings {
        let d = partitioned(&mesh, &bd, &u, &full, &part, PATCH3, r);
        println!("{r:3}  {:.2e}  {:.2e}", d.cre, d.coef);
    }
}

#[test]
fn overlap_reads_back_as_written_and_damaged_bytes_are_refused() {
    let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 8, 6);
    let colours = vertex_colours(&mesh);
    let own: Vec<bool> = (0..mesh.triangles.len()).map(|e| e % 3 == 0).collect();
    let ov = Overlap::new(&mesh, &own, 2, &colours);
    let mut w = Writer::default();
    ov.write(&mut w);
    let back = Overlap::read(&mut Reader::new(&w.0)).unwrap();
    assert_eq!(
        (&back.elements, &back.nodes, &back.owned, &back.vertex_key),
        (&ov.elements, &ov.nodes, &ov.owned, &ov.vertex_key)
    );
    assert_eq!(back.mesh.fingerprint(), ov.mesh.fingerprint());
    assert!(Overlap::read(&mut Reader::new(&w.0[..w.0.len() - 1])).is_none());
    // (one owned flag short of the sub-mesh's elements)
    let mut short = ov.clone();
    short.owned.pop();
    let mut w = Writer::default();
    short.write(&mut w);
    assert!(Overlap::read(&mut Reader::new(&w.0)).is_none());
}

/// The rings grown through the vertex stars are those of sweeps over the whole mesh
/// (ring r + 1: every element with a vertex of an element of the rings ≤ r), up to the
/// connected component (`usize::MAX`).
#[test]
fn rings_grown_through_the_stars_are_the_whole_mesh_sweeps() {
    let mesh = Mesh::structured([0.0, 0.0], [3.0, 1.0], 12, 5);
    let colours = vertex_colours(&mesh);
    let mut rng = Lcg(11);
    let own: Vec<bool> = (0..mesh.triangles.len())
        .map(|_| rng.next() > 0.93)
        .collect();
    for rings in [0, 1, 2, 3, 5, usize::MAX] {
        let mut inside = own.clone();
        for _ in 0..rings.min(100) {
            let mut marked = vec![false; mesh.num_nodes()];
            for (t, _) in mesh.triangles.iter().zip(&inside).filter(|(_, &i)| i) {
                t.iter().for_each(|&v| marked[v] = true);
            }
            for (t, i) in mesh.triangles.iter().zip(inside.iter_mut()) {
                *i |= t.iter().any(|&v| marked[v]);
            }
        }
        let swept: Vec<usize> = (0..inside.len()).filter(|&e| inside[e]).collect();
        let ov = Overlap::new(&mesh, &own, rings, &colours);
        assert_eq!(ov.elements, swept, "{rings} rings");
        let owned: Vec<bool> = swept.iter().map(|&e| own[e]).collect();
        assert_eq!(ov.owned, owned, "{rings} rings");
    }
}

#[test]
fn overlap_structure() {
    let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 8, 6);
    let (nt, nn) = (mesh.triangles.len(), mesh.num_nodes());
    let colours = vertex_colours(&mesh);
    assert_eq!(colour_count(&colours), 4);
    let mut rng = Lcg(5);
    let own: Vec<bool> = (0..nt).map(|_| rng.next() > 0.7).collect();
    let ov = Overlap::new(&mesh, &own, 1, &colours);
    assert!(ov.elements.windows(2).all(|w| w[0] < w[1]));
    assert!(ov.nodes.windows(2).all(|w| w[0] < w[1]));
    // Own elements plus exactly those sharing a vertex with one.
    let mut touched = vec![false; nn];
    for (t, _) in mesh.triangles.iter().zip(&own).filter(|(_, &o)| o) {
        t.iter().for_each(|&v| touched[v] = true);
    }
    let expected: Vec<usize> = (0..nt)
        .filter(|&e| mesh.triangles.get(e).iter().any(|&v| touched[v]))
        .collect();
    assert_eq!(ov.elements, expected);
    for (le, &ge) in ov.elements.iter().enumerate() {
        assert_eq!(ov.owned[le], own[ge]);
        assert_eq!(
            ov.mesh.triangles.get(le).map(|v| ov.nodes[v]),
            mesh.triangles.get(ge)
        );
    }
    for (k, &g) in ov.nodes.iter().enumerate() {
        assert_eq!(ov.mesh.points.get(k), mesh.points.get(g));
        assert_eq!(
            ov.vertex_key[k],
            crate::estimate::equilibrate::sweep_key(colours[g], g)
        );
    }
    let u: Vec<f64> = (0..mesh.num_dofs()).map(|d| d as f64).collect();
    let us = ov.restrict_dofs(&u);
    assert_eq!(us.len(), ov.mesh.num_dofs());
    assert!(ov
        .nodes
        .iter()
        .enumerate()
        .all(|(k, &g)| us[2 * k + 1] == (2 * g + 1) as f64));
    // Real boundary edges only: every listed edge is on the full mesh's boundary.
    let (_, bd) = block_rect(8, 6);
    let bs = ov.restrict_boundary(&bd);
    assert!(!bs.edges.is_empty() && bs.edges.len() < bd.edges.len());
    for be in &bs.edges {
        let g = be.nodes.map(|v| ov.nodes[v]);
        assert!(bd.edges.iter().any(|b| b.nodes == g && b.comps == be.comps));
    }
    assert!(ov
        .nodes
        .iter()
        .enumerate()
        .all(|(k, &g)| bs.constrained[2 * k] == bd.constrained[2 * g]));
    // Unbounded rings: the whole (connected) mesh; Recovery::Star asks for that and is
    // refused anyway.
    let rings = Overlap::rings_for(Recovery::star(), 4);
    let all = Overlap::new(&mesh, &own, rings, &colours);
    assert_eq!(all.elements.len(), nt);
    let (_, bd) = block_rect(8, 6);
    let err = equilibrate_restricted(
        &all.mesh,
        &STEEL,
        &all.restrict_dofs(&u),
        &all.restrict_boundary(&bd),
        Recovery::star(),
        Some(&all.restriction()),
        None,
        None,
    );
    assert!(matches!(
        err,
        Err(EquilibrationError::RestrictedMinimumEnergy)
    ));
}
