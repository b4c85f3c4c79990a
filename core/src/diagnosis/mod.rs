//! The sim-to-real gap diagnosis (spec/effects.md): **where** the residual of the geometric
//! calibration lies, **which** effect causes it, and **how far** the gap shrinks when the
//! model is extended by it.
//!
//! # Flow of [`diagnose`]
//! 1. *Groups and folds.* Rows sharing a `pose_id` (the caller's group id) form a group;
//!    groups are dealt to `k` folds by a seeded hash of their id (balanced, order-free,
//!    repeats always in the same fold).
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
//!   about Bonferroni 5 % over the 28 candidates).
//! - **Winner**: among significant candidates not significantly worse than the best one
//!   (`z(c, best) < z_equivalence`, default 3; best = least held-out total), the one with
//!   the fewest effects, then the fewest fitted parameters, then the least held-out total.
//! - **Confounded**: other significant candidates with as many effects as the winner, not
//!   significantly worse than the best nor than the winner, that reach the winner's
//!   status class (below) — they explain the data equally well; listed, never chosen at
//!   random.
//! - **Gap closed**: `(B − A)/(B − N)` clipped to [0, 1], B and A the baseline's and the
//!   winner's held-out RMS position error, `N = √3·σ_pos` (spec/effects.md). When the
//!   position shows no gap (B ≤ N) the same ratio of whitened RMS per row is used.
//! - **Status**: `explained` when the winner closes ≥ [`Config::explained_fraction`]
//!   (default 0.8) of the gap; `partially_explained` when it closes ≥
//!   [`Config::partial_fraction`] (default 0.25); otherwise, or with no significant
//!   candidate, `unexplained` (no effects).
//!
//! # Memory
//! No heap: fixed-capacity results ([`MAX_CANDIDATES`] candidates), caller slices for the
//! per-pose outputs ([`PoseDiagnosis`]), and a caller-provided [`DiagWorkspace`] of
//! capacity `P` columns (the union of all models' parameters: 71 for a 6-joint arm with
//! every effect, so `P = 80` suffices there; `P = 144` for 9 joints), which includes the
//! fixed ~110 KiB of the smooth check ([`SmoothWorkspace`]).

mod cv;
mod folds;
mod locate;
mod noise;
mod smooth;

pub use locate::{Correlate, Location, QuantityKind, RegionStats};
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
/// Models of a diagnosis: the geometric baseline (index 0) and the candidates.
pub const MAX_MODELS: usize = MAX_CANDIDATES + 1;
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
}

impl Default for Config {
    /// Estimated noise, 5 folds, all effects with their inputs and their pairs, thresholds
    /// z = 3 / 3 / 3, explained at 80 % of the gap, partial at 25 %, repeats within 0.5 °C,
    /// rank tolerance 1e-6.
    fn default() -> Self {
        Config {
            sigma_pos_m: None,
            sigma_rot_rad: None,
            folds: 5,
            fold_seed: 0x6b69_6e63_616c,
            candidates: None,
            pairs: true,
            z_gap: 3.0,
            z_significance: 3.0,
            z_equivalence: 3.0,
            explained_fraction: 0.8,
            partial_fraction: 0.25,
            repeat_temp_tol_c: 0.5,
            rank_tol: 1e-6,
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
    /// Share of the gap above the noise floor this model closes.
    pub gap_closed_fraction: f64,
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
    /// effects).
    pub heldout_final: [f64; 6],
    pub(crate) leader: u32,
    pub(crate) sub_leader: u32,
    pub(crate) sq: [f64; MAX_MODELS],
    pub(crate) gsq: [f64; MAX_MODELS],
    pub(crate) scratch: f64,
}

impl PoseDiagnosis {
    /// An empty record.
    pub const EMPTY: PoseDiagnosis = PoseDiagnosis {
        group: 0,
        fold: 0,
        residual: [0.0; 6],
        heldout_baseline: [0.0; 6],
        heldout_final: [0.0; 6],
        leader: 0,
        sub_leader: 0,
        sq: [0.0; MAX_MODELS],
        gsq: [0.0; MAX_MODELS],
        scratch: 0.0,
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
    pub pos2: f64,
    pub rot2: f64,
    pub n_pos: usize,
    pub n_rot: usize,
    pub rows: usize,
    pub expected_pos: f64,
    pub expected_rot: f64,
    pub variance: f64,
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
                pos2: 0.0,
                rot2: 0.0,
                n_pos: 0,
                n_rot: 0,
                rows: 0,
                expected_pos: 0.0,
                expected_rot: 0.0,
                variance: 0.0,
            }; MAX_MODELS],
            jac: [[0.0; 6]; MAX_MODEL_PARAMS],
            a: [[0.0; P]; 6],
            b: [0.0; 6],
            smooth: SmoothWorkspace::new(),
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
            },
            remaining: GapTest::default(),
            final_heldout_rms_pos_m: 0.0,
            final_heldout_rms_rot_rad: 0.0,
            location: Location::empty(),
            explainable: SmoothCheck::default(),
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

/// Paired z of models `a` and `b` over groups (see the module documentation): the
/// Wilcoxon signed-rank statistic of `D_g = S_g^a − S_g^b` in its normal approximation,
/// zero differences dropped, mid-ranks and the tie correction for equal |D|. Ranks are
/// counted in O(G²) (no memory); data sets have tens to hundreds of groups.
pub(crate) fn paired_z(poses: &mut [PoseDiagnosis], a: usize, b: usize) -> f64 {
    // Compact the non-zero group differences into the first slots' scratch.
    let mut g = 0;
    for l in 0..poses.len() {
        if poses[l].leader as usize != l {
            continue;
        }
        let d = poses[l].gsq[a] - poses[l].gsq[b];
        if d != 0.0 {
            poses[g].scratch = d;
            g += 1;
        }
    }
    let (mut w_plus, mut ties) = (0.0, 0.0);
    for i in 0..g {
        let x = poses[i].scratch.abs();
        let (mut below, mut equal) = (0usize, 0usize);
        for q in &poses[..g] {
            let y = q.scratch.abs();
            if y < x {
                below += 1;
            } else if y == x {
                equal += 1;
            }
        }
        if poses[i].scratch > 0.0 {
            w_plus += below as f64 + 0.5 * (equal as f64 + 1.0);
        }
        // A tie group of size t adds (t³ − t)/48 to the variance correction: (t² − 1)/48
        // from each of its t members.
        let t = equal as f64;
        ties += (t * t - 1.0) / 48.0;
    }
    if g == 0 {
        return 0.0;
    }
    let nf = g as f64;
    let mean = nf * (nf + 1.0) / 4.0;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - ties;
    if var <= 0.0 {
        return 0.0;
    }
    (w_plus - mean) / sqrt(var)
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
    }
}

/// Share of the gap closed, from the baseline's and the model's totals.
fn gap_closed(base: &ModelAcc, model: &ModelAcc, noise: &NoiseFloor) -> f64 {
    let rms = |s: f64, n: usize| if n == 0 { 0.0 } else { sqrt(s / n as f64) };
    let b = rms(base.pos2, base.n_pos);
    let a = rms(model.pos2, model.n_pos);
    let floor = noise.rms_pos_m();
    let f = if base.n_pos > 0 && b > floor {
        (b - a) / (b - floor)
    } else {
        let b = rms(base.chi2, base.rows);
        let a = rms(model.chi2, model.rows);
        if b > 1.0 { (b - a) / (b - 1.0) } else { 0.0 }
    };
    f.clamp(0.0, 1.0)
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
    };
    if gap.z < cfg.z_gap {
        v.status = Status::NoGap;
        return v;
    }
    let n = candidates.len().min(MAX_CANDIDATES);
    let cands = &mut candidates[..n];
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
    let Some(w) = (0..n).filter(|&c| eligible(&cands[c])).min_by(|&a, &b| {
        key(&cands[a])
            .cmp(&key(&cands[b]))
            .then(cands[a].heldout_chi2.total_cmp(&cands[b].heldout_chi2))
    }) else {
        return v;
    };
    let f = cands[w].gap_closed_fraction;
    let class = |f: f64| status_class(f, cfg);
    v.status = class(f);
    if v.status == Status::Unexplained {
        return v;
    }
    v.effects = cands[w].effects;
    v.gap_closed_fraction = f;
    v.candidate = Some(w);
    for c in 0..n {
        if c == w || !eligible(&cands[c]) || cands[c].effects.len() != cands[w].effects.len() {
            continue;
        }
        cands[c].z_vs_winner = paired(c, w);
        if cands[c].z_vs_winner < cfg.z_equivalence
            && class(cands[c].gap_closed_fraction) == v.status
        {
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
    check_config(cfg)?;
    let n = data.len();
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

    // 1–2. Groups, folds, noise floor.
    let n_groups = folds::assign(groups, cfg.folds, cfg.fold_seed, poses)?;
    let noise = noise::noise_floor(robot, data, poses, cfg)?;
    let (wp, wr) = (
        1.0 / (noise.sigma_pos_m * noise.sigma_pos_m),
        1.0 / (noise.sigma_rot_rad * noise.sigma_rot_rad),
    );
    let sw = [sqrt(wp), sqrt(wp), sqrt(wp), sqrt(wr), sqrt(wr), sqrt(wr)];

    // 3. Geometric calibration on all rows.
    let mut opts = IdentifyOptions::new(Algorithm::Ols, robot.geometric_param_set());
    opts.weight_pos = wp;
    opts.weight_rot = wr;
    opts.rank_tol = cfg.rank_tol;
    opts.allow_data_deficiency = true;
    // In place: a returned Identification would be a second copy in this frame.
    crate::identify::identify_in_place(robot, data, &opts, &mut ws.id, &mut out.fit)?;
    let lin = out.fit.robot;
    out.geometric = lin;
    out.model = lin;
    out.geometric_residuals = out.fit.fitted;
    out.noise = noise;
    out.groups = n_groups;
    out.folds = cfg.folds;

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
    let mut structural = [ParamSet::new(); 7];
    let mut universe = geometric;
    for e in effects.iter() {
        let mut o = opts;
        o.requested = geometric.union(&e.params(N));
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
        for i in e.params(N).iter() {
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
            for i in e.params(N).iter() {
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

    // 5a. Whitened Gram of all rows at the geometric calibration; in-sample residuals.
    ws.g_all.reset(n_u)?;
    for (l, m) in data.iter().enumerate() {
        let mut e = cv::pose_rows(&lin, m, &sw, ws)?;
        cv::fold_rows(ws, false)?;
        // Components the pose does not measure have no residual (the where-analysis and the
        // reports must not see the model's unmeasured orientation).
        for (k, v) in e.iter_mut().enumerate() {
            if !m.mask.has(k) {
                *v = 0.0;
            }
        }
        poses[l].residual = e;
    }
    // 5b. What the poses determine, per model; keep only those columns.
    for mdl in 0..=n_cand {
        let n_cols = ws.model_n[mdl];
        let mut fate = [cv::ColumnFate {
            kept: false,
            distinct: 0.0,
            partner: None,
        }; P];
        let n_kept = cv::factor(ws, mdl, false, cfg.rank_tol, Some(&mut fate[..n_cols]));
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
        let _ = n_kept;
        ws.model_n[mdl] = k;
        s.fitted_params = k;
        s.evaluated = mdl == 0 || any_effect;
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
    cv::cross_validate(
        &lin,
        data,
        &sw,
        poses,
        cfg.folds,
        &list[..n_list],
        cv::Pass::Candidates,
        cfg.rank_tol,
        ws,
    )?;

    // 6. Statistics and decision.
    for l in 0..n {
        let lead = poses[l].leader as usize;
        for mdl in 0..=n_cand {
            let s = poses[l].sq[mdl];
            poses[lead].gsq[mdl] += s;
        }
    }
    let rms = |s: f64, k: usize| if k == 0 { 0.0 } else { sqrt(s / k as f64) };
    for mdl in 0..=n_cand {
        if !score(out, mdl).evaluated {
            continue;
        }
        let acc = ws.acc[mdl];
        let improvement = if mdl > 0 {
            paired_z(poses, 0, mdl)
        } else {
            0.0
        };
        let s = score(out, mdl);
        s.heldout_rms_pos_m = rms(acc.pos2, acc.n_pos);
        s.heldout_rms_rot_rad = rms(acc.rot2, acc.n_rot);
        s.heldout_chi2 = acc.chi2;
        if mdl > 0 {
            s.improvement_z = improvement;
            s.significant = s.improvement_z > cfg.z_significance;
            s.gap_closed_fraction = gap_closed(&ws.acc[0], &acc, &noise);
        }
    }
    let gap = gap_test(&ws.acc[0], &noise);
    out.gap = gap;
    let verdict = decide(
        &mut out.candidates[..n_cand],
        |a, b| paired_z(&mut *poses, a + 1, b + 1),
        &gap,
        cfg,
    );

    // 6b. The verdict's model on all rows, and its held-out residuals, re-linearised at
    // that fit (the first pass's one Gauss–Newton step from the geometric calibration
    // leaves second-order terms of the effect's size, tens of micrometres for large frame
    // errors; from the fitted model, only those of the fold-to-fold changes remain).
    let mut verdict = verdict;
    let mut refined = false;
    if let Some(c) = verdict.candidate {
        let mdl = c + 1;
        let mut o = opts;
        o.requested = score(out, mdl).requested;
        // The fit and its analysis built in one place (no separate copies on the stack).
        let mut fit = Identification::start(&lin, o.algorithm, None);
        model_analysis(ws, mdl, score(out, mdl), cfg.rank_tol, &mut fit.analysis)?;
        crate::identify::identify_into(data, &o, &mut ws.id, &mut fit)?;
        ws.g_all.reset(n_u)?;
        for m in data {
            cv::pose_rows(&fit.robot, m, &sw, ws)?;
            cv::fold_rows(ws, false)?;
        }
        cv::cross_validate(
            &fit.robot,
            data,
            &sw,
            poses,
            cfg.folds,
            &[],
            cv::Pass::Final(mdl),
            cfg.rank_tol,
            ws,
        )?;
        let acc = ws.acc[mdl];
        let closed = gap_closed(&ws.acc[0], &acc, &noise);
        let cand = &mut out.candidates[c];
        cand.heldout_rms_pos_m = rms(acc.pos2, acc.n_pos);
        cand.heldout_rms_rot_rad = rms(acc.rot2, acc.n_rot);
        cand.heldout_chi2 = acc.chi2;
        cand.gap_closed_fraction = closed;
        verdict.gap_closed_fraction = closed;
        verdict.status = status_class(closed, cfg);
        if verdict.status != Status::Unexplained {
            out.remaining = gap_test(&acc, &noise);
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

    // 7. Where.
    out.location = locate::locate(robot, data, poses, &noise);
    // 8. Explainable at all? (library-free smooth model on the same folds.)
    out.explainable = smooth::check(robot, data, poses, &noise, &ws.acc[0], cfg, &mut ws.smooth);
    Ok(())
}

/// Label of a parameter (`compliance_2`, …) for reports.
#[must_use]
pub fn param_label<const N: usize>(i: ParamIndex) -> Option<ParamId> {
    ParamId::from_index(i, N).ok()
}
