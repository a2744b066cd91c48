//! A body's load f^α held by its non-zero entries: it is non-zero on the loaded Γ_N edges
//! only, so the body keeps a boundary's worth of it rather than a whole vector per rank of its
//! group (docs/scaling.md, "Memory per rank"); whole vectors are made for the time of a solve.

use crate::problem::Frames;

/// A load vector held by its non-zero entries: a body's f^α is non-zero on its loaded Γ_N
/// edges only, so a whole vector per body (8 bytes per dof on every rank of its group) is
/// made only for the time of a solve.
pub(super) struct Load {
    /// (dof, value), by increasing dof.
    entries: Vec<(usize, f64)>,
    /// The dofs of the body.
    pub(super) len: usize,
}

impl Load {
    /// The non-zero entries of `whole` (global components) in the nodal `frames`.
    pub(super) fn of(mut whole: Vec<f64>, frames: &Frames) -> Load {
        frames.to_local(&mut whole);
        Load {
            entries: (whole.iter().enumerate())
                .filter(|(_, v)| **v != 0.0)
                .map(|(d, &v)| (d, v))
                .collect(),
            len: whole.len(),
        }
    }

    /// The whole vector.
    pub(super) fn whole(&self) -> Vec<f64> {
        let mut v = vec![0.0; self.len];
        self.add_to(&mut v, 1.0);
        v
    }

    /// v += scale · f.
    pub(super) fn add_to(&self, v: &mut [f64], scale: f64) {
        for &(d, f) in &self.entries {
            v[d] += scale * f;
        }
    }

    /// The entry of dof `d`.
    pub(super) fn at(&self, d: usize) -> f64 {
        match self.entries.binary_search_by_key(&d, |e| e.0) {
            Ok(i) => self.entries[i].1,
            Err(_) => 0.0,
        }
    }

    /// fᵀu.
    pub(super) fn dot(&self, u: &[f64]) -> f64 {
        self.entries.iter().map(|&(d, f)| f * u[d]).sum()
    }

    /// ‖f‖∞.
    pub(super) fn norm_inf(&self) -> f64 {
        self.entries.iter().fold(0.0, |m, e| m.max(e.1.abs()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sparse_load_is_its_whole_vector() {
        let whole = vec![0.0, 1.5, 0.0, 0.0, -2.0, 0.25, 0.0, 0.0];
        let load = Load::of(whole.clone(), &Frames::default());
        assert_eq!(load.entries.len(), 3);
        assert_eq!(load.whole(), whole);
        for (d, &w) in whole.iter().enumerate() {
            assert_eq!(load.at(d), w);
        }
        let u: Vec<f64> = (0..8).map(|i| 1.0 + i as f64).collect();
        let dot: f64 = whole.iter().zip(&u).map(|(a, b)| a * b).sum();
        assert_eq!(load.dot(&u), dot);
        assert_eq!(load.norm_inf(), 2.0);
        let mut v = u.clone();
        load.add_to(&mut v, -2.0);
        for d in 0..8 {
            assert_eq!(v[d], u[d] - 2.0 * whole[d]);
        }
    }
}
