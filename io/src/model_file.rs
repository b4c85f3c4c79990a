//! The versioned JSON model file written by `calibrate` (and later `diagnose`).
//!
//! Layout (`schema_version` "MAJOR.MINOR"; a reader refuses a newer MAJOR and ignores
//! unknown fields, so MINOR versions may add fields):
//!
//! ```text
//! { "schema_version": "1.0", "format": "kincal-model", "generator": "kincal 0.1.0",
//!   "robot": { "name", "n_joints",
//!              "length_params": ["d" | "beta", …]          per link: which of d/β is identified
//!              "joint_types": ["revolute" | "prismatic", …] per joint; written only when a
//!                            joint is prismatic, absent = every joint revolute
//!              "parameters": [ { "label": "theta0_1", "value", "unit", "nominal",
//!                                "identified", "status", "std_error"?, "at_bound"? }, … ]
//!                            every parameter of the flat layout (links, base, tool, effects)
//!              "nominal": { "links": [{theta0, d, a, alpha, beta}], "base": [6], "tool": [6] }
//!              "joint_limits": [{ "lower", "upper" }]  [rad] ([m] for a prismatic joint)
//!              "mass": { "link_masses_kg", "tool_mass_kg", "gravity_m_s2" },
//!              "effects": ["joint_compliance", …] },
//!   "calibration": { "data": { "path", "sha256", "poses", "rows" },
//!                    "algorithm", "algorithms", "effects", "options",
//!                    "identifiability", "residuals": { "before", "after" },
//!                    "results": [ per algorithm, "robust"? ], "consensus"?,
//!                    "robust"? } }
//! ```
//!
//! `robust` (written by `calibrate --robust LOSS` only; absent otherwise, so readers that
//! do not know it are unaffected): the loss, the weight thresholds c² and suspect thresholds
//! d² per number of measured components, and the model's run's robust scales, reweighted
//! fits and suspect rows (CSV line, pose_id, d, |e_p|, |e_φ|, robust weight); each entry of
//! `results` carries its own run's scales and suspects under `robust`.
//!
//! Values are SI (m, rad, rad/(N·m), 1/K) written by serde_json in the shortest form that
//! reads back to the same `f64` (parsed with `float_roundtrip`), so a loaded model
//! reproduces the written one's FK bit for bit. Non-finite numbers never appear (serde_json
//! would write `null`): an infinite condition number is written as `null`.

use kincal::any::AnyRobot;
use kincal::identify::{Algorithm, Identifiability, ResidualStats};
use kincal::model::{JointKind, JointLimits, LengthParam, Link, MassModel};
use kincal::{Effect, EffectSet, ParamId, ParamIndex, ParamSet, Robot};
use serde::{Deserialize, Serialize};

use crate::calibration::{Calibration, Consensus, Disagreement, RobustRun};
use crate::error::Error as CliError;
use crate::units::si_unit;

/// Version written by this build.
pub const SCHEMA_VERSION: &str = "1.0";
/// Major version this build reads.
pub const SCHEMA_MAJOR: u64 = 1;
/// Value of the `format` field.
pub const FORMAT: &str = "kincal-model";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    pub schema_version: String,
    pub format: String,
    #[serde(default)]
    pub generator: String,
    pub robot: RobotJson,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationJson>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotJson {
    pub name: String,
    pub n_joints: usize,
    pub length_params: Vec<LengthChoice>,
    /// Per joint; empty (absent in the file) when every joint is revolute, so files of
    /// revolute robots are unchanged and older files read as revolute.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joint_types: Vec<JointTypeJson>,
    pub parameters: Vec<ParamJson>,
    pub nominal: GeometryJson,
    pub joint_limits: Vec<LimitsJson>,
    pub mass: MassJson,
    #[serde(default)]
    pub effects: Vec<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LengthChoice {
    D,
    Beta,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointTypeJson {
    Revolute,
    Prismatic,
    Sensor,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamJson {
    pub label: String,
    pub value: f64,
    pub unit: String,
    /// Value before calibration (the ROBOT's).
    pub nominal: f64,
    pub identified: bool,
    /// `identified`, `fixed` (not requested), `structurally_redundant`, `data_deficient`.
    pub status: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub at_bound: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometryJson {
    pub links: Vec<LinkJson>,
    pub base: [f64; 6],
    pub tool: [f64; 6],
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkJson {
    pub theta0: f64,
    pub d: f64,
    pub a: f64,
    pub alpha: f64,
    pub beta: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LimitsJson {
    pub lower: f64,
    pub upper: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MassJson {
    pub link_masses_kg: Vec<f64>,
    pub tool_mass_kg: f64,
    pub gravity_m_s2: [f64; 3],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationJson {
    pub data: DataJson,
    /// The algorithm whose result is the model.
    pub algorithm: String,
    /// Every algorithm run.
    pub algorithms: Vec<String>,
    pub effects: Vec<String>,
    pub options: OptionsJson,
    pub identifiability: IdentifiabilityJson,
    pub residuals: ResidualsJson,
    pub results: Vec<ResultJson>,
    /// Requested algorithms that failed (`--algorithm all`: OPT1 or OPT2 not converged),
    /// absent from `results` and from the consensus.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub failed: Vec<FailedRunJson>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consensus: Option<ConsensusJson>,
    /// The robust fit (with `calibrate --robust`): loss, thresholds, and the model's run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<RobustJson>,
    /// Plausibility warnings (`crate::plausibility`): suspicious data or results that were
    /// not refused.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Instrument-free data: the targets, planes and known distances as the calibrated
    /// model sees them (docs/constraints.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constraints: Option<ConstraintsJson>,
}

/// Targets, planes and distances estimated by the calibrated model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConstraintsJson {
    /// The constraints file, if any (as given on the command line) and its SHA-256.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sha256: Option<String>,
    pub targets: Vec<GroupJson>,
    pub planes: Vec<GroupJson>,
    pub distances: Vec<DistanceJson>,
}

/// One target or plane: the estimate and the scatter of the contacts about it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroupJson {
    pub id: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session: Option<String>,
    /// Given in the constraints file (not estimated).
    pub known: bool,
    pub contacts: usize,
    /// Target position, or the contacts' mean point on a plane [m] (base frame).
    pub xyz_m: [f64; 3],
    /// Plane normal (planes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Plane offset normal·p [m] (planes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<f64>,
    pub rms_mm: f64,
    pub max_mm: f64,
}

/// A known distance and what the model predicts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DistanceJson {
    pub between: [String; 2],
    pub m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_m: Option<f64>,
    /// Predicted by the calibrated model (null when a target has no contact).
    pub predicted_m: Option<f64>,
    /// predicted − known [mm].
    pub error_mm: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataJson {
    /// As given on the command line.
    pub path: String,
    pub sha256: String,
    pub poses: usize,
    pub rows: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OptionsJson {
    pub orientation_error: String,
    pub weighting: String,
    pub weight_pos: f64,
    pub weight_rot: f64,
    pub bounds_length_mm: f64,
    pub bounds_angle_deg: f64,
    pub allow_data_deficiency: bool,
    pub allow_out_of_limits: bool,
    pub max_iterations: u32,
    /// Gaussian priors around the initial model (`calibrate --prior`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorJson>,
}

/// The prior of a calibration: one σ per kind (none: no prior on that kind), centred on the
/// initial model, rows whitened against the data's 1/σ² weights; its χ² at the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PriorJson {
    pub length_mm: f64,
    pub angle_deg: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_length_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_angle_deg: Option<f64>,
    /// `Σ ((x − x_initial)/σ)²` of the model's run, and its number of rows.
    pub chi2: f64,
    pub rows: usize,
    /// Data-deficient parameters fitted because their prior holds them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentifiabilityJson {
    pub requested: Vec<String>,
    pub identifiable: Vec<String>,
    pub structurally_redundant: Vec<NotKeptJson>,
    pub data_deficient: Vec<NotKeptJson>,
    /// Not observable without an external reference (constraint data: base frame, scale),
    /// kept at their values.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_observable: Vec<NotKeptJson>,
    pub rank: usize,
    /// σ_max/σ_min of the unit-scaled Jacobian; `null` when infinite.
    pub condition_number: Option<f64>,
    pub singular_values: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotKeptJson {
    pub label: String,
    /// The kept parameter whose Jacobian column is most aligned with this one.
    pub aligned_with: Option<String>,
    pub cosine: Option<f64>,
    /// Data-deficient at the fitted model, kept by the analysis at the starting model
    /// (whose errors made the columns differ): `Calibration::found_at_fit`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub found_at_fit: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResidualsJson {
    pub before: StatsJson,
    pub after: StatsJson,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StatsJson {
    pub poses: usize,
    pub rows: usize,
    /// Weighted sum of squares.
    pub cost: f64,
    pub rms_pos_mm: f64,
    pub max_pos_mm: f64,
    pub rms_rot_deg: f64,
    pub max_rot_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultJson {
    pub algorithm: String,
    pub iterations: u32,
    /// Run time [s]: shown on screen, never written, so that identical inputs give
    /// bit-identical model files whatever the machine load or thread count (older files that
    /// carry it still read).
    #[serde(default, skip_serializing)]
    pub seconds: f64,
    /// Residual variance cost/(rows − fitted).
    pub sigma2: f64,
    pub residuals: ResidualsJson,
    /// The identified parameters (every other parameter keeps the model's value).
    pub parameters: Vec<ResultParamJson>,
    pub correlations: Vec<CorrelationJson>,
    /// This run's robust fit (with `calibrate --robust`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<RobustRunJson>,
}

/// A requested algorithm that failed, and why (the core's error, as text).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailedRunJson {
    pub algorithm: String,
    pub error: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultParamJson {
    pub label: String,
    pub value: f64,
    pub std_error: f64,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub at_bound: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrelationJson {
    pub a: String,
    pub b: String,
    pub rho: f64,
}

/// The robust fit of the stored model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobustJson {
    /// `huber` or `cauchy`.
    pub loss: String,
    /// c² of the weight function for a pose with k = 1..6 measured components (index k − 1),
    /// in units of the standardised residual d².
    pub tuning_chi2: [f64; 6],
    /// A pose with d² above this (index k − 1) is a suspect.
    pub suspect_chi2: [f64; 6],
    /// The algorithm whose robust fit is the model (the first run).
    pub algorithm: String,
    #[serde(flatten)]
    pub run: RobustRunJson,
}

/// One algorithm's robust fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobustRunJson {
    /// Reweighted fits performed.
    pub reweights: u32,
    /// Robust per-axis position scale σ_p [mm].
    pub scale_pos_mm: f64,
    /// Robust per-axis orientation scale σ_φ [deg]; `null` for position-only data.
    pub scale_rot_deg: Option<f64>,
    /// The poses the residual test names, in data order.
    pub suspects: Vec<SuspectJson>,
}

/// A suspect row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuspectJson {
    /// Line of DATA where the row is.
    pub line: u64,
    pub pose_id: Option<String>,
    /// Standardised residual d.
    pub distance: f64,
    /// |e_p| at the model [mm].
    pub pos_mm: f64,
    /// |e_φ| at the model [deg]; `null` for a position-only row.
    pub rot_deg: Option<f64>,
    /// Final robust weight factor in (0, 1].
    pub robust_weight: f64,
}

/// Where a pose of the calibration data sits in DATA.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PoseLabel {
    pub line: u64,
    pub pose_id: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConsensusJson {
    pub agree: bool,
    /// How a disagreement is defined.
    pub rule: String,
    pub k_sigma: f64,
    pub floor_si: f64,
    pub largest: Option<DisagreementJson>,
    pub disagreeing: Vec<DisagreementJson>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisagreementJson {
    pub label: String,
    pub unit: String,
    pub a: String,
    pub b: String,
    pub difference: f64,
    pub combined_std_error: f64,
    pub tolerance: f64,
}

// ---------------------------------------------------------------------------------------
// Writing

use crate::units::{param_label as label, param_labels as labels};

fn finite_or_none(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Per-parameter calibration status used when describing a robot.
#[derive(Debug)]
pub struct ParamInfo<'a> {
    pub analysis: &'a Identifiability,
    pub std_errors: &'a [f64],
    pub at_bound: &'a ParamSet,
}

impl RobotJson {
    /// Describes `robot`; `initial` gives each parameter's `nominal` value.
    pub fn from_robot<const N: usize>(
        name: &str,
        robot: &Robot<N>,
        initial: &Robot<N>,
        info: Option<&ParamInfo<'_>>,
        effects: EffectSet,
    ) -> Self {
        let parameters = (0..Robot::<N>::NUM_PARAMS)
            .filter_map(|i| {
                let id = ParamId::from_index(ParamIndex(i), N).ok()?;
                let value = robot.param(ParamIndex(i)).ok()?;
                let nominal = initial.param(ParamIndex(i)).ok()?;
                let (status, identified, std_error, at_bound) = match info {
                    Some(inf) if inf.analysis.identifiable.contains(i) => (
                        "identified",
                        true,
                        inf.std_errors.get(i).copied().and_then(finite_or_none),
                        inf.at_bound.contains(i),
                    ),
                    Some(inf) if inf.analysis.structural.contains(i) => {
                        ("structurally_redundant", false, None, false)
                    }
                    Some(inf) if inf.analysis.data_deficient.contains(i) => {
                        ("data_deficient", false, None, false)
                    }
                    Some(inf) if inf.analysis.gauge.contains(i) => {
                        ("not_observable", false, None, false)
                    }
                    _ => ("fixed", false, None, false),
                };
                Some(ParamJson {
                    label: id.to_string(),
                    value,
                    unit: crate::units::si_unit_for(id, |j| {
                        robot.joint_kind(j) == JointKind::Prismatic
                    })
                    .to_string(),
                    nominal,
                    identified,
                    status: status.to_string(),
                    std_error,
                    at_bound,
                })
            })
            .collect();
        let nominal_links = robot.nominal_links();
        let (nb, nt) = robot.nominal_frames();
        let mass = robot.mass();
        let effects = effects
            .iter()
            .chain(robot.active_effects().iter())
            .fold(EffectSet::NONE, EffectSet::with);
        RobotJson {
            name: name.to_string(),
            n_joints: N,
            length_params: robot
                .length_params()
                .iter()
                .map(|lp| match lp {
                    LengthParam::D => LengthChoice::D,
                    LengthParam::Beta => LengthChoice::Beta,
                })
                .collect(),
            joint_types: if robot.has_prismatic() || robot.has_sensor_joints() {
                robot
                    .joint_kinds()
                    .iter()
                    .map(|k| match k {
                        JointKind::Revolute => JointTypeJson::Revolute,
                        JointKind::Prismatic => JointTypeJson::Prismatic,
                        JointKind::Sensor => JointTypeJson::Sensor,
                    })
                    .collect()
            } else {
                Vec::new()
            },
            parameters,
            nominal: GeometryJson {
                links: nominal_links
                    .iter()
                    .map(|l| LinkJson {
                        theta0: l.theta0,
                        d: l.d,
                        a: l.a,
                        alpha: l.alpha,
                        beta: l.beta,
                    })
                    .collect(),
                base: nb,
                tool: nt,
            },
            joint_limits: robot
                .limits()
                .iter()
                .map(|l| LimitsJson {
                    lower: l.lower,
                    upper: l.upper,
                })
                .collect(),
            mass: MassJson {
                link_masses_kg: mass.link_masses_kg.to_vec(),
                tool_mass_kg: mass.tool_mass_kg,
                gravity_m_s2: mass.gravity,
            },
            effects: effects.iter().map(|e| e.name().to_string()).collect(),
        }
    }
}

fn stats(s: &ResidualStats) -> StatsJson {
    StatsJson {
        poses: s.poses,
        rows: s.rows,
        cost: s.cost,
        rms_pos_mm: s.rms_pos_m * 1e3,
        max_pos_mm: s.max_pos_m * 1e3,
        rms_rot_deg: s.rms_rot_rad.to_degrees(),
        max_rot_deg: s.max_rot_rad.to_degrees(),
    }
}

fn not_kept<const N: usize>(
    set: &ParamSet,
    a: &Identifiability,
    at_fit: &ParamSet,
) -> Vec<NotKeptJson> {
    set.iter()
        .map(|i| {
            let p = a.partner.get(i).copied().flatten();
            NotKeptJson {
                label: label::<N>(i),
                aligned_with: p.map(|p| label::<N>(p.param.0)),
                cosine: p.map(|p| p.cosine),
                found_at_fit: at_fit.contains(i),
            }
        })
        .collect()
}

/// The identifiability report as written to files (`found_at_fit`: as
/// `Calibration::found_at_fit`).
pub fn identifiability_json<const N: usize>(
    a: &Identifiability,
    singular_values: &[f64],
    found_at_fit: &ParamSet,
) -> IdentifiabilityJson {
    let none = ParamSet::new();
    IdentifiabilityJson {
        requested: labels::<N>(&a.requested),
        identifiable: labels::<N>(&a.identifiable),
        structurally_redundant: not_kept::<N>(&a.structural, a, &none),
        data_deficient: not_kept::<N>(&a.data_deficient, a, found_at_fit),
        not_observable: not_kept::<N>(&a.gauge, a, &none),
        rank: a.rank,
        condition_number: finite_or_none(a.condition_number),
        singular_values: singular_values.to_vec(),
    }
}

fn disagreement<const N: usize>(d: &Disagreement) -> DisagreementJson {
    let unit = ParamId::from_index(d.param, N).map_or("", si_unit);
    DisagreementJson {
        label: label::<N>(d.param.0),
        unit: unit.to_string(),
        a: d.a.name().to_string(),
        b: d.b.name().to_string(),
        difference: d.difference,
        combined_std_error: d.combined_std_error,
        tolerance: d.tolerance,
    }
}

/// The consensus as written to files.
pub fn consensus_json<const N: usize>(c: &Consensus) -> ConsensusJson {
    ConsensusJson {
        agree: c.agree(),
        rule: format!(
            "two algorithms disagree on a parameter when |difference| > {} * sqrt(se_a^2 + se_b^2) + {:e} (SI units), each run's std errors rescaled to the smallest residual variance of the runs",
            c.k_sigma, c.floor_si
        ),
        k_sigma: c.k_sigma,
        floor_si: c.floor_si,
        largest: c.largest.as_ref().map(disagreement::<N>),
        disagreeing: c.disagreeing.iter().map(disagreement::<N>).collect(),
    }
}

fn robust_run_json(r: &RobustRun, labels: &dyn Fn(usize) -> Option<PoseLabel>) -> RobustRunJson {
    let orientation = r.poses.iter().any(|p| p.components > 3);
    RobustRunJson {
        reweights: r.reweights,
        scale_pos_mm: r.test.scale_pos_m * 1e3,
        scale_rot_deg: orientation.then(|| r.test.scale_rot_rad.to_degrees()),
        suspects: r
            .suspects()
            .into_iter()
            .map(|i| {
                let p = &r.poses[i];
                let label = labels(i);
                SuspectJson {
                    line: label.as_ref().map_or(0, |l| l.line),
                    pose_id: label.and_then(|l| l.pose_id),
                    distance: p.distance,
                    pos_mm: p.pos_m * 1e3,
                    rot_deg: (p.components > 3).then(|| p.rot_rad.to_degrees()),
                    robust_weight: p.robust_weight,
                }
            })
            .collect(),
    }
}

impl ModelFile {
    /// A nominal robot (no calibration).
    pub fn nominal<const N: usize>(name: &str, robot: &Robot<N>) -> Self {
        ModelFile {
            schema_version: SCHEMA_VERSION.to_string(),
            format: FORMAT.to_string(),
            generator: generator(),
            robot: RobotJson::from_robot(name, robot, robot, None, EffectSet::NONE),
            calibration: None,
        }
    }

    /// The model of run `primary` of a calibration, recording every run and the consensus.
    pub fn from_calibration<const N: usize>(
        name: &str,
        cal: &Calibration<N>,
        primary: usize,
        data: DataJson,
        allow_out_of_limits: bool,
    ) -> Self {
        let main = &cal.runs[primary].ident;
        let info = ParamInfo {
            analysis: &cal.analysis,
            std_errors: &main.std_errors,
            at_bound: &main.at_bound,
        };
        let s = &cal.settings;
        let (wp, wr) = s.weighting.weights();
        let results = cal
            .runs
            .iter()
            .map(|run| {
                let r = &run.ident;
                ResultJson {
                    algorithm: r.algorithm.name().to_string(),
                    iterations: r.iterations,
                    seconds: run.seconds,
                    sigma2: r.sigma2,
                    residuals: ResidualsJson {
                        before: stats(&r.initial),
                        after: stats(&r.fitted),
                    },
                    parameters: cal
                        .analysis
                        .identifiable
                        .iter()
                        .map(|i| ResultParamJson {
                            label: label::<N>(i),
                            value: r.robot.param(ParamIndex(i)).unwrap_or(f64::NAN),
                            std_error: r.std_errors[i],
                            at_bound: r.at_bound.contains(i),
                        })
                        .collect(),
                    correlations: r
                        .correlations()
                        .iter()
                        .map(|c| CorrelationJson {
                            a: label::<N>(c.a.0),
                            b: label::<N>(c.b.0),
                            rho: c.rho,
                        })
                        .collect(),
                    robust: None,
                }
            })
            .collect();
        ModelFile {
            schema_version: SCHEMA_VERSION.to_string(),
            format: FORMAT.to_string(),
            generator: generator(),
            robot: RobotJson::from_robot(name, &main.robot, &cal.start, Some(&info), s.effects),
            calibration: Some(CalibrationJson {
                data,
                algorithm: main.algorithm.name().to_string(),
                algorithms: s.algorithms.iter().map(|a| a.name().to_string()).collect(),
                effects: s.effects.iter().map(|e| e.name().to_string()).collect(),
                options: OptionsJson {
                    orientation_error: match s.orientation {
                        kincal::pose::OrientationError::Exact => "exact",
                        kincal::pose::OrientationError::SmallAngle => "small_angle",
                    }
                    .to_string(),
                    weighting: s.weighting.name().to_string(),
                    weight_pos: wp,
                    weight_rot: wr,
                    bounds_length_mm: s.bounds_length_m * 1e3,
                    bounds_angle_deg: s.bounds_angle_rad.to_degrees(),
                    allow_data_deficiency: s.allow_data_deficiency,
                    allow_out_of_limits,
                    max_iterations: s.max_iterations,
                    prior: s.prior.map(|p| PriorJson {
                        length_mm: p.length_m * 1e3,
                        angle_deg: p.angle_rad.to_degrees(),
                        frame_length_mm: p
                            .frame_length_m
                            .is_finite()
                            .then_some(p.frame_length_m * 1e3),
                        frame_angle_deg: p
                            .frame_angle_rad
                            .is_finite()
                            .then_some(p.frame_angle_rad.to_degrees()),
                        chi2: main.prior_chi2,
                        rows: main.prior_rows,
                        held: main.prior_held.iter().map(label::<N>).collect(),
                    }),
                },
                identifiability: identifiability_json::<N>(
                    &cal.analysis,
                    &cal.singular_values,
                    &cal.found_at_fit,
                ),
                residuals: ResidualsJson {
                    before: stats(&main.initial),
                    after: stats(&main.fitted),
                },
                results,
                failed: cal
                    .failed
                    .iter()
                    .map(|(a, e)| FailedRunJson {
                        algorithm: a.name().to_string(),
                        error: e.to_string(),
                    })
                    .collect(),
                consensus: cal.consensus.as_ref().map(consensus_json::<N>),
                robust: None,
                warnings: Vec::new(),
                constraints: None,
            }),
        }
    }

    /// Records the robust fits of `cal` (runs with `Calibration::runs[k].robust`): each
    /// result's scales and suspects, and under `calibration.robust` the loss, thresholds and
    /// run `primary`'s (the model's). `labels(i)` places pose `i` in DATA. Nothing is
    /// recorded without a robust fit.
    pub fn record_robust<const N: usize>(
        &mut self,
        cal: &Calibration<N>,
        primary: usize,
        labels: &dyn Fn(usize) -> Option<PoseLabel>,
    ) {
        let (Some(c), Some(opts)) = (self.calibration.as_mut(), cal.settings.robust) else {
            return;
        };
        for (res, run) in c.results.iter_mut().zip(&cal.runs) {
            res.robust = run.robust.as_ref().map(|r| robust_run_json(r, labels));
        }
        let Some(main) = cal.runs.get(primary) else {
            return;
        };
        c.robust = main.robust.as_ref().map(|r| RobustJson {
            loss: opts.loss.name().to_string(),
            tuning_chi2: opts.tuning_chi2,
            suspect_chi2: opts.suspect_chi2,
            algorithm: main.ident.algorithm.name().to_string(),
            run: robust_run_json(r, labels),
        });
    }

    /// Pretty JSON text (ends with a newline).
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).unwrap_or_default();
        s.push('\n');
        s
    }
}

fn generator() -> String {
    format!("kincal {}", env!("CARGO_PKG_VERSION"))
}

// ---------------------------------------------------------------------------------------
// Reading

/// Whether `text` looks like a model file (a JSON object), so MODEL arguments can tell
/// model files from robot descriptions.
pub fn looks_like_json(text: &str) -> bool {
    text.trim_start().starts_with('{')
}

/// Parses and checks a model file's text; `source` names it in messages.
pub fn parse(text: &str, source: &str) -> Result<ModelFile, CliError> {
    let at = |e: &serde_json::Error| format!("{source}:{}:{}", e.line(), e.column());
    let value: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| CliError::input(format!("{}: not valid JSON: {e}", at(&e))))?;
    let version = value
        .get("schema_version")
        .and_then(|v| v.as_str())
        .ok_or_else(|| {
            CliError::input(format!(
                "{source}: missing \"schema_version\": not a kincal model file"
            ))
        })?;
    let major = version
        .split('.')
        .next()
        .and_then(|m| m.parse::<u64>().ok())
        .ok_or_else(|| {
            CliError::input(format!(
                "{source}: schema_version \"{version}\" is not of the form MAJOR.MINOR"
            ))
        })?;
    if major > SCHEMA_MAJOR {
        return Err(CliError::input(format!(
            "{source}: schema_version {version} is newer than this kincal reads \
             ({SCHEMA_MAJOR}.x): the file was written by a newer kincal; upgrade kincal to read it"
        )));
    }
    if major < SCHEMA_MAJOR {
        return Err(CliError::input(format!(
            "{source}: schema_version {version} is older than any this kincal reads ({SCHEMA_MAJOR}.x)"
        )));
    }
    let file: ModelFile =
        serde_json::from_str(text).map_err(|e| CliError::input(format!("{}: {e}", at(&e))))?;
    if file.format != FORMAT {
        return Err(CliError::input(format!(
            "{source}: format \"{}\" is not \"{FORMAT}\"",
            file.format
        )));
    }
    Ok(file)
}

fn arr<const N: usize, T: Copy>(v: &[T], what: &str) -> Result<[T; N], String> {
    v.try_into().map_err(|_| {
        format!(
            "\"{what}\" has {} entries, the robot has {N} joints",
            v.len()
        )
    })
}

impl RobotJson {
    /// The robot with every parameter at its `value`.
    pub fn robot<const N: usize>(&self) -> Result<Robot<N>, String> {
        if self.n_joints != N {
            return Err(format!("n_joints is {}, expected {N}", self.n_joints));
        }
        let links: [LinkJson; N] = arr(&self.nominal.links, "nominal.links")?;
        let limits: [LimitsJson; N] = arr(&self.joint_limits, "joint_limits")?;
        let masses: [f64; N] = arr(&self.mass.link_masses_kg, "mass.link_masses_kg")?;
        let choices: [LengthChoice; N] = arr(&self.length_params, "length_params")?;
        fn e(what: &str) -> impl Fn(kincal::Error) -> String + '_ {
            move |err| format!("{what}: {err}")
        }
        let mut r = Robot::new(
            links.map(|l| Link {
                theta0: l.theta0,
                d: l.d,
                a: l.a,
                alpha: l.alpha,
                beta: l.beta,
            }),
            limits.map(|l| JointLimits::new(l.lower, l.upper)),
        )
        .map_err(e("nominal geometry or joint limits"))?
        .with_base(self.nominal.base)
        .map_err(e("nominal.base"))?
        .with_tool(self.nominal.tool)
        .map_err(e("nominal.tool"))?
        .with_mass(MassModel {
            link_masses_kg: masses,
            tool_mass_kg: self.mass.tool_mass_kg,
            gravity: self.mass.gravity_m_s2,
        })
        .map_err(e("mass"))?;
        for (link, c) in choices.iter().enumerate() {
            let lp = match c {
                LengthChoice::D => LengthParam::D,
                LengthChoice::Beta => LengthParam::Beta,
            };
            r.set_length_param(link, lp).map_err(e("length_params"))?;
        }
        if !self.joint_types.is_empty() {
            let kinds: [JointTypeJson; N] = arr(&self.joint_types, "joint_types")?;
            for (j, k) in kinds.iter().enumerate() {
                let kind = match k {
                    JointTypeJson::Revolute => JointKind::Revolute,
                    JointTypeJson::Prismatic => JointKind::Prismatic,
                    JointTypeJson::Sensor => JointKind::Sensor,
                };
                r.set_joint_kind(j, kind).map_err(e("joint_types"))?;
            }
        }
        let mut seen = vec![false; Robot::<N>::NUM_PARAMS];
        for p in &self.parameters {
            let id = ParamId::parse(&p.label, N)
                .ok_or_else(|| format!("unknown parameter label \"{}\"", p.label))?;
            let i = id.index(N).0;
            if std::mem::replace(&mut seen[i], true) {
                return Err(format!("parameter \"{}\" appears twice", p.label));
            }
            if matches!(crate::units::si_unit(id), "m" | "rad")
                && let Some(why) = crate::units::implausible_si(p.value)
            {
                return Err(format!("parameter \"{}\": {why}", p.label));
            }
            r.set_param(ParamIndex(i), p.value)
                .map_err(e(&format!("parameter \"{}\"", p.label)))?;
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(format!("parameter \"{}\" is missing", label::<N>(i)));
        }
        Ok(r)
    }

    /// The robot with every parameter at its `nominal` value (before calibration).
    pub fn nominal_robot<const N: usize>(&self) -> Result<Robot<N>, String> {
        let mut r = self.robot::<N>()?;
        for p in &self.parameters {
            if let Some(id) = ParamId::parse(&p.label, N) {
                r.set_param(id.index(N), p.nominal)
                    .map_err(|err| format!("parameter \"{}\" nominal: {err}", p.label))?;
            }
        }
        Ok(r)
    }

    /// The robot as a run-time joint count.
    pub fn any_robot(&self) -> Result<AnyRobot, String> {
        macro_rules! by_n {
            ($($n:literal)*) => {
                match self.n_joints {
                    $($n => Ok(AnyRobot::from(self.robot::<$n>()?)),)*
                    n => Err(format!(
                        "n_joints is {n}: kincal supports 1 to {} joints",
                        kincal::any::MAX_JOINTS
                    )),
                }
            };
        }
        by_n!(1 2 3 4 5 6 7 8 9 10 11 12)
    }
}

impl ModelFile {
    /// The models to compare in `validate`: `NOM` (every parameter at its nominal value),
    /// then one per algorithm recorded in the calibration (`OLS`, `OPT1`, `OPT2`), each the
    /// model with that algorithm's identified parameters. Without a calibration: `NOM` only.
    pub fn variants<const N: usize>(&self) -> Result<Vec<(String, Robot<N>)>, String> {
        let model = self.robot.robot::<N>()?;
        let mut out = vec![("NOM".to_string(), self.robot.nominal_robot::<N>()?)];
        let Some(cal) = &self.calibration else {
            return Ok(out);
        };
        for res in &cal.results {
            let mut r = model;
            for p in &res.parameters {
                let id = ParamId::parse(&p.label, N)
                    .ok_or_else(|| format!("results: unknown parameter label \"{}\"", p.label))?;
                r.set_param(id.index(N), p.value)
                    .map_err(|err| format!("results: parameter \"{}\": {err}", p.label))?;
            }
            out.push((res.algorithm.to_uppercase(), r));
        }
        Ok(out)
    }

    /// The effects of the model (names checked).
    pub fn effects(&self) -> Result<EffectSet, String> {
        self.robot
            .effects
            .iter()
            .try_fold(EffectSet::NONE, |acc, n| {
                Effect::parse(n)
                    .map(|e| acc.with(e))
                    .ok_or_else(|| format!("unknown effect \"{n}\""))
            })
    }

    /// The algorithm of the stored model, if calibrated.
    pub fn algorithm(&self) -> Option<Algorithm> {
        self.calibration
            .as_ref()
            .and_then(|c| Algorithm::parse(&c.algorithm))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::aria;

    /// A robot with every parameter moved off its nominal value (links, base, tool and
    /// effects), so the round trip covers the whole layout.
    fn perturbed() -> Robot<6> {
        let mut r = aria::virtual_truth();
        let mut s: u64 = 0x1234_5678;
        for i in 0..Robot::<6>::NUM_PARAMS {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let v = r.param(ParamIndex(i)).unwrap() + 1e-3 * u;
            r.set_param(ParamIndex(i), v).unwrap();
        }
        r
    }

    #[test]
    fn model_file_reloads_the_same_robot_bit_for_bit() {
        let r = perturbed();
        let file = ModelFile {
            schema_version: SCHEMA_VERSION.into(),
            format: FORMAT.into(),
            generator: generator(),
            robot: RobotJson::from_robot("aria", &r, &aria::nominal(), None, EffectSet::NONE),
            calibration: None,
        };
        let text = file.to_json();
        let back = parse(&text, "mem").unwrap();
        assert_eq!(back, file);
        let loaded = back.robot.robot::<6>().unwrap();
        assert_eq!(loaded, r, "every field of the core robot");
        for q in [[0.1, 0.2, -0.3, 0.4, 0.5, -0.6], aria::TOOL_SEED_Q] {
            let mut st = kincal::JointState::new(q);
            st.approach = Some([1.0, -1.0, 0.0, 1.0, 1.0, -1.0]);
            st.temp_c = Some(31.5);
            let (a, b) = (r.fk(&st).unwrap(), loaded.fk(&st).unwrap());
            assert_eq!(a.to_homogeneous(), b.to_homogeneous());
        }
        // The nominal variant gives back the initial values.
        let nom = back.robot.nominal_robot::<6>().unwrap();
        for i in 0..Robot::<6>::NUM_PARAMS {
            assert_eq!(
                nom.param(ParamIndex(i)).unwrap().to_bits(),
                aria::nominal().param(ParamIndex(i)).unwrap().to_bits()
            );
        }
    }

    #[test]
    fn json_numbers_round_trip_exactly() {
        let mut s: u64 = 99;
        let mut values = vec![
            0.1 + 0.2,
            5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            -0.0,
            1.0 / 3.0,
            std::f64::consts::FRAC_PI_2,
            f64::from_bits(0x000F_FFFF_FFFF_FFFF),
        ];
        for _ in 0..20_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let v = f64::from_bits(s);
            if v.is_finite() {
                values.push(v);
            }
        }
        let text = serde_json::to_string(&values).unwrap();
        let back: Vec<f64> = serde_json::from_str(&text).unwrap();
        for (a, b) in values.iter().zip(&back) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a:e}");
        }
    }

    #[test]
    fn robust_block_round_trips_flat() {
        let r = RobustJson {
            loss: "cauchy".into(),
            tuning_chi2: kincal::identify::robust::CHI2_95,
            suspect_chi2: kincal::identify::robust::CHI2_9999,
            algorithm: "ols".into(),
            run: RobustRunJson {
                reweights: 12,
                scale_pos_mm: 0.1 + 0.2,
                scale_rot_deg: None,
                suspects: vec![SuspectJson {
                    line: 26,
                    pose_id: Some("p24".into()),
                    distance: 99.2,
                    pos_mm: 4.999,
                    rot_deg: None,
                    robust_weight: 1.277e-3,
                }],
            },
        };
        let text = serde_json::to_string(&r).unwrap();
        // The run's fields sit beside the loss (flattened), as documented.
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["suspects"][0]["line"], 26);
        assert_eq!(v["reweights"], 12);
        let back: RobustJson = serde_json::from_str(&text).unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn newer_major_version_is_refused_and_minor_accepted() {
        let file = ModelFile::nominal("aria", &aria::nominal());
        let text = file.to_json();
        let newer = text.replace("\"schema_version\": \"1.0\"", "\"schema_version\": \"2.0\"");
        let e = parse(&newer, "m.json").unwrap_err();
        assert_eq!(e.kind, crate::error::Kind::Input);
        assert!(e.message.contains("newer"), "{}", e.message);
        let minor = text.replace(
            "\"schema_version\": \"1.0\"",
            "\"schema_version\": \"1.7\", \"a_future_field\": [1, 2]",
        );
        assert!(parse(&minor, "m.json").is_ok());
        let broken = text.replace("\"label\": \"d_1\"", "\"label\": \"d_9\"");
        let f = parse(&broken, "m.json").unwrap();
        assert!(f.robot.robot::<6>().unwrap_err().contains("d_9"));
        let bad = parse("{\"schema_version\": \"1.0\",\n \"format\": 3}", "m.json").unwrap_err();
        assert!(bad.message.starts_with("m.json:2:"), "{}", bad.message);
    }
}
