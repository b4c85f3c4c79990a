//! One-sided Jacobi SVD (Hestenes, with de Rijk's column pivoting) of a square block.
//!
//! Why: singular values of `R` are those of the whole identification Jacobian; Jacobi is
//! short, allocation-free and relatively accurate even for tiny singular values.

use super::util::{check_capacity, check_finite_block, scale_block, scale_exponent};
use crate::error::{Error, Result};

/// Maximum number of sweeps before `NotConverged`; quadratic convergence normally needs
/// fewer than 15 for `n <= 100`.
pub const MAX_SWEEPS: u32 = 60;

/// Computes `A = U Σ Vᵀ` of the leading `n`×`n` block of `a` in place.
///
/// On success: `sigma[0..n]` holds the singular values sorted descending (the rest of
/// `sigma` is untouched), columns `0..n` of `v`'s leading block hold the matching right
/// singular vectors (an orthogonal matrix even for rank-deficient input), and columns
/// `0..n` of `a` hold `U·Σ` (left singular vectors scaled by `sigma`; a zero column for a
/// zero singular value). Pairs are rotated until `|aᵢᵀaⱼ| <= n·ε·|aᵢ||aⱼ|` for all `i < j`.
/// The input is scaled by an exact power of two internally, so entries anywhere in the
/// normal range cannot overflow the sums of squares.
///
/// Errors: `CapacityExceeded` if `n > P`; `NonFinite { Parameter, i * n + j }` (nothing
/// modified); `NotConverged { iterations: MAX_SWEEPS }` (outputs hold the partial,
/// still orthogonal, iterate).
pub fn jacobi_svd<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    sigma: &mut [f64; P],
    v: &mut [[f64; P]; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(a, n, false)?;
    for (i, row) in v.iter_mut().take(n).enumerate() {
        for (j, x) in row.iter_mut().take(n).enumerate() {
            *x = if i == j { 1.0 } else { 0.0 };
        }
    }
    let Some(e) = scale_exponent(a, n) else {
        sigma.iter_mut().take(n).for_each(|s| *s = 0.0);
        return Ok(());
    };
    scale_block(a, n, -e);
    let tol = (n as f64) * f64::EPSILON;
    let mut converged = false;
    for _ in 0..MAX_SWEEPS {
        // sigma holds squared column norms during the sweep (recomputed exactly here).
        for (j, s) in sigma.iter_mut().take(n).enumerate() {
            *s = col_dot(a, n, j, j);
        }
        let mut rotated = false;
        for p in 0..n {
            // de Rijk: bring the largest remaining column to position p.
            let mut best = p;
            for k in p + 1..n {
                if sigma[k] > sigma[best] {
                    best = k;
                }
            }
            if best != p {
                swap_cols(a, n, p, best);
                swap_cols(v, n, p, best);
                sigma.swap(p, best);
            }
            for q in p + 1..n {
                let alpha = sigma[p];
                let beta = sigma[q];
                let gamma = col_dot(a, n, p, q);
                // A column whose squared norm underflows to 0 (entries below ~1e-154 of the
                // scaled block's largest) is numerically zero; without this test its
                // non-zero inner products would fail the pair test for ever.
                if gamma == 0.0
                    || alpha == 0.0
                    || beta == 0.0
                    || libm::fabs(gamma) <= tol * libm::sqrt(alpha) * libm::sqrt(beta)
                {
                    continue;
                }
                rotated = true;
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = libm::copysign(1.0, zeta) / (libm::fabs(zeta) + libm::hypot(1.0, zeta));
                let c = 1.0 / libm::hypot(1.0, t);
                let s = c * t;
                rotate_cols(a, n, p, q, c, s);
                rotate_cols(v, n, p, q, c, s);
                // Incremental norms; recomputed exactly when cancellation leaves nothing
                // (a rank-deficient block): a clamped 0 against a column of rounding-level
                // entries would fail the pair test for ever.
                let (np, nq) = (alpha - t * gamma, beta + t * gamma);
                sigma[p] = if np > 0.0 { np } else { col_dot(a, n, p, p) };
                sigma[q] = if nq > 0.0 { nq } else { col_dot(a, n, q, q) };
            }
        }
        if !rotated {
            converged = true;
            break;
        }
    }
    for (j, s) in sigma.iter_mut().take(n).enumerate() {
        *s = libm::sqrt(col_dot(a, n, j, j));
    }
    // Final stable selection sort, descending.
    for p in 0..n {
        let mut best = p;
        for k in p + 1..n {
            if sigma[k] > sigma[best] {
                best = k;
            }
        }
        if best != p {
            swap_cols(a, n, p, best);
            swap_cols(v, n, p, best);
            sigma.swap(p, best);
        }
    }
    scale_block(a, n, e);
    for s in sigma.iter_mut().take(n) {
        *s = libm::scalbn(*s, e);
    }
    if converged {
        Ok(())
    } else {
        Err(Error::NotConverged {
            iterations: MAX_SWEEPS,
        })
    }
}

/// The pair test `|γ| <= tol·√α·√β` of the values-only sweep, squared when no product can
/// underflow (the square roots, not the vector work, dominate a pair of short rows).
#[inline]
fn orthogonal(gamma: f64, alpha: f64, beta: f64, tol: f64) -> bool {
    let ab = alpha * beta;
    if ab > 1e-250 && gamma * gamma > 1e-280 {
        gamma * gamma <= (tol * tol) * ab
    } else {
        gamma.abs() <= tol * libm::sqrt(alpha) * libm::sqrt(beta)
    }
}

/// Singular values only (sorted descending into `sigma[0..n]`) of the leading `n`×`n`
/// block of `a`, which is destroyed.
///
/// Why a second routine: when only the values are wanted (a condition number), one-sided
/// Jacobi can orthogonalise the *rows* instead of the columns (`A` and `Aᵀ` have the same
/// singular values): rows are contiguous in row-major storage, so every dot product and
/// rotation streams through memory, and no `V` is accumulated. For a triangular factor
/// `R` of a QR decomposition the rows are also closer to orthogonal than the columns
/// (Drmač–Veselić), so fewer sweeps are needed. Same scaling, pivoting, pair test and
/// errors as [`jacobi_svd`].
pub fn jacobi_singular_values<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    sigma: &mut [f64; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(a, n, false)?;
    let Some(e) = scale_exponent(a, n) else {
        sigma.iter_mut().take(n).for_each(|s| *s = 0.0);
        return Ok(());
    };
    scale_block(a, n, -e);
    let tol = (n as f64) * f64::EPSILON;
    let mut converged = false;
    for _ in 0..MAX_SWEEPS {
        for (j, s) in sigma.iter_mut().take(n).enumerate() {
            *s = row_dot(a, n, j, j);
        }
        let mut rotated = false;
        for p in 0..n {
            let mut best = p;
            for k in p + 1..n {
                if sigma[k] > sigma[best] {
                    best = k;
                }
            }
            if best != p {
                a.swap(p, best);
                sigma.swap(p, best);
            }
            for q in p + 1..n {
                let alpha = sigma[p];
                let beta = sigma[q];
                let gamma = row_dot(a, n, p, q);
                if gamma == 0.0
                    || alpha == 0.0
                    || beta == 0.0
                    || orthogonal(gamma, alpha, beta, tol)
                {
                    continue;
                }
                rotated = true;
                let (c, s, t) = jacobi_rotation(alpha, beta, gamma);
                rotate_rows(a, n, p, q, c, s);
                let (np, nq) = (alpha - t * gamma, beta + t * gamma);
                sigma[p] = if np > 0.0 { np } else { row_dot(a, n, p, p) };
                sigma[q] = if nq > 0.0 { nq } else { row_dot(a, n, q, q) };
            }
        }
        if !rotated {
            converged = true;
            break;
        }
    }
    for (j, s) in sigma.iter_mut().take(n).enumerate() {
        *s = libm::scalbn(libm::sqrt(row_dot(a, n, j, j)), e);
    }
    if let Some(s) = sigma.get_mut(..n) {
        s.sort_unstable_by(|x, y| y.total_cmp(x));
    }
    if converged {
        Ok(())
    } else {
        Err(Error::NotConverged {
            iterations: MAX_SWEEPS,
        })
    }
}

/// Rutishauser's rotation `(c, s, t = s/c)` that orthogonalises two vectors of squared
/// norms `alpha`, `beta` and inner product `gamma != 0`:
/// `t = sign(ζ)/(|ζ| + √(1 + ζ²))`, `ζ = (β − α)/(2γ)`, `c = 1/√(1 + t²)`.
///
/// Why this form: for short rows the pair's chain of dependent divisions and square roots,
/// not its two vector passes, sets the cost. With `d = β − α`, `g = 2γ`, `r = √(d² + g²)`
/// and `u = |d| + r`, the same rotation is `t = ±|g|/u`, `c = u/w`, `s = ±|g|/w` with
/// `w = √(u² + g²) = √(2ru)`: two dependent square roots and one division instead of three
/// divisions and two square roots (`t` comes off the critical path). Outside the range in
/// which `d² + g²` can neither overflow nor underflow, the textbook form in `ζ`.
#[inline]
fn jacobi_rotation(alpha: f64, beta: f64, gamma: f64) -> (f64, f64, f64) {
    let d = beta - alpha;
    let g = 2.0 * gamma;
    let m = d.abs().max(g.abs());
    if m > 1e-150 && m < 1e150 {
        let r = libm::sqrt(d * d + g * g);
        let u = d.abs() + r;
        let w = libm::sqrt(2.0 * r * u);
        // sign(ζ) = sign(d)·sign(g), with d = +0 counted positive as ζ = +0/g would be.
        let ag = if (d < 0.0) == (g < 0.0) {
            g.abs()
        } else {
            -g.abs()
        };
        return (u / w, ag / w, ag / u);
    }
    let zeta = d / g;
    let t = if zeta.abs() < 1e150 {
        zeta.signum() / (zeta.abs() + libm::sqrt(1.0 + zeta * zeta))
    } else {
        0.5 / zeta
    };
    let c = 1.0 / libm::sqrt(1.0 + t * t);
    (c, c * t, t)
}

/// `Σⱼ a[p][j]·a[q][j]` over the leading `n` columns.
fn row_dot<const P: usize>(a: &[[f64; P]; P], n: usize, p: usize, q: usize) -> f64 {
    super::util::dot(&a[p][..n], &a[q][..n])
}

/// `(a_p, a_q) ← (c·a_p − s·a_q, s·a_p + c·a_q)` for rows `p < q`, leading `n` columns.
fn rotate_rows<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    p: usize,
    q: usize,
    c: f64,
    s: f64,
) {
    let (head, tail) = a.split_at_mut(q);
    let (Some(rp), Some(rq)) = (head.get_mut(p), tail.first_mut()) else {
        return;
    };
    for (x, y) in rp[..n].iter_mut().zip(rq[..n].iter_mut()) {
        let (u, v) = (*x, *y);
        *x = c * u - s * v;
        *y = s * u + c * v;
    }
}

/// `Σᵢ a[i][p]·a[i][q]` over the leading `n` rows.
fn col_dot<const P: usize>(a: &[[f64; P]; P], n: usize, p: usize, q: usize) -> f64 {
    a.iter().take(n).map(|row| row[p] * row[q]).sum()
}

/// Swaps columns `p` and `q` in the leading `n` rows.
pub(crate) fn swap_cols<const P: usize>(a: &mut [[f64; P]; P], n: usize, p: usize, q: usize) {
    for row in a.iter_mut().take(n) {
        row.swap(p, q);
    }
}

/// `(a_p, a_q) ← (c·a_p − s·a_q, s·a_p + c·a_q)` over the leading `n` rows.
fn rotate_cols<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    p: usize,
    q: usize,
    c: f64,
    s: f64,
) {
    for row in a.iter_mut().take(n) {
        let x = row[p];
        let y = row[q];
        row[p] = c * x - s * y;
        row[q] = s * x + c * y;
    }
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
    use crate::linalg::testutil::{Rng, assert_close, from_d, low_rank, to_d};
    use nalgebra::DMatrix;

    const P: usize = 12;

    /// Runs the SVD and checks it against nalgebra; returns sigma.
    fn check(a0: &[[f64; P]; P], n: usize) -> [f64; P] {
        let mut a = *a0;
        let mut sigma = [0.0; P];
        let mut v = [[0.0; P]; P];
        jacobi_svd(&mut a, n, &mut sigma, &mut v).unwrap();
        let ad = to_d(a0, n);
        let mut sn: std::vec::Vec<f64> = ad
            .clone()
            .svd(false, false)
            .singular_values
            .iter()
            .copied()
            .collect();
        sn.sort_by(|x, y| y.partial_cmp(x).unwrap());
        let smax = sn[0].max(f64::MIN_POSITIVE);
        for k in 0..n {
            assert!(k == 0 || sigma[k] <= sigma[k - 1], "descending");
            assert!(
                (sigma[k] - sn[k]).abs() <= 1e-12 * smax,
                "sigma[{k}] {} vs {}",
                sigma[k],
                sn[k]
            );
        }
        let us = to_d(&a, n);
        let vd = to_d(&v, n);
        assert_close(&(&us * vd.transpose()), &ad, 1e-12, "U Σ Vᵀ = A");
        assert_close(
            &(vd.transpose() * &vd),
            &DMatrix::identity(n, n),
            1e-12,
            "VᵀV = I",
        );
        // (UΣ)ᵀ(UΣ) = Σ².
        let s2 = DMatrix::from_fn(n, n, |i, j| if i == j { sigma[i] * sigma[i] } else { 0.0 });
        let g = us.transpose() * &us;
        assert!(
            (&g - &s2).amax() <= 1e-12 * smax * smax,
            "columns of UΣ orthogonal"
        );
        sigma
    }

    #[test]
    fn random_matches_nalgebra_for_sizes_1_2_5_p() {
        let mut rng = Rng(10);
        for n in [1, 2, 5, P] {
            for _ in 0..3 {
                let a = rng.mat::<P>(n);
                let sigma = check(&a, n);
                // Well-conditioned random: each value relatively accurate too.
                let sn = to_d(&a, n).singular_values();
                let mut sn: std::vec::Vec<f64> = sn.iter().copied().collect();
                sn.sort_by(|x, y| y.partial_cmp(x).unwrap());
                for k in 0..n {
                    assert!(
                        (sigma[k] - sn[k]).abs() <= 1e-11 * sn[k],
                        "relative sigma[{k}]"
                    );
                }
            }
        }
    }

    #[test]
    fn rank_deficient_and_duplicate_or_zero_columns() {
        let mut rng = Rng(11);
        let n = 9;
        let a = from_d::<P>(&low_rank(&mut rng, n, 3));
        let sigma = check(&a, n);
        assert!(sigma[2] > 1e-3 * sigma[0]);
        assert!(
            sigma[3..n].iter().all(|s| *s <= 1e-14 * sigma[0]),
            "{sigma:?}"
        );

        let mut b = rng.mat::<P>(n);
        for row in b.iter_mut().take(n) {
            row[4] = 0.0;
            row[6] = row[1];
        }
        let sigma = check(&b, n);
        assert_eq!(sigma[n - 1], 0.0);
        assert!(sigma[n - 2] <= 1e-14 * sigma[0]);
    }

    #[test]
    fn column_with_underflowing_squares_terminates() {
        // Entries ~1e-200 next to entries ~1: the tiny column's squared norm underflows to
        // 0 while its inner products do not (seen on the Givens factor of a rank-deficient
        // pose set); the sweep used to rotate that pair for ever.
        let n = 4;
        let mut a = [[0.0; P]; P];
        for i in 0..n {
            for j in 0..n {
                a[i][j] = 1.0 / (1.0 + (i + 2 * j) as f64);
            }
            a[i][2] = 1e-200 * (i as f64 + 1.0);
        }
        let mut sigma = [0.0; P];
        let mut v = [[0.0; P]; P];
        jacobi_svd(&mut a, n, &mut sigma, &mut v).unwrap();
        assert!(sigma[n - 1] <= 1e-150, "{sigma:?}");
        assert!(sigma[n - 2] > 1e-6, "{sigma:?}");
    }

    #[test]
    fn zero_matrix_gives_zero_sigma_and_identity_v() {
        for n in [0, 1, 4] {
            let mut a = [[0.0; P]; P];
            let mut sigma = [5.0; P];
            let mut v = [[3.0; P]; P];
            jacobi_svd(&mut a, n, &mut sigma, &mut v).unwrap();
            for i in 0..n {
                assert_eq!(sigma[i], 0.0);
                for j in 0..n {
                    assert_eq!(v[i][j], if i == j { 1.0 } else { 0.0 });
                }
            }
            assert!(sigma[n..].iter().all(|s| *s == 5.0));
        }
    }

    #[test]
    fn huge_and_tiny_scales_and_untouched_outside_block() {
        let mut rng = Rng(12);
        let n = 6;
        let base = rng.mat::<P>(n);
        let s0 = check(&base, n);
        for scale in [1e200, 1e-200] {
            let mut a = base;
            for (i, row) in a.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    if i < n && j < n {
                        *x *= scale;
                    } else {
                        *x = 7.0;
                    }
                }
            }
            let mut sigma = [0.0; P];
            let mut v = [[9.0; P]; P];
            jacobi_svd(&mut a, n, &mut sigma, &mut v).unwrap();
            for k in 0..n {
                assert!((sigma[k] / scale - s0[k]).abs() <= 1e-13 * s0[0]);
            }
            for i in 0..P {
                for j in 0..P {
                    if i >= n || j >= n {
                        assert_eq!(a[i][j], 7.0);
                        assert_eq!(v[i][j], 9.0);
                    }
                }
            }
        }
    }

    #[test]
    fn graded_matrix_keeps_small_singular_values_relatively_accurate() {
        // A = D1 · Q · D2 with known tiny singular values is hard to verify without a
        // reference; use a diagonal with a rotation: singular values are exact.
        let mut a = [[0.0; P]; P];
        let (c, s) = (0.6, 0.8);
        a[0][0] = 1.0 * c;
        a[0][1] = -1e-9 * s;
        a[1][0] = 1.0 * s;
        a[1][1] = 1e-9 * c;
        a[2][2] = 1e-15;
        let mut sigma = [0.0; P];
        let mut v = [[0.0; P]; P];
        jacobi_svd(&mut a, 3, &mut sigma, &mut v).unwrap();
        assert!((sigma[0] - 1.0).abs() <= 1e-15);
        assert!((sigma[1] - 1e-9).abs() <= 1e-9 * 1e-14, "{}", sigma[1]);
        assert!((sigma[2] - 1e-15).abs() <= 1e-15 * 1e-14);
    }

    #[test]
    fn values_only_row_jacobi_matches_the_full_svd() {
        let mut rng = Rng(77);
        for (n, k) in [(1, 1), (2, 2), (5, 5), (P, P), (P, 7), (6, 0)] {
            let a0: [[f64; P]; P] = if k == n {
                rng.mat(n)
            } else {
                from_d(&low_rank(&mut rng, n, k))
            };
            let (mut a, mut b) = (a0, a0);
            let (mut s1, mut s2) = ([0.0; P], [0.0; P]);
            let mut v = [[0.0; P]; P];
            jacobi_svd(&mut a, n, &mut s1, &mut v).unwrap();
            jacobi_singular_values(&mut b, n, &mut s2).unwrap();
            for i in 0..n {
                assert!(
                    (s1[i] - s2[i]).abs() <= 1e-13 * (s1[0] + 1e-300),
                    "{n}/{k}: {i}"
                );
                assert!(i == 0 || s2[i] <= s2[i - 1], "descending");
            }
        }
        // Graded: the small values keep their relative accuracy.
        let mut a = [[0.0; P]; P];
        a[0][0] = 0.6;
        a[0][1] = -0.8e-9;
        a[1][0] = 0.8;
        a[1][1] = 0.6e-9;
        a[2][2] = 1e-15;
        let mut sigma = [0.0; P];
        jacobi_singular_values(&mut a, 3, &mut sigma).unwrap();
        assert!((sigma[0] - 1.0).abs() <= 1e-15);
        assert!((sigma[1] - 1e-9).abs() <= 1e-9 * 1e-14, "{}", sigma[1]);
        assert!((sigma[2] - 1e-15).abs() <= 1e-15 * 1e-14);
        let mut z = [[0.0; P]; P];
        jacobi_singular_values(&mut z, 4, &mut sigma).unwrap();
        assert_eq!(&sigma[..4], &[0.0; 4]);
        z[1][2] = f64::NAN;
        assert!(jacobi_singular_values(&mut z, 4, &mut sigma).is_err());
    }

    #[test]
    fn large_ill_conditioned_converges() {
        const Q: usize = 48;
        let mut rng = Rng(13);
        let n = Q;
        // Rank 30 plus 1e-10 noise: a typical nearly-unidentifiable calibration R.
        let ad = low_rank(&mut rng, n, 30) + rng.dmat(n, n) * 1e-10;
        let a0 = std::boxed::Box::new(from_d::<Q>(&ad));
        let mut a = a0.clone();
        let mut sigma = [0.0; Q];
        let mut v = std::boxed::Box::new([[0.0; Q]; Q]);
        jacobi_svd(&mut a, n, &mut sigma, &mut v).unwrap();
        let mut sn: std::vec::Vec<f64> = ad.clone().singular_values().iter().copied().collect();
        sn.sort_by(|x, y| y.partial_cmp(x).unwrap());
        for k in 0..n {
            assert!((sigma[k] - sn[k]).abs() <= 1e-12 * sn[0], "sigma[{k}]");
        }
        let us = to_d(&a, n);
        let vd = to_d(&v, n);
        assert_close(&(&us * vd.transpose()), &ad, 1e-12, "U Σ Vᵀ = A");
        assert_close(
            &(vd.transpose() * &vd),
            &DMatrix::identity(n, n),
            1e-12,
            "VᵀV = I",
        );
    }

    #[test]
    fn errors_are_returned() {
        let mut a = [[1.0; 3]; 3];
        let mut sigma = [0.0; 3];
        let mut v = [[0.0; 3]; 3];
        assert_eq!(
            jacobi_svd(&mut a, 4, &mut sigma, &mut v),
            Err(Error::CapacityExceeded {
                needed: 4,
                capacity: 3
            })
        );
        a[1][2] = f64::NAN;
        assert_eq!(
            jacobi_svd(&mut a, 3, &mut sigma, &mut v),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 5
            })
        );
        assert_eq!(a[0][0], 1.0);
        // NaN outside the leading block is ignored.
        assert!(jacobi_svd(&mut a, 2, &mut sigma, &mut v).is_ok());
        assert!((sigma[0] - 2.0).abs() < 1e-15 && sigma[1].abs() < 1e-15);
    }
}
