//! Linearised k-fold cross-validation of every model at once.
//!
//! All models are fitted around one point, the geometric calibration on all data `lin`:
//! with `e_l` the residual and `J_l` the identification Jacobian of pose `l` there, a
//! model with parameter columns `S` fitted on the training poses `T` is one Gauss–Newton
//! step `δ = argmin Σ_{l∈T} |W^½(e_l − J_l[S]·δ)|²`, and its held-out residual on pose
//! `l` is `e_l − J_l[S]·δ`. The neglected terms are second order in the step (about
//! `|δ|²·reach`, micrometres for effects of realistic size; the test suite checks the
//! held-out RMS against fold-by-fold nonlinear fits).
//!
//! The normal equations of every training set come from two whitened Gram matrices over
//! the union `U` of all models' columns: `G_all` (all poses) minus `G_fold` (the fold's
//! poses). Each model's system is its sub-block, solved by a greedy Cholesky factor on
//! unit-scaled columns in priority order (the test of [`crate::identify::analyze`]:
//! a column whose part outside the span of the earlier kept columns is shorter than the
//! rank tolerance is dropped). Cost: three Jacobians per pose, two Gram updates per pose,
//! and one small factorisation per model and fold.

use super::{DiagWorkspace, MAX_MODELS, ModelAcc, PoseDiagnosis};
use crate::error::{Error, Result};
use crate::identify::Measurement;
use crate::math::sqrt;
use crate::model::Robot;
use crate::pose::{OrientationError, pose_error};

/// The model a pass over the rows is linearised at, with the caches bound to it once for
/// the pass (a key comparison per pose would cost a tenth of the pose's Jacobian).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lin<'r, const N: usize> {
    robot: &'r Robot<N>,
    /// [`TorqueCache::generation`] right after binding it to `robot`.
    ///
    /// [`TorqueCache::generation`]: crate::identify::torques::TorqueCache::generation
    torques: u64,
    /// The row cache's generation right after binding it to `robot` and the union `U`.
    rows: u64,
}

impl<'r, const N: usize> Lin<'r, N> {
    /// `robot`, with the gravity-torque cache and the row cache of `ws` bound to it (the
    /// row cache also to the current union `U`: narrow or restore it before binding).
    pub(crate) fn bind<const P: usize>(robot: &'r Robot<N>, ws: &mut DiagWorkspace<P>) -> Self {
        ws.id.torques.bind(robot);
        let n_u = ws.n_u.min(P);
        ws.rows.bind(robot, &ws.u[..n_u]);
        Lin {
            robot,
            torques: ws.id.torques.generation(),
            rows: ws.rows.generation(),
        }
    }
}

/// Whitened rows of pose `m` (row `l` of the data) at `lin` into `ws.a`/`ws.b`
/// (`a[k][c] = √w_k·J_k[U_c]`, `b[k] = √w_k·e_k`; rows of unmeasured components are zero);
/// returns the raw residual. The row's Jacobian columns and residual come from the row
/// cache (`ws.rows`, `rows.rs`) when kept there, and are kept there when computed; its
/// gravity torques from the fits' cache (`ws.id.torques`, exact key) likewise.
pub(crate) fn pose_rows<const N: usize, const P: usize>(
    at: &Lin<'_, N>,
    l: usize,
    m: &Measurement<N>,
    sw: &[f64; 6],
    ws: &mut DiagWorkspace<P>,
) -> Result<[f64; 6]> {
    let w: [f64; 6] = core::array::from_fn(|k| if m.mask.has(k) { sw[k] } else { 0.0 });
    // The form check's alternative columns need the whole Jacobian in `ws.jac`.
    let cached =
        ws.alternative == super::form::Alternative::None && ws.rows.generation() == at.rows;
    if cached {
        let DiagWorkspace { rows, a, b, .. } = &mut *ws;
        if let Some((e, cols)) = rows.get(l) {
            whiten(&w, &e, cols.chunks_exact(6), a, b);
            return Ok(e);
        }
    }
    let n_jac = Robot::<N>::NUM_PARAMS;
    let jac = super::jacobian_slots::<N>(&mut ws.jac)?;
    let lin = at.robot;
    let torques = &mut ws.id.torques;
    if torques.generation() != at.torques {
        // Rebound since the pass began (not within a diagnosis's passes): bind again.
        torques.bind(lin);
    }
    let t = torques.through(l, &m.state.q, |tau| {
        m.model_jacobian_torques(lin, jac, true, tau)
    })?;
    let e = pose_error(&m.pose, &t, OrientationError::Exact);
    if cached {
        ws.rows.put(l, &e, ws.jac.get(..n_jac).unwrap_or(&[]));
    }
    let DiagWorkspace {
        u, n_u, jac, a, b, ..
    } = &mut *ws;
    let cols = u[..(*n_u).min(P)]
        .iter()
        .map(|&uc| jac.get(uc).map_or(&ZERO_COLUMN[..], |j| &j[..]));
    whiten(&w, &e, cols, a, b);
    if ws.alternative != super::form::Alternative::None {
        super::form::alternative_columns(m, sw, ws);
    }
    Ok(e)
}

/// `ws.b = w·e` and `ws.a[k][c] = w_k·J_k[U_c]` from the union's Jacobian columns `cols`
/// (six numbers each, in the union's order): the same products whether the columns come
/// from the Jacobian just evaluated or from the row cache. Column by column: one column
/// (six contiguous values) read once.
fn whiten<'c, const P: usize>(
    w: &[f64; 6],
    e: &[f64; 6],
    cols: impl Iterator<Item = &'c [f64]>,
    a: &mut [[f64; P]; 6],
    b: &mut [f64; 6],
) {
    for k in 0..6 {
        b[k] = w[k] * e[k];
    }
    for (c, jc) in cols.enumerate().take(P) {
        for (ak, (wk, jk)) in a.iter_mut().zip(w.iter().zip(jc)) {
            ak[c] = wk * jk;
        }
    }
}

/// The column of a parameter outside the Jacobian (none: `U` holds model parameters).
const ZERO_COLUMN: [f64; 6] = [0.0; 6];

/// The union `U` as it was before [`narrow_to_model`]: restore it with [`restore_union`].
#[derive(Debug)]
pub(crate) struct SavedUnion<const P: usize> {
    u: [usize; P],
    n_u: usize,
    model: usize,
    cols: [u8; P],
}

/// Narrows the union `U` (`ws.u`, `ws.n_u`) to the columns of model `model`, in `U`'s
/// order, and renumbers the model's column positions (`ws.model_cols[model]`, its
/// priority order kept): every Gram entry a pass then folds is the same product of the
/// same two columns in the same orientation, summed in the same order, as in `U`, so the
/// model's fits are bit for bit those on `U`, for `p²` instead of `|U|²` work per row
/// (the verdict's model has about half the columns of the 28 candidates' union). The
/// model's old positions, ascending, go to `sorted[..p]` (for
/// [`GramAccumulator::select`] on a Gram folded over `U`); other models' positions are
/// meaningless until [`restore_union`].
///
/// [`GramAccumulator::select`]: crate::linalg::gram::GramAccumulator::select
pub(crate) fn narrow_to_model<const P: usize>(
    ws: &mut DiagWorkspace<P>,
    model: usize,
    sorted: &mut [usize; P],
) -> SavedUnion<P> {
    let cols = ws.model_cols.get(model).copied().unwrap_or([0; P]);
    let saved = SavedUnion {
        u: ws.u,
        n_u: ws.n_u,
        model,
        cols,
    };
    let p = ws.model_n.get(model).copied().unwrap_or(0).min(P);
    for (s, &c) in sorted.iter_mut().zip(&cols).take(p) {
        *s = usize::from(c);
    }
    if let Some(head) = sorted.get_mut(..p) {
        head.sort_unstable();
    }
    for (u, &c) in ws.u.iter_mut().zip(sorted.iter()).take(p) {
        *u = saved.u.get(c).copied().unwrap_or(0);
    }
    ws.n_u = p;
    if let (Some(mc), Some(head)) = (ws.model_cols.get_mut(model), sorted.get(..p)) {
        for (col, &old) in mc.iter_mut().zip(&cols).take(p) {
            *col = head.partition_point(|&c| c < usize::from(old)) as u8;
        }
    }
    saved
}

/// Undoes [`narrow_to_model`] (the union and the model's positions; a Gram folded or
/// selected meanwhile stays narrow).
pub(crate) fn restore_union<const P: usize>(ws: &mut DiagWorkspace<P>, saved: &SavedUnion<P>) {
    ws.u = saved.u;
    ws.n_u = saved.n_u;
    if let Some(mc) = ws.model_cols.get_mut(saved.model) {
        *mc = saved.cols;
    }
}

/// Folds the rows in `ws.a`/`ws.b` into `ws.g_all` (`fold = false`) or `ws.g_fold`: the
/// pose's six rows in one pass, with the sums of six single-row updates in their order
/// ([`GramAccumulator::add_rows6_in_order`]: bit-identical, a third of the memory traffic).
///
/// [`GramAccumulator::add_rows6_in_order`]: crate::linalg::gram::GramAccumulator::add_rows6_in_order
pub(crate) fn fold_rows<const P: usize>(ws: &mut DiagWorkspace<P>, fold: bool) -> Result<()> {
    let DiagWorkspace {
        a,
        b,
        g_all,
        g_fold,
        ..
    } = ws;
    let g = if fold { g_fold } else { g_all };
    g.add_rows6_in_order(a, b)
}

/// Entry (i, j) of the whitened Gram over positions of `U`, all data minus the fold
/// (when `fold`).
#[inline]
fn gram<const P: usize>(ws: &DiagWorkspace<P>, i: usize, j: usize, fold: bool) -> f64 {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    let v = ws.g_all.gram()[i][j];
    if fold { v - ws.g_fold.gram()[i][j] } else { v }
}

#[inline]
fn rhs<const P: usize>(ws: &DiagWorkspace<P>, i: usize, fold: bool) -> f64 {
    let v = ws.g_all.atb()[i];
    if fold { v - ws.g_fold.atb()[i] } else { v }
}

/// What the greedy factorisation found for one column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ColumnFate {
    /// Kept in the factor.
    pub kept: bool,
    /// Length of the unit-scaled column's part outside the span of the kept columns before
    /// it (1 = orthogonal to them, 0 = inside their span).
    pub distinct: f64,
    /// For a dropped column: the kept column (model position) it is most aligned with, and
    /// |cos| of the angle.
    pub partner: Option<(usize, f64)>,
}

/// Greedy Cholesky of the unit-scaled normal matrix of model `model` (its columns
/// `ws.model_cols[model][..]`), all data (`fold = false`) or the training set of the
/// current fold. Factor in `ws.chol` (lower, kept order), scales in `ws.scale`, kept
/// positions in `ws.kept[..n]`; `fate`, when given, receives each column's fate. Returns
/// the number of kept columns.
pub(crate) fn factor<const P: usize>(
    ws: &mut DiagWorkspace<P>,
    model: usize,
    fold: bool,
    tol: f64,
    fate: Option<&mut [ColumnFate]>,
) -> usize {
    factor_from(ws, model, fold, tol, fate, Resume::START)
}

/// Where [`factor_from`] starts: after the first `cols` columns of the model, `kept` of
/// them kept (their factor already in `ws.chol`, `ws.scale`, `ws.kept`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Resume {
    cols: usize,
    kept: usize,
}

impl Resume {
    /// From the first column.
    pub(crate) const START: Resume = Resume { cols: 0, kept: 0 };

    /// Resuming model `next` from the factor model `prev` left (`n_prev` kept columns, the
    /// same Gram): the greedy factor of a column depends only on the columns before it, so
    /// over the leading columns both models share (the same positions of `U` in the same
    /// order) it is the same, bit for bit, and only the rest needs factoring.
    pub(crate) fn shared<const P: usize>(
        ws: &DiagWorkspace<P>,
        prev: usize,
        n_prev: usize,
        next: usize,
    ) -> Resume {
        let (Some(a), Some(b)) = (ws.model_cols.get(prev), ws.model_cols.get(next)) else {
            return Resume::START;
        };
        let na = ws.model_n.get(prev).copied().unwrap_or(0).min(P);
        let nb = ws.model_n.get(next).copied().unwrap_or(0).min(P);
        Resume::between(&a[..na], &ws.kept[..n_prev.min(P)], &b[..nb])
    }

    /// Resuming a model of columns `next` from the factor of one of columns `prev` whose
    /// kept positions are `kept` (as [`Resume::shared`], for a caller that kept `prev`'s
    /// list itself).
    pub(crate) fn between(prev: &[u8], kept: &[usize], next: &[u8]) -> Resume {
        let cols = prev.iter().zip(next).take_while(|(x, y)| x == y).count();
        let kept = kept.partition_point(|&j| j < cols);
        Resume { cols, kept }
    }
}

/// [`factor`] from `start` (columns before it already factored, see [`Resume`]); `fate`
/// receives the fates of the columns from `start.cols` on (those before are the earlier
/// model's, which the caller keeps).
pub(crate) fn factor_from<const P: usize>(
    ws: &mut DiagWorkspace<P>,
    model: usize,
    fold: bool,
    tol: f64,
    mut fate: Option<&mut [ColumnFate]>,
    start: Resume,
) -> usize {
    let n_cols = ws.model_n[model];
    let mut n = start.kept;
    for j in start.cols..n_cols {
        let cj = ws.model_cols[model][j] as usize;
        let djj = gram(ws, cj, cj, fold);
        let mut f = ColumnFate {
            kept: false,
            distinct: 0.0,
            partner: None,
        };
        if djj > 0.0 && djj.is_finite() {
            let dj = sqrt(djj);
            // y = L⁻¹·(unit-scaled cross products with the kept columns).
            let mut y2 = 0.0;
            for r in 0..n {
                let cr = ws.model_cols[model][ws.kept[r]] as usize;
                let mut v = gram(ws, cr, cj, fold) / (ws.scale[r] * dj);
                for c in 0..r {
                    v -= ws.chol[r][c] * ws.tmp[c];
                }
                let v = v / ws.chol[r][r];
                ws.tmp[r] = v;
                y2 += v * v;
            }
            let piv2 = 1.0 - y2;
            f.distinct = sqrt(piv2.max(0.0));
            if piv2 > tol * tol && n < P {
                for c in 0..n {
                    ws.chol[n][c] = ws.tmp[c];
                }
                ws.chol[n][n] = sqrt(piv2);
                ws.scale[n] = dj;
                ws.kept[n] = j;
                n += 1;
                f.kept = true;
            } else {
                let mut best: Option<(usize, f64)> = None;
                for r in 0..n {
                    let cr = ws.model_cols[model][ws.kept[r]] as usize;
                    let c = (gram(ws, cr, cj, fold) / (ws.scale[r] * dj)).abs();
                    if best.is_none_or(|b| c > b.1) {
                        best = Some((ws.kept[r], c));
                    }
                }
                f.partner = best;
            }
        }
        if let Some(slot) = fate.as_deref_mut().and_then(|fs| fs.get_mut(j)) {
            *slot = f;
        }
    }
    n
}

/// Solves the factored system for the current fold; writes the step of model `model` into
/// `ws.delta[model]` (model column order, zero for dropped columns).
pub(crate) fn solve<const P: usize>(ws: &mut DiagWorkspace<P>, model: usize, n: usize, fold: bool) {
    for j in 0..ws.model_n[model] {
        ws.delta[model][j] = 0.0;
    }
    for r in 0..n {
        let cr = ws.model_cols[model][ws.kept[r]] as usize;
        let mut v = rhs(ws, cr, fold) / ws.scale[r];
        for c in 0..r {
            v -= ws.chol[r][c] * ws.tmp[c];
        }
        ws.tmp[r] = v / ws.chol[r][r];
    }
    for r in (0..n).rev() {
        let mut v = ws.tmp[r];
        for c in (r + 1)..n {
            v -= ws.chol[c][r] * ws.tmp[c];
        }
        ws.tmp[r] = v / ws.chol[r][r];
    }
    for r in 0..n {
        ws.delta[model][ws.kept[r]] = ws.tmp[r] / ws.scale[r];
    }
}

/// Leverage of the current pose's rows under the factor in `ws.chol` (model `model`, `n`
/// kept columns): `Σ_k |L⁻¹·D⁻¹·a_k[S]|²`, split into position and rotation rows.
fn leverage<const P: usize>(ws: &mut DiagWorkspace<P>, model: usize, n: usize) -> (f64, f64) {
    let (mut hp, mut hr) = (0.0, 0.0);
    for k in 0..6 {
        let mut h = 0.0;
        for r in 0..n {
            let cr = ws.model_cols[model][ws.kept[r]] as usize;
            let mut v = ws.a[k][cr] / ws.scale[r];
            for c in 0..r {
                v -= ws.chol[r][c] * ws.tmp[c];
            }
            let v = v / ws.chol[r][r];
            ws.tmp[r] = v;
            h += v * v;
        }
        if k < 3 {
            hp += h;
        } else {
            hr += h;
        }
    }
    (hp, hr)
}

/// Which pass of [`cross_validate`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Pass {
    /// Every model in `models`; model 0 (the geometric baseline) gives the leverage and the
    /// per-pose `heldout_baseline`.
    Candidates,
    /// One model (the verdict's): leverage and per-pose `heldout_final`.
    Final(usize),
}

/// Runs the k-fold cross-validation of `models` and of the pass's leverage model (indices
/// into the workspace's model list) with the Gram `ws.g_all` already accumulated at `lin`. Per-pose whitened held-out
/// squared errors go to `poses[l].sq[model]`, totals to `ws.acc[model]`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cross_validate<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    folds: usize,
    models: &[usize],
    pass: Pass,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<()> {
    let at = Lin::bind(lin, ws);
    let lev_model = match pass {
        Pass::Candidates => 0,
        Pass::Final(m) => m,
    };
    let order = || {
        models
            .iter()
            .copied()
            .filter(move |&m| m != lev_model)
            .chain(core::iter::once(lev_model))
    };
    for m in order() {
        if m >= MAX_MODELS {
            return Err(Error::CapacityExceeded {
                needed: m + 1,
                capacity: MAX_MODELS,
            });
        }
        ws.acc[m] = ModelAcc::default();
    }
    let mut factor_order = [0usize; MAX_MODELS];
    let n_order = sharing_order(ws, order(), lev_model, &mut factor_order);
    for f in 0..folds {
        ws.g_fold.reset(ws.n_u)?;
        for (l, m) in data.iter().enumerate() {
            if usize::from(poses[l].fold) == f && !poses[l].suspect {
                pose_rows(&at, l, m, sw, ws)?;
                fold_rows(ws, true)?;
            }
        }
        // The leverage model last, so its factor stays in `ws.chol`; each model resumes the
        // factor of the one before over their shared leading columns.
        let mut n_lev = 0;
        let mut prev: Option<(usize, usize)> = None;
        for &model in &factor_order[..n_order] {
            let start = match prev {
                Some((pm, pn)) => Resume::shared(ws, pm, pn, model),
                None => Resume::START,
            };
            let n = factor_from(ws, model, true, tol, None, start);
            solve(ws, model, n, true);
            n_lev = n;
            prev = Some((model, n));
        }
        for (l, m) in data.iter().enumerate() {
            if usize::from(poses[l].fold) != f || poses[l].suspect {
                continue;
            }
            pose_rows(&at, l, m, sw, ws)?;
            let (n_pos, n_rot) = measured(m);
            for model in order() {
                let r = record(ws, model, m, sw, &mut poses[l]);
                if model == lev_model {
                    match pass {
                        Pass::Candidates => poses[l].heldout_baseline = r,
                        Pass::Final(_) => poses[l].heldout_final = r,
                    }
                }
            }
            let (hp, hr) = leverage(ws, lev_model, n_lev);
            let acc = &mut ws.acc[lev_model];
            acc.expected_pos += n_pos as f64 + hp;
            acc.expected_rot += n_rot as f64 + hr;
            acc.var_pos += 2.0 * (n_pos as f64 + 2.0 * hp);
            acc.var_rot += 2.0 * (n_rot as f64 + 2.0 * hr);
            acc.variance += 2.0 * ((n_pos + n_rot) as f64 + 2.0 * (hp + hr));
        }
    }
    Ok(())
}

/// The models of `models` (each once, `lev` among them) into `out`, in an order in which
/// neighbours' factors share many leading columns: sorted by their column lists (a pair
/// follows the single effect it extends; every candidate starts with the geometric
/// columns), and `lev` last (its factor must stay in `ws.chol`; it shares the geometric
/// columns with the model before it). Returns the number written. The order changes no
/// result: each model's step depends on its own columns only.
fn sharing_order<const P: usize>(
    ws: &DiagWorkspace<P>,
    models: impl Iterator<Item = usize>,
    lev: usize,
    out: &mut [usize; MAX_MODELS],
) -> usize {
    let cols = |m: usize| {
        let n = ws.model_n.get(m).copied().unwrap_or(0).min(P);
        ws.model_cols.get(m).map_or(&[][..], |c| &c[..n])
    };
    let mut n = 0;
    for m in models.filter(|&m| m != lev) {
        // Insertion (at most MAX_MODELS models, once per cross-validation): every entry
        // after `m`'s place moves up one, carried along by swaps.
        let Some((last, sorted)) = out.get_mut(..=n).and_then(|h| h.split_last_mut()) else {
            break;
        };
        let mut carry = m;
        for slot in sorted.iter_mut() {
            if cols(*slot) > cols(carry) {
                core::mem::swap(slot, &mut carry);
            }
        }
        *last = carry;
        n += 1;
    }
    if let Some(slot) = out.get_mut(n) {
        *slot = lev;
        n += 1;
    }
    n
}

/// Numbers of measured position and rotation components of `m`.
fn measured<const N: usize>(m: &Measurement<N>) -> (usize, usize) {
    (
        (0..3).filter(|&k| m.mask.has(k)).count(),
        (3..6).filter(|&k| m.mask.has(k)).count(),
    )
}

/// The residual of the pose in `ws.a`/`ws.b` under model `model`'s step `ws.delta[model]`:
/// its whitened squared error (total and rotation part) into `pose` and `ws.acc[model]`;
/// returns the raw residual (zero in unmeasured components).
fn record<const N: usize, const P: usize>(
    ws: &mut DiagWorkspace<P>,
    model: usize,
    m: &Measurement<N>,
    sw: &[f64; 6],
    pose: &mut PoseDiagnosis,
) -> [f64; 6] {
    let (n_pos, n_rot) = measured(m);
    let mut r = [0.0; 6];
    let (mut s, mut s_rot) = (0.0, 0.0);
    // Column by column, the six rows together: each row's subtractions keep their order
    // (the columns in model order, zero steps skipped), so every sum is the row-by-row one.
    let mut vs = ws.b;
    let n_cols = ws.model_n[model].min(P);
    for (&d, &c) in ws.delta[model][..n_cols]
        .iter()
        .zip(ws.model_cols[model][..n_cols].iter())
    {
        if d != 0.0 {
            let c = c as usize;
            for (v, ak) in vs.iter_mut().zip(ws.a.iter()) {
                *v -= ak[c] * d;
            }
        }
    }
    for k in 0..6 {
        let v = vs[k];
        r[k] = if sw[k] > 0.0 && m.mask.has(k) {
            v / sw[k]
        } else {
            0.0
        };
        s += v * v;
        if k >= 3 {
            s_rot += v * v;
        }
    }
    pose.sq[model] = s;
    pose.sq_rot[model] = s_rot;
    let acc = &mut ws.acc[model];
    acc.chi2 += s;
    acc.chi2_rot += s_rot;
    if n_pos == 3 {
        acc.pos2 += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        acc.n_pos += 1;
    }
    if n_rot == 3 {
        acc.rot2 += r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
        acc.n_rot += 1;
    }
    acc.rows += n_pos + n_rot;
    acc.rows_pos += n_pos;
    r
}

/// In-sample counterpart of [`cross_validate`] for data too small to hold poses out (the
/// nested test of the module documentation): every model in `models` and the pass's model
/// fitted (one linearised step at `lin`) on all clean rows, with `ws.g_all` accumulated
/// there; per-pose in-sample whitened squared errors into `poses[l].sq`, totals into
/// `ws.acc`. The expected totals under "the model is exact" are the χ² degrees of freedom
/// `rows − p`, shared between position and rotation rows in proportion to their numbers.
#[allow(clippy::too_many_arguments)]
pub(crate) fn in_sample<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    models: &[usize],
    pass: Pass,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<()> {
    let at = Lin::bind(lin, ws);
    let lev_model = match pass {
        Pass::Candidates => 0,
        Pass::Final(m) => m,
    };
    let order = || {
        models
            .iter()
            .copied()
            .filter(move |&m| m != lev_model)
            .chain(core::iter::once(lev_model))
    };
    let mut kept = [0usize; MAX_MODELS];
    for m in order() {
        if m >= MAX_MODELS {
            return Err(Error::CapacityExceeded {
                needed: m + 1,
                capacity: MAX_MODELS,
            });
        }
        ws.acc[m] = ModelAcc::default();
        let n = factor(ws, m, false, tol, None);
        solve(ws, m, n, false);
        kept[m] = n;
    }
    for (l, m) in data.iter().enumerate() {
        if poses[l].suspect {
            continue;
        }
        pose_rows(&at, l, m, sw, ws)?;
        for model in order() {
            let r = record(ws, model, m, sw, &mut poses[l]);
            if model == lev_model {
                match pass {
                    Pass::Candidates => poses[l].heldout_baseline = r,
                    Pass::Final(_) => poses[l].heldout_final = r,
                }
            }
        }
    }
    for m in order() {
        let acc = &mut ws.acc[m];
        let rows = acc.rows as f64;
        if rows > 0.0 {
            let dof = (rows - kept[m] as f64).max(1.0);
            acc.expected_pos = dof * acc.rows_pos as f64 / rows;
            acc.expected_rot = dof - acc.expected_pos;
            acc.var_pos = 2.0 * acc.expected_pos;
            acc.var_rot = 2.0 * acc.expected_rot;
            acc.variance = 2.0 * dof;
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    extern crate std;
    use super::*;
    use crate::rng::SplitMix64;
    use std::boxed::Box;

    const P: usize = 12;

    /// A Gram over 10 columns of random rows, column 7 = column 2 + column 3 (so the greedy
    /// factor drops it after both), and models with shared and unshared leading columns.
    fn workspace() -> Box<DiagWorkspace<P>> {
        let mut ws = Box::new(DiagWorkspace::<P>::new());
        let mut rng = SplitMix64::new(18);
        ws.g_all.reset(10).unwrap();
        for _ in 0..40 {
            let mut a = [0.0; 10];
            for v in &mut a {
                *v = rng.normal();
            }
            a[7] = a[2] + a[3];
            ws.g_all.add_row_weighted(&a, rng.normal(), 1.0).unwrap();
        }
        let models: [&[u8]; 4] = [
            &[0, 1, 2, 3, 4, 7, 5],
            &[0, 1, 2, 3, 4, 7, 8, 9],
            &[0, 1, 2, 6],
            &[1, 0, 2, 3],
        ];
        for (m, cols) in models.iter().enumerate() {
            ws.model_cols[m][..cols.len()].copy_from_slice(cols);
            ws.model_n[m] = cols.len();
        }
        ws
    }

    /// What a factor and its solve leave: kept count, factor, scales, kept positions, step.
    fn state(ws: &DiagWorkspace<P>, model: usize, n: usize) -> std::vec::Vec<u64> {
        let mut out = std::vec![n as u64];
        for r in 0..n {
            out.extend(ws.chol[r][..=r].iter().map(|v| v.to_bits()));
            out.push(ws.scale[r].to_bits());
            out.push(ws.kept[r] as u64);
        }
        out.extend(
            ws.delta[model][..ws.model_n[model]]
                .iter()
                .map(|v| v.to_bits()),
        );
        out
    }

    /// Column fates with their numbers as bits.
    #[allow(clippy::type_complexity)]
    fn fate_bits(f: &[ColumnFate]) -> std::vec::Vec<(bool, u64, Option<(usize, u64)>)> {
        f.iter()
            .map(|c| {
                let partner = c.partner.map(|(j, v)| (j, v.to_bits()));
                (c.kept, c.distinct.to_bits(), partner)
            })
            .collect()
    }

    #[test]
    fn a_factor_resumed_over_shared_columns_is_the_fresh_factor_bit_for_bit() {
        let tol = 1e-6;
        let mut ws = workspace();
        for prev in 0..4 {
            for next in 0..4 {
                let blank = ColumnFate {
                    kept: false,
                    distinct: f64::NAN,
                    partner: None,
                };
                let mut fresh_fate = [blank; P];
                let n = factor(&mut ws, next, false, tol, Some(&mut fresh_fate));
                solve(&mut ws, next, n, false);
                let fresh = state(&ws, next, n);
                // The earlier model's fates stand for the shared columns (as in step 5b).
                let mut fate = [blank; P];
                let n_prev = factor(&mut ws, prev, false, tol, Some(&mut fate));
                solve(&mut ws, prev, n_prev, false);
                let start = Resume::shared(&ws, prev, n_prev, next);
                let n = factor_from(&mut ws, next, false, tol, Some(&mut fate), start);
                solve(&mut ws, next, n, false);
                assert_eq!(
                    state(&ws, next, n),
                    fresh,
                    "{prev} -> {next} from {start:?}"
                );
                let n_cols = ws.model_n[next];
                assert_eq!(
                    fate_bits(&fate[..n_cols]),
                    fate_bits(&fresh_fate[..n_cols]),
                    "{prev} -> {next}"
                );
            }
        }
        // The dependent column is dropped, and the resumed factors did skip work.
        let n = factor(&mut ws, 0, false, tol, None);
        assert_eq!(n, 6);
        assert_eq!(Resume::shared(&ws, 0, n, 1), Resume { cols: 6, kept: 5 });
        assert_eq!(Resume::shared(&ws, 0, n, 3), Resume::START);
    }
}
