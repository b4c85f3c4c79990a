//! Parameter identification (Sections 3.2–4.1): the identifiability analysis, the paper's
//! three algorithms (OLS, OPT1, OPT2), parameter covariance, and robust identification with
//! a residual test that names suspect poses ([`robust`]).
//!
//! Memory: everything of size p×p (p = fitted parameters, at most the workspace capacity
//! `P`) lives in a caller-provided [`Workspace`]; the data are a caller slice, folded pose
//! by pose into a streaming triangular factor, so memory does not grow with the number
//! of poses. No heap, no panics. The workspace also remembers the structural step of the
//! identifiability analysis under an exact key of the model and the selection (`memo`),
//! so repeated fits of one model skip it with bit-identical results
//! ([`Workspace::forget_structure`] drops it).
//!
//! Problem: `min Σ_l Σ_rows w_row·e_row²`, `e = [p_meas − p_model; φ(R_meas·R_modelᵀ)]`
//! (positions in metres, rotations in radians, [`IdentifyOptions::orientation`] decides
//! exact log or eq. 16), over the identifiable subset of the requested parameters; the
//! others keep their initial values and are reported. Optionally with Gaussian priors
//! around the initial model ([`Prior`], [`IdentifyOptions::prior`]): one whitened row per
//! parameter, in every algorithm and in the covariance, for directions the data leave weak.
//!
//! The analysis runs at the initial model, and its data step is confirmed at the fitted
//! one: a parameter the data determine at the start but not at the fit (ARIA's tool poses
//! and the base's x) is reported data-deficient, held at its initial value, and the rest
//! refitted from the start (`core/src/identify/at_fit.rs`).

mod at_fit;
pub mod constraints;
mod data;
mod held_out;
mod identifiability;
pub mod instrument_sessions;
mod memo;
mod prior;
pub mod robust;
mod sessions;
mod solvers;
pub(crate) mod torques;
mod workspace;

pub use constraints::{
    ConstraintData, Contact, Distance, Group, GroupEstimate, GroupKind, MIN_SESSION_ROWS,
    USABLE_PLANE_MIN_ASPECT, analyze_constrained, distance_estimate, group_estimate,
    identify_constrained,
};
pub use data::{ComponentMask, Measurement, ResidualStats, residual_stats};
pub(crate) use data::{distinct_points, validate as validate_data};
pub use held_out::{EstimationError, held_out_estimation_error};
pub(crate) use identifiability::structural_step;
pub use identifiability::{Identifiability, Partner, analyze};
pub use instrument_sessions::{InstrumentSession, fit_session_frame};
pub use prior::{DEFAULT_PRIOR_ANGLE_RAD, DEFAULT_PRIOR_LENGTH_M, Prior, PriorSizes};
pub use robust::{
    Loss, PoseResidual, RobustIdentification, RobustOptions, identify_constrained_robust,
    identify_robust, residual_test,
};
pub use sessions::{
    MIN_FRAME_ROWS, NO_ROW, RowRole, SessionFault, SessionLayout, SessionScratch, check_sessions,
};
pub use solvers::{identify, identify_with_analysis};
pub(crate) use solvers::{identify_in_place, identify_into};
pub use workspace::Workspace;

use crate::error::ParamIndex;
use crate::params::ParamSet;
use crate::pose::OrientationError;

/// Largest number of parameters of any model ([`crate::params::num_params`] of
/// [`crate::any::MAX_JOINTS`] joints).
pub const MAX_MODEL_PARAMS: usize = crate::params::num_params(crate::any::MAX_JOINTS);

/// The three algorithms of the paper (Section 4.1.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Algorithm {
    /// Gauss–Newton with the minimum-norm least-squares step (Matlab `lsqminnorm`), with
    /// step halving when a full step increases the cost (on contact data, after six
    /// halvings, also a damped step of the same length).
    Ols,
    /// Bounded fit inside prior intervals (Matlab `fmincon` in the paper): projected
    /// Levenberg–Marquardt with an active set; parameters ending on a bound are reported.
    Opt1,
    /// Levenberg–Marquardt with MINPACK's trust region and column scaling (`lmder`, as
    /// Matlab `lsqnonlin`).
    Opt2,
}

impl Algorithm {
    /// All three, in the paper's order.
    pub const ALL: [Algorithm; 3] = [Algorithm::Ols, Algorithm::Opt1, Algorithm::Opt2];
    /// Lower-case name (`ols`, `opt1`, `opt2`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Algorithm::Ols => "ols",
            Algorithm::Opt1 => "opt1",
            Algorithm::Opt2 => "opt2",
        }
    }
    /// Parses a lower-case name.
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        Algorithm::ALL.into_iter().find(|a| a.name() == s)
    }
}

/// Prior intervals for OPT1, absolute values per flat parameter index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower bounds (index = flat parameter index).
    pub lower: [f64; MAX_MODEL_PARAMS],
    /// Upper bounds.
    pub upper: [f64; MAX_MODEL_PARAMS],
}

/// The paper's manufacturing tolerance on lengths: 5 mm (Section 2.4).
pub const DEFAULT_LENGTH_TOL_M: f64 = 5e-3;
/// The paper's manufacturing tolerance on angles: 5° (Section 2.4).
pub const DEFAULT_ANGLE_TOL_RAD: f64 = 5.0 * core::f64::consts::PI / 180.0;

impl Bounds {
    /// Intervals around the robot's current parameters: ± `length_tol_m` for lengths,
    /// ± `angle_tol_rad` for angles, and for the effects: compliance in [0, 1e-2] rad/(N·m)
    /// (it is non-negative by definition), scale ±1e-2, cyclic and backlash ±`angle_tol_rad`,
    /// thermal ±1e-3 1/K.
    #[must_use]
    pub fn around<const N: usize>(
        robot: &crate::Robot<N>,
        length_tol_m: f64,
        angle_tol_rad: f64,
    ) -> Self {
        use crate::params::ParamId;
        let mut b = Bounds {
            lower: [f64::NEG_INFINITY; MAX_MODEL_PARAMS],
            upper: [f64::INFINITY; MAX_MODEL_PARAMS],
        };
        for i in 0..crate::Robot::<N>::NUM_PARAMS.min(MAX_MODEL_PARAMS) {
            let Ok(id) = ParamId::from_index(ParamIndex(i), N) else {
                continue;
            };
            let v = robot.param(ParamIndex(i)).unwrap_or(0.0);
            let (lo, hi) = match id {
                ParamId::Compliance(_) => (0.0, 1e-2),
                ParamId::Scale(_) => (v - 1e-2, v + 1e-2),
                ParamId::Thermal => (v - 1e-3, v + 1e-3),
                _ if id.is_length() => (v - length_tol_m, v + length_tol_m),
                _ => (v - angle_tol_rad, v + angle_tol_rad),
            };
            b.lower[i] = lo;
            b.upper[i] = hi;
        }
        b
    }
    /// The paper's defaults (5 mm, 5°) around the robot's current parameters.
    #[must_use]
    pub fn paper_default<const N: usize>(robot: &crate::Robot<N>) -> Self {
        Self::around(robot, DEFAULT_LENGTH_TOL_M, DEFAULT_ANGLE_TOL_RAD)
    }
}

/// Options of [`identify`]. Convergence (documented thresholds, MINPACK-style): the scaled
/// step `|D·δ| <= xtol·(|D·x| + xtol)`, or both the actual and the predicted relative
/// cost reduction below `ftol`, or the cost below `abs_cost_tol` (noise-free data);
/// reaching `max_iterations` first is [`crate::Error::NotConverged`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyOptions<'a> {
    /// Which algorithm.
    pub algorithm: Algorithm,
    /// Parameters to identify (flat indices); only their identifiable subset is fitted.
    pub requested: ParamSet,
    /// Iteration limit.
    pub max_iterations: u32,
    /// Relative step tolerance.
    pub xtol: f64,
    /// Relative cost-reduction tolerance.
    pub ftol: f64,
    /// Absolute cost below which the fit is exact (sum of squares).
    pub abs_cost_tol: f64,
    /// A unit-scaled Jacobian column whose part outside the span of the columns kept
    /// before it is shorter than this is not identifiable from the data.
    pub rank_tol: f64,
    /// Orientation error used in the cost.
    pub orientation: OrientationError,
    /// Weight of each position row (1/m²) …
    pub weight_pos: f64,
    /// … and of each rotation row (1/rad²); the paper weighs both 1.
    pub weight_rot: f64,
    /// OPT1's intervals (required for OPT1, ignored otherwise).
    pub bounds: Option<&'a Bounds>,
    /// Fit the identifiable subset even when the data leave some generically identifiable
    /// parameters undetermined, at the initial or at the fitted model (otherwise that is
    /// [`crate::Error::RankDeficient`]).
    pub allow_data_deficiency: bool,
    /// Compute σ², standard errors and correlations of the result (a p×p inverse, and one
    /// more Jacobian pass unless the solver ended holding the normal equations of the
    /// fitted model). Off, they are reported as 0 / none: for repeated fits that only need
    /// the parameters, e.g. a Monte-Carlo study.
    pub covariance: bool,
    /// Indices of rows left out of the fit as if their weight were 0 (sorted ascending):
    /// e.g. the suspect rows of a diagnosis, whose data the caller shares read-only.
    pub excluded: &'a [u32],
    /// Gaussian priors around the initial model ([`Prior`]): one whitened row per fitted
    /// parameter with a finite σ, in every algorithm; parameters the data leave undetermined
    /// are fitted when they carry a prior. `None`: no prior (the paper's fits).
    pub prior: Option<&'a Prior>,
}

impl IdentifyOptions<'_> {
    /// Defaults for `algorithm` and the `requested` parameters.
    #[must_use]
    pub fn new(algorithm: Algorithm, requested: ParamSet) -> Self {
        IdentifyOptions {
            algorithm,
            requested,
            max_iterations: 200,
            xtol: 1e-12,
            ftol: 1e-14,
            abs_cost_tol: 1e-28,
            rank_tol: 1e-6,
            orientation: OrientationError::Exact,
            weight_pos: 1.0,
            weight_rot: 1.0,
            bounds: None,
            allow_data_deficiency: false,
            covariance: true,
            excluded: &[],
            prior: None,
        }
    }
}

/// Pairs of fitted parameters whose estimates are correlated above this are reported.
pub const CORRELATION_REPORT_THRESHOLD: f64 = 0.95;
/// At most this many correlated pairs are stored (the total is counted).
pub const MAX_CORRELATED_PAIRS: usize = 32;

/// A pair of strongly correlated parameter estimates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correlation {
    /// First parameter.
    pub a: ParamIndex,
    /// Second parameter.
    pub b: ParamIndex,
    /// Correlation coefficient.
    pub rho: f64,
}

/// The result of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Identification<const N: usize> {
    /// The identified model.
    pub robot: crate::Robot<N>,
    /// Which algorithm.
    pub algorithm: Algorithm,
    /// What could be identified from the data.
    pub analysis: Identifiability,
    /// Iterations used.
    pub iterations: u32,
    /// Residuals at the initial model.
    pub initial: ResidualStats,
    /// Residuals at the identified model.
    pub fitted: ResidualStats,
    /// Residual variance σ² = cost/(rows − fitted parameters) (0 without redundancy); with
    /// whitened rows, the reduced χ². With a prior: σ² = data cost/(rows − n_eff), where
    /// `n_eff = n − tr(A⁻¹·P)` counts the parameters the data (not the prior) determine
    /// (`A` the normal matrix with the prior rows, `P` their part): today's σ² as the prior
    /// vanishes, cost/rows when it pins everything, and unbiased when the truth is drawn
    /// from the prior. The standard errors are then those of the posterior,
    /// `σ²·(JᵀWJ + s²·Σ_p⁻¹)⁻¹` ([`Prior`]); the prior's own χ² is
    /// [`Identification::prior_chi2`].
    pub sigma2: f64,
    /// Standard error of each fitted parameter (flat index; 0 for parameters not fitted).
    pub std_errors: [f64; MAX_MODEL_PARAMS],
    /// OPT1: fitted parameters that ended on a bound.
    pub at_bound: ParamSet,
    /// Strongly correlated pairs (first `n_correlated.min(MAX_CORRELATED_PAIRS)` valid).
    pub correlated: [Correlation; MAX_CORRELATED_PAIRS],
    /// Number of pairs above [`CORRELATION_REPORT_THRESHOLD`].
    pub n_correlated: usize,
    /// With a prior: `Σ ((x_i − c_i)/σ_i)²` of the fitted parameters at the result (0 without).
    pub prior_chi2: f64,
    /// With a prior: its rows (fitted parameters with a finite σ; 0 without).
    pub prior_rows: usize,
    /// With a prior: the data-deficient parameters fitted because their prior holds them.
    pub prior_held: ParamSet,
}

impl<const N: usize> Identification<N> {
    /// The stored correlated pairs.
    #[must_use]
    pub fn correlations(&self) -> &[Correlation] {
        let k = self.n_correlated.min(MAX_CORRELATED_PAIRS);
        self.correlated.get(..k).unwrap_or(&[])
    }
}
