//! Minimum-norm least-squares solution via the Jacobi SVD (like Matlab `lsqminnorm`).
//!
//! Why: with unidentifiable parameters `R` is singular; the minimum-norm solution leaves
//! the unobservable directions at zero change instead of failing or blowing up.

use super::svd::jacobi_svd;
use super::util::{bad_setting, check_capacity, check_finite, check_finite_block, check_len};
use crate::error::Result;

/// Work space of [`min_norm_solve`]; after a successful call it holds the SVD of the
/// input. Any contents (all-zero included) are valid on entry.
#[derive(Debug, Clone)]
pub struct SvdScratch<const P: usize> {
    us: [[f64; P]; P],
    v: [[f64; P]; P],
    sigma: [f64; P],
}

impl<const P: usize> SvdScratch<P> {
    /// Zeroed scratch; prefer zeroed caller memory for large `P` (returned by value).
    pub const fn new() -> Self {
        Self {
            us: [[0.0; P]; P],
            v: [[0.0; P]; P],
            sigma: [0.0; P],
        }
    }

    /// Singular values (descending) of the last input, entries `0..n`.
    pub fn sigma(&self) -> &[f64; P] {
        &self.sigma
    }

    /// Right singular vectors (columns `0..n`) of the last input.
    pub fn v(&self) -> &[[f64; P]; P] {
        &self.v
    }

    /// `U·Σ` (columns `0..n`) of the last input.
    pub fn us(&self) -> &[[f64; P]; P] {
        &self.us
    }
}

impl<const P: usize> Default for SvdScratch<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// Default relative tolerance `max(n, 1)·ε` (singular values `<= tol·σ_max` are dropped),
/// as `lsqminnorm`'s `max(size(A))·eps(norm(A))` for a square matrix.
pub fn default_rel_tol(n: usize) -> f64 {
    (n.max(1) as f64) * f64::EPSILON
}

/// Writes the minimum-norm minimiser of `|A x − b|` into `x`, where `A` is the full
/// leading `n`×`n` block of `a` (typically `R`, with `b = qtb`), and returns the rank
/// used: the number of singular values `> rel_tol·σ_max` (`rel_tol` defaults to
/// [`default_rel_tol`]). `x = Σ_{k<rank} v_k (u_kᵀ b) / σ_k`; `x = 0` when `A = 0`.
///
/// Errors: `CapacityExceeded`; `DimensionMismatch` (`b`, `x` length `!= n`);
/// `NonFinite { Setting, 0 }` for a negative or non-finite `rel_tol`;
/// `NonFinite { Parameter, .. }` for `a` (index `i*n+j`) or `b`; `NotConverged` from the
/// SVD. `x` is unchanged after an error.
pub fn min_norm_solve<const P: usize>(
    a: &[[f64; P]; P],
    n: usize,
    b: &[f64],
    rel_tol: Option<f64>,
    x: &mut [f64],
    scratch: &mut SvdScratch<P>,
) -> Result<usize> {
    check_capacity::<P>(n)?;
    check_len(b.len(), n)?;
    check_len(x.len(), n)?;
    let rel_tol = rel_tol.unwrap_or(default_rel_tol(n));
    if !(rel_tol.is_finite() && rel_tol >= 0.0) {
        return Err(bad_setting());
    }
    check_finite_block(a, n, false)?;
    check_finite(b)?;
    let SvdScratch { us, v, sigma } = scratch;
    for (d, s) in us.iter_mut().zip(a.iter()).take(n) {
        for (dv, sv) in d.iter_mut().zip(s.iter()).take(n) {
            *dv = *sv;
        }
    }
    jacobi_svd(us, n, sigma, v)?;
    let smax = sigma.first().copied().unwrap_or(0.0);
    let mut rank = if smax > 0.0 {
        let thresh = rel_tol * smax;
        sigma.iter().take(n).take_while(|s| **s > thresh).count()
    } else {
        0
    };
    x.fill(0.0);
    for k in 0..rank {
        // u_kᵀb / σ_k = (σ_k u_k)ᵀ b / σ_k².
        let dot: f64 = us
            .iter()
            .take(n)
            .zip(b.iter())
            .map(|(row, bi)| row[k] * bi)
            .sum();
        let coef = (dot / sigma[k]) / sigma[k];
        if !coef.is_finite() {
            // Only possible for rel_tol ≈ 0 and a subnormal σ_k: truncate there.
            rank = k;
            break;
        }
        for (row, xi) in v.iter().take(n).zip(x.iter_mut()) {
            *xi += coef * row[k];
        }
    }
    Ok(rank)
}

#[cfg(test)]
#[allow(
    clippy::needless_range_loop,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic
)]
mod tests {
    extern crate std;

    use super::*;
    use crate::error::{Error, Quantity};
    use crate::linalg::testutil::{Rng, from_d, low_rank};
    use nalgebra::DVector;

    const P: usize = 12;

    #[test]
    fn rank_deficient_matches_pseudo_inverse() {
        let mut rng = Rng(40);
        let mut scratch = SvdScratch::<P>::new();
        for (n, k) in [(7, 3), (P, 5), (4, 1)] {
            let ad = low_rank(&mut rng, n, k);
            let a = from_d::<P>(&ad);
            // b with a component outside the range, so the solution is least squares.
            let b = rng.dvec(n);
            let mut x = std::vec![0.0; n];
            let rank = min_norm_solve(&a, n, b.as_slice(), None, &mut x, &mut scratch).unwrap();
            assert_eq!(rank, k);
            let smax = scratch.sigma()[0];
            let pinv = ad.clone().pseudo_inverse(1e-10 * smax).unwrap();
            let xn = &pinv * &b;
            let xd = DVector::from_column_slice(&x);
            assert!((&xd - &xn).amax() <= 1e-10 * xn.amax(), "{xd} {xn}");
            // Optimality: residual orthogonal to the range, and x in the row space (min norm).
            let res = &b - &ad * &xd;
            assert!((ad.transpose() * &res).amax() <= 1e-10 * b.amax() * smax);
        }
    }

    #[test]
    fn full_rank_equals_inverse_and_zero_matrix_gives_zero() {
        let mut rng = Rng(41);
        let mut scratch = SvdScratch::<P>::new();
        let n = 6;
        let a = rng.mat::<P>(n);
        let ad = crate::linalg::testutil::to_d(&a, n);
        let b = rng.dvec(n);
        let mut x = std::vec![0.0; n];
        assert_eq!(
            min_norm_solve(&a, n, b.as_slice(), None, &mut x, &mut scratch).unwrap(),
            n
        );
        let xn = ad.lu().solve(&b).unwrap();
        assert!((DVector::from_column_slice(&x) - &xn).amax() <= 1e-11 * xn.amax());

        let z = [[0.0; P]; P];
        let mut x = std::vec![1.0; n];
        assert_eq!(
            min_norm_solve(&z, n, b.as_slice(), None, &mut x, &mut scratch).unwrap(),
            0
        );
        assert!(x.iter().all(|v| *v == 0.0));

        // A loose tolerance drops small singular values.
        let mut d = [[0.0; P]; P];
        d[0][0] = 1.0;
        d[1][1] = 1e-6;
        let mut x = [0.0; 2];
        assert_eq!(
            min_norm_solve(&d, 2, &[2.0, 3.0], Some(1e-3), &mut x, &mut scratch).unwrap(),
            1
        );
        assert_eq!(x, [2.0, 0.0]);
        assert_eq!(
            min_norm_solve(&d, 2, &[2.0, 3.0], None, &mut x, &mut scratch).unwrap(),
            2
        );
        assert!((x[1] - 3e6).abs() < 1e-6);
    }

    #[test]
    fn errors_are_returned() {
        let mut scratch = SvdScratch::<3>::new();
        let a = [[1.0; 3]; 3];
        let mut x = [0.0; 3];
        assert_eq!(
            min_norm_solve(&a, 4, &[0.0; 4], None, &mut [0.0; 4], &mut scratch),
            Err(Error::CapacityExceeded {
                needed: 4,
                capacity: 3
            })
        );
        assert_eq!(
            min_norm_solve(&a, 3, &[0.0; 2], None, &mut x, &mut scratch),
            Err(Error::DimensionMismatch {
                expected: 3,
                found: 2
            })
        );
        assert_eq!(
            min_norm_solve(&a, 3, &[0.0; 3], None, &mut x[..2], &mut scratch),
            Err(Error::DimensionMismatch {
                expected: 3,
                found: 2
            })
        );
        assert_eq!(
            min_norm_solve(&a, 3, &[0.0, f64::NAN, 0.0], None, &mut x, &mut scratch),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );
        assert_eq!(
            min_norm_solve(&a, 3, &[0.0; 3], Some(f64::NAN), &mut x, &mut scratch),
            Err(Error::NonFinite {
                what: Quantity::Setting,
                index: 0
            })
        );
    }
}
