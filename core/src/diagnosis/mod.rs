//! The sim-to-real gap diagnosis (spec/effects.md): **where** the residual of the geometric
//! calibration lies, **which** effect causes it, and **how far** the gap shrinks when the
//! model is extended by it.
//!
//! # Flow of [`diagnose`]
//! 1. *Groups and folds.* Rows sharing a `pose_id` (the caller's group id) form a group;
//!    groups are dealt to `k` folds by a seeded hash of their id (balanced, order-free,
//!    repeats always in the same fold). With fewer than [`Config::min_groups_per_fold`]
//!    groups per fold (default 5: 25 groups for 5 folds) held-out poses are too few for a
//!    significant paired test, and every model is judged in-sample instead
//!    ([`Method::InSampleNested`], rules below).
//! 2. *Noise floor.* The stated σ (per axis) where given; otherwise the pooled per-axis
//!    standard deviation of the residuals within repeat subgroups — rows of one group with
//!    the same measured components, the same approach directions and temperatures within
//!    [`Config::repeat_temp_tol_c`] — with its degrees of freedom. No σ and no repeats for a
//!    measured component is [`crate::Error::MissingInput`] (`Quantity::NoiseFloor`).
//! 3. *Geometric calibration* on all rows (OLS, rows weighted by 1/σ²): the baseline and
//!    the point every model is linearised at.
//! 4. *Models.* The baseline (geometric parameters), every candidate effect alone and, with
//!    [`Config::pairs`], every pair — each with the structurally redundant parameters of its
//!    effects removed ([`crate::identify::analyze`]'s test on generic configurations) and
//!    the parameters the poses do not determine dropped (the same greedy test on the data,
//!    with the kept parameter each dropped one aligns with). A candidate none of whose
//!    effect parameters the poses determine is *confounded with the geometric parameters*
//!    and not evaluated.
//!
//!    *Outliers* (with [`Config::screen_outliers`], see `screen.rs`): the union of all
//!    models fitted on the rows, each row's residual tested against robust scales; gross
//!    outliers become *suspects* ([`Diagnosis::suspects`]), excluded from every fit, test
//!    and the repeat noise estimate; the noise floor and the geometric calibration are
//!    then redone without them.
//! 5. *Cross-validation* of all models at once, linearised (see `cv.rs`): per pose, the
//!    whitened held-out squared error `s_l = Σ_k r_k²/σ_k²`; per model, the held-out RMS
//!    position error and rotation angle (spec/effects.md definitions).
//! 6. *Decision* ([`decide`], rules below), then the verdict's model fitted (nonlinear) on
//!    all rows, and its held-out residuals recomputed linearised at that fit (the
//!    verdict's held-out RMS, gap closed and status use these refined values).
//! 7. *Where* ([`Location`]): the geometric calibration's residuals by axis, by octant of
//!    the data's bounding box, and their correlation with each joint angle, gravity
//!    torque, approach direction and the temperature.
//! 8. *Explainable at all?* ([`SmoothCheck`], `smooth.rs`): a library-free, cross-validated
//!    smooth function of the joint angles fitted to the baseline's held-out residuals on
//!    the same folds: how much of the gap any smooth function of q explains.
//! 9. *Structure left?* The same smooth check on the verdict's held-out residuals
//!    (`explained` verdicts only).
//! 10. *Does it extrapolate?* ([`ExtrapolationCheck`], `extrapolate.rs`): the verdict's
//!     model fitted on one half of each joint's range and judged on the other
//!     (`explained` verdicts under cross-validation only).
//! 11. *Is the form determined?* ([`FormCheck`], `form.rs`): a verdict with
//!     `joint_cyclic` against the same model with the 3rd and 4th harmonics in place of
//!     the 1st and 2nd (`explained` verdicts under cross-validation only).
//!
//! # Decision rules
//! Statistics (all on whitened held-out errors, so position and rotation rows count by
//! their noise):
//! - **Gap test.** Under "the geometric model is exact", the baseline's held-out total
//!   `Q = Σ_l s_l` has expectation `E = Σ_l (m_l + h_l)` (m_l measured components, h_l the
//!   pose's leverage under its fold's training fit — the inflation by parameter-estimation
//!   error on held-out poses, computed exactly for the linearised model) and variance
//!   `≈ 2·Σ_l (m_l + 2h_l)`. With σ estimated from ν repeat degrees of freedom, `σ̂²/σ²`
//!   adds a relative variance `2/ν` per component type. The statistic is
//!   `z_gap = ln(Q/E) / sd(ln(Q/E))`; **`no_gap`** when `z_gap < z_gap` of the config
//!   (default 3: a one-sided false-alarm rate of ~0.1 % per data set under the Gaussian
//!   model, chosen so that pure-noise data give `no_gap` in well over 95 % of cases while a
//!   gap of the size of the noise floor itself, `Q/E ≈ 1.5` at 80 poses, still gives
//!   `z ≈ 4`).
//! - **Paired test** between models a and b: over groups g (a group's repeats are not
//!   independent), `D_g = S_g^a − S_g^b` with `S_g` the group's sum of `s_l`; `z(a, b)` is
//!   the Wilcoxon signed-rank statistic of the `D_g` (normal approximation). Positive: a
//!   has the larger held-out errors. A rank test, because held-out errors are heavy-tailed:
//!   one pose a model extrapolates badly to would dominate a t statistic (seen in the
//!   blind suite: a 90 % RMS improvement at t = 2.9).
//! - A candidate is **significant** when `z(baseline, c) > z_significance` (default 3,
//!   about Bonferroni 5 % over the 28 candidates). A significant candidate is a gap
//!   whatever the gap test says (a σ stated too large hides gaps from the gap test, not
//!   from the paired test, which is scale-free): the candidates are then judged as usual
//!   and [`Warning::GapDespiteGapTest`] is raised.
//! - **In-sample nested** ([`Method::InSampleNested`]): every model fitted on all rows;
//!   `z(baseline, c)` from the likelihood ratio `Δχ² = χ²_base − χ²_c` against χ² with
//!   `Δp` degrees of freedom (Wilson–Hilferty z); between candidates, Vuong's statistic
//!   over groups with the parameter-count correction; the gap test's expectation is the
//!   χ² degrees of freedom `rows − p`.
//! - **Winner**: among significant candidates not significantly worse than the best one
//!   (`z(c, best) < z_equivalence`, default 3; best = least held-out total), the one with
//!   the fewest effects, then the fewest fitted parameters, then the least held-out total.
//! - **Confounded**: other significant candidates not significantly worse than the best
//!   nor than the winner, whatever status class they would reach — they explain the data
//!   equally well; listed, never chosen at random. Candidates that only add effects to
//!   the winner or to one already listed are as good trivially and not listed.
//! - **Gap closed** (spec/effects.md, reported): `(B − A)/(B − N)` clipped to [0, 1], B
//!   and A the baseline's and the winner's held-out RMS position error, `N = √3·σ_pos`;
//!   when the position shows no gap (B ≤ N) the same ratio of whitened RMS per row. The
//!   same share of the RMS rotation angle (`N = √3·σ_rot`) is reported beside it.
//! - **Status share**: the share of the *whitened* held-out RMS per row, position and
//!   rotation each by its noise, with the floor `√(E/rows)` that includes the
//!   parameter-estimation inflation (the leverage terms of the gap test): a gap that lives
//!   in rotation counts as much as one in position, and a baseline just above √3·σ_pos
//!   by inflation alone does not make the position share noise.
//! - **Status**: `explained` when the winner's status share is ≥
//!   [`Config::explained_fraction`] (default 0.8), the gap test on its own held-out
//!   residuals (the *remaining gap*) is not significant, and it makes neither position
//!   nor rotation significantly worse (paired z on those rows alone below
//!   −`z_significance`); `partially_explained` when the share is ≥
//!   [`Config::partial_fraction`] (default 0.25), or when it would be `explained` but the
//!   remaining gap is significant ([`Reason::RemainingGap`], with where it lies) or a part
//!   gets worse ([`Reason::Worsens`]); otherwise, or with no significant candidate,
//!   `unexplained` (no effects). An `explained` verdict is further demoted to
//!   `partially_explained` when a library-free smooth function of q still explains part
//!   of what it leaves ([`Reason::RemainingStructure`]) or when, fitted on one half of a
//!   joint's range, it does not predict the other half ([`Reason::DoesNotExtrapolate`]:
//!   the largest z of the `2N` half-range splits above the gap threshold
//!   Bonferroni-corrected for their number). Random folds only test interpolation, and a
//!   flexible candidate (`joint_cyclic`, four terms per joint: nearly a quartic in each
//!   joint over a working region's narrow ranges) interpolates smooth effects of other
//!   forms (a third harmonic, a wobbling axis) to the noise floor; only a model of the
//!   right form also predicts outside its training range. That test is exact (Chow's
//!   predictive test, χ² whatever the extrapolation leverage) but has little power on a
//!   working region: fitted on half a joint's range, the flexible model's prediction of
//!   the other half is so uncertain that an absorbed surrogate stays within it (Chow's F
//!   1.1–1.7 on the cases of tests/diagnosis_families.rs). What decides those cases is
//!   the *form check* ([`Reason::FormNotDetermined`]): a verdict containing
//!   `joint_cyclic` stays `explained` only when the same model with the 3rd and 4th
//!   harmonics in place of the 1st and 2nd (a function of the same joints outside the
//!   library, as many parameters) is significantly worse held out (paired z ≥
//!   `z_equivalence`, the rule of `confounded_with`). Otherwise the data do not single out
//!   the library's form: `partially_explained`. This also applies to a true cyclic
//!   error on narrow joint ranges, where the library's harmonics and the next ones are
//!   equally good: the data cannot tell it from an effect outside the library, so
//!   `explained` would claim more than they show. A verdict containing `thermal` is
//!   checked the same way against a translation that follows the temperature (`(T −
//!   20 °C)·ḡ`, the part of thermal's column common to every pose): where the arm warms
//!   over the session, a drift of the instrument in time fits thermal's column as well.
//! - **Stated σ checked**: against the repeats (either way) and against the geometric
//!   calibration's in-sample χ² per degree of freedom (significantly below 1: the data are
//!   quieter than stated) — [`Warning::NoiseVsRepeats`], [`Warning::NoiseVsResiduals`].
//! - **Repeats checked for drift**: repeats overrule a smaller stated σ (the floor cannot
//!   lie below the repeatability) only when their differences do not follow the order of
//!   the rows. When the set-up drifts during a session and the repeats come after the first
//!   measurements, the repeats measure the drift too; letting them overrule raised the
//!   floor above the gap the drift leaves, and a candidate that closed a little of it
//!   (thermal, whose recorded temperature rises with the session) was `explained` with
//!   its held-out position error unchanged (`common/outside3.rs`'s random-walk drift:
//!   5 of 47 detectable cases). The serial test ([`Warning::RepeatsDrift`], z above
//!   3 over at least [`MIN_DRIFT_PAIRS`] pairs) keeps the stated σ then.
//!
//! # Memory
//! No heap: fixed-capacity results ([`MAX_CANDIDATES`] candidates), caller slices for the
//! per-pose outputs ([`PoseDiagnosis`]), and a caller-provided [`DiagWorkspace`] of
//! capacity `P` columns (the union of all models' parameters: 71 for a 6-joint arm with
//! every effect, so `P = 80` suffices there; `P = 144` for 9 joints), which includes the
//! fixed ~321 KiB of the smooth check ([`SmoothWorkspace`]) and ~112 KiB of caches (the
//! first rows' Jacobian columns, `rows.rs`, and their gravity torques): 1,030,256 bytes
//! at `P = 80`.

pub mod contacts;
mod cv;
mod extrapolate;
mod folds;
mod form;
mod locate;
mod noise;
mod rank;
mod rows;
mod screen;
mod sessions;
mod smooth;

pub use extrapolate::ExtrapolationCheck;
pub use form::FormCheck;
pub use locate::{Correlate, Location, QuantityKind, RegionStats};
pub use sessions::{MAX_SESSIONS, SessionConfounding};
pub use smooth::{SmoothCheck, SmoothWorkspace};

use crate::effects::{Effect, EffectSet};
use crate::error::{Error, ParamIndex, Quantity, Result};
use crate::identify::{
    Algorithm, Identifiability, Identification, IdentifyOptions, MAX_MODEL_PARAMS, Measurement,
    Partner, Workspace,
};
use crate::linalg::gram::GramAccumulator;
use crate::math::{ln, sqrt};
use crate::model::Robot;
use crate::params::{ParamId, ParamSet};

/// Largest number of candidate models: the 7 effects alone and their 21 pairs.
pub const MAX_CANDIDATES: usize = 28;
/// Model slots of a diagnosis: the geometric baseline (index 0), the candidates and the
/// union of all of them used to screen outliers (last).
pub const MAX_MODELS: usize = MAX_CANDIDATES + 2;
/// Slot of the union model of the outlier screening.
pub(crate) const SCREEN_MODEL: usize = MAX_CANDIDATES + 1;
/// Suspect rows (gross outliers) listed and excluded at most; the screen excludes at most
/// this many or a tenth of the rows, whichever is less (more rows over the threshold are
/// heavy tails, not gross outliers: none is then excluded, [`Warning::TooManySuspects`]).
/// 64: 2 % of a 3,000-row set such as Hilti's (whose screen stopped at the former 16),
/// 256 bytes of result.
pub const MAX_SUSPECTS: usize = 64;
/// Warnings stored at most.
pub const MAX_WARNINGS: usize = 8;
/// Dropped effect parameters stored per model (with their partners).
pub const MAX_DROPPED: usize = 8;

/// Settings of [`diagnose`]. [`Config::default`] documents the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Stated position noise, 1σ per axis \[m\]; `None`: estimate from repeats.
    pub sigma_pos_m: Option<f64>,
    /// Stated rotation noise, 1σ per axis \[rad\]; `None`: estimate from repeats.
    pub sigma_rot_rad: Option<f64>,
    /// Number of cross-validation folds (≥ 2).
    pub folds: usize,
    /// Seed of the fold assignment.
    pub fold_seed: u64,
    /// Candidate effects; `None`: every effect whose inputs all rows carry (backlash needs
    /// approach directions, thermal needs temperatures).
    pub candidates: Option<EffectSet>,
    /// Also evaluate every pair of candidate effects.
    pub pairs: bool,
    /// The candidates' effect parameters restricted to this set (e.g. `joint_scale` on the
    /// sensor joints only: the scale parameters of the other joints left out); `None`:
    /// every parameter of each effect. Geometric parameters are not affected.
    pub effect_params: Option<ParamSet>,
    /// Threshold of the gap test (one-sided z).
    pub z_gap: f64,
    /// Threshold of a candidate's improvement over the baseline (one-sided z).
    pub z_significance: f64,
    /// A candidate is "not significantly worse" than another below this paired z.
    pub z_equivalence: f64,
    /// Share of the gap closed for `explained`.
    pub explained_fraction: f64,
    /// Share of the gap closed for `partially_explained`.
    pub partial_fraction: f64,
    /// Repeats within this temperature difference [°C] count as the same conditions.
    pub repeat_temp_tol_c: f64,
    /// Rank tolerance of the data identifiability test (as
    /// [`IdentifyOptions::rank_tol`]).
    pub rank_tol: f64,
    /// Cross-validation needs at least this many pose groups per fold; with fewer, the
    /// in-sample nested test is used ([`Method::InSampleNested`]).
    pub min_groups_per_fold: usize,
    /// Screen gross outliers before judging the candidates (module documentation).
    pub screen_outliers: bool,
    /// A candidate is confounded with the sessions when every column's `sin θ` against the
    /// geometric and session-frame columns, or its input's within-session share `√w`, is
    /// at most this (`sessions.rs`; [`diagnose_sessions_into`] only).
    pub session_sin_max: f64,
}

impl Default for Config {
    /// Estimated noise, 5 folds, all effects with their inputs and their pairs, thresholds
    /// z = 3 / 3 / 3, explained at 80 % of the gap, partial at 25 %, repeats within 0.5 °C,
    /// rank tolerance 1e-6, cross-validation from 5 groups per fold (25 groups), outlier
    /// screening on, session confounding at sin θ ≤ 0.1 (under 1 % of a column's squared
    /// length, or of an input's variance, outside the sessions' span: θ < 5.7°).
    fn default() -> Self {
        Config {
            sigma_pos_m: None,
            sigma_rot_rad: None,
            folds: 5,
            fold_seed: 0x6b69_6e63_616c,
            candidates: None,
            pairs: true,
            effect_params: None,
            z_gap: 3.0,
            z_significance: 3.0,
            z_equivalence: 3.0,
            explained_fraction: 0.8,
            partial_fraction: 0.25,
            repeat_temp_tol_c: 0.5,
            rank_tol: 1e-6,
            min_groups_per_fold: 5,
            screen_outliers: true,
            session_sin_max: 0.1,
        }
    }
}

/// The noise floor used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFloor {
    /// Position noise, 1σ per axis \[m\].
    pub sigma_pos_m: f64,
    /// Rotation noise, 1σ per axis \[rad\].
    pub sigma_rot_rad: f64,
    /// Degrees of freedom of the position estimate (infinite when stated).
    pub dof_pos: f64,
    /// Degrees of freedom of the rotation estimate (infinite when stated).
    pub dof_rot: f64,
    /// Repeat subgroups (same pose, same conditions, ≥ 2 rows) in the data.
    pub repeat_subgroups: usize,
    /// Whether σ_pos was stated.
    pub stated_pos: bool,
    /// Whether σ_rot was stated.
    pub stated_rot: bool,
    /// Whether any row measures a position component. Without, and without a stated
    /// σ_pos, `sigma_pos_m` is a placeholder (1 m) that weighs nothing: report "not
    /// measured", not a number.
    pub measured_pos: bool,
    /// Whether any row measures an orientation component (position-only data: `false`,
    /// and `sigma_rot_rad` is a placeholder of 1 rad unless stated).
    pub measured_rot: bool,
    /// Position σ per axis the repeats alone give \[m\] and its degrees of freedom (also
    /// when σ_pos was stated: the check of [`Warning::NoiseVsRepeats`]).
    pub repeat_pos: Option<(f64, f64)>,
    /// Rotation σ per axis the repeats alone give \[rad\] and its degrees of freedom.
    pub repeat_rot: Option<(f64, f64)>,
    /// The stated σ_pos \[m\] when the repeats showed the data significantly noisier
    /// (z > 3 and over 1.25×): the floor then uses the repeats' σ (repeatability is a lower
    /// bound of the instrument noise, so a smaller stated σ cannot be right).
    pub overruled_pos: Option<f64>,
    /// The same for σ_rot \[rad\].
    pub overruled_rot: Option<f64>,
    /// Serial z of the position differences between repeats in measurement order
    /// ([`Warning::RepeatsDrift`]); `None` with fewer than [`MIN_DRIFT_PAIRS`] repeat pairs.
    pub drift_pos: Option<f64>,
    /// The same for the rotation differences.
    pub drift_rot: Option<f64>,
}

impl NoiseFloor {
    /// Expected RMS position error of a pose at the noise floor, √3·σ_pos \[m\].
    #[must_use]
    pub fn rms_pos_m(&self) -> f64 {
        sqrt(3.0) * self.sigma_pos_m
    }
    /// Expected RMS rotation angle at the noise floor, √3·σ_rot \[rad\].
    #[must_use]
    pub fn rms_rot_rad(&self) -> f64 {
        sqrt(3.0) * self.sigma_rot_rad
    }
}

/// An effect parameter the poses do not determine, and the parameter it aligns with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dropped {
    /// The dropped parameter.
    pub param: ParamIndex,
    /// The kept parameter whose column is most aligned with it.
    pub partner: Option<ParamIndex>,
    /// |cos| of the angle between their whitened columns.
    pub cosine: f64,
}

/// One model's identifiability and cross-validated score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelScore {
    /// Effects added to the geometric parameters (none for the baseline).
    pub effects: EffectSet,
    /// Parameters of the model after removing the structurally redundant ones.
    pub requested: ParamSet,
    /// Parameters the poses determine (what is fitted).
    pub identifiable: ParamSet,
    /// Effect parameters redundant in the model whatever the poses (e.g. base-frame terms
    /// duplicating link 1, compliance of a joint without gravity torque).
    pub structural: ParamSet,
    /// Parameters the poses do not determine.
    pub data_deficient: ParamSet,
    /// The first [`MAX_DROPPED`] data-deficient parameters with their partners.
    pub dropped: [Option<Dropped>; MAX_DROPPED],
    /// Number of fitted parameters.
    pub fitted_params: usize,
    /// Least distinctness of the fitted effect parameters: the length of a unit whitened
    /// column's part outside the span of the parameters before it (geometric first); near
    /// 0 the effect is nearly confounded with the geometry on these poses. 1 for the
    /// baseline.
    pub distinctness: f64,
    /// The effect parameter of least distinctness.
    pub least_distinct: Option<ParamIndex>,
    /// Whether the model was cross-validated (false: no effect parameter identifiable).
    pub evaluated: bool,
    /// Held-out RMS position error \[m\].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle \[rad\].
    pub heldout_rms_rot_rad: f64,
    /// Sum over held-out poses of the whitened squared errors.
    pub heldout_chi2: f64,
    /// Paired z of the improvement over the baseline (positive: better); 0 for the
    /// baseline.
    pub improvement_z: f64,
    /// Whether the improvement is significant.
    pub significant: bool,
    /// Paired z against the best candidate (positive: this one is worse); 0 when not
    /// compared (no gap, not evaluated).
    pub z_vs_best: f64,
    /// Paired z against the verdict's candidate; 0 when not compared.
    pub z_vs_winner: f64,
    /// Share of the gap above the noise floor this model closes: held-out RMS position
    /// error (spec/effects.md); the whitened share when the position shows no gap.
    pub gap_closed_fraction: f64,
    /// The same share of the held-out RMS rotation angle (floor √3·σ_rot); 0 when the
    /// rotation shows no gap.
    pub gap_closed_rot_fraction: f64,
    /// The share of the whitened held-out RMS per row (position and rotation together,
    /// each by its noise), floor including the parameter-estimation inflation: the share
    /// the status is decided on.
    pub gap_closed_total_fraction: f64,
    /// Paired z of the improvement in position alone (positive: better); negative beyond
    /// `z_significance`: this model makes the position significantly worse.
    pub z_pos: f64,
    /// Paired z of the improvement in rotation alone (positive: better).
    pub z_rot: f64,
    /// Confounding with the sessions (`sessions.rs`): never chosen when confounded.
    pub session: SessionConfounding,
}

impl ModelScore {
    fn empty(effects: EffectSet) -> Self {
        ModelScore {
            effects,
            requested: ParamSet::new(),
            identifiable: ParamSet::new(),
            structural: ParamSet::new(),
            data_deficient: ParamSet::new(),
            dropped: [None; MAX_DROPPED],
            fitted_params: 0,
            distinctness: 1.0,
            least_distinct: None,
            evaluated: false,
            heldout_rms_pos_m: 0.0,
            heldout_rms_rot_rad: 0.0,
            heldout_chi2: 0.0,
            improvement_z: 0.0,
            significant: false,
            z_vs_best: 0.0,
            z_vs_winner: 0.0,
            gap_closed_fraction: 0.0,
            gap_closed_rot_fraction: 0.0,
            gap_closed_total_fraction: 0.0,
            z_pos: 0.0,
            z_rot: 0.0,
            session: SessionConfounding {
                evaluated: false,
                column_sin: 0.0,
                input_sin: None,
                columns_in_span: false,
                input_constant: false,
            },
        }
    }
}

/// The gap test of a model's held-out errors against the noise floor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GapTest {
    /// Observed over expected whitened held-out total, Q/E.
    pub ratio: f64,
    /// z of ln(Q/E).
    pub z: f64,
    /// Held-out RMS position error expected at the noise floor, √(σ²·Σ(3 + h_pos)/n) \[m\]
    /// (√3·σ inflated by the parameter-estimation error on held-out poses).
    pub expected_rms_pos_m: f64,
    /// Held-out RMS rotation angle expected at the noise floor \[rad\].
    pub expected_rms_rot_rad: f64,
    /// The same test on the position rows alone (0 without position rows).
    pub z_pos: f64,
    /// The same test on the rotation rows alone (0 without rotation rows).
    pub z_rot: f64,
}

/// The verdict's status (spec/cli.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Status {
    /// The geometric model is already at the noise floor.
    NoGap,
    /// The verdict's effects close most of the gap.
    Explained,
    /// They close a significant but smaller share.
    PartiallyExplained,
    /// A gap, but no candidate closes a significant share.
    Unexplained,
}

impl Status {
    /// The public name (`no_gap`, `explained`, `partially_explained`, `unexplained`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Status::NoGap => "no_gap",
            Status::Explained => "explained",
            Status::PartiallyExplained => "partially_explained",
            Status::Unexplained => "unexplained",
        }
    }
}

/// Which effects explain the gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// The chosen effects (empty for `no_gap` and `unexplained`).
    pub effects: EffectSet,
    /// The status.
    pub status: Status,
    /// Candidates that explain the data as well as the chosen one (first
    /// `n_confounded`).
    pub confounded_with: [EffectSet; MAX_CANDIDATES],
    /// Number of confounded candidates.
    pub n_confounded: usize,
    /// Share of the gap above the noise floor the chosen effects close (0 without effects).
    pub gap_closed_fraction: f64,
    /// Index of the chosen candidate in [`Diagnosis::candidates`].
    pub candidate: Option<usize>,
    /// Why the status is what it is.
    pub reason: Reason,
}

/// Where a gap lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// Position rows.
    Position,
    /// Rotation rows.
    Rotation,
    /// Both significantly.
    Both,
}

impl Part {
    /// `position`, `rotation`, `position and rotation`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Part::Position => "position",
            Part::Rotation => "rotation",
            Part::Both => "position and rotation",
        }
    }
}

/// The reason of a verdict's status. A model-free check of how much of the gap any smooth
/// function of the joint angles explains (an effect outside the library) belongs next to
/// [`Reason::RemainingGap`] and [`Reason::SmallShare`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reason {
    /// `no_gap`: the geometric model's held-out error is consistent with the noise floor
    /// and no candidate improves on it significantly.
    AtNoiseFloor,
    /// `explained`: the share closed reaches [`Config::explained_fraction`] and what
    /// remains is consistent with the noise floor.
    Closed,
    /// `partially_explained`: the share closed would be `explained`, but the remaining gap
    /// is still significant (its gap-test z, and where it lies).
    RemainingGap {
        /// z of the remaining gap test.
        z: f64,
        /// Where it lies.
        part: Part,
    },
    /// `partially_explained`: what the chosen effects leave is small but not noise-like: a
    /// library-free smooth function of q explains part of it held out (its paired z).
    RemainingStructure {
        /// Paired z of the smooth model on the verdict's held-out residuals.
        z: f64,
    },
    /// `partially_explained`: what the chosen effects leave is noise-like where they were
    /// fitted, but fitted on one half of a joint's range they do not predict the other half
    /// (`extrapolate.rs`): a flexible candidate absorbing an effect of another form.
    DoesNotExtrapolate {
        /// z of the worst split (above its Bonferroni threshold).
        z: f64,
        /// Joint (zero-based) whose range was split.
        joint: usize,
        /// Whether the upper half of its range was held out.
        upper: bool,
    },
    /// `partially_explained`: a function of another form outside the library explains the
    /// data as well as `effect` (`form.rs`: the 3rd and 4th harmonics in place of
    /// `joint_cyclic`'s 1st and 2nd; a translation that follows the temperature in place of
    /// `thermal`'s length expansion): they do not determine the effect's form.
    FormNotDetermined {
        /// Paired z of the alternative against the chosen effects (below
        /// [`Config::z_equivalence`]).
        z: f64,
        /// The effect whose form is not determined (`joint_cyclic` or `thermal`).
        effect: Effect,
    },
    /// `partially_explained`: the chosen effects make position or rotation significantly
    /// worse (paired z, negative).
    Worsens {
        /// The paired z in that part.
        z: f64,
        /// Which part gets worse.
        part: Part,
    },
    /// `partially_explained` / `unexplained`: the share closed is below the class's
    /// threshold.
    SmallShare,
    /// `unexplained`: no candidate improves significantly on the geometric model.
    NoSignificantCandidate,
    /// `unexplained`: the candidates that improve significantly are all confounded with
    /// the sessions (`sessions.rs`, listed in [`Verdict::confounded_with`]): the data cannot
    /// attribute the gap to them rather than to what differs between the sessions.
    ConfoundedWithSessions,
}

impl Reason {
    /// The public name (REPORT.json `verdict.reason`: `at_noise_floor`, `closed`,
    /// `remaining_gap`, ...), here so the CLI's report and the C ABI share one spelling.
    #[must_use]
    pub const fn name(&self) -> &'static str {
        match self {
            Reason::AtNoiseFloor => "at_noise_floor",
            Reason::Closed => "closed",
            Reason::RemainingGap { .. } => "remaining_gap",
            Reason::RemainingStructure { .. } => "remaining_structure",
            Reason::DoesNotExtrapolate { .. } => "does_not_extrapolate",
            Reason::FormNotDetermined { .. } => "form_not_determined",
            Reason::Worsens { .. } => "worsens",
            Reason::SmallShare => "small_share",
            Reason::NoSignificantCandidate => "no_significant_candidate",
            Reason::ConfoundedWithSessions => "confounded_with_sessions",
        }
    }
}

/// How the candidates were judged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// k-fold cross-validation on held-out pose groups.
    CrossValidation,
    /// Too few pose groups for cross-validation ([`Config::min_groups_per_fold`]): every
    /// model fitted on all rows, each candidate tested against the geometric model by the
    /// likelihood-ratio test with the noise floor (Δχ² against χ² with Δp degrees of
    /// freedom, as z by Wilson–Hilferty), candidates against each other by Vuong's test
    /// with the parameter-count correction.
    InSampleNested,
}

impl Method {
    /// `cross_validation` or `in_sample_nested`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Method::CrossValidation => "cross_validation",
            Method::InSampleNested => "in_sample_nested",
        }
    }
}

/// Something the user should know about the data or the noise they stated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Warning {
    /// The repeats scatter `ratio` times the stated σ (per axis), significantly different
    /// from 1 (`z` of ln ratio² with the repeats' degrees of freedom).
    NoiseVsRepeats {
        /// Position or rotation.
        part: Part,
        /// σ of the repeats over the stated σ.
        ratio: f64,
        /// z of the difference.
        z: f64,
    },
    /// The geometric calibration's residuals are significantly smaller than the stated σ
    /// allows: √(χ²/dof) = `ratio` < 1 (a gap can only add to them).
    NoiseVsResiduals {
        /// Position or rotation.
        part: Part,
        /// √(χ²/dof) of the geometric fit's residuals at the stated σ.
        ratio: f64,
        /// z of χ² against its degrees of freedom.
        z: f64,
    },
    /// The gap test found no gap (`z_gap` below its threshold) but a candidate improves
    /// significantly (`z_candidate`): a gap whatever σ says, and the candidates were
    /// judged.
    GapDespiteGapTest {
        /// The baseline's gap-test z.
        z_gap: f64,
        /// The best candidate improvement z.
        z_candidate: f64,
    },
    /// The differences between repeats of the same pose follow the order of the rows
    /// (serial z above 3: each repeat pair's difference resembles the next
    /// pair's): something drifted during the session, so the repeats measure that drift as
    /// well as the noise. A stated σ is then kept as the floor (the repeats do not overrule
    /// it, and [`Warning::NoiseVsRepeats`] is not given for this part); without one the
    /// floor from these repeats is too high.
    RepeatsDrift {
        /// Position or rotation.
        part: Part,
        /// σ of the repeats over the stated σ (`NaN` when none was stated).
        ratio: f64,
        /// The serial z.
        z: f64,
    },
    /// More rows failed the outlier test (`count`) than gross outliers can be (`cap`:
    /// [`MAX_SUSPECTS`] or a tenth of the rows, whichever is less): none excluded.
    TooManySuspects {
        /// Rows that failed.
        count: usize,
        /// Suspects the screen may exclude on these data.
        cap: usize,
    },
}

impl Warning {
    /// A short code (`noise_vs_repeats`, `noise_vs_residuals`, `gap_despite_gap_test`,
    /// `too_many_suspects`, `repeats_drift`).
    #[must_use]
    pub const fn code(&self) -> &'static str {
        match self {
            Warning::NoiseVsRepeats { .. } => "noise_vs_repeats",
            Warning::NoiseVsResiduals { .. } => "noise_vs_residuals",
            Warning::GapDespiteGapTest { .. } => "gap_despite_gap_test",
            Warning::TooManySuspects { .. } => "too_many_suspects",
            Warning::RepeatsDrift { .. } => "repeats_drift",
        }
    }
}

impl Verdict {
    /// The confounded candidates.
    #[must_use]
    pub fn confounded(&self) -> &[EffectSet] {
        self.confounded_with
            .get(..self.n_confounded.min(MAX_CANDIDATES))
            .unwrap_or(&[])
    }
    /// Union of the effects of all confounded candidates (the contract's flat list).
    #[must_use]
    pub fn confounded_effects(&self) -> EffectSet {
        self.confounded().iter().fold(EffectSet::NONE, |acc, s| {
            s.iter().fold(acc, |a, e| a.with(e))
        })
    }
}

/// Per-pose outputs of [`diagnose`] (caller slice, one per measurement).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseDiagnosis {
    /// Group id (`pose_id`).
    pub group: u32,
    /// Cross-validation fold.
    pub fold: u16,
    /// Residual of the geometric calibration on all rows, `[Δp (m); Δφ (rad)]`; zero in the
    /// components the pose does not measure.
    pub residual: [f64; 6],
    /// Held-out residual of the geometric model (fitted without this pose's fold).
    pub heldout_baseline: [f64; 6],
    /// Held-out residual of the verdict's model (equals `heldout_baseline` without
    /// effects). With [`Method::InSampleNested`] both are in-sample residuals; zero for
    /// suspect rows.
    pub heldout_final: [f64; 6],
    /// A gross outlier by the screening: excluded from every fit and test.
    pub suspect: bool,
    pub(crate) leader: u32,
    /// The next row of the same group ([`folds::NO_NEXT`] after the last): the group's
    /// rows in order from its leader, without a scan of all rows.
    pub(crate) next: u32,
    pub(crate) sub_leader: u32,
    pub(crate) sq: [f64; MAX_MODELS],
    pub(crate) sq_rot: [f64; MAX_MODELS],
    pub(crate) gsq: [f64; MAX_MODELS],
    pub(crate) gsq_rot: [f64; MAX_MODELS],
    pub(crate) scratch: f64,
    /// The smooth check's per-pose features at each of its length scales (`smooth.rs`),
    /// kept so they are computed once per check.
    pub(crate) smooth: [f64; smooth::STORED],
}

impl PoseDiagnosis {
    /// An empty record.
    pub const EMPTY: PoseDiagnosis = PoseDiagnosis {
        group: 0,
        fold: 0,
        residual: [0.0; 6],
        heldout_baseline: [0.0; 6],
        heldout_final: [0.0; 6],
        suspect: false,
        leader: 0,
        next: folds::NO_NEXT,
        sub_leader: 0,
        sq: [0.0; MAX_MODELS],
        sq_rot: [0.0; MAX_MODELS],
        gsq: [0.0; MAX_MODELS],
        gsq_rot: [0.0; MAX_MODELS],
        scratch: 0.0,
        smooth: [0.0; smooth::STORED],
    };
    /// Whitened held-out squared error of model `model` (0 = baseline, c + 1 = candidate c).
    #[must_use]
    pub fn heldout_sq(&self, model: usize) -> f64 {
        self.sq.get(model).copied().unwrap_or(0.0)
    }
}

impl Default for PoseDiagnosis {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Running totals of one model's held-out errors.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct ModelAcc {
    pub chi2: f64,
    pub chi2_rot: f64,
    pub pos2: f64,
    pub rot2: f64,
    pub n_pos: usize,
    pub n_rot: usize,
    pub rows: usize,
    pub rows_pos: usize,
    pub expected_pos: f64,
    pub expected_rot: f64,
    pub variance: f64,
    pub var_pos: f64,
    pub var_rot: f64,
}

/// Working memory of [`diagnose`] for up to `P` parameter columns (the union of all
/// models). All-zero is a valid state (use `Box::new_zeroed` or a zeroed `static` for
/// large `P`).
#[derive(Debug, Clone)]
pub struct DiagWorkspace<const P: usize> {
    /// Working memory of the nonlinear fits.
    pub(crate) id: Workspace<P>,
    pub(crate) u: [usize; P],
    pub(crate) n_u: usize,
    pub(crate) g_all: GramAccumulator<P>,
    pub(crate) g_fold: GramAccumulator<P>,
    pub(crate) chol: [[f64; P]; P],
    pub(crate) scale: [f64; P],
    pub(crate) kept: [usize; P],
    pub(crate) tmp: [f64; P],
    pub(crate) model_cols: [[u8; P]; MAX_MODELS],
    pub(crate) model_n: [usize; MAX_MODELS],
    pub(crate) delta: [[f64; P]; MAX_MODELS],
    pub(crate) acc: [ModelAcc; MAX_MODELS],
    pub(crate) jac: [[f64; 6]; MAX_MODEL_PARAMS],
    pub(crate) a: [[f64; P]; 6],
    pub(crate) b: [f64; 6],
    pub(crate) smooth: SmoothWorkspace,
    /// The columns the form check's alternative replaces while it is cross-validated
    /// (`form.rs`).
    pub(crate) alternative: form::Alternative,
    /// The first rows' Jacobian columns and residuals at the model of the passes
    /// (`rows.rs`).
    pub(crate) rows: rows::RowCache<P>,
}

impl<const P: usize> DiagWorkspace<P> {
    /// A zeroed workspace (by value: large; prefer zeroed heap or static memory).
    #[must_use]
    pub const fn new() -> Self {
        DiagWorkspace {
            id: Workspace::new(),
            u: [0; P],
            n_u: 0,
            g_all: GramAccumulator::new(),
            g_fold: GramAccumulator::new(),
            chol: [[0.0; P]; P],
            scale: [0.0; P],
            kept: [0; P],
            tmp: [0.0; P],
            model_cols: [[0; P]; MAX_MODELS],
            model_n: [0; MAX_MODELS],
            delta: [[0.0; P]; MAX_MODELS],
            acc: [ModelAcc {
                chi2: 0.0,
                chi2_rot: 0.0,
                pos2: 0.0,
                rot2: 0.0,
                n_pos: 0,
                n_rot: 0,
                rows: 0,
                rows_pos: 0,
                expected_pos: 0.0,
                expected_rot: 0.0,
                variance: 0.0,
                var_pos: 0.0,
                var_rot: 0.0,
            }; MAX_MODELS],
            jac: [[0.0; 6]; MAX_MODEL_PARAMS],
            a: [[0.0; P]; 6],
            b: [0.0; 6],
            smooth: SmoothWorkspace::new(),
            alternative: form::Alternative::None,
            rows: rows::RowCache::new(),
        }
    }
}

impl<const P: usize> Default for DiagWorkspace<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// Everything [`diagnose`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnosis<const N: usize> {
    /// The noise floor used.
    pub noise: NoiseFloor,
    /// The geometric calibration on all rows (the baseline model).
    pub geometric: Robot<N>,
    /// The verdict's model (geometric + effects) fitted on all rows; equals `geometric`
    /// without effects. This is what runs on the controller.
    pub model: Robot<N>,
    /// The identification that produced `model` (its identifiability analysis, standard
    /// errors, residuals): the verdict's fit, or the geometric calibration without effects.
    pub fit: Identification<N>,
    /// In-sample residuals of the geometric calibration on all rows.
    pub geometric_residuals: crate::identify::ResidualStats,
    /// Number of groups (distinct `pose_id`s).
    pub groups: usize,
    /// Number of folds.
    pub folds: usize,
    /// The baseline's score.
    pub baseline: ModelScore,
    /// The baseline's gap test.
    pub gap: GapTest,
    /// Candidates (first `n_candidates`): singles in [`Effect::ALL`] order, then pairs.
    pub candidates: [ModelScore; MAX_CANDIDATES],
    /// Number of candidates.
    pub n_candidates: usize,
    /// The verdict.
    pub verdict: Verdict,
    /// Gap test of the verdict's model (the baseline's without effects): what remains.
    pub remaining: GapTest,
    /// Held-out RMS position error of the verdict's model \[m\].
    pub final_heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle of the verdict's model \[rad\].
    pub final_heldout_rms_rot_rad: f64,
    /// Where the geometric calibration's residual lies.
    pub location: Location,
    /// How much of the held-out gap any smooth function of q explains (`smooth.rs`).
    pub explainable: SmoothCheck,
    /// The same check on the verdict's held-out residuals, run when the verdict would be
    /// `explained` (otherwise not evaluated).
    pub remaining_structure: SmoothCheck,
    /// Whether the verdict's model predicts across a joint's range when fitted on half of
    /// it (`extrapolate.rs`), run when the verdict would still be `explained` under
    /// cross-validation (otherwise not evaluated).
    pub extrapolation: ExtrapolationCheck,
    /// Whether the data determine the form of the verdict's `joint_cyclic` (`form.rs`),
    /// run when the verdict would still be `explained` under cross-validation and
    /// contains it (otherwise not evaluated).
    pub form: FormCheck,
    /// How the candidates were judged.
    pub method: Method,
    /// Suspect rows (indices into the data, ascending; first `n_suspects`): gross
    /// outliers excluded from every fit and test.
    pub suspects: [u32; MAX_SUSPECTS],
    /// Number of suspect rows.
    pub n_suspects: usize,
    /// Suspects the outlier screen may exclude on these data: [`MAX_SUSPECTS`] or a tenth
    /// of the rows, whichever is less (0 without screening).
    pub suspect_cap: usize,
    /// Rows over the outlier threshold at the screen's last pass: `n_suspects` when they
    /// were excluded, more than `suspect_cap` when there were too many to exclude any.
    pub rows_over_threshold: usize,
    /// Warnings (first `n_warnings`).
    pub warnings: [Option<Warning>; MAX_WARNINGS],
    /// Number of warnings.
    pub n_warnings: usize,
    /// Held-out RMS of the verdict's residual per component (x, y, z \[m\], rx, ry, rz
    /// \[rad\]) over the clean rows: where what remains lies.
    pub final_rms_axis: [f64; 6],
}

/// What the library-free smooth check ([`SmoothCheck`]) says about a gap the library's
/// effects leave open (status `partially_explained` or `unexplained`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeyondLibrary {
    /// Nothing to say: no gap, the gap is explained, or the check did not run.
    NotApplicable,
    /// A smooth function of the joint angles closes significantly more of the held-out gap
    /// than the verdict's effects: an effect outside the library (its share of the gap).
    SmoothEffect {
        /// Share of the gap the smooth model closes, held out.
        share: f64,
    },
    /// The smooth model does not improve significantly on the geometric model either: what
    /// is left is not a smooth function of q (noise-like, drift, set-up changes, ...).
    NotAFunctionOfQ,
}

impl BeyondLibrary {
    /// The public name (`not_applicable`, `smooth_effect`, `not_a_function_of_q`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            BeyondLibrary::NotApplicable => "not_applicable",
            BeyondLibrary::SmoothEffect { .. } => "smooth_effect",
            BeyondLibrary::NotAFunctionOfQ => "not_a_function_of_q",
        }
    }
}

impl<const N: usize> Diagnosis<N> {
    /// An empty result for [`diagnose_into`]: `robot` as every model, nothing evaluated.
    #[must_use]
    pub fn new(robot: &Robot<N>) -> Self {
        Diagnosis {
            noise: NoiseFloor {
                sigma_pos_m: 0.0,
                sigma_rot_rad: 0.0,
                dof_pos: 0.0,
                dof_rot: 0.0,
                repeat_subgroups: 0,
                stated_pos: false,
                stated_rot: false,
                measured_pos: false,
                measured_rot: false,
                repeat_pos: None,
                repeat_rot: None,
                overruled_pos: None,
                overruled_rot: None,
                drift_pos: None,
                drift_rot: None,
            },
            geometric: *robot,
            model: *robot,
            fit: Identification::start(robot, Algorithm::Ols, None),
            geometric_residuals: crate::identify::ResidualStats::default(),
            groups: 0,
            folds: 0,
            baseline: ModelScore::empty(EffectSet::NONE),
            gap: GapTest::default(),
            candidates: [ModelScore::empty(EffectSet::NONE); MAX_CANDIDATES],
            n_candidates: 0,
            verdict: Verdict {
                effects: EffectSet::NONE,
                status: Status::Unexplained,
                confounded_with: [EffectSet::NONE; MAX_CANDIDATES],
                n_confounded: 0,
                gap_closed_fraction: 0.0,
                candidate: None,
                reason: Reason::NoSignificantCandidate,
            },
            remaining: GapTest::default(),
            final_heldout_rms_pos_m: 0.0,
            final_heldout_rms_rot_rad: 0.0,
            location: Location::empty(),
            explainable: SmoothCheck::default(),
            remaining_structure: SmoothCheck::default(),
            extrapolation: ExtrapolationCheck::default(),
            form: FormCheck::default(),
            method: Method::CrossValidation,
            suspects: [0; MAX_SUSPECTS],
            n_suspects: 0,
            suspect_cap: 0,
            rows_over_threshold: 0,
            warnings: [None; MAX_WARNINGS],
            n_warnings: 0,
            final_rms_axis: [0.0; 6],
        }
    }

    /// What lies beyond the library: read only when the verdict leaves a gap open
    /// (`partially_explained`, `unexplained`). A smooth effect needs the smooth check to be
    /// significant against the geometric model and to close a larger share of the gap than
    /// the verdict's own combined share — or, when the verdict does not extrapolate
    /// ([`Reason::DoesNotExtrapolate`]: its share is interpolation, not explanation), only
    /// to be significant.
    #[must_use]
    pub fn beyond_library(&self) -> BeyondLibrary {
        let open = matches!(
            self.verdict.status,
            Status::PartiallyExplained | Status::Unexplained
        );
        let absorbed = matches!(
            self.verdict.reason,
            Reason::DoesNotExtrapolate { .. } | Reason::FormNotDetermined { .. }
        );
        let x = &self.explainable;
        if !open || !x.evaluated {
            BeyondLibrary::NotApplicable
        } else if x.significant && (absorbed || x.share_of_gap > self.verdict_share()) {
            BeyondLibrary::SmoothEffect {
                share: x.share_of_gap,
            }
        } else if x.significant {
            BeyondLibrary::NotApplicable
        } else {
            BeyondLibrary::NotAFunctionOfQ
        }
    }

    /// The verdict's combined (position and rotation) share of the gap closed; 0 without a
    /// chosen candidate.
    fn verdict_share(&self) -> f64 {
        self.verdict
            .candidate
            .and_then(|c| self.candidates().get(c))
            .map_or(0.0, |c| c.gap_closed_total_fraction)
    }

    /// The suspect rows (indices into the data).
    #[must_use]
    pub fn suspects(&self) -> &[u32] {
        self.suspects
            .get(..self.n_suspects.min(MAX_SUSPECTS))
            .unwrap_or(&[])
    }

    /// The warnings.
    pub fn warnings(&self) -> impl Iterator<Item = &Warning> {
        self.warnings.iter().flatten()
    }

    fn warn(&mut self, w: Warning) {
        if let Some(slot) = self.warnings.get_mut(self.n_warnings) {
            *slot = Some(w);
            self.n_warnings += 1;
        }
    }

    /// The candidates.
    #[must_use]
    pub fn candidates(&self) -> &[ModelScore] {
        self.candidates
            .get(..self.n_candidates.min(MAX_CANDIDATES))
            .unwrap_or(&[])
    }
}

/// Candidate effects by default: all, except backlash unless every row carries approach
/// directions and thermal unless every row carries a temperature.
#[must_use]
pub fn default_candidates<const N: usize>(data: &[Measurement<N>]) -> EffectSet {
    let mut set = EffectSet::NONE;
    for e in Effect::ALL {
        let ok = (!e.needs_approach() || data.iter().all(|m| m.state.approach.is_some()))
            && (!e.needs_temperature() || data.iter().all(|m| m.state.temp_c.is_some()));
        if ok {
            set = set.with(e);
        }
    }
    set
}

/// The candidate effect sets for `effects`: singles in [`Effect::ALL`] order, then (with
/// `pairs`) every pair in lexicographic order. Returns how many were written.
pub fn candidate_sets(
    effects: EffectSet,
    pairs: bool,
    out: &mut [EffectSet; MAX_CANDIDATES],
) -> usize {
    let mut n = 0;
    for e in effects.iter() {
        out[n] = EffectSet::of(e);
        n += 1;
    }
    if pairs {
        for a in effects.iter() {
            for b in effects.iter().filter(|&b| b > a) {
                out[n] = EffectSet::of(a).with(b);
                n += 1;
            }
        }
    }
    n
}

/// Which rows of a pose a paired test compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rows {
    /// All measured components (whitened).
    All,
    /// Position components only.
    Pos,
    /// Rotation components only.
    Rot,
}

/// Group total of model `m` over the selected rows (group leaders only).
fn group_sq(p: &PoseDiagnosis, m: usize, rows: Rows) -> f64 {
    match rows {
        Rows::All => p.gsq[m],
        Rows::Pos => p.gsq[m] - p.gsq_rot[m],
        Rows::Rot => p.gsq_rot[m],
    }
}

/// Paired z of models `a` and `b` over groups (see the module documentation): the
/// Wilcoxon signed-rank statistic of `D_g = S_g^a − S_g^b` in its normal approximation,
/// zero differences dropped, mid-ranks and the tie correction for equal |D|
/// ([`rank::signed_rank_z`], O(G log G)). Overwrites the first records' `scratch`.
pub(crate) fn paired_z(poses: &mut [PoseDiagnosis], a: usize, b: usize, rows: Rows) -> f64 {
    // Compact the non-zero group differences into the first slots' scratch.
    let mut g = 0;
    for l in 0..poses.len() {
        if poses[l].leader as usize != l {
            continue;
        }
        let d = group_sq(&poses[l], a, rows) - group_sq(&poses[l], b, rows);
        if d != 0.0 {
            poses[g].scratch = d;
            g += 1;
        }
    }
    poses.get_mut(..g).map_or(0.0, rank::signed_rank_z)
}

/// In-sample comparison of models `a` and `b` with `p_a`, `p_b` fitted parameters
/// (Vuong's test with the parameter-count correction): over groups, `D_g = S_g^a − S_g^b`
/// of in-sample whitened totals; `z = (Σ D_g − (p_b − p_a)) / (√G · sd(D))` (the
/// correction only for all rows). Positive: `a` fits worse than its parameter count
/// explains.
pub(crate) fn vuong_z(
    poses: &[PoseDiagnosis],
    (a, p_a): (usize, usize),
    (b, p_b): (usize, usize),
    rows: Rows,
) -> f64 {
    let diffs = || {
        poses
            .iter()
            .enumerate()
            .filter(|&(l, p)| p.leader as usize == l)
            .map(|(_, p)| group_sq(p, a, rows) - group_sq(p, b, rows))
    };
    let g = diffs().count();
    if g < 2 {
        return 0.0;
    }
    let sum: f64 = diffs().sum();
    let mean = sum / g as f64;
    let ss: f64 = diffs().map(|d| (d - mean) * (d - mean)).sum();
    let penalty = if rows == Rows::All {
        p_b as f64 - p_a as f64
    } else {
        0.0
    };
    let sd = sqrt(ss * g as f64 / (g - 1) as f64);
    if sd > 0.0 { (sum - penalty) / sd } else { 0.0 }
}

/// z of a likelihood-ratio statistic `Δχ²` with `dp` degrees of freedom (Wilson–Hilferty:
/// `(Δχ²/dp)^(1/3)` is nearly normal with mean `1 − 2/(9dp)` and variance `2/(9dp)`).
pub(crate) fn lr_z(dchi2: f64, dp: usize) -> f64 {
    if dp == 0 {
        return 0.0;
    }
    let k = dp as f64;
    let v = 2.0 / (9.0 * k);
    (crate::math::cbrt(dchi2.max(0.0) / k) - (1.0 - v)) / sqrt(v)
}

/// z of ln(Q/E) with variance `var/E²` plus `2/dof` for an estimated σ (0 when empty).
fn log_ratio_z(q: f64, e: f64, var: f64, dof: f64) -> f64 {
    if e <= 0.0 || q <= 0.0 {
        return 0.0;
    }
    let mut v = var / (e * e);
    if dof.is_finite() && dof > 0.0 {
        v += 2.0 / dof;
    }
    if v > 0.0 { ln(q / e) / sqrt(v) } else { 0.0 }
}

/// The gap test of a model's totals (`acc` with its leverage terms).
fn gap_test(acc: &ModelAcc, noise: &NoiseFloor) -> GapTest {
    let e = acc.expected_pos + acc.expected_rot;
    if e <= 0.0 || acc.chi2 <= 0.0 {
        return GapTest::default();
    }
    let ratio = acc.chi2 / e;
    let (fp, fr) = (acc.expected_pos / e, acc.expected_rot / e);
    let mut var = acc.variance / (e * e);
    if noise.dof_pos.is_finite() && noise.dof_pos > 0.0 {
        var += fp * fp * 2.0 / noise.dof_pos;
    }
    if noise.dof_rot.is_finite() && noise.dof_rot > 0.0 {
        var += fr * fr * 2.0 / noise.dof_rot;
    }
    let z = if var > 0.0 {
        ln(ratio) / sqrt(var)
    } else {
        0.0
    };
    let per = |exp: f64, n: usize, sigma: f64| {
        if n == 0 {
            0.0
        } else {
            sigma * sqrt(exp / n as f64)
        }
    };
    GapTest {
        ratio,
        z,
        expected_rms_pos_m: per(acc.expected_pos, acc.n_pos, noise.sigma_pos_m),
        expected_rms_rot_rad: per(acc.expected_rot, acc.n_rot, noise.sigma_rot_rad),
        z_pos: log_ratio_z(
            acc.chi2 - acc.chi2_rot,
            acc.expected_pos,
            acc.var_pos,
            noise.dof_pos,
        ),
        z_rot: log_ratio_z(acc.chi2_rot, acc.expected_rot, acc.var_rot, noise.dof_rot),
    }
}

/// Where a significant gap (`gap`) lies: the part(s) whose own test exceeds `z`, else the
/// part with the larger z.
fn gap_part(gap: &GapTest, z: f64) -> Part {
    match (gap.z_pos > z, gap.z_rot > z) {
        (true, true) => Part::Both,
        (true, false) => Part::Position,
        (false, true) => Part::Rotation,
        (false, false) if gap.z_rot > gap.z_pos => Part::Rotation,
        (false, false) => Part::Position,
    }
}

fn rms_of(s: f64, n: usize) -> f64 {
    if n == 0 { 0.0 } else { sqrt(s / n as f64) }
}

/// `(B − A)/(B − N)` clipped to [0, 1]; 0 when `B ≤ N` (no gap in this measure).
fn share(b: f64, a: f64, floor: f64) -> f64 {
    if b > floor {
        ((b - a) / (b - floor)).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Share of the gap closed, from the baseline's and the model's totals (spec/effects.md:
/// held-out RMS position error; the whitened RMS per row when the position shows no gap).
fn gap_closed(base: &ModelAcc, model: &ModelAcc, noise: &NoiseFloor) -> f64 {
    let b = rms_of(base.pos2, base.n_pos);
    let a = rms_of(model.pos2, model.n_pos);
    let floor = noise.rms_pos_m();
    if base.n_pos > 0 && b > floor {
        share(b, a, floor)
    } else {
        share(
            rms_of(base.chi2, base.rows),
            rms_of(model.chi2, model.rows),
            1.0,
        )
    }
}

/// The share of the held-out RMS rotation angle closed (floor √3·σ_rot).
fn gap_closed_rot(base: &ModelAcc, model: &ModelAcc, noise: &NoiseFloor) -> f64 {
    share(
        rms_of(base.rot2, base.n_rot),
        rms_of(model.rot2, model.n_rot),
        noise.rms_rot_rad(),
    )
}

/// The share of the whitened held-out RMS per row closed, the floor `√(E/rows)` including
/// the parameter-estimation inflation (the model's own expectation where computed, else
/// the baseline's). When the baseline is already below that floor (σ stated too large)
/// but the model still improves, the whole share is closed: only a significant candidate
/// gets there, and what remains is below the floor.
fn gap_closed_total(base: &ModelAcc, model: &ModelAcc) -> f64 {
    let e_model = model.expected_pos + model.expected_rot;
    let e = if e_model > 0.0 {
        e_model
    } else {
        base.expected_pos + base.expected_rot
    };
    let b = rms_of(base.chi2, base.rows);
    let a = rms_of(model.chi2, model.rows);
    let floor = rms_of(e, base.rows);
    if b > floor {
        share(b, a, floor)
    } else if a < b {
        1.0
    } else {
        0.0
    }
}

/// The part a model makes significantly worse (paired z below −`z_significance`).
fn worsens(s: &ModelScore, cfg: &Config) -> Option<(f64, Part)> {
    let (p, r) = (s.z_pos < -cfg.z_significance, s.z_rot < -cfg.z_significance);
    match (p, r) {
        (true, true) => Some((s.z_pos.min(s.z_rot), Part::Both)),
        (true, false) => Some((s.z_pos, Part::Position)),
        (false, true) => Some((s.z_rot, Part::Rotation)),
        (false, false) => None,
    }
}

/// The decision rules of the module documentation, from the candidates' scores, a paired
/// test between candidates (`paired(a, b)`: z, positive when a has the larger held-out
/// errors; indices into `candidates`) and the baseline's gap test. Fills each evaluated
/// candidate's `z_vs_best` and `z_vs_winner`. Pure: testable on synthetic numbers.
pub fn decide(
    candidates: &mut [ModelScore],
    mut paired: impl FnMut(usize, usize) -> f64,
    gap: &GapTest,
    cfg: &Config,
) -> Verdict {
    let mut v = Verdict {
        effects: EffectSet::NONE,
        status: Status::Unexplained,
        confounded_with: [EffectSet::NONE; MAX_CANDIDATES],
        n_confounded: 0,
        gap_closed_fraction: 0.0,
        candidate: None,
        reason: Reason::NoSignificantCandidate,
    };
    let n = candidates.len().min(MAX_CANDIDATES);
    let cands = &mut candidates[..n];
    // A significant improvement is a gap whatever σ was stated.
    if gap.z < cfg.z_gap && !cands.iter().any(|c| c.evaluated && c.significant) {
        v.status = Status::NoGap;
        v.reason = Reason::AtNoiseFloor;
        return v;
    }
    let Some(best) = (0..n)
        .filter(|&c| cands[c].evaluated)
        .min_by(|&a, &b| cands[a].heldout_chi2.total_cmp(&cands[b].heldout_chi2))
    else {
        return v;
    };
    for c in 0..n {
        if cands[c].evaluated && c != best {
            cands[c].z_vs_best = paired(c, best);
        }
    }
    let eligible = |s: &ModelScore| s.evaluated && s.significant && s.z_vs_best < cfg.z_equivalence;
    let key = |s: &ModelScore| (s.effects.len(), s.fitted_params);
    // A candidate confounded with the sessions is never chosen (sessions.rs).
    let Some(w) = (0..n)
        .filter(|&c| eligible(&cands[c]) && !cands[c].session.confounded())
        .min_by(|&a, &b| {
            key(&cands[a])
                .cmp(&key(&cands[b]))
                .then(cands[a].heldout_chi2.total_cmp(&cands[b].heldout_chi2))
        })
    else {
        // Only session-confounded candidates explain the gap: list them, choose none.
        for c in 0..n {
            let set = cands[c].effects;
            let redundant = v.confounded_with[..v.n_confounded]
                .iter()
                .any(|&k| k.iter().all(|e| set.contains(e)));
            if eligible(&cands[c]) && !redundant && v.n_confounded < MAX_CANDIDATES {
                v.confounded_with[v.n_confounded] = set;
                v.n_confounded += 1;
                v.reason = Reason::ConfoundedWithSessions;
            }
        }
        return v;
    };
    v.status = status_class(cands[w].gap_closed_total_fraction, cfg);
    if v.status == Status::Unexplained {
        v.reason = Reason::SmallShare;
        return v;
    }
    v.reason = if v.status == Status::Explained {
        Reason::Closed
    } else {
        Reason::SmallShare
    };
    if let Some((z, part)) = worsens(&cands[w], cfg) {
        v.status = Status::PartiallyExplained;
        v.reason = Reason::Worsens { z, part };
    }
    v.effects = cands[w].effects;
    v.gap_closed_fraction = cands[w].gap_closed_fraction;
    v.candidate = Some(w);
    // Equally good alternatives, whatever status class they would reach (confounded with
    // the sessions or not). A candidate that adds effects to the winner or to an
    // alternative already listed is as good trivially and not listed (singles come before
    // pairs).
    let winner = cands[w].effects;
    let contains = |big: EffectSet, small: EffectSet| small.iter().all(|e| big.contains(e));
    for c in 0..n {
        let set = cands[c].effects;
        let redundant = contains(set, winner)
            || v.confounded_with[..v.n_confounded]
                .iter()
                .any(|&k| contains(set, k));
        if c == w || !eligible(&cands[c]) || redundant {
            continue;
        }
        cands[c].z_vs_winner = paired(c, w);
        if cands[c].z_vs_winner < cfg.z_equivalence && v.n_confounded < MAX_CANDIDATES {
            v.confounded_with[v.n_confounded] = cands[c].effects;
            v.n_confounded += 1;
        }
    }
    v
}

/// The identifiability analysis of model `mdl` on all rows, from the whitened Gram at the
/// geometric calibration (the same greedy test as [`crate::identify::analyze`], so the
/// nonlinear fit need not redo it): identifiable set, partners of the dropped parameters,
/// condition number of the unit-scaled whitened Jacobian.
fn model_analysis<const P: usize>(
    ws: &mut DiagWorkspace<P>,
    mdl: usize,
    score: &ModelScore,
    tol: f64,
    out: &mut Identifiability,
) -> Result<()> {
    out.requested = score.requested;
    out.identifiable = score.identifiable;
    out.structural = score.structural;
    out.data_deficient = score.data_deficient;
    out.rank = score.identifiable.len();
    out.condition_number = f64::INFINITY;
    for p in out.partner.iter_mut() {
        *p = None;
    }
    for d in score.dropped.iter().flatten() {
        if let (Some(slot), Some(p)) = (out.partner.get_mut(d.param.0), d.partner) {
            *slot = Some(Partner {
                param: p,
                cosine: d.cosine,
            });
        }
    }
    // The model's columns are its identifiable ones now; refactor and take the SVD of Lᵀ.
    let n = cv::factor(ws, mdl, false, tol, None);
    for i in 0..n {
        for j in 0..n {
            ws.id.mat[i][j] = if j >= i { ws.chol[j][i] } else { 0.0 };
        }
    }
    let crate::identify::Workspace { mat, sv, v, .. } = &mut ws.id;
    if n > 0 && crate::linalg::svd::jacobi_svd(mat, n, sv, v).is_ok() {
        let (mut smax, mut smin) = (0.0f64, f64::INFINITY);
        for &x in sv.iter().take(n) {
            smax = smax.max(x);
            smin = smin.min(x);
        }
        if smin > 0.0 {
            out.condition_number = smax / smin;
        }
    }
    Ok(())
}

/// The status a share `f` of the gap closed earns (module documentation).
fn status_class(f: f64, cfg: &Config) -> Status {
    if f >= cfg.explained_fraction {
        Status::Explained
    } else if f >= cfg.partial_fraction {
        Status::PartiallyExplained
    } else {
        Status::Unexplained
    }
}

fn check_config(cfg: &Config) -> Result<()> {
    let finite = [
        cfg.z_gap,
        cfg.z_significance,
        cfg.z_equivalence,
        cfg.explained_fraction,
        cfg.partial_fraction,
        cfg.repeat_temp_tol_c,
        cfg.rank_tol,
    ];
    crate::error::check_finite(&finite, Quantity::Setting)?;
    if cfg.folds < 2 || cfg.folds > usize::from(u16::MAX) {
        return Err(Error::InvalidParameter {
            index: 0,
            value: cfg.folds as f64,
        });
    }
    if !(cfg.rank_tol > 0.0 && cfg.rank_tol < 1.0) {
        return Err(Error::InvalidParameter {
            index: 1,
            value: cfg.rank_tol,
        });
    }
    Ok(())
}

/// Runs the whole diagnosis (module documentation) of `data` against the robot
/// description `robot` (nominal geometry, mass model, limits; its effect parameters
/// should be zero). `groups[l]` is measurement l's group id (`pose_id`; give unique ids
/// to rows without one); `poses` receives the per-pose outputs. Every measurement must
/// have weight 1 (the diagnosis does its own holding out).
///
/// Errors: mismatched lengths ([`Error::DimensionMismatch`]), bad data or settings, fewer
/// groups than folds ([`Error::TooFewData`]), no noise floor
/// ([`Error::MissingInput`]`(Quantity::NoiseFloor)`), a requested effect whose input
/// the rows lack ([`Error::MissingInput`]), more columns than `P`
/// ([`Error::CapacityExceeded`]), and the identification errors of the fits.
pub fn diagnose<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    groups: &[u32],
    cfg: &Config,
    poses: &mut [PoseDiagnosis],
    ws: &mut DiagWorkspace<P>,
) -> Result<Diagnosis<N>> {
    let mut out = Diagnosis::new(robot);
    diagnose_into(robot, data, groups, cfg, poses, ws, &mut out)?;
    Ok(out)
}

/// The model score of model `mdl` (0 = baseline, c + 1 = candidate c) inside `out`.
fn score<const N: usize>(out: &mut Diagnosis<N>, mdl: usize) -> &mut ModelScore {
    if mdl == 0 {
        &mut out.baseline
    } else {
        &mut out.candidates[mdl - 1]
    }
}

/// [`diagnose`] into the caller's `out` (e.g. a `static` on a controller): the result
/// (about 28 KiB for six joints) is not held on the stack, which then stays near that of
/// identification. `out` is overwritten; on error its content is unspecified.
pub fn diagnose_into<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    groups: &[u32],
    cfg: &Config,
    poses: &mut [PoseDiagnosis],
    ws: &mut DiagWorkspace<P>,
    out: &mut Diagnosis<N>,
) -> Result<()> {
    diagnose_sessions_into(robot, data, groups, &[], cfg, poses, ws, out)
}

/// [`diagnose_into`] of data from several sessions (set-ups), `sessions[l]` row l's
/// zero-based session (empty: one session). The rows must already be expressed in one base
/// frame (each session registered into the robot's, e.g. by kincal-io's `session_frames`);
/// the sessions enter the test of each candidate's confounding with them
/// ([`ModelScore::session`], `sessions.rs`): a confounded candidate is never chosen.
// Long by design: the numbered steps of spec/effects.md, in order, over one caller-provided workspace (no heap); split, each step would take a dozen of its buffers as arguments.
#[allow(clippy::too_many_arguments)]
pub fn diagnose_sessions_into<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    groups: &[u32],
    sessions: &[u16],
    cfg: &Config,
    poses: &mut [PoseDiagnosis],
    ws: &mut DiagWorkspace<P>,
    out: &mut Diagnosis<N>,
) -> Result<()> {
    check_config(cfg)?;
    let n = data.len();
    if !sessions.is_empty() && sessions.len() != n {
        return Err(Error::DimensionMismatch {
            expected: n,
            found: sessions.len(),
        });
    }
    if groups.len() != n || poses.len() != n {
        return Err(Error::DimensionMismatch {
            expected: n,
            found: if groups.len() != n {
                groups.len()
            } else {
                poses.len()
            },
        });
    }
    crate::identify::validate_data(data)?;
    if let Some(l) = data.iter().position(|m| m.weight != 1.0) {
        return Err(Error::InvalidParameter {
            index: l,
            value: data[l].weight,
        });
    }
    for p in poses.iter_mut() {
        *p = PoseDiagnosis::EMPTY;
    }
    // Rows kept by an earlier diagnosis are of other data.
    ws.rows.clear();

    // 1–2. Groups, folds, method, noise floor.
    let n_groups = folds::assign(groups, cfg.folds, cfg.fold_seed, poses)?;
    let method = if n_groups < cfg.folds.saturating_mul(cfg.min_groups_per_fold) {
        Method::InSampleNested
    } else {
        Method::CrossValidation
    };
    out.method = method;
    let mut noise = noise::noise_floor(robot, data, poses, cfg)?;
    let (mut wp, mut wr, mut sw) = whitening(&noise);

    // 3. Geometric calibration on all rows.
    let mut opts = IdentifyOptions::new(Algorithm::Ols, robot.geometric_param_set());
    opts.weight_pos = wp;
    opts.weight_rot = wr;
    opts.rank_tol = cfg.rank_tol;
    opts.allow_data_deficiency = true;
    // In place: a returned Identification would be a second copy in this frame.
    crate::identify::identify_in_place(robot, data, &opts, &mut ws.id, &mut out.fit)?;
    let mut lin = out.fit.robot;

    // 4. Candidates and their columns.
    let effects = match cfg.candidates {
        Some(set) => {
            let avail = default_candidates(data);
            if let Some(e) = set.iter().find(|&e| !avail.contains(e)) {
                return Err(Error::MissingInput {
                    what: if e.needs_approach() {
                        Quantity::ApproachDirection
                    } else {
                        Quantity::Temperature
                    },
                });
            }
            set
        }
        None => default_candidates(data),
    };
    let mut sets = [EffectSet::NONE; MAX_CANDIDATES];
    let n_cand = candidate_sets(effects, cfg.pairs, &mut sets);
    let geometric = robot.geometric_param_set();
    // Structural redundancy of each effect next to the geometric parameters.
    let mut mask = 0u8;
    for m in data {
        mask |= m.mask.0;
    }
    let mask = crate::identify::ComponentMask(mask);
    let (points, n_points) = crate::identify::distinct_points(data);
    let any_approach = data.iter().any(|m| m.state.approach.is_some());
    let any_temp = data.iter().any(|m| m.state.temp_c.is_some());
    // An effect's parameters, restricted by the caller's selection.
    let effect_params = |e: Effect| {
        let all = e.params(N);
        match cfg.effect_params {
            Some(allowed) => {
                let mut kept = ParamSet::new();
                for i in all.iter().filter(|&i| allowed.contains(i)) {
                    // Same capacity as `all`: cannot fail.
                    let _ = kept.insert(i);
                }
                kept
            }
            None => all,
        }
    };
    let mut structural = [ParamSet::new(); 7];
    let mut universe = geometric;
    for e in effects.iter() {
        let mut o = opts;
        o.requested = geometric.union(&effect_params(e));
        let mut partner = [None; MAX_MODEL_PARAMS];
        crate::identify::structural_step(
            &lin,
            mask,
            &points[..n_points],
            any_approach,
            any_temp,
            &o,
            &mut ws.id,
            &mut structural[e as usize],
            &mut partner,
        )?;
        for i in effect_params(e).iter() {
            if !structural[e as usize].contains(i) {
                universe.insert(i)?;
            }
        }
    }
    let n_u = universe.len();
    if n_u > P || n_u > 256 {
        return Err(Error::CapacityExceeded {
            needed: n_u,
            capacity: P.min(256),
        });
    }
    ws.n_u = n_u;
    for (k, i) in universe.iter().enumerate() {
        ws.u[k] = i;
    }
    let position = |ws: &DiagWorkspace<P>, i: usize| (0..ws.n_u).find(|&k| ws.u[k] == i);
    // Model columns: 0 = baseline, c + 1 = candidate c.
    out.n_candidates = n_cand;
    for mdl in 0..=n_cand {
        let set = if mdl == 0 {
            EffectSet::NONE
        } else {
            sets[mdl - 1]
        };
        let mut requested = geometric;
        let mut structural_set = ParamSet::new();
        for e in set.iter() {
            structural_set = structural_set.union(&structural[e as usize]);
            for i in effect_params(e).iter() {
                if !structural[e as usize].contains(i) {
                    requested.insert(i)?;
                }
            }
        }
        let mut k = 0;
        for i in requested.iter() {
            if let Some(pos) = position(ws, i) {
                ws.model_cols[mdl][k] = pos as u8;
                k += 1;
            }
        }
        ws.model_n[mdl] = k;
        let sc = score(out, mdl);
        *sc = ModelScore::empty(set);
        sc.requested = requested;
        sc.structural = structural_set;
    }

    // 4b. Gross outliers: screened with the union model, then the noise floor and the
    // geometric calibration again without them.
    let mut suspects = [0u32; MAX_SUSPECTS];
    let mut n_susp = 0;
    out.suspect_cap = 0;
    out.rows_over_threshold = 0;
    // The screen's Gram of the clean rows, still valid at the geometric calibration when
    // the screen excluded nothing (the same rows, calibration and weights as step 5a).
    let mut screened_gram = false;
    if cfg.screen_outliers {
        out.suspect_cap = screen::cap(MAX_SUSPECTS, data.len());
        ws.model_n[SCREEN_MODEL] = n_u;
        for k in 0..n_u {
            ws.model_cols[SCREEN_MODEL][k] = k as u8;
        }
        let (screening, current) =
            screen::screen(&lin, data, &sw, poses, MAX_SUSPECTS, cfg.rank_tol, ws)?;
        screened_gram = current && screening == screen::Screening::Suspects(0);
        match screening {
            screen::Screening::TooMany(count) => {
                out.rows_over_threshold = count;
                out.warn(Warning::TooManySuspects {
                    count,
                    cap: out.suspect_cap,
                });
            }
            screen::Screening::Suspects(0) => {}
            screen::Screening::Suspects(count) => {
                out.rows_over_threshold = count;
                for (l, _) in poses.iter().enumerate().filter(|(_, p)| p.suspect) {
                    if let Some(slot) = suspects.get_mut(n_susp) {
                        *slot = l as u32;
                        n_susp += 1;
                    }
                }
                noise = noise::noise_floor(robot, data, poses, cfg)?;
                (wp, wr, sw) = whitening(&noise);
                opts.weight_pos = wp;
                opts.weight_rot = wr;
                opts.excluded = &suspects[..n_susp];
                crate::identify::identify_in_place(robot, data, &opts, &mut ws.id, &mut out.fit)?;
                lin = out.fit.robot;
            }
        }
    }
    out.suspects = suspects;
    out.n_suspects = n_susp;
    out.geometric = lin;
    out.model = lin;
    out.geometric_residuals = out.fit.fitted;
    out.noise = noise;
    out.groups = n_groups;
    out.folds = cfg.folds;

    // 5a. Whitened Gram of the clean rows at the geometric calibration; in-sample
    // residuals (of every row) and their whitened totals per part (the σ check).
    let fold_again = !(screened_gram && ws.g_all.n() == n_u);
    if fold_again {
        ws.g_all.reset(n_u)?;
    }
    let mut insample = ModelAcc::default();
    let at = cv::Lin::bind(&lin, ws);
    for (l, m) in data.iter().enumerate() {
        let mut e = cv::pose_rows(&at, l, m, &sw, ws)?;
        if !poses[l].suspect {
            if fold_again {
                cv::fold_rows(ws, false)?;
            }
            for k in (0..6).filter(|&k| m.mask.has(k)) {
                let b2 = ws.b[k] * ws.b[k];
                insample.chi2 += b2;
                insample.rows += 1;
                if k < 3 {
                    insample.rows_pos += 1;
                } else {
                    insample.chi2_rot += b2;
                }
            }
        }
        // Components the pose does not measure have no residual (the where-analysis and the
        // reports must not see the model's unmeasured orientation).
        for (k, v) in e.iter_mut().enumerate() {
            if !m.mask.has(k) {
                *v = 0.0;
            }
        }
        poses[l].residual = e;
    }
    // 5b. What the poses determine, per model; keep only those columns. Each model's
    // factor resumes the one before it over their shared leading columns (the geometric
    // ones at least; `cv::Resume`), whose fates are then the earlier model's, still in
    // `fate` (in a block, so that its stack slot is free again after it: the diagnosis's
    // stack bound is tight).
    {
        let mut fate = [cv::ColumnFate {
            kept: false,
            distinct: 0.0,
            partner: None,
        }; P];
        let (mut prev_cols, mut prev_n, mut prev_kept) = ([0u8; P], 0usize, 0usize);
        for mdl in 0..=n_cand {
            let n_cols = ws.model_n[mdl];
            let cols = ws.model_cols[mdl];
            let start = cv::Resume::between(
                &prev_cols[..prev_n.min(P)],
                &ws.kept[..prev_kept.min(P)],
                &cols[..n_cols.min(P)],
            );
            let n_kept = cv::factor_from(
                ws,
                mdl,
                false,
                cfg.rank_tol,
                Some(&mut fate[..n_cols]),
                start,
            );
            (prev_cols, prev_n, prev_kept) = (cols, n_cols, n_kept);
            let s = score(out, mdl);
            let mut k = 0;
            let mut n_dropped = 0;
            let mut any_effect = false;
            for j in 0..n_cols {
                let col = ws.model_cols[mdl][j];
                let flat = ws.u[col as usize];
                let is_effect = !geometric.contains(flat);
                if fate[j].kept {
                    ws.model_cols[mdl][k] = col;
                    k += 1;
                    s.identifiable.insert(flat)?;
                    if is_effect {
                        any_effect = true;
                        if fate[j].distinct < s.distinctness {
                            s.distinctness = fate[j].distinct;
                            s.least_distinct = Some(ParamIndex(flat));
                        }
                    }
                } else {
                    s.data_deficient.insert(flat)?;
                    if n_dropped < MAX_DROPPED {
                        s.dropped[n_dropped] = Some(Dropped {
                            param: ParamIndex(flat),
                            // Partner positions index the model's columns before compaction.
                            partner: fate[j]
                                .partner
                                .map(|(pj, _)| ParamIndex(ws.u[ws.model_cols[mdl][pj] as usize])),
                            cosine: fate[j].partner.map_or(0.0, |(_, c)| c),
                        });
                        n_dropped += 1;
                    }
                }
            }
            ws.model_n[mdl] = k;
            s.fitted_params = k;
            s.evaluated = mdl == 0 || any_effect;
        }
    }

    // 5c. Cross-validation of every evaluated model.
    let mut list = [0usize; MAX_MODELS];
    let mut n_list = 0;
    for mdl in 1..=n_cand {
        if score(out, mdl).evaluated {
            list[n_list] = mdl;
            n_list += 1;
        }
    }
    match method {
        Method::CrossValidation => cv::cross_validate(
            &lin,
            data,
            &sw,
            poses,
            cfg.folds,
            &list[..n_list],
            cv::Pass::Candidates,
            cfg.rank_tol,
            ws,
        )?,
        Method::InSampleNested => cv::in_sample(
            &lin,
            data,
            &sw,
            poses,
            &list[..n_list],
            cv::Pass::Candidates,
            cfg.rank_tol,
            ws,
        )?,
    }

    // 6. Statistics and decision.
    for l in 0..n {
        let lead = poses[l].leader as usize;
        for mdl in 0..=n_cand {
            let (s, r) = (poses[l].sq[mdl], poses[l].sq_rot[mdl]);
            poses[lead].gsq[mdl] += s;
            poses[lead].gsq_rot[mdl] += r;
        }
    }
    let model_n = ws.model_n;
    // Paired z of models a and b (positive: a has the larger errors) by the method.
    let pair = |poses: &mut [PoseDiagnosis], a: usize, b: usize, rows: Rows| match method {
        Method::CrossValidation => paired_z(poses, a, b, rows),
        Method::InSampleNested => vuong_z(poses, (a, model_n[a]), (b, model_n[b]), rows),
    };
    for mdl in 0..=n_cand {
        if !score(out, mdl).evaluated {
            continue;
        }
        let acc = ws.acc[mdl];
        let (improvement, z_pos, z_rot) = if mdl > 0 {
            let all = match method {
                Method::CrossValidation => paired_z(poses, 0, mdl, Rows::All),
                Method::InSampleNested => lr_z(
                    ws.acc[0].chi2 - acc.chi2,
                    model_n[mdl].saturating_sub(model_n[0]),
                ),
            };
            (
                all,
                pair(poses, 0, mdl, Rows::Pos),
                pair(poses, 0, mdl, Rows::Rot),
            )
        } else {
            (0.0, 0.0, 0.0)
        };
        let s = score(out, mdl);
        s.heldout_rms_pos_m = rms_of(acc.pos2, acc.n_pos);
        s.heldout_rms_rot_rad = rms_of(acc.rot2, acc.n_rot);
        s.heldout_chi2 = acc.chi2;
        if mdl > 0 {
            s.improvement_z = improvement;
            s.z_pos = z_pos;
            s.z_rot = z_rot;
            s.significant = s.improvement_z > cfg.z_significance;
            s.gap_closed_fraction = gap_closed(&ws.acc[0], &acc, &noise);
            s.gap_closed_rot_fraction = gap_closed_rot(&ws.acc[0], &acc, &noise);
            s.gap_closed_total_fraction = gap_closed_total(&ws.acc[0], &acc);
        }
    }
    // 5d. Confounding with the sessions: each single effect's fitted columns against the
    // geometric and session-frame columns, and its input; a pair inherits its effects'.
    if sessions::count(sessions) >= 2 {
        let base_geo = out.baseline.identifiable;
        let mut single = [SessionConfounding::default(); 7];
        for c in 0..n_cand {
            let s = out.candidates[c];
            if s.effects.len() != 1 || !s.evaluated {
                continue;
            }
            let Some(e) = s.effects.iter().next() else {
                continue;
            };
            let mut own = ParamSet::new();
            for i in s.identifiable.iter().filter(|&i| !geometric.contains(i)) {
                own.insert(i)?;
            }
            let t = sessions::test(
                &lin,
                data,
                sessions,
                poses,
                &sw,
                e,
                &base_geo,
                &own,
                cfg.session_sin_max,
                cfg.rank_tol,
                ws,
            )?;
            single[e as usize] = t;
            out.candidates[c].session = t;
        }
        for c in 0..n_cand {
            let set = out.candidates[c].effects;
            if set.len() == 2 && out.candidates[c].evaluated {
                let mut it = set.iter();
                if let (Some(a), Some(b)) = (it.next(), it.next()) {
                    out.candidates[c].session =
                        SessionConfounding::combine(&single[a as usize], &single[b as usize]);
                }
            }
        }
    }
    let gap = gap_test(&ws.acc[0], &noise);
    out.gap = gap;
    let verdict = decide(
        &mut out.candidates[..n_cand],
        |a, b| pair(&mut *poses, a + 1, b + 1, Rows::All),
        &gap,
        cfg,
    );
    if gap.z < cfg.z_gap && verdict.status != Status::NoGap {
        let z_candidate = out
            .candidates()
            .iter()
            .filter(|c| c.evaluated)
            .map(|c| c.improvement_z)
            .fold(f64::NEG_INFINITY, f64::max);
        out.warn(Warning::GapDespiteGapTest {
            z_gap: gap.z,
            z_candidate,
        });
    }

    // 6b. The verdict's model on all rows, and its held-out residuals, re-linearised at
    // that fit (the first pass's one Gauss–Newton step from the geometric calibration
    // leaves second-order terms of the effect's size, tens of micrometres for large frame
    // errors; from the fitted model, only those of the fold-to-fold changes remain).
    let mut verdict = verdict;
    let mut refined = false;
    // The union `U` while the final pass and the extrapolation check work on the verdict's
    // columns only (`cv::narrow_to_model`: bit for bit, a fraction of the work).
    let mut narrowed = None;
    if let Some(c) = verdict.candidate {
        let mdl = c + 1;
        let mut o = opts;
        o.requested = score(out, mdl).requested;
        // The fit and its analysis built in one place (no separate copies on the stack).
        let mut fit = Identification::start(&lin, o.algorithm, None);
        model_analysis(ws, mdl, score(out, mdl), cfg.rank_tol, &mut fit.analysis)?;
        match crate::identify::identify_into(data, &o, &mut ws.id, &mut fit) {
            Ok(()) => {}
            // From the geometric calibration the fit of the verdict's model can crawl
            // without end on position-only rows (seen with base_frame, joint_compliance
            // and joint_cyclic; with base_frame the model's analysis there keeps 27
            // parameters, condition numbers 1e4–1e5, where `calibrate`'s analysis at the
            // description keeps 24, condition number 140): the whole
            // diagnosis failed (13 of 5,700 cases of tests/diagnosis_families.rs). Fitted
            // from the description, as `calibrate` fits, the same model converges.
            Err(Error::NotConverged { .. }) => {
                crate::identify::identify_in_place(robot, data, &o, &mut ws.id, &mut fit)?;
            }
            Err(e) => return Err(e),
        }
        let mut sorted = [0usize; P];
        narrowed = Some(cv::narrow_to_model(ws, mdl, &mut sorted));
        ws.g_all.reset(ws.n_u)?;
        let at = cv::Lin::bind(&fit.robot, ws);
        for (l, m) in data.iter().enumerate() {
            if !poses[l].suspect {
                cv::pose_rows(&at, l, m, &sw, ws)?;
                cv::fold_rows(ws, false)?;
            }
        }
        match method {
            Method::CrossValidation => cv::cross_validate(
                &fit.robot,
                data,
                &sw,
                poses,
                cfg.folds,
                &[],
                cv::Pass::Final(mdl),
                cfg.rank_tol,
                ws,
            )?,
            Method::InSampleNested => cv::in_sample(
                &fit.robot,
                data,
                &sw,
                poses,
                &[],
                cv::Pass::Final(mdl),
                cfg.rank_tol,
                ws,
            )?,
        }
        let acc = ws.acc[mdl];
        let closed = gap_closed(&ws.acc[0], &acc, &noise);
        let cand = &mut out.candidates[c];
        cand.heldout_rms_pos_m = rms_of(acc.pos2, acc.n_pos);
        cand.heldout_rms_rot_rad = rms_of(acc.rot2, acc.n_rot);
        cand.heldout_chi2 = acc.chi2;
        cand.gap_closed_fraction = closed;
        cand.gap_closed_rot_fraction = gap_closed_rot(&ws.acc[0], &acc, &noise);
        cand.gap_closed_total_fraction = gap_closed_total(&ws.acc[0], &acc);
        verdict.gap_closed_fraction = closed;
        verdict.status = status_class(cand.gap_closed_total_fraction, cfg);
        let remaining = gap_test(&acc, &noise);
        verdict.reason = match verdict.status {
            Status::Explained if remaining.z > cfg.z_gap => {
                verdict.status = Status::PartiallyExplained;
                Reason::RemainingGap {
                    z: remaining.z,
                    part: gap_part(&remaining, cfg.z_gap),
                }
            }
            Status::Explained => Reason::Closed,
            _ => Reason::SmallShare,
        };
        if verdict.status != Status::Unexplained
            && let Some((z, part)) = worsens(cand, cfg)
        {
            verdict.status = Status::PartiallyExplained;
            verdict.reason = Reason::Worsens { z, part };
        }
        if verdict.status != Status::Unexplained {
            out.remaining = remaining;
            out.final_heldout_rms_pos_m = cand.heldout_rms_pos_m;
            out.final_heldout_rms_rot_rad = cand.heldout_rms_rot_rad;
            out.fit = fit;
            out.model = fit.robot;
            refined = true;
        } else {
            verdict.effects = EffectSet::NONE;
            verdict.candidate = None;
            verdict.n_confounded = 0;
            verdict.gap_closed_fraction = 0.0;
        }
    }
    if !refined {
        // The geometric calibration (still in `out.fit`) is the model.
        for p in poses.iter_mut() {
            p.heldout_final = p.heldout_baseline;
        }
        out.remaining = gap;
        out.final_heldout_rms_pos_m = out.baseline.heldout_rms_pos_m;
        out.final_heldout_rms_rot_rad = out.baseline.heldout_rms_rot_rad;
    }
    out.verdict = verdict;
    out.final_rms_axis = rms_axis(data, poses);
    check_stated_noise(out, &insample, model_n[0]);

    // 7. Where.
    out.location = locate::locate(robot, data, poses, &noise);
    // 8. Explainable at all? (library-free smooth model on the same folds.)
    // 9. Structure left in what the verdict's effects leave: `explained` needs the remainder
    // to be noise-like, not only small (an out-of-library effect a candidate absorbs in part
    // can leave a total near the floor while a smooth function of q still finds it). Both
    // checks in one run: they share the features, Grams and factorisations.
    let remaining = match out.verdict.candidate {
        Some(c) if out.verdict.status == Status::Explained => {
            Some(ws.acc.get(c + 1).copied().unwrap_or(ws.acc[0]))
        }
        _ => None,
    };
    let base = ws.acc[0];
    let (explainable, rest) = smooth::check_both(
        robot,
        data,
        poses,
        &noise,
        &base,
        remaining.as_ref(),
        cfg,
        &mut ws.smooth,
    );
    out.explainable = explainable;
    if let Some(rest) = rest {
        out.remaining_structure = rest;
        if rest.evaluated && rest.significant {
            out.verdict.status = Status::PartiallyExplained;
            out.verdict.reason = Reason::RemainingStructure { z: rest.z };
        }
    }
    // 10. Does it predict where it was not fitted? (Leave-one-range-out: a flexible
    // candidate can interpolate an effect of another form inside the poses' region.)
    if out.verdict.status == Status::Explained
        && method == Method::CrossValidation
        && let Some(c) = out.verdict.candidate
    {
        let model = out.model;
        let x = extrapolate::check(&model, data, &sw, poses, c + 1, cfg, ws)?;
        out.extrapolation = x;
        if x.significant {
            out.verdict.status = Status::PartiallyExplained;
            out.verdict.reason = Reason::DoesNotExtrapolate {
                z: x.z,
                joint: x.joint,
                upper: x.upper,
            };
        }
    }
    if let Some(saved) = narrowed.take() {
        cv::restore_union(ws, &saved);
    }
    // 11. Do the data single out the library's form? (`joint_cyclic` against a function of
    // the same joints, `thermal` against a translation that follows the temperature, both
    // outside the library.)
    for effect in [Effect::JointCyclic, Effect::Thermal] {
        if out.verdict.status != Status::Explained
            || method != Method::CrossValidation
            || !out.verdict.effects.contains(effect)
        {
            continue;
        }
        let Some(c) = out.verdict.candidate else {
            break;
        };
        let geometric = out.geometric;
        let x = form::check(
            &geometric,
            data,
            &sw,
            poses,
            c + 1,
            effect,
            cfg.folds,
            cfg.z_equivalence,
            cfg.rank_tol,
            ws,
        )?;
        out.form = x;
        if x.equivalent {
            out.verdict.status = Status::PartiallyExplained;
            out.verdict.reason = Reason::FormNotDetermined { z: x.z, effect };
        }
    }
    Ok(())
}

/// The first `Robot::<N>::NUM_PARAMS` columns of the workspace's Jacobian (`ws.jac`), where
/// a pose's whole identification Jacobian goes; capacity exceeded for a larger model.
pub(crate) fn jacobian_slots<const N: usize>(
    jac: &mut [[f64; 6]; MAX_MODEL_PARAMS],
) -> Result<&mut [[f64; 6]]> {
    let n = Robot::<N>::NUM_PARAMS;
    jac.get_mut(..n).ok_or(Error::CapacityExceeded {
        needed: n,
        capacity: MAX_MODEL_PARAMS,
    })
}

/// Row weights `1/σ²` and their square roots per component for the noise floor.
fn whitening(noise: &NoiseFloor) -> (f64, f64, [f64; 6]) {
    let wp = 1.0 / (noise.sigma_pos_m * noise.sigma_pos_m);
    let wr = 1.0 / (noise.sigma_rot_rad * noise.sigma_rot_rad);
    let (sp, sr) = (sqrt(wp), sqrt(wr));
    (wp, wr, [sp, sp, sp, sr, sr, sr])
}

/// RMS of the verdict's held-out residual per component over the clean rows measuring it.
fn rms_axis<const N: usize>(data: &[Measurement<N>], poses: &[PoseDiagnosis]) -> [f64; 6] {
    let mut out = [0.0; 6];
    for (k, o) in out.iter_mut().enumerate() {
        let (mut s, mut c) = (0.0, 0usize);
        for (m, p) in data.iter().zip(poses) {
            if m.mask.has(k) && !p.suspect {
                s += p.heldout_final[k] * p.heldout_final[k];
                c += 1;
            }
        }
        *o = rms_of(s, c);
    }
    out
}

/// |z| beyond which a stated σ disagrees with the data (and beyond which the repeats
/// drift: [`Warning::RepeatsDrift`]).
pub(crate) const NOISE_CHECK_Z: f64 = 3.0;
/// Repeat pairs below which the drift of the repeats is not tested.
pub const MIN_DRIFT_PAIRS: usize = 8;

/// The serial z of [`NoiseFloor::drift_pos`] / `drift_rot` when it says the repeats drift
/// (above [`NOISE_CHECK_Z`]): the one rule for the floor (`noise.rs`) and the warning.
pub(crate) fn drifting(z: Option<f64>) -> Option<f64> {
    z.filter(|&z| z > NOISE_CHECK_Z)
}
/// … and only when it is off by more than this factor either way.
pub(crate) const NOISE_CHECK_RATIO: f64 = 1.25;

/// Warns when the repeats drift with the order of the rows; checks a stated σ against
/// repeats that do not (either way) and against the geometric
/// calibration's in-sample residuals (`insample`, whitened at the stated σ; `p` fitted
/// parameters): residuals significantly below the stated noise mean the data are quieter
/// than stated (a gap can only add to them).
fn check_stated_noise<const N: usize>(out: &mut Diagnosis<N>, insample: &ModelAcc, p: usize) {
    let noise = out.noise;
    let parts = [
        (
            Part::Position,
            noise.stated_pos,
            noise.repeat_pos,
            noise.sigma_pos_m,
            insample.chi2 - insample.chi2_rot,
            insample.rows_pos,
        ),
        (
            Part::Rotation,
            noise.stated_rot,
            noise.repeat_rot,
            noise.sigma_rot_rad,
            insample.chi2_rot,
            insample.rows - insample.rows_pos,
        ),
    ];
    let overruled = [noise.overruled_pos, noise.overruled_rot];
    let drift = [noise.drift_pos, noise.drift_rot];
    for (((part, stated, repeats, sigma, chi2, rows), overruled), drift) in
        parts.into_iter().zip(overruled).zip(drift)
    {
        if rows == 0 {
            continue;
        }
        // Judged against what the user stated, also when the floor overruled it.
        let sigma = overruled.unwrap_or(sigma);
        let off = |ratio: f64| !(1.0 / NOISE_CHECK_RATIO..=NOISE_CHECK_RATIO).contains(&ratio);
        match (drifting(drift), repeats) {
            (Some(z), _) => {
                let ratio = match repeats {
                    Some((s, _)) if stated => s / sigma,
                    _ => f64::NAN,
                };
                out.warn(Warning::RepeatsDrift { part, ratio, z });
            }
            (None, Some((s, dof))) if stated => {
                let ratio = s / sigma;
                let z = ln(ratio * ratio) / sqrt(2.0 / dof);
                if z.abs() > NOISE_CHECK_Z && off(ratio) {
                    out.warn(Warning::NoiseVsRepeats { part, ratio, z });
                }
            }
            _ => {}
        }
        if !stated {
            continue;
        }
        let dof = rows as f64 * (1.0 - p as f64 / insample.rows.max(1) as f64);
        if dof > 0.0 {
            let z = (chi2 - dof) / sqrt(2.0 * dof);
            let ratio = sqrt(chi2 / dof);
            if z < -NOISE_CHECK_Z && off(ratio) {
                out.warn(Warning::NoiseVsResiduals { part, ratio, z });
            }
        }
    }
}

/// Label of a parameter (`compliance_2`, …) for reports.
#[must_use]
pub fn param_label<const N: usize>(i: ParamIndex) -> Option<ParamId> {
    ParamId::from_index(i, N).ok()
}
