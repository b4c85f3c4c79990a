//! Gross-outlier screening before the candidates are judged: one mistyped joint row or a
//! lost marker must not turn a clear effect into `unexplained`.
//!
//! The most flexible model — the geometric parameters and every candidate effect's, the
//! union `U` — is fitted (one linearised step at the geometric calibration) on the rows
//! not yet suspect, so that a real effect in the library leaves no structured residual.
//! Each row's whitened residual is standardised by robust per-part scales: the median norm
//! over the clean rows divided by the median of χ₃ (breakdown 50 %), then the root mean
//! square over the rows the test accepts, both corrected for the fitted parameters and
//! never below half the noise floor (stated σ too large must not flag everything). A row
//! with `d² = |v_p|²/s_p² + |v_φ|²/s_φ²` above the 99.99 % quantile of χ² with its number
//! of measured components is a suspect; the fit and the test are repeated until the set
//! settles. More suspects than [`super::MAX_SUSPECTS`] or a tenth of the rows are not "a
//! few gross outliers" but heavy-tailed residuals: then none is excluded.

use super::{DiagWorkspace, PoseDiagnosis, SCREEN_MODEL, cv};
use crate::error::Result;
use crate::identify::Measurement;
use crate::identify::robust::{CHI2_9999, CHI3_MEDIAN};
use crate::math::sqrt;
use crate::model::Robot;

/// Passes of fit-and-test at most.
const MAX_PASSES: usize = 5;
/// Robust scales never drop below this share of the noise floor (whitened units).
const MIN_SCALE: f64 = 0.5;

/// Outcome of [`screen`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Screening {
    /// These many rows are marked `suspect` in the pose records.
    Suspects(usize),
    /// This many rows failed the test: too many to be outliers, none excluded.
    TooMany(usize),
}

/// Screens `data` (module documentation) with the union model in slot [`SCREEN_MODEL`]
/// of `ws` (its columns set by the caller); marks `poses[l].suspect`. Leaves
/// `heldout_final` of every pose zeroed and `ws.g_all` folded over the rows that were
/// clean in the last pass; the flag returned says whether those are the rows clean now
/// (the last pass changed no mark), i.e. whether `ws.g_all` is the Gram of the clean rows
/// at `lin`, bit for bit as a new pass over them would fold it.
pub(crate) fn screen<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    max_suspects: usize,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<(Screening, bool)> {
    let n = data.len();
    let cap = cap(max_suspects, n);
    let mut outcome = Screening::Suspects(0);
    let mut current = false;
    let lin = cv::Lin::bind(lin, ws);
    for _ in 0..MAX_PASSES {
        ws.g_all.reset(ws.n_u)?;
        for (l, m) in data.iter().enumerate() {
            if !poses[l].suspect {
                cv::pose_rows(&lin, l, m, sw, ws)?;
                cv::fold_rows(ws, false)?;
            }
        }
        let p = cv::factor(ws, SCREEN_MODEL, false, tol, None);
        cv::solve(ws, SCREEN_MODEL, p, false);
        // Per row: |v_p|², |v_φ|², measured position and rotation components (kept in the
        // `heldout_final` slot, which the diagnosis overwrites later).
        let mut rows = 0usize;
        for (l, m) in data.iter().enumerate() {
            cv::pose_rows(&lin, l, m, sw, ws)?;
            let mut rec = [0.0; 6];
            for k in 0..6 {
                if !m.mask.has(k) {
                    continue;
                }
                let mut v = ws.b[k];
                for j in 0..ws.model_n[SCREEN_MODEL] {
                    v -= ws.a[k][ws.model_cols[SCREEN_MODEL][j] as usize]
                        * ws.delta[SCREEN_MODEL][j];
                }
                rec[usize::from(k >= 3)] += v * v;
                rec[2 + usize::from(k >= 3)] += 1.0;
            }
            if !poses[l].suspect {
                rows += (rec[2] + rec[3]) as usize;
            }
            poses[l].heldout_final = rec;
        }
        let dof = if rows > p {
            sqrt(rows as f64 / (rows - p) as f64)
        } else {
            1.0
        };
        let mut scale = [0.0; 2];
        for (part, s) in scale.iter_mut().enumerate() {
            *s = (dof * median_norm(poses, part) / CHI3_MEDIAN).max(MIN_SCALE);
        }
        let robust = scale;
        for (part, s) in scale.iter_mut().enumerate() {
            let (mut ss, mut k) = (0.0, 0.0);
            for q in poses
                .iter()
                .filter(|q| !q.suspect && d2(q, &robust) <= thr(q))
            {
                ss += q.heldout_final[part];
                k += q.heldout_final[2 + part];
            }
            if k > 0.0 {
                *s = (dof * sqrt(ss / k)).max(MIN_SCALE);
            }
        }
        let mut changed = false;
        let mut count = 0;
        for q in poses.iter_mut() {
            let flag = d2(q, &scale) > thr(q);
            changed |= flag != q.suspect;
            q.suspect = flag;
            count += usize::from(flag);
        }
        if count > cap {
            for q in poses.iter_mut() {
                q.suspect = false;
            }
            outcome = Screening::TooMany(count);
            break;
        }
        outcome = Screening::Suspects(count);
        if !changed {
            current = true;
            break;
        }
    }
    for q in poses.iter_mut() {
        q.heldout_final = [0.0; 6];
    }
    Ok((outcome, current))
}

/// Suspects the screen excludes at most among `rows` rows: `max_suspects` (the capacity
/// of the result) or a tenth of the rows, whichever is less.
pub(crate) fn cap(max_suspects: usize, rows: usize) -> usize {
    max_suspects.min(rows / 10)
}

/// Standardised squared residual of a screened row at the part scales.
fn d2(q: &PoseDiagnosis, scale: &[f64; 2]) -> f64 {
    let r = &q.heldout_final;
    r[0] / (scale[0] * scale[0]) + r[1] / (scale[1] * scale[1])
}

/// The suspect threshold of a row: χ² 99.99 % with its number of measured components.
fn thr(q: &PoseDiagnosis) -> f64 {
    let k = (q.heldout_final[2] + q.heldout_final[3]) as usize;
    CHI2_9999
        .get(k.clamp(1, 6) - 1)
        .copied()
        .unwrap_or(f64::INFINITY)
}

/// Median over the clean rows measuring part `part` (0 position, 1 rotation) of the
/// residual norm rescaled to three components, `|v|·√(3/k)`; 0 without such rows. Exact:
/// the values are sorted in place in the first records' `scratch` (O(n log n), no memory).
fn median_norm(poses: &mut [PoseDiagnosis], part: usize) -> f64 {
    let mut n = 0;
    for l in 0..poses.len() {
        let q = &poses[l];
        let k = q.heldout_final[2 + part];
        if !q.suspect && k > 0.0 {
            let v = sqrt(3.0 * q.heldout_final[part] / k);
            // Slot n ≤ l: every record at or before it has been read.
            poses[n].scratch = v;
            n += 1;
        }
    }
    let Some(values) = poses.get_mut(..n) else {
        return 0.0;
    };
    // Non-negative values: ascending magnitude is ascending value.
    super::rank::sort_by_magnitude(values);
    let at = |i: usize| values.get(i).map_or(0.0, |p| p.scratch);
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => at(n / 2),
        _ => 0.5 * (at(n / 2 - 1) + at(n / 2)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use std::vec::Vec;

    /// The former O(n²) selection by counting, kept as the reference.
    fn counted_median(poses: &[PoseDiagnosis], part: usize) -> f64 {
        let value = |q: &PoseDiagnosis| {
            let k = q.heldout_final[2 + part];
            (!q.suspect && k > 0.0).then(|| sqrt(3.0 * q.heldout_final[part] / k))
        };
        let n = poses.iter().filter_map(value).count();
        if n == 0 {
            return 0.0;
        }
        let select = |rank: usize| {
            poses
                .iter()
                .filter_map(value)
                .find(|&x| {
                    let below = poses.iter().filter_map(value).filter(|&y| y < x).count();
                    let equal = poses.iter().filter_map(value).filter(|&y| y == x).count();
                    below <= rank && rank < below + equal
                })
                .unwrap_or(0.0)
        };
        if n % 2 == 1 {
            select(n / 2)
        } else {
            0.5 * (select(n / 2 - 1) + select(n / 2))
        }
    }

    /// Sorted median equals the counted one bit for bit: odd and even counts, suspects and
    /// rows without the part skipped, tied values.
    #[test]
    fn sorted_median_matches_the_counted_one() {
        let mut rng = SplitMix64::new(4);
        for case in 0..200 {
            let n = rng.below(60);
            let poses: Vec<PoseDiagnosis> = (0..n)
                .map(|_| {
                    let mut p = PoseDiagnosis::EMPTY;
                    let level = if case % 2 == 0 {
                        rng.below(4) as f64
                    } else {
                        rng.uniform()
                    };
                    p.heldout_final = [level, 2.0 * level, rng.below(4) as f64, 3.0, 0.0, 0.0];
                    p.suspect = rng.uniform() < 0.1;
                    p
                })
                .collect();
            for part in 0..2 {
                let want = counted_median(&poses, part);
                let got = median_norm(&mut poses.clone(), part);
                assert_eq!(got.to_bits(), want.to_bits(), "case {case} part {part}");
            }
        }
    }
}
