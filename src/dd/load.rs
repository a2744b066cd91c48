//! A body's load f^α held by its non-zero entries: it is non-zero on the loaded Γ_N edges
//! only, so the body keeps a boundary's worth of it rather than a whole vector per rank of its
//! group (docs/scaling.md, "Memory per rank"); a solve's load adds the Γc forces to it
//! ([`Loading`]), and its right-hand side is formed on each rank's rows from that.

use crate::problem::Frames;

/// A load vector held by its non-zero entries: a body's f^α is non-zero on its loaded Γ_N
/// edges only (a whole vector would be 8 bytes per dof on every rank of its group).
pub(super) struct Load {
    /// (dof, value), by increasing dof.
    entries: Vec<(usize, f64)>,
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
        }
    }

    /// The entry of dof `d`.
    pub(super) fn at(&self, d: usize) -> f64 {
        match self.entries.binary_search_by_key(&d, |e| e.0) {
            Ok(i) => self.entries[i].1,
            Err(_) => 0.0,
        }
    }

    /// ‖f‖∞.
    pub(super) fn norm_inf(&self) -> f64 {
        self.entries.iter().fold(0.0, |m, e| m.max(e.1.abs()))
    }
}

/// A load for one solve without a whole vector: a body's data f^α (or none) plus nodal
/// contributions (the Γc forces), each dof's summed in the order they were added.
pub(super) struct Loading<'a> {
    data: Option<&'a Load>,
    added: std::collections::HashMap<usize, Vec<f64>>,
}

impl<'a> Loading<'a> {
    /// `data` (f^α) or nothing, with no contribution yet.
    pub(super) fn new(data: Option<&'a Load>) -> Loading<'a> {
        Loading {
            data,
            added: Default::default(),
        }
    }

    /// Add `value` at dof `d`.
    pub(super) fn add(&mut self, d: usize, value: f64) {
        self.added.entry(d).or_default().push(value);
    }

    /// The load at dof `d`.
    pub(super) fn at(&self, d: usize) -> f64 {
        let mut v = self.data.map_or(0.0, |l| l.at(d));
        for &x in self.added.get(&d).map_or(&[][..], |a| &a[..]) {
            v += x;
        }
        v
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
        for (d, &w) in whole.iter().enumerate() {
            assert_eq!(load.at(d), w);
        }
        assert_eq!(load.norm_inf(), 2.0);
        // With contributions: each dof's summed in order onto f.
        let mut loading = Loading::new(Some(&load));
        loading.add(1, 0.5);
        loading.add(3, 2.0);
        loading.add(1, -0.25);
        let want = [0.0, 1.5 + 0.5 - 0.25, 0.0, 2.0, -2.0, 0.25, 0.0, 0.0];
        for (d, &w) in want.iter().enumerate() {
            assert_eq!(loading.at(d), w);
        }
        assert_eq!(Loading::new(None).at(1), 0.0);
    }
}
