//! Runs the core's identification for the CLI: the identifiability analysis once, then the
//! requested algorithms in parallel (rayon), each by least squares or, with
//! `Settings::robust`, by the core's robust IRLS fit, and the consensus check between them.
//! Instrument data and contact data (targets, planes) go through the one runner.

use std::time::Instant;

use kincal::identify::{
    Algorithm, Bounds, ConstraintData, Identifiability, Identification, IdentifyOptions,
    MAX_MODEL_PARAMS, Measurement, PoseResidual, Prior, PriorSizes, RobustIdentification,
    RobustOptions, Workspace, analyze, analyze_constrained, identify, identify_constrained,
    identify_constrained_robust, identify_robust, robust::ResidualTest,
};
use kincal::pose::OrientationError;
use kincal::{EffectSet, ParamIndex, ParamSet, Robot};
use rayon::prelude::*;

/// Workspace capacity: every parameter of the largest supported model.
pub const WS_PARAMS: usize = MAX_MODEL_PARAMS;

/// A zeroed identification workspace on the heap (it is several hundred KiB: never on a
/// thread's stack).
pub fn new_workspace() -> Box<Workspace<WS_PARAMS>> {
    let b = Box::<Workspace<WS_PARAMS>>::new_zeroed();
    // SAFETY: the core documents all-zero as a valid `Workspace` (it holds only f64/usize
    // arrays and counters), which is what `new_zeroed` provides.
    unsafe { b.assume_init() }
}

/// How residual rows are weighted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Weighting {
    /// Both weights 1 (positions in m, rotations in rad), as in the paper.
    Unit,
    /// Explicit weights [1/m²], [1/rad²].
    Explicit { pos: f64, rot: f64 },
    /// Weights 1/σ² from the instrument's 1σ noise per axis.
    Sigma { pos_m: f64, rot_rad: f64 },
}

impl Weighting {
    /// (position weight [1/m²], rotation weight [1/rad²]).
    pub fn weights(&self) -> (f64, f64) {
        match *self {
            Weighting::Unit => (1.0, 1.0),
            Weighting::Explicit { pos, rot } => (pos, rot),
            Weighting::Sigma { pos_m, rot_rad } => {
                (1.0 / (pos_m * pos_m), 1.0 / (rot_rad * rot_rad))
            }
        }
    }
    /// Name written to model files.
    pub fn name(&self) -> &'static str {
        match self {
            Weighting::Unit => "unit",
            Weighting::Explicit { .. } => "explicit",
            Weighting::Sigma { .. } => "sigma",
        }
    }
}

/// What to identify and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub effects: EffectSet,
    /// The joints whose scale (`joint_scale`) is identified (`joint_scale@JOINT`,
    /// [`crate::effects_arg`]); `None`: every joint.
    pub scale_joints: Option<Vec<usize>>,
    pub algorithms: Vec<Algorithm>,
    /// OPT1 interval half-width for lengths [m] …
    pub bounds_length_m: f64,
    /// … and for angles [rad].
    pub bounds_angle_rad: f64,
    pub weighting: Weighting,
    pub orientation: OrientationError,
    pub allow_data_deficiency: bool,
    pub max_iterations: u32,
    /// Robust fit (core `identify_robust`: Huber/Cauchy IRLS around each algorithm) instead
    /// of plain least squares; `None`: least squares.
    pub robust: Option<RobustOptions>,
    /// Gaussian priors around the starting model (core `Prior`), one σ per kind; `None`:
    /// none. The prior's rows are whitened against data rows of weight 1/σ², so the
    /// weighting should be [`Weighting::Sigma`] (the commands require it).
    pub prior: Option<PriorSizes>,
}

impl Settings {
    /// The geometric parameters plus those of the effects that apply to `start`, the scale
    /// limited to [`Settings::scale_joints`].
    pub fn param_set<const N: usize>(&self, start: &Robot<N>) -> ParamSet {
        crate::effects_arg::EffectChoice {
            effects: self.effects,
            scale_joints: self.scale_joints.clone(),
        }
        .param_set(start)
    }

    /// The paper's set-up: geometric parameters, unit weights, exact orientation error,
    /// OPT1 intervals 5 mm / 5°.
    pub fn paper(algorithms: Vec<Algorithm>) -> Self {
        Settings {
            effects: EffectSet::NONE,
            scale_joints: None,
            algorithms,
            bounds_length_m: kincal::identify::DEFAULT_LENGTH_TOL_M,
            bounds_angle_rad: kincal::identify::DEFAULT_ANGLE_TOL_RAD,
            weighting: Weighting::Unit,
            orientation: OrientationError::Exact,
            allow_data_deficiency: false,
            max_iterations: 200,
            robust: None,
            prior: None,
        }
    }

    fn options<'a>(
        &self,
        algorithm: Algorithm,
        requested: ParamSet,
        bounds: Option<&'a Bounds>,
        prior: Option<&'a Prior>,
    ) -> IdentifyOptions<'a> {
        let mut o = IdentifyOptions::new(algorithm, requested);
        let (wp, wr) = self.weighting.weights();
        o.weight_pos = wp;
        o.weight_rot = wr;
        o.orientation = self.orientation;
        o.allow_data_deficiency = self.allow_data_deficiency;
        o.max_iterations = self.max_iterations;
        o.bounds = bounds;
        o.prior = prior;
        o
    }

    /// The weighting and orientation error of these settings (what the fit weighs rows
    /// by, e.g. for the frame of an instrument session fitted as the fit eliminates it).
    pub fn row_options(&self) -> IdentifyOptions<'static> {
        self.options(
            self.algorithms.first().copied().unwrap_or(Algorithm::Ols),
            ParamSet::new(),
            None,
            None,
        )
    }

    /// The prior of these settings around `start` (rows whitened: data variance 1).
    pub fn prior_around<const N: usize>(&self, start: &Robot<N>) -> Option<Box<Prior>> {
        self.prior
            .map(|sizes| Box::new(Prior::around(start, &sizes)))
    }
}

/// One algorithm's result.
#[derive(Debug, Clone)]
pub struct Run<const N: usize> {
    /// With a robust fit: the final reweighted fit (its cost, σ² and standard errors are
    /// those of the robustly weighted problem).
    pub ident: Identification<N>,
    pub seconds: f64,
    /// The robust fit's residual test, when `Settings::robust` is set.
    pub robust: Option<RobustRun>,
}

/// What the robust fit of one algorithm found.
#[derive(Debug, Clone)]
pub struct RobustRun {
    /// Scales and suspect count at the final model.
    pub test: ResidualTest,
    /// Reweighted fits performed (both phases for Cauchy).
    pub reweights: u32,
    /// One per pose, in data order (contact data: the core's order, instrument rows then
    /// contacts by group, see `ContactData::row_of`): residuals, standardised residual d,
    /// final robust weight, suspect flag.
    pub poses: Vec<PoseResidual>,
}

impl RobustRun {
    /// Indices (data order) of the suspect poses.
    pub fn suspects(&self) -> Vec<usize> {
        (0..self.poses.len())
            .filter(|&i| self.poses[i].suspect)
            .collect()
    }
}

/// The outcome of a calibration.
#[derive(Debug, Clone)]
pub struct Calibration<const N: usize> {
    /// The initial model (the ROBOT).
    pub start: Robot<N>,
    pub settings: Settings,
    pub analysis: Identifiability,
    /// Singular values of the unit-scaled Jacobian of the identifiable parameters.
    pub singular_values: Vec<f64>,
    /// The data-deficient parameters of `analysis` that the analysis at the starting model
    /// kept and a fit's check at its fitted model dropped (the data determine them only
    /// while the model is off: a report says so, since the start's figures kept them).
    pub found_at_fit: ParamSet,
    /// One per requested algorithm that succeeded, in the order asked; the first is the
    /// first algorithm asked (the model's: a calibration whose first algorithm fails fails).
    pub runs: Vec<Run<N>>,
    /// The other requested algorithms that failed, in the order asked, with their error:
    /// with `--algorithm all` an OPT1 or OPT2 that does not converge costs its column of
    /// the comparison, not the OLS model.
    pub failed: FailedRuns,
    /// With two or more algorithms.
    pub consensus: Option<Consensus>,
}

/// Requested algorithms that failed, with their error (see [`Calibration::failed`]).
pub type FailedRuns = Vec<(Algorithm, kincal::Error)>;

/// Why a calibration stopped.
#[derive(Debug, Clone)]
pub enum Failure {
    /// The data determine too few parameters (the analysis says which).
    Deficient {
        analysis: Box<Identifiability>,
        singular_values: Vec<f64>,
        /// As [`Calibration::found_at_fit`] (empty when the start's analysis refused).
        found_at_fit: ParamSet,
    },
    /// The core refused or failed (`algorithm` when one algorithm failed).
    Core {
        algorithm: Option<Algorithm>,
        error: kincal::Error,
    },
}

/// `start` with base and tool frames estimated from `data` (`kincal::frames`), and a note
/// saying how far they moved and how well the nominal geometry then fits.
pub fn init_frames<const N: usize>(
    start: &Robot<N>,
    data: &[Measurement<N>],
    source: &str,
) -> Result<(Robot<N>, String), crate::error::Error> {
    let est = kincal::frames::estimate_frames(start, data).map_err(|e| {
        crate::error::Error::numeric(format!(
            "{source}: cannot estimate the base and tool frames from these poses: {e}"
        ))
    })?;
    let moved = |t: &kincal::Transform| {
        let v = kincal::pose::pose_to_vector6(t);
        (
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() * 1e3,
            (v[3] * v[3] + v[4] * v[4] + v[5] * v[5])
                .sqrt()
                .to_degrees(),
        )
    };
    let (bp, br) = moved(&est.base_change);
    let (tp, tr) = moved(&est.tool_change);
    let mut note = format!(
        "kincal: frames estimated from the data: base moved {bp:.1} mm / {br:.2}°, tool {tp:.1} mm / {tr:.2}°{}; \
         nominal geometry with them: RMS {:.3} mm",
        if est.tool_rotation_estimated {
            ""
        } else {
            " (tool rotation not seen by single-point positions: kept)"
        },
        est.rms_pos_m * 1e3
    );
    if est.rms_rot_rad > 0.0 {
        note.push_str(&format!(", {:.3}°", est.rms_rot_rad.to_degrees()));
    }
    Ok((est.robot, note))
}

/// Analysis, then every algorithm of `settings` in parallel.
pub fn calibrate<const N: usize>(
    start: &Robot<N>,
    data: &[Measurement<N>],
    settings: &Settings,
) -> Result<Calibration<N>, Failure> {
    run_all(
        start,
        Rows::Instrument(data),
        settings.param_set(start),
        settings,
    )
}

/// The rows a calibration runs on.
#[derive(Clone, Copy)]
enum Rows<'d, const N: usize> {
    /// Instrument rows only (`identify`, `identify_robust`).
    Instrument(&'d [Measurement<N>]),
    /// Contacts, possibly with instrument rows (`identify_constrained`,
    /// `identify_constrained_robust`).
    Contacts(&'d ConstraintData<'d, N>),
}

impl<const N: usize> Rows<'_, N> {
    fn analyze(
        self,
        start: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        ws: &mut Workspace<WS_PARAMS>,
    ) -> Result<Identifiability, kincal::Error> {
        match self {
            Rows::Instrument(d) => analyze(start, d, opts, ws),
            Rows::Contacts(d) => analyze_constrained(start, d, opts, ws),
        }
    }

    /// One fit: least squares, or with `robust` the IRLS fit on a copy of the rows (the
    /// core writes the robust weights into the rows while it iterates).
    fn fit(
        self,
        start: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        robust: Option<&RobustOptions>,
        ws: &mut Workspace<WS_PARAMS>,
    ) -> Result<(Identification<N>, Option<RobustRun>), kincal::Error> {
        let run = |r: RobustIdentification<N>, poses| {
            (
                r.fit,
                Some(RobustRun {
                    test: r.test,
                    reweights: r.reweights,
                    poses,
                }),
            )
        };
        match (self, robust) {
            (Rows::Instrument(d), None) => Ok((identify(start, d, opts, ws)?, None)),
            (Rows::Contacts(d), None) => Ok((identify_constrained(start, d, opts, ws)?, None)),
            (Rows::Instrument(d), Some(ro)) => {
                let mut own = d.to_vec();
                let mut poses = vec![PoseResidual::default(); own.len()];
                let r = identify_robust(start, &mut own, opts, ro, &mut poses, ws)?;
                Ok(run(r, poses))
            }
            (Rows::Contacts(d), Some(ro)) => {
                let (mut inst, mut contacts) = (d.instrument.to_vec(), d.contacts.to_vec());
                let mut poses = vec![PoseResidual::default(); inst.len() + contacts.len()];
                let r = identify_constrained_robust(
                    start,
                    &mut inst,
                    &mut contacts,
                    d.groups,
                    d.distances,
                    opts,
                    ro,
                    &mut poses,
                    ws,
                )?;
                Ok(run(r, poses))
            }
        }
    }
}

/// The one runner: the analysis of `requested` once (refused when deficient), then every
/// algorithm of `settings` in parallel on the same rows, then the consensus check.
fn run_all<const N: usize>(
    start: &Robot<N>,
    rows: Rows<'_, N>,
    requested: ParamSet,
    settings: &Settings,
) -> Result<Calibration<N>, Failure> {
    let core = |algorithm| move |error| Failure::Core { algorithm, error };
    let mut ws = new_workspace();
    let prior = settings.prior_around(start);
    let opts = settings.options(Algorithm::Ols, requested, None, None);
    let analysis = rows.analyze(start, &opts, &mut ws).map_err(core(None))?;
    let singular_values = ws.singular_values().to_vec();
    refuse_deficient(
        &analysis,
        &singular_values,
        &ParamSet::new(),
        settings,
        prior.as_deref(),
    )?;
    let results: Vec<Result<(Run<N>, Vec<f64>), Failure>> = settings
        .algorithms
        .par_iter()
        .map(|&algorithm| {
            let t0 = Instant::now();
            let bounds = Box::new(Bounds::around(
                start,
                settings.bounds_length_m,
                settings.bounds_angle_rad,
            ));
            let mut opts = settings.options(algorithm, requested, Some(&bounds), prior.as_deref());
            // The core repeats the analysis's data test at the fitted model; what it finds
            // there is refused below as the start's finding is, with the report.
            opts.allow_data_deficiency = true;
            let mut ws = new_workspace();
            let (ident, robust) = rows
                .fit(start, &opts, settings.robust.as_ref(), &mut ws)
                .map_err(core(Some(algorithm)))?;
            let run = Run {
                ident,
                seconds: t0.elapsed().as_secs_f64(),
                robust,
            };
            Ok((run, ws.singular_values().to_vec()))
        })
        .collect();
    let (fits, failed) = split_failed(results)?;
    // Parameters the data determine only while the model is off: the fits' analysis.
    let (mut analysis, mut singular_values) = (analysis, singular_values);
    let mut found_at_fit = ParamSet::new();
    if let Some((run, sv)) = fits
        .iter()
        .find(|(run, _)| run.ident.analysis.data_deficient != analysis.data_deficient)
    {
        found_at_fit = run
            .ident
            .analysis
            .data_deficient
            .difference(&analysis.data_deficient);
        analysis = run.ident.analysis;
        singular_values = sv.clone();
        refuse_deficient(
            &analysis,
            &singular_values,
            &found_at_fit,
            settings,
            prior.as_deref(),
        )?;
    }
    let runs: Vec<Run<N>> = fits.into_iter().map(|(run, _)| run).collect();
    let consensus = (runs.len() >= 2).then(|| Consensus::check(&runs, &analysis.identifiable));
    Ok(Calibration {
        start: *start,
        settings: settings.clone(),
        analysis,
        singular_values,
        found_at_fit,
        runs,
        failed,
        consensus,
    })
}

/// The successful fits and the failed algorithms of `results` (in the order asked), or the
/// first algorithm's failure: its fit is the model, so without it there is no calibration.
fn split_failed<T>(results: Vec<Result<T, Failure>>) -> Result<(Vec<T>, FailedRuns), Failure> {
    let (mut fits, mut failed) = (Vec::new(), Vec::new());
    for (k, result) in results.into_iter().enumerate() {
        match result {
            Ok(fit) => fits.push(fit),
            Err(Failure::Core {
                algorithm: Some(algorithm),
                error,
            }) if k > 0 => failed.push((algorithm, error)),
            Err(f) => return Err(f),
        }
    }
    Ok((fits, failed))
}

/// The parameters a calibration from contact rows requests: those of `settings` plus the
/// tool translation (the contacted point, e.g. a ball centre, identified as the tool
/// translation; the structural test drops it if the last link already covers it).
pub fn contact_params<const N: usize>(start: &Robot<N>, settings: &Settings) -> ParamSet {
    let mut requested = settings.param_set(start);
    for k in 0..3 {
        // Tool-frame translation: flat indices 5N + 6 .. 5N + 9.
        let _ = requested.insert(5 * N + 6 + k);
    }
    requested
}

/// The analysis's refusal, shared by the instrument and the contact path: no identifiable
/// parameter, or data-deficient directions without `allow_data_deficiency`.
fn refuse_deficient(
    analysis: &kincal::identify::Identifiability,
    singular_values: &[f64],
    found_at_fit: &ParamSet,
    settings: &Settings,
    prior: Option<&Prior>,
) -> Result<(), Failure> {
    // A data-deficient parameter with a prior is fitted: the prior holds it.
    let undetermined = analysis
        .data_deficient
        .iter()
        .any(|i| !prior.is_some_and(|p| p.has(i)));
    if analysis.rank == 0 || (undetermined && !settings.allow_data_deficiency) {
        return Err(Failure::Deficient {
            analysis: Box::new(*analysis),
            singular_values: singular_values.to_vec(),
            found_at_fit: *found_at_fit,
        });
    }
    Ok(())
}

/// [`calibrate`] for instrument-free (or mixed) data: the core's constraint analysis and
/// `identify_constrained` (or, with `Settings::robust`, `identify_constrained_robust`:
/// IRLS weights per contact and instrument row), every algorithm in parallel.
pub fn calibrate_constrained<const N: usize>(
    start: &Robot<N>,
    data: &ConstraintData<'_, N>,
    settings: &Settings,
) -> Result<Calibration<N>, Failure> {
    // Instrument rows alone (in several sessions' frames) request what instrument data do.
    let requested = if data.contacts.is_empty() {
        settings.param_set(start)
    } else {
        contact_params(start, settings)
    };
    run_all(start, Rows::Contacts(data), requested, settings)
}

/// Two algorithms disagree on a parameter when the difference exceeds
/// `CONSENSUS_K_SIGMA` combined standard errors plus `CONSENSUS_FLOOR_SI`. Each run's
/// standard errors are first rescaled to the smallest residual variance σ² among the runs
/// (se·sqrt(σ²_min/σ²_run)): a run that stopped far from the least-squares minimum (OPT1
/// held on its bounds) has a σ² inflated by its own misfit, which must not widen the
/// tolerance and hide the disagreement.
pub const CONSENSUS_K_SIGMA: f64 = 3.0;
/// Absolute floor of the consensus tolerance, in the parameter's SI unit (m, rad, …): on
/// noise-free data the standard errors vanish and the algorithms' stopping rules alone
/// leave differences of ~1e-11.
pub const CONSENSUS_FLOOR_SI: f64 = 1e-8;

/// A parameter on which two algorithms differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disagreement {
    pub param: ParamIndex,
    pub a: Algorithm,
    pub b: Algorithm,
    /// |value_a − value_b| (SI unit).
    pub difference: f64,
    /// sqrt(se_a² + se_b²).
    pub combined_std_error: f64,
    /// k·combined + floor.
    pub tolerance: f64,
}

/// The consensus check between the algorithms' results.
#[derive(Debug, Clone, PartialEq)]
pub struct Consensus {
    pub k_sigma: f64,
    pub floor_si: f64,
    /// The pair and parameter with the largest difference relative to its tolerance.
    pub largest: Option<Disagreement>,
    /// Every (pair, parameter) beyond its tolerance.
    pub disagreeing: Vec<Disagreement>,
}

impl Consensus {
    /// Compares every pair of runs on every identified parameter.
    pub fn check<const N: usize>(runs: &[Run<N>], identified: &ParamSet) -> Self {
        let mut largest: Option<Disagreement> = None;
        let mut disagreeing = Vec::new();
        let s2_min = runs
            .iter()
            .map(|r| r.ident.sigma2)
            .filter(|&s| s > 0.0)
            .fold(f64::INFINITY, f64::min);
        let scale = |r: &Run<N>| {
            if r.ident.sigma2 > 0.0 && s2_min.is_finite() {
                (s2_min / r.ident.sigma2).sqrt()
            } else {
                1.0
            }
        };
        for (i, ra) in runs.iter().enumerate() {
            for rb in &runs[i + 1..] {
                for p in identified.iter() {
                    let idx = ParamIndex(p);
                    let (Ok(va), Ok(vb)) = (ra.ident.robot.param(idx), rb.ident.robot.param(idx))
                    else {
                        continue;
                    };
                    let (sa, sb) = (
                        ra.ident.std_errors[p] * scale(ra),
                        rb.ident.std_errors[p] * scale(rb),
                    );
                    let combined = (sa * sa + sb * sb).sqrt();
                    let d = Disagreement {
                        param: idx,
                        a: ra.ident.algorithm,
                        b: rb.ident.algorithm,
                        difference: parameter_difference::<N>(idx, va, vb),
                        combined_std_error: combined,
                        tolerance: CONSENSUS_K_SIGMA * combined + CONSENSUS_FLOOR_SI,
                    };
                    if largest.is_none_or(|l| d.ratio() > l.ratio()) {
                        largest = Some(d);
                    }
                    if d.difference > d.tolerance {
                        disagreeing.push(d);
                    }
                }
            }
        }
        Consensus {
            k_sigma: CONSENSUS_K_SIGMA,
            floor_si: CONSENSUS_FLOOR_SI,
            largest,
            disagreeing,
        }
    }
    /// No parameter disagrees.
    pub fn agree(&self) -> bool {
        self.disagreeing.is_empty()
    }
}

/// |a − b| for parameter `idx`, whole turns apart counting as equal for a link angle
/// (θ0, α, β: the kinematics see them through sines and cosines only): the same model
/// reached by two algorithms a turn apart is no disagreement.
pub fn parameter_difference<const N: usize>(idx: ParamIndex, a: f64, b: f64) -> f64 {
    if kincal::ParamId::from_index(idx, N).is_ok_and(kincal::ParamId::is_link_angle) {
        kincal::ParamId::less_whole_turns(a - b).abs()
    } else {
        (a - b).abs()
    }
}

impl Disagreement {
    /// Difference over tolerance (> 1: disagreement).
    pub fn ratio(&self) -> f64 {
        self.difference / self.tolerance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// Link angles a whole number of turns apart are no disagreement; lengths, and angles
    /// a part of a turn apart, differ by their plain difference.
    #[test]
    fn a_link_angle_a_turn_apart_is_the_same() {
        let theta0_6 = ParamIndex(25);
        let alpha_1 = ParamIndex(3);
        let d_1 = ParamIndex(1);
        assert!(parameter_difference::<6>(theta0_6, 0.1 + 3.0 * TAU, 0.1) < 1e-12);
        assert!((parameter_difference::<6>(alpha_1, -TAU + 0.5, 0.2) - 0.3).abs() < 1e-12);
        assert_eq!(
            parameter_difference::<6>(theta0_6, 0.5, 0.2),
            (0.5f64 - 0.2).abs()
        );
        assert_eq!(parameter_difference::<6>(d_1, TAU, 0.0), TAU);
    }
}
