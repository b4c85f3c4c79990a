//! Shared argument checks, exact power-of-two scaling and the Givens row fold.

use crate::error::{Error, Quantity, Result};

/// Rejects `n > P`, because only the leading `P`×`P` block exists.
pub(crate) fn check_capacity<const P: usize>(n: usize) -> Result<()> {
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    Ok(())
}

/// Rejects a slice whose length is not `n`, because indices are taken from `n`.
pub(crate) fn check_len(len: usize, n: usize) -> Result<()> {
    if len != n {
        return Err(Error::DimensionMismatch {
            expected: n,
            found: len,
        });
    }
    Ok(())
}

/// `Σ x[i]·y[i]` over the shorter length, in four interleaved partial sums: a single
/// running sum is one dependent chain of additions (latency-bound, ~4 cycles per term),
/// four independent ones pipeline and vectorise. The order is fixed, so the result is
/// deterministic.
#[inline]
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..4 {
            acc[k] += a[k] * b[k];
        }
    }
    let tail: f64 = xr.iter().zip(yr.iter()).map(|(a, b)| a * b).sum();
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// Whether every value is finite, without a branch per value: a non-finite `f64` has all
/// exponent bits set, and OR-ing the per-value flags vectorises.
#[inline]
pub(crate) fn all_finite<'a>(x: impl Iterator<Item = &'a f64>) -> bool {
    const EXP: u64 = 0x7ff0_0000_0000_0000;
    x.fold(0u64, |acc, v| acc | u64::from(v.to_bits() & EXP == EXP)) == 0
}

/// First non-finite entry of `x`, reported as a `Parameter` at its position.
pub(crate) fn check_finite(x: &[f64]) -> Result<()> {
    if all_finite(x.iter()) {
        return Ok(());
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite {
            what: Quantity::Parameter,
            index,
        }),
        None => Ok(()),
    }
}

/// First non-finite entry of the leading `n`×`n` block (columns `j >= i` only when
/// `upper`), reported at index `i * n + j`. Caller guarantees `n <= P`.
pub(crate) fn check_finite_block<const P: usize>(
    a: &[[f64; P]; P],
    n: usize,
    upper: bool,
) -> Result<()> {
    // Fast path; only a failing block is scanned for the index.
    if a.iter()
        .take(n)
        .enumerate()
        .all(|(i, row)| all_finite(row.iter().take(n).skip(if upper { i } else { 0 })))
    {
        return Ok(());
    }
    for (i, row) in a.iter().take(n).enumerate() {
        let from = if upper { i } else { 0 };
        for (j, v) in row.iter().enumerate().take(n).skip(from) {
            if !v.is_finite() {
                return Err(Error::NonFinite {
                    what: Quantity::Parameter,
                    index: i * n + j,
                });
            }
        }
    }
    Ok(())
}

/// Error for an invalid tuning value (weight, damping, tolerance, radius).
pub(crate) fn bad_setting() -> Error {
    Error::NonFinite {
        what: Quantity::Setting,
        index: 0,
    }
}

/// Exponent `e` such that the leading block times `2^-e` has max |entry| in [0.5, 1);
/// `None` for an all-zero block. Scaling by a power of two is exact, and afterwards sums
/// of squares cannot overflow. Caller guarantees `n <= P` and finite entries.
pub(crate) fn scale_exponent<const P: usize>(a: &[[f64; P]; P], n: usize) -> Option<i32> {
    let mut amax = 0.0_f64;
    for row in a.iter().take(n) {
        for v in row.iter().take(n) {
            let m = libm::fabs(*v);
            if m > amax {
                amax = m;
            }
        }
    }
    if amax == 0.0 {
        None
    } else {
        Some(libm::frexp(amax).1)
    }
}

/// Multiplies the leading block by `2^e` (exact unless entries become subnormal).
///
/// When `2^e` is itself a normal number (|e| <= 1022, every practical case) this is one
/// multiplication per entry, the very operation `scalbn` performs then, without a call
/// per entry; otherwise `scalbn` entry by entry.
pub(crate) fn scale_block<const P: usize>(a: &mut [[f64; P]; P], n: usize, e: i32) {
    if (-1022..=1022).contains(&e) {
        let f = libm::scalbn(1.0, e);
        for row in a.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v *= f;
            }
        }
        return;
    }
    for row in a.iter_mut().take(n) {
        for v in row.iter_mut().take(n) {
            *v = libm::scalbn(*v, e);
        }
    }
}

/// Givens rotation `(c, s, h)` with `c·x + s·y = h = hypot(x, y) >= 0` and
/// `-s·x + c·y = 0`; `(1, 0, 0)` when both are zero.
#[inline]
pub(crate) fn givens(x: f64, y: f64) -> (f64, f64, f64) {
    if y == 0.0 {
        if x < 0.0 {
            (-1.0, 0.0, -x)
        } else {
            (1.0, 0.0, x)
        }
    } else {
        // Plain sqrt(x² + y²) when neither square can overflow or underflow (the common
        // case, several times faster); libm's careful hypot otherwise.
        let m = x.abs().max(y.abs());
        let h = if m > 1e-150 && m < 1e150 {
            libm::sqrt(x * x + y * y)
        } else {
            libm::hypot(x, y)
        };
        (x / h, y / h, h)
    }
}

/// Folds the row `(row[start..n], beta)` into the upper-triangular `r` and `qtb` with
/// Givens rotations (row entries before `start` must be zero), keeping `r`'s diagonal
/// non-negative; returns the rotated-out right-hand side, whose square is the row's
/// contribution to the residual outside the column span. `row` is destroyed.
/// Caller guarantees `start <= n <= P`.
pub(crate) fn fold_row<const P: usize>(
    r: &mut [[f64; P]; P],
    qtb: &mut [f64; P],
    n: usize,
    row: &mut [f64; P],
    mut beta: f64,
    start: usize,
) -> f64 {
    for k in start..n {
        let y = row[k];
        if y == 0.0 {
            continue;
        }
        let rk = &mut r[k];
        let (c, s, h) = givens(rk[k], y);
        rk[k] = h;
        row[k] = 0.0;
        for (rkj, xj) in rk[k + 1..n].iter_mut().zip(row[k + 1..n].iter_mut()) {
            let t = *rkj;
            *rkj = c * t + s * *xj;
            *xj = c * *xj - s * t;
        }
        let t = qtb[k];
        qtb[k] = c * t + s * beta;
        beta = c * beta - s * t;
    }
    beta
}
