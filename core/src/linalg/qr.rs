//! Householder QR with column pivoting (Businger–Golub), rank-revealing.
//!
//! Why: the first `rank` pivot columns of the identification Jacobian (or of its `R`) are
//! a well-conditioned identifiable ("base") parameter subset.

use super::svd::swap_cols;
use super::util::{
    bad_setting, check_capacity, check_finite, check_finite_block, check_len, scale_block,
    scale_exponent,
};
use crate::error::Result;

/// Computes `A·Π = Q·R` of the leading `n`×`n` block of `a` in place.
///
/// At step `k` the remaining column of largest (downdated) norm is moved to position `k`;
/// partial norms are downdated and recomputed on cancellation as in MINPACK `qrfac` /
/// LAPACK `dgeqp3`, so `|rdiag|` is non-increasing (to rounding).
///
/// On success: the upper triangle of `a` (with diagonal) is `R`, `rdiag[k] = R[k][k]`
/// (any sign), `perm[k]` is the original index of the column in position `k`, and the
/// strict lower triangle holds the Householder vectors `v_k` (`v_k[k] = 1` implicit,
/// `H_k = I − 2 v_k v_kᵀ / |v_k|²`, `Q = H_0 ⋯ H_{n−1}`), for [`apply_qt`]. Entries of
/// `perm` and `rdiag` beyond `n` are untouched.
///
/// Errors: `CapacityExceeded` if `n > P`; `NonFinite { Parameter, i * n + j }` (nothing
/// modified).
pub fn pivoted_qr<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    perm: &mut [usize; P],
    rdiag: &mut [f64; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(a, n, false)?;
    for (k, p) in perm.iter_mut().take(n).enumerate() {
        *p = k;
    }
    let e = scale_exponent(a, n).unwrap_or(0);
    scale_block(a, n, -e);
    // rdiag: downdated partial norms; wa: norm at the last recomputation.
    let mut wa = [0.0_f64; P];
    for j in 0..n {
        let norm = libm::sqrt(col_sq(a, n, j, 0));
        rdiag[j] = norm;
        wa[j] = norm;
    }
    for j in 0..n {
        let mut kmax = j;
        for k in j + 1..n {
            if rdiag[k] > rdiag[kmax] {
                kmax = k;
            }
        }
        if kmax != j {
            swap_cols(a, n, j, kmax);
            rdiag.swap(j, kmax);
            wa.swap(j, kmax);
            perm.swap(j, kmax);
        }
        // Reflector for x = a[j..n][j]: H x = beta e_j, v = (x − beta e_j) / (x_j − beta).
        let xnorm = libm::sqrt(col_sq(a, n, j, j));
        let xj = a[j][j];
        let beta = if xj < 0.0 { xnorm } else { -xnorm };
        let vj = xj - beta;
        if vj != 0.0 {
            for row in a.iter_mut().take(n).skip(j + 1) {
                row[j] /= vj;
            }
        }
        // |v|² with v_j = 1 (v = e_j, a no-op-on-zero reflector, when x = 0).
        let vsq = 1.0 + col_sq(a, n, j, j + 1);
        a[j][j] = beta;
        for k in j + 1..n {
            // a_k ← a_k − v (2 vᵀa_k / |v|²)
            let mut dot = a[j][k];
            for row in a.iter().take(n).skip(j + 1) {
                dot += row[j] * row[k];
            }
            let f = 2.0 * dot / vsq;
            a[j][k] -= f;
            for row in a.iter_mut().take(n).skip(j + 1) {
                row[k] -= f * row[j];
            }
            if rdiag[k] != 0.0 {
                let ratio = a[j][k] / rdiag[k];
                rdiag[k] *= libm::sqrt(libm::fmax(0.0, 1.0 - ratio * ratio));
                let rel = rdiag[k] / wa[k];
                if 0.05 * rel * rel <= f64::EPSILON {
                    let norm = libm::sqrt(col_sq(a, n, k, j + 1));
                    rdiag[k] = norm;
                    wa[k] = norm;
                }
            }
        }
        rdiag[j] = beta;
    }
    for (j, row) in a.iter_mut().take(n).enumerate() {
        for x in row.iter_mut().take(n).skip(j) {
            *x = libm::scalbn(*x, e);
        }
    }
    for d in rdiag.iter_mut().take(n) {
        *d = libm::scalbn(*d, e);
    }
    Ok(())
}

/// Applies `Qᵀ` from [`pivoted_qr`] to `x` in place, because solving `R z = Qᵀb` needs it.
///
/// Errors: `CapacityExceeded`, `DimensionMismatch` (`x.len() != n`), `NonFinite` (`x`).
pub fn apply_qt<const P: usize>(qr: &[[f64; P]; P], n: usize, x: &mut [f64]) -> Result<()> {
    check_capacity::<P>(n)?;
    check_len(x.len(), n)?;
    check_finite(x)?;
    for j in 0..n {
        let mut dot = x[j];
        let mut vsq = 1.0;
        for (row, xi) in qr.iter().take(n).skip(j + 1).zip(x.iter().skip(j + 1)) {
            dot += row[j] * xi;
            vsq += row[j] * row[j];
        }
        let f = 2.0 * dot / vsq;
        x[j] -= f;
        for (row, xi) in qr.iter().take(n).skip(j + 1).zip(x.iter_mut().skip(j + 1)) {
            *xi -= f * row[j];
        }
    }
    Ok(())
}

/// Number of leading `|rdiag[k]| > rel_tol·|rdiag[0]|` (stops at the first that fails),
/// because pivoted `R` puts the identifiable directions first. Zero if `rdiag[0] == 0`.
/// A common choice is `rel_tol = n·ε` for numerical rank, or larger (e.g. 1e-8) for a
/// well-conditioned base set.
///
/// Errors: `CapacityExceeded` if `n > P`; `NonFinite { Setting, 0 }` if `rel_tol` is
/// negative or not finite; `NonFinite { Parameter, k }` for a non-finite `rdiag[k]`.
pub fn numerical_rank<const P: usize>(rdiag: &[f64; P], n: usize, rel_tol: f64) -> Result<usize> {
    check_capacity::<P>(n)?;
    if !(rel_tol.is_finite() && rel_tol >= 0.0) {
        return Err(bad_setting());
    }
    let d = &rdiag[..n];
    check_finite(d)?;
    let Some(first) = d.first() else {
        return Ok(0);
    };
    let thresh = rel_tol * libm::fabs(*first);
    Ok(d.iter().take_while(|x| libm::fabs(**x) > thresh).count())
}

/// `Σ_{i >= from} a[i][j]²` over the leading `n` rows.
fn col_sq<const P: usize>(a: &[[f64; P]; P], n: usize, j: usize, from: usize) -> f64 {
    a.iter().take(n).skip(from).map(|row| row[j] * row[j]).sum()
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
    use crate::linalg::testutil::{Rng, assert_close, from_d, low_rank, to_d, upper_d};
    use nalgebra::DMatrix;

    const P: usize = 12;

    /// Factorises, checks the decomposition, returns (qr, perm, rdiag).
    fn check(a0: &[[f64; P]; P], n: usize) -> ([[f64; P]; P], [usize; P], [f64; P]) {
        let mut a = *a0;
        let mut perm = [usize::MAX; P];
        let mut rdiag = [0.0; P];
        pivoted_qr(&mut a, n, &mut perm, &mut rdiag).unwrap();
        let mut seen = [false; P];
        for &p in &perm[..n] {
            assert!(p < n && !seen[p], "perm is a permutation");
            seen[p] = true;
        }
        let ad = to_d(a0, n);
        let ap = DMatrix::from_fn(n, n, |i, j| ad[(i, perm[j])]);
        let r = upper_d(&a, n);
        // Normalise before forming Gram matrices so huge inputs do not overflow the check.
        let sc = ad.amax().max(f64::MIN_POSITIVE);
        let (rs, aps) = (&r / sc, &ap / sc);
        assert_close(
            &(rs.transpose() * &rs),
            &(aps.transpose() * &aps),
            1e-12,
            "RᵀR = (AΠ)ᵀ(AΠ)",
        );
        let scale = rdiag[..n].iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        for k in 0..n {
            assert_eq!(rdiag[k], a[k][k]);
            if k > 0 {
                assert!(
                    rdiag[k].abs() <= rdiag[k - 1].abs() + 1e-12 * scale,
                    "non-increasing"
                );
            }
        }
        // Qᵀ (AΠ) = R via apply_qt, column by column.
        let mut qtap = DMatrix::zeros(n, n);
        for j in 0..n {
            let mut col: std::vec::Vec<f64> = (0..n).map(|i| ap[(i, j)]).collect();
            apply_qt(&a, n, &mut col).unwrap();
            for i in 0..n {
                qtap[(i, j)] = col[i];
            }
        }
        assert_close(&(qtap / sc), &rs, 1e-12, "Qᵀ A Π = R");
        (a, perm, rdiag)
    }

    #[test]
    fn random_full_rank_reconstructs() {
        let mut rng = Rng(20);
        for n in [1, 2, 9, P] {
            let a = rng.mat::<P>(n);
            let (_, _, rdiag) = check(&a, n);
            assert_eq!(numerical_rank(&rdiag, n, 1e-10).unwrap(), n);
        }
    }

    #[test]
    fn rank_detected_on_constructed_deficient_matrices() {
        let mut rng = Rng(21);
        let n = 10;
        let a = from_d::<P>(&low_rank(&mut rng, n, 4));
        let (_, perm, rdiag) = check(&a, n);
        assert_eq!(numerical_rank(&rdiag, n, 1e-10).unwrap(), 4);
        // The chosen base columns are independent.
        let ad = to_d(&a, n);
        let base = DMatrix::from_fn(n, 4, |i, j| ad[(i, perm[j])]);
        assert_eq!(base.rank(1e-8), 4);

        // Calibration-like: duplicated column and a sum of two columns, plus a zero column.
        let mut b = rng.mat::<P>(n);
        for row in b.iter_mut().take(n) {
            row[5] = row[2];
            row[7] = row[1] + row[3];
            row[9] = 0.0;
        }
        let (_, perm, rdiag) = check(&b, n);
        let rank = numerical_rank(&rdiag, n, 1e-10).unwrap();
        assert_eq!(rank, n - 3);
        let chosen = &perm[..rank];
        assert!(!chosen.contains(&9));
        assert!(!(chosen.contains(&5) && chosen.contains(&2)));
        assert!(!(chosen.contains(&7) && chosen.contains(&1) && chosen.contains(&3)));
        assert!(
            rdiag[rank..n]
                .iter()
                .all(|d| d.abs() <= 1e-12 * rdiag[0].abs())
        );
    }

    #[test]
    fn zero_matrix_and_scaled_input() {
        let (_, _, rdiag) = check(&[[0.0; P]; P], 5);
        assert_eq!(numerical_rank(&rdiag, 5, 0.0).unwrap(), 0);
        let mut rng = Rng(22);
        let a = rng.mat::<P>(6);
        let (_, _, r1) = check(&a, 6);
        let mut big = a;
        big.iter_mut().flatten().for_each(|x| *x *= 1e250);
        let (_, _, r2) = check(&big, 6);
        for k in 0..6 {
            assert!((r2[k] / 1e250 - r1[k]).abs() <= 1e-13 * r1[0].abs());
        }
    }

    #[test]
    fn numerical_rank_edges_and_errors() {
        let d = [3.0, -2.0, 1e-9, 0.0];
        assert_eq!(numerical_rank(&d, 4, 1e-6).unwrap(), 2);
        assert_eq!(numerical_rank(&d, 4, 1e-12).unwrap(), 3);
        assert_eq!(numerical_rank(&d, 4, 0.0).unwrap(), 3);
        assert_eq!(numerical_rank(&d, 0, 0.1).unwrap(), 0);
        assert_eq!(
            numerical_rank(&d, 5, 0.1),
            Err(Error::CapacityExceeded {
                needed: 5,
                capacity: 4
            })
        );
        assert_eq!(
            numerical_rank(&d, 4, -1.0),
            Err(Error::NonFinite {
                what: Quantity::Setting,
                index: 0
            })
        );
        assert_eq!(
            numerical_rank(&[1.0, f64::NAN], 2, 0.1),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );

        let mut a = [[1.0; 3]; 3];
        let mut perm = [0; 3];
        let mut rdiag = [0.0; 3];
        assert_eq!(
            pivoted_qr(&mut a, 4, &mut perm, &mut rdiag),
            Err(Error::CapacityExceeded {
                needed: 4,
                capacity: 3
            })
        );
        a[2][0] = f64::INFINITY;
        assert_eq!(
            pivoted_qr(&mut a, 3, &mut perm, &mut rdiag),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 6
            })
        );
        assert_eq!(
            apply_qt(&a, 3, &mut [1.0, 2.0]),
            Err(Error::DimensionMismatch {
                expected: 3,
                found: 2
            })
        );
        assert_eq!(
            apply_qt(&a, 2, &mut [1.0, f64::NAN]),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );
    }
}
