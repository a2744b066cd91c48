//! Mortar operators of two contact curves meshed on their own, with dual multipliers
//! (Wohlmuth 2000; Popp, Gee and Wall 2009 for contact): the contact constraint is integrated
//! along the segments of one curve (the non-mortar side, body 1's polyline with its nodal
//! normals n_j) against the other's shape functions, no node inserted into either mesh.
//!
//! On each non-mortar segment [j, j+1] (parameter t, length |e|) the dual basis ψ_j = 2φ_j −
//! φ_{j+1}, ψ_{j+1} = 2φ_{j+1} − φ_j is biorthogonal to the hat functions: ∫ψ_i φ_k = δ_ik ∫φ_k.
//! The point p(t) is paired with the point where its line along the interpolated normal
//! ν(t) ∝ (1 − t)n_j + t n_{j+1} meets the mortar polyline (the normal field of
//! docs/method.md §5 and of the matching of [`super::conform`]), at distance g(t) along ν. Then
//! - D_jj = ∫ ψ_j φ_j ds = ∫ φ_j ds (diagonal: the constraint stays nodal),
//! - M_jk = ∫ ψ_j N_k ds, N_k the mortar side's hat functions at the paired point,
//! - g̃_j = ∫ ψ_j g ds, the weighted gap,
//!
//! each over the part of the non-mortar side the mortar side covers, integrated between the
//! projections of the mortar nodes (where N_k is smooth) by Gauss–Legendre rules. On a segment
//! the mortar side covers only in part (the ends of Γc), the dual basis is made biorthogonal on
//! the covered part (ψ = Aφ, A = D_e M_e⁻¹ with the segment's mass matrices over that part:
//! the consistent dual functions of Cichosz and Bischoff, 2011), so that D stays diagonal and
//! the patch test holds there too. The discrete
//! constraint at node j reads g̃_j + n_j·(Σ_k M_jk u²_k − D_jj u¹_j) ≥ 0. On matching curves
//! M = D and g̃_j = D_jj g₀_j: the node-to-node constraint. Not yet used by the NNDD (its
//! interface algebra pairs nodes); the operators and their tests come first.

use super::polyline::{lerp, project, ray, sub, unit};

/// The mortar operators of one pair of curves ([`operators`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Operators {
    /// D_jj per non-mortar node.
    pub d: Vec<f64>,
    /// Row j of M: (mortar node k, M_jk), by increasing k.
    pub m: Vec<Vec<(usize, f64)>>,
    /// g̃_j per non-mortar node.
    pub gap: Vec<f64>,
}

/// Gauss–Legendre points and weights on [0, 1], 5 points (exact to degree 9).
const GAUSS: [(f64, f64); 5] = [
    (0.046_910_077_030_668, 0.118_463_442_528_094_5),
    (0.230_765_344_947_158_5, 0.239_314_335_249_683_2),
    (0.5, 0.284_444_444_444_444_4),
    (0.769_234_655_052_841_5, 0.239_314_335_249_683_2),
    (0.953_089_922_969_332, 0.118_463_442_528_094_5),
];

/// The mortar operators of the non-mortar polyline `side` (nodal normals `normals`, pointing
/// towards the other body) against the mortar polyline `mortar`.
pub fn operators(side: &[[f64; 2]], normals: &[[f64; 2]], mortar: &[[f64; 2]]) -> Operators {
    let n = side.len();
    let mut d = vec![0.0; n];
    let mut rows: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n];
    let mut gap = vec![0.0; n];
    // Where each mortar node projects onto the non-mortar side: the breaks of the integrands.
    let mut breaks: Vec<Vec<f64>> = vec![vec![0.0, 1.0]; n.saturating_sub(1)];
    for &q in mortar {
        if let Some(f) = project(q, side, normals) {
            breaks[f.k].push(f.t);
        }
    }
    for (j, cuts) in breaks.iter_mut().enumerate() {
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-14);
        let len = {
            let e = sub(side[j + 1], side[j]);
            e[0].hypot(e[1])
        };
        // The points of the pieces the mortar side covers, with their feet on it.
        let mut points = Vec::new();
        for w in cuts.windows(2) {
            let (t0, t1) = (w[0], w[1]);
            for (x, wt) in GAUSS {
                let t = t0 + (t1 - t0) * x;
                let nu = unit(lerp(normals[j], normals[j + 1], t));
                let p = lerp(side[j], side[j + 1], t);
                // (none: the mortar side does not reach here)
                if let Some(foot) = ray(p, nu, mortar) {
                    points.push((t, wt * (t1 - t0) * len, foot));
                }
            }
        }
        let dual = dual_coefficients(points.iter().map(|&(t, ds, _)| (t, ds)));
        for (t, ds, foot) in points {
            let phi = [1.0 - t, t];
            let psi = [
                dual[0][0] * phi[0] + dual[0][1] * phi[1],
                dual[1][0] * phi[0] + dual[1][1] * phi[1],
            ];
            for a in 0..2 {
                d[j + a] += ds * psi[a] * phi[a];
                gap[j + a] += ds * psi[a] * foot.s;
                for (b, nk) in [(0, 1.0 - foot.t), (1, foot.t)] {
                    *rows[j + a].entry(foot.k + b).or_insert(0.0) += ds * psi[a] * nk;
                }
            }
        }
    }
    Operators {
        d,
        m: rows.into_iter().map(|r| r.into_iter().collect()).collect(),
        gap,
    }
}

/// The dual basis ψ_a = Σ_b A_ab φ_b of one segment, biorthogonal over the quadrature points
/// `points` (t, weight): A = D_e M_e⁻¹, M_e the mass matrix of φ = (1 − t, t) and D_e its row
/// sums. On a whole segment A = [[2, −1], [−1, 2]]; zero where nothing is covered.
fn dual_coefficients(points: impl Iterator<Item = (f64, f64)>) -> [[f64; 2]; 2] {
    let mut m = [[0.0; 2]; 2];
    for (t, w) in points {
        let phi = [1.0 - t, t];
        for a in 0..2 {
            for b in 0..2 {
                m[a][b] += w * phi[a] * phi[b];
            }
        }
    }
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let scale = (m[0][0] + m[1][1]).powi(2);
    if scale == 0.0 || det.abs() <= 1e-14 * scale {
        // Nothing covered, or a sliver: the lumped (diagonal) mass, ψ = φ / its row sum share.
        let d = [m[0][0] + m[0][1], m[1][0] + m[1][1]];
        return [0, 1].map(|a| {
            let mut r = [0.0; 2];
            if m[a][a] > 0.0 {
                r[a] = d[a] / m[a][a];
            }
            r
        });
    }
    let inv = [
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ];
    let d = [m[0][0] + m[0][1], m[1][0] + m[1][1]];
    [0, 1].map(|a| [d[a] * inv[a][0], d[a] * inv[a][1]])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row_sum(m: &[(usize, f64)]) -> f64 {
        m.iter().map(|(_, v)| v).sum()
    }

    /// Points of y = h at the given x.
    fn line(xs: &[f64], h: f64) -> Vec<[f64; 2]> {
        xs.iter().map(|&x| [x, h]).collect()
    }

    #[test]
    fn matching_curves_give_the_node_to_node_constraint() {
        // A curved side: an arc of radius 1, body 2 on the same nodes.
        let th: Vec<f64> = (0..=8).map(|i| -0.6 + 0.15 * i as f64).collect();
        let side: Vec<[f64; 2]> = th.iter().map(|t| [t.sin(), -t.cos()]).collect();
        let normals: Vec<[f64; 2]> = {
            let seg: Vec<[f64; 2]> = side
                .windows(2)
                .map(|w| {
                    let e = sub(w[1], w[0]);
                    unit([-e[1], e[0]])
                })
                .collect();
            (0..side.len())
                .map(|k| {
                    let (a, b) = (seg[k.saturating_sub(1)], seg[k.min(seg.len() - 1)]);
                    unit([a[0] + b[0], a[1] + b[1]])
                })
                .collect()
        };
        let op = operators(&side, &normals, &side);
        for j in 0..side.len() {
            for &(k, v) in &op.m[j] {
                let expected = if k == j { op.d[j] } else { 0.0 };
                assert!(
                    (v - expected).abs() < 1e-14,
                    "M[{j}][{k}] = {v:e}, D {:e}",
                    op.d[j]
                );
            }
            assert!(op.gap[j].abs() < 1e-15);
        }
        // D sums to Γc's length.
        let length: f64 = side
            .windows(2)
            .map(|w| {
                let e = sub(w[1], w[0]);
                e[0].hypot(e[1])
            })
            .sum();
        assert!((op.d.iter().sum::<f64>() - length).abs() < 1e-14);
    }

    /// Two flat sides meshed on their own (ratios 1:1.7, 3:1, 1:10, 10:1), body 2 a distance g
    /// above and reaching beyond both ends: the mortar side's hat functions sum to one and
    /// reproduce linear functions, so Σ_k M_jk = D_jj, Σ_k M_jk x_k = D_jj x_j and g̃_j = D_jj g
    /// exactly (the patch test at the level of the operators).
    #[test]
    fn flat_sides_meshed_on_their_own_pass_the_patch_test() {
        let g = 0.01;
        for (n1, n2) in [(10, 17), (30, 10), (4, 40), (40, 4)] {
            let xs1: Vec<f64> = (0..=n1).map(|i| i as f64 / n1 as f64).collect();
            // Body 2's nodes: uneven, reaching beyond [0, 1].
            let xs2: Vec<f64> = (0..=n2)
                .map(|i| {
                    let u = i as f64 / n2 as f64;
                    -0.05 + 1.1 * (u + 0.03 * (7.0 * u).sin())
                })
                .collect();
            let (side, mortar) = (line(&xs1, 0.0), line(&xs2, g));
            let normals = vec![[0.0, 1.0]; side.len()];
            let op = operators(&side, &normals, &mortar);
            for (j, x) in side.iter().enumerate() {
                let s = row_sum(&op.m[j]);
                let first: f64 = op.m[j].iter().map(|&(k, v)| v * mortar[k][0]).sum();
                let tol = 1e-13;
                assert!(
                    (s - op.d[j]).abs() < tol,
                    "{n1}:{n2} row {j}: {s:e} vs {:e}",
                    op.d[j]
                );
                assert!((first - op.d[j] * x[0]).abs() < tol, "{n1}:{n2} row {j}: x");
                assert!(
                    (op.gap[j] - op.d[j] * g).abs() < tol * g,
                    "{n1}:{n2} row {j}: gap"
                );
            }
            assert!((op.d.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
    }

    /// A mortar side shorter than the non-mortar one, ending inside two of its segments: the
    /// dual basis made biorthogonal on the covered parts keeps D diagonal with D's sum the
    /// covered length, and the patch test (rows sum to D, linear functions reproduced).
    #[test]
    fn a_partly_covered_side_keeps_the_patch_test() {
        let g = 0.02;
        let xs1: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let xs2: Vec<f64> = (0..=7).map(|i| 0.33 + 0.38 * i as f64 / 7.0).collect();
        let (side, mortar) = (line(&xs1, 0.0), line(&xs2, g));
        let op = operators(&side, &vec![[0.0, 1.0]; side.len()], &mortar);
        assert!(
            (op.d.iter().sum::<f64>() - 0.38).abs() < 1e-14,
            "{:?}",
            op.d
        );
        for (j, x) in side.iter().enumerate() {
            let s = row_sum(&op.m[j]);
            let first: f64 = op.m[j].iter().map(|&(k, v)| v * mortar[k][0]).sum();
            assert!(
                (s - op.d[j]).abs() < 1e-14,
                "row {j}: {s:e} vs {:e}",
                op.d[j]
            );
            assert!((first - op.d[j] * x[0]).abs() < 1e-14, "row {j}: x");
            assert!((op.gap[j] - op.d[j] * g).abs() < 1e-14 * g, "row {j}: gap");
            // Nodes whose segments the mortar side does not reach have no constraint.
            if x[0] < 0.2 || x[0] > 0.8 {
                assert_eq!(op.d[j], 0.0, "row {j}");
            }
        }
    }

    /// Concentric arcs (a pin of radius 1 in a hole of radius 1 + c, meshed 2:3): the weighted
    /// gap per unit D is the clearance measured along the interpolated normals, c to O(h²), and
    /// M's rows still sum to D (the hole's hat functions sum to one where it covers the pin).
    #[test]
    fn concentric_arcs_meshed_on_their_own() {
        let c = 0.02;
        for n in [8, 16, 32] {
            let arc = |r: f64, m: usize, half: f64| -> Vec<[f64; 2]> {
                (0..=m)
                    .map(|i| {
                        let t = -half + 2.0 * half * i as f64 / m as f64;
                        [r * t.sin(), -r * t.cos()]
                    })
                    .collect()
            };
            let side = arc(1.0, 2 * n, 0.5);
            let mortar = arc(1.0 + c, 3 * n, 0.6);
            // The pin's outward normals (radial), towards the hole.
            let normals: Vec<[f64; 2]> = side.iter().map(|p| unit(*p)).collect();
            let op = operators(&side, &normals, &mortar);
            let mut worst: f64 = 0.0;
            for j in 0..side.len() {
                assert!((row_sum(&op.m[j]) - op.d[j]).abs() < 1e-13 * op.d[j].abs().max(1e-3));
                worst = worst.max((op.gap[j] / op.d[j] - c).abs() / c);
            }
            // The chords: the polygons' distance differs from c by about h²/8 · (1 + 1/(1 + c)).
            let h = 1.0 / (2 * n) as f64;
            assert!(
                worst < 0.5 * h * h / c,
                "n {n}: relative gap error {worst:e}"
            );
        }
    }
}
