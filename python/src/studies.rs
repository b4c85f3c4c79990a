//! `kincal.crossval` and `kincal.diagnose`: the studies `kincal crossval` and `kincal
//! diagnose` run (io's `crossval` and `diagnose`), with keyword arguments instead of flags.
//! Each returns its report as plain Python data: the dict `kincal crossval --json` writes,
//! and REPORT.json's dict (without `files`: nothing is written).

use std::path::{Path, PathBuf};

use kincal::identify::{Loss, PriorSizes};
use kincal::{Effect, EffectSet, Robot as CoreRobot};
use kincal_io::constraints::ConstraintsFile;
use kincal_io::crossval::{self as cv, PriorChoice, Weighting};
use kincal_io::crossval_contacts::{self as ccv, GroupBy};
use kincal_io::diagnose::{self as diag, SigmaNames};
use kincal_io::diagnose_contacts as diag_contacts;
use kincal_io::effects_arg::EffectChoice;
use kincal_io::measurements::MeasurementSet;
use pyo3::prelude::*;

use crate::errors;
use crate::robot::Robot;

/// Effect names to a set, or a `UsageError` naming the unknown one.
fn effect_set(py: Python<'_>, names: &[String]) -> PyResult<Vec<Effect>> {
    names
        .iter()
        .map(|name| {
            Effect::parse(name).ok_or_else(|| {
                let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
                errors::usage(
                    py,
                    format!(
                        "unknown effect {name:?}: expected one of {}",
                        all.join(", ")
                    ),
                )
            })
        })
        .collect()
}

fn positive(py: Python<'_>, name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(errors::usage(
            py,
            format!("{name} = {v}: expected a finite number > 0"),
        ))
    }
}

fn check_folds(py: Python<'_>, folds: usize) -> PyResult<()> {
    if folds < 2 {
        return Err(errors::usage(
            py,
            format!("folds = {folds}: at least 2 folds are needed"),
        ));
    }
    Ok(())
}

/// The rows of `data` for `robot`, refusing data without the columns `effects` need.
fn study_rows(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    robot: &Robot,
    effects: EffectSet,
    allow_out_of_limits: bool,
) -> PyResult<MeasurementSet> {
    let set = crate::measurements::measurement_set(py, data, robot, allow_out_of_limits)?;
    let source = set.source.clone();
    if set.n_joints != robot.n_joints() {
        return Err(errors::usage(
            py,
            format!(
                "{source}: {} joints, the robot has {}",
                set.n_joints,
                robot.n_joints()
            ),
        ));
    }
    kincal_io::data::require_inputs(&set, effects)
        .map_err(|e| errors::from_io(py, &e, &[&source]))?;
    Ok(set)
}

/// Whether the study takes the contact route: a constraints file, target/plane rows, or
/// instrument rows in several sessions (io's `crossval_contacts::takes_this_route`).
fn is_contact_study(set: &MeasurementSet, constraints: Option<&Path>) -> bool {
    ccv::takes_this_route(set, constraints.is_some())
}

/// `group_by` of a contact cross-validation (`None`: by session when the data have one).
fn group_by(py: Python<'_>, name: Option<&str>, set: &MeasurementSet) -> PyResult<GroupBy> {
    match name {
        None => Ok(GroupBy::default_for(set)),
        Some("target") => Ok(GroupBy::Target),
        Some("session") => Ok(GroupBy::Session),
        Some("pose_id" | "pose-id") => Ok(GroupBy::PoseId),
        Some(other) => Err(errors::usage(
            py,
            format!("group_by {other:?}: expected 'target', 'session' or 'pose_id'"),
        )),
    }
}

/// The io crate's crossval options from the keyword arguments.
#[allow(clippy::too_many_arguments)]
fn crossval_options(
    py: Python<'_>,
    effects: &[String],
    init_frames: bool,
    folds: usize,
    seed: u64,
    geometry: Vec<String>,
    sigma_pos_mm: Option<f64>,
    sigma_rot_deg: Option<f64>,
    unit_weights: bool,
    robust: Option<String>,
    max_iterations: u32,
    prior: Option<&Bound<'_, PyAny>>,
) -> PyResult<cv::Options> {
    check_folds(py, folds)?;
    if let Some(k) = geometry
        .iter()
        .find(|k| !["theta0", "d", "a", "alpha"].contains(&k.as_str()))
    {
        return Err(errors::usage(
            py,
            format!("geometry {k:?}: expected 'theta0', 'd', 'a' or 'alpha'"),
        ));
    }
    let weighting = match (sigma_pos_mm, sigma_rot_deg, unit_weights) {
        (Some(_), Some(_), true) => {
            return Err(errors::usage(
                py,
                "give sigma_pos_mm/sigma_rot_deg or unit_weights, not both",
            ));
        }
        (Some(sp), Some(sr), false) => Weighting::Stated {
            pos_mm: positive(py, "sigma_pos_mm", sp)?,
            rot_deg: positive(py, "sigma_rot_deg", sr)?,
        },
        (None, None, true) => Weighting::Unit,
        (None, None, false) => Weighting::Residual,
        _ => {
            return Err(errors::usage(
                py,
                "sigma_pos_mm and sigma_rot_deg go together",
            ));
        }
    };
    let robust = robust
        .map(|l| {
            Loss::parse(&l).ok_or_else(|| {
                errors::usage(py, format!("robust {l:?}: expected 'huber' or 'cauchy'"))
            })
        })
        .transpose()?;
    let prior = match prior {
        None => PriorChoice::None,
        Some(p) if p.extract::<String>().is_ok_and(|s| s == "auto") => PriorChoice::Auto {
            template: PriorSizes::DEFAULT,
        },
        Some(p) => {
            let (mm, deg): (f64, f64) = p
                .extract()
                .map_err(|_| errors::usage(py, "prior: expected (mm, deg) or 'auto'"))?;
            PriorChoice::Sizes(PriorSizes::links(
                positive(py, "prior length [mm]", mm)? * 1e-3,
                positive(py, "prior angle [deg]", deg)?.to_radians(),
            ))
        }
    };
    if unit_weights && prior != PriorChoice::None {
        return Err(errors::usage(
            py,
            "prior needs weights from the noise (not unit_weights)",
        ));
    }
    Ok(cv::Options {
        effects: effect_set(py, effects)?
            .into_iter()
            .fold(EffectSet::NONE, EffectSet::with),
        scale_joints: None,
        init_frames,
        folds,
        seed,
        geometry,
        weighting,
        robust,
        max_iterations,
        prior,
    })
}

fn crossval_run<'py, const N: usize>(
    py: Python<'py>,
    nominal: &CoreRobot<N>,
    name: &str,
    set: &MeasurementSet,
    options: &cv::Options,
) -> PyResult<Bound<'py, PyAny>> {
    let study = py
        .detach(|| cv::run(nominal, set, options))
        .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
    let doc = cv::json(&study, set, nominal, name, options);
    crate::json::loads(py, &doc.to_string())
}

/// The constraints file `path`, read by io (errors name its line and column).
fn read_constraints(py: Python<'_>, path: Option<&Path>) -> PyResult<Option<ConstraintsFile>> {
    path.map(|p| {
        kincal_io::constraints::read_constraints(p)
            .map_err(|e| errors::from_io(py, &e, &[&p.display().to_string()]))
    })
    .transpose()
}

/// io's contact cross-validation (`kincal crossval` on target/plane rows) with the keyword
/// arguments' settings: whole groups held out, the contacted point fitted as the tool
/// translation, weight 1/σ² from ``sigma_pos_mm``.
fn crossval_contacts_run<'py, const N: usize>(
    py: Python<'py>,
    nominal: &CoreRobot<N>,
    set: &MeasurementSet,
    options: &cv::Options,
    group_by: GroupBy,
    constraints: Option<&Path>,
) -> PyResult<Bound<'py, PyAny>> {
    if options.init_frames || options.prior != PriorChoice::None {
        return Err(errors::usage(
            py,
            "init_frames and prior are not implemented for data with target/plane rows",
        ));
    }
    let cons = read_constraints(py, constraints)?;
    let sigma_pos_mm = match options.weighting {
        Weighting::Stated { pos_mm, .. } => Some(pos_mm),
        Weighting::Unit | Weighting::Residual => None,
    };
    let plan = ccv::Plan {
        group_by,
        folds: options.folds,
        seed: options.seed,
        requested: ccv::requested_params(
            nominal,
            &options.geometry,
            &EffectChoice::all(options.effects),
        ),
        weight_pos: ccv::weight_pos(sigma_pos_mm),
        max_iterations: options.max_iterations,
        constraints: cons.as_ref(),
        robust: options.robust,
    };
    let report = py
        .detach(|| ccv::run(nominal, set, &plan))
        .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
    crate::json::loads(py, &ccv::json(&report).to_string())
}

/// K-fold cross-validation of a calibration on held-out poses, as ``kincal crossval``:
/// poses dealt to ``folds`` folds by ``pose_id`` (seeded by ``seed``), each predicted by the
/// nominal model (``robot``; base/tool frames fitted when ``effects`` names them) and the
/// calibrated one (geometry kinds ``geometry`` + ``effects``) fitted on the other folds.
/// Weights: ``sigma_pos_mm``/``sigma_rot_deg`` [mm, deg] (1/σ²), ``unit_weights``, or by
/// default from the calibrated residuals. ``robust`` ``"huber"``/``"cauchy"`` fits every
/// model by IRLS; ``prior`` is ``(mm, deg)`` or ``"auto"``. Returns the dict ``kincal
/// crossval --json`` writes: ``heldout``/``insample`` (``nominal``, ``calibrated``:
/// ``rms_pos_mm``, ``max_pos_mm``, ``rms_rot_deg``, ``max_rot_deg``), ``per_fold``,
/// ``noise_floor``, ``outliers``, ``poses`` (per row: line, fold, held-out error norms in
/// mm and degrees), ``weighting`` (``weight_pos`` [1/m²], ``weight_rot`` [1/rad²]), ….
///
/// Data with target/plane rows (or a ``constraints`` TOML file: known targets, planes,
/// distances) are cross-validated as ``kincal crossval --constraints``: whole groups held
/// out (``group_by`` ``"session"`` (default with a session column), ``"target"`` or
/// ``"pose_id"``), each held-out contact scored about its target/plane re-estimated from
/// the held-out contacts only; weight 1/``sigma_pos_mm``² [mm]. The dict is that command's
/// ``--json``: ``group_by``, ``robust_loss``, ``folds`` (``held_out`` labels, ``nominal``/
/// ``calibrated`` ``mean_mm``, ``distance_error_mm``, ``algorithm``), ``held_out``
/// (``scored_groups``; ``mean_mm``, ``rms_mm``, ``max_mm``, ``distance_error_mm``).
/// The GIL is released during the fits.
#[pyfunction]
#[pyo3(signature = (data, robot, *, effects=Vec::new(), init_frames=false, folds=5, seed=1, geometry=vec!["theta0".to_string(), "d".to_string(), "a".to_string(), "alpha".to_string()], sigma_pos_mm=None, sigma_rot_deg=None, unit_weights=false, robust=None, max_iterations=200, prior=None, allow_out_of_limits=false, constraints=None, group_by=None))]
#[allow(clippy::too_many_arguments)]
pub fn crossval<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    robot: &Robot,
    effects: Vec<String>,
    init_frames: bool,
    folds: usize,
    seed: u64,
    geometry: Vec<String>,
    sigma_pos_mm: Option<f64>,
    sigma_rot_deg: Option<f64>,
    unit_weights: bool,
    robust: Option<String>,
    max_iterations: u32,
    prior: Option<&Bound<'py, PyAny>>,
    allow_out_of_limits: bool,
    constraints: Option<PathBuf>,
    group_by: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let options = crossval_options(
        py,
        &effects,
        init_frames,
        folds,
        seed,
        geometry,
        sigma_pos_mm,
        sigma_rot_deg,
        unit_weights,
        robust,
        max_iterations,
        prior,
    )?;
    let set = study_rows(py, data, robot, options.effects, allow_out_of_limits)?;
    let constraints = constraints.as_deref();
    if is_contact_study(&set, constraints) {
        let by = self::group_by(py, group_by.as_deref(), &set)?;
        return kincal::with_any_robot!(&robot.robot, r => {
            crossval_contacts_run(py, r, &set, &options, by, constraints)
        });
    }
    if group_by.is_some() {
        return Err(errors::usage(
            py,
            "group_by applies to data with target/plane rows (instrument data: folds by pose_id)",
        ));
    }
    kincal::with_any_robot!(&robot.robot, r => crossval_run(py, r, &robot.name, &set, &options))
}

fn diagnose_run<'py, const N: usize>(
    py: Python<'py>,
    robot: &CoreRobot<N>,
    set: &MeasurementSet,
    options: &diag::Options,
) -> PyResult<Bound<'py, PyAny>> {
    const NAMES: SigmaNames<'static> = SigmaNames {
        pos: "sigma_pos_mm",
        rot: "sigma_rot_deg",
    };
    let study = py
        .detach(|| diag::run(robot, set, options, NAMES))
        .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
    let report = diag::report(&study, set, Path::new(&set.source), None);
    crate::json::loads(py, &diag::report_text(&report))
}

/// The sim-to-real diagnosis of ``kincal diagnose`` (spec/effects.md): the noise floor
/// (``sigma_pos_mm``/``sigma_rot_deg`` [mm, deg] 1σ per axis, else from repeated
/// ``pose_id``\ s), a geometric calibration, where its residuals lie, and which candidate
/// effect (``candidates``, default: every effect whose inputs the data have; ``pairs``:
/// also in pairs) closes the gap on held-out poses (``folds``-fold cross-validation,
/// ``seed``). Returns REPORT.json's dict (spec/cli.md; no ``files``): ``verdict``
/// (``status``, ``effects``, ``reason``, ``parameters`` in SI units), ``noise_floor``,
/// ``baseline``, ``candidates``, ``where`` (``per_pose`` residuals), …; fields say their
/// units (``_mm``, ``_deg``).
///
/// Data with target/plane rows (or a ``constraints`` TOML file) are diagnosed as ``kincal
/// diagnose --constraints``: leave-one-session-out (without sessions, ``folds`` folds of
/// whole targets/planes), candidates compared with the geometric model by a paired
/// signed-rank z, the gap by a χ² test against ``sigma_pos_mm`` [mm] when given
/// (``sigma_rot_deg`` and ``seed`` are unused). The dict is that command's REPORT.json:
/// ``method`` ``"leave_one_group_out_contacts"``, ``noise_floor``, ``gap_z``,
/// ``candidates`` (``heldout_mean_mm``, ``heldout_rms_mm``, ``distance_error_mm``,
/// ``improvement_z``, ``gap_closed_fraction``), ``not_candidates``, ``verdict``.
/// The GIL is released during the diagnosis.
#[pyfunction]
#[pyo3(signature = (data, robot, *, sigma_pos_mm=None, sigma_rot_deg=None, candidates=Vec::new(), pairs=true, folds=5, seed=None, allow_out_of_limits=false, constraints=None))]
#[allow(clippy::too_many_arguments)]
pub fn diagnose<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    robot: &Robot,
    sigma_pos_mm: Option<f64>,
    sigma_rot_deg: Option<f64>,
    candidates: Vec<String>,
    pairs: bool,
    folds: usize,
    seed: Option<u64>,
    allow_out_of_limits: bool,
    constraints: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    check_folds(py, folds)?;
    let sigma_pos_mm = sigma_pos_mm
        .map(|s| positive(py, "sigma_pos_mm", s))
        .transpose()?;
    let sigma_rot_deg = sigma_rot_deg
        .map(|s| positive(py, "sigma_rot_deg", s))
        .transpose()?;
    let defaults = diag::Options::default();
    let options = diag::Options {
        sigma_pos_mm,
        sigma_rot_deg,
        candidates: effect_set(py, &candidates)?,
        scale_joints: None,
        pairs,
        folds,
        seed: seed.unwrap_or(defaults.seed),
    };
    // Contact data read no effect columns up front: a candidate whose inputs are absent is
    // reported as not a candidate, as `kincal diagnose` does.
    let set = study_rows(py, data, robot, EffectSet::NONE, allow_out_of_limits)?;
    let constraints = constraints.as_deref();
    if is_contact_study(&set, constraints) {
        let contact_options = diag_contacts::Options {
            candidates: &options.candidates,
            no_pairs: !options.pairs,
            constraints,
            sigma_pos_mm: options.sigma_pos_mm,
            folds: options.folds,
        };
        return kincal::with_any_robot!(&robot.robot, r => {
            let report = py
                .detach(|| diag_contacts::run(r, &set, &contact_options))
                .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
            crate::json::loads(py, &diag_contacts::json(&report).to_string())
        });
    }
    kincal_io::data::require_inputs(&set, options.effects_to_read())
        .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
    kincal::with_any_robot!(&robot.robot, r => diagnose_run(py, r, &set, &options))
}
