//! The contact half of η^glo's admissible pair on a polygonal Γc (docs/method.md §5, "The
//! admissible pair" and "The bound"). The continuous problem pairs the point at fraction t of body 1's
//! segment [k, k+1] with the point at fraction t of body 2's, and constrains their distance
//! along ν(t) = m(t)/|m(t)|, m(t) = (1 − t) n_k + t n_{k+1} (the nodal normals interpolated):
//! G(v)(t) = d(t)·ν(t) ≥ 0 with d = (x² + v²) − (x¹ + v¹). With G̃ = d·m = |m| G:
//!
//! - **The traction** must be parallel to ν and compressive, t̂¹ = −p̂ν with p̂ ≥ 0. A linear
//!   vector traction is parallel to m(t) at every t only as t̂¹ = s m(t) with s constant when
//!   n_k ≠ n_{k+1}; on such a segment s is the mean of the admissible density g ≤ 0 at its
//!   two ends (the same resultant), on a straight one s = g, linear. [`edge_traction`].
//! - **The displacement** must satisfy G(û) ≥ 0 between the nodes, not only at them. With d
//!   and m linear in t, G̃(t) = (1 − t)G_k + tG_{k+1} − t(1 − t)D, D = (d_{k+1} − d_k)·(n_{k+1}
//!   − n_k), so the FE iterate (G_k ≥ 0 at the nodes) may violate it by t(1 − t)D. Adding
//!   to body 2 the edge bubble δ = c φ_a φ_b w, with w·n_k = w·n_{k+1} = 1, adds c t(1 − t)
//!   to G̃: û = u_p + δ satisfies G(û) ≥ 0 everywhere for any c ≥ D − (√G_k + √G_{k+1})²
//!   ([`SegmentGap::least_amplitude`]); the estimator chooses c in that range
//!   ([`choose_amplitudes`]).
//!
//! The contact term of η^glo is then 2∫ p̂ G(û) ds = −2|e| ∫₀¹ s(t) G̃_c(t) dt per segment
//! ([`contact_term`]), and ‖Kε(δ)‖ enters the body-2 element of the segment
//! ([`Bubble::strain`]). On a straight segment D = 0: no bubble, and everything is the
//! P1 construction of §3.2.

/// A traction on one Γc segment: its (x, y) values at the segment's two ends, linear between,
/// per unit length of body 1's side.
pub type EdgeValues = [[f64; 2]; 2];

/// Whether a segment's two end normals differ beyond round-off (a segment of a curved side,
/// or one next to a corner).
pub fn turns(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() > 1e-12 || (a[1] - b[1]).abs() > 1e-12
}

/// The factors s of t̂¹(t) = s(t) m(t) at each segment's two ends, from the admissible normal
/// density `g` ≤ 0 at the nodes: g itself on a straight segment, its mean on one that turns.
pub fn factors(normals: &[[f64; 2]], g: &[f64]) -> Vec<[f64; 2]> {
    (0..g.len().saturating_sub(1))
        .map(|k| {
            if turns(normals[k], normals[k + 1]) {
                let q = 0.5 * (g[k] + g[k + 1]);
                [q, q]
            } else {
                [g[k], g[k + 1]]
            }
        })
        .collect()
}

/// Body 1's traction s(t) m(t) on each segment ([`factors`]) as edge values.
pub fn edge_traction(normals: &[[f64; 2]], factors: &[[f64; 2]]) -> Vec<EdgeValues> {
    factors
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (a, b) = (normals[k], normals[k + 1]);
            [[s[0] * a[0], s[0] * a[1]], [s[1] * b[0], s[1] * b[1]]]
        })
        .collect()
}

/// The edge values of a P1 vector density given at the nodes (continuous along Γc).
pub fn nodal_edges(c: &[[f64; 2]]) -> Vec<EdgeValues> {
    c.windows(2).map(|w| [w[0], w[1]]).collect()
}

/// The consistent nodal forces (x, y) of edge tractions on segments of body 1's `lengths`:
/// f_a = L(2t_a + t_b)/6, f_b = L(t_a + 2t_b)/6 per segment.
pub fn nodal_forces(lengths: &[f64], edges: &[EdgeValues]) -> Vec<[f64; 2]> {
    let mut f = vec![[0.0; 2]; edges.len() + 1];
    for (k, (l, [ta, tb])) in lengths.iter().zip(edges).enumerate() {
        for c in 0..2 {
            f[k][c] += l / 6.0 * (2.0 * ta[c] + tb[c]);
            f[k + 1][c] += l / 6.0 * (ta[c] + 2.0 * tb[c]);
        }
    }
    f
}

/// G̃ = d·m along one segment, and the bubbles that keep it ≥ 0 between the nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentGap {
    /// G_k, G_{k+1}: the gap along the nodal normal at the two ends (≥ 0 for the iterate).
    pub ends: [f64; 2],
    /// D = (d_{k+1} − d_k)·(n_{k+1} − n_k): G̃(t) = (1 − t)G_k + tG_{k+1} − t(1 − t)D.
    pub curvature_term: f64,
    /// Whether the segment's normals turn (else D = 0 and it takes no bubble).
    pub turns: bool,
}

impl SegmentGap {
    /// The least bubble amplitude that keeps G̃ ≥ 0 on [0, 1]: (1 − t)A + tB − k t(1 − t) ≥ 0
    /// for all t iff k ≤ (√A + √B)² (min_t A/t + B/(1 − t)), so c ≥ D − (√G_k + √G_{k+1})²
    /// (the nodal gaps taken ≥ 0: round-off). 0 on a straight segment.
    pub fn least_amplitude(&self) -> f64 {
        if !self.turns {
            return 0.0;
        }
        let r = self.ends[0].max(0.0).sqrt() + self.ends[1].max(0.0).sqrt();
        self.curvature_term - r * r
    }

    /// G̃ of û = u_p + δ at fraction t for the bubble amplitude c: (1 − t)G_k + tG_{k+1} +
    /// t(1 − t)(c − D).
    pub fn corrected(&self, t: f64, c: f64) -> f64 {
        (1.0 - t) * self.ends[0] + t * self.ends[1] + t * (1.0 - t) * (c - self.curvature_term)
    }
}

/// The segments' gaps of the displacement jumps `jumps` = û²_k − û¹_k (x, y) at the pairs, the
/// initial gaps `g0` along the nodal `normals` (body 2's node at x¹_k + g₀_k n_k).
pub fn segment_gaps(normals: &[[f64; 2]], g0: &[f64], jumps: &[[f64; 2]]) -> Vec<SegmentGap> {
    let d: Vec<[f64; 2]> = (0..g0.len())
        .map(|k| {
            let n = normals[k];
            [g0[k] * n[0] + jumps[k][0], g0[k] * n[1] + jumps[k][1]]
        })
        .collect();
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    (0..g0.len().saturating_sub(1))
        .map(|k| {
            let (na, nb) = (normals[k], normals[k + 1]);
            let dd = [d[k + 1][0] - d[k][0], d[k + 1][1] - d[k][1]];
            let turns = turns(na, nb);
            SegmentGap {
                ends: [dot(d[k], na), dot(d[k + 1], nb)],
                curvature_term: if turns {
                    dot(dd, [nb[0] - na[0], nb[1] - na[1]])
                } else {
                    0.0
                },
                turns,
            }
        })
        .collect()
}

/// The contact term 2∫ p̂ G(û) ds of one segment of body 1's length `len`, with t̂¹ = s(t)m(t)
/// (p̂ = −s|m|) and G(û) = G̃_c/|m| for the bubble amplitude c: −2 len ∫₀¹ s(t) G̃_c(t) dt, by
/// Simpson's rule (exact: the integrand is cubic). ≥ 0 when s ≤ 0 and G̃_c ≥ 0; linear in c
/// with the slope [`contact_slope`].
pub fn contact_term(len: f64, s: [f64; 2], gap: &SegmentGap, c: f64) -> f64 {
    let f = |t: f64| ((1.0 - t) * s[0] + t * s[1]) * gap.corrected(t, c);
    -2.0 * len * (f(0.0) + 4.0 * f(0.5) + f(1.0)) / 6.0
}

/// d/dc of [`contact_term`]: −2 len ∫₀¹ s(t) t(1 − t) dt = −len (s_k + s_{k+1})/6 (≥ 0).
pub fn contact_slope(len: f64, s: [f64; 2]) -> f64 {
    -len * (s[0] + s[1]) / 6.0
}

/// What η^glo depends on through the bubble amplitude c of one body-2 element:
/// its CRE plus contact term is q(c) = q(0) + a c² − 2b c + l c, and ‖δ‖²_E = a c²; c ≥ `least`.
#[derive(Clone, Copy, Debug, Default)]
pub struct BubbleTerms {
    pub element: usize,
    /// ‖Kε(δ₁)‖²_{K⁻¹} of the unit bubble δ₁.
    pub a: f64,
    /// ∫ (σ̂ − Kε(u_p)):ε(δ₁).
    pub b: f64,
    /// The contact term's slope.
    pub l: f64,
    pub least: f64,
}

/// The bubble amplitudes and the bound: the answer's error ‖u − u_p‖ ≤ ‖u − û‖ + ‖δ‖, and
/// (‖u − û‖ + ‖δ‖)² ≤ (1 + θ)Q + (1 + 1/θ)Δ for every θ > 0 (Young), Q = Σ q_E(c_E) the CRE of
/// (û, σ̂), Δ = Σ a_E c_E². For a fixed θ the right side is separable in the c_E: each is the
/// minimiser of (1 + θ)(a c² − 2b c + l c) + (1 + 1/θ)a c² over c ≥ least; for fixed c_E the best
/// θ is √(Δ/Q). Alternating the two (each step lowers the bound) from θ = 1. `q0` is Q at
/// c = 0 and `sum` the reduction over the ranks (the terms are this rank's elements'). Returns
/// the amplitudes and (θ, Q, Δ); θ = 0 when no bubble is needed (Δ = 0, the bound is Q).
pub fn choose_amplitudes(
    terms: &[BubbleTerms],
    q0: f64,
    sum: &dyn Fn([f64; 2]) -> [f64; 2],
) -> (Vec<f64>, [f64; 3]) {
    let mut theta: f64 = 1.0;
    let mut c = vec![0.0; terms.len()];
    let mut last = [0.0, q0, 0.0];
    for _ in 0..12 {
        let (wq, wd) = (1.0 + theta, 1.0 + 1.0 / theta);
        let mut local = [0.0; 2];
        for (ci, t) in c.iter_mut().zip(terms) {
            *ci = (wq * (2.0 * t.b - t.l) / (2.0 * t.a * (wq + wd))).max(t.least);
            local[0] += t.a * *ci * *ci - 2.0 * t.b * *ci + t.l * *ci;
            local[1] += t.a * *ci * *ci;
        }
        let [dq, delta] = sum(local);
        let q = (q0 + dq).max(0.0);
        if delta <= 0.0 {
            return (c, [0.0, q, 0.0]);
        }
        let next = (delta / q.max(f64::MIN_POSITIVE)).sqrt();
        last = [next, q, delta];
        if (next - theta).abs() <= 1e-6 * theta {
            break;
        }
        theta = next;
    }
    (c, last)
}

/// The correction δ = c φ_a φ_b w of body 2 on the element with its Γc edge [a, b] (a, b its
/// local vertex indices): w·n_k = w·n_{k+1} = 1, so that δ(t)·m(t) = c t(1 − t) on the edge;
/// on an element with two Γc edges, the sum of their two.
#[derive(Clone, Debug)]
pub struct Bubble {
    /// The element's vertices.
    pub points: [[f64; 2]; 3],
    /// Per edge: the local indices of its two vertices, and c w.
    pub edges: Vec<([usize; 2], [f64; 2])>,
}

impl Bubble {
    /// The bubble of amplitude `c` on the edge `edge` of the triangle `points` whose ends carry
    /// the normals `na`, `nb`.
    pub fn new(
        points: [[f64; 2]; 3],
        edge: [usize; 2],
        c: f64,
        na: [f64; 2],
        nb: [f64; 2],
    ) -> Bubble {
        let mut b = Bubble {
            points,
            edges: Vec::new(),
        };
        b.add_edge(edge, c, na, nb);
        b
    }

    /// Adds the bubble of amplitude `c` on another edge.
    pub fn add_edge(&mut self, edge: [usize; 2], c: f64, na: [f64; 2], nb: [f64; 2]) {
        let s = 1.0 + na[0] * nb[0] + na[1] * nb[1];
        self.edges
            .push((edge, [c * (na[0] + nb[0]) / s, c * (na[1] + nb[1]) / s]));
    }

    /// The values and gradients of the hat functions of an edge's two vertices at x.
    fn hats(&self, edge: [usize; 2], x: [f64; 2]) -> [(f64, [f64; 2]); 2] {
        let p = self.points;
        let det =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        edge.map(|i| {
            // φ_i vanishes on the opposite side [q, r]: φ_i(x) = ∇φ_i·(x − q).
            let (q, r) = (p[(i + 1) % 3], p[(i + 2) % 3]);
            let g = [(q[1] - r[1]) / det, (r[0] - q[0]) / det];
            (g[0] * (x[0] - q[0]) + g[1] * (x[1] - q[1]), g)
        })
    }

    /// The strain (xx, yy, γxy) of δ at the point x.
    pub fn strain(&self, x: [f64; 2]) -> [f64; 3] {
        let mut e = [0.0; 3];
        for &(edge, w) in &self.edges {
            let [(fa, ga), (fb, gb)] = self.hats(edge, x);
            let grad = [fb * ga[0] + fa * gb[0], fb * ga[1] + fa * gb[1]];
            e[0] += w[0] * grad[0];
            e[1] += w[1] * grad[1];
            e[2] += w[0] * grad[1] + w[1] * grad[0];
        }
        e
    }

    /// δ at the point x.
    pub fn value(&self, x: [f64; 2]) -> [f64; 2] {
        let mut v = [0.0; 2];
        for &(edge, w) in &self.edges {
            let [(fa, _), (fb, _)] = self.hats(edge, x);
            v[0] += fa * fb * w[0];
            v[1] += fa * fb * w[1];
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An arc's points and normals, the gaps, the segment lengths and the jumps.
    type Arc = (
        Vec<[f64; 2]>,
        Vec<[f64; 2]>,
        Vec<f64>,
        Vec<f64>,
        Vec<[f64; 2]>,
    );

    /// Two circles' arcs (radius 1 and 1.001, half-angle 0.4, m segments) with radial nodal
    /// normals, and a jump field with a sliding part that changes along Γc.
    fn arc(m: usize) -> Arc {
        let th: Vec<f64> = (0..=m).map(|i| -0.4 + 0.8 * i as f64 / m as f64).collect();
        let n: Vec<[f64; 2]> = th.iter().map(|t| [t.sin(), t.cos()]).collect();
        let x1: Vec<[f64; 2]> = n.to_vec();
        let g0: Vec<f64> = vec![1e-3; m + 1];
        // Slip 1e-3 sin(3θ) along τ, normal jump such that G_k = 1e-5 max(cos 5θ, 0) ≥ 0 (in
        // contact where it is 0).
        let jumps: Vec<[f64; 2]> = th
            .iter()
            .zip(&n)
            .zip(&g0)
            .map(|((t, n), g)| {
                let slip = 1e-3 * (3.0 * t).sin();
                let un = 1e-5 * (5.0 * t).cos().max(0.0) - g;
                [slip * n[1] + un * n[0], -slip * n[0] + un * n[1]]
            })
            .collect();
        let lengths = crate::problem::segment_lengths(&x1);
        (x1, n, g0, lengths, jumps)
    }

    #[test]
    fn the_bubble_keeps_the_gap_nonnegative_between_the_nodes() {
        let (x1, n, g0, _, jumps) = arc(12);
        let gaps = segment_gaps(&n, &g0, &jumps);
        let (mut violated, mut worst) = (0, f64::INFINITY);
        for (k, gap) in gaps.iter().enumerate() {
            // G̃ from its definition d(t)·m(t), without and with the bubble on body 2.
            for i in 0..=20 {
                let t = i as f64 / 20.0;
                let lerp = |a: [f64; 2], b: [f64; 2]| {
                    [(1.0 - t) * a[0] + t * b[0], (1.0 - t) * a[1] + t * b[1]]
                };
                let x2a = [x1[k][0] + g0[k] * n[k][0], x1[k][1] + g0[k] * n[k][1]];
                let x2b = [
                    x1[k + 1][0] + g0[k + 1] * n[k + 1][0],
                    x1[k + 1][1] + g0[k + 1] * n[k + 1][1],
                ];
                let (p1, p2) = (lerp(x1[k], x1[k + 1]), lerp(x2a, x2b));
                let j = lerp(jumps[k], jumps[k + 1]);
                let m = lerp(n[k], n[k + 1]);
                let d = [p2[0] - p1[0] + j[0], p2[1] - p1[1] + j[1]];
                let plain = d[0] * m[0] + d[1] * m[1];
                let expected =
                    (1.0 - t) * gap.ends[0] + t * gap.ends[1] - t * (1.0 - t) * gap.curvature_term;
                assert!(
                    (plain - expected).abs() < 1e-15,
                    "segment {k} t {t}: {plain} {expected}"
                );
                // The bubble of body 2's edge [x2a, x2b] (its element's third vertex inside).
                let inner = [0.5 * (x2a[0] + x2b[0]) * 1.1, 0.5 * (x2a[1] + x2b[1]) * 1.1];
                let c = gap.least_amplitude();
                let bubble = Bubble::new([x2a, x2b, inner], [0, 1], c, n[k], n[k + 1]);
                let delta = bubble.value(p2);
                let corrected = (d[0] + delta[0]) * m[0] + (d[1] + delta[1]) * m[1];
                assert!((corrected - gap.corrected(t, c)).abs() < 1e-15);
                violated += (plain < -1e-15) as usize;
                worst = worst.min(corrected);
                // Any larger amplitude keeps it too (max(D, 0), the one that makes G̃ linear).
                assert!(gap.corrected(t, c.max(gap.curvature_term).max(0.0)) >= -1e-15);
            }
        }
        // The sliding violates the constraint between nodes; the bubble restores it, and the
        // least amplitude is sharp: G̃ touches 0 inside every segment that needs a bubble.
        assert!(violated > 10, "{violated}");
        for gap in &gaps {
            let c = gap.least_amplitude();
            let min = (1..1000)
                .map(|i| gap.corrected(i as f64 / 1000.0, c))
                .fold(f64::INFINITY, f64::min);
            let scale = gap.ends[0].max(gap.ends[1]).max(gap.curvature_term.abs());
            assert!(min >= -1e-15 && min <= 1e-5 * scale, "{gap:?}: min {min:e}");
        }
        // (round-off of the nodal gaps, which are 0 on the contact set, against g₀ = 1e−3)
        assert!(worst >= -1e-15, "{worst}");
    }

    /// The amplitudes minimise (1 + θ)Q + (1 + 1/θ)Δ: no other choice (a grid around them, and
    /// the least amplitudes) gives a smaller (√Q + √Δ)², and the returned θ is √(Δ/Q).
    #[test]
    fn the_chosen_amplitudes_minimise_the_bound() {
        let term = |element, a, b, l, least| BubbleTerms {
            element,
            a,
            b,
            l,
            least,
        };
        let terms = [
            term(0, 2.0, 0.3, 0.1, -0.5),
            term(1, 1.0, -0.2, 0.4, 0.25),
            term(2, 3.0, 1.0, 0.0, -1.0),
        ];
        let q0 = 1.5;
        let bound = |c: &[f64]| {
            let q: f64 = q0
                + terms
                    .iter()
                    .zip(c)
                    .map(|(t, c)| t.a * c * c - 2.0 * t.b * c + t.l * c)
                    .sum::<f64>();
            let d: f64 = terms.iter().zip(c).map(|(t, c)| t.a * c * c).sum();
            (q.sqrt() + d.sqrt()).powi(2)
        };
        let (c, [theta, q, delta]) = choose_amplitudes(&terms, q0, &|x| x);
        for (ci, t) in c.iter().zip(&terms) {
            assert!(*ci >= t.least);
        }
        assert!((theta - (delta / q).sqrt()).abs() < 1e-6 * theta);
        let best = bound(&c);
        assert!(((1.0 + theta) * q + (1.0 + 1.0 / theta) * delta - best).abs() < 1e-9 * best);
        let least: Vec<f64> = terms.iter().map(|t| t.least.max(0.0)).collect();
        assert!(best <= bound(&least));
        for i in 0..3 {
            for h in [-1e-3, 1e-3] {
                let mut other = c.clone();
                other[i] = (other[i] + h).max(terms[i].least);
                assert!(
                    best <= bound(&other) * (1.0 + 1e-9),
                    "element {i}, step {h}"
                );
            }
        }
        // No bubble needed: θ = 0 and the bound is Q.
        let (c, [theta, q, _]) = choose_amplitudes(&[term(0, 1.0, 0.0, 0.5, 0.0)], q0, &|x| x);
        assert_eq!((c[0], theta, q), (0.0, 0.0, q0));
    }

    #[test]
    fn the_bubbles_strain_is_its_gradient() {
        let points = [[0.1, 0.2], [1.3, 0.4], [0.5, 1.1]];
        let b = Bubble::new(points, [2, 0], 0.7, [0.6, 0.8], [0.8, 0.6]);
        let x = [0.6, 0.5];
        let h = 1e-6;
        let du = |dx: [f64; 2]| {
            let (p, m) = (
                b.value([x[0] + dx[0], x[1] + dx[1]]),
                b.value([x[0] - dx[0], x[1] - dx[1]]),
            );
            [(p[0] - m[0]) / (2.0 * h), (p[1] - m[1]) / (2.0 * h)]
        };
        let (dx, dy) = (du([h, 0.0]), du([0.0, h]));
        let e = b.strain(x);
        for (a, b) in e.iter().zip([dx[0], dy[1], dx[1] + dy[0]]) {
            assert!((a - b).abs() < 1e-8, "{e:?}");
        }
        // w·n_a = w·n_b = 1 (times c).
        let w = b.edges[0].1;
        assert!((w[0] * 0.6 + w[1] * 0.8 - 0.7).abs() < 1e-15);
        assert!((w[0] * 0.8 + w[1] * 0.6 - 0.7).abs() < 1e-15);
    }

    #[test]
    fn the_traction_is_parallel_to_the_normal_field_and_keeps_the_resultant() {
        let (_, n, _, lengths, _) = arc(8);
        let g: Vec<f64> = (0..=8).map(|k| -1.0 - 0.5 * (k as f64).sin()).collect();
        let s = factors(&n, &g);
        let edges = edge_traction(&n, &s);
        for (k, e) in edges.iter().enumerate() {
            for i in 0..=10 {
                let t = i as f64 / 10.0;
                let v = [
                    (1.0 - t) * e[0][0] + t * e[1][0],
                    (1.0 - t) * e[0][1] + t * e[1][1],
                ];
                let m = [
                    (1.0 - t) * n[k][0] + t * n[k + 1][0],
                    (1.0 - t) * n[k][1] + t * n[k + 1][1],
                ];
                assert!((v[0] * m[1] - v[1] * m[0]).abs() < 1e-15, "parallel");
                assert!(v[0] * m[0] + v[1] * m[1] <= 0.0, "compressive");
            }
        }
        // The same normal resultant ∫ g ds as the P1 density.
        let p1: f64 = (0..8).map(|k| lengths[k] * 0.5 * (g[k] + g[k + 1])).sum();
        let p0: f64 = (0..8).map(|k| lengths[k] * 0.5 * (s[k][0] + s[k][1])).sum();
        assert!((p1 - p0).abs() < 1e-15 * p1.abs());
        // The nodal forces are the exact integrals: their sum is ∫ t̂ ds.
        let f = nodal_forces(&lengths, &edges);
        for c in 0..2 {
            let sum: f64 = f.iter().map(|v| v[c]).sum();
            let exact: f64 = (0..8)
                .map(|k| lengths[k] * 0.5 * (edges[k][0][c] + edges[k][1][c]))
                .sum();
            assert!((sum - exact).abs() < 1e-14);
        }
    }

    #[test]
    fn a_straight_side_keeps_the_p1_density_and_needs_no_bubble() {
        let n = vec![[0.0, 1.0]; 4];
        let g = [-1.0, -2.0, -0.5, 0.0];
        assert_eq!(
            factors(&n, &g),
            vec![[-1.0, -2.0], [-2.0, -0.5], [-0.5, 0.0]]
        );
        let jumps = [[0.3, -0.1], [-0.2, 0.0], [0.5, 0.1], [0.0, 0.2]];
        let g0 = [0.1, 0.0, 0.0, 0.0];
        for gap in segment_gaps(&n, &g0, &jumps) {
            assert_eq!(gap.curvature_term, 0.0);
            assert_eq!(gap.least_amplitude(), 0.0);
        }
        // Its contact term is the P1 product −2∫ g G ds.
        let gap = SegmentGap {
            ends: [0.2, 0.4],
            curvature_term: 0.0,
            turns: false,
        };
        let exact = 2.0 * 0.5 / 6.0 * (2.0 * 0.2 + 0.4 + 2.0 * 0.2 + 2.0 * 2.0 * 0.4);
        assert!((contact_term(0.5, [-1.0, -2.0], &gap, 0.0) - exact).abs() < 1e-15);
        // Its slope in the bubble amplitude.
        let curved = SegmentGap { turns: true, ..gap };
        let slope = contact_term(0.5, [-1.0, -2.0], &curved, 1.0)
            - contact_term(0.5, [-1.0, -2.0], &curved, 0.0);
        assert!((slope - contact_slope(0.5, [-1.0, -2.0])).abs() < 1e-15);
    }
}
