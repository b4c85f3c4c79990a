//! Levenberg–Marquardt step kernels: MINPACK `qrsolv` and `lmpar` on an unpivoted `R`.
//!
//! Why: the damped step `(RᵀR + λD²) x = Rᵀ qtb` must be formed from `R` (never from the
//! squared normal equations) and without destroying `R`, which is reused for every λ.

use super::tri::forward_unchecked;
use super::util::{
    bad_setting, check_capacity, check_finite, check_finite_block, check_len, fold_row,
};
use crate::error::{Error, Result};

/// Maximum iterations of [`lm_parameter`] (MINPACK's value); its result is then accepted.
pub const LM_PAR_MAX_ITER: u32 = 10;

/// Work space of [`solve_damped`] and [`lm_parameter`]; any contents (all-zero included)
/// are valid on entry.
#[derive(Debug, Clone)]
pub struct DampedScratch<const P: usize> {
    /// After a successful solve: upper-triangular `S` with `SᵀS = RᵀR + λD²`.
    s: [[f64; P]; P],
    /// After a successful solve: the rotated right-hand side, `S x = wa`.
    wa: [f64; P],
    row: [f64; P],
}

impl<const P: usize> DampedScratch<P> {
    /// Zeroed scratch; prefer zeroed caller memory for large `P` (returned by value).
    pub const fn new() -> Self {
        Self {
            s: [[0.0; P]; P],
            wa: [0.0; P],
            row: [0.0; P],
        }
    }

    /// The factor `S` of the last successful [`solve_damped`] (`SᵀS = RᵀR + λD²`).
    pub fn s(&self) -> &[[f64; P]; P] {
        &self.s
    }
}

impl<const P: usize> Default for DampedScratch<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// Solves `min |[R; √λ·D] x − [qtb; 0]|²`, i.e. `(RᵀR + λD²) x = Rᵀ·qtb`, by Givens
/// elimination of the diagonal rows (MINPACK `qrsolv`, identity permutation), so each
/// trial λ costs about n³/3 flops independent of the number of data rows, and `r` is
/// left unchanged for the next λ.
///
/// Uses the upper triangle of `r`'s leading block; `diag` is `D`'s diagonal (any sign;
/// zeros allowed), `lambda >= 0`.
///
/// Errors: `CapacityExceeded`; `DimensionMismatch` (`diag`, `qtb`, `x` length `!= n`);
/// `NonFinite { Setting, 0 }` for a negative or non-finite `lambda`;
/// `NonFinite { Parameter, .. }` for `r` (index `i*n+j`), `diag` or `qtb` (index `k`);
/// `RankDeficient` if the damped matrix is singular (e.g. `λ = 0` with a zero diagonal in
/// `R`) or the solution overflows. `x` is unspecified after an error.
#[allow(clippy::too_many_arguments)]
pub fn solve_damped<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    diag: &[f64],
    lambda: f64,
    qtb: &[f64],
    x: &mut [f64],
    scratch: &mut DampedScratch<P>,
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_len(diag.len(), n)?;
    check_len(qtb.len(), n)?;
    check_len(x.len(), n)?;
    if !(lambda.is_finite() && lambda >= 0.0) {
        return Err(bad_setting());
    }
    check_finite_block(r, n, true)?;
    check_finite(diag)?;
    check_finite(qtb)?;
    factor_damped(r, n, diag, libm::sqrt(lambda), qtb, scratch);
    back_substitute(scratch, n, x)
}

/// Builds `S` and `wa` in `scratch` for `√λ = sqrt_lambda` (arguments already checked).
fn factor_damped<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    diag: &[f64],
    sqrt_lambda: f64,
    qtb: &[f64],
    scratch: &mut DampedScratch<P>,
) {
    let DampedScratch { s, wa, row } = scratch;
    for (i, (srow, rrow)) in s.iter_mut().zip(r.iter()).take(n).enumerate() {
        for (j, (sv, rv)) in srow.iter_mut().zip(rrow.iter()).take(n).enumerate() {
            *sv = if j >= i { *rv } else { 0.0 };
        }
    }
    for (w, q) in wa.iter_mut().zip(qtb.iter()) {
        *w = *q;
    }
    if sqrt_lambda == 0.0 {
        return;
    }
    for (j, d) in diag.iter().enumerate() {
        let dj = sqrt_lambda * *d;
        if dj == 0.0 {
            continue;
        }
        row.iter_mut().take(n).for_each(|v| *v = 0.0);
        row[j] = dj;
        // The rotated-out right-hand side is the damping row's residual; not needed.
        let _ = fold_row(s, wa, n, row, 0.0, j);
    }
}

/// Solves `S x = wa` from the scratch, reporting a singular `S` as `RankDeficient`.
fn back_substitute<const P: usize>(
    scratch: &DampedScratch<P>,
    n: usize,
    x: &mut [f64],
) -> Result<()> {
    let s = &scratch.s;
    let rank = (0..n).filter(|&k| s[k][k] != 0.0).count();
    if rank < n {
        return Err(Error::RankDeficient { rank, required: n });
    }
    for i in (0..n).rev() {
        let si = &s[i];
        let mut sum = scratch.wa[i];
        for (sij, xj) in si[i + 1..n].iter().zip(x[i + 1..n].iter()) {
            sum -= sij * xj;
        }
        let v = sum / si[i];
        if !v.is_finite() {
            return Err(Error::RankDeficient {
                rank: n.saturating_sub(1),
                required: n,
            });
        }
        x[i] = v;
    }
    Ok(())
}

/// Overflow-safe Euclidean norm of `(f(0), …, f(len − 1))` (two passes, scaled).
fn enorm_by(len: usize, f: impl Fn(usize) -> f64) -> f64 {
    let scale = (0..len).fold(0.0_f64, |m, i| libm::fmax(m, libm::fabs(f(i))));
    if scale == 0.0 || !scale.is_finite() {
        return scale;
    }
    let sum: f64 = (0..len)
        .map(|i| {
            let t = f(i) / scale;
            t * t
        })
        .sum();
    scale * libm::sqrt(sum)
}

/// `|D x|` for `D = diag(d)`.
fn dx_norm(d: &[f64], x: &[f64]) -> f64 {
    enorm_by(d.len().min(x.len()), |i| d[i] * x[i])
}

/// `|x|`.
fn enorm(x: &[f64]) -> f64 {
    enorm_by(x.len(), |i| x[i])
}

/// Moré's trust-region Levenberg–Marquardt parameter (MINPACK `lmpar`, identity
/// permutation), because a radius `delta` is easier to control than λ directly.
///
/// Finds `λ >= 0` such that the solution `x` of `(RᵀR + λD²) x = Rᵀ·qtb` has either
/// `λ = 0` and `|D x| <= 1.1·delta` (Gauss–Newton step accepted), or
/// `| |D x| − delta | <= 0.1·delta`, or the best after [`LM_PAR_MAX_ITER`] iterations.
/// `lambda0` is the starting guess (the previous λ; 0 is fine). Returns λ and writes `x`.
/// If `R` has a zero diagonal, the Gauss–Newton step uses only the leading non-singular
/// block (components from the first zero pivot on are set to zero), as in MINPACK.
/// `diag` must be strictly positive.
///
/// Errors: `CapacityExceeded`; `DimensionMismatch` (`diag`, `qtb`, `x` length `!= n`);
/// `NonFinite { Setting, 0 }` if `delta <= 0`, `lambda0 < 0` or either is non-finite;
/// `NonFinite { Setting, k }` if `diag[k] <= 0` or non-finite;
/// `NonFinite { Parameter, .. }` for `r` or `qtb`; `RankDeficient` if a damped solve
/// overflows. `x` is unspecified after an error.
#[allow(clippy::too_many_arguments)]
pub fn lm_parameter<const P: usize>(
    r: &[[f64; P]; P],
    n: usize,
    diag: &[f64],
    qtb: &[f64],
    delta: f64,
    lambda0: f64,
    x: &mut [f64],
    scratch: &mut DampedScratch<P>,
) -> Result<f64> {
    check_capacity::<P>(n)?;
    check_len(diag.len(), n)?;
    check_len(qtb.len(), n)?;
    check_len(x.len(), n)?;
    if !(delta.is_finite() && delta > 0.0 && lambda0.is_finite() && lambda0 >= 0.0) {
        return Err(bad_setting());
    }
    if let Some(k) = diag.iter().position(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(Error::NonFinite {
            what: crate::error::Quantity::Setting,
            index: k,
        });
    }
    check_finite_block(r, n, true)?;
    check_finite(qtb)?;
    let dwarf = f64::MIN_POSITIVE;

    // Gauss–Newton direction on the leading non-singular block.
    let nsing = (0..n).find(|&j| r[j][j] == 0.0).unwrap_or(n);
    for (j, (xj, qj)) in x.iter_mut().zip(qtb.iter()).enumerate() {
        *xj = if j < nsing { *qj } else { 0.0 };
    }
    for j in (0..nsing).rev() {
        let v = x[j] / r[j][j];
        if !v.is_finite() {
            return Err(Error::RankDeficient {
                rank: j,
                required: n,
            });
        }
        x[j] = v;
        for i in 0..j {
            x[i] -= r[i][j] * v;
        }
    }
    let mut dxnorm = dx_norm(diag, x);
    let mut fp = dxnorm - delta;
    if fp <= 0.1 * delta {
        return Ok(0.0);
    }

    let wa1 = &mut scratch.row;
    // Lower bound from the Newton step at λ = 0 (only for full rank).
    let mut parl = 0.0;
    if nsing == n {
        for j in 0..n {
            wa1[j] = diag[j] * (diag[j] * x[j] / dxnorm);
        }
        if forward_unchecked(r, n, &mut wa1[..n]).is_ok() {
            let t = enorm(&wa1[..n]);
            parl = ((fp / delta) / t) / t;
            if !parl.is_finite() {
                parl = 0.0;
            }
        }
    }
    // Upper bound: |D⁻¹ Rᵀ qtb| / delta.
    for j in 0..n {
        let mut sum = 0.0;
        for i in 0..=j {
            sum += r[i][j] * qtb[i];
        }
        wa1[j] = sum / diag[j];
    }
    let gnorm = enorm(&wa1[..n]);
    let mut paru = gnorm / delta;
    if paru == 0.0 {
        paru = dwarf / libm::fmin(delta, 0.1);
    }
    let mut par = libm::fmin(libm::fmax(lambda0, parl), paru);
    if par == 0.0 {
        par = gnorm / dxnorm;
    }

    let mut iter = 0;
    loop {
        iter += 1;
        if par == 0.0 {
            par = libm::fmax(dwarf, 0.001 * paru);
        }
        factor_damped(r, n, diag, libm::sqrt(par), qtb, scratch);
        back_substitute(scratch, n, x)?;
        dxnorm = dx_norm(diag, x);
        let temp = fp;
        fp = dxnorm - delta;
        if libm::fabs(fp) <= 0.1 * delta
            || (parl == 0.0 && fp <= temp && temp < 0.0)
            || iter == LM_PAR_MAX_ITER
        {
            break;
        }
        // Newton correction: parc = fp / (delta · |S⁻ᵀ D² x / |D x||²).
        let wa1 = &mut scratch.row;
        for j in 0..n {
            wa1[j] = diag[j] * (diag[j] * x[j] / dxnorm);
        }
        forward_unchecked(&scratch.s, n, &mut scratch.row[..n])?;
        let t = enorm(&scratch.row[..n]);
        let parc = ((fp / delta) / t) / t;
        if fp > 0.0 {
            parl = libm::fmax(parl, par);
        }
        if fp < 0.0 {
            paru = libm::fmin(paru, par);
        }
        par = libm::fmax(parl, par + parc);
        if !par.is_finite() {
            return Err(Error::RankDeficient {
                rank: n.saturating_sub(1),
                required: n,
            });
        }
    }
    Ok(par)
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
    use crate::linalg::lsq::LsqAccumulator;
    use crate::linalg::testutil::{Rng, upper_d};
    use crate::linalg::tri::solve_upper;
    use nalgebra::{DMatrix, DVector};
    use std::vec::Vec;

    const P: usize = 12;

    /// R and qtb of a random tall problem with `n` unknowns, optionally making column
    /// `dup` a copy of column 0 (exactly rank deficient).
    fn problem(rng: &mut Rng, n: usize, dup: Option<usize>) -> ([[f64; P]; P], Vec<f64>) {
        let mut acc = LsqAccumulator::<P>::new();
        acc.reset(n).unwrap();
        for _ in 0..3 * n {
            let mut row: Vec<f64> = (0..n).map(|_| rng.sym()).collect();
            if let Some(d) = dup {
                row[d] = row[0];
            }
            acc.add_row(&row, rng.sym()).unwrap();
        }
        (*acc.r(), acc.qtb()[..n].to_vec())
    }

    /// Solves (RᵀR + λD²) x = Rᵀqtb with nalgebra.
    fn reference(
        r: &[[f64; P]; P],
        n: usize,
        diag: &[f64],
        lambda: f64,
        qtb: &[f64],
    ) -> DVector<f64> {
        let rd = upper_d(r, n);
        let d2 = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                lambda * diag[i] * diag[i]
            } else {
                0.0
            }
        });
        let m = rd.transpose() * &rd + d2;
        m.lu()
            .solve(&(rd.transpose() * DVector::from_column_slice(qtb)))
            .unwrap()
    }

    fn close(x: &[f64], y: &DVector<f64>, tol: f64) -> bool {
        let scale = y.amax().max(1e-300);
        x.iter()
            .zip(y.iter())
            .all(|(a, b)| (a - b).abs() <= tol * scale)
    }

    #[test]
    fn damped_matches_normal_equations_and_keeps_r() {
        let mut rng = Rng(50);
        let mut scratch = DampedScratch::<P>::new();
        for n in [1, 5, P] {
            let (r, qtb) = problem(&mut rng, n, None);
            let r0 = r;
            let diag: Vec<f64> = (0..n)
                .map(|k| if k == 1 { 0.0 } else { rng.range(0.2, 3.0) })
                .collect();
            for lambda in [1e-3, 1.0, 100.0] {
                let mut x = std::vec![0.0; n];
                solve_damped(&r, n, &diag, lambda, &qtb, &mut x, &mut scratch).unwrap();
                assert!(
                    close(&x, &reference(&r, n, &diag, lambda, &qtb), 1e-10),
                    "n={n} λ={lambda}"
                );
                assert_eq!(r, r0, "r must not be modified");
                // SᵀS = RᵀR + λD².
                let s = upper_d(scratch.s(), n);
                let rd = upper_d(&r, n);
                let want = rd.transpose() * &rd
                    + DMatrix::from_fn(n, n, |i, j| {
                        if i == j {
                            lambda * diag[i] * diag[i]
                        } else {
                            0.0
                        }
                    });
                assert!((s.transpose() * &s - &want).amax() <= 1e-12 * want.amax());
            }
        }
    }

    #[test]
    fn lambda_zero_equals_plain_solve() {
        let mut rng = Rng(51);
        let mut scratch = DampedScratch::<P>::new();
        let n = 8;
        let (r, qtb) = problem(&mut rng, n, None);
        let diag = std::vec![1.0; n];
        let mut x = std::vec![0.0; n];
        solve_damped(&r, n, &diag, 0.0, &qtb, &mut x, &mut scratch).unwrap();
        let mut y = qtb.clone();
        solve_upper(&r, n, &mut y).unwrap();
        assert_eq!(x, y);
    }

    #[test]
    fn rank_deficient_r_errors_at_zero_lambda_and_solves_when_damped() {
        let mut rng = Rng(52);
        let mut scratch = DampedScratch::<P>::new();
        let n = 6;
        let (mut r, qtb) = problem(&mut rng, n, Some(3));
        // Make the dependency exact in R (rounding leaves ~1e-16).
        r[3][3] = 0.0;
        let diag = std::vec![1.0; n];
        let mut x = std::vec![0.0; n];
        assert_eq!(
            solve_damped(&r, n, &diag, 0.0, &qtb, &mut x, &mut scratch),
            Err(Error::RankDeficient {
                rank: n - 1,
                required: n
            })
        );
        assert!(x.iter().all(|v| v.is_finite()));
        // A parameter with no effect (zero column) and no damping stays singular.
        let mut rz = r;
        rz.iter_mut().for_each(|row| row[3] = 0.0);
        let mut d0 = diag.clone();
        d0[3] = 0.0;
        assert!(matches!(
            solve_damped(&rz, n, &d0, 1.0, &qtb, &mut x, &mut scratch),
            Err(Error::RankDeficient { .. })
        ));
        solve_damped(&rz, n, &diag, 1.0, &qtb, &mut x, &mut scratch).unwrap();
        assert!(close(&x, &reference(&rz, n, &diag, 1.0, &qtb), 1e-10));
        solve_damped(&r, n, &diag, 0.5, &qtb, &mut x, &mut scratch).unwrap();
        assert!(close(&x, &reference(&r, n, &diag, 0.5, &qtb), 1e-10));
    }

    #[test]
    fn lm_parameter_hits_trust_region() {
        let mut rng = Rng(53);
        let mut scratch = DampedScratch::<P>::new();
        for (n, dup) in [(7, None), (P, None), (6, Some(2))] {
            let (mut r, qtb) = problem(&mut rng, n, dup);
            if let Some(d) = dup {
                r[d][d] = 0.0;
            }
            let diag: Vec<f64> = (0..n).map(|_| rng.range(0.5, 2.0)).collect();
            let mut x = std::vec![0.0; n];
            // Gauss–Newton step norm (for full rank).
            let par_big = lm_parameter(&r, n, &diag, &qtb, 1e6, 0.0, &mut x, &mut scratch).unwrap();
            assert_eq!(par_big, 0.0);
            if dup.is_none() {
                let mut y = qtb.clone();
                solve_upper(&r, n, &mut y).unwrap();
                assert!(close(&x, &DVector::from_column_slice(&y), 1e-12));
            } else {
                assert_eq!(x[dup.unwrap_or(0)], 0.0);
            }
            let gn = dx_norm(&diag, &x);
            for (frac, start) in [(0.3, 0.0), (0.05, 0.0), (0.5, 10.0)] {
                let delta = frac * gn;
                let par =
                    lm_parameter(&r, n, &diag, &qtb, delta, start, &mut x, &mut scratch).unwrap();
                assert!(par > 0.0);
                let dxn = dx_norm(&diag, &x);
                assert!(
                    (dxn - delta).abs() <= 0.1 * delta,
                    "n={n} |Dx|={dxn} Δ={delta}"
                );
                assert!(close(&x, &reference(&r, n, &diag, par, &qtb), 1e-9));
            }
        }
    }

    #[test]
    fn errors_are_returned() {
        let mut scratch = DampedScratch::<3>::new();
        let r = [[1.0, 0.5, 0.2], [0.0, 1.0, 0.3], [0.0, 0.0, 1.0]];
        let d = [1.0; 3];
        let q = [1.0; 3];
        let mut x = [0.0; 3];
        let setting = Err(Error::NonFinite {
            what: Quantity::Setting,
            index: 0,
        });
        assert_eq!(
            solve_damped(
                &r,
                4,
                &[1.0; 4],
                1.0,
                &[1.0; 4],
                &mut [0.0; 4],
                &mut scratch
            ),
            Err(Error::CapacityExceeded {
                needed: 4,
                capacity: 3
            })
        );
        assert_eq!(
            solve_damped(&r, 3, &d[..2], 1.0, &q, &mut x, &mut scratch),
            Err(Error::DimensionMismatch {
                expected: 3,
                found: 2
            })
        );
        assert_eq!(
            solve_damped(&r, 3, &d, -1.0, &q, &mut x, &mut scratch),
            setting
        );
        assert_eq!(
            solve_damped(&r, 3, &d, f64::NAN, &q, &mut x, &mut scratch),
            setting
        );
        assert_eq!(
            solve_damped(&r, 3, &[1.0, f64::NAN, 1.0], 1.0, &q, &mut x, &mut scratch),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );
        assert_eq!(
            lm_parameter(&r, 3, &d, &q, 0.0, 0.0, &mut x, &mut scratch).map(|_| ()),
            setting
        );
        assert_eq!(
            lm_parameter(&r, 3, &d, &q, 1.0, -1.0, &mut x, &mut scratch).map(|_| ()),
            setting
        );
        assert_eq!(
            lm_parameter(&r, 3, &[1.0, 0.0, 1.0], &q, 1.0, 0.0, &mut x, &mut scratch),
            Err(Error::NonFinite {
                what: Quantity::Setting,
                index: 1
            })
        );
        let mut bad = r;
        bad[0][1] = f64::INFINITY;
        assert_eq!(
            lm_parameter(&bad, 3, &d, &q, 1.0, 0.0, &mut x, &mut scratch),
            Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: 1
            })
        );
    }
}
