//! Triangular solves and the inverse Gram matrix on the leading upper triangle.
//!
//! Why: every least-squares solve and covariance goes through `R`; a zero pivot must be
//! reported as an error, never turned into `inf`/`NaN`.

use super::util::{check_capacity, check_finite, check_finite_block, check_len};
use crate::error::{Error, Result};

/// Rejects a zero on the diagonal of the leading `n`×`n` block, reporting the number of
/// non-zero diagonal entries as the rank. Caller guarantees `n <= P`.
pub(crate) fn check_diagonal<const P: usize>(r: &[[f64; P]; P], n: usize) -> Result<()> {
    let rank = (0..n).filter(|&k| r[k][k] != 0.0).count();
    if rank < n {
        return Err(Error::RankDeficient { rank, required: n });
    }
    Ok(())
}

/// Error for a solve that over- or underflowed although every pivot was non-zero.
fn overflow(n: usize) -> Error {
    Error::RankDeficient {
        rank: n.saturating_sub(1),
        required: n,
    }
}

/// Copies the leading `n`×`n` upper triangle of `src` into `dst` and zeroes the rest of
/// `dst`'s leading block, because the kernels below work in place on a caller copy.
///
/// Errors: `CapacityExceeded` if `n > P`.
pub fn copy_upper<const P: usize>(
    src: &[[f64; P]; P],
    n: usize,
    dst: &mut [[f64; P]; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    for (i, (d, s)) in dst.iter_mut().zip(src.iter()).take(n).enumerate() {
        for (j, (dv, sv)) in d.iter_mut().zip(s.iter()).take(n).enumerate() {
            *dv = if j >= i { *sv } else { 0.0 };
        }
    }
    Ok(())
}

/// Solves `R x = b` in place (`x` holds `b` on entry) by back substitution, using only the
/// upper triangle of the leading block of `r`.
///
/// Errors: `CapacityExceeded`, `DimensionMismatch` (`x.len() != n`), `NonFinite`
/// (in `r`'s upper triangle or `x`; `x` then unchanged), `RankDeficient` if a diagonal
/// entry is zero (`x` unchanged) or the result overflows (`x` then unspecified).
pub fn solve_upper<const P: usize>(r: &[[f64; P]; P], n: usize, x: &mut [f64]) -> Result<()> {
    check_capacity::<P>(n)?;
    check_len(x.len(), n)?;
    check_finite_block(r, n, true)?;
    check_finite(x)?;
    check_diagonal(r, n)?;
    backward_unchecked(r, n, x)
}

/// Solves `RᵀR x = b` in place (`x` holds `b` on entry) for a factor `r` that
/// [`super::gram::cholesky_upper_in_place`] has just returned without error: the same
/// result and errors as [`solve_upper_transpose`] then [`solve_upper`], without their
/// scans of the factor (finite, non-zero diagonal), which such a factor always passes —
/// each off-diagonal entry entered a later pivot (`d − r²`), so a non-finite one would
/// have failed that pivot's test, and every diagonal entry is the root of a positive
/// pivot. The right-hand side is checked as those do; after the forward substitution
/// every entry of `x` is a finite quotient, which the second check would pass.
pub(crate) fn solve_normal_factored<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    x: &mut [f64],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_len(x.len(), n)?;
    check_finite(x)?;
    let n = n.min(P);
    forward_unchecked(r, n, x)?;
    backward_unchecked(r, n, x)
}

/// Solves `Rᵀ x = b` in place (`x` holds `b` on entry) by forward substitution, using
/// only the upper triangle of the leading block of `r`.
///
/// Errors: as [`solve_upper`].
pub fn solve_upper_transpose<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    x: &mut [f64],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_len(x.len(), n)?;
    check_finite_block(r, n, true)?;
    check_finite(x)?;
    check_diagonal(r, n)?;
    forward_unchecked(r, n, x)
}

/// Forward substitution for `Rᵀ x = b` without argument checks (column-oriented so `r`
/// is read by rows). Caller guarantees `n <= P`, `x.len() == n`, non-zero diagonal.
pub(crate) fn forward_unchecked<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    x: &mut [f64],
) -> Result<()> {
    for k in 0..n {
        let rk = &r[k];
        let v = x[k] / rk[k];
        if !v.is_finite() {
            return Err(overflow(n));
        }
        x[k] = v;
        for (rkj, xj) in rk[k + 1..n].iter().zip(x[k + 1..n].iter_mut()) {
            *xj -= rkj * v;
        }
    }
    Ok(())
}

/// Back substitution `R x = b` in place without checking `r` (the callers have, or hold a
/// factor that needs no check); refuses an overflowed entry. `n` is clamped to what `r`
/// and `x` hold (the callers checked it) so that no index can be out of bounds.
fn backward_unchecked<const P: usize>(r: &[[f64; P]; P], n: usize, x: &mut [f64]) -> Result<()> {
    let n = n.min(P).min(x.len());
    for i in (0..n).rev() {
        let ri = &r[i];
        let mut sum = x[i];
        for (rij, xj) in ri[i + 1..n].iter().zip(x[i + 1..n].iter()) {
            sum -= rij * xj;
        }
        let v = sum / ri[i];
        if !v.is_finite() {
            return Err(overflow(n));
        }
        x[i] = v;
    }
    Ok(())
}

/// Writes `(RᵀR)⁻¹ = R⁻¹R⁻ᵀ` (full symmetric) into the leading block of `out`, because
/// that is the parameter covariance up to the residual variance.
///
/// Errors: `CapacityExceeded`, `NonFinite` (upper triangle of `r`), `RankDeficient` if a
/// diagonal entry is zero or the inverse overflows (`out` then unspecified).
pub fn upper_inverse_gram<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    out: &mut [[f64; P]; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(r, n, true)?;
    check_diagonal(r, n)?;
    // X = R⁻¹, row by row from the bottom (R·X = I): X[i] = (e_i − Σ_{k>i} R[i][k]·X[k]) /
    // R[i][i]. Each step is an update of a contiguous row (it vectorises, no dependent
    // chain of additions), and every X[i][j] gets its terms in ascending k as in the
    // textbook column recurrence, so the result is the same.
    let n = n.min(P);
    for i in (0..n).rev() {
        let (head, tail) = out.split_at_mut(i + 1);
        let (Some(xi), Some(ri)) = (head.last_mut(), r.get(i)) else {
            continue;
        };
        xi[..n].fill(0.0);
        for (k, xk) in (i + 1..n).zip(tail.iter()) {
            let f = ri[k];
            for (x, &y) in xi[k..n].iter_mut().zip(xk[k..n].iter()) {
                *x -= f * y;
            }
        }
        xi[i] = 1.0;
        for x in &mut xi[i..n] {
            *x /= ri[i];
        }
    }
    // C = X Xᵀ in place, row by row: C[i][j] (j >= i) only needs X[i][k], X[j][k] for k >= j,
    // which are not yet overwritten; the mirror goes to the strictly lower part.
    for i in 0..n {
        for j in i..n {
            let (xi, xj) = (&out[i], &out[j]);
            let sum = super::util::dot(&xi[j..n], &xj[j..n]);
            if !sum.is_finite() {
                return Err(overflow(n));
            }
            out[i][j] = sum;
        }
        let (head, tail) = out.split_at_mut(i + 1);
        if let Some(row_i) = head.last() {
            for (row_j, v) in tail
                .iter_mut()
                .zip(row_i.iter().skip(i + 1))
                .take(n - i - 1)
            {
                row_j[i] = *v;
            }
        }
    }
    Ok(())
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
    use crate::error::Quantity;
    use crate::linalg::testutil::{Rng, assert_close, upper_d};
    use nalgebra::{DMatrix, DVector};

    const P: usize = 12;

    /// Random upper-triangular R with a safely non-zero diagonal (garbage below).
    fn random_r(rng: &mut Rng, n: usize) -> [[f64; P]; P] {
        let mut r = rng.mat::<P>(n);
        for k in 0..n {
            r[k][k] = rng.range(0.5, 2.0) * if k % 2 == 0 { 1.0 } else { -1.0 };
            for j in 0..k {
                r[k][j] = 99.0; // must be ignored
            }
        }
        r
    }

    #[test]
    fn solves_match_nalgebra() {
        let mut rng = Rng(30);
        for n in [0, 1, 5, P] {
            let r = random_r(&mut rng, n);
            let rd = upper_d(&r, n);
            let b = rng.dvec(n);
            let mut x: std::vec::Vec<f64> = b.iter().copied().collect();
            solve_upper(&r, n, &mut x).unwrap();
            let xn = rd.solve_upper_triangular(&b).unwrap();
            assert_close(
                &DMatrix::from_column_slice(n, 1, &x),
                &DMatrix::from_column_slice(n, 1, xn.as_slice()),
                1e-12,
                "R x = b",
            );
            let mut y: std::vec::Vec<f64> = b.iter().copied().collect();
            solve_upper_transpose(&r, n, &mut y).unwrap();
            let res = rd.transpose() * DVector::from_column_slice(&y) - &b;
            assert!(res.amax() <= 1e-12 * (1.0 + b.amax()), "Rᵀ y = b");
        }
    }

    #[test]
    fn inverse_gram_matches_nalgebra_and_is_symmetric() {
        let mut rng = Rng(31);
        for n in [1, 4, P] {
            let r = random_r(&mut rng, n);
            let rd = upper_d(&r, n);
            let mut out = [[5.0; P]; P];
            upper_inverse_gram(&r, n, &mut out).unwrap();
            let c = DMatrix::from_fn(n, n, |i, j| out[i][j]);
            let cn = (rd.transpose() * &rd).try_inverse().unwrap();
            assert_close(&c, &cn, 1e-10, "(RᵀR)⁻¹");
            assert_eq!(c, c.transpose());
            assert_close(
                &(&c * (rd.transpose() * &rd)),
                &DMatrix::identity(n, n),
                1e-10,
                "C·RᵀR = I",
            );
            for i in 0..P {
                for j in 0..P {
                    if i >= n || j >= n {
                        assert_eq!(out[i][j], 5.0);
                    }
                }
            }
        }
    }

    #[test]
    fn copy_upper_zeroes_lower_part() {
        let src = [[1.0; 4]; 4];
        let mut dst = [[7.0; 4]; 4];
        copy_upper(&src, 3, &mut dst).unwrap();
        for i in 0..4 {
            for j in 0..4 {
                let want = if i >= 3 || j >= 3 {
                    7.0
                } else if j >= i {
                    1.0
                } else {
                    0.0
                };
                assert_eq!(dst[i][j], want);
            }
        }
        assert!(copy_upper(&src, 5, &mut dst).is_err());
    }

    #[test]
    fn errors_not_inf() {
        let mut r = [[1.0; 3]; 3];
        r[1][1] = 0.0;
        let mut x = [1.0, 2.0, 3.0];
        let want = Err(Error::RankDeficient {
            rank: 2,
            required: 3,
        });
        assert_eq!(solve_upper(&r, 3, &mut x), want);
        assert_eq!(solve_upper_transpose(&r, 3, &mut x), want);
        assert_eq!(x, [1.0, 2.0, 3.0]);
        let mut out = [[0.0; 3]; 3];
        assert_eq!(upper_inverse_gram(&r, 3, &mut out), want);
        assert_eq!(
            solve_upper(&r, 4, &mut x),
            Err(Error::CapacityExceeded {
                needed: 4,
                capacity: 3
            })
        );
        assert_eq!(
            solve_upper(&r, 2, &mut x),
            Err(Error::DimensionMismatch {
                expected: 2,
                found: 3
            })
        );
        r[1][1] = 1.0;
        r[0][2] = f64::NAN;
        assert_eq!(
            solve_upper(&r, 3, &mut x),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 2
            })
        );
        r[0][2] = 1.0;
        r[2][0] = f64::NAN; // below the diagonal: ignored
        assert!(solve_upper(&r, 3, &mut x).is_ok());
        let mut y = [1.0, f64::INFINITY, 0.0];
        assert_eq!(
            solve_upper_transpose(&r, 3, &mut y),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );
        // Tiny pivot: overflow is reported, not returned as inf.
        let mut t = [[1e-300, 0.0], [0.0, 1.0]];
        t[0][1] = 1.0;
        let mut z = [1e300, 1.0];
        assert!(matches!(
            solve_upper(&t, 2, &mut z),
            Err(Error::RankDeficient { .. })
        ));
    }
}
