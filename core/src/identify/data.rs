//! Measurements and the residual/Jacobian rows they contribute.

use super::{IdentifyOptions, Workspace};
use crate::error::{Error, Quantity, Result, check_finite};
use crate::kinematics::JacobianColumn;
use crate::model::{JointState, Robot};
use crate::pose::{OrientationError, Transform, pose_error};

/// Which of the six pose components `[x, y, z, φx, φy, φz]` a measurement carries (bit k =
/// component k). Position-only data (mocap points, laser-tracker reflectors) use
/// [`ComponentMask::POSITION`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ComponentMask(pub u8);

impl ComponentMask {
    /// Full pose.
    pub const ALL: ComponentMask = ComponentMask(0x3f);
    /// Position only.
    pub const POSITION: ComponentMask = ComponentMask(0x07);
    /// Whether component `k` (0..6) is measured.
    #[must_use]
    pub const fn has(self, k: usize) -> bool {
        k < 6 && self.0 & (1 << k) != 0
    }
    /// Whether all three position components are measured.
    #[must_use]
    pub const fn has_position(self) -> bool {
        self.0 & 0x07 == 0x07
    }
    /// Whether all three orientation components are measured.
    #[must_use]
    pub const fn has_orientation(self) -> bool {
        self.0 & 0x38 == 0x38
    }
}

/// One measured pose: joint state (readings and auxiliary data) and the measured
/// end-effector pose `T_e^b` in the base frame — or, with [`Measurement::point`], the pose of
/// a point on the end effector at a known position in the tool frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement<const N: usize> {
    /// Joint readings and auxiliary data.
    pub state: JointState<N>,
    /// Measured `T_e^b` (components outside `mask` are ignored).
    pub pose: Transform,
    /// Measured components.
    pub mask: ComponentMask,
    /// Weight of the pose in the fit (>= 0): 1 normally, 0 to hold it out (cross-validation),
    /// other values for robust reweighting. Multiplies the row weights.
    pub weight: f64,
    /// The measured point's position in the tool frame \[m\], known by design (one of several
    /// markers or reflectors on the end effector): the measurement is then of the frame
    /// `T_e^b(q)·Trans(point)` — the tool frame moved to that point, not rotated — so
    /// several points on one body share one tool frame (whose parameters, with position-only
    /// rows, are then identifiable in rotation too). `None`: the tool frame itself.
    pub point: Option<[f64; 3]>,
}

impl<const N: usize> Measurement<N> {
    /// A full-pose measurement at readings `q`.
    #[must_use]
    pub const fn new(q: [f64; N], pose: Transform) -> Self {
        Measurement {
            state: JointState::new(q),
            pose,
            mask: ComponentMask::ALL,
            weight: 1.0,
            point: None,
        }
    }

    /// What the model predicts for this measurement: `T_e^b` at its joint state, moved to
    /// [`Measurement::point`] when given.
    pub fn model_pose(&self, robot: &Robot<N>) -> Result<Transform> {
        Ok(self.at_point(robot.fk(&self.state)?))
    }

    /// [`Measurement::model_pose`] with the gravity torques at the readings in `tau` when
    /// known, left there when computed ([`Robot::fk_with_torques`]).
    pub(crate) fn model_pose_torques(
        &self,
        robot: &Robot<N>,
        tau: &mut Option<[f64; N]>,
    ) -> Result<Transform> {
        Ok(self.at_point(robot.fk_with_torques(&self.state, tau)?))
    }

    /// [`Measurement::model_pose`] and its identification Jacobian (as
    /// [`Robot::jacobian`]): with a point `r` (in the base frame `R_e·point`) each column's
    /// position rows gain `Δφ × r`, the rotation rows are unchanged.
    pub fn model_jacobian(
        &self,
        robot: &Robot<N>,
        jac: &mut [JacobianColumn],
    ) -> Result<Transform> {
        self.model_jacobian_with(robot, jac, true)
    }

    /// [`Measurement::model_jacobian`], the base and tool rotation columns left unwritten
    /// unless `frame_rotations` (see [`Robot::jacobian_with`]). A point at the tool origin
    /// would add `Δφ × 0 = ±0` to each position entry: skipped. That leaves every entry's
    /// value, and can only keep a −0 that adding +0 would have made +0; every sum the rows
    /// enter (Gram matrix, right-hand side, `J̄`) starts at +0, where a ±0 term adds
    /// nothing, so the fits are the same bit for bit (MUKCa's contacts, whose point is the
    /// tool origin: `core/tests/mukca_convergence.rs`).
    pub(crate) fn model_jacobian_with(
        &self,
        robot: &Robot<N>,
        jac: &mut [JacobianColumn],
        frame_rotations: bool,
    ) -> Result<Transform> {
        self.model_jacobian_torques(robot, jac, frame_rotations, &mut None)
    }

    /// [`Measurement::model_jacobian_with`] with the gravity torques at the readings in
    /// `tau` when known, left there when computed ([`Robot::jacobian_with_torques`]).
    pub(crate) fn model_jacobian_torques(
        &self,
        robot: &Robot<N>,
        jac: &mut [JacobianColumn],
        frame_rotations: bool,
        tau: &mut Option<[f64; N]>,
    ) -> Result<Transform> {
        let t = robot.jacobian_with_torques(&self.state, jac, frame_rotations, tau)?;
        if let Some(p) = self.point.filter(|p| *p != [0.0; 3]) {
            let r = t.rotation * nalgebra::Vector3::new(p[0], p[1], p[2]);
            for c in jac.iter_mut() {
                let w = nalgebra::Vector3::new(c[3], c[4], c[5]);
                let d = w.cross(&r);
                c[0] += d.x;
                c[1] += d.y;
                c[2] += d.z;
            }
        }
        Ok(self.at_point(t))
    }

    fn at_point(&self, t: Transform) -> Transform {
        match self.point {
            None => t,
            Some(p) => t * nalgebra::Translation3::new(p[0], p[1], p[2]),
        }
    }
}

/// Most distinct measured points ([`Measurement::point`]) the structural test of the
/// identifiability analysis places on the end effector: four points in general position
/// already make every rigid motion of the tool visible.
pub(crate) const MAX_STRUCTURAL_POINTS: usize = 4;

/// The distinct measured points of the poses with a positive weight (the tool-frame origin,
/// `None`, counts as one), at most [`MAX_STRUCTURAL_POINTS`], in order of appearance.
pub(crate) fn distinct_points<const N: usize>(
    data: &[Measurement<N>],
) -> ([Option<[f64; 3]>; MAX_STRUCTURAL_POINTS], usize) {
    let mut out = [None; MAX_STRUCTURAL_POINTS];
    let mut n = 0;
    for m in data.iter().filter(|m| m.weight > 0.0) {
        if n == MAX_STRUCTURAL_POINTS {
            break;
        }
        if !out[..n].contains(&m.point) {
            out[n] = m.point;
            n += 1;
        }
    }
    (out, n)
}

/// Checks every measurement: finite numbers, valid masks. Errors carry the pose index.
pub(crate) fn validate<const N: usize>(data: &[Measurement<N>]) -> Result<()> {
    for (l, m) in data.iter().enumerate() {
        m.state.validate().map_err(|e| match e {
            Error::NonFinite { what, .. } => Error::NonFinite { what, index: l },
            other => other,
        })?;
        if check_finite(m.pose.translation.vector.as_slice(), Quantity::Position).is_err() {
            return Err(Error::NonFinite {
                what: Quantity::Position,
                index: l,
            });
        }
        if m.point
            .is_some_and(|p| check_finite(&p, Quantity::Position).is_err())
        {
            return Err(Error::NonFinite {
                what: Quantity::Position,
                index: l,
            });
        }
        if check_finite(m.pose.rotation.matrix().as_slice(), Quantity::Orientation).is_err() {
            return Err(Error::NonFinite {
                what: Quantity::Orientation,
                index: l,
            });
        }
        if !(m.weight.is_finite() && m.weight >= 0.0) {
            return Err(Error::NonFinite {
                what: Quantity::Setting,
                index: l,
            });
        }
        if m.mask.0 == 0 || m.mask.0 & !0x3f != 0 {
            return Err(Error::BadPose {
                pose: crate::error::PoseIndex(l),
            });
        }
    }
    Ok(())
}

/// The rows that take part in a fit: positive weight, not excluded by `opts`.
pub(crate) fn active_rows<'d, const N: usize>(
    data: &'d [Measurement<N>],
    opts: &IdentifyOptions<'_>,
) -> impl Iterator<Item = &'d Measurement<N>> {
    data.iter()
        .enumerate()
        .filter_map(move |(l, m)| is_active(l, m, opts).then_some(m))
}

/// Whether row `l` takes part in a fit (see [`active_rows`]).
pub(crate) fn is_active<const N: usize>(
    l: usize,
    m: &Measurement<N>,
    opts: &IdentifyOptions<'_>,
) -> bool {
    m.weight > 0.0 && u32::try_from(l).map_or(true, |l| opts.excluded.binary_search(&l).is_err())
}

/// Row weight of component `k`.
pub(crate) fn weight(opts: &IdentifyOptions<'_>, k: usize) -> f64 {
    if k < 3 {
        opts.weight_pos
    } else {
        opts.weight_rot
    }
}

/// The weighted cost `Σ w·e²` of `robot` on `data`.
pub(crate) fn cost<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
) -> Result<f64> {
    cost_by(data, opts, |_, m| m.model_pose(robot))
}

/// [`cost`] with row `l`'s model pose from `pose(l, m)` (e.g. through the torque cache).
fn cost_by<const N: usize>(
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    mut pose: impl FnMut(usize, &Measurement<N>) -> Result<Transform>,
) -> Result<f64> {
    let mut c = 0.0;
    for (l, m) in data.iter().enumerate() {
        if !is_active(l, m, opts) {
            continue;
        }
        let e = pose_error(&m.pose, &pose(l, m)?, opts.orientation);
        for (k, v) in e.iter().enumerate() {
            if m.mask.has(k) {
                c += m.weight * weight(opts, k) * v * v;
            }
        }
    }
    Ok(c)
}

/// Folds every measured row `(J[:, cols]·colscale, e)` of `data` into `ws.lsq` (reset to
/// `n_cols` columns `ws.cols[..n_cols]`) and returns the weighted cost.
pub(crate) fn accumulate<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    ws.lsq.reset(n_cols)?;
    ws.to_gram = false;
    data.fold(robot, true, opts, n_cols, ws)
}

/// As [`accumulate`] with a zero right-hand side: only the triangular factor of the
/// Jacobian, which is all the identifiability analysis reads (it does not depend on the
/// right-hand side), without a pose error per measurement.
pub(crate) fn accumulate_jacobian<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<()> {
    ws.lsq.reset(n_cols)?;
    ws.to_gram = false;
    data.fold(robot, false, opts, n_cols, ws).map(|_| ())
}

/// [`accumulate_jacobian`] at a fit's starting model that also leaves in `ws.gram` the
/// unit-scaled normal equations (with the right-hand side) the fit's first iteration
/// folds, in `ws.first_cost` their cost and in `ws.pass_stats` the residual statistics of
/// that model: one Jacobian per pose for the identifiability analysis, the first iteration
/// and the initial residuals, instead of three passes. Each sum is the one the separate
/// passes compute, term for term and in the same order (the pose's transform is the one
/// [`Measurement::model_pose`] computes, by the same chain), so the results are the same
/// bit for bit (`core/tests/calibration_fingerprint.rs`). Only for instrument rows
/// (`[Measurement]`, whose `stats` is [`residual_stats`]); `ws.colscale[..n_cols]` must
/// be 1.
pub(crate) fn fold_first_pass<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<()> {
    ws.lsq.reset(n_cols)?;
    ws.gram.reset(n_cols)?;
    ws.pass_stats = StatsAcc::EMPTY;
    ws.to_gram = false;
    // Cleared by a pose whose rows the normal equations refuse (see `add_rows`).
    ws.first_pass = true;
    ws.fold_both = true;
    let folded = data.fold(robot, true, opts, n_cols, ws);
    ws.fold_both = false;
    match folded {
        Ok(c) => ws.first_cost = c,
        Err(e) => {
            ws.first_pass = false;
            return Err(e);
        }
    }
    Ok(())
}

/// The cost of the trial model `robot`, [`cost`]'s value bit for bit (the same terms summed
/// in the same order; the pose is [`Measurement::model_pose`]'s, by the same chain), and
/// its unit-scaled normal equations in `ws.gram` as [`accumulate_gram`] folds them, with
/// the residual statistics of `robot` in `ws.pass_stats`: for OLS's last trial, whose
/// normal equations the covariance then needs (one pass instead of three: the trial's cost,
/// the fitted residuals and the covariance's fold). `None` when the fold fails (the caller
/// then takes [`cost`], which reports what it reports); `ws.gram` is then stale.
pub(crate) fn fold_last_trial<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Option<f64> {
    ws.pass_stats = StatsAcc::EMPTY;
    ws.last_cost = 0.0;
    ws.last_pass = true;
    let folded = accumulate_gram(robot, data, opts, n_cols, ws);
    ws.last_pass = false;
    folded.ok().map(|_| ws.last_cost)
}

/// [`accumulate_gram`] at a solver's starting model, or what [`fold_first_pass`] left for
/// it (then taken: a second call folds).
pub(crate) fn first_gram<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    if ws.first_pass && ws.gram.n() == n_cols {
        ws.first_pass = false;
        return Ok(ws.first_cost);
    }
    accumulate_gram(robot, data, opts, n_cols, ws)
}

/// As [`accumulate`], into the normal equations `ws.gram` (the fast path of the iterations).
pub(crate) fn accumulate_gram<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    ws.gram.reset(n_cols)?;
    ws.first_pass = false;
    ws.to_gram = true;
    let folded = data.fold(robot, true, opts, n_cols, ws);
    // Also on an error: a later fold must not land in `ws.gram` by accident.
    ws.to_gram = false;
    folded
}

/// The cost of the trial model `robot` and, unless that cost exceeds `current` (a rejected
/// trial), its normal equations in `ws.gram`: the value [`accumulate_gram`] returns, bit for
/// bit, with the Jacobian pass skipped for rejected trials where the data have a
/// Jacobian-free cost pass ([`RowSource::fold_cost`]; contact data, where most trials of a
/// step-halving iteration are rejected: of the 290 Jacobian passes of OLS on MUKCa's Panda
/// recordings about 160 were for trials then rejected), and the cost pass of a rejected
/// trial stops once its running sum is certain to exceed `current` (the value returned is
/// then that running sum: above `current`, which is all a rejection is judged by). After a
/// rejected trial `ws.gram` is stale, as after any rejected trial.
pub(crate) fn accumulate_trial_gram<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    current: f64,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    if let Some(c) = data.fold_cost(robot, opts, n_cols, current, ws)? {
        // A non-finite cost takes the full pass, which reports the error as before.
        if c.is_finite() && c > current {
            return Ok(c);
        }
    }
    accumulate_gram(robot, data, opts, n_cols, ws)
}

/// The rows a fit folds: a slice of instrument [`Measurement`]s, or instrument-free
/// constraint data ([`super::constraints::ConstraintData`]). The solvers, the covariance
/// and the identifiability analysis see data only through this.
pub(crate) trait RowSource<const N: usize> {
    /// Finite numbers, valid masks and layout; errors carry the row index.
    fn validate(&self) -> Result<()>;
    /// Every row with a positive weight carries the inputs (approach directions,
    /// temperature) the requested effects need.
    fn check_inputs(&self, opts: &IdentifyOptions<'_>) -> Result<()>;
    /// Number of scalar residual rows that take part in a fit (positive weight, not
    /// excluded by `opts`).
    fn row_count(&self, opts: &IdentifyOptions<'_>) -> usize;
    /// Folds every row into `ws.lsq` or `ws.gram` (as `ws.to_gram` says, already reset to
    /// `n_cols` columns `ws.cols[..n_cols]` scaled by `ws.colscale`); `with_rhs = false`
    /// folds a zero right-hand side (analysis). Returns the weighted cost.
    fn fold<const P: usize>(
        &self,
        robot: &Robot<N>,
        with_rhs: bool,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        ws: &mut Workspace<P>,
    ) -> Result<f64>;
    /// The weighted cost `Σ w·e²`.
    fn cost(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64>;
    /// [`RowSource::cost`] bit for bit, with what `ws` keeps between passes (the rows'
    /// gravity torques) where the source uses it.
    fn cost_ws<const P: usize>(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        _ws: &mut Workspace<P>,
    ) -> Result<f64> {
        self.cost(robot, opts)
    }
    /// [`RowSource::stats`] bit for bit, with what `ws` keeps between passes (as
    /// [`RowSource::cost_ws`]).
    fn stats_ws<const P: usize>(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        _ws: &mut Workspace<P>,
    ) -> Result<ResidualStats> {
        self.stats(robot, opts)
    }
    /// The cost [`RowSource::fold`] into `ws.gram` returns, bit for bit, from forward
    /// kinematics alone (no Jacobian, nothing folded; `ws.gram` is left alone), or `None`
    /// where the source has no such pass. The solvers use it to reject a trial step
    /// without paying for its Jacobian ([`RowSource::cost`] is the same sum to rounding,
    /// not bit for bit). The pass may stop early once the cost is certain to exceed
    /// `stop_above` (a rejected trial); it then returns a partial sum, still above
    /// `stop_above` (`f64::INFINITY`: the whole sum).
    fn fold_cost<const P: usize>(
        &self,
        _robot: &Robot<N>,
        _opts: &IdentifyOptions<'_>,
        _n_cols: usize,
        _stop_above: f64,
        _ws: &mut Workspace<P>,
    ) -> Result<Option<f64>> {
        Ok(None)
    }
    /// Residual statistics.
    fn stats(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<ResidualStats>;
    /// The instrument rows themselves, when the source is just those (no prior rows, no
    /// frames): then [`fold_last_trial`] gives this source's cost and statistics.
    fn instrument_rows(&self) -> Option<&[Measurement<N>]> {
        None
    }
    /// The prior whose rows [`RowSource::fold`] adds after the data's, if any.
    fn prior(&self) -> Option<&super::Prior> {
        None
    }
    /// Whether OLS may take a damped step after many halvings of a rejected Gauss–Newton
    /// step (see `gauss_newton` in `solvers.rs`): only where that was checked to reach the
    /// same minima (contact data).
    fn damped_fallback(&self) -> bool {
        false
    }
}

impl<const N: usize> RowSource<N> for [Measurement<N>] {
    fn validate(&self) -> Result<()> {
        validate(self)
    }
    fn check_inputs(&self, opts: &IdentifyOptions<'_>) -> Result<()> {
        super::solvers::check_effect_inputs(self.iter().map(|m| &m.state), opts)
    }
    fn row_count(&self, opts: &IdentifyOptions<'_>) -> usize {
        active_rows(self, opts)
            .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
            .sum()
    }
    fn fold<const P: usize>(
        &self,
        robot: &Robot<N>,
        with_rhs: bool,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        ws: &mut Workspace<P>,
    ) -> Result<f64> {
        let mut c = 0.0;
        ws.torques.bind(robot);
        for (l, m) in self.iter().enumerate() {
            if is_active(l, m, opts) {
                c += add_rows(robot, l, m, with_rhs, opts, n_cols, ws)?;
            }
        }
        Ok(c)
    }
    fn cost(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64> {
        cost(robot, self, opts)
    }
    fn stats(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<ResidualStats> {
        residual_stats(robot, self, opts)
    }
    fn cost_ws<const P: usize>(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        ws: &mut Workspace<P>,
    ) -> Result<f64> {
        ws.torques.bind(robot);
        let torques = &mut ws.torques;
        cost_by(self, opts, |l, m| model_pose_cached(robot, l, m, torques))
    }
    fn stats_ws<const P: usize>(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        ws: &mut Workspace<P>,
    ) -> Result<ResidualStats> {
        ws.torques.bind(robot);
        let torques = &mut ws.torques;
        stats_by(self, opts, |l, m| model_pose_cached(robot, l, m, torques))
    }
    fn instrument_rows(&self) -> Option<&[Measurement<N>]> {
        Some(self)
    }
}

/// [`Measurement::model_pose`] of row `l`, its gravity torques taken from `torques` (bound
/// to `robot`'s key by the caller) when kept there, and kept there when computed.
fn model_pose_cached<const N: usize>(
    robot: &Robot<N>,
    l: usize,
    m: &Measurement<N>,
    torques: &mut super::torques::TorqueCache,
) -> Result<Transform> {
    torques.through(l, &m.state.q, |tau| m.model_pose_torques(robot, tau))
}

/// Folds the rows of one pose (weighted by its weight) into `ws.lsq` or `ws.gram`; with
/// `with_rhs = false` the right-hand side is zero (only the Jacobian matters, as in the
/// identifiability analysis). Returns the cost. `l` is the row's index in its data, for
/// the gravity torques kept in `ws.torques` (bound to `robot` by the caller's pass).
pub(crate) fn add_rows<const N: usize, const P: usize>(
    robot: &Robot<N>,
    l: usize,
    m: &Measurement<N>,
    with_rhs: bool,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    let cols = ws.cols.get(..n_cols).ok_or(Error::CapacityExceeded {
        needed: n_cols,
        capacity: P,
    })?;
    let n_jac = jacobian_len::<N>(cols);
    let jac = ws.jac.get_mut(..n_jac).ok_or(Error::CapacityExceeded {
        needed: n_jac,
        capacity: super::MAX_MODEL_PARAMS,
    })?;
    let t = ws.torques.through(l, &m.state.q, |tau| {
        m.model_jacobian_torques(robot, jac, true, tau)
    })?;
    let e = if with_rhs {
        pose_error(&m.pose, &t, opts.orientation)
    } else {
        [0.0; 6]
    };
    // The pose's six rows at once; an unmeasured row gets weight 0 (and zero entries).
    let mut c = 0.0;
    let mut wk = [0.0; 6];
    let mut on = [false; 6];
    for k in 0..6 {
        if !m.mask.has(k) {
            continue;
        }
        wk[k] = m.weight * weight(opts, k);
        on[k] = true;
        c += wk[k] * e[k] * e[k];
    }
    // Column by column: one Jacobian column (six contiguous values) per parameter, every
    // row written (no branch, no bounds check: `j < n <= P`); an unmeasured row is zeroed
    // afterwards, which leaves the same entries (0) as not scaling it.
    // Only `[..n]` of each row is written, and only that is read (`add_rows6` of both
    // accumulators): the rest of `ws.pose_rows` may hold anything.
    let n = cols.len().min(P);
    let rows = &mut ws.pose_rows;
    for j in 0..n {
        let jc = jac.get(cols[j]).copied().unwrap_or([0.0; 6]);
        let scale = ws.colscale[j];
        for k in 0..6 {
            rows[k][j] = jc[k] * scale;
        }
    }
    for k in 0..6 {
        if !on[k] {
            rows[k][..n].fill(0.0);
        }
    }
    let rows = &ws.pose_rows;
    // Only `[..n]` of `ws.pose_rows` is this pose's: an accumulator reset for more columns
    // would fold stale entries beyond it, a wrong sum, so that is refused.
    let fits = |acc_n: usize| {
        if acc_n > n {
            Err(Error::DimensionMismatch {
                expected: acc_n,
                found: n,
            })
        } else {
            Ok(())
        }
    };
    if ws.fold_both {
        // The analysis's rows (zero right-hand side) first, so that any error is the one the
        // analysis alone reports; then the first iteration's, and the pose's statistics
        // (`t` is `model_pose`'s transform bit for bit: the same chain).
        // A pose the first iteration cannot fold (a non-finite residual) is no error of the
        // analysis: the first pass is then not taken, and the fit's own passes report it.
        fits(ws.lsq.n())?;
        ws.lsq.add_rows6(rows, &[0.0; 6], &wk)?;
        if ws.first_pass {
            ws.first_pass = fits(ws.gram.n()).is_ok() && ws.gram.add_rows6(rows, &e, &wk).is_ok();
            ws.pass_stats.add(m, &t, opts);
        }
    } else if ws.to_gram {
        fits(ws.gram.n())?;
        ws.gram.add_rows6(rows, &e, &wk)?;
        if ws.last_pass {
            ws.pass_stats.add(m, &t, opts);
            for k in 0..6 {
                if on[k] {
                    ws.last_cost += wk[k] * e[k] * e[k];
                }
            }
        }
    } else {
        fits(ws.lsq.n())?;
        ws.lsq.add_rows6(rows, &e, &wk)?;
    }
    Ok(c)
}

/// How many Jacobian columns (a prefix of the flat parameters) cover the columns `cols`:
/// only the links, the geometry, or everything.
pub(crate) fn jacobian_len<const N: usize>(cols: &[usize]) -> usize {
    let full = cols.iter().any(|&c| c >= Robot::<N>::NUM_GEOMETRIC_PARAMS);
    let links = cols.iter().all(|&c| c < 5 * N);
    if full {
        Robot::<N>::NUM_PARAMS
    } else if links {
        5 * N
    } else {
        Robot::<N>::NUM_GEOMETRIC_PARAMS
    }
}

/// Residual statistics of a model on a data set.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ResidualStats {
    /// Number of poses.
    pub poses: usize,
    /// Number of measured rows (components).
    pub rows: usize,
    /// Weighted sum of squares (the identification cost).
    pub cost: f64,
    /// Poses measuring at least one position component (contacts included): the RMS and
    /// max of |e_p| run over them; 0 means no position is measured.
    pub pos_poses: usize,
    /// Poses measuring at least one orientation component; 0 means none.
    pub rot_poses: usize,
    /// RMS of |e_p| over the poses measuring a position component, |e_p| taken over the
    /// measured components only (a row giving only `x` contributes |e_x|) \[m\].
    pub rms_pos_m: f64,
    /// Largest |e_p| \[m\].
    pub max_pos_m: f64,
    /// RMS of the rotation angle over poses measuring an orientation component (over the
    /// measured components when only some are) \[rad\].
    pub rms_rot_rad: f64,
    /// Largest rotation angle \[rad\].
    pub max_rot_rad: f64,
}

/// Residual statistics of `robot` on the poses of `data` with a positive weight (exact
/// orientation error for the angle statistics, unweighted; `opts` and the pose weights
/// decide the cost).
pub fn residual_stats<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
) -> Result<ResidualStats> {
    stats_by(data, opts, |_, m| m.model_pose(robot))
}

/// [`residual_stats`] with row `l`'s model pose from `pose(l, m)` (as [`cost_by`]).
fn stats_by<const N: usize>(
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    mut pose: impl FnMut(usize, &Measurement<N>) -> Result<Transform>,
) -> Result<ResidualStats> {
    let mut acc = StatsAcc::default();
    for (l, m) in data.iter().enumerate() {
        if is_active(l, m, opts) {
            acc.add(m, &pose(l, m)?, opts);
        }
    }
    Ok(acc.finish())
}

/// Running sums of [`ResidualStats`], one row at a time (the model pose given, so rows
/// compared in a frame of their own, e.g. a session's, share the statistics).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct StatsAcc {
    s: ResidualStats,
    sum_pos2: f64,
    sum_rot2: f64,
}

impl StatsAcc {
    /// No rows yet (the `Default`, usable in a `const` workspace).
    pub(crate) const EMPTY: StatsAcc = StatsAcc {
        s: ResidualStats {
            poses: 0,
            rows: 0,
            cost: 0.0,
            pos_poses: 0,
            rot_poses: 0,
            rms_pos_m: 0.0,
            max_pos_m: 0.0,
            rms_rot_rad: 0.0,
            max_rot_rad: 0.0,
        },
        sum_pos2: 0.0,
        sum_rot2: 0.0,
    };

    /// Adds measurement `m` against the model pose `t` (its weight and `opts` decide the
    /// cost; the angle statistics use the exact orientation error, unweighted).
    pub(crate) fn add<const N: usize>(
        &mut self,
        m: &Measurement<N>,
        t: &Transform,
        opts: &IdentifyOptions<'_>,
    ) {
        let s = &mut self.s;
        s.poses += 1;
        let ex = pose_error(&m.pose, t, OrientationError::Exact);
        // The cost's form is usually the exact one too: one rotation log then.
        let e = if opts.orientation == OrientationError::Exact {
            ex
        } else {
            pose_error(&m.pose, t, opts.orientation)
        };
        for k in 0..6 {
            if m.mask.has(k) {
                s.rows += 1;
                s.cost += m.weight * weight(opts, k) * e[k] * e[k];
            }
        }
        // Over the measured components only (a partly measured kind counts too): the
        // unmeasured ones are not residuals, and a full kind gives the usual norm.
        let sq = |ks: core::ops::Range<usize>| {
            ks.filter(|&k| m.mask.has(k))
                .map(|k| ex[k] * ex[k])
                .sum::<f64>()
        };
        if (0..3).any(|k| m.mask.has(k)) {
            let p2 = sq(0..3);
            self.sum_pos2 += p2;
            s.pos_poses += 1;
            s.max_pos_m = s.max_pos_m.max(crate::math::sqrt(p2));
        }
        if (3..6).any(|k| m.mask.has(k)) {
            let r2 = sq(3..6);
            self.sum_rot2 += r2;
            s.rot_poses += 1;
            s.max_rot_rad = s.max_rot_rad.max(crate::math::sqrt(r2));
        }
    }

    /// The statistics of the rows added.
    pub(crate) fn finish(self) -> ResidualStats {
        let mut s = self.s;
        if s.pos_poses > 0 {
            s.rms_pos_m = crate::math::sqrt(self.sum_pos2 / s.pos_poses as f64);
        }
        if s.rot_poses > 0 {
            s.rms_rot_rad = crate::math::sqrt(self.sum_rot2 / s.rot_poses as f64);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Algorithm;
    use crate::params::ParamSet;

    /// The pose rows kept in the workspace are written only for the pose's columns: an
    /// accumulator reset for more columns is refused, never fed the stale entries beyond.
    #[test]
    fn an_accumulator_wider_than_the_pose_rows_is_refused() {
        let robot = crate::aria::nominal();
        let q = crate::aria::TOOL_SEED_Q;
        let m = Measurement::new(q, robot.fk(&crate::JointState::new(q)).unwrap());
        let opts = IdentifyOptions::new(Algorithm::Ols, ParamSet::default());
        let mut ws = std::boxed::Box::<Workspace<32>>::default();
        ws.cols[..3].copy_from_slice(&[0, 1, 2]);
        ws.colscale = [1.0; 32];
        ws.pose_rows = [[f64::NAN; 32]; 6];
        ws.lsq.reset(5).unwrap();
        assert_eq!(
            add_rows(&robot, usize::MAX, &m, true, &opts, 3, &mut ws),
            Err(Error::DimensionMismatch {
                expected: 5,
                found: 3
            })
        );
        ws.lsq.reset(3).unwrap();
        assert!(add_rows(&robot, usize::MAX, &m, true, &opts, 3, &mut ws).is_ok());
    }

    /// A row giving only `x`, 2 mm off in x and far off in the unmeasured y and z, and a
    /// full position row 3, 4, 0 mm off: |e_p| is 2 mm and 5 mm, the RMS √((4 + 25)/2) mm,
    /// no orientation is measured (`rot_poses` 0), and the cost counts x, x, y, z.
    #[test]
    fn partly_measured_positions_count_their_measured_components() {
        let robot = crate::aria::nominal();
        let q = crate::aria::TOOL_SEED_Q;
        let t = robot.fk(&crate::JointState::new(q)).unwrap();
        let moved = |d: [f64; 3]| {
            let mut m = Measurement::new(q, t);
            m.pose.translation.vector += nalgebra::Vector3::new(d[0], d[1], d[2]);
            m
        };
        let mut x_only = moved([2e-3, 0.5, -0.7]);
        x_only.mask = ComponentMask(0x01);
        let mut full = moved([3e-3, 4e-3, 0.0]);
        full.mask = ComponentMask::POSITION;
        let opts = IdentifyOptions::new(Algorithm::Ols, ParamSet::default());
        let s = residual_stats(&robot, &[x_only, full], &opts).unwrap();
        assert_eq!((s.poses, s.rows, s.pos_poses, s.rot_poses), (2, 4, 2, 0));
        assert!(
            (s.rms_pos_m - (29e-6f64 / 2.0).sqrt()).abs() < 1e-12,
            "{s:?}"
        );
        assert!((s.max_pos_m - 5e-3).abs() < 1e-12, "{s:?}");
        assert!((s.cost - 29e-6 * opts.weight_pos).abs() < 1e-15, "{s:?}");
        assert_eq!((s.rms_rot_rad, s.max_rot_rad), (0.0, 0.0));
    }
}
