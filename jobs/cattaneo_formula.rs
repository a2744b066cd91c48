//! Cattaneo and Mindlin's partial slip of a cylinder on a flat of the same material (plane
//! strain; K. L. Johnson, Contact Mechanics, §4.2 and §7.1): under a normal force P and a
//! tangential force Q < μP per unit length, the contact half-width a = √(4PR/(πE*)) with
//! 1/E* = 2(1 − ν²)/E, the peak pressure p₀ = 2P/(πa), a central stick zone of half-width
//! c = a √(1 − Q/(μP)) and slip zones c ≤ |x| ≤ a; the shear is μp₀(√(1 − x²/a²) − (c/a)
//! √(1 − x²/c²)) in the stick zone and μp in the slip zones, its peak μp₀ √(1 − c²/a²) at
//! |x| = c. Shared by tests/friction.rs and jobs/cattaneo.

/// The formulas' contact for P, Q (N/m), μ, the radius R and the material (E, ν).
#[derive(Clone, Copy, Debug)]
pub struct Cattaneo {
    pub a: f64,
    pub p0: f64,
    pub c: f64,
    pub peak_shear: f64,
}

pub fn cattaneo(p: f64, q: f64, mu: f64, r: f64, e: f64, nu: f64) -> Cattaneo {
    let e_star = e / (2.0 * (1.0 - nu * nu));
    let a = (4.0 * p * r / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    let ratio = (q.abs() / (mu * p)).min(1.0);
    let c = a * (1.0 - ratio).sqrt();
    Cattaneo {
        a,
        p0,
        c,
        peak_shear: mu * p0 * (1.0 - (c / a).powi(2)).sqrt(),
    }
}

/// What a run's Γc nodes give (a flat Γc along x): the contact half-width, the stick zone's
/// half-width and centre (each edge midway between the last node of a zone and the first
/// beyond it), the largest |shear| (Pa).
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    pub a: f64,
    pub c: f64,
    pub stick_centre: f64,
    pub peak_shear: f64,
}

/// From the Γc nodes' x, their `contact_state` (0 separated, 1 stick, 2 slip) and `shear`.
pub fn measure(x: &[f64], state: &[f64], shear: &[f64]) -> Measured {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&i, &j| x[i].total_cmp(&x[j]));
    let xs: Vec<f64> = order.iter().map(|&i| x[i]).collect();
    let st: Vec<i64> = order.iter().map(|&i| state[i].round() as i64).collect();
    let half = |keep: &dyn Fn(i64) -> bool| {
        let first = st.iter().position(|&s| keep(s)).unwrap_or(0);
        let last = st.iter().rposition(|&s| keep(s)).unwrap_or(0);
        let lo = if first > 0 {
            0.5 * (xs[first - 1] + xs[first])
        } else {
            xs[first]
        };
        let hi = if last + 1 < xs.len() {
            0.5 * (xs[last] + xs[last + 1])
        } else {
            xs[last]
        };
        (0.5 * (hi - lo), 0.5 * (hi + lo))
    };
    let (a, _) = half(&|s| s > 0);
    let (c, centre) = half(&|s| s == 1);
    Measured {
        a,
        c,
        stick_centre: centre,
        peak_shear: shear.iter().fold(0.0_f64, |m, v| m.max(v.abs())),
    }
}
