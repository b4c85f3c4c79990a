//! Confounding with the sessions: data from several set-ups (sessions), each measured in
//! its own base frame, cannot attribute to an effect what is the same in every row of a
//! session. Two general tests, per candidate effect, on the clean rows at the geometric
//! calibration (whitened as everywhere in the diagnosis):
//!
//! - **Columns.** The principal angle between each of the effect's parameter columns and
//!   the span of the geometric columns plus the *session-frame* columns (the six
//!   base-frame columns of [`crate::Effect::BaseFrame`] restricted to one session's rows,
//!   per session): `sin θ` is the length of the unit column's part outside that span (the
//!   pivot of a greedy Cholesky factor, as in `cv::factor`). When every column of the
//!   effect has `sin θ ≤` [`super::Config::session_sin_max`], a rigid frame per session
//!   (with the geometry) reproduces what the effect does: the data cannot tell them apart.
//! - **Input.** An effect driven by a measured input other than the joint readings
//!   (`temp_c` for `thermal`, the approach directions for `backlash`) whose values are
//!   (nearly) constant within every session: the share of the input's variance that lies
//!   within sessions, `w = Σ(x − x̄_s)² / Σ(x − x̄)²`, is the `sin²` of the angle between the
//!   centred input and the span of the session indicators. With `√w ≤` the same threshold
//!   the effect's parameter is estimated from differences *between* sessions only, and
//!   everything else that differs between the sessions (the set-up, the floor, the
//!   instrument, its frame) is an equally good explanation: the data cannot attribute it to
//!   the input. Two input values within one session, or two sessions in the same set-up at
//!   different input values, separate them.
//!
//! A candidate confounded either way is never chosen as the verdict; when it explains the
//! data as well as the chosen one (or no other candidate does) it is listed.

use super::{DiagWorkspace, PoseDiagnosis};
use crate::effects::Effect;
use crate::error::Result;
use crate::identify::Measurement;
use crate::math::sqrt;
use crate::model::Robot;
use crate::params::ParamSet;

/// Sessions the test handles at most (more: not evaluated).
pub const MAX_SESSIONS: usize = 32;

/// How one candidate relates to the sessions ([`super::ModelScore::session`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SessionConfounding {
    /// Whether the test ran (two sessions or more, capacity, an identifiable effect).
    pub evaluated: bool,
    /// Largest `sin θ` over the effect's columns against the geometric and session-frame
    /// columns (0: inside that span; 1: orthogonal to it).
    pub column_sin: f64,
    /// `√w` of the effect's input (module documentation); `None` for effects of the joint
    /// readings alone.
    pub input_sin: Option<f64>,
    /// The columns lie in the session frames' span (`column_sin ≤` the threshold).
    pub columns_in_span: bool,
    /// The input is constant within sessions (`input_sin ≤` the threshold).
    pub input_constant: bool,
}

impl SessionConfounding {
    /// Confounded with the sessions either way.
    #[must_use]
    pub const fn confounded(&self) -> bool {
        self.evaluated && (self.columns_in_span || self.input_constant)
    }

    /// The test of a pair: confounded when either effect is (its share is not attributable),
    /// the smaller sines.
    #[must_use]
    pub fn combine(a: &Self, b: &Self) -> Self {
        if !a.evaluated || !b.evaluated {
            return if a.evaluated { *a } else { *b };
        }
        let input_sin = match (a.input_sin, b.input_sin) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        };
        SessionConfounding {
            evaluated: true,
            column_sin: a.column_sin.min(b.column_sin),
            input_sin,
            columns_in_span: a.columns_in_span || b.columns_in_span,
            input_constant: a.input_constant || b.input_constant,
        }
    }
}

/// Number of sessions named by `sessions` (largest index + 1); 0 for an empty slice.
pub(crate) fn count(sessions: &[u16]) -> usize {
    sessions
        .iter()
        .map(|&s| usize::from(s) + 1)
        .max()
        .unwrap_or(0)
}

/// The input test: `√w` of `x(l)` over the clean rows, `None` when the input is absent.
fn input_sin<const N: usize>(
    data: &[Measurement<N>],
    sessions: &[u16],
    poses: &[PoseDiagnosis],
    n_s: usize,
    x: impl Fn(&Measurement<N>) -> Option<f64>,
) -> Option<f64> {
    let mut sum = [0.0f64; MAX_SESSIONS];
    let mut cnt = [0usize; MAX_SESSIONS];
    let (mut all, mut n) = (0.0, 0usize);
    let clean = || {
        data.iter()
            .zip(sessions)
            .zip(poses)
            .filter(|(_, p)| !p.suspect)
            .map(|((m, &s), _)| (m, usize::from(s)))
    };
    for (m, s) in clean() {
        let v = x(m)?;
        if let (Some(a), Some(c)) = (sum.get_mut(s), cnt.get_mut(s)) {
            *a += v;
            *c += 1;
        }
        all += v;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let mean = all / n as f64;
    let (mut within, mut total) = (0.0, 0.0);
    for (m, s) in clean() {
        let v = x(m)?;
        let ms = match (sum.get(s), cnt.get(s)) {
            (Some(&a), Some(&c)) if c > 0 => a / c as f64,
            _ => mean,
        };
        within += (v - ms) * (v - ms);
        total += (v - mean) * (v - mean);
    }
    let _ = n_s;
    Some(if total > 0.0 {
        sqrt(within / total)
    } else {
        0.0
    })
}

/// The session test of effect `effect` whose fitted parameters are `effect_params`, next
/// to the baseline's fitted geometric parameters `geometric`. Uses `ws.id.mat` (Gram) and
/// `ws.chol` (factor) as scratch.
#[allow(clippy::too_many_arguments)]
pub(crate) fn test<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sessions: &[u16],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    effect: Effect,
    geometric: &ParamSet,
    effect_params: &ParamSet,
    sin_max: f64,
    rank_tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<SessionConfounding> {
    let mut out = SessionConfounding::default();
    let n_s = count(sessions);
    if !(2..=MAX_SESSIONS).contains(&n_s)
        || sessions.len() != data.len()
        || effect_params.is_empty()
    {
        return Ok(out);
    }
    // Columns: geometric, then 6 per session, then the effect's. `col[c]` is the flat
    // parameter index; `sess[c]` the session a frame column belongs to (u16::MAX: all).
    let n_g = geometric.len();
    let n_a = n_g + 6 * n_s;
    let n_cols = n_a + effect_params.len();
    if n_cols > P || n_cols > 256 {
        return Ok(out);
    }
    let mut col = [0usize; 256];
    let mut sess = [u16::MAX; 256];
    for (c, i) in geometric.iter().enumerate() {
        col[c] = i;
    }
    let base = Effect::BaseFrame.params(N);
    for s in 0..n_s {
        for (k, i) in base.iter().enumerate().take(6) {
            let c = n_g + 6 * s + k;
            col[c] = i;
            sess[c] = s as u16;
        }
    }
    for (k, i) in effect_params.iter().enumerate() {
        col[n_a + k] = i;
    }
    // Whitened Gram of the clean rows in ws.id.mat.
    for r in ws.id.mat.iter_mut().take(n_cols) {
        for v in r.iter_mut().take(n_cols) {
            *v = 0.0;
        }
    }
    for ((m, &s), p) in data.iter().zip(sessions).zip(poses) {
        if p.suspect {
            continue;
        }
        let jac = super::jacobian_slots::<N>(&mut ws.jac)?;
        m.model_jacobian(lin, jac)?;
        for k in (0..6).filter(|&k| m.mask.has(k)) {
            for c in 0..n_cols {
                let on = sess[c] == u16::MAX || sess[c] == s;
                ws.tmp[c] = if on {
                    sw[k] * ws.jac.get(col[c]).map_or(0.0, |j| j[k])
                } else {
                    0.0
                };
            }
            for a in 0..n_cols {
                let va = ws.tmp[a];
                if va == 0.0 {
                    continue;
                }
                for b in a..n_cols {
                    ws.id.mat[a][b] += va * ws.tmp[b];
                }
            }
        }
    }
    // Greedy unit-scaled Cholesky of the geometric and frame columns (ws.chol, kept order).
    let mut scale = [0.0f64; 256];
    let mut kept = [0usize; 256];
    let mut n = 0;
    let mut y = [0.0f64; 256];
    for j in 0..n_a {
        let (piv2, dj) = pivot(ws, &kept[..n], &scale[..n], j, &mut y);
        if piv2 > rank_tol * rank_tol && dj > 0.0 {
            for (dst, &v) in ws.chol[n].iter_mut().zip(y.iter()).take(n) {
                *dst = v;
            }
            ws.chol[n][n] = sqrt(piv2);
            scale[n] = dj;
            kept[n] = j;
            n += 1;
        }
    }
    // Each effect column against that span.
    let mut worst = 0.0f64;
    for j in n_a..n_cols {
        let (piv2, dj) = pivot(ws, &kept[..n], &scale[..n], j, &mut y);
        if dj > 0.0 {
            worst = worst.max(sqrt(piv2.clamp(0.0, 1.0)));
        }
    }
    out.evaluated = true;
    out.column_sin = worst;
    out.columns_in_span = worst <= sin_max;
    out.input_sin = match effect {
        Effect::Thermal => input_sin(data, sessions, poses, n_s, |m| m.state.temp_c),
        Effect::Backlash => (0..N)
            .filter_map(|j| {
                input_sin(data, sessions, poses, n_s, |m| {
                    m.state.approach.and_then(|a| a.get(j).copied())
                })
            })
            .reduce(f64::max),
        _ => None,
    };
    out.input_constant = out.input_sin.is_some_and(|s| s <= sin_max);
    Ok(out)
}

/// Column `j`'s unit-scaled squared length outside the span of the kept columns
/// (`kept`, `scale`, factor in `ws.chol`) and its norm; `y` receives `L⁻¹·g`.
fn pivot<const P: usize>(
    ws: &DiagWorkspace<P>,
    kept: &[usize],
    scale: &[f64],
    j: usize,
    y: &mut [f64; 256],
) -> (f64, f64) {
    let djj = ws.id.mat[j][j];
    if !(djj > 0.0 && djj.is_finite()) {
        return (0.0, 0.0);
    }
    let dj = sqrt(djj);
    let mut y2 = 0.0;
    for (r, (&kr, &sr)) in kept.iter().zip(scale).enumerate() {
        let g = if kr <= j {
            ws.id.mat[kr][j]
        } else {
            ws.id.mat[j][kr]
        };
        let mut v = g / (sr * dj);
        for c in 0..r {
            v -= ws.chol[r][c] * y[c];
        }
        let v = v / ws.chol[r][r];
        y[r] = v;
        y2 += v * v;
    }
    (1.0 - y2, dj)
}
