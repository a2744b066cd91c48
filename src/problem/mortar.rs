//! Mortar operators of two contact curves meshed on their own, with dual multipliers
//! (Wohlmuth 2000; Popp, Gee and Wall 2009 for contact): the contact constraint is integrated
//! along the segments of one curve (the non-mortar side S, a polyline with its nodal normals
//! n_j towards the other) against the other's (the mortar side M) shape functions, no node
//! inserted into either mesh (docs/method.md §7).
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
//! constraint at node j reads g̃_j + n_j·(Σ_k M_jk u^M_k − D_jj u^S_j) ≥ 0. On matching curves
//! M = D and g̃_j = D_jj g₀_j: the node-to-node constraint. A closed curve (a pin's whole
//! circle, a bore) is a polyline whose last point repeats its first, folded onto it
//! ([`Ends::Closed`]). [`Coupling`] puts the operators in the form of the node-to-node algebra
//! (S's node against a point of M's curve), which the NNDD, the monolithic solve and the
//! checks then use unchanged ([`super::GcTrace::Mortar`]).

pub use super::polyline::Ends;
use super::polyline::{lerp, project, ray, sub, unit, Arcs, Foot};

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

/// What the mortar constraint's initial gap g_j is measured to (`-nndd_mortar_gap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GapGeometry {
    /// The distance from S's node j along n_j to the smooth curve through M's nodes
    /// ([`Arcs`]): the curves the meshes sample, exact on circles. Two polygons of one curved
    /// surface meshed on their own differ between their nodes by the chords' heights, which
    /// the pressure would feel as a ripple; the nodes themselves lie on the surfaces.
    #[default]
    Curves,
    /// g̃_j / D_jj: the ψ_j-weighted distance between the polygons as meshed.
    Polygons,
}

/// One contact curve as [`Coupling::new`] takes it: its nodes' mesh numbers and points in
/// order (a closed curve's first node repeated at the end), and for the non-mortar side its
/// nodal normals, towards the other body.
pub struct CurveNodes<'a> {
    pub ids: &'a [usize],
    pub points: &'a [[f64; 2]],
    pub normals: &'a [[f64; 2]],
    pub ends: Ends,
}

/// The mortar coupling of a non-mortar curve S with a mortar curve M, in the form of the
/// node-to-node algebra: one constraint per node j of S that M covers (D_jj > 0),
///   g_j + n_j·(Σ_k P_jk u^M_k − u^S_j) ≥ 0,  P = D⁻¹M,  g = D⁻¹g̃,
/// i.e. S's node against the point Σ_k P_jk x_k of M's curve (P's rows sum to one: M's hat
/// functions sum to one where its curve covers S's), with n_j S's normal towards M as
/// [`Coupling::new`] makes it (the caller may turn it to body 1's direction, the constraint's
/// sign with it). A multiplier T_j, the nodal force along n_j on S's node and P_jk T_j n_j on
/// M's node k, keeps the virtual work: Σ_j T_j n_j·Σ_k P_jk u_k = Σ_k f_k · u_k.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coupling {
    /// S's constrained nodes (mesh numbers), in the curve's order.
    pub nodes: Vec<usize>,
    /// n_j.
    pub normals: Vec<[f64; 2]>,
    /// g_j = g̃_j / D_jj, the weighted initial gap.
    pub gap: Vec<f64>,
    /// Row j of P: (M's mesh node, P_jk).
    pub rows: Vec<Vec<(usize, f64)>>,
    /// The wall time of building it (s; for the summary).
    pub seconds: f64,
    /// Where S is closed and Γc goes all round it: the length of S's segment from the last
    /// pair back to the first, which closes Γc (its pairs run along S from a cut).
    pub closing: Option<f64>,
}

impl Coupling {
    /// The coupling of the non-mortar curve `side` with the mortar curve `mortar`; a node of
    /// `side` that `mortar` does not reach (D_jj below 1e−12 of its segments' length) has no
    /// constraint. The gap g_j is measured as `geometry` says (the weighted one where the
    /// node's normal line misses `mortar`'s curve).
    pub fn new(side: &CurveNodes, mortar: &CurveNodes, geometry: GapGeometry) -> Coupling {
        let started = std::time::Instant::now();
        let op = operators(
            side.points,
            side.normals,
            mortar.points,
            [side.ends, mortar.ends],
        );
        let distinct = |c: &CurveNodes| match c.ends {
            Ends::Open => c.ids.len(),
            Ends::Closed => c.ids.len() - 1,
        };
        let near = |j: usize| {
            let n = side.points.len();
            let len = |a: usize, b: usize| {
                let e = sub(side.points[b], side.points[a]);
                e[0].hypot(e[1])
            };
            let before = if j > 0 { len(j - 1, j) } else { 0.0 };
            let after = if j + 1 < n { len(j, j + 1) } else { 0.0 };
            let wrap = match side.ends {
                Ends::Closed if j == 0 => len(n - 2, n - 1),
                _ => 0.0,
            };
            before + after + wrap
        };
        let arcs = Arcs::new(mortar.points, mortar.ends);
        let mut c = Coupling::default();
        for j in 0..distinct(side) {
            let d = op.d[j];
            if d <= 1e-12 * near(j) {
                continue;
            }
            c.nodes.push(side.ids[j]);
            c.normals.push(side.normals[j]);
            c.gap.push(
                match geometry {
                    GapGeometry::Curves => {
                        // (the crossing lies by the mortar nodes of j's row)
                        let hint = op.m[j].first().map_or(0, |e| e.0)
                            ..op.m[j].last().map_or(0, |e| e.0 + 1);
                        arcs.ray(side.points[j], side.normals[j], hint)
                    }
                    GapGeometry::Polygons => None,
                }
                .unwrap_or(op.gap[j] / d),
            );
            c.rows.push(
                op.m[j]
                    .iter()
                    .map(|&(k, v)| (mortar.ids[k], v / d))
                    .collect(),
            );
        }
        c.seconds = started.elapsed().as_secs_f64();
        c
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// M's normal trace n_j·Σ_k P_jk u_k at each constraint (u in global components).
    pub fn mortar_trace<U: crate::fem::Dofs + ?Sized>(&self, u2: &U) -> Vec<f64> {
        self.rows
            .iter()
            .zip(&self.normals)
            .map(|(row, n)| {
                row.iter()
                    .map(|&(k, p)| p * (n[0] * u2[2 * k] + n[1] * u2[2 * k + 1]))
                    .sum()
            })
            .collect()
    }
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
/// towards the other body) against the mortar polyline `mortar`. A closed curve's repeated
/// last point is folded onto its first ([`Ends::Closed`]): D, g̃ and M's rows are then those
/// of its distinct nodes, its last entry (row or column) empty.
pub fn operators(
    side: &[[f64; 2]],
    normals: &[[f64; 2]],
    mortar: &[[f64; 2]],
    ends: [Ends; 2],
) -> Operators {
    let mut op = polyline_operators(side, normals, mortar);
    if ends[1] == Ends::Closed {
        let last = mortar.len() - 1;
        for row in &mut op.m {
            if let Some(pos) = row.iter().position(|&(k, _)| k == last) {
                let (_, v) = row.remove(pos);
                match row.iter_mut().find(|(k, _)| *k == 0) {
                    Some(first) => first.1 += v,
                    None => row.insert(0, (0, v)),
                }
            }
        }
    }
    if ends[0] == Ends::Closed {
        let last = side.len() - 1;
        op.d[0] += std::mem::take(&mut op.d[last]);
        op.gap[0] += std::mem::take(&mut op.gap[last]);
        for (k, v) in std::mem::take(&mut op.m[last]) {
            match op.m[0].iter_mut().find(|(c, _)| *c == k) {
                Some(e) => e.1 += v,
                None => op.m[0].push((k, v)),
            }
        }
        op.m[0].sort_by_key(|&(k, _)| k);
    }
    op
}

/// [`operators`] of two polylines, each point a node.
fn polyline_operators(side: &[[f64; 2]], normals: &[[f64; 2]], mortar: &[[f64; 2]]) -> Operators {
    let n = side.len();
    let mut d = vec![0.0; n];
    let mut rows: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n];
    let mut gap = vec![0.0; n];
    // Where each mortar node projects onto the non-mortar side: the breaks of the integrands.
    let mut breaks: Vec<Vec<f64>> = vec![vec![0.0, 1.0]; n.saturating_sub(1)];
    // The mortar nodes that project onto each segment: where its points' feet lie.
    let mut near: Vec<Vec<usize>> = vec![Vec::new(); n.saturating_sub(1)];
    for (k, &q) in mortar.iter().enumerate() {
        if let Some(f) = project(q, side, normals) {
            breaks[f.k].push(f.t);
            near[f.k].push(k);
        }
    }
    // The mortar segments around those of segment j and its neighbours (all where none).
    let window = |j: usize| {
        let around = near[j.saturating_sub(1)..(j + 2).min(near.len())]
            .iter()
            .flatten();
        let (lo, hi) = around.fold((usize::MAX, 0), |(a, b), &k| (a.min(k), b.max(k)));
        if lo > hi {
            0..mortar.len()
        } else {
            lo.saturating_sub(1)..(hi + 2).min(mortar.len())
        }
    };
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
                if let Some(foot) = ray_near(p, nu, mortar, window(j)) {
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

/// [`ray`] on the segments of `mortar` between the nodes `range` (a window around where the
/// line should meet it), else on all of them.
fn ray_near(
    x: [f64; 2],
    n: [f64; 2],
    mortar: &[[f64; 2]],
    range: std::ops::Range<usize>,
) -> Option<Foot> {
    let whole = range.len() == mortar.len();
    let start = range.start;
    match ray(x, n, &mortar[range]) {
        Some(f) => Some(Foot {
            k: f.k + start,
            ..f
        }),
        None if !whole => ray(x, n, mortar),
        None => None,
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

    /// The arc of radius r about the origin over the angles [−half, half] from (0, −r), in m
    /// segments.
    fn arc(r: f64, m: usize, half: f64) -> Vec<[f64; 2]> {
        (0..=m)
            .map(|i| {
                let t = -half + 2.0 * half * i as f64 / m as f64;
                [r * t.sin(), -r * t.cos()]
            })
            .collect()
    }

    /// The coupling of the open curves `curves` (non-mortar, mortar; nodal normals `normals` of
    /// the first) whose nodes are the mesh nodes `ids`.
    fn open_coupling(
        curves: [&[[f64; 2]]; 2],
        normals: &[[f64; 2]],
        ids: [&[usize]; 2],
        geometry: GapGeometry,
    ) -> Coupling {
        Coupling::new(
            &CurveNodes {
                ids: ids[0],
                points: curves[0],
                normals,
                ends: Ends::Open,
            },
            &CurveNodes {
                ids: ids[1],
                points: curves[1],
                normals: &[],
                ends: Ends::Open,
            },
            geometry,
        )
    }

    /// Points of y = h at the given x.
    fn line(xs: &[f64], h: f64) -> Vec<[f64; 2]> {
        xs.iter().map(|&x| [x, h]).collect()
    }

    #[test]
    fn matching_curves_give_the_node_to_node_constraint() {
        // A curved side: an arc of radius 1, body 2 on the same nodes.
        let side = arc(1.0, 8, 0.6);
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
        let op = operators(&side, &normals, &side, [Ends::Open; 2]);
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
            let op = operators(&side, &normals, &mortar, [Ends::Open; 2]);
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
        let op = operators(
            &side,
            &vec![[0.0, 1.0]; side.len()],
            &mortar,
            [Ends::Open; 2],
        );
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
            let side = arc(1.0, 2 * n, 0.5);
            let mortar = arc(1.0 + c, 3 * n, 0.6);
            // The pin's outward normals (radial), towards the hole.
            let normals: Vec<[f64; 2]> = side.iter().map(|p| unit(*p)).collect();
            let op = operators(&side, &normals, &mortar, [Ends::Open; 2]);
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

    /// A pin's whole circle (radius 1, 2n segments, the non-mortar side) in a bore (radius
    /// 1 + c, 3n segments), both closed: the repeated node folds onto the first, D sums to
    /// the pin polygon's perimeter, M's rows sum to D across the seam, the weighted gap is the
    /// clearance to O(h²), and every node of the pin is constrained once.
    #[test]
    fn a_pin_in_a_bore_all_round() {
        let c = 0.02;
        let n = 16;
        let circle = |r: f64, m: usize| -> Vec<[f64; 2]> {
            (0..=m)
                .map(|i| {
                    let t = std::f64::consts::TAU * (i % m) as f64 / m as f64;
                    [r * t.sin(), -r * t.cos()]
                })
                .collect()
        };
        let side = circle(1.0, 2 * n);
        let mortar = circle(1.0 + c, 3 * n);
        let normals: Vec<[f64; 2]> = side.iter().map(|p| unit(*p)).collect();
        let op = operators(&side, &normals, &mortar, [Ends::Closed; 2]);
        let perimeter: f64 = side
            .windows(2)
            .map(|w| {
                let e = sub(w[1], w[0]);
                e[0].hypot(e[1])
            })
            .sum();
        assert!((op.d.iter().sum::<f64>() - perimeter).abs() < 1e-13);
        assert_eq!(op.d[2 * n], 0.0);
        assert!(op.m[2 * n].is_empty());
        let h = std::f64::consts::TAU / (2 * n) as f64;
        for j in 0..2 * n {
            assert!(op.m[j].iter().all(|&(k, _)| k < 3 * n), "row {j}");
            assert!((row_sum(&op.m[j]) - op.d[j]).abs() < 1e-13, "row {j}");
            let err = (op.gap[j] / op.d[j] - c).abs() / c;
            assert!(err < 0.5 * h * h / c, "row {j}: relative gap error {err:e}");
        }
        let ids1: Vec<usize> = (0..=2 * n).map(|i| 100 + i % (2 * n)).collect();
        let ids2: Vec<usize> = (0..=3 * n).map(|i| i % (3 * n)).collect();
        let coupling = Coupling::new(
            &CurveNodes {
                ids: &ids1,
                points: &side,
                normals: &normals,
                ends: Ends::Closed,
            },
            &CurveNodes {
                ids: &ids2,
                points: &mortar,
                normals: &[],
                ends: Ends::Closed,
            },
            GapGeometry::Curves,
        );
        assert_eq!(coupling.nodes, ids1[..2 * n].to_vec());
        for row in &coupling.rows {
            assert!((row_sum(row) - 1.0).abs() < 1e-13);
        }
        // Measured to the circle through the mortar nodes, the gap is the clearance itself.
        for (j, g) in coupling.gap.iter().enumerate() {
            assert!(
                (g - c).abs() < 1e-12 * c,
                "node {j}: gap {g:e} against {c:e}"
            );
        }
    }

    /// The coupling of flat sides meshed 10:17 with body 2 a gap g above: body 2's trace of an
    /// affine displacement is that field at (x_j, g) along n.
    #[test]
    fn the_coupling_traces_affine_fields() {
        let g = 0.01;
        let xs1: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let xs2: Vec<f64> = (0..=17).map(|i| -0.05 + 1.1 * i as f64 / 17.0).collect();
        let (side, mortar) = (line(&xs1, 0.0), line(&xs2, g));
        let normals = vec![[0.0, 1.0]; side.len()];
        let ids1: Vec<usize> = (0..side.len()).collect();
        // Body 2's curve nodes are mesh nodes 3, 5, 7, … of a larger mesh.
        let ids2: Vec<usize> = (0..mortar.len()).map(|k| 3 + 2 * k).collect();
        let c = open_coupling(
            [&side, &mortar],
            &normals,
            [&ids1, &ids2],
            GapGeometry::Curves,
        );
        assert_eq!(c.len(), side.len());
        let nodes2 = 3 + 2 * mortar.len();
        let field = |x: [f64; 2]| {
            [
                0.3 + 2.0 * x[0] - 0.7 * x[1],
                -0.1 + 0.4 * x[0] + 1.5 * x[1],
            ]
        };
        let mut u2 = vec![0.0; 2 * nodes2];
        for (k, &id) in ids2.iter().enumerate() {
            let u = field(mortar[k]);
            u2[2 * id] = u[0];
            u2[2 * id + 1] = u[1];
        }
        let trace = c.mortar_trace(&u2);
        for (j, x) in side.iter().enumerate() {
            assert!((c.gap[j] - g).abs() < 1e-14, "gap {j}");
            let want = field([x[0], g])[1];
            assert!(
                (trace[j] - want).abs() < 1e-13,
                "trace {j}: {} vs {want}",
                trace[j]
            );
        }
    }

    /// The weighted gap g̃_j = ∫ψ_j g of a hole's arc (radius 1 + c, the non-mortar side) over
    /// a pin's (radius 1) meshed 2:3 and 1:10 is the integral of the polygons' distance along
    /// the interpolated normals: against a 20 000-point midpoint rule per segment, to 1e−10 of
    /// the clearance (the rule's own error; the Gauss rules between the mortar nodes'
    /// projections integrate the smooth pieces to round-off).
    #[test]
    fn the_weighted_gap_is_the_integral_of_the_polygons_distance() {
        let c = 0.02;
        for (n1, n2) in [(32usize, 48usize), (32, 320)] {
            let side = arc(1.0 + c, n1, 0.5);
            let mortar = arc(1.0, n2, 0.6);
            // The hole's normals point inwards, towards the pin.
            let normals: Vec<[f64; 2]> = side
                .iter()
                .map(|p| {
                    let u = unit(*p);
                    [-u[0], -u[1]]
                })
                .collect();
            let op = operators(&side, &normals, &mortar, [Ends::Open; 2]);
            let mut worst: f64 = 0.0;
            for j in (1..n1).step_by(5) {
                let mut g = 0.0;
                for seg in [j - 1, j] {
                    let len = {
                        let e = sub(side[seg + 1], side[seg]);
                        e[0].hypot(e[1])
                    };
                    let points = 20_000;
                    for q in 0..points {
                        let t = (q as f64 + 0.5) / points as f64;
                        let nu = unit(lerp(normals[seg], normals[seg + 1], t));
                        let foot = ray(lerp(side[seg], side[seg + 1], t), nu, &mortar).unwrap();
                        let (own, other) = if seg == j { (1.0 - t, t) } else { (t, 1.0 - t) };
                        g += len / points as f64 * (2.0 * own - other) * foot.s;
                    }
                }
                worst = worst.max((g - op.gap[j]).abs() / op.d[j] / c);
            }
            assert!(
                worst < 1e-10,
                "{n1}:{n2}: weighted gap off by {worst:e} of c"
            );
        }
    }

    /// A hole's arc (radius 1 + c, the non-mortar side, evenly meshed) over a pin's (radius 1)
    /// meshed 1:10 at uneven spacing: measured to the curves, every node's gap is the clearance
    /// to 1e−12 of it; measured between the polygons it is off by the chords' heights.
    #[test]
    fn the_gap_to_the_curves_is_exact_on_circles() {
        let c = 2e-3;
        let side = arc(1.0 + c, 8, 0.5);
        let mortar: Vec<[f64; 2]> = (0..=80)
            .map(|i| {
                let u = i as f64 / 80.0;
                let t = -0.6 + 1.2 * (u + 0.03 * (7.0 * u).sin());
                [t.sin(), -t.cos()]
            })
            .collect();
        let normals: Vec<[f64; 2]> = side.iter().map(|p| unit([-p[0], -p[1]])).collect();
        let ids1: Vec<usize> = (0..side.len()).collect();
        let ids2: Vec<usize> = (0..mortar.len()).collect();
        let couple = |geometry| open_coupling([&side, &mortar], &normals, [&ids1, &ids2], geometry);
        let worst = |cp: &Coupling| cp.gap.iter().fold(0.0_f64, |m, g| m.max((g - c).abs() / c));
        let (curves, polygons) = (couple(GapGeometry::Curves), couple(GapGeometry::Polygons));
        assert_eq!(curves.len(), side.len());
        assert!(worst(&curves) < 1e-12, "curves: {:e}", worst(&curves));
        assert!(worst(&polygons) > 1e-4, "polygons: {:e}", worst(&polygons));
    }

    /// A corner of the mortar polyline is not rounded: the gap to a right-angled corner's legs is
    /// the distance to the polygon.
    #[test]
    fn a_corner_is_not_rounded() {
        // The mortar side: a corner at (0, 1), legs down to (−1, 0) and (1, 0) in three segments
        // each; the non-mortar side straight at y = −0.1 below it.
        let mut mortar: Vec<[f64; 2]> = (0..=3)
            .map(|i| {
                let t = i as f64 / 3.0;
                [-1.0 + t, t]
            })
            .collect();
        mortar.extend((1..=3).map(|i| {
            let t = i as f64 / 3.0;
            [t, 1.0 - t]
        }));
        let arcs = Arcs::new(&mortar, Ends::Open);
        for x in [-0.9, -0.5, -0.01, 0.2, 0.7] {
            let s = arcs
                .ray([x, -0.1], [0.0, 1.0], 0..0)
                .expect("the ray meets the legs");
            let want = 1.0 - x.abs() + 0.1;
            assert!((s - want).abs() < 1e-14, "at x = {x}: {s} vs {want}");
        }
    }
}
