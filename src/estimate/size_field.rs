//! The mesh sizes the element estimates ask for (docs/method.md §8): where the next mesh of an
//! adaptive run should be finer and where coarser, so that its discretisation error meets a
//! target with the fewest elements.
//!
//! The optimal-mesh criterion (Ladevèze and Pelle, *Mastering Calculations in Linear and
//! Nonlinear Mechanics*, 2005, §3.3; Coorevits, Hild and Hjiaj for contact): with e_E the
//! contribution of element E to η^FE and a P1 error that goes as h^p (p = 1 where the answer is
//! smooth), refining E by the factor r_E = h*_E / h_E leaves about e_E r_E^p of error in its
//! place and puts r_E^(−2) elements there (2D). Minimising the count Σ_E r_E^(−2) under the
//! predicted error Σ_E e_E² r_E^(2p) = ε² gives
//!   r_E = (ε² / Σ_F e_F^(2/(p+1)))^(1/(2p)) · e_E^(−1/(p+1)),
//! each new element then carrying the same share of ε² (equidistribution). The ratios are
//! kept within [`Limits`] (a mesh is not coarsened or refined without bound in one cycle, and
//! an element without error is not grown past the largest ratio). Dörfler marking (Dörfler
//! 1996), for comparison: the fewest elements whose contributions make up the fraction θ of
//! η^FE² are halved, the others kept.

/// How the new sizes are chosen (`-nndd_adapt_strategy`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Strategy {
    /// The optimal-mesh criterion above, with convergence order p.
    Optimal { order: f64 },
    /// Halve the elements that carry the fraction θ ∈ (0, 1] of η^FE², keep the others.
    Dorfler { fraction: f64 },
}

/// The bounds of one cycle's change: of the ratio r_E = h*_E / h_E, and of the element count
/// (the estimates of a coarse mesh are a coarse guide: a mesh that grows by more than
/// `growth` aims at a larger error, reached in more cycles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub refine: f64,
    pub coarsen: f64,
    pub growth: f64,
}

impl Default for Limits {
    /// At most 8 times finer and 2 times coarser in one cycle, and 16 times the elements.
    fn default() -> Limits {
        Limits {
            refine: 0.125,
            coarsen: 2.0,
            growth: 16.0,
        }
    }
}

/// The new sizes of a mesh's elements and what they predict.
#[derive(Clone, Debug, PartialEq)]
pub struct SizeField {
    /// h*_E per element (the edge length the mesher should aim at there).
    pub sizes: Vec<f64>,
    /// r_E = h*_E / h_E.
    pub ratios: Vec<f64>,
    /// The predicted number of elements of the new mesh, Σ_E r_E^(−2).
    pub elements: f64,
    /// The predicted discretisation error (Optimal: √Σ e_E² r_E^(2p); Dörfler: not predicted).
    pub error: Option<f64>,
}

/// The size of a triangle as a mesher means it: the edge of the equilateral triangle of the
/// same area.
pub fn triangle_size(p: [[f64; 2]; 3]) -> f64 {
    let area = 0.5
        * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
            .abs();
    (4.0 * area / 3f64.sqrt()).sqrt()
}

/// The new sizes for the element contributions `squares` (e_E², η^FE² = Σ) of elements of
/// sizes `sizes`, aiming at the discretisation error `target` (> 0).
pub fn size_field(
    squares: &[f64],
    sizes: &[f64],
    target: f64,
    strategy: Strategy,
    limits: Limits,
) -> SizeField {
    let mut field = field_at(squares, sizes, target, strategy, limits);
    // Too many elements: aim higher, by the element count's excess (N ∝ ε^(−2/p); the clamps
    // make the count fall slower than that, hence a few steps).
    if let Strategy::Optimal { order: p } = strategy {
        let cap = limits.growth * squares.len() as f64;
        let mut aim = target;
        for _ in 0..20 {
            if field.elements <= cap {
                break;
            }
            aim *= (field.elements / cap).powf(0.5 * p) * 1.01;
            field = field_at(squares, sizes, aim, strategy, limits);
        }
    }
    field
}

fn field_at(
    squares: &[f64],
    sizes: &[f64],
    target: f64,
    strategy: Strategy,
    limits: Limits,
) -> SizeField {
    let clamp = |r: f64| r.clamp(limits.refine, limits.coarsen);
    let (ratios, error) = match strategy {
        Strategy::Optimal { order: p } => {
            let sum: f64 = squares.iter().map(|&e2| e2.powf(1.0 / (p + 1.0))).sum();
            let scale = if sum > 0.0 {
                (target * target / sum).powf(0.5 / p)
            } else {
                f64::INFINITY
            };
            let ratios: Vec<f64> = squares
                .iter()
                .map(|&e2| match e2 > 0.0 {
                    true => clamp(scale * e2.powf(-0.5 / (p + 1.0))),
                    false => limits.coarsen,
                })
                .collect();
            let predicted: f64 = squares
                .iter()
                .zip(&ratios)
                .map(|(&e2, &r)| e2 * r.powf(2.0 * p))
                .sum();
            (ratios, Some(predicted.sqrt()))
        }
        Strategy::Dorfler { fraction } => {
            let mut order: Vec<usize> = (0..squares.len()).collect();
            order.sort_by(|&a, &b| squares[b].total_cmp(&squares[a]));
            let total: f64 = squares.iter().sum();
            let mut ratios = vec![1.0; squares.len()];
            let mut marked = 0.0;
            for e in order {
                if marked >= fraction * total {
                    break;
                }
                marked += squares[e];
                ratios[e] = 0.5;
            }
            (ratios, None)
        }
    };
    SizeField {
        sizes: sizes.iter().zip(&ratios).map(|(h, r)| h * r).collect(),
        elements: ratios.iter().map(|r| r.powi(-2)).sum(),
        ratios,
        error,
    }
}

/// A size per node of a mesh (`triangles` over `nodes` points) from sizes per element: the
/// mean of its elements' (what a mesher interpolates across each triangle).
pub fn nodal_sizes(nodes: usize, triangles: &[[usize; 3]], sizes: &[f64]) -> Vec<f64> {
    let mut sum = vec![0.0; nodes];
    let mut count = vec![0usize; nodes];
    for (t, &h) in triangles.iter().zip(sizes) {
        for &v in t {
            sum[v] += h;
            count[v] += 1;
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(&s, &c)| if c > 0 { s / c as f64 } else { 0.0 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors that sit in one corner: sizes shrink there and grow elsewhere, and the new
    /// elements carry equal shares of the predicted error, which is the target.
    #[test]
    fn the_optimal_sizes_equidistribute_the_error_at_the_target() {
        // 100 elements of size 0.1 on a line of cells; the error falls off away from cell 0.
        let n = 100;
        let squares: Vec<f64> = (0..n).map(|i| 1.0 / (1.0 + i as f64).powi(3)).collect();
        let sizes = vec![0.1; n];
        let total: f64 = squares.iter().sum::<f64>().sqrt();
        let target = 0.5 * total;
        let wide = Limits {
            refine: 1e-6,
            coarsen: 1e6,
            growth: 1e6,
        };
        let f = size_field(
            &squares,
            &sizes,
            target,
            Strategy::Optimal { order: 1.0 },
            wide,
        );
        assert!(f.ratios[0] < 1.0 && f.ratios[n - 1] > 1.0, "{:?}", f.ratios);
        assert!(f.ratios.windows(2).all(|w| w[0] < w[1]));
        assert!((f.error.unwrap() - target).abs() < 1e-12 * target);
        // Each element's predicted error over its new element count is the same share.
        let share: Vec<f64> = (0..n)
            .map(|e| squares[e] * f.ratios[e].powi(2) / f.ratios[e].powi(-2))
            .collect();
        let mean = share.iter().sum::<f64>() / n as f64;
        assert!(
            share.iter().all(|s| (s - mean).abs() < 1e-10 * mean),
            "{share:?}"
        );
        // The sizes are the ratios times the old sizes; the limits hold.
        let g = size_field(
            &squares,
            &sizes,
            target,
            Strategy::Optimal { order: 1.0 },
            Limits::default(),
        );
        assert!(g.ratios.iter().all(|&r| (0.125..=2.0).contains(&r)));
        assert!((g.sizes[3] - 0.1 * g.ratios[3]).abs() < 1e-15);
        // A target far below reach: the element count stops at the growth limit, near it.
        let far = size_field(
            &squares,
            &sizes,
            1e-3 * target,
            Strategy::Optimal { order: 1.0 },
            Limits::default(),
        );
        let cap = 16.0 * n as f64;
        assert!(
            far.elements <= cap && far.elements > 0.5 * cap,
            "{}",
            far.elements
        );
    }

    /// Dörfler: the fewest largest contributions that make up the fraction are halved.
    #[test]
    fn dorfler_halves_the_largest_contributions() {
        let squares = [4.0, 1.0, 3.0, 2.0];
        let f = size_field(
            &squares,
            &[1.0; 4],
            1.0,
            Strategy::Dorfler { fraction: 0.6 },
            Limits::default(),
        );
        assert_eq!(f.ratios, vec![0.5, 1.0, 0.5, 1.0]);
        assert_eq!(f.elements, 4.0 + 1.0 + 4.0 + 1.0);
        assert_eq!(f.error, None);
    }

    #[test]
    fn a_triangles_size_is_the_equilateral_edge_of_its_area() {
        let s = triangle_size([[0.0, 0.0], [1.0, 0.0], [0.5, 3f64.sqrt() / 2.0]]);
        assert!((s - 1.0).abs() < 1e-15);
        let nodal = nodal_sizes(4, &[[0, 1, 2], [1, 3, 2]], &[1.0, 3.0]);
        assert_eq!(nodal, vec![1.0, 2.0, 2.0, 3.0]);
    }
}
