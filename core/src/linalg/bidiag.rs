//! Singular values (only) of a square block: Householder bidiagonalisation, then the
//! implicit-shift QR iteration of Golub, Kahan and Reinsch on the bidiagonal.
//!
//! Why: the identifiability analysis needs all singular values of the unit-column-scaled
//! triangular factor (a condition number, and the spectrum it reports). One-sided Jacobi
//! spends about six sweeps of n²/2 rotations on it, each rotation a chain of dependent
//! square roots and divisions; here the O(n³) work is one bidiagonalisation of contiguous
//! row updates, and the iteration works on 2n numbers. Both are backward stable: every
//! singular value carries an absolute error of a small multiple of `ε·σ_max`, which for a
//! unit-column-scaled matrix is as accurate as Jacobi (whose advantage, relative accuracy
//! for badly *column-scaled* matrices, the scaling has already taken).

use super::util::{check_capacity, check_finite_block, scale_block, scale_exponent};
use crate::error::{Error, Result};

/// Most QR iterations per singular value before `NotConverged` (2–3 are usual).
pub const MAX_QR_ITERATIONS: u32 = 75;

/// Singular values (sorted descending into `sigma[0..n]`) of the leading `n`×`n` block of
/// `a`, which is destroyed; `e` is scratch (the superdiagonal). The block is scaled by an
/// exact power of two first, so no square can overflow.
///
/// Errors: `CapacityExceeded` if `n > P`; `NonFinite { Parameter, i * n + j }` (nothing
/// modified); `NotConverged` if one value needs more than [`MAX_QR_ITERATIONS`] steps
/// (not seen for finite input).
pub fn singular_values<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    sigma: &mut [f64; P],
    e: &mut [f64; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(a, n, false)?;
    let n = n.min(P);
    let Some(exp) = scale_exponent(a, n) else {
        sigma.iter_mut().take(n).for_each(|s| *s = 0.0);
        return Ok(());
    };
    scale_block(a, n, -exp);
    bidiagonalise(a, n, sigma, e);
    // Superdiagonal in the QR iteration's convention: e[i] couples d[i − 1] and d[i].
    for i in (1..n).rev() {
        e[i] = e[i - 1];
    }
    if let Some(e0) = e.first_mut() {
        *e0 = 0.0;
    }
    let (d, e) = (&mut sigma[..n], &mut e[..n]);
    let anorm = d
        .iter()
        .zip(e.iter())
        .fold(0.0_f64, |m, (x, y)| m.max(x.abs() + y.abs()));
    for k in (0..n).rev() {
        converge_last(d, e, k, anorm)?;
    }
    for s in d.iter_mut() {
        *s = libm::scalbn(s.abs(), exp);
    }
    d.sort_unstable_by(|x, y| y.total_cmp(x));
    Ok(())
}

/// `√(x² + y²)` without spurious overflow or underflow.
#[inline]
fn pythag(x: f64, y: f64) -> f64 {
    let m = x.abs().max(y.abs());
    if m > 1e-150 && m < 1e150 {
        libm::sqrt(x * x + y * y)
    } else {
        libm::hypot(x, y)
    }
}

/// Householder reflector of `x` (length >= 1): `(β, τ, 1/v₀)` with `H·x = β·e₀`,
/// `H = I − τ·v·vᵀ`, `v = x − β·e₀` scaled to `v₀ = 1` (the caller multiplies by `1/v₀`).
/// `None` when `x` is negligible (its squares underflow): nothing to reflect.
#[inline]
fn reflector(x: &[f64]) -> Option<(f64, f64, f64)> {
    let x0 = *x.first()?;
    let norm = libm::sqrt(super::util::dot(x, x));
    if norm == 0.0 {
        return None;
    }
    let beta = if x0 < 0.0 { norm } else { -norm };
    let v0 = x0 - beta;
    Some((beta, (beta - x0) / beta, 1.0 / v0))
}

/// Reduces the leading block to upper bidiagonal form by reflections from both sides:
/// diagonal in `d[0..n]`, superdiagonal in `e[0..n − 1]` (`e[k]` couples `d[k]`, `d[k + 1]`),
/// `e[n − 1] = 0`. Every update runs over contiguous rows; the left reflection's row sums
/// go to `d[k + 1..n]`, not yet in use.
fn bidiagonalise<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    d: &mut [f64; P],
    e: &mut [f64; P],
) {
    let n = n.min(P);
    for k in 0..n {
        left_reflection(a, n, k, d);
        let Some(ek) = e.get_mut(k) else {
            return;
        };
        *ek = right_reflection(a, n, k);
    }
}

/// Zeroes column `k` below the diagonal (rows `k..n`, columns `k..n`); `d[k] = β`. The
/// reflector's vector is kept in column `k` itself, below the diagonal.
fn left_reflection<const P: usize>(a: &mut [[f64; P]; P], n: usize, k: usize, d: &mut [f64; P]) {
    let n = n.min(P);
    if k >= n {
        return;
    }
    let (head, tail) = a.split_at_mut(k + 1);
    let (Some(rk), Some(dk)) = (head.last_mut(), d.get_mut(k)) else {
        return;
    };
    let tail = &mut tail[..n - k - 1];
    let x0 = rk[k];
    let sq = tail.iter().fold(x0 * x0, |s, row| s + row[k] * row[k]);
    let norm = libm::sqrt(sq);
    if norm == 0.0 {
        // Negligible column (its squares underflow): nothing to reflect.
        *dk = x0;
        return;
    }
    let beta = if x0 < 0.0 { norm } else { -norm };
    let (tau, inv_v0) = ((beta - x0) / beta, 1.0 / (x0 - beta));
    *dk = beta;
    // v = (1, a[k+1..n][k]/v₀); w = vᵀ·A[k..n][k+1..n] accumulated row by row in d[k+1..n].
    for row in tail.iter_mut() {
        row[k] *= inv_v0;
    }
    let w = &mut d[k + 1..n];
    w.copy_from_slice(&rk[k + 1..n]);
    for row in tail.iter() {
        let v = row[k];
        for (wj, &aj) in w.iter_mut().zip(&row[k + 1..n]) {
            *wj += v * aj;
        }
    }
    for (rj, &wj) in rk[k + 1..n].iter_mut().zip(w.iter()) {
        *rj -= tau * wj;
    }
    for row in tail.iter_mut() {
        let f = tau * row[k];
        for (aj, &wj) in row[k + 1..n].iter_mut().zip(w.iter()) {
            *aj -= f * wj;
        }
    }
}

/// Zeroes row `k` right of the superdiagonal (columns `k + 1..n`, rows `k + 1..n`) and
/// returns the superdiagonal entry (0 for the last row).
fn right_reflection<const P: usize>(a: &mut [[f64; P]; P], n: usize, k: usize) -> f64 {
    let n = n.min(P);
    if k + 1 >= n {
        return 0.0;
    }
    let (head, tail) = a.split_at_mut(k + 1);
    let Some(rk) = head.last_mut() else {
        return 0.0;
    };
    let v = &mut rk[k + 1..n];
    let Some((beta, tau, inv_v0)) = reflector(v) else {
        return v.first().copied().unwrap_or(0.0);
    };
    v[0] = 1.0;
    for x in &mut v[1..] {
        *x *= inv_v0;
    }
    let v = &rk[k + 1..n];
    for row in tail.iter_mut().take(n - k - 1) {
        let seg = &mut row[k + 1..n];
        let f = tau * super::util::dot(seg, v);
        for (x, &vi) in seg.iter_mut().zip(v.iter()) {
            *x -= f * vi;
        }
    }
    beta
}

/// Implicit-shift QR steps on the bidiagonal (`d`, `e` with `e[i]` coupling `d[i − 1]`,
/// `d[i]`, `e[0] = 0`) until `e[k]` is negligible against `anorm`; `d[k]` is then a
/// singular value (any sign). Golub–Kahan–Reinsch as in Numerical Recipes' `svdcmp`,
/// without the singular vectors.
fn converge_last(d: &mut [f64], e: &mut [f64], k: usize, anorm: f64) -> Result<()> {
    let negligible = |x: f64| x.abs() + anorm == anorm;
    for _ in 0..MAX_QR_ITERATIONS {
        // Split point l: e[l] negligible (always at l = 0), or d[l − 1] negligible.
        let mut l = k;
        let mut cancel = false;
        while l > 0 && !negligible(e[l]) {
            if negligible(d[l - 1]) {
                cancel = true;
                break;
            }
            l -= 1;
        }
        if cancel {
            cancel_superdiagonal(d, e, l, k, negligible);
        }
        if l == k {
            return Ok(());
        }
        qr_step(d, e, l, k, anorm);
    }
    Err(Error::NotConverged {
        iterations: MAX_QR_ITERATIONS,
    })
}

/// With `d[l − 1]` negligible, rotates `e[l]` away (Givens from the left on rows `l..=k`).
fn cancel_superdiagonal(
    d: &mut [f64],
    e: &mut [f64],
    l: usize,
    k: usize,
    negligible: impl Fn(f64) -> bool,
) {
    let (mut c, mut s) = (0.0, 1.0);
    for i in l..=k {
        let f = s * e[i];
        e[i] *= c;
        if negligible(f) {
            break;
        }
        let g = d[i];
        let h = pythag(f, g);
        d[i] = h;
        if h == 0.0 {
            (c, s) = (1.0, 0.0);
        } else {
            (c, s) = (g / h, -f / h);
        }
    }
}

/// One implicit QR step with the Wilkinson-type shift of the trailing 2×2 on the
/// unreduced block `l..=k` (`l < k`).
fn qr_step(d: &mut [f64], e: &mut [f64], l: usize, k: usize, anorm: f64) {
    let z = d[k];
    // A (numerically) zero leading diagonal entry is moved off zero by far less than the
    // rounding already committed (ε·anorm), so that the shift formula stays finite.
    let mut x = d[l];
    if x.abs() < f64::EPSILON * f64::EPSILON * anorm {
        x = f64::EPSILON * f64::EPSILON * anorm;
    }
    let (y, g, h) = (d[k - 1], e[k - 1], e[k]);
    let mut f = ((y - z) * (y + z) + (g - h) * (g + h)) / (2.0 * h * y);
    let r = pythag(f, 1.0);
    f = ((x - z) * (x + z) + h * ((y / (f + r.copysign(f))) - h)) / x;
    let (mut c, mut s) = (1.0, 1.0);
    for j in l..k {
        let i = j + 1;
        let (mut g, mut y) = (e[i], d[i]);
        let mut h = s * g;
        g *= c;
        let mut z = pythag(f, h);
        e[j] = z;
        (c, s) = if z == 0.0 { (1.0, 0.0) } else { (f / z, h / z) };
        f = x * c + g * s;
        g = g * c - x * s;
        h = y * s;
        y *= c;
        z = pythag(f, h);
        d[j] = z;
        if z != 0.0 {
            z = 1.0 / z;
            c = f * z;
            s = h * z;
        }
        f = c * g + s * y;
        x = c * y - s * g;
    }
    e[l] = 0.0;
    e[k] = f;
    d[k] = x;
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
    use crate::linalg::svd::jacobi_singular_values;
    use crate::linalg::testutil::{Rng, from_d, low_rank, to_d};

    const P: usize = 12;

    fn check(a0: &[[f64; P]; P], n: usize) {
        let mut a = *a0;
        let (mut s, mut e) = ([0.0; P], [0.0; P]);
        singular_values(&mut a, n, &mut s, &mut e).unwrap();
        let mut want: std::vec::Vec<f64> = to_d(a0, n).singular_values().iter().copied().collect();
        want.sort_by(|x, y| y.total_cmp(x));
        let mut j = *a0;
        let mut sj = [0.0; P];
        jacobi_singular_values(&mut j, n, &mut sj).unwrap();
        let smax = want.first().copied().unwrap_or(0.0);
        for k in 0..n {
            let tol = 64.0 * f64::EPSILON * smax.max(f64::MIN_POSITIVE);
            assert!(
                (s[k] - want[k]).abs() <= tol,
                "n={n} k={k}: {} vs {}",
                s[k],
                want[k]
            );
            assert!(
                (s[k] - sj[k]).abs() <= tol,
                "n={n} k={k}: {} vs jacobi {}",
                s[k],
                sj[k]
            );
        }
    }

    #[test]
    fn agrees_with_nalgebra_and_jacobi() {
        let mut rng = Rng(0xb1d1_a600);
        for n in 1..=P {
            for _ in 0..20 {
                let mut a = rng.mat::<P>(n);
                check(&a, n);
                // Upper triangular, as the analysis passes it.
                for i in 0..n {
                    for j in 0..i {
                        a[i][j] = 0.0;
                    }
                }
                check(&a, n);
            }
        }
    }

    #[test]
    fn rank_deficient_graded_and_special_blocks() {
        let mut rng = Rng(7);
        for n in 1..=P {
            for r in 0..=n {
                check(&from_d::<P>(&low_rank(&mut rng, n, r)), n);
            }
        }
        // Graded columns (1 … 1e-12), a zero block, identity, a single entry.
        let mut g = [[0.0; P]; P];
        for i in 0..P {
            for j in 0..P {
                g[i][j] = rng.range(-1.0, 1.0) * libm::pow(10.0, -(j as f64));
            }
        }
        check(&g, P);
        check(&[[0.0; P]; P], P);
        let mut id = [[0.0; P]; P];
        for i in 0..P {
            id[i][i] = 1.0;
        }
        check(&id, P);
        let mut one = [[0.0; P]; P];
        one[0][0] = -3.0;
        check(&one, 1);
        // Huge and tiny magnitudes are scaled by an exact power of two: the singular values
        // of g·2^±900 are those of g times 2^±900, bit for bit.
        let (mut s_g, mut e) = ([0.0; P], [0.0; P]);
        singular_values(&mut g.clone(), P, &mut s_g, &mut e).unwrap();
        for shift in [900, -900] {
            let mut m = g;
            scale_block(&mut m, P, shift);
            let mut s = [0.0; P];
            singular_values(&mut m, P, &mut s, &mut e).unwrap();
            for k in 0..P {
                assert_eq!(s[k], libm::scalbn(s_g[k], shift), "shift {shift}, k {k}");
            }
        }
    }

    #[test]
    fn refuses_bad_input() {
        let mut a = [[0.0; P]; P];
        a[1][2] = f64::NAN;
        let (mut s, mut e) = ([0.0; P], [0.0; P]);
        assert!(matches!(
            singular_values(&mut a, 3, &mut s, &mut e),
            Err(Error::NonFinite { index: 5, .. })
        ));
        assert!(matches!(
            singular_values(&mut a, P + 1, &mut s, &mut e),
            Err(Error::CapacityExceeded { .. })
        ));
    }
}
