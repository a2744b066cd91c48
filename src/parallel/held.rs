//! A rank's part of a vector that is indexed like the whole: the entries from index `first`
//! on (`first` = 0 and the whole length: the vector whole). What a rank keeps of an estimated
//! step for the output (its η maps on the elements it writes, its displacement on the dofs
//! they need) is held so.

use std::ops::Range;

/// Entry `i` of a vector held from index `first` on: 0 where it is not held.
pub fn value_at(held: &[f64], first: usize, i: usize) -> f64 {
    i.checked_sub(first)
        .and_then(|j| held.get(j))
        .copied()
        .unwrap_or(0.0)
}

/// The entries `keep` of a vector held from index `first` on (those of them it holds); the
/// part returned is held from index max(keep.start, first) on.
pub fn keep(held: &[f64], first: usize, keep: &Range<usize>) -> Vec<f64> {
    let start = keep.start.max(first);
    let hi = (keep.end.max(start) - first).min(held.len());
    held[(start - first).min(hi)..hi].to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_part_has_the_values_of_its_entries() {
        let whole: Vec<f64> = (0..10).map(|e| e as f64 + 0.5).collect();
        let part = keep(&whole, 0, &(3..7));
        assert_eq!(part, vec![3.5, 4.5, 5.5, 6.5]);
        for e in 0..10 {
            let want = if (3..7).contains(&e) { whole[e] } else { 0.0 };
            assert_eq!(value_at(&part, 3, e), want, "entry {e}");
            assert_eq!(value_at(&whole, 0, e), whole[e]);
        }
        // Kept again (the same part, or a wider one): unchanged; a narrower one: its entries.
        assert_eq!(keep(&part, 3, &(3..7)), part);
        assert_eq!(keep(&part, 3, &(0..10)), part);
        assert_eq!(keep(&part, 3, &(5..6)), vec![5.5]);
        // An empty range keeps nothing.
        assert!(keep(&whole, 0, &(0..0)).is_empty());
    }
}
