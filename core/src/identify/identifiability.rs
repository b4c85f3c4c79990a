//! Which requested parameters the data can determine.
//!
//! Two questions, answered with the same greedy test on unit-scaled Jacobian columns taken
//! in a fixed priority order (links before base and tool frames before effects, each in
//! flat-index order): a column is kept when the part of it outside the span of the columns
//! already kept is at least a tolerance long.
//! 1. *Structural*: on many generic configurations (seeded uniform joint angles within the
//!    limits, independent approach signs taking both values for every joint, random
//!    temperatures; the data's measured components), which parameters are redundant in the
//!    model itself (e.g. base-frame parameters that duplicate link 1, compliance of a joint
//!    that carries no gravity torque). These are removed and reported.
//! 2. *Data*: of the structurally identifiable parameters, which the given poses determine.
//!    The rest are data-deficient: reported, and an error unless the caller allows fitting
//!    the identifiable subset.
//!
//! Because the test runs in priority order, a redundant group keeps its highest-priority
//! member; the dropped ones name the kept parameter their column is most aligned with.

use super::data::{ComponentMask, Measurement, RowSource, add_rows};
use super::{IdentifyOptions, MAX_MODEL_PARAMS, Workspace};
use crate::error::{Error, ParamIndex, Result};
use crate::linalg::bidiag::singular_values;
use crate::linalg::dot;
use crate::math::sqrt;
use crate::model::{JointState, Robot};
use crate::params::ParamSet;
use crate::rng::SplitMix64;

/// Tolerance of the structural test (generic configurations): redundant columns leave
/// residuals at rounding level (~1e-14), identifiable ones far above this.
pub const STRUCTURAL_TOL: f64 = 1e-9;

/// A column shorter than this times the longest requested column counts as zero: e.g. the
/// compliance column of a joint whose gravity torque vanishes except for rounding.
pub const ZERO_COLUMN_REL: f64 = 1e-10;

/// A parameter that was not kept and the kept parameter its column aligns with most.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Partner {
    /// The kept parameter.
    pub param: ParamIndex,
    /// |cos| of the angle between the two Jacobian columns.
    pub cosine: f64,
}

/// The outcome of the identifiability analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Identifiability {
    /// What was asked for.
    pub requested: ParamSet,
    /// What the data determine (and will be fitted).
    pub identifiable: ParamSet,
    /// Redundant in the model for the measured components, whatever the poses.
    pub structural: ParamSet,
    /// Identifiable in general but not from these poses: at the initial model, or (in an
    /// [`super::Identification`]) at the fitted one, which then reports the rank and
    /// condition number of the parameters fitted, at the fitted model.
    pub data_deficient: ParamSet,
    /// Not observable because the data have no external reference (instrument-free
    /// constraint data, [`super::constraints`]): the base-frame parameters when no row
    /// refers to the base frame (no instrument row, known target or known plane), and one
    /// length (the longest nominal one) when nothing fixes the scale (no known distance,
    /// instrument row, known target or known plane). Held at their initial values, never
    /// fitted; not an error.
    pub gauge: ParamSet,
    /// Number of identifiable parameters.
    pub rank: usize,
    /// σ_max/σ_min of the unit-column-scaled Jacobian of the identifiable parameters.
    pub condition_number: f64,
    /// For each parameter not kept (flat index), its most aligned kept parameter.
    pub partner: [Option<Partner>; MAX_MODEL_PARAMS],
}

/// Seed of the generic configurations of the structural test (fixed: the test's outcome
/// must not depend on the call).
const STRUCTURAL_SEED: u64 = 0x7374_7275_6374;

/// Number of generic configurations for `p` requested parameters: rows (6 per sample)
/// outnumber the parameters about twice over, and at least 16 samples so that every
/// joint's approach direction takes both signs several times.
pub(crate) fn structural_samples(p: usize) -> usize {
    (8 + p / 3).max(16)
}

/// Approach directions of generic sample `s`: independent uniform signs per joint for
/// even `s`, their negation for the following odd `s` (antithetic pairs). Every joint
/// thus takes both signs in any two consecutive samples, and signs of different joints
/// stay independent — unlike a Halton digit test `halton(s, base) < 0.5`, which for a
/// large base is −1 for the first `base/2` samples (backlash of the last joint then looked
/// redundant with its zero offset).
pub(crate) fn approach_signs<const N: usize>(s: usize, rng: &mut SplitMix64, signs: &mut [f64; N]) {
    if s.is_multiple_of(2) {
        let mut bits = rng.next_u64();
        for v in signs.iter_mut() {
            *v = if bits & 1 == 0 { -1.0 } else { 1.0 };
            bits = bits.rotate_right(1);
        }
    } else {
        for v in signs.iter_mut() {
            *v = -*v;
        }
    }
}

/// Runs the analysis for `opts.requested` on `data` at `robot`'s current parameters. The
/// singular values of the identifiable set are left in the workspace. Data without a pose
/// of positive weight is [`Error::TooFewData`] (0 rows found, one per requested parameter
/// needed at least).
pub fn analyze<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<Identifiability> {
    let mut out = Identifiability::empty(opts.requested);
    analyze_into(robot, data, opts, ws, &mut out)?;
    Ok(out)
}

impl Identifiability {
    /// Nothing identified yet of `requested`.
    pub(crate) const fn empty(requested: ParamSet) -> Self {
        Identifiability {
            requested,
            identifiable: ParamSet::new(),
            structural: ParamSet::new(),
            data_deficient: ParamSet::new(),
            gauge: ParamSet::new(),
            rank: 0,
            condition_number: f64::INFINITY,
            partner: [None; MAX_MODEL_PARAMS],
        }
    }
}

impl Identifiability {
    /// [`Identifiability::empty`] in place (no temporary of this size on the stack).
    pub(crate) fn reset(&mut self, requested: ParamSet) {
        self.requested = requested;
        self.identifiable = ParamSet::new();
        self.structural = ParamSet::new();
        self.data_deficient = ParamSet::new();
        self.gauge = ParamSet::new();
        self.rank = 0;
        self.condition_number = f64::INFINITY;
        for p in self.partner.iter_mut() {
            *p = None;
        }
    }
}

/// [`analyze`] into the caller's `out` (so that callers keep one copy on the stack).
pub(crate) fn analyze_into<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identifiability,
) -> Result<()> {
    super::data::validate(data)?;
    let requested = opts.requested;
    let p = requested.len();
    if p == 0 {
        return Err(Error::TooFewData {
            found: 0,
            needed: 1,
        });
    }
    if p > P {
        return Err(Error::CapacityExceeded {
            needed: p,
            capacity: P,
        });
    }
    if let Some(bad) = requested.iter().find(|&i| i >= Robot::<N>::NUM_PARAMS) {
        return Err(Error::DimensionMismatch {
            expected: Robot::<N>::NUM_PARAMS,
            found: bad + 1,
        });
    }
    let mut union = 0u8;
    let (mut any_approach, mut any_temp) = (false, false);
    for m in super::data::active_rows(data, opts) {
        union |= m.mask.0;
        any_approach |= m.state.approach.is_some();
        any_temp |= m.state.temp_c.is_some();
    }
    if union == 0 {
        // No pose in the fit: nothing can be said, not even which parameters are
        // structurally redundant (that depends on the measured components).
        return Err(Error::TooFewData {
            found: 0,
            needed: p,
        });
    }
    let mask = ComponentMask(union);
    let (points, n_points) = super::data::distinct_points(data);
    out.reset(requested);

    // 1. Structural: generic configurations.
    let n_struct = structural_step(
        robot,
        mask,
        &points[..n_points],
        any_approach,
        any_temp,
        opts,
        ws,
        &mut out.structural,
        &mut out.partner,
    )?;

    // 2. Data: the structurally identifiable columns on the given poses.
    for k in 0..n_struct {
        ws.cols[k] = ws.free[k];
        ws.colscale[k] = 1.0;
    }
    if ws.share_first_pass {
        // `identify`: the fit's first iteration and initial residuals from the same pass.
        super::data::fold_first_pass(robot, data, opts, n_struct, ws)?;
    } else {
        super::data::accumulate_jacobian(robot, data, opts, n_struct, ws)?;
    }
    data_step_folded(robot, data, opts, ws, out, n_struct)
}

/// Steps 2 and 3 of [`analyze`] on the candidate columns `ws.cols[..n_struct]`: which the
/// data determine (the rest are data-deficient) and the conditioning of those.
pub(super) fn data_step<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identifiability,
    n_struct: usize,
) -> Result<()> {
    for k in 0..n_struct {
        ws.colscale[k] = 1.0;
    }
    super::data::accumulate_jacobian(robot, data, opts, n_struct, ws)?;
    data_step_folded(robot, data, opts, ws, out, n_struct)
}

/// [`data_step`] once the Jacobian of the candidate columns (unit scale) is folded into
/// `ws.lsq`. When `ws.gram` holds the first pass's normal equations of the same columns
/// ([`super::data::fold_first_pass`]), they are narrowed to the identifiable ones, as if
/// folded with those alone (each entry is its own sum: bit for bit the same).
fn data_step_folded<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identifiability,
    n_struct: usize,
) -> Result<()> {
    let kept = greedy(ws, n_struct, opts.rank_tol, &mut out.partner)?;
    let mut n_id = 0;
    for k in 0..n_struct {
        let col = ws.cols[k];
        if kept.contains(k) {
            ws.free[n_id] = col;
            n_id += 1;
            out.identifiable.insert(col)?;
        } else {
            out.data_deficient.insert(col)?;
        }
    }
    out.rank = n_id;
    if ws.first_pass && n_id < n_struct {
        let mut positions = [0usize; P];
        for (slot, k) in positions.iter_mut().zip(kept.iter()) {
            *slot = k;
        }
        ws.gram.select(positions.get(..n_id).unwrap_or(&[]))?;
    }

    // 3. Conditioning of the identifiable set (unit-scaled columns). The factor of step 2
    // is that of the identifiable columns unless some were dropped.
    for k in 0..n_id {
        ws.cols[k] = ws.free[k];
    }
    conditioning(robot, data, opts, ws, out, n_id, n_id < n_struct)
}

/// Step 3 of [`analyze`]: the singular values (into `ws.sv`) and condition number of the
/// unit-scaled Jacobian of the columns `ws.cols[..n_id]` at `robot`, folded first when
/// `fold` (otherwise `ws.lsq` must hold their factor).
pub(super) fn conditioning<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identifiability,
    n_id: usize,
    fold: bool,
) -> Result<()> {
    for k in 0..n_id {
        ws.colscale[k] = 1.0;
    }
    if fold {
        super::data::accumulate_jacobian(robot, data, opts, n_id, ws)?;
    }
    copy_r_unit_scaled(ws, n_id);
    let Workspace { mat, sv, tmp, .. } = ws;
    singular_values(mat, n_id, sv, tmp)?;
    ws.n_sv = n_id;
    if n_id > 0 {
        let (smax, smin) = (ws.sv[0], ws.sv[n_id - 1]);
        out.condition_number = if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        };
    }
    Ok(())
}

/// Which of `opts.requested` are structurally redundant (step 1 of [`analyze`]): the
/// greedy test on generic configurations with the measured components `mask` of each of the
/// measured `points` (see [`Measurement::point`]; empty: the tool-frame origin) and, when
/// `any_approach`/`any_temp`, random approach directions and temperatures. Redundant
/// parameters go to `structural` with their partner; the kept ones are left in
/// `ws.free[..k]` (flat indices, priority order) and `k` is returned.
#[allow(clippy::too_many_arguments)]
pub(crate) fn structural_step<const N: usize, const P: usize>(
    robot: &Robot<N>,
    mask: ComponentMask,
    points: &[Option<[f64; 3]>],
    any_approach: bool,
    any_temp: bool,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    structural: &mut ParamSet,
    partner: &mut [Option<Partner>; MAX_MODEL_PARAMS],
) -> Result<usize> {
    let sel = StructuralSel {
        mask,
        points,
        any_approach,
        any_temp,
        base_first: false,
    };
    structural_step_with(robot, &sel, opts, ws, structural, partner)
}

/// What the structural test runs on (see [`structural_step`]).
pub(crate) struct StructuralSel<'p> {
    pub(crate) mask: ComponentMask,
    pub(crate) points: &'p [Option<[f64; 3]>],
    pub(crate) any_approach: bool,
    pub(crate) any_temp: bool,
    /// Test the six base-frame parameters first, requested or not (constraint data
    /// without an external reference: every rigid motion of the arm is then attributed to
    /// the base, whose parameters are the gauge, and link parameters that only duplicate
    /// a rigid motion are dropped with a base partner). Unrequested base parameters are
    /// neither kept nor reported.
    pub(crate) base_first: bool,
}

/// [`structural_step`] with the selection in one struct.
pub(crate) fn structural_step_with<const N: usize, const P: usize>(
    robot: &Robot<N>,
    sel: &StructuralSel<'_>,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    structural: &mut ParamSet,
    partner: &mut [Option<Partner>; MAX_MODEL_PARAMS],
) -> Result<usize> {
    let StructuralSel {
        mask,
        points,
        any_approach,
        any_temp,
        base_first,
    } = *sel;
    let requested = opts.requested;
    let base = 5 * N..5 * N + 6;
    let extra = if base_first {
        base.clone().filter(|&i| !requested.contains(i)).count()
    } else {
        0
    };
    let p = requested.len() + extra;
    if p > P {
        return Err(Error::CapacityExceeded {
            needed: p,
            capacity: P,
        });
    }
    if ws.memo.lookup(robot, sel, opts) {
        let Workspace { memo, free, .. } = ws;
        return memo.replay(&requested, free, structural, partner);
    }
    if base_first {
        let rest = requested.iter().filter(|i| !base.contains(i));
        load_cols(ws, base.clone().chain(rest));
    } else {
        load_cols(ws, requested.iter());
    }
    ws.lsq.reset(p)?;
    ws.to_gram = false;
    // Rows (6 per sample) outnumber the parameters about twice over: generic enough.
    let samples = structural_samples(p);
    let limits = robot.limits();
    let mut rng = SplitMix64::new(STRUCTURAL_SEED);
    let mut signs = [1.0; N];
    for s in 0..samples {
        let mut st = JointState::new([0.0; N]);
        for (j, q) in st.q.iter_mut().enumerate() {
            let lo = limits[j].lower.max(-core::f64::consts::PI);
            let hi = limits[j].upper.min(core::f64::consts::PI);
            *q = rng.range(lo, hi);
        }
        if any_approach {
            approach_signs(s, &mut rng, &mut signs);
            st.approach = Some(signs);
        }
        if any_temp {
            st.temp_c = Some(rng.range(0.0, 40.0));
        }
        let origin = [None];
        let points = if points.is_empty() {
            &origin[..]
        } else {
            points
        };
        for &point in points {
            let m = Measurement {
                state: st,
                pose: crate::pose::Transform::identity(),
                mask,
                weight: 1.0,
                point,
            };
            // Generic configurations, not rows of the data: no torque cache slot.
            add_rows(robot, usize::MAX, &m, false, opts, p, ws)?;
        }
    }
    let kept = greedy(ws, p, STRUCTURAL_TOL, partner)?;
    let mut n_struct = 0;
    for (k, &col) in ws.cols.iter().take(p).enumerate() {
        if kept.contains(k) {
            ws.free[n_struct] = col;
            n_struct += 1;
        } else {
            ws.memo
                .store_dropped(col, partner.get(col).copied().flatten());
            if requested.contains(col) {
                structural.insert(col)?;
            }
        }
    }
    let Workspace { memo, free, .. } = ws;
    memo.store_kept(free.get(..n_struct).unwrap_or(&[]));
    memo.commit();
    Ok(n_struct)
}

fn load_cols<const P: usize>(ws: &mut Workspace<P>, cols: impl Iterator<Item = usize>) {
    for (k, c) in cols.take(P).enumerate() {
        ws.cols[k] = c;
        ws.colscale[k] = 1.0;
    }
}

/// |R e_k|: the norm of Jacobian column k.
fn column_norm<const P: usize>(ws: &Workspace<P>, k: usize) -> f64 {
    let r = ws.lsq.r();
    sqrt((0..=k).map(|i| r[i][k] * r[i][k]).sum::<f64>())
}

/// Copies `R·D` into `ws.mat` (upper triangle, zero below), `D` scaling each column of the
/// Jacobian to unit length (`ws.colscale`): `J·D = Q·(R·D)`, so the column-scaled
/// Jacobian's factor needs no second pass over the data.
pub(super) fn copy_r_unit_scaled<const P: usize>(ws: &mut Workspace<P>, n: usize) {
    for k in 0..n {
        let norm = column_norm(ws, k);
        ws.colscale[k] = if norm > 0.0 { 1.0 / norm } else { 1.0 };
    }
    let r = ws.lsq.r();
    for i in 0..n {
        for j in 0..n {
            ws.mat[i][j] = if j >= i {
                r[i][j] * ws.colscale[j]
            } else {
                0.0
            };
        }
    }
}

/// Greedy selection over the columns of `ws.lsq`'s R (same inner products as the Jacobian's
/// columns) in order; returns the kept column positions. Dropped columns get a partner.
pub(super) fn greedy<const P: usize>(
    ws: &mut Workspace<P>,
    n: usize,
    tol: f64,
    partner: &mut [Option<Partner>; MAX_MODEL_PARAMS],
) -> Result<ParamSet> {
    let mut kept = ParamSet::new();
    let mut n_basis = 0;
    // While every column so far is kept, the basis is ±e_0 … ±e_{k−1} (R is triangular
    // with a non-zero diagonal there): Gram–Schmidt against it only zeroes the leading
    // entries, exactly. `prefix` counts these implicit basis vectors.
    let mut prefix = 0;
    let mut longest = 0.0f64;
    for k in 0..n {
        let norm = column_norm(ws, k);
        // A non-finite factor is an error, never a classification: NaN fails every
        // comparison, so its column would read as zero ("redundant") below.
        if !norm.is_finite() {
            return Err(Error::NonFinite {
                what: crate::error::Quantity::Parameter,
                index: ws.cols.get(k).copied().unwrap_or(k),
            });
        }
        longest = longest.max(norm);
    }
    for k in 0..n {
        let norm = column_norm(ws, k);
        let norm = if norm > ZERO_COLUMN_REL * longest {
            norm
        } else {
            0.0
        };
        let r = ws.lsq.r();
        for i in 0..n {
            ws.tmp[i] = if i <= k && norm > 0.0 {
                r[i][k] / norm
            } else {
                0.0
            };
        }
        if norm > 0.0 {
            // Two passes of modified Gram–Schmidt for a stable residual. Column k of the
            // triangular R, and every basis vector built from columns before it, vanish
            // below row k: only the leading k + 1 entries take part.
            let len = (k + 1).min(n);
            ws.tmp[..prefix.min(len)].fill(0.0);
            for _ in 0..2 {
                for b in prefix..n_basis {
                    let (q, t) = (&ws.mat[b][..len], &mut ws.tmp[..len]);
                    let d = dot(q, t);
                    for (ti, &qi) in t.iter_mut().zip(q.iter()) {
                        *ti -= d * qi;
                    }
                }
            }
        }
        let res = sqrt(dot(&ws.tmp[..n], &ws.tmp[..n]));
        if norm > 0.0 && res >= tol {
            for i in 0..n {
                ws.mat[n_basis][i] = ws.tmp[i] / res;
            }
            if prefix == k {
                // Columns 0..=k all kept: this basis vector is ±e_k.
                prefix += 1;
            }
            n_basis += 1;
            kept.insert(k)?;
        } else if let Some(slot) = partner.get_mut(ws.cols[k]) {
            *slot = best_partner(ws, k, norm, &kept);
        }
    }
    Ok(kept)
}

fn best_partner<const P: usize>(
    ws: &Workspace<P>,
    k: usize,
    norm_k: f64,
    kept: &ParamSet,
) -> Option<Partner> {
    if norm_k == 0.0 {
        return None;
    }
    let r = ws.lsq.r();
    let mut best: Option<Partner> = None;
    for j in kept.iter() {
        let norm_j = column_norm(ws, j);
        if norm_j == 0.0 {
            continue;
        }
        let dot: f64 = (0..=j.min(k)).map(|i| r[i][k] * r[i][j]).sum();
        let c = (dot / (norm_k * norm_j)).abs();
        if best.is_none_or(|b| c > b.cosine) {
            best = Some(Partner {
                param: ParamIndex(ws.cols[j]),
                cosine: c,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every joint's approach sign takes both values within the samples of even the
    /// smallest structural test, for up to 9 joints (regression: the Halton digit test
    /// gave joint 6 of a 6-joint arm the sign −1 in every sample).
    #[test]
    fn every_joint_approach_sign_takes_both_values() {
        fn check<const N: usize>() {
            let samples = structural_samples(1);
            let mut rng = SplitMix64::new(STRUCTURAL_SEED);
            let (mut neg, mut pos) = ([0usize; N], [0usize; N]);
            let mut signs = [1.0; N];
            for s in 0..samples {
                approach_signs(s, &mut rng, &mut signs);
                for j in 0..N {
                    if signs[j] < 0.0 {
                        neg[j] += 1;
                    } else {
                        pos[j] += 1;
                    }
                }
            }
            for j in 0..N {
                assert_eq!(neg[j], pos[j], "joint {} of {N}", j + 1);
                assert!(neg[j] >= samples / 2, "joint {} of {N}", j + 1);
            }
        }
        check::<6>();
        check::<7>();
        check::<9>();
    }
}
