//! One base frame per session for instrument rows (spec: "rows of different sessions get a
//! base frame each"): a set-up re-mounted or re-stationed between sessions measures in its
//! own frame `T_s` (robot base → the session's measuring frame), so the rows of session `s`
//! say `y_i ≈ T_s·f_i(θ)`.
//!
//! **Elimination.** `T_s` (6 nuisance parameters, whether the rows carry poses or only
//! positions) never enters the parameter vector. At the current model an inner solve fits
//! it: a weighted Kabsch/Horn start on the rows measuring a full position (else the first
//! full pose), then Gauss–Newton steps on all the session's measured components. The
//! session's rows are then folded with the Schur complement of its 6×6 block: with `B_i`
//! the rows' derivative with respect to a motion `δ = [δp; δφ]` of the frame (`T_s ←
//! Exp(δ)·T_s`: position rows `[I, −[p]×]`, orientation rows `[0, I]`), `N = Σ B_iᵀW B_i`,
//! `C = Σ B_iᵀW J_i`, `g = Σ B_iᵀW e_i`, the reduced normal equations are
//! `Σ J_iᵀW J_i − CᵀN⁻¹C` and `Σ J_iᵀW e_i − CᵀN⁻¹g` — on the Gram path the rows are folded
//! as they come and `L⁻¹C`, `L⁻¹g` (`N = LLᵀ`) removed afterwards; on the Givens path the
//! reduced rows `J_i − B_i N⁻¹C`, `e_i − B_i N⁻¹g` are folded in a second pass. The outer
//! parameter vector does not grow with the number of sessions, and memory does not grow
//! with the rows.
//!
//! **Gauge.** Instrument rows outside every session are in the robot's base frame: they
//! (or known targets/planes) fix the base, which is then identifiable as usual. When every
//! instrument row lies in a session of its own frame, the frames absorb the base frame: it
//! is not observable and the identifiability analysis reports its parameters as gauge
//! ([`super::ConstraintData::has_external_reference`]). The CLI keeps the first session in
//! the base frame (so a single-session file calibrates as before) and gives the others
//! their own frames.

use super::constraints::ConstraintData;
use super::data::{Measurement, StatsAcc, jacobian_len, weight};
use super::{IdentifyOptions, ResidualStats, Workspace};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::pose::{Transform, pose_error, rotation_exp, transform};
use nalgebra::{Matrix3, Vector3};

/// The instrument rows `start..start + len` of [`ConstraintData::instrument`], measured in
/// a frame of their own (eliminated, see the module doc). Sessions are in row order and do
/// not overlap; rows outside every session are in the robot's base frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InstrumentSession {
    /// First instrument row.
    pub start: usize,
    /// Number of rows.
    pub len: usize,
}

/// Most Gauss–Newton steps of the inner fit of a session's frame (it converges
/// quadratically from the Kabsch start: 3–5 steps on real data).
pub const SESSION_FRAME_STEPS: u32 = 30;

/// A step of the frame below this (metres plus radians) ends the inner fit.
const SESSION_FRAME_TOL: f64 = 1e-14;

/// `B` of one row: the derivative of the model's component `k` in the session frame with
/// respect to the frame motion `[δp; δφ]` at the model point `p` (session frame).
fn b_row(k: usize, p: &[f64; 3]) -> [f64; 6] {
    match k {
        0 => [1.0, 0.0, 0.0, 0.0, p[2], -p[1]],
        1 => [0.0, 1.0, 0.0, -p[2], 0.0, p[0]],
        2 => [0.0, 0.0, 1.0, p[1], -p[0], 0.0],
        3 => [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        4 => [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        _ => [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    }
}

/// Lower Cholesky factor of a symmetric 6×6 matrix; [`Error::RankDeficient`] (with the
/// rank reached) when it is not positive definite to working precision.
fn cholesky6(a: &[[f64; 6]; 6]) -> Result<[[f64; 6]; 6]> {
    let mut l = [[0.0; 6]; 6];
    let scale = (0..6).fold(0.0f64, |m, i| m.max(a[i][i].abs()));
    for j in 0..6 {
        let mut d = a[j][j];
        for k in 0..j {
            d -= l[j][k] * l[j][k];
        }
        if !d.is_finite() || d <= 1e-13 * scale {
            return Err(Error::RankDeficient {
                rank: j,
                required: 6,
            });
        }
        let d = crate::math::sqrt(d);
        l[j][j] = d;
        for i in j + 1..6 {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = s / d;
        }
    }
    Ok(l)
}

/// Solves `L·x = b` in place (forward substitution).
fn forward6(l: &[[f64; 6]; 6], b: &mut [f64; 6]) {
    for i in 0..6 {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * b[k];
        }
        b[i] = s / l[i][i];
    }
}

/// Solves `Lᵀ·x = b` in place (back substitution).
fn backward6(l: &[[f64; 6]; 6], b: &mut [f64; 6]) {
    for i in (0..6).rev() {
        let mut s = b[i];
        for k in i + 1..6 {
            s -= l[k][i] * b[k];
        }
        b[i] = s / l[i][i];
    }
}

fn v3(t: &Transform) -> [f64; 3] {
    let v = t.translation.vector;
    [v.x, v.y, v.z]
}

/// The starting frame: weighted Kabsch/Horn on the rows measuring a full position (three
/// or more, not all on a line), else the first full pose, else the identity.
fn start_frame<const N: usize>(robot: &Robot<N>, rows: &[Measurement<N>]) -> Result<Transform> {
    let (mut w, mut ca, mut cb) = (0.0, Vector3::zeros(), Vector3::zeros());
    let mut used = 0usize;
    for m in rows
        .iter()
        .filter(|m| m.weight > 0.0 && m.mask.has_position())
    {
        let a = m.model_pose(robot)?.translation.vector;
        w += m.weight;
        ca += a * m.weight;
        cb += m.pose.translation.vector * m.weight;
        used += 1;
    }
    if used >= 3 {
        ca /= w;
        cb /= w;
        let mut s = Matrix3::zeros();
        for m in rows
            .iter()
            .filter(|m| m.weight > 0.0 && m.mask.has_position())
        {
            let a = m.model_pose(robot)?.translation.vector - ca;
            let b = m.pose.translation.vector - cb;
            s += a * b.transpose() * m.weight;
        }
        if let Ok(r) = crate::registration::rotation_from_correlation(&s) {
            return Ok(transform(r, cb - r * ca));
        }
    }
    let full = rows
        .iter()
        .find(|m| m.weight > 0.0 && m.mask.has_position() && m.mask.has_orientation());
    match full {
        Some(m) => Ok(m.pose * m.model_pose(robot)?.inverse()),
        None => Ok(Transform::identity()),
    }
}

/// The frame `T_s` (robot base → the session's measuring frame) that best fits the active
/// `rows` of one session at `robot` (weighted least squares over their measured components,
/// as the fit weighs them). Errors: [`Error::RankDeficient`] when the rows do not fix a
/// frame (fewer than three non-collinear positions and no orientation), kinematics errors.
pub fn fit_session_frame<const N: usize>(
    robot: &Robot<N>,
    rows: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
) -> Result<Transform> {
    let mut frame = start_frame(robot, rows)?;
    for _ in 0..SESSION_FRAME_STEPS {
        let mut n = [[0.0; 6]; 6];
        let mut g = [0.0; 6];
        for m in rows.iter().filter(|m| m.weight > 0.0) {
            let t = frame * m.model_pose(robot)?;
            let e = pose_error(&m.pose, &t, opts.orientation);
            let p = v3(&t);
            for k in (0..6).filter(|&k| m.mask.has(k)) {
                let w = m.weight * weight(opts, k);
                let b = b_row(k, &p);
                for i in 0..6 {
                    g[i] += w * b[i] * e[k];
                    for j in 0..6 {
                        n[i][j] += w * b[i] * b[j];
                    }
                }
            }
        }
        let l = cholesky6(&n)?;
        forward6(&l, &mut g);
        backward6(&l, &mut g);
        frame = apply_motion(&frame, &g);
        let size = g.iter().map(|x| x.abs()).sum::<f64>();
        if !size.is_finite() {
            return Err(Error::NotConverged {
                iterations: SESSION_FRAME_STEPS,
            });
        }
        if size < SESSION_FRAME_TOL * (1.0 + frame.translation.vector.norm()) {
            break;
        }
    }
    Ok(frame)
}

/// `Exp(δ)·T` to first order as a rigid motion: `Trans(δp)·Rot(exp δφ)·T`.
fn apply_motion(t: &Transform, d: &[f64; 6]) -> Transform {
    let r = rotation_exp(&Vector3::new(d[3], d[4], d[5]));
    let rot = r * t.rotation.matrix();
    let tr = r * t.translation.vector + Vector3::new(d[0], d[1], d[2]);
    transform(rot, tr)
}

/// The model's pose of `m` in the frame and its scaled Jacobian rows of the selected
/// columns rotated into the frame (`rows`), the error `e` and the row weights `w`.
#[allow(clippy::too_many_arguments)]
fn frame_rows<const N: usize, const P: usize>(
    robot: &Robot<N>,
    m: &Measurement<N>,
    frame: &Transform,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
    rows: &mut [[f64; P]; 6],
) -> Result<([f64; 3], [f64; 6], [f64; 6])> {
    let Workspace {
        jac,
        cols,
        colscale,
        ..
    } = ws;
    let cols = cols.get(..n_cols).ok_or(Error::CapacityExceeded {
        needed: n_cols,
        capacity: P,
    })?;
    let n_jac = jacobian_len::<N>(cols);
    let jac = jac.get_mut(..n_jac).ok_or(Error::CapacityExceeded {
        needed: n_jac,
        capacity: super::MAX_MODEL_PARAMS,
    })?;
    let t = *frame * m.model_jacobian(robot, jac)?;
    let r = frame.rotation.matrix();
    let e = pose_error(&m.pose, &t, opts.orientation);
    let mut w = [0.0; 6];
    for (k, wk) in w.iter_mut().enumerate() {
        if m.mask.has(k) {
            *wk = m.weight * weight(opts, k);
        }
    }
    for (j, (&col, &scale)) in cols.iter().zip(colscale.iter()).enumerate() {
        let jc = jac.get(col).copied().unwrap_or([0.0; 6]);
        let dp = r * Vector3::new(jc[0], jc[1], jc[2]);
        let dr = r * Vector3::new(jc[3], jc[4], jc[5]);
        let rotated = [dp.x, dp.y, dp.z, dr.x, dr.y, dr.z];
        for (k, row) in rows.iter_mut().enumerate() {
            if let Some(x) = row.get_mut(j) {
                *x = if w[k] > 0.0 || m.mask.has(k) {
                    rotated[k] * scale
                } else {
                    0.0
                };
            }
        }
    }
    Ok((v3(&t), e, w))
}

/// `N`, `C` and `g` of one session (see the module doc), summed over its rows.
struct Blocks<const P: usize> {
    n: [[f64; 6]; 6],
    c: [[f64; P]; 6],
    g: [f64; 6],
}

impl<const P: usize> Blocks<P> {
    fn add(
        &mut self,
        p: &[f64; 3],
        rows: &[[f64; P]; 6],
        e: &[f64; 6],
        w: &[f64; 6],
        n_cols: usize,
    ) {
        for k in (0..6).filter(|&k| w[k] > 0.0) {
            let b = b_row(k, p);
            for i in 0..6 {
                let wb = w[k] * b[i];
                if wb == 0.0 {
                    continue;
                }
                self.g[i] += wb * e[k];
                for j in 0..6 {
                    self.n[i][j] += wb * b[j];
                }
                for (c, r) in self.c[i].iter_mut().zip(rows[k].iter()).take(n_cols) {
                    *c += wb * r;
                }
            }
        }
    }
}

/// Folds the rows of one session with its frame eliminated (Schur complement, see the
/// module doc) into `ws.gram` or `ws.lsq`; `with_rhs = false` folds zero right-hand sides.
/// Returns the weighted cost at the fitted frame.
pub(crate) fn fold_session<const N: usize, const P: usize>(
    robot: &Robot<N>,
    rows: &[Measurement<N>],
    with_rhs: bool,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    if !rows.iter().any(|m| m.weight > 0.0) {
        return Ok(0.0);
    }
    let frame = fit_session_frame(robot, rows, opts)?;
    let mut blocks = Blocks {
        n: [[0.0; 6]; 6],
        c: [[0.0; P]; 6],
        g: [0.0; 6],
    };
    let mut buf = [[0.0; P]; 6];
    let mut cost = 0.0;
    let to_gram = ws.to_gram;
    for m in rows.iter().filter(|m| m.weight > 0.0) {
        let (p, mut e, w) = frame_rows(robot, m, &frame, opts, n_cols, ws, &mut buf)?;
        cost += (0..6).map(|k| w[k] * e[k] * e[k]).sum::<f64>();
        if !with_rhs {
            e = [0.0; 6];
        }
        blocks.add(&p, &buf, &e, &w, n_cols);
        if to_gram {
            ws.gram.add_rows6(&buf, &e, &w)?;
        }
    }
    let l = cholesky6(&blocks.n)?;
    if to_gram {
        // Remove CᵀN⁻¹C and CᵀN⁻¹g as the six rows L⁻¹C with right-hand sides L⁻¹g.
        let mut h = blocks.g;
        forward6(&l, &mut h);
        let mut m = [[0.0; P]; 6];
        for j in 0..n_cols {
            let mut col = [0.0; 6];
            for (i, x) in col.iter_mut().enumerate() {
                *x = blocks.c[i].get(j).copied().unwrap_or(0.0);
            }
            forward6(&l, &mut col);
            for (i, x) in col.iter().enumerate() {
                if let Some(v) = m[i].get_mut(j) {
                    *v = *x;
                }
            }
        }
        for (row, &b) in m.iter().zip(h.iter()) {
            ws.gram
                .downdate_with_rhs(row.get(..n_cols).unwrap_or(&[]), b, 1.0)?;
        }
        return Ok(cost);
    }
    // Givens path: K = N⁻¹C, d = N⁻¹g, then the reduced rows in a second pass.
    let mut d = blocks.g;
    forward6(&l, &mut d);
    backward6(&l, &mut d);
    let mut k = [[0.0; P]; 6];
    for j in 0..n_cols {
        let mut col = [0.0; 6];
        for (i, x) in col.iter_mut().enumerate() {
            *x = blocks.c[i].get(j).copied().unwrap_or(0.0);
        }
        forward6(&l, &mut col);
        backward6(&l, &mut col);
        for (i, x) in col.iter().enumerate() {
            if let Some(v) = k[i].get_mut(j) {
                *v = *x;
            }
        }
    }
    for m in rows.iter().filter(|m| m.weight > 0.0) {
        let (p, mut e, w) = frame_rows(robot, m, &frame, opts, n_cols, ws, &mut buf)?;
        for kk in 0..6 {
            let b = b_row(kk, &p);
            for (i, &bi) in b.iter().enumerate() {
                if bi == 0.0 {
                    continue;
                }
                for (x, y) in buf[kk].iter_mut().zip(k[i].iter()).take(n_cols) {
                    *x -= bi * y;
                }
                e[kk] -= bi * d[i];
            }
        }
        if !with_rhs {
            e = [0.0; 6];
        }
        ws.lsq.add_rows6(&buf, &e, &w)?;
    }
    Ok(cost)
}

/// Cost and residual statistics of one session's active rows at their fitted frame (the
/// frame fitted as the calibration eliminates it).
pub(crate) fn session_stats<const N: usize>(
    robot: &Robot<N>,
    rows: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    acc: &mut StatsAcc,
) -> Result<()> {
    if !rows.iter().any(|m| m.weight > 0.0) {
        return Ok(());
    }
    let frame = fit_session_frame(robot, rows, opts)?;
    for m in rows.iter().filter(|m| m.weight > 0.0) {
        acc.add(m, &(frame * m.model_pose(robot)?), opts);
    }
    Ok(())
}

impl<'a, const N: usize> ConstraintData<'a, N> {
    /// The rows of instrument session `s`.
    #[must_use]
    pub fn session_rows(&self, s: usize) -> &'a [Measurement<N>] {
        self.sessions
            .get(s)
            .and_then(|x| self.instrument.get(x.start..x.start.saturating_add(x.len)))
            .unwrap_or(&[])
    }

    /// Whether instrument row `l` lies in a session of its own frame.
    #[must_use]
    pub fn in_session(&self, l: usize) -> bool {
        let k = self.sessions.partition_point(|s| s.start + s.len <= l);
        self.sessions.get(k).is_some_and(|s| s.start <= l)
    }

    /// The fitted frame of instrument session `s` at `robot` (robot base → the session's
    /// measuring frame), as the calibration eliminates it. Errors: as
    /// [`fit_session_frame`].
    pub fn session_frame(
        &self,
        robot: &Robot<N>,
        s: usize,
        opts: &IdentifyOptions<'_>,
    ) -> Result<Transform> {
        fit_session_frame(robot, self.session_rows(s), opts)
    }

    /// Residual statistics of the instrument rows, each session's in its fitted frame.
    pub(crate) fn instrument_stats(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
    ) -> Result<ResidualStats> {
        let mut acc = StatsAcc::default();
        self.base_rows_stats(robot, opts, &mut acc)?;
        for s in 0..self.sessions.len() {
            session_stats(robot, self.session_rows(s), opts, &mut acc)?;
        }
        Ok(acc.finish())
    }

    fn base_rows_stats(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        acc: &mut StatsAcc,
    ) -> Result<()> {
        let excluded = opts.excluded;
        for (l, m) in self.instrument.iter().enumerate() {
            let skip = m.weight <= 0.0
                || self.in_session(l)
                || u32::try_from(l).is_ok_and(|l| excluded.binary_search(&l).is_ok());
            if !skip {
                acc.add(m, &m.model_pose(robot)?, opts);
            }
        }
        Ok(())
    }

    /// Checks the sessions' layout: in row order, disjoint, inside the instrument rows.
    pub(crate) fn validate_sessions(&self) -> Result<()> {
        let mut next = 0usize;
        for s in self.sessions {
            let end = s.start.checked_add(s.len).ok_or(Error::DimensionMismatch {
                expected: self.instrument.len(),
                found: usize::MAX,
            })?;
            if s.start < next || s.len == 0 || end > self.instrument.len() {
                return Err(Error::DimensionMismatch {
                    expected: self.instrument.len(),
                    found: end,
                });
            }
            next = end;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! The eliminated normal equations against an explicit, un-eliminated problem: the
    //! Jacobian of the model over `[θ; ξ_1; ξ_2]` (robot parameters and both sessions'
    //! frame motions) by finite differences of the composed transforms, its full normal
    //! equations, then the Schur complement taken densely — on the Gram path and the
    //! Givens path.
    use super::*;
    use crate::ParamIndex;
    use crate::aria;
    use crate::identify::constraints::ConstraintData;
    use crate::identify::data::RowSource;
    use crate::identify::{Algorithm, ComponentMask};
    use crate::params::ParamSet;
    use crate::pose::{pose_from_vector6, rotation_log};
    extern crate std;
    use std::boxed::Box;
    use std::vec::Vec;

    type Ws = Workspace<48>;

    fn ws() -> Box<Ws> {
        // SAFETY: all-zero is a valid Workspace (documented).
        unsafe { Box::<Ws>::new_zeroed().assume_init() }
    }

    fn q(k: usize) -> [f64; 6] {
        let mut q = aria::TOOL_SEED_Q;
        for (j, v) in q.iter_mut().enumerate() {
            *v += 0.5 * libm::sin(1.3 * k as f64 + 2.1 * j as f64);
        }
        q
    }

    fn params() -> ParamSet {
        let mut s = ParamSet::new();
        for i in 0..Robot::<6>::NUM_GEOMETRIC_PARAMS {
            s.insert(i).unwrap();
        }
        s
    }

    const FRAMES: [[f64; 6]; 2] = [
        [0.8, -1.2, 0.3, 0.2, -0.4, 1.1],
        [-2.0, 0.4, 0.1, -0.6, 0.3, -2.2],
    ];

    /// Four base-frame rows (partial coordinates), a session of full poses and a session of
    /// positions of two points, measured by a perturbed arm in two frames and offset by
    /// millimetres, so no residual vanishes.
    fn rows() -> Vec<Measurement<6>> {
        let truth = {
            let mut r = aria::nominal();
            for i in 0..30 {
                let v = r.param(ParamIndex(i)).unwrap();
                r.set_param(ParamIndex(i), v + 1e-3 * libm::sin(i as f64))
                    .unwrap();
            }
            r
        };
        let mut out = Vec::new();
        for k in 0..22 {
            let mut m = Measurement::new(q(k), Transform::identity());
            let (frame, mask, point) = match k {
                0..4 => (
                    Transform::identity(),
                    ComponentMask(0b011 + (k as u8 % 2) * 4),
                    None,
                ),
                4..12 => (pose_from_vector6(&FRAMES[0]), ComponentMask::ALL, None),
                _ => (
                    pose_from_vector6(&FRAMES[1]),
                    ComponentMask::POSITION,
                    Some(if k % 2 == 0 {
                        [0.05, 0.0, 0.02]
                    } else {
                        [0.0, -0.04, 0.0]
                    }),
                ),
            };
            m.point = point;
            m.mask = mask;
            let off = 2e-3 * libm::cos(k as f64);
            let t = frame * m.model_pose(&truth).unwrap();
            m.pose = pose_from_vector6(&[off, -off, 0.5 * off, off, 0.0, -off]) * t;
            out.push(m);
        }
        out
    }

    const SESSIONS: [InstrumentSession; 2] = [
        InstrumentSession { start: 4, len: 8 },
        InstrumentSession { start: 12, len: 10 },
    ];

    fn fold_all(robot: &Robot<6>, d: &ConstraintData<'_, 6>, gram: bool, ws: &mut Ws) -> f64 {
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let n = params().len();
        for (k, i) in params().iter().enumerate() {
            ws.cols[k] = i;
            ws.colscale[k] = 1.0;
        }
        if gram {
            ws.gram.reset(n).unwrap();
        } else {
            ws.lsq.reset(n).unwrap();
        }
        ws.to_gram = gram;
        let c = d.fold(robot, true, &opts, n, ws).unwrap();
        ws.to_gram = false;
        c
    }

    /// The model's 6-vector `[p; φ]` of every row, at robot `r` and frame motions `xi`
    /// (`Exp(ξ_s)·T̂_s` for session `s`, `T̂_s` the fitted frame at the nominal robot).
    fn model(
        r: &Robot<6>,
        rows: &[Measurement<6>],
        fitted: &[Transform; 2],
        xi: &[[f64; 6]; 2],
    ) -> Vec<Transform> {
        rows.iter()
            .enumerate()
            .map(|(l, m)| {
                let t = m.model_pose(r).unwrap();
                match l {
                    0..4 => t,
                    4..12 => pose_from_vector6(&xi[0]) * fitted[0] * t,
                    _ => pose_from_vector6(&xi[1]) * fitted[1] * t,
                }
            })
            .collect()
    }

    #[test]
    fn schur_step_matches_the_explicit_problem_with_the_frames_in_the_parameters() {
        let robot = aria::nominal();
        let rows = rows();
        let d = ConstraintData {
            instrument: &rows,
            contacts: &[],
            groups: &[],
            distances: &[],
            sessions: &SESSIONS,
        };
        d.validate().unwrap();
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let fitted = [
            d.session_frame(&robot, 0, &opts).unwrap(),
            d.session_frame(&robot, 1, &opts).unwrap(),
        ];
        let mut ws = ws();
        let cost = fold_all(&robot, &d, true, &mut ws);
        assert!(cost > 1e-5, "residuals must not vanish: {cost}");
        assert!((cost - d.cost(&robot, &opts).unwrap()).abs() <= 1e-12 * cost);
        let (gram, atb) = (*ws.gram.gram(), *ws.gram.atb());
        fold_all(&robot, &d, false, &mut ws);
        let (r, qtb) = (*ws.lsq.r(), *ws.lsq.qtb());
        let n = params().len();
        let nx = n + 12;
        // FD Jacobian of the model over [θ; ξ_1; ξ_2].
        let xi0 = [[0.0; 6]; 2];
        let base = model(&robot, &rows, &fitted, &xi0);
        let mut jac = std::vec![[[0.0; 6]; 22]; nx];
        let h = 1e-6;
        for (x, col) in jac.iter_mut().enumerate() {
            let at = |s: f64| {
                let mut r = robot;
                let mut xi = xi0;
                if x < n {
                    let i = params().iter().nth(x).unwrap();
                    let v = r.param(ParamIndex(i)).unwrap();
                    r.set_param(ParamIndex(i), v + s).unwrap();
                } else {
                    xi[(x - n) / 6][(x - n) % 6] = s;
                }
                model(&r, &rows, &fitted, &xi)
            };
            let (p, m) = (at(h), at(-h));
            for (l, c) in col.iter_mut().enumerate() {
                let dp = (p[l].translation.vector - m[l].translation.vector) / (2.0 * h);
                let dr =
                    rotation_log(&(p[l].rotation.matrix() * m[l].rotation.matrix().transpose()))
                        / (2.0 * h);
                *c = [dp.x, dp.y, dp.z, dr.x, dr.y, dr.z];
            }
        }
        // Full normal equations A x = b (unit weights on measured components).
        let mut a = std::vec![std::vec![0.0; nx]; nx];
        let mut b = std::vec![0.0; nx];
        for (l, m) in rows.iter().enumerate() {
            let e = pose_error(&m.pose, &base[l], opts.orientation);
            for k in (0..6).filter(|&k| m.mask.has(k)) {
                let w = weight(&opts, k);
                for i in 0..nx {
                    b[i] += w * jac[i][l][k] * e[k];
                    for j in 0..nx {
                        a[i][j] += w * jac[i][l][k] * jac[j][l][k];
                    }
                }
            }
        }
        // Schur complement of the 12×12 frame block (dense, Gauss–Jordan on [A_ξξ | A_ξθ b_ξ]).
        let mut aug: Vec<Vec<f64>> = (0..12)
            .map(|i| {
                let mut row: Vec<f64> = (0..12).map(|j| a[n + i][n + j]).collect();
                row.extend((0..n).map(|j| a[n + i][j]));
                row.push(b[n + i]);
                row
            })
            .collect();
        for c in 0..12 {
            let piv = aug[c][c];
            for v in aug[c].iter_mut() {
                *v /= piv;
            }
            for i in 0..12 {
                if i != c {
                    let f = aug[i][c];
                    let rc = aug[c].clone();
                    for (v, y) in aug[i].iter_mut().zip(rc) {
                        *v -= f * y;
                    }
                }
            }
        }
        for i in 0..n {
            let rb = b[i] - (0..12).map(|s| a[i][n + s] * aug[s][12 + n]).sum::<f64>();
            let scale_b = b[i].abs().max(1e-3);
            assert!(
                (atb[i] - rb).abs() <= 1e-5 * scale_b,
                "rhs {i}: {} vs explicit {rb}",
                atb[i]
            );
            let givens_b: f64 = (0..=i).map(|k| r[k][i] * qtb[k]).sum();
            assert!(
                (givens_b - rb).abs() <= 1e-5 * scale_b,
                "Givens rhs {i}: {givens_b} vs {rb}"
            );
            for j in i..n {
                let rs = a[i][j] - (0..12).map(|s| a[i][n + s] * aug[s][12 + j]).sum::<f64>();
                let scale = (a[i][i].abs() * a[j][j].abs()).sqrt().max(1e-3);
                assert!(
                    (gram[i][j] - rs).abs() <= 1e-5 * scale,
                    "G[{i}][{j}] {} vs explicit {rs}",
                    gram[i][j]
                );
                let givens: f64 = (0..=i).map(|k| r[k][i] * r[k][j]).sum();
                assert!(
                    (givens - rs).abs() <= 1e-5 * scale,
                    "Givens G[{i}][{j}] {givens} vs {rs}"
                );
            }
        }
    }

    #[test]
    fn the_frame_fit_recovers_a_frame_exactly_and_refuses_a_line() {
        let robot = aria::nominal();
        let want = pose_from_vector6(&FRAMES[1]);
        let mut rows: Vec<Measurement<6>> = (0..6)
            .map(|k| {
                let mut m = Measurement::new(q(k), Transform::identity());
                m.mask = ComponentMask::POSITION;
                m.pose = want * m.model_pose(&robot).unwrap();
                m
            })
            .collect();
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let got = fit_session_frame(&robot, &rows, &opts).unwrap();
        let d = got.inverse() * want;
        let (dt, dr) = (
            d.translation.vector.norm(),
            rotation_log(d.rotation.matrix()).norm(),
        );
        assert!(dt < 1e-12 && dr < 1e-12, "{dt} m {dr} rad");
        // Two positions (a line) do not fix a frame.
        for m in rows.iter_mut().skip(2) {
            m.weight = 0.0;
        }
        assert!(matches!(
            fit_session_frame(&robot, &rows, &opts),
            Err(Error::RankDeficient { required: 6, .. })
        ));
    }
}
