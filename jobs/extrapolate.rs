//! The true error extrapolated from reference errors at three reference factors (shared by
//! `jobs/effectivity.rs` and `tests/curved.rs`): e_ref(r)² = e∞² − K r^(−q), q fitted.
#![allow(dead_code)]

/// (q, e∞) of e(r)² = e∞² − K r^(−q) through (r, e) at three factors r₀ < r₁ < r₂; `None`
/// where e_ref does not grow monotonically as that family with q in [0.05, 8].
pub fn extrapolate(r: [f64; 3], e: [f64; 3]) -> Option<(f64, f64)> {
    let e2 = e.map(|x| x * x);
    let rho = (e2[1] - e2[0]) / (e2[2] - e2[1]);
    // The ratio of the increments, increasing with q.
    let ratio = |q: f64| (r[0].powf(-q) - r[1].powf(-q)) / (r[1].powf(-q) - r[2].powf(-q));
    let (mut lo, mut hi) = (0.05, 8.0);
    if !(ratio(lo)..=ratio(hi)).contains(&rho) {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if ratio(mid) < rho {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let q = 0.5 * (lo + hi);
    let k = (e2[2] - e2[1]) / (r[1].powf(-q) - r[2].powf(-q));
    Some((q, (e2[2] + k * r[2].powf(-q)).sqrt()))
}
