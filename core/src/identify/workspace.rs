//! Caller-provided working memory of identification: every p×p array lives here, so the
//! stack stays small and the caller decides where the memory is (a `static` on firmware,
//! a `Box` on a host).

use super::MAX_MODEL_PARAMS;
use crate::linalg::gram::GramAccumulator;
use crate::linalg::lm::DampedScratch;
use crate::linalg::lsq::LsqAccumulator;
use crate::linalg::minnorm::SvdScratch;

/// Working memory for identifying up to `P` parameters at once. All-zero is a valid
/// state, so `Box::<Workspace<P>>::new_zeroed()` or a zero-initialised `static` work;
/// [`Workspace::new`] returns it by value (large for big `P`).
#[derive(Debug, Clone)]
pub struct Workspace<const P: usize> {
    pub(crate) lsq: LsqAccumulator<P>,
    pub(crate) gram: GramAccumulator<P>,
    /// Whether rows go to `gram` (iterations) or `lsq` (analysis, covariance).
    pub(crate) to_gram: bool,
    /// Whether a fold computes its cost only (no Jacobian, nothing folded): see
    /// [`super::data::RowSource::fold_cost`].
    pub(crate) cost_only: bool,
    /// Whether a contact fold's Jacobians need the base and tool rotation columns (one of
    /// them is selected); set by each fold of constraint data.
    pub(crate) frame_rotations: bool,
    pub(crate) damped: DampedScratch<P>,
    pub(crate) svd: SvdScratch<P>,
    /// Scratch matrix (orthonormal basis, covariance).
    pub(crate) mat: [[f64; P]; P],
    /// Scratch matrix (right singular vectors, covariance factor).
    pub(crate) v: [[f64; P]; P],
    /// Singular values of the last analysis (scaled Jacobian of the identifiable set).
    pub(crate) sv: [f64; P],
    pub(crate) jac: [[f64; 6]; MAX_MODEL_PARAMS],
    /// Flat parameter index of each column.
    pub(crate) cols: [usize; P],
    /// Factor applied to each column when accumulating.
    pub(crate) colscale: [f64; P],
    /// Scratch row: OPT1's damping scales, a prior row while folding (never held across a
    /// fold).
    pub(crate) row: [f64; P],
    /// A pose's six scaled rows while `add_rows` folds them (only `[..n_cols]` of each is
    /// written and read; kept here so no pose pays for clearing all `6·P` entries).
    pub(crate) pose_rows: [[f64; P]; 6],
    pub(crate) diag: [f64; P],
    pub(crate) x: [f64; P],
    pub(crate) step: [f64; P],
    pub(crate) tmp: [f64; P],
    pub(crate) free: [usize; P],
    /// The fitted parameters' starting values (order of `cols`), for the refit after a
    /// parameter is found data-deficient at the fitted model ([`super::at_fit`]).
    pub(crate) start: [f64; P],
    pub(crate) n_sv: usize,
    /// Means of the last few constraint groups folded (for known distances).
    pub(crate) means: [super::constraints::GroupMean<P>; super::constraints::MEAN_CACHE],
    /// The last structural step of the identifiability analysis, with its exact key
    /// ([`super::memo`]): repeated fits of one model skip it.
    pub(crate) memo: super::memo::StructuralMemo<P>,
    /// The first pass at the initial model, shared ([`super::data::fold_first_pass`]): set
    /// by `identify` for the analysis's data step, which then also folds `gram`, the cost
    /// and the residual statistics at the model it analyses (the first fit's starting model).
    pub(crate) share_first_pass: bool,
    /// Whether `add_rows` folds into both `lsq` (zero right-hand side) and `gram`, and adds
    /// the pose to `pass_stats` (only inside [`super::data::fold_first_pass`]).
    pub(crate) fold_both: bool,
    /// Whether `gram` holds the unit-scaled normal equations of the fit's starting model
    /// and `first_cost`, `pass_stats` its cost and residual statistics: the first
    /// iteration of the solver takes them instead of folding the data again. Cleared by
    /// every other fold into `gram` and when taken.
    pub(crate) first_pass: bool,
    pub(crate) first_cost: f64,
    /// Residual statistics collected by a pass: the first pass's ([`Self::first_pass`]), or
    /// the last trial's ([`Self::last_pass`]).
    pub(crate) pass_stats: super::data::StatsAcc,
    /// Whether `add_rows` folding into `gram` also adds each pose to `pass_stats` and its
    /// cost, summed as [`super::data::cost`] sums it, to `last_cost` (OLS's last trial with a
    /// covariance to follow, [`super::data::fold_last_trial`]).
    pub(crate) last_pass: bool,
    pub(crate) last_cost: f64,
    /// Whether `pass_stats` are the residual statistics of the model the solver returned.
    pub(crate) fitted_stats: bool,
    /// Gravity torques of the first rows, kept across passes and fits under an exact key.
    pub(crate) torques: super::torques::TorqueCache,
}

impl<const P: usize> Workspace<P> {
    /// A zeroed workspace (by value; prefer zeroed caller memory for large `P`).
    #[must_use]
    pub const fn new() -> Self {
        Workspace {
            lsq: LsqAccumulator::new(),
            gram: GramAccumulator::new(),
            to_gram: false,
            cost_only: false,
            frame_rotations: true,
            damped: DampedScratch::new(),
            svd: SvdScratch::new(),
            mat: [[0.0; P]; P],
            v: [[0.0; P]; P],
            sv: [0.0; P],
            jac: [[0.0; 6]; MAX_MODEL_PARAMS],
            cols: [0; P],
            colscale: [0.0; P],
            row: [0.0; P],
            pose_rows: [[0.0; P]; 6],
            diag: [0.0; P],
            x: [0.0; P],
            step: [0.0; P],
            tmp: [0.0; P],
            free: [0; P],
            start: [0.0; P],
            n_sv: 0,
            means: [super::constraints::GroupMean::EMPTY; super::constraints::MEAN_CACHE],
            memo: super::memo::StructuralMemo::new(),
            share_first_pass: false,
            fold_both: false,
            first_pass: false,
            first_cost: 0.0,
            pass_stats: super::data::StatsAcc::EMPTY,
            last_pass: false,
            last_cost: 0.0,
            fitted_stats: false,
            torques: super::torques::TorqueCache::new(),
        }
    }

    /// Forgets the remembered structural step of the identifiability analysis, so that the
    /// next analysis computes it again. Never needed for correct results (the step is
    /// remembered under an exact key of the model and the selection); for timing the
    /// analysis from scratch, or to compare both paths.
    pub fn forget_structure(&mut self) {
        self.memo.clear();
    }

    /// Singular values (descending) of the unit-column-scaled identification Jacobian of the
    /// identifiable parameters, from the last [`super::analyze`] or [`super::identify`].
    #[must_use]
    pub fn singular_values(&self) -> &[f64] {
        self.sv.get(..self.n_sv).unwrap_or(&[])
    }
}

impl<const P: usize> Default for Workspace<P> {
    fn default() -> Self {
        Self::new()
    }
}
