//! The sim-to-real gap diagnosis from C (spec/effects.md, `kincal diagnose`): where the
//! geometric calibration's residual lies, which effect causes it, how far the gap shrinks.
//! A thin shell over `kincal::diagnosis::diagnose_into`; the report struct carries the
//! fields of the CLI's REPORT.json in fixed-size arrays (SI units: metres and radians where
//! REPORT.json shows mm and degrees).
//!
//! Only instrument data (`kincal_measurements`): the diagnosis of contact data
//! (targets, planes, sessions) cross-validates by session in the CLI and is not in the ABI.

use core::ffi::{CStr, c_char, c_void};

use kincal::diagnosis::{
    BeyondLibrary, Config, DiagWorkspace, Diagnosis, GapTest, MAX_CANDIDATES, MAX_SUSPECTS,
    MAX_WARNINGS, Method, ModelScore, Part, PoseDiagnosis, Reason, SmoothCheck, Status, Warning,
    diagnose_into,
};
use kincal::identify::Measurement;
use kincal::{Effect, EffectSet, Robot, with_any_robot};

use crate::identify::{Data, KINCAL_WORKSPACE_ALIGN, data_view, kincal_measurements, round_up};
use crate::robot::{KINCAL_MAX_PARAMS, from_robot, kincal_robot, to_any};
use crate::status::{FfiResult, KINCAL_NO_INDEX, kincal_error, kincal_status};

/// Candidate models a report lists at most: every effect alone and every pair (7 + 21).
pub const KINCAL_DIAG_MAX_CANDIDATES: usize = 28;
/// Suspect rows (gross outliers) a report lists at most.
pub const KINCAL_DIAG_MAX_SUSPECTS: usize = 64;
/// Warnings a report lists at most.
pub const KINCAL_DIAG_MAX_WARNINGS: usize = 8;
const _: () = assert!(KINCAL_DIAG_MAX_CANDIDATES == MAX_CANDIDATES);
const _: () = assert!(KINCAL_DIAG_MAX_SUSPECTS == MAX_SUSPECTS);
const _: () = assert!(KINCAL_DIAG_MAX_WARNINGS == MAX_WARNINGS);

/// Parameter columns the diagnosis workspace holds (the union of all models: every
/// parameter of a 9-joint robot).
const DIAG_P: usize = KINCAL_MAX_PARAMS;

/// The verdict's status (REPORT.json `verdict.status`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_status {
    /// `no_gap`: the geometric model is already at the noise floor.
    NoGap = 0,
    /// `explained`: the verdict's effects close most of the gap and what remains is noise.
    Explained = 1,
    /// `partially_explained`: a significant but smaller share, or a remaining gap.
    PartiallyExplained = 2,
    /// `unexplained`: a gap no candidate closes significantly.
    Unexplained = 3,
}

/// How the candidates were judged (REPORT.json `method`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_method {
    /// `cross_validation`: k-fold on held-out pose groups.
    CrossValidation = 0,
    /// `in_sample_nested`: too few pose groups; likelihood-ratio test with the noise floor.
    InSampleNested = 1,
}

/// Why the status (REPORT.json `verdict.reason`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_reason {
    /// `at_noise_floor`.
    AtNoiseFloor = 0,
    /// `closed`.
    Closed = 1,
    /// `remaining_gap` (`reason_z`, `reason_part`).
    RemainingGap = 2,
    /// `remaining_structure` (`reason_z`: the smooth model's paired z).
    RemainingStructure = 3,
    /// `worsens` (`reason_z` negative, `reason_part`).
    Worsens = 4,
    /// `small_share`.
    SmallShare = 5,
    /// `no_significant_candidate`.
    NoSignificantCandidate = 6,
    /// `does_not_extrapolate` (`reason_z`: the worst half-range split's z; `reason_joint`).
    DoesNotExtrapolate = 7,
    /// `form_not_determined` (`reason_z`: the out-of-library alternative's paired z, below
    /// the equivalence threshold: the library's form is not singled out by the data;
    /// `reason_effects`: whose form).
    FormNotDetermined = 8,
    /// `confounded_with_sessions`: the candidates that improve significantly are all
    /// confounded with the sessions (the C ABI diagnoses one session: not produced there).
    ConfoundedWithSessions = 9,
}

/// Position, rotation or both (`reason_part`, warning `part`); 0 = not applicable.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_part {
    /// Not applicable.
    None = 0,
    /// Position rows.
    Position = 1,
    /// Rotation rows.
    Rotation = 2,
    /// Both.
    Both = 3,
}

/// What lies beyond the library (REPORT.json `verdict.beyond_library`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_beyond_library {
    /// `not_applicable`: no open gap, or the check did not run.
    NotApplicable = 0,
    /// `smooth_effect`: a smooth function of q closes more (`beyond_library_share`).
    SmoothEffect = 1,
    /// `not_a_function_of_q`.
    NotAFunctionOfQ = 2,
}

/// Warning codes (REPORT.json `warnings[].code`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_warning_code {
    /// `noise_vs_repeats`: the repeats scatter `ratio` × the stated σ (`z`, `part`).
    NoiseVsRepeats = 1,
    /// `noise_vs_residuals`: the residuals are below the stated σ, √(χ²/dof) = `ratio`.
    NoiseVsResiduals = 2,
    /// `gap_despite_gap_test`: no gap by the gap test (`z_gap`) but a candidate improves
    /// significantly (`z_candidate`).
    GapDespiteGapTest = 3,
    /// `too_many_suspects`: `count` rows failed the outlier test; none excluded.
    TooManySuspects = 4,
    /// `repeats_drift`: the repeats' differences follow the order of the rows (serial `z`,
    /// `part`; `ratio` their σ over the stated one, NaN when none was stated): the stated
    /// σ stays the floor.
    RepeatsDrift = 5,
}

/// Which code `kincal_diagnosis_name` names.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_diagnosis_name_kind {
    /// A `kincal_diagnosis_status`.
    Status = 0,
    /// A `kincal_diagnosis_reason`.
    Reason = 1,
    /// A `kincal_diagnosis_part`.
    Part = 2,
    /// A `kincal_diagnosis_warning_code`.
    Warning = 3,
    /// A `kincal_diagnosis_method`.
    Method = 4,
    /// A `kincal_beyond_library`.
    BeyondLibrary = 5,
}

/// Options of `kincal_diagnose`; fill with `kincal_diagnose_options_default`, then edit.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_diagnose_options {
    /// Stated position noise, 1σ per axis [m]; NaN: estimate from repeats.
    pub sigma_pos_m: f64,
    /// Stated rotation noise, 1σ per axis [rad]; NaN: estimate from repeats.
    pub sigma_rot_rad: f64,
    /// Cross-validation folds (≥ 2; default 5).
    pub folds: u32,
    /// Non-zero: also evaluate every pair of candidate effects (default 1).
    pub pairs: u32,
    /// Seed of the fold assignment.
    pub fold_seed: u64,
    /// Candidate effects (mask of `kincal_effect` bits); 0: every effect whose inputs all
    /// rows carry (default).
    pub candidates: u32,
    /// Cross-validation needs this many pose groups per fold (default 5), else the
    /// in-sample nested test.
    pub min_groups_per_fold: u32,
    /// Non-zero: screen gross outliers first (default 1).
    pub screen_outliers: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Threshold of the gap test (one-sided z, default 3).
    pub z_gap: f64,
    /// Threshold of a candidate's improvement (default 3).
    pub z_significance: f64,
    /// "Not significantly worse" below this paired z (default 3).
    pub z_equivalence: f64,
    /// Share of the gap closed for `explained` (default 0.8).
    pub explained_fraction: f64,
    /// Share for `partially_explained` (default 0.25).
    pub partial_fraction: f64,
    /// Repeats within this temperature difference [°C] are the same conditions (0.5).
    pub repeat_temp_tol_c: f64,
    /// Rank tolerance of the identifiability tests (default 1e-6).
    pub rank_tol: f64,
}

/// The gap test of a model's held-out errors against the noise floor.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_gap_test {
    /// Observed over expected whitened held-out total, Q/E.
    pub ratio: f64,
    /// z of ln(Q/E).
    pub z: f64,
    /// Held-out RMS position error expected at the noise floor [m].
    pub expected_rms_pos_m: f64,
    /// Held-out RMS rotation angle expected at the noise floor [rad].
    pub expected_rms_rot_rad: f64,
    /// The test on the position rows alone (0 without).
    pub z_pos: f64,
    /// The test on the rotation rows alone (0 without).
    pub z_rot: f64,
}

/// One model's score (REPORT.json `candidates[]`, `baseline`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_model_score {
    /// Effects of the model (mask of `kincal_effect` bits; 0 for the baseline).
    pub effects: u32,
    /// Non-zero: evaluated (0: no effect parameter separable from the geometry,
    /// `confounded_with_geometry`).
    pub evaluated: u32,
    /// Non-zero: significantly better than the geometric model.
    pub significant: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Parameters fitted.
    pub fitted_params: usize,
    /// Held-out RMS position error [m].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle [rad].
    pub heldout_rms_rot_rad: f64,
    /// Whitened held-out total.
    pub heldout_chi2: f64,
    /// Paired z of the improvement over the baseline.
    pub improvement_z: f64,
    /// Paired z against the best candidate (positive: worse).
    pub z_vs_best: f64,
    /// Paired z against the winner.
    pub z_vs_winner: f64,
    /// Paired z of the improvement in position alone (negative: worse).
    pub z_pos: f64,
    /// The same in rotation alone.
    pub z_rot: f64,
    /// Share of the position gap closed.
    pub gap_closed_fraction: f64,
    /// Share of the rotation gap closed.
    pub gap_closed_rot_fraction: f64,
    /// Whitened share (position and rotation): what the status is decided on.
    pub gap_closed_total_fraction: f64,
    /// How distinct the effect's columns are from the geometry (smallest sine).
    pub distinctness: f64,
}

/// The library-free smooth check (REPORT.json `explainable`, `remaining_structure`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_smooth_check {
    /// Non-zero: the check ran.
    pub evaluated: u32,
    /// Non-zero: `z` exceeds the significance threshold.
    pub significant: u32,
    /// Share of the held-out gap a smooth function of q removes (whitened), in [0, 1].
    pub share_of_gap: f64,
    /// The same on the position RMS.
    pub share_pos: f64,
    /// The same on the rotation RMS.
    pub share_rot: f64,
    /// Held-out RMS position error after the smooth correction [m].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle after it [rad].
    pub heldout_rms_rot_rad: f64,
    /// Paired z against the geometric model (positive: better).
    pub z: f64,
}

/// The noise floor used (REPORT.json `noise_floor`). A component type no row measures and
/// whose σ was not stated (position-only data: the orientation) has no noise floor:
/// `measured_*` and `stated_*` are both 0 and its σ and degrees of freedom are 0 (REPORT.json
/// `"not_measured"`, null), never a placeholder.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_noise_floor {
    /// Position noise, 1σ per axis [m]; 0 when not measured (see `measured_pos`).
    pub sigma_pos_m: f64,
    /// Rotation noise, 1σ per axis [rad]; 0 when not measured (see `measured_rot`).
    pub sigma_rot_rad: f64,
    /// Degrees of freedom of the position estimate (infinity when stated, 0 when not
    /// measured).
    pub dof_pos: f64,
    /// Degrees of freedom of the rotation estimate (infinity when stated, 0 when not
    /// measured).
    pub dof_rot: f64,
    /// Repeat subgroups in the data.
    pub repeat_subgroups: usize,
    /// Non-zero: σ_pos was stated (else from repeats).
    pub stated_pos: u32,
    /// Non-zero: σ_rot was stated.
    pub stated_rot: u32,
    /// Non-zero: some row measures a position component. 0 with `stated_pos` 0: position
    /// not measured, no position noise floor.
    pub measured_pos: u32,
    /// Non-zero: some row measures an orientation component. 0 with `stated_rot` 0:
    /// orientation not measured (position-only data), no orientation noise floor; the
    /// report's rotation RMS values are then 0.
    pub measured_rot: u32,
    /// σ per axis the repeats alone give [m] (NaN without repeats).
    pub repeats_pos_m: f64,
    /// Its degrees of freedom (0 without).
    pub repeats_pos_dof: f64,
    /// σ per axis of the rotation repeats [rad] (NaN without).
    pub repeats_rot_rad: f64,
    /// Its degrees of freedom.
    pub repeats_rot_dof: f64,
    /// Non-zero: the stated σ_pos was overruled by noisier repeats (the floor uses them).
    pub overruled_pos: u32,
    /// Non-zero: the stated σ_rot was overruled.
    pub overruled_rot: u32,
    /// The overruled stated σ_pos [m] (NaN when not overruled).
    pub overruled_pos_m: f64,
    /// The overruled stated σ_rot [rad] (NaN when not overruled).
    pub overruled_rot_rad: f64,
}

/// A warning (REPORT.json `warnings[]`); the fields its code documents are set, the others 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_diagnosis_warning {
    /// A `kincal_diagnosis_warning_code`.
    pub code: u32,
    /// A `kincal_diagnosis_part`.
    pub part: u32,
    /// Ratio (noise warnings).
    pub ratio: f64,
    /// z (noise warnings).
    pub z: f64,
    /// The baseline's gap-test z (`gap_despite_gap_test`).
    pub z_gap: f64,
    /// The best candidate's improvement z (`gap_despite_gap_test`).
    pub z_candidate: f64,
    /// Rows that failed the outlier test (`too_many_suspects`).
    pub count: usize,
}

/// Everything `kincal_diagnose` found: the fields of REPORT.json (`where`, per-pose rows,
/// files and settings aside), in SI units.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_diagnosis_report {
    /// A `kincal_diagnosis_status`.
    pub status: u32,
    /// A `kincal_diagnosis_method` (`in_sample_nested` with too few pose groups).
    pub method: u32,
    /// A `kincal_diagnosis_reason`.
    pub reason: u32,
    /// Where the remaining gap lies or what gets worse (a `kincal_diagnosis_part`).
    pub reason_part: u32,
    /// The z of the reason (remaining gap, remaining structure, worsening, extrapolation,
    /// form check); NaN otherwise.
    pub reason_z: f64,
    /// For `does_not_extrapolate`: the joint (zero-based) whose half range was held out;
    /// `KINCAL_NO_INDEX` otherwise.
    pub reason_joint: usize,
    /// For `form_not_determined`: the effect whose form the data do not determine
    /// (`joint_cyclic` or `thermal`, as a mask of `kincal_effect` bits); 0 otherwise.
    pub reason_effects: u32,
    /// The verdict's effects (the winner; mask of `kincal_effect` bits; 0 for none).
    pub effects: u32,
    /// Union of the effects of every confounded candidate (REPORT.json `confounded_with`).
    pub confounded_effects: u32,
    /// The winner's index in `candidates`, or `KINCAL_NO_INDEX`.
    pub winner: usize,
    /// Candidates that explain the data as well as the winner (first `n_confounded` of
    /// `confounded_with`, each an effect mask).
    pub n_confounded: usize,
    /// The confounded candidates.
    pub confounded_with: [u32; KINCAL_DIAG_MAX_CANDIDATES],
    /// Share of the position gap closed.
    pub gap_closed_fraction: f64,
    /// Share of the rotation gap closed.
    pub gap_closed_rot_fraction: f64,
    /// Whitened share (position and rotation): the status's share.
    pub gap_closed_total_fraction: f64,
    /// Held-out RMS position error of the verdict's model [m].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle of the verdict's model [rad]; 0 (like every rotation
    /// RMS of the report) when no row measures the orientation (`noise.measured_rot` 0).
    pub heldout_rms_rot_rad: f64,
    /// The gap test of what remains (z, z_pos, z_rot).
    pub remaining: kincal_gap_test,
    /// Non-zero: the remaining gap test exceeds `z_gap`.
    pub remaining_gap_significant: u32,
    /// A `kincal_beyond_library`.
    pub beyond_library: u32,
    /// Share a smooth function of q closes when `beyond_library` is `smooth_effect`, else
    /// NaN.
    pub beyond_library_share: f64,
    /// Held-out RMS of what remains per axis (x, y, z [m], rx, ry, rz [rad]).
    pub remaining_rms_axis: [f64; 6],
    /// "Explainable at all?": the smooth check on the baseline's held-out residuals.
    pub explainable: kincal_smooth_check,
    /// The same check on the verdict's held-out residuals (run when it would be explained).
    pub remaining_structure: kincal_smooth_check,
    /// The noise floor used.
    pub noise: kincal_noise_floor,
    /// The geometric model's score.
    pub baseline: kincal_model_score,
    /// The geometric model's gap test.
    pub gap: kincal_gap_test,
    /// In-sample RMS position error of the geometric calibration [m].
    pub insample_rms_pos_m: f64,
    /// In-sample RMS rotation angle of the geometric calibration [rad].
    pub insample_rms_rot_rad: f64,
    /// Number of candidates (singles in `kincal_effect` order, then pairs).
    pub n_candidates: usize,
    /// The candidates.
    pub candidates: [kincal_model_score; KINCAL_DIAG_MAX_CANDIDATES],
    /// Number of suspect rows (gross outliers excluded from every fit and test).
    pub n_suspects: usize,
    /// Suspect rows (zero-based indices into the data, ascending).
    pub suspects: [usize; KINCAL_DIAG_MAX_SUSPECTS],
    /// Number of warnings.
    pub n_warnings: usize,
    /// The warnings.
    pub warnings: [kincal_diagnosis_warning; KINCAL_DIAG_MAX_WARNINGS],
    /// Distinct pose groups.
    pub groups: usize,
    /// Folds used.
    pub folds: usize,
}

/// Per-pose outputs of `kincal_diagnose` (REPORT.json `where.per_pose`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_pose_diagnosis {
    /// The pose's group id.
    pub group: u32,
    /// Its cross-validation fold.
    pub fold: u32,
    /// Non-zero: a suspect row (excluded).
    pub suspect: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Residual of the geometric calibration on all rows `[Δp (m); Δφ (rad)]`; 0 in the
    /// components the pose does not measure (its `masks` bits).
    pub residual: [f64; 6],
    /// Held-out residual of the geometric model.
    pub heldout_baseline: [f64; 6],
    /// Held-out residual of the verdict's model.
    pub heldout_final: [f64; 6],
}

fn config_of(c: &Config) -> kincal_diagnose_options {
    kincal_diagnose_options {
        sigma_pos_m: c.sigma_pos_m.unwrap_or(f64::NAN),
        sigma_rot_rad: c.sigma_rot_rad.unwrap_or(f64::NAN),
        folds: u32::try_from(c.folds).unwrap_or(5),
        pairs: u32::from(c.pairs),
        fold_seed: c.fold_seed,
        candidates: c.candidates.map_or(0, |s| u32::from(s.bits())),
        min_groups_per_fold: u32::try_from(c.min_groups_per_fold).unwrap_or(5),
        screen_outliers: u32::from(c.screen_outliers),
        reserved: 0,
        z_gap: c.z_gap,
        z_significance: c.z_significance,
        z_equivalence: c.z_equivalence,
        explained_fraction: c.explained_fraction,
        partial_fraction: c.partial_fraction,
        repeat_temp_tol_c: c.repeat_temp_tol_c,
        rank_tol: c.rank_tol,
    }
}

/// Default diagnosis options (those of `kincal diagnose`): noise from repeats, 5 folds, all
/// candidates whose inputs the rows carry, pairs, z thresholds 3/3/3, explained at 80 %,
/// partial at 25 %, outlier screening on. Returns OK or NULL_POINTER / MISALIGNED_POINTER.
///
/// # Safety
/// `opts_out` NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_diagnose_options_default(
    opts_out: *mut kincal_diagnose_options,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(opts_out);
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(config_of(&Config::default())) };
        Ok(())
    })
}

fn sigma(v: f64, name: &'static core::ffi::CStr) -> FfiResult<Option<f64>> {
    if v.is_nan() {
        Ok(None)
    } else if v.is_finite() && v > 0.0 {
        Ok(Some(v))
    } else {
        Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(name)
            .value(v))
    }
}

fn config(o: &kincal_diagnose_options) -> FfiResult<Config> {
    let candidates = if o.candidates == 0 {
        None
    } else {
        Some(crate::effects::effect_set(o.candidates).map_err(|e| e.arg(c"opts->candidates"))?)
    };
    for (v, name) in [
        (o.z_gap, c"opts->z_gap"),
        (o.z_significance, c"opts->z_significance"),
        (o.z_equivalence, c"opts->z_equivalence"),
        (o.explained_fraction, c"opts->explained_fraction"),
        (o.partial_fraction, c"opts->partial_fraction"),
        (o.repeat_temp_tol_c, c"opts->repeat_temp_tol_c"),
        (o.rank_tol, c"opts->rank_tol"),
    ] {
        crate::args::finite(&[v], name)?;
    }
    if o.folds < 2 {
        return Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"opts->folds")
            .value(f64::from(o.folds)));
    }
    if !(o.rank_tol > 0.0 && o.rank_tol < 1.0) {
        return Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"opts->rank_tol")
            .value(o.rank_tol));
    }
    Ok(Config {
        sigma_pos_m: sigma(o.sigma_pos_m, c"opts->sigma_pos_m")?,
        sigma_rot_rad: sigma(o.sigma_rot_rad, c"opts->sigma_rot_rad")?,
        folds: o.folds as usize,
        fold_seed: o.fold_seed,
        candidates,
        pairs: o.pairs != 0,
        effect_params: None,
        z_gap: o.z_gap,
        z_significance: o.z_significance,
        z_equivalence: o.z_equivalence,
        explained_fraction: o.explained_fraction,
        partial_fraction: o.partial_fraction,
        repeat_temp_tol_c: o.repeat_temp_tol_c,
        rank_tol: o.rank_tol,
        min_groups_per_fold: o.min_groups_per_fold as usize,
        screen_outliers: o.screen_outliers != 0,
        session_sin_max: Config::default().session_sin_max,
    })
}

/// Byte offsets of the workspace: DiagWorkspace, measurements, per-pose records, group
/// ids, result.
struct Layout {
    meas: usize,
    poses: usize,
    ids: usize,
    result: usize,
    total: usize,
}

fn layout<const N: usize>(n_poses: usize) -> Option<Layout> {
    let a = KINCAL_WORKSPACE_ALIGN;
    let after = |off: usize, size: usize| -> Option<usize> {
        Some(round_up(off.checked_add(n_poses.checked_mul(size)?)?, a))
    };
    let meas = round_up(core::mem::size_of::<DiagWorkspace<DIAG_P>>(), a);
    let poses = after(meas, core::mem::size_of::<Measurement<N>>())?;
    let ids = after(poses, core::mem::size_of::<PoseDiagnosis>())?;
    let result = after(ids, core::mem::size_of::<u32>())?;
    let total = round_up(result.checked_add(core::mem::size_of::<Diagnosis<N>>())?, a);
    Some(Layout {
        meas,
        poses,
        ids,
        result,
        total,
    })
}

const _: () = assert!(core::mem::align_of::<DiagWorkspace<DIAG_P>>() <= KINCAL_WORKSPACE_ALIGN);
const _: () = assert!(core::mem::align_of::<PoseDiagnosis>() <= KINCAL_WORKSPACE_ALIGN);
const _: () = assert!(core::mem::align_of::<Diagnosis<9>>() <= KINCAL_WORKSPACE_ALIGN);

fn workspace_size(n_joints: usize, n_poses: usize) -> Option<usize> {
    match n_joints {
        1 => layout::<1>(n_poses),
        2 => layout::<2>(n_poses),
        3 => layout::<3>(n_poses),
        4 => layout::<4>(n_poses),
        5 => layout::<5>(n_poses),
        6 => layout::<6>(n_poses),
        7 => layout::<7>(n_poses),
        8 => layout::<8>(n_poses),
        9 => layout::<9>(n_poses),
        _ => None,
    }
    .map(|l| l.total)
}

/// Bytes of caller memory `kincal_diagnose` needs for `n_poses` measurements of an
/// `n_joints` robot (the diagnosis workspace, about 2.54 MB, plus about 2.1 KB per pose and the
/// result). Returns 0 for an invalid joint count or an overflowing size.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_diagnose_workspace_size(n_joints: usize, n_poses: usize) -> usize {
    ffi_boundary!(on_panic = 0; { workspace_size(n_joints, n_poses).unwrap_or(0) })
}

fn mask(s: EffectSet) -> u32 {
    u32::from(s.bits())
}

fn gap(g: &GapTest) -> kincal_gap_test {
    kincal_gap_test {
        ratio: g.ratio,
        z: g.z,
        expected_rms_pos_m: g.expected_rms_pos_m,
        expected_rms_rot_rad: g.expected_rms_rot_rad,
        z_pos: g.z_pos,
        z_rot: g.z_rot,
    }
}

fn score(m: &ModelScore) -> kincal_model_score {
    kincal_model_score {
        effects: mask(m.effects),
        evaluated: u32::from(m.evaluated),
        significant: u32::from(m.significant),
        reserved: 0,
        fitted_params: m.fitted_params,
        heldout_rms_pos_m: m.heldout_rms_pos_m,
        heldout_rms_rot_rad: m.heldout_rms_rot_rad,
        heldout_chi2: m.heldout_chi2,
        improvement_z: m.improvement_z,
        z_vs_best: m.z_vs_best,
        z_vs_winner: m.z_vs_winner,
        z_pos: m.z_pos,
        z_rot: m.z_rot,
        gap_closed_fraction: m.gap_closed_fraction,
        gap_closed_rot_fraction: m.gap_closed_rot_fraction,
        gap_closed_total_fraction: m.gap_closed_total_fraction,
        distinctness: m.distinctness,
    }
}

fn smooth(s: &SmoothCheck) -> kincal_smooth_check {
    kincal_smooth_check {
        evaluated: u32::from(s.evaluated),
        significant: u32::from(s.significant),
        share_of_gap: s.share_of_gap,
        share_pos: s.share_pos,
        share_rot: s.share_rot,
        heldout_rms_pos_m: s.heldout_rms_pos_m,
        heldout_rms_rot_rad: s.heldout_rms_rot_rad,
        z: s.z,
    }
}

// The C codes of the core's enums: the report and `kincal_diagnosis_name` both map through
// these, so a name always belongs to the code the report gives.

const fn status_code(s: Status) -> kincal_diagnosis_status {
    match s {
        Status::NoGap => kincal_diagnosis_status::NoGap,
        Status::Explained => kincal_diagnosis_status::Explained,
        Status::PartiallyExplained => kincal_diagnosis_status::PartiallyExplained,
        Status::Unexplained => kincal_diagnosis_status::Unexplained,
    }
}

const fn method_code(m: Method) -> kincal_diagnosis_method {
    match m {
        Method::CrossValidation => kincal_diagnosis_method::CrossValidation,
        Method::InSampleNested => kincal_diagnosis_method::InSampleNested,
    }
}

const fn reason_code(r: Reason) -> kincal_diagnosis_reason {
    match r {
        Reason::AtNoiseFloor => kincal_diagnosis_reason::AtNoiseFloor,
        Reason::Closed => kincal_diagnosis_reason::Closed,
        Reason::RemainingGap { .. } => kincal_diagnosis_reason::RemainingGap,
        Reason::RemainingStructure { .. } => kincal_diagnosis_reason::RemainingStructure,
        Reason::Worsens { .. } => kincal_diagnosis_reason::Worsens,
        Reason::SmallShare => kincal_diagnosis_reason::SmallShare,
        Reason::NoSignificantCandidate => kincal_diagnosis_reason::NoSignificantCandidate,
        Reason::DoesNotExtrapolate { .. } => kincal_diagnosis_reason::DoesNotExtrapolate,
        Reason::FormNotDetermined { .. } => kincal_diagnosis_reason::FormNotDetermined,
        Reason::ConfoundedWithSessions => kincal_diagnosis_reason::ConfoundedWithSessions,
    }
}

const fn part_code(p: Part) -> kincal_diagnosis_part {
    match p {
        Part::Position => kincal_diagnosis_part::Position,
        Part::Rotation => kincal_diagnosis_part::Rotation,
        Part::Both => kincal_diagnosis_part::Both,
    }
}

const fn beyond_code(b: BeyondLibrary) -> kincal_beyond_library {
    match b {
        BeyondLibrary::NotApplicable => kincal_beyond_library::NotApplicable,
        BeyondLibrary::SmoothEffect { .. } => kincal_beyond_library::SmoothEffect,
        BeyondLibrary::NotAFunctionOfQ => kincal_beyond_library::NotAFunctionOfQ,
    }
}

const fn warning_code(w: Warning) -> kincal_diagnosis_warning_code {
    match w {
        Warning::NoiseVsRepeats { .. } => kincal_diagnosis_warning_code::NoiseVsRepeats,
        Warning::NoiseVsResiduals { .. } => kincal_diagnosis_warning_code::NoiseVsResiduals,
        Warning::GapDespiteGapTest { .. } => kincal_diagnosis_warning_code::GapDespiteGapTest,
        Warning::TooManySuspects { .. } => kincal_diagnosis_warning_code::TooManySuspects,
        Warning::RepeatsDrift { .. } => kincal_diagnosis_warning_code::RepeatsDrift,
    }
}

/// `s` and a NUL, for a `const` (its length `N` is `s.len() + 1`; a wrong `N` fails the build).
#[allow(clippy::indexing_slicing)] // evaluated at compile time only: no runtime panic path
const fn nul_terminated<const N: usize>(s: &str) -> [u8; N] {
    let b = s.as_bytes();
    assert!(N == b.len() + 1);
    let mut out = [0; N];
    let mut i = 0;
    while i < b.len() {
        out[i] = b[i];
        i += 1;
    }
    out
}

/// A name-table entry: the C code of the core value `$v` (through `$code`, as in the report)
/// and the core's name of it (`$v.$name()`) as a C string built at compile time, so that the
/// C text is the core's text and not a copy of it.
macro_rules! core_name {
    ($code:ident, $v:expr, $name:ident) => {{
        const NAME: &str = $v.$name();
        const BYTES: [u8; NAME.len() + 1] = nul_terminated(NAME);
        const ENTRY: (u32, &CStr) = (
            $code($v) as u32,
            match CStr::from_bytes_with_nul(&BYTES) {
                Ok(c) => c,
                Err(_) => panic!("a core name holds a NUL"),
            },
        );
        ENTRY
    }};
}

/// Codes and names of one `kincal_diagnosis_name_kind`.
type Names = &'static [(u32, &'static CStr)];

const STATUS_NAMES: Names = &[
    core_name!(status_code, Status::NoGap, name),
    core_name!(status_code, Status::Explained, name),
    core_name!(status_code, Status::PartiallyExplained, name),
    core_name!(status_code, Status::Unexplained, name),
];

const REASON_NAMES: Names = &[
    core_name!(reason_code, Reason::AtNoiseFloor, name),
    core_name!(reason_code, Reason::Closed, name),
    core_name!(
        reason_code,
        Reason::RemainingGap {
            z: 0.0,
            part: Part::Both
        },
        name
    ),
    core_name!(reason_code, Reason::RemainingStructure { z: 0.0 }, name),
    core_name!(
        reason_code,
        Reason::Worsens {
            z: 0.0,
            part: Part::Both
        },
        name
    ),
    core_name!(reason_code, Reason::SmallShare, name),
    core_name!(reason_code, Reason::NoSignificantCandidate, name),
    core_name!(
        reason_code,
        Reason::DoesNotExtrapolate {
            z: 0.0,
            joint: 0,
            upper: false
        },
        name
    ),
    core_name!(
        reason_code,
        Reason::FormNotDetermined {
            z: 0.0,
            effect: Effect::JointCyclic
        },
        name
    ),
    core_name!(reason_code, Reason::ConfoundedWithSessions, name),
];

const PART_NAMES: Names = &[
    (kincal_diagnosis_part::None as u32, c""),
    core_name!(part_code, Part::Position, name),
    core_name!(part_code, Part::Rotation, name),
    core_name!(part_code, Part::Both, name),
];

const WARNING_NAMES: Names = &[
    core_name!(
        warning_code,
        Warning::NoiseVsRepeats {
            part: Part::Both,
            ratio: 0.0,
            z: 0.0
        },
        code
    ),
    core_name!(
        warning_code,
        Warning::NoiseVsResiduals {
            part: Part::Both,
            ratio: 0.0,
            z: 0.0
        },
        code
    ),
    core_name!(
        warning_code,
        Warning::GapDespiteGapTest {
            z_gap: 0.0,
            z_candidate: 0.0
        },
        code
    ),
    core_name!(
        warning_code,
        Warning::TooManySuspects { count: 0, cap: 0 },
        code
    ),
    core_name!(
        warning_code,
        Warning::RepeatsDrift {
            part: Part::Both,
            ratio: 0.0,
            z: 0.0
        },
        code
    ),
];

const METHOD_NAMES: Names = &[
    core_name!(method_code, Method::CrossValidation, name),
    core_name!(method_code, Method::InSampleNested, name),
];

const BEYOND_NAMES: Names = &[
    core_name!(beyond_code, BeyondLibrary::NotApplicable, name),
    core_name!(
        beyond_code,
        BeyondLibrary::SmoothEffect { share: 0.0 },
        name
    ),
    core_name!(beyond_code, BeyondLibrary::NotAFunctionOfQ, name),
];

/// The public name of code `code` of the diagnosis enum `kind` (a
/// `kincal_diagnosis_name_kind`): the string REPORT.json shows, e.g. `"partially_explained"`
/// for (STATUS, `KINCAL_DIAGNOSIS_STATUS_PARTIALLY_EXPLAINED`) or `"repeats_drift"` for
/// (WARNING, `KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT`); `""` for
/// `KINCAL_DIAGNOSIS_PART_NONE`. The text is the Rust library's own, so C callers need no
/// table of their own. A static NUL-terminated string (never free it), or NULL for an unknown
/// kind or code.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_diagnosis_name(kind: u32, code: u32) -> *const c_char {
    ffi_boundary!(on_panic = core::ptr::null(); {
        [
            (kincal_diagnosis_name_kind::Status, STATUS_NAMES),
            (kincal_diagnosis_name_kind::Reason, REASON_NAMES),
            (kincal_diagnosis_name_kind::Part, PART_NAMES),
            (kincal_diagnosis_name_kind::Warning, WARNING_NAMES),
            (kincal_diagnosis_name_kind::Method, METHOD_NAMES),
            (kincal_diagnosis_name_kind::BeyondLibrary, BEYOND_NAMES),
        ]
        .into_iter()
        .find(|(k, _)| *k as u32 == kind)
        .and_then(|(_, names)| names.iter().find(|(c, _)| *c == code))
        .map_or(core::ptr::null(), |(_, name)| name.as_ptr())
    })
}

fn part(p: Part) -> u32 {
    part_code(p) as u32
}

fn warning(w: &Warning) -> kincal_diagnosis_warning {
    let mut out = kincal_diagnosis_warning {
        code: warning_code(*w) as u32,
        ..kincal_diagnosis_warning::default()
    };
    match *w {
        Warning::NoiseVsRepeats { part: p, ratio, z }
        | Warning::NoiseVsResiduals { part: p, ratio, z }
        | Warning::RepeatsDrift { part: p, ratio, z } => {
            out.part = part(p);
            out.ratio = ratio;
            out.z = z;
        }
        Warning::GapDespiteGapTest { z_gap, z_candidate } => {
            out.z_gap = z_gap;
            out.z_candidate = z_candidate;
        }
        Warning::TooManySuspects { count, .. } => out.count = count,
    }
    out
}

/// The C report of a diagnosis.
pub(crate) fn report_of<const N: usize>(d: &Diagnosis<N>, cfg: &Config) -> kincal_diagnosis_report {
    let v = &d.verdict;
    let winner = v.candidate.and_then(|c| d.candidates().get(c));
    let reason_joint = match v.reason {
        Reason::DoesNotExtrapolate { joint, .. } => joint,
        _ => KINCAL_NO_INDEX,
    };
    let reason_effects = match v.reason {
        Reason::FormNotDetermined { effect, .. } => mask(EffectSet::of(effect)),
        _ => 0,
    };
    let (reason_part, reason_z) = match v.reason {
        Reason::RemainingGap { z, part: p } | Reason::Worsens { z, part: p } => (part(p), z),
        Reason::RemainingStructure { z }
        | Reason::DoesNotExtrapolate { z, .. }
        | Reason::FormNotDetermined { z, .. } => (0, z),
        Reason::AtNoiseFloor
        | Reason::Closed
        | Reason::SmallShare
        | Reason::NoSignificantCandidate
        | Reason::ConfoundedWithSessions => (0, f64::NAN),
    };
    let beyond = d.beyond_library();
    let beyond_share = match beyond {
        BeyondLibrary::SmoothEffect { share } => share,
        BeyondLibrary::NotApplicable | BeyondLibrary::NotAFunctionOfQ => f64::NAN,
    };
    let n = &d.noise;
    // A component type no row measures, with no σ stated, has only the core's placeholder
    // σ (it weighs nothing): the report says 0 and `measured_*` = 0 instead.
    let (known_pos, known_rot) = (
        n.measured_pos || n.stated_pos,
        n.measured_rot || n.stated_rot,
    );
    let known = |v: f64, known: bool| if known { v } else { 0.0 };
    let mut out = kincal_diagnosis_report {
        status: status_code(v.status) as u32,
        method: method_code(d.method) as u32,
        reason: reason_code(v.reason) as u32,
        reason_part,
        reason_z,
        reason_joint,
        reason_effects,
        effects: mask(v.effects),
        confounded_effects: mask(v.confounded_effects()),
        winner: v.candidate.unwrap_or(KINCAL_NO_INDEX),
        n_confounded: v.confounded().len(),
        confounded_with: [0; KINCAL_DIAG_MAX_CANDIDATES],
        gap_closed_fraction: v.gap_closed_fraction,
        gap_closed_rot_fraction: winner.map_or(0.0, |c| c.gap_closed_rot_fraction),
        gap_closed_total_fraction: winner.map_or(0.0, |c| c.gap_closed_total_fraction),
        heldout_rms_pos_m: d.final_heldout_rms_pos_m,
        heldout_rms_rot_rad: d.final_heldout_rms_rot_rad,
        remaining: gap(&d.remaining),
        remaining_gap_significant: u32::from(d.remaining.z > cfg.z_gap),
        beyond_library: beyond_code(beyond) as u32,
        beyond_library_share: beyond_share,
        remaining_rms_axis: d.final_rms_axis,
        explainable: smooth(&d.explainable),
        remaining_structure: smooth(&d.remaining_structure),
        noise: kincal_noise_floor {
            sigma_pos_m: known(n.sigma_pos_m, known_pos),
            sigma_rot_rad: known(n.sigma_rot_rad, known_rot),
            dof_pos: known(n.dof_pos, known_pos),
            dof_rot: known(n.dof_rot, known_rot),
            repeat_subgroups: n.repeat_subgroups,
            stated_pos: u32::from(n.stated_pos),
            stated_rot: u32::from(n.stated_rot),
            measured_pos: u32::from(n.measured_pos),
            measured_rot: u32::from(n.measured_rot),
            repeats_pos_m: n.repeat_pos.map_or(f64::NAN, |r| r.0),
            repeats_pos_dof: n.repeat_pos.map_or(0.0, |r| r.1),
            repeats_rot_rad: n.repeat_rot.map_or(f64::NAN, |r| r.0),
            repeats_rot_dof: n.repeat_rot.map_or(0.0, |r| r.1),
            overruled_pos: u32::from(n.overruled_pos.is_some()),
            overruled_rot: u32::from(n.overruled_rot.is_some()),
            overruled_pos_m: n.overruled_pos.unwrap_or(f64::NAN),
            overruled_rot_rad: n.overruled_rot.unwrap_or(f64::NAN),
        },
        baseline: score(&d.baseline),
        gap: gap(&d.gap),
        insample_rms_pos_m: d.geometric_residuals.rms_pos_m,
        insample_rms_rot_rad: d.geometric_residuals.rms_rot_rad,
        n_candidates: d.candidates().len(),
        candidates: [kincal_model_score::default(); KINCAL_DIAG_MAX_CANDIDATES],
        n_suspects: d.suspects().len(),
        suspects: [0; KINCAL_DIAG_MAX_SUSPECTS],
        n_warnings: 0,
        warnings: [kincal_diagnosis_warning::default(); KINCAL_DIAG_MAX_WARNINGS],
        groups: d.groups,
        folds: d.folds,
    };
    for (o, s) in out.confounded_with.iter_mut().zip(v.confounded()) {
        *o = mask(*s);
    }
    for (o, c) in out.candidates.iter_mut().zip(d.candidates()) {
        *o = score(c);
    }
    for (o, &s) in out.suspects.iter_mut().zip(d.suspects()) {
        *o = s as usize;
    }
    for (o, w) in out.warnings.iter_mut().zip(d.warnings()) {
        *o = warning(w);
        out.n_warnings += 1;
    }
    out
}

fn pose_of(p: &PoseDiagnosis) -> kincal_pose_diagnosis {
    kincal_pose_diagnosis {
        group: p.group,
        fold: u32::from(p.fold),
        suspect: u32::from(p.suspect),
        reserved: 0,
        residual: p.residual,
        heldout_baseline: p.heldout_baseline,
        heldout_final: p.heldout_final,
    }
}

/// Results of one call, computed before any output is written.
struct Results {
    model: kincal_robot,
    geometric: kincal_robot,
    report: kincal_diagnosis_report,
}

/// # Safety
/// `ws` is NULL or writable for `ws_len` bytes, and no reference into it is alive.
unsafe fn run<const N: usize>(
    r: &Robot<N>,
    data: &Data<'_>,
    groups: Option<&[u32]>,
    cfg: &Config,
    ws: *mut c_void,
    ws_len: usize,
    poses_out: Option<&mut [kincal_pose_diagnosis]>,
) -> FfiResult<Results> {
    let l = data.n_poses();
    let lay = layout::<N>(l).ok_or(kincal_error::new(kincal_status::CapacityExceeded))?;
    if ws.is_null() {
        return Err(crate::args::null(c"workspace"));
    }
    if !(ws as usize).is_multiple_of(KINCAL_WORKSPACE_ALIGN) {
        return Err(kincal_error::new(kincal_status::MisalignedPointer).arg(c"workspace"));
    }
    if ws_len < lay.total {
        return Err(crate::args::bad_length(c"workspace", lay.total, ws_len));
    }
    let base = ws.cast::<u8>();
    // SAFETY: the five regions lie inside the checked `lay.total <= ws_len` bytes, are
    // disjoint and aligned (base aligned to 16 >= each alignment, offsets rounded to 16).
    // All-zero bytes are a valid DiagWorkspace (documented by the core); every other region
    // is written before it is referenced.
    let (dws, meas, poses, ids, out) = unsafe {
        core::ptr::write_bytes(base, 0, core::mem::size_of::<DiagWorkspace<DIAG_P>>());
        let dws = &mut *base.cast::<DiagWorkspace<DIAG_P>>();
        let mp = base.add(lay.meas).cast::<Measurement<N>>();
        for k in 0..l {
            mp.add(k).write(data.measurement::<N>(k)?);
        }
        let pp = base.add(lay.poses).cast::<PoseDiagnosis>();
        for k in 0..l {
            pp.add(k).write(PoseDiagnosis::EMPTY);
        }
        let ip = base.add(lay.ids).cast::<u32>();
        for k in 0..l {
            // One group per row when the caller gives none.
            let id = match groups {
                Some(g) => g.get(k).copied().unwrap_or(0),
                None => u32::try_from(k).unwrap_or(u32::MAX),
            };
            ip.add(k).write(id);
        }
        let dp = base.add(lay.result).cast::<Diagnosis<N>>();
        dp.write(Diagnosis::new(r));
        (
            dws,
            core::slice::from_raw_parts(mp, l),
            core::slice::from_raw_parts_mut(pp, l),
            core::slice::from_raw_parts(ip, l),
            &mut *dp,
        )
    };
    diagnose_into(r, meas, ids, cfg, poses, dws, out).map_err(|e| {
        let mut k = kincal_error::from(e);
        if let kincal::Error::InvalidParameter { index, .. } = e {
            // The core's only per-row InvalidParameter: a weight other than 1.
            if index < l {
                k = k.arg(c"data->weights");
                k.pose = index;
            }
        }
        k
    })?;
    if let Some(po) = poses_out {
        for (o, p) in po.iter_mut().zip(poses.iter()) {
            *o = pose_of(p);
        }
    }
    Ok(Results {
        model: from_robot(&out.model)?,
        geometric: from_robot(&out.geometric)?,
        report: report_of(out, cfg),
    })
}

/// The sim-to-real gap diagnosis (`kincal diagnose`, spec/effects.md) of instrument
/// measurements against the robot description `robot` (nominal geometry, mass model,
/// limits; effect parameters zero): the geometric calibration, every candidate effect and
/// pair cross-validated over pose groups (or the in-sample nested test with too few
/// groups), the verdict, and the library-free smooth check.
///
/// - `data`: the measurements (`weights` NULL or all 1: the diagnosis holds out by itself).
/// - `groups`, `groups_len`: group id of every pose (`pose_id`: repeats of one pose share
///   it; `groups_len` = `n_poses`), or NULL: every pose its own group.
/// - `opts`: from `kincal_diagnose_options_default`; NaN σ: estimate from repeats.
/// - `workspace`: at least `kincal_diagnose_workspace_size(N, n_poses)` bytes aligned to
///   `KINCAL_WORKSPACE_ALIGN`; scratch.
/// - `model_out`: the verdict's model (geometry + effects) fitted on all rows;
///   `geometric_out` (NULL if not wanted): the geometric calibration; `report_out`: the
///   report; `poses_out` (NULL or `n_poses` entries): per-pose residuals.
///
/// Returns OK; the argument statuses of `kincal_identify`; MISSING_INPUT (no stated σ and
/// no repeats, or a candidate's input missing), TOO_FEW_DATA (fewer groups than folds),
/// INVALID_PARAMETER with `pose` set (a weight other than 1), INVALID_ARGUMENT (an option),
/// CAPACITY_EXCEEDED, and the numerical statuses of the fits. Outputs are written on
/// success only.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
/// `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn kincal_diagnose(
    robot: *const kincal_robot,
    data: *const kincal_measurements,
    groups: *const u32,
    groups_len: usize,
    opts: *const kincal_diagnose_options,
    workspace: *mut c_void,
    workspace_len: usize,
    model_out: *mut kincal_robot,
    geometric_out: *mut kincal_robot,
    report_out: *mut kincal_diagnosis_report,
    poses_out: *mut kincal_pose_diagnosis,
    poses_out_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let o = arg_ref!(opts);
        let cfg = config(o)?;
        let model = arg_out1!(model_out);
        let geometric = arg_out_opt!(geometric_out, 1, 1);
        let report = arg_out1!(report_out);
        let any = to_any(r)?;
        // SAFETY: forwarded contract.
        let view = unsafe { data_view(data, any.n_joints()) }?;
        let l = view.n_poses();
        let groups = if groups.is_null() { None } else { Some(arg_slice!(groups, groups_len, l)) };
        let mut poses = arg_out_opt!(poses_out, poses_out_len, l);
        // Per-pose results go to a local copy of the pointer only after the call succeeds:
        // `run` writes them last, after every fallible step but the model conversion.
        // SAFETY: checked by `arg_out_opt!`; writable by contract, no other reference.
        let poses_slice = poses.as_mut().map(|p| unsafe { p.as_mut_slice() });
        // SAFETY: forwarded contract.
        let res = with_any_robot!(&any, r => unsafe {
            run(r, &view, groups, &cfg, workspace, workspace_len, poses_slice)
        })?;
        // SAFETY: checked by `arg_out1!`/`arg_out_opt!`; writable by contract.
        unsafe {
            model.put(res.model);
            if let Some(g) = geometric {
                g.put(res.geometric);
            }
            report.put(res.report);
        }
        Ok(())
    })
}
