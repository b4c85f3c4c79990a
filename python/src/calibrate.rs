//! `kincal.calibrate`: the calibration `kincal calibrate` runs (io's `pose_calibration` and
//! `calibration`), with keyword arguments instead of flags. The result is a calibrated
//! `Robot` whose model file (`Robot.model_file()`) is the one the CLI writes.

use kincal::identify::{Algorithm, Loss, PriorSizes, RobustOptions};
use kincal::pose::OrientationError;
use kincal::{Effect, EffectSet, Robot as CoreRobot};
use kincal_io::calibration::{self, Failure, Settings, Weighting};
use kincal_io::measurements::MeasurementSet;
use kincal_io::pose_calibration;
use pyo3::prelude::*;

use crate::errors;
use crate::robot::Robot;

/// The keyword arguments of `calibrate`, as given.
struct Options {
    algorithm: String,
    effects: Vec<String>,
    bounds_mm: f64,
    bounds_deg: f64,
    weight_pos: Option<f64>,
    weight_rot: Option<f64>,
    sigma_pos_mm: Option<f64>,
    sigma_rot_deg: Option<f64>,
    orientation_error: String,
    allow_data_deficiency: bool,
    max_iterations: u32,
    robust: Option<String>,
    robust_tuning: Option<f64>,
    prior: Option<(f64, f64)>,
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

impl Options {
    /// The io crate's settings, or a `UsageError` naming the bad argument.
    fn settings(&self, py: Python<'_>) -> PyResult<Settings> {
        let algorithms = match self.algorithm.as_str() {
            "all" => Algorithm::ALL.to_vec(),
            a => vec![Algorithm::parse(a).ok_or_else(|| {
                errors::usage(
                    py,
                    format!("algorithm {a:?}: expected 'ols', 'opt1', 'opt2' or 'all'"),
                )
            })?],
        };
        let mut effects = EffectSet::NONE;
        for name in &self.effects {
            let e = Effect::parse(name).ok_or_else(|| {
                let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
                errors::usage(
                    py,
                    format!(
                        "unknown effect {name:?}: expected one of {}",
                        all.join(", ")
                    ),
                )
            })?;
            effects = effects.with(e);
        }
        let weighting = match (self.sigma_pos_mm, self.sigma_rot_deg) {
            (Some(sp), Some(sr)) => {
                if self.weight_pos.is_some() || self.weight_rot.is_some() {
                    return Err(errors::usage(
                        py,
                        "give sigma_pos_mm/sigma_rot_deg or weight_pos/weight_rot, not both",
                    ));
                }
                Weighting::Sigma {
                    pos_m: positive(py, "sigma_pos_mm", sp)? * 1e-3,
                    rot_rad: positive(py, "sigma_rot_deg", sr)?.to_radians(),
                }
            }
            (None, None) => match (self.weight_pos, self.weight_rot) {
                (None, None) => Weighting::Unit,
                (wp, wr) => Weighting::Explicit {
                    pos: positive(py, "weight_pos", wp.unwrap_or(1.0))?,
                    rot: positive(py, "weight_rot", wr.unwrap_or(1.0))?,
                },
            },
            _ => {
                return Err(errors::usage(
                    py,
                    "sigma_pos_mm and sigma_rot_deg go together",
                ));
            }
        };
        let orientation = match self.orientation_error.as_str() {
            "exact" => OrientationError::Exact,
            "small_angle" => OrientationError::SmallAngle,
            o => {
                return Err(errors::usage(
                    py,
                    format!("orientation_error {o:?}: expected 'exact' or 'small_angle'"),
                ));
            }
        };
        let robust = match &self.robust {
            None => None,
            Some(l) => {
                let loss = Loss::parse(l).ok_or_else(|| {
                    errors::usage(py, format!("robust {l:?}: expected 'huber' or 'cauchy'"))
                })?;
                let mut o = RobustOptions::new(loss);
                if let Some(c) = self.robust_tuning {
                    let c = positive(py, "robust_tuning", c)?;
                    o.tuning_chi2 = [c * c; 6];
                }
                Some(o)
            }
        };
        if self.robust_tuning.is_some() && robust.is_none() {
            return Err(errors::usage(
                py,
                "robust_tuning needs robust='huber' or 'cauchy'",
            ));
        }
        let prior = match self.prior {
            None => None,
            Some(_) if !matches!(weighting, Weighting::Sigma { .. }) => {
                return Err(errors::usage(
                    py,
                    "prior needs sigma_pos_mm and sigma_rot_deg (the prior's rows are whitened against the data's)",
                ));
            }
            Some((mm, deg)) => Some(PriorSizes::links(
                positive(py, "prior length [mm]", mm)? * 1e-3,
                positive(py, "prior angle [deg]", deg)?.to_radians(),
            )),
        };
        Ok(Settings {
            effects,
            scale_joints: None,
            algorithms,
            bounds_length_m: positive(py, "bounds_mm", self.bounds_mm)? * 1e-3,
            bounds_angle_rad: positive(py, "bounds_deg", self.bounds_deg)?.to_radians(),
            weighting,
            orientation,
            allow_data_deficiency: self.allow_data_deficiency,
            max_iterations: self.max_iterations,
            robust,
            prior,
        })
    }
}

struct Flags {
    init_frames: bool,
    allow_out_of_limits: bool,
    allow_implausible: bool,
}

fn run<const N: usize>(
    py: Python<'_>,
    start: &CoreRobot<N>,
    name: &str,
    set: &MeasurementSet,
    settings: &Settings,
    flags: &Flags,
) -> PyResult<Robot> {
    let source = set.source.as_str();
    let io_err = |e: kincal_io::Error| errors::from_io(py, &e, &[source]);
    kincal_io::data::require_inputs(set, settings.effects).map_err(io_err)?;
    if kincal_io::constraints::has_contacts(set) {
        return Err(errors::usage(
            py,
            format!(
                "{source}: target/plane rows: instrument-free calibration is not in the Python package yet (use `kincal calibrate --constraints`)"
            ),
        ));
    }
    let data = pose_calibration::pose_data::<N>(set, start, flags.init_frames).map_err(io_err)?;
    if let (Some(e), false) = (data.findings.errors.first(), flags.allow_implausible) {
        return Err(errors::from_io(
            py,
            &kincal_io::Error::input(format!(
                "{e}\nhint: pass allow_implausible=True to fit these data anyway"
            )),
            &[source],
        ));
    }
    let initial;
    let start = if flags.init_frames {
        initial = calibration::init_frames(start, &data.meas, source)
            .map_err(io_err)?
            .0;
        &initial
    } else {
        start
    };
    let cal = py
        .detach(|| calibration::calibrate(start, &data.meas, settings))
        .map_err(|f| failure::<N>(py, f, set))?;
    warn_failed(py, &cal)?;
    let (file, _) =
        pose_calibration::model_file(name, &cal, set, source, &data, flags.allow_out_of_limits);
    // The robot the model file describes: what loading the saved file gives.
    let robot = file
        .robot
        .any_robot()
        .map_err(|m| errors::numeric(py, format!("the calibrated model: {m}")))?;
    Ok(Robot {
        name: name.to_string(),
        robot,
        file,
    })
}

/// A `UserWarning` per requested algorithm that failed while the model's succeeded
/// (`algorithm="all"`): the model file records it under `calibration.failed`.
fn warn_failed<const N: usize>(py: Python<'_>, cal: &calibration::Calibration<N>) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    let model = cal
        .runs
        .first()
        .map_or(String::new(), |r| r.ident.algorithm.name().to_uppercase());
    for (algorithm, error) in &cal.failed {
        let text = format!(
            "{} failed: {error} (left out of the comparison; the model is {model}'s)",
            algorithm.name().to_uppercase(),
        );
        let message = std::ffi::CString::new(text.replace('\0', " "))
            .map_err(|e| errors::numeric(py, e.to_string()))?;
        PyErr::warn(py, category.as_any(), &message, 1)?;
    }
    Ok(())
}

/// The data-deficient parameters of a refusal, each with the identified parameter its
/// column is most aligned with and whether it was found at the fitted model: the model
/// file's entries (`identifiability_json`), worded on one line.
fn deficient_list<const N: usize>(
    analysis: &kincal::identify::Identifiability,
    found_at_fit: &kincal::ParamSet,
) -> String {
    kincal_io::model_file::identifiability_json::<N>(analysis, &[], found_at_fit)
        .data_deficient
        .iter()
        .map(|e| {
            let why = e.aligned_with.as_ref().map_or_else(
                || "no effect on the measured pose".to_string(),
                |p| format!("aligned with {p}"),
            );
            let at_fit = if e.found_at_fit {
                ", at the fitted model"
            } else {
                ""
            };
            format!("{} ({why}{at_fit})", e.label)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn failure<const N: usize>(py: Python<'_>, f: Failure, set: &MeasurementSet) -> PyErr {
    match f {
        Failure::Deficient {
            analysis,
            found_at_fit,
            ..
        } => errors::numeric(
            py,
            format!(
                "{}: rank deficient: the data determine {} of the {} structurally identifiable parameters; data-deficient: {} (pass allow_data_deficiency=True to fit the identifiable subset)",
                set.source,
                analysis.rank,
                analysis.requested.len() - analysis.structural.len(),
                deficient_list::<N>(&analysis, &found_at_fit)
            ),
        ),
        Failure::Core { algorithm, error } => {
            let e = kincal_io::error::core_error(error, &set.source, |i| {
                kincal_io::data::line_of(set, i)
            });
            let e = kincal_io::Error {
                kind: e.kind,
                message: match algorithm {
                    Some(a) => format!("{} failed: {}", a.name().to_uppercase(), e.message),
                    None => e.message,
                },
            };
            errors::from_io(py, &e, &[&set.source])
        }
    }
}

/// Calibrates ``robot`` (the initial model) from measured poses, as ``kincal calibrate``
/// does: ``data`` is a measurement CSV path or a :class:`Measurements`. ``algorithm`` is
/// ``"ols"``, ``"opt1"``, ``"opt2"`` or ``"all"`` (the three in parallel; the model is
/// OLS's and the file records the others and their consensus). ``effects`` names
/// non-geometric effects to identify; ``bounds_mm``/``bounds_deg`` are OPT1's intervals;
/// ``sigma_pos_mm``/``sigma_rot_deg`` [mm, deg] the instrument's 1σ noise (weights 1/σ²),
/// or ``weight_pos`` [1/m²]/``weight_rot`` [1/rad²]; ``robust`` ``"huber"``/``"cauchy"``
/// fits by IRLS and names suspect rows; ``prior=(mm, deg)`` adds Gaussian priors on the
/// link parameters. Returns the calibrated :class:`Robot`; ``model_file()`` is the JSON
/// ``kincal calibrate --out`` writes. The GIL is released during the fit.
#[pyfunction]
#[pyo3(signature = (data, robot, *, algorithm="ols".to_string(), effects=Vec::new(), bounds_mm=5.0, bounds_deg=5.0, weight_pos=None, weight_rot=None, sigma_pos_mm=None, sigma_rot_deg=None, orientation_error="exact".to_string(), allow_data_deficiency=false, max_iterations=200, robust=None, robust_tuning=None, prior=None, init_frames=false, allow_out_of_limits=false, allow_implausible=false))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    robot: &Robot,
    algorithm: String,
    effects: Vec<String>,
    bounds_mm: f64,
    bounds_deg: f64,
    weight_pos: Option<f64>,
    weight_rot: Option<f64>,
    sigma_pos_mm: Option<f64>,
    sigma_rot_deg: Option<f64>,
    orientation_error: String,
    allow_data_deficiency: bool,
    max_iterations: u32,
    robust: Option<String>,
    robust_tuning: Option<f64>,
    prior: Option<(f64, f64)>,
    init_frames: bool,
    allow_out_of_limits: bool,
    allow_implausible: bool,
) -> PyResult<Robot> {
    let settings = Options {
        algorithm,
        effects,
        bounds_mm,
        bounds_deg,
        weight_pos,
        weight_rot,
        sigma_pos_mm,
        sigma_rot_deg,
        orientation_error,
        allow_data_deficiency,
        max_iterations,
        robust,
        robust_tuning,
        prior,
    }
    .settings(py)?;
    let set = crate::measurements::measurement_set(py, data, robot, allow_out_of_limits)?;
    if set.n_joints != robot.n_joints() {
        return Err(errors::usage(
            py,
            format!(
                "{}: {} joints, the robot has {}",
                set.source,
                set.n_joints,
                robot.n_joints()
            ),
        ));
    }
    let flags = Flags {
        init_frames,
        allow_out_of_limits,
        allow_implausible,
    };
    kincal::with_any_robot!(&robot.robot, r => run(py, r, &robot.name, &set, &settings, &flags))
}
