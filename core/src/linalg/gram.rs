//! Streaming normal equations: `G = AᵀWA`, `g = AᵀWb`, `s = bᵀWb`, folded row by row.
//!
//! Why: the iterations of Gauss–Newton and Levenberg–Marquardt need a descent step, not a
//! backward-stable factor; the fixed point they reach is set by the gradient `Aᵀb`, which
//! is accumulated exactly here. Folding a row costs n²/2 multiply-adds (Givens needs about
//! six times that plus a square root per entry), so the hot loop of identification uses
//! this, while the identifiability analysis and the covariance keep the Givens factor of
//! [`super::lsq`]. Memory is O(n²) whatever the number of rows.

use super::util::{check_capacity, check_finite, check_len};
use crate::error::{Error, Result};

/// Upper triangle of `AᵀWA`, `AᵀWb` and `bᵀWb`. All-zero is the valid empty state.
#[derive(Debug, Clone)]
pub struct GramAccumulator<const P: usize> {
    g: [[f64; P]; P],
    atb: [f64; P],
    btb: f64,
    n: usize,
}

impl<const P: usize> GramAccumulator<P> {
    /// Empty, with `n = 0`.
    #[must_use]
    pub const fn new() -> Self {
        GramAccumulator {
            g: [[0.0; P]; P],
            atb: [0.0; P],
            btb: 0.0,
            n: 0,
        }
    }
    /// Clears for `n` unknowns.
    pub fn reset(&mut self, n: usize) -> Result<()> {
        check_capacity::<P>(n)?;
        for row in self.g.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v = 0.0;
            }
        }
        for v in self.atb.iter_mut().take(n) {
            *v = 0.0;
        }
        self.btb = 0.0;
        self.n = n;
        Ok(())
    }
    /// Folds `a·x ≈ b` with weight `w >= 0`.
    pub fn add_row_weighted(&mut self, a: &[f64], b: f64, w: f64) -> Result<()> {
        let n = self.n;
        check_len(a.len(), n)?;
        check_finite(a)?;
        if !b.is_finite() || !w.is_finite() || w < 0.0 {
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: n,
            });
        }
        for (i, &ai) in a.iter().enumerate() {
            let wai = w * ai;
            if wai == 0.0 {
                continue;
            }
            if let Some(row) = self.g.get_mut(i) {
                for (gij, &aj) in row[i..n].iter_mut().zip(a[i..].iter()) {
                    *gij += wai * aj;
                }
            }
            self.atb[i] += wai * b;
        }
        self.btb += w * b * b;
        Ok(())
    }
    /// Folds the six equations `a[r]·x ≈ b[r]` with weights `w[r] >= 0` (a pose's rows; a
    /// weight of 0 leaves a row out) at once: the same sums as six
    /// [`add_row_weighted`](Self::add_row_weighted) calls, in a third of the memory traffic.
    /// Only `a[r][..n]` is read.
    pub fn add_rows6(&mut self, a: &[[f64; P]; 6], b: &[f64; 6], w: &[f64; 6]) -> Result<()> {
        // `reset` keeps n <= P; saying so lets the compiler drop every bounds check below.
        let n = self.n.min(P);
        let finite = super::util::all_finite(a.iter().flat_map(|r| r[..n].iter()))
            && super::util::all_finite(b.iter().chain(w.iter()));
        if !finite || w.iter().any(|&v| v < 0.0) {
            for r in a {
                check_finite(&r[..n])?;
            }
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: n,
            });
        }
        let [a0, a1, a2, a3, a4, a5] = a;
        let coef = |i: usize| {
            [
                w[0] * a0[i],
                w[1] * a1[i],
                w[2] * a2[i],
                w[3] * a3[i],
                w[4] * a4[i],
                w[5] * a5[i],
            ]
        };
        let (g, atb) = (&mut self.g, &mut self.atb);
        // Two rows of the triangle at a time where both have something to add: each entry
        // gets the very sum `fold3`/`fold6` gives it (same products, same order), the
        // pose's rows read once for both (half the loads of the hot loop).
        let mut i = 0;
        while i < n {
            let c = coef(i);
            atb[i] += c.iter().zip(b.iter()).map(|(x, y)| x * y).sum::<f64>();
            if c.iter().all(|&v| v == 0.0) {
                // A structurally zero column of this pose (e.g. a parameter beyond the
                // joints it moves): nothing to add.
                i += 1;
                continue;
            }
            // Length columns have no rotation part: three terms suffice.
            let rot_c = !(c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0);
            let j = i + 1;
            let d = if j < n { coef(j) } else { [0.0; 6] };
            if j < n && d.iter().any(|&v| v != 0.0) {
                atb[j] += d.iter().zip(b.iter()).map(|(x, y)| x * y).sum::<f64>();
                let rot_d = !(d[3] == 0.0 && d[4] == 0.0 && d[5] == 0.0);
                let (lo, hi) = g.split_at_mut(j);
                let (Some(gi), Some(gj)) = (lo.last_mut(), hi.first_mut()) else {
                    break;
                };
                let rows = [
                    &a0[j..n],
                    &a1[j..n],
                    &a2[j..n],
                    &a3[j..n],
                    &a4[j..n],
                    &a5[j..n],
                ];
                let at_i = [a0[i], a1[i], a2[i], a3[i], a4[i], a5[i]];
                gi[i] += if rot_c {
                    sum6(&c, &at_i)
                } else {
                    sum3(&c, &at_i)
                };
                match (rot_c, rot_d) {
                    (true, true) => {
                        fold_pair::<true, true>(&mut gi[j..n], &mut gj[j..n], &c, &d, rows)
                    }
                    (true, false) => {
                        fold_pair::<true, false>(&mut gi[j..n], &mut gj[j..n], &c, &d, rows)
                    }
                    (false, true) => {
                        fold_pair::<false, true>(&mut gi[j..n], &mut gj[j..n], &c, &d, rows)
                    }
                    (false, false) => {
                        fold_pair::<false, false>(&mut gi[j..n], &mut gj[j..n], &c, &d, rows)
                    }
                }
                i += 2;
                continue;
            }
            let Some(grow) = g.get_mut(i) else {
                break;
            };
            let row = &mut grow[i..n];
            if rot_c {
                let rot = [&a3[i..n], &a4[i..n], &a5[i..n]];
                fold6(row, &c, [&a0[i..n], &a1[i..n], &a2[i..n]], rot);
            } else {
                fold3(row, &c, [&a0[i..n], &a1[i..n], &a2[i..n]]);
            }
            i += 1;
        }
        self.btb += (0..6).map(|r| w[r] * b[r] * b[r]).sum::<f64>();
        Ok(())
    }
    /// [`add_rows6`](Self::add_rows6) of a position-only row block: rows 3–5 zero with
    /// weight and right-hand side 0 (contact data), reading only `a[..3]`. The same sums,
    /// bit for bit: each entry adds the same three products in the same order (the three
    /// zero rows add exact zeros there, and `x + 0 = x` for every sum that is not −0, which
    /// neither accumulator ever holds), with half the finiteness checks and none of the
    /// rotation rows' arithmetic. Errors as `add_rows6`.
    pub fn add_rows3(&mut self, a: &[[f64; P]; 6], b: &[f64; 3], w: &[f64; 3]) -> Result<()> {
        let n = self.n.min(P);
        let [a0, a1, a2, ..] = a;
        let (a0, a1, a2) = (&a0[..n], &a1[..n], &a2[..n]);
        let finite = super::util::all_finite(a0.iter())
            && super::util::all_finite(a1.iter())
            && super::util::all_finite(a2.iter())
            && super::util::all_finite(b.iter().chain(w.iter()));
        if !finite || w.iter().any(|&v| v < 0.0) {
            for r in [a0, a1, a2] {
                check_finite(r)?;
            }
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: n,
            });
        }
        // Two rows of the triangle per pass (one load of the three rows' entries for both):
        // each entry still adds its own three products in the same order. A row whose
        // coefficients are all zero adds ±0 to entries that are never −0 (every sum starts
        // at +0), so folding it too changes nothing.
        let coef = |i: usize| [w[0] * a0[i], w[1] * a1[i], w[2] * a2[i], 0.0, 0.0, 0.0];
        let (g, atb) = (&mut self.g[..n], &mut self.atb[..n]);
        let mut i = 0;
        while i + 1 < n {
            let (c, d) = (coef(i), coef(i + 1));
            atb[i] += c[0] * b[0] + c[1] * b[1] + c[2] * b[2];
            atb[i + 1] += d[0] * b[0] + d[1] * b[1] + d[2] * b[2];
            let (lo, hi) = g.split_at_mut(i + 1);
            let (Some(gi), Some(gj)) = (lo.last_mut(), hi.first_mut()) else {
                break;
            };
            gi[i] += c[0] * a0[i] + c[1] * a1[i] + c[2] * a2[i];
            let j = i + 1;
            fold3_pair(
                &mut gi[j..n],
                &mut gj[j..n],
                &c,
                &d,
                [&a0[j..], &a1[j..], &a2[j..]],
            );
            i += 2;
        }
        if let (Some(grow), Some(atb)) = (g.get_mut(i), atb.get_mut(i)) {
            let c = coef(i);
            *atb += c[0] * b[0] + c[1] * b[1] + c[2] * b[2];
            fold3(&mut grow[i..n], &c, [&a0[i..], &a1[i..], &a2[i..]]);
        }
        self.btb += w[0] * b[0] * b[0] + w[1] * b[1] * b[1] + w[2] * b[2] * b[2];
        Ok(())
    }
    /// Folds the six unit-weight equations `a[r]·x ≈ b[r]` with the same sums, added in
    /// the same order, as six [`add_row_weighted`](Self::add_row_weighted) calls with
    /// `w = 1` (bit-identical results: each entry adds its six products one after the
    /// other, rows 0 to 5), in one pass over the matrix instead of six. Zero rows and
    /// entries add ±0, which leaves every sum unchanged (a sum of products started at +0
    /// is never −0). Non-finite input fails as the single-row calls would.
    pub fn add_rows6_in_order(&mut self, a: &[[f64; P]; 6], b: &[f64; 6]) -> Result<()> {
        let n = self.n.min(P);
        let finite = super::util::all_finite(a.iter().flat_map(|r| r[..n].iter()))
            && super::util::all_finite(b.iter());
        if !finite {
            for (r, &br) in a.iter().zip(b) {
                self.add_row_weighted(&r[..n], br, 1.0)?;
            }
            return Ok(());
        }
        let [a0, a1, a2, a3, a4, a5] = a;
        let coef = |i: usize| [a0[i], a1[i], a2[i], a3[i], a4[i], a5[i]];
        let (g, atb) = (&mut self.g, &mut self.atb);
        // Two rows at a time where both have something to add (the same sums in the same
        // order per entry; the pose's rows read once for both).
        let mut i = 0;
        while i < n {
            let c = coef(i);
            if c.iter().all(|&v| v == 0.0) {
                i += 1;
                continue;
            }
            for (ck, bk) in c.iter().zip(b) {
                atb[i] += ck * bk;
            }
            let j = i + 1;
            let d = if j < n { coef(j) } else { [0.0; 6] };
            if j < n && d.iter().any(|&v| v != 0.0) {
                for (dk, bk) in d.iter().zip(b) {
                    atb[j] += dk * bk;
                }
                let (lo, hi) = g.split_at_mut(j);
                let (Some(gi), Some(gj)) = (lo.last_mut(), hi.first_mut()) else {
                    break;
                };
                let mut v = gi[i];
                for (ck, ak) in c.iter().zip(c.iter()) {
                    v += ck * ak;
                }
                gi[i] = v;
                let rows = [
                    &a0[j..n],
                    &a1[j..n],
                    &a2[j..n],
                    &a3[j..n],
                    &a4[j..n],
                    &a5[j..n],
                ];
                in_order_pair(&mut gi[j..n], &mut gj[j..n], &c, &d, rows);
                i += 2;
                continue;
            }
            let Some(grow) = g.get_mut(i) else {
                break;
            };
            let (Some(row), Some(r0), Some(r1), Some(r2), Some(r3), Some(r4), Some(r5)) = (
                grow.get_mut(i..n),
                a0.get(i..n),
                a1.get(i..n),
                a2.get(i..n),
                a3.get(i..n),
                a4.get(i..n),
                a5.get(i..n),
            ) else {
                i += 1;
                continue;
            };
            for (j, g) in row.iter_mut().enumerate() {
                let mut v = *g;
                v += c[0] * r0[j];
                v += c[1] * r1[j];
                v += c[2] * r2[j];
                v += c[3] * r3[j];
                v += c[4] * r4[j];
                v += c[5] * r5[j];
                *g = v;
            }
            i += 1;
        }
        for &br in b {
            self.btb += br * br;
        }
        Ok(())
    }
    /// Subtracts `w·a·aᵀ` (`w >= 0`) from the Gram matrix, leaving `Aᵀb` and `bᵀb` alone:
    /// the downdate that turns `Σ w_i·J_iᵀJ_i` into the centred `Σ w_i·(J_i − J̄)ᵀ(J_i − J̄)`
    /// (with `a = J̄` row by row, `w = Σ w_i`) when the rows were folded uncentred.
    pub fn downdate(&mut self, a: &[f64], w: f64) -> Result<()> {
        let n = self.n;
        check_len(a.len(), n)?;
        check_finite(a)?;
        if !w.is_finite() || w < 0.0 {
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: n,
            });
        }
        for (i, &ai) in a.iter().enumerate() {
            let wai = w * ai;
            if let Some(row) = self.g.get_mut(i) {
                for (gij, &aj) in row[i..n].iter_mut().zip(a[i..].iter()) {
                    *gij -= wai * aj;
                }
            }
        }
        Ok(())
    }
    /// Removes a row `(a, b)` of weight `w >= 0` folded earlier: `AᵀWA −= w·a·aᵀ`,
    /// `AᵀWb −= w·a·b`, `bᵀWb −= w·b²`. With `a = J̄` row by row, `b = ō − p̄` and `w = Σ w_i`
    /// it turns rows `(J_i, ō − p_i)` folded in one pass (`ō` any fixed point, e.g. the
    /// first `p_i`, while `p̄` is not yet known) into the centred `(J_i − J̄, p̄ − p_i)`.
    /// It also folds the Schur complement of eliminated session frames, as rows `L⁻¹C` with
    /// right-hand sides `L⁻¹g` (see `identify::instrument_sessions`).
    pub fn downdate_with_rhs(&mut self, a: &[f64], b: f64, w: f64) -> Result<()> {
        if !b.is_finite() {
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: self.n,
            });
        }
        self.downdate(a, w)?;
        for (atb, &ai) in self.atb.iter_mut().zip(a.iter()) {
            *atb -= w * ai * b;
        }
        self.btb -= w * b * b;
        Ok(())
    }
    /// Number of unknowns.
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }
    /// Upper triangle of `AᵀWA` (row-major, `g[i][j]` for `j >= i`).
    #[must_use]
    pub fn gram(&self) -> &[[f64; P]; P] {
        &self.g
    }
    /// `AᵀWb`.
    #[must_use]
    pub fn atb(&self) -> &[f64; P] {
        &self.atb
    }
    /// `bᵀWb`.
    #[must_use]
    pub fn btb(&self) -> f64 {
        self.btb
    }
    /// Narrows the normal equations to the unknowns `cols` (strictly increasing, each
    /// below [`Self::n`]) in place: unknown `i` becomes the old `cols[i]`, every entry
    /// copied bit for bit, `bᵀWb` kept. Rows folded afterwards with the same columns
    /// (in the same order) give exactly what folding them into a narrow accumulator from
    /// the start would have given, since each entry is its own sum.
    pub fn select(&mut self, cols: &[usize]) -> Result<()> {
        let increasing = cols.windows(2).all(|w| w[0] < w[1]);
        if !increasing || cols.last().is_some_and(|&c| c >= self.n) {
            return Err(Error::InvalidParameter {
                index: 0,
                value: cols.len() as f64,
            });
        }
        // In place: entry (i, j) reads (cols[i], cols[j]) with cols[i] ≥ i, cols[j] ≥ j,
        // i.e. a later row, or a later column of this row, neither written yet.
        for (i, &ci) in cols.iter().enumerate() {
            for (j, &cj) in cols.iter().enumerate().skip(i) {
                self.g[i][j] = self.g[ci][cj];
            }
            self.atb[i] = self.atb[ci];
        }
        self.n = cols.len();
        Ok(())
    }
}

/// `row[j] += Σ_r c[r]·a[r][j]` over the three position rows. The slices are cut to one
/// length first, so the loop has no bounds checks and vectorises.
#[inline]
fn fold3(row: &mut [f64], c: &[f64; 6], a: [&[f64]; 3]) {
    let m = row.len();
    let (Some(a0), Some(a1), Some(a2)) = (a[0].get(..m), a[1].get(..m), a[2].get(..m)) else {
        return;
    };
    for k in 0..m {
        row[k] += c[0] * a0[k] + c[1] * a1[k] + c[2] * a2[k];
    }
}

/// [`fold3`] into two rows at once (`r0` with coefficients `c`, `r1` with `d`).
#[inline]
fn fold3_pair(r0: &mut [f64], r1: &mut [f64], c: &[f64; 6], d: &[f64; 6], a: [&[f64]; 3]) {
    let m = r0.len();
    let (Some(r1), Some(a0), Some(a1), Some(a2)) =
        (r1.get_mut(..m), a[0].get(..m), a[1].get(..m), a[2].get(..m))
    else {
        return;
    };
    for k in 0..m {
        let (x0, x1, x2) = (a0[k], a1[k], a2[k]);
        r0[k] += c[0] * x0 + c[1] * x1 + c[2] * x2;
        r1[k] += d[0] * x0 + d[1] * x1 + d[2] * x2;
    }
}

/// As [`fold3`] over all six rows of a pose (`p`: position rows, `r`: rotation rows).
#[inline]
fn fold6(row: &mut [f64], c: &[f64; 6], p: [&[f64]; 3], r: [&[f64]; 3]) {
    let m = row.len();
    let ([b0, b1, b2], [b3, b4, b5]) = (p, r);
    let (Some(b0), Some(b1), Some(b2), Some(b3), Some(b4), Some(b5)) = (
        b0.get(..m),
        b1.get(..m),
        b2.get(..m),
        b3.get(..m),
        b4.get(..m),
        b5.get(..m),
    ) else {
        return;
    };
    for k in 0..m {
        row[k] +=
            c[0] * b0[k] + c[1] * b1[k] + c[2] * b2[k] + c[3] * b3[k] + c[4] * b4[k] + c[5] * b5[k];
    }
}

/// `Σ_r c[r]·x[r]` over the three position rows, in `fold3`'s order.
#[inline]
fn sum3(c: &[f64; 6], x: &[f64; 6]) -> f64 {
    c[0] * x[0] + c[1] * x[1] + c[2] * x[2]
}

/// `Σ_r c[r]·x[r]` over all six rows, in `fold6`'s order.
#[inline]
fn sum6(c: &[f64; 6], x: &[f64; 6]) -> f64 {
    c[0] * x[0] + c[1] * x[1] + c[2] * x[2] + c[3] * x[3] + c[4] * x[4] + c[5] * x[5]
}

/// [`fold3`] or [`fold6`] (`R0`, `R1`: whether the row's coefficients have a rotation
/// part) into two rows at once: `r0` with coefficients `c`, `r1` with `d`. Each entry gets
/// the expression the single-row kernel gives it, term for term.
#[inline]
fn fold_pair<const R0: bool, const R1: bool>(
    r0: &mut [f64],
    r1: &mut [f64],
    c: &[f64; 6],
    d: &[f64; 6],
    a: [&[f64]; 6],
) {
    let m = r0.len();
    let [b0, b1, b2, b3, b4, b5] = a;
    let (Some(r1), Some(b0), Some(b1), Some(b2), Some(b3), Some(b4), Some(b5)) = (
        r1.get_mut(..m),
        b0.get(..m),
        b1.get(..m),
        b2.get(..m),
        b3.get(..m),
        b4.get(..m),
        b5.get(..m),
    ) else {
        return;
    };
    for k in 0..m {
        let x = [b0[k], b1[k], b2[k], b3[k], b4[k], b5[k]];
        r0[k] += if R0 { sum6(c, &x) } else { sum3(c, &x) };
        r1[k] += if R1 { sum6(d, &x) } else { sum3(d, &x) };
    }
}

/// The loop of [`GramAccumulator::add_rows6_in_order`] into two rows at once (`r0` with
/// coefficients `c`, `r1` with `d`): each entry adds its six products one after the other.
#[inline]
fn in_order_pair(r0: &mut [f64], r1: &mut [f64], c: &[f64; 6], d: &[f64; 6], a: [&[f64]; 6]) {
    let m = r0.len();
    let [b0, b1, b2, b3, b4, b5] = a;
    let (Some(r1), Some(b0), Some(b1), Some(b2), Some(b3), Some(b4), Some(b5)) = (
        r1.get_mut(..m),
        b0.get(..m),
        b1.get(..m),
        b2.get(..m),
        b3.get(..m),
        b4.get(..m),
        b5.get(..m),
    ) else {
        return;
    };
    for k in 0..m {
        let x = [b0[k], b1[k], b2[k], b3[k], b4[k], b5[k]];
        let (mut u, mut v) = (r0[k], r1[k]);
        for r in 0..6 {
            u += c[r] * x[r];
            v += d[r] * x[r];
        }
        r0[k] = u;
        r1[k] = v;
    }
}

impl<const P: usize> Default for GramAccumulator<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// Cholesky factor of the symmetric positive definite matrix whose upper triangle is the
/// leading `n`×`n` block of `a`, written into `r` (upper, `RᵀR = A`, zero below the
/// diagonal). `RankDeficient { rank: k }` at the first pivot `<= rel_tol·max diag`.
pub fn cholesky_upper<const P: usize>(
    a: &[[f64; P]; P],
    n: usize,
    rel_tol: f64,
    r: &mut [[f64; P]; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    for (i, (ri, ai)) in r.iter_mut().zip(a.iter()).take(n).enumerate() {
        ri[..i].fill(0.0);
        ri[i..n].copy_from_slice(&ai[i..n]);
    }
    cholesky_upper_in_place(r, n, rel_tol)
}

/// [`cholesky_upper`] overwriting its input: the upper triangle of the leading `n`×`n`
/// block of `r` becomes the factor (the strict lower triangle is neither read nor
/// written), so a caller that builds the matrix in its final place needs no copy.
///
/// Right-looking (outer-product) order: after row `k` is final, its outer product is
/// subtracted from the trailing rows, each a contiguous run in row-major storage, so the
/// inner loop has no dependent chain of additions and vectorises.
pub fn cholesky_upper_in_place<const P: usize>(
    r: &mut [[f64; P]; P],
    n: usize,
    rel_tol: f64,
) -> Result<()> {
    check_capacity::<P>(n)?;
    let n = n.min(P);
    let dmax = r
        .iter()
        .take(n)
        .enumerate()
        .map(|(i, ri)| ri[i])
        .fold(0.0, f64::max);
    for k in 0..n {
        let (head, tail) = r.split_at_mut(k + 1);
        let Some(rk) = head.last_mut() else {
            break;
        };
        let d = rk[k];
        if d.is_nan() || d <= rel_tol * dmax || !d.is_finite() {
            return Err(Error::RankDeficient {
                rank: k,
                required: n,
            });
        }
        let dk = libm::sqrt(d);
        rk[k] = dk;
        // One division per pivot, not per entry (divisions are the slow scalar step here).
        let inv = 1.0 / dk;
        for x in &mut rk[k + 1..n] {
            *x *= inv;
        }
        for (i, ri) in (k + 1..n).zip(tail.iter_mut()) {
            let f = rk[i];
            for (x, &y) in ri[i..n].iter_mut().zip(rk[i..n].iter()) {
                *x -= f * y;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::linalg::lsq::LsqAccumulator;

    /// Narrowing after folding equals folding only the selected columns, bit for bit, and
    /// later rows keep agreeing; unsorted or out-of-range selections are refused.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn select_equals_folding_the_selected_columns() {
        const P: usize = 9;
        let cols = [1usize, 2, 5, 8];
        let (mut wide, mut narrow) = (GramAccumulator::<P>::new(), GramAccumulator::<P>::new());
        wide.reset(P).unwrap();
        narrow.reset(cols.len()).unwrap();
        let row = |r: usize| -> [[f64; P]; 6] {
            let mut a = [[0.0; P]; 6];
            for (k, ak) in a.iter_mut().enumerate() {
                for (j, v) in ak.iter_mut().enumerate() {
                    *v = ((r * 31 + k * 7 + j * 3) % 17) as f64 / 7.0 - 1.1;
                }
            }
            a
        };
        let pick = |a: &[[f64; P]; 6]| -> [[f64; P]; 6] {
            let mut s = [[0.0; P]; 6];
            for (sk, ak) in s.iter_mut().zip(a) {
                for (v, &c) in sk.iter_mut().zip(&cols) {
                    *v = ak[c];
                }
            }
            s
        };
        let b = |r: usize| [0.3 * r as f64, -1.0, 0.7, 0.1, 2.0 / (1.0 + r as f64), 0.5];
        for r in 0..5 {
            wide.add_rows6_in_order(&row(r), &b(r)).unwrap();
            narrow.add_rows6_in_order(&pick(&row(r)), &b(r)).unwrap();
        }
        wide.select(&cols).unwrap();
        for r in 5..8 {
            // Narrowed, `wide` takes the narrow rows from now on.
            wide.add_rows6_in_order(&pick(&row(r)), &b(r)).unwrap();
            narrow.add_rows6_in_order(&pick(&row(r)), &b(r)).unwrap();
        }
        assert_eq!(wide.n(), cols.len());
        for i in 0..cols.len() {
            assert_eq!(wide.atb()[i].to_bits(), narrow.atb()[i].to_bits());
            for j in i..cols.len() {
                assert_eq!(wide.gram()[i][j].to_bits(), narrow.gram()[i][j].to_bits());
            }
        }
        assert_eq!(wide.btb().to_bits(), narrow.btb().to_bits());
        // The selection is not a no-op here: entry (0, 0) moved.
        let mut fresh = GramAccumulator::<P>::new();
        fresh.reset(P).unwrap();
        fresh.add_rows6_in_order(&row(0), &b(0)).unwrap();
        assert_ne!(fresh.gram()[0][0], fresh.gram()[1][1]);
        assert!(wide.select(&[2, 1]).is_err());
        assert!(wide.select(&[0, cols.len()]).is_err());
    }

    #[test]
    #[allow(clippy::unwrap_used)]
    fn add_rows3_is_add_rows6_of_position_rows_bit_for_bit() {
        const P: usize = 12;
        // Odd and even counts (the rows of G go in pairs), the last one the capacity.
        for n in [11, 12] {
            check_add_rows3::<P>(n);
        }
    }

    #[allow(clippy::unwrap_used)]
    fn check_add_rows3<const P: usize>(n: usize) {
        let (mut g6, mut g3) = (GramAccumulator::<P>::new(), GramAccumulator::<P>::new());
        g6.reset(n).unwrap();
        g3.reset(n).unwrap();
        for k in 0..40 {
            let x = |r: usize, j: usize| libm::sin(0.37 * (k * 31 + r * 7 + j) as f64 + 1.3);
            let mut a = [[0.0; P]; 6];
            for (r, row) in a.iter_mut().enumerate().take(3) {
                for (j, v) in row.iter_mut().enumerate().take(n) {
                    // Negative values, exact zeros (column 4 always, some entries sometimes)
                    // and a value beyond n that must not be read.
                    *v = if j == 4 || (k + r + j) % 9 == 0 {
                        0.0
                    } else {
                        x(r, j)
                    };
                }
                if let Some(v) = row.get_mut(n) {
                    *v = f64::NAN;
                }
            }
            let b = [
                x(5, 0) * 1e-3,
                -x(6, 1),
                if k % 5 == 0 { 0.0 } else { x(7, 2) },
            ];
            let w = [0.5 + x(8, 0).abs(), if k % 7 == 0 { 0.0 } else { 2.0 }, 1.0];
            g6.add_rows6(
                &a,
                &[b[0], b[1], b[2], 0.0, 0.0, 0.0],
                &[w[0], w[1], w[2], 0.0, 0.0, 0.0],
            )
            .unwrap();
            g3.add_rows3(&a, &b, &w).unwrap();
        }
        for i in 0..n {
            for j in i..n {
                assert_eq!(
                    g3.gram()[i][j].to_bits(),
                    g6.gram()[i][j].to_bits(),
                    "{i},{j}"
                );
            }
            assert_eq!(g3.atb()[i].to_bits(), g6.atb()[i].to_bits(), "{i}");
        }
        assert_eq!(g3.btb().to_bits(), g6.btb().to_bits());
        assert!(g3.gram()[0][0] > 1.0 && g3.gram()[4][4] == 0.0);
        // Non-finite input fails as add_rows6 does.
        let mut a = [[0.0; P]; 6];
        a[1][3] = f64::INFINITY;
        let err = g3.add_rows3(&a, &[0.0; 3], &[1.0; 3]).unwrap_err();
        assert_eq!(err, g6.add_rows6(&a, &[0.0; 6], &[1.0; 6]).unwrap_err());
        assert!(
            g3.add_rows3(&[[0.0; P]; 6], &[0.0; 3], &[-1.0, 1.0, 1.0])
                .is_err()
        );
    }

    /// Rows of a pose whose columns mix every class the paired kernels tell apart: all
    /// zero (column 2, and column 9 at every third pose), position only (3, 4, 7, and 8 at
    /// odd poses) and full; entries beyond `n` are NaN and must not be read.
    fn mixed_rows<const P: usize>(k: usize, n: usize) -> [[f64; P]; 6] {
        let x = |r: usize, j: usize| libm::sin(0.41 * (k * 37 + r * 11 + j) as f64 + 0.7);
        let mut a = [[0.0; P]; 6];
        for (r, row) in a.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                let zero = j == 2 || (j == 9 && k.is_multiple_of(3));
                let length = matches!(j, 3 | 4 | 7) || (j == 8 && !k.is_multiple_of(2));
                *v = if j >= n {
                    f64::NAN
                } else if zero || (length && r >= 3) {
                    0.0
                } else {
                    x(r, j)
                };
            }
        }
        a
    }

    /// The paired kernels against their definitions, bit for bit: `add_rows6` against each
    /// entry's `fold3`/`fold6` expression computed one row at a time, `add_rows6_in_order`
    /// against six `add_row_weighted` calls of weight 1; odd and even `n`.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn paired_rows_give_each_entry_its_single_row_sum() {
        const P: usize = 12;
        for n in [11, 12] {
            let mut g = GramAccumulator::<P>::new();
            let mut o = GramAccumulator::<P>::new();
            let mut s = GramAccumulator::<P>::new();
            g.reset(n).unwrap();
            o.reset(n).unwrap();
            s.reset(n).unwrap();
            let mut r = [[0.0f64; P]; P];
            let mut ratb = [0.0f64; P];
            for k in 0..30 {
                let a = mixed_rows::<P>(k, n);
                let b = [0.3, -1.1, 0.02, 0.5, -0.25, 0.9].map(|v| v * (k as f64 + 1.0));
                let w = [
                    1.5,
                    0.5,
                    if k.is_multiple_of(4) { 0.0 } else { 2.0 },
                    1.0,
                    3.0,
                    0.25,
                ];
                g.add_rows6(&a, &b, &w).unwrap();
                o.add_rows6_in_order(&a, &b).unwrap();
                for (row, &br) in a.iter().zip(&b) {
                    s.add_row_weighted(&row[..n], br, 1.0).unwrap();
                }
                // The reference: row by row, each entry's single-row expression.
                for i in 0..n {
                    let c: [f64; 6] = core::array::from_fn(|t| w[t] * a[t][i]);
                    ratb[i] += c.iter().zip(b.iter()).map(|(x, y)| x * y).sum::<f64>();
                    if c.iter().all(|&v| v == 0.0) {
                        continue;
                    }
                    let rot = !(c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0);
                    for j in i..n {
                        let x: [f64; 6] = core::array::from_fn(|t| a[t][j]);
                        r[i][j] += if rot { sum6(&c, &x) } else { sum3(&c, &x) };
                    }
                }
            }
            for i in 0..n {
                for j in i..n {
                    assert_eq!(g.gram()[i][j].to_bits(), r[i][j].to_bits(), "{n}: {i},{j}");
                    let (u, v) = (o.gram()[i][j], s.gram()[i][j]);
                    assert_eq!(u.to_bits(), v.to_bits(), "{n}: {i},{j}");
                }
                assert_eq!(g.atb()[i].to_bits(), ratb[i].to_bits(), "{n}: {i}");
                assert_eq!(o.atb()[i].to_bits(), s.atb()[i].to_bits(), "{n}: {i}");
            }
            // Not vacuous: the zero column stays zero, the others fill.
            assert_eq!(g.gram()[2][2], 0.0);
            assert!(g.gram()[0][1] != 0.0 && g.gram()[3][4] != 0.0 && o.gram()[5][6] != 0.0);
        }
    }

    #[test]
    #[allow(clippy::unwrap_used)]
    fn gram_and_cholesky_match_the_givens_factor() {
        const P: usize = 8;
        let mut g = GramAccumulator::<P>::new();
        let mut l = LsqAccumulator::<P>::new();
        g.reset(5).unwrap();
        l.reset(5).unwrap();
        let mut s = 0x1234_5678_u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for _ in 0..40 {
            let a = [next(), next(), next(), next(), next()];
            let b = next();
            let w = 0.5 + next();
            g.add_row_weighted(&a, b, w).unwrap();
            l.add_row_weighted(&a, b, w).unwrap();
        }
        let mut r = [[0.0; P]; P];
        cholesky_upper(g.gram(), 5, 1e-14, &mut r).unwrap();
        // RᵀR from both routes agree (Givens R may differ in row signs only).
        for i in 0..5 {
            for j in i..5 {
                let a: f64 = (0..5).map(|k| r[k][i] * r[k][j]).sum();
                let b: f64 = (0..5).map(|k| l.r()[k][i] * l.r()[k][j]).sum();
                assert!(
                    (a - b).abs() < 1e-12 * (1.0 + b.abs()),
                    "{i},{j}: {a} vs {b}"
                );
            }
            let atb: f64 = (0..5).map(|k| l.r()[k][i] * l.qtb()[k]).sum();
            assert!((g.atb()[i] - atb).abs() < 1e-12);
        }
        // Six rows at once equal six single rows.
        let mut g6 = GramAccumulator::<P>::new();
        let mut g1 = GramAccumulator::<P>::new();
        g6.reset(5).unwrap();
        g1.reset(5).unwrap();
        for _ in 0..7 {
            let mut a = [[0.0; P]; 6];
            let (mut b, mut w) = ([0.0; 6], [0.0; 6]);
            for r in 0..6 {
                for v in a[r].iter_mut().take(5) {
                    *v = next();
                }
                // Rotation-like rows with zero length columns, and a left-out row.
                if r >= 3 {
                    a[r][1] = 0.0;
                    a[r][2] = 0.0;
                }
                b[r] = next();
                w[r] = if r == 4 { 0.0 } else { 0.5 + next() };
                g1.add_row_weighted(&a[r][..5], b[r], w[r]).unwrap();
            }
            g6.add_rows6(&a, &b, &w).unwrap();
        }
        for i in 0..5 {
            for j in i..5 {
                assert!((g6.gram()[i][j] - g1.gram()[i][j]).abs() < 1e-13);
            }
            assert!((g6.atb()[i] - g1.atb()[i]).abs() < 1e-13);
        }
        assert!((g6.btb() - g1.btb()).abs() < 1e-13);
        let mut bad = [[0.0; P]; 6];
        bad[2][3] = f64::NAN;
        assert!(matches!(
            g6.add_rows6(&bad, &[0.0; 6], &[1.0; 6]),
            Err(Error::NonFinite { index: 3, .. })
        ));
        assert!(g6.add_rows6(&[[0.0; P]; 6], &[0.0; 6], &[-1.0; 6]).is_err());

        // A rank-deficient Gram matrix is refused at the right pivot.
        let mut d = GramAccumulator::<P>::new();
        d.reset(3).unwrap();
        for k in 0..10 {
            let x = k as f64;
            d.add_row_weighted(&[x, 2.0 * x, 1.0], 1.0, 1.0).unwrap();
        }
        assert!(matches!(
            cholesky_upper(d.gram(), 3, 1e-12, &mut r),
            Err(Error::RankDeficient {
                rank: 1,
                required: 3
            })
        ));
    }
}
