//! Dense symmetric positive definite linear algebra.
//!
//! One job only: store small dense symmetric matrices (Schur complements on
//! the contact interface, a few hundred to about a thousand unknowns), factor
//! them by Cholesky (`A = L Lᵀ`), solve with the factor and invert. No external
//! crates are used.
//!
//! Storage is full (both triangles), row-major. Symmetry is *not* enforced by
//! [`SymMatrix::set`]; call [`SymMatrix::symmetrize`] after assembling a matrix
//! whose two triangles may differ by round-off. [`SymMatrix::cholesky`] reads
//! the lower triangle only.

/// Errors from dense linear algebra.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DenseError {
    /// The Cholesky factorisation met a non-positive (or non-finite) pivot.
    #[error("matrix is not positive definite: pivot {pivot} is {value:e}")]
    NotPositiveDefinite {
        /// Row/column index of the failing pivot.
        pivot: usize,
        /// Value of the pivot `a_ii - Σ_k l_ik²` (≤ 0 or non-finite).
        value: f64,
    },
    /// A vector or matrix had the wrong size.
    #[error("dimension mismatch: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Expected length.
        expected: usize,
        /// Actual length.
        found: usize,
    },
}

/// Dense symmetric `n × n` matrix, full row-major storage.
#[derive(Debug, Clone, PartialEq)]
pub struct SymMatrix {
    n: usize,
    data: Vec<f64>,
}

impl SymMatrix {
    /// R A Rᵀ for the sparse rows R (row k: its (column, value) entries), A this matrix: the
    /// operator A seen through the linear map R (a mortar trace's Delassus operator).
    pub fn congruence(&self, rows: &[Vec<(usize, f64)>]) -> SymMatrix {
        // A Rᵀ, column k: Σ_i r_ki A e_i.
        let art: Vec<Vec<f64>> = rows
            .iter()
            .map(|row| {
                (0..self.n)
                    .map(|r| row.iter().map(|&(i, w)| w * self.get(r, i)).sum())
                    .collect()
            })
            .collect();
        let mut d = SymMatrix::new(rows.len());
        for (k, row) in rows.iter().enumerate() {
            for (l, col) in art.iter().enumerate().take(k + 1) {
                let v: f64 = row.iter().map(|&(i, w)| w * col[i]).sum();
                d.set(k, l, v);
                d.set(l, k, v);
            }
        }
        d
    }

    /// The `n × n` zero matrix.
    pub fn new(n: usize) -> Self {
        SymMatrix {
            n,
            data: vec![0.0; n * n],
        }
    }

    /// Matrix from row-major data (`data[i * n + j] = a_ij`).
    ///
    /// # Panics
    /// If `data.len() != n * n`.
    pub fn from_rows(n: usize, data: Vec<f64>) -> Self {
        assert_eq!(
            data.len(),
            n * n,
            "SymMatrix::from_rows: {} entries for a {n}x{n} matrix",
            data.len()
        );
        SymMatrix { n, data }
    }

    /// Dimension `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Entry `a_ij`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.n + j]
    }

    /// Set entry `a_ij` only (not `a_ji`).
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        self.data[i * self.n + j] = v;
    }

    /// Row-major data, `n * n` entries.
    pub fn data(&self) -> &[f64] {
        &self.data
    }

    /// `y = A x`.
    ///
    /// # Panics
    /// If `x` or `y` does not have length `n`.
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        let n = self.n;
        assert_eq!(x.len(), n, "SymMatrix::matvec: x has wrong length");
        assert_eq!(y.len(), n, "SymMatrix::matvec: y has wrong length");
        for (i, yi) in y.iter_mut().enumerate() {
            *yi = dot(&self.data[i * n..(i + 1) * n], x);
        }
    }

    /// Mean of the diagonal entries (0 for the empty matrix).
    pub fn diag_mean(&self) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        (0..self.n).map(|i| self.get(i, i)).sum::<f64>() / self.n as f64
    }

    /// The principal submatrix `A[idx, idx]` (rows and columns in the order
    /// given).
    ///
    /// # Panics
    /// If an index is out of range.
    pub fn submatrix(&self, idx: &[usize]) -> SymMatrix {
        let k = idx.len();
        let mut data = Vec::with_capacity(k * k);
        for &i in idx {
            let row = &self.data[i * self.n..(i + 1) * self.n];
            data.extend(idx.iter().map(|&j| row[j]));
        }
        SymMatrix { n: k, data }
    }

    /// Replace `A` by `½ (A + Aᵀ)`.
    pub fn symmetrize(&mut self) {
        let n = self.n;
        for i in 0..n {
            for j in 0..i {
                let v = 0.5 * (self.data[i * n + j] + self.data[j * n + i]);
                self.data[i * n + j] = v;
                self.data[j * n + i] = v;
            }
        }
    }

    /// Cholesky factorisation `A = L Lᵀ`, reading the lower triangle of `A`.
    ///
    /// Row-oriented (Cholesky–Crout by rows): every inner product runs over
    /// two contiguous row prefixes of `L`, which suits row-major storage.
    /// About `n³/6` multiply-adds.
    ///
    /// # Errors
    /// [`DenseError::NotPositiveDefinite`] naming the first pivot that is not
    /// strictly positive (or not finite).
    pub fn cholesky(&self) -> Result<Cholesky, DenseError> {
        let n = self.n;
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            let (done, rest) = l.split_at_mut(i * n);
            let li = &mut rest[..n];
            for j in 0..i {
                let lj = &done[j * n..j * n + j];
                let s = self.data[i * n + j] - dot(&li[..j], lj);
                li[j] = s / done[j * n + j];
            }
            let s = self.data[i * n + i] - dot(&li[..i], &li[..i]);
            if !(s > 0.0 && s.is_finite()) {
                return Err(DenseError::NotPositiveDefinite { pivot: i, value: s });
            }
            li[i] = s.sqrt();
        }
        Ok(Cholesky { n, l })
    }

    /// Inverse of a symmetric positive definite matrix (via Cholesky; the
    /// result is exactly symmetric).
    ///
    /// # Errors
    /// [`DenseError::NotPositiveDefinite`] if the factorisation fails.
    pub fn inverse_spd(&self) -> Result<SymMatrix, DenseError> {
        let n = self.n;
        let chol = self.cholesky()?;
        let mut inv = SymMatrix::new(n);
        let mut col = vec![0.0; n];
        for j in 0..n {
            col.iter_mut().for_each(|v| *v = 0.0);
            col[j] = 1.0;
            chol.solve_from(j, &mut col);
            // Column j of A⁻¹ equals row j because A⁻¹ is symmetric.
            inv.data[j * n..(j + 1) * n].copy_from_slice(&col);
        }
        inv.symmetrize();
        Ok(inv)
    }
}

/// Cholesky factor `L` (lower triangular, row-major) of an SPD matrix.
#[derive(Debug, Clone)]
pub struct Cholesky {
    n: usize,
    l: Vec<f64>,
}

impl Cholesky {
    /// Dimension `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Entry `l_ij` of the factor (zero above the diagonal).
    pub fn l(&self, i: usize, j: usize) -> f64 {
        if j > i {
            0.0
        } else {
            self.l[i * self.n + j]
        }
    }

    /// Overwrite `b` with `A⁻¹ b`.
    ///
    /// # Panics
    /// If `b.len() != n`.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        self.solve_from(0, b);
    }

    /// Solve assuming `b[..start] == 0` (skips the leading zeros in the
    /// forward substitution).
    fn solve_from(&self, start: usize, b: &mut [f64]) {
        let n = self.n;
        assert_eq!(b.len(), n, "Cholesky::solve_in_place: wrong length");
        let l = &self.l;
        // Forward: L z = b.
        for i in start..n {
            let row = &l[i * n..i * n + i];
            let s = b[i] - dot(&row[start..], &b[start..i]);
            b[i] = s / l[i * n + i];
        }
        // Backward: Lᵀ x = z, column-oriented so that rows of L are read
        // contiguously.
        for i in (0..n).rev() {
            let xi = b[i] / l[i * n + i];
            b[i] = xi;
            let row = &l[i * n..i * n + i];
            for (bk, &lik) in b[..i].iter_mut().zip(row) {
                *bk -= lik * xi;
            }
        }
    }
}

/// Inner product of two equally long slices, with independent partial sums
/// so that the compiler can keep several multiply-add chains in flight.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len();
    let b = &b[..n];
    let mut acc = [0.0f64; 8];
    let ca = a.chunks_exact(8);
    let cb = b.chunks_exact(8);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    use crate::testutil::Lcg;

    fn random_spd(n: usize, rng: &mut Lcg) -> SymMatrix {
        let b: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
        let mut a = SymMatrix::new(n);
        for i in 0..n {
            for j in 0..n {
                let mut s = if i == j { n as f64 } else { 0.0 };
                for k in 0..n {
                    s += b[k * n + i] * b[k * n + j];
                }
                a.set(i, j, s);
            }
        }
        a
    }

    #[test]
    fn cholesky_hand_example() {
        // A = L Lᵀ with L = [[2,0,0],[6,1,0],[-8,5,3]].
        let a = SymMatrix::from_rows(
            3,
            vec![4.0, 12.0, -16.0, 12.0, 37.0, -43.0, -16.0, -43.0, 98.0],
        );
        let c = a.cholesky().unwrap();
        let l = [[2.0, 0.0, 0.0], [6.0, 1.0, 0.0], [-8.0, 5.0, 3.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((c.l(i, j) - l[i][j]).abs() < 1e-14, "L[{i}][{j}]");
            }
        }
        // A x = b with x = (1, 2, 3): b = (-16, -43, 200).
        let mut b = vec![4.0 + 24.0 - 48.0, 12.0 + 74.0 - 129.0, -16.0 - 86.0 + 294.0];
        c.solve_in_place(&mut b);
        for (k, v) in b.iter().enumerate() {
            assert!((v - (k + 1) as f64).abs() < 1e-12, "x[{k}] = {v}");
        }
        assert_eq!(a.diag_mean(), (4.0 + 37.0 + 98.0) / 3.0);
        let s = a.submatrix(&[2, 0]);
        assert_eq!(s.data(), &[98.0, -16.0, -16.0, 4.0]);
    }

    #[test]
    fn inverse_times_matrix_is_identity() {
        let n = 50;
        let mut rng = Lcg(12345);
        let a = random_spd(n, &mut rng);
        let inv = a.inverse_spd().unwrap();
        let mut col = vec![0.0; n];
        let mut prod = vec![0.0; n];
        let mut worst: f64 = 0.0;
        for j in 0..n {
            for i in 0..n {
                col[i] = a.get(i, j);
            }
            inv.matvec(&col, &mut prod);
            for i in 0..n {
                let e = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((prod[i] - e).abs());
            }
        }
        assert!(worst < 1e-13, "|inv(A) A - I| = {worst:e}");
        for i in 0..n {
            for j in 0..n {
                assert_eq!(inv.get(i, j), inv.get(j, i));
            }
        }
    }

    #[test]
    fn detects_non_spd() {
        // Indefinite: eigenvalues 3 and -1.
        let a = SymMatrix::from_rows(2, vec![1.0, 2.0, 2.0, 1.0]);
        match a.cholesky() {
            Err(DenseError::NotPositiveDefinite { pivot, value }) => {
                assert_eq!(pivot, 1);
                assert!((value + 3.0).abs() < 1e-14);
            }
            other => panic!("expected NotPositiveDefinite, got {other:?}"),
        }
        // Singular (semi-definite) and a negative leading entry.
        let s = SymMatrix::from_rows(2, vec![1.0, 1.0, 1.0, 1.0]);
        assert!(matches!(
            s.cholesky(),
            Err(DenseError::NotPositiveDefinite { pivot: 1, .. })
        ));
        let neg = SymMatrix::from_rows(2, vec![-1.0, 0.0, 0.0, 1.0]);
        assert!(matches!(
            neg.inverse_spd(),
            Err(DenseError::NotPositiveDefinite { pivot: 0, .. })
        ));
        let nan = SymMatrix::from_rows(1, vec![f64::NAN]);
        assert!(nan.cholesky().is_err());
    }

    #[test]
    fn symmetrize_and_matvec() {
        let mut a = SymMatrix::from_rows(2, vec![1.0, 2.0, 4.0, 3.0]);
        a.symmetrize();
        assert_eq!(a.data(), &[1.0, 3.0, 3.0, 3.0]);
        let mut y = [0.0; 2];
        a.matvec(&[1.0, -1.0], &mut y);
        assert_eq!(y, [-2.0, 0.0]);
    }

    #[test]
    fn the_congruence_is_r_a_r_transposed() {
        let a = SymMatrix::from_rows(3, vec![4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0]);
        let rows = vec![
            vec![(0, 1.0), (2, -2.0)],
            vec![(1, 0.5)],
            vec![(0, 0.3), (1, 0.7)],
        ];
        let r = |k: usize, i: usize| rows[k].iter().find(|e| e.0 == i).map_or(0.0, |e| e.1);
        let d = a.congruence(&rows);
        for k in 0..3 {
            for l in 0..3 {
                let mut want = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        want += r(k, i) * a.get(i, j) * r(l, j);
                    }
                }
                assert!((d.get(k, l) - want).abs() < 1e-14, "({k}, {l})");
            }
        }
    }
}
