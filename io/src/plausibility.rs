//! Plausibility of a calibration's data and result (issue #16 item 12): grossly wrong data
//! — millimetres under metre headers, metres under millimetre headers — and a result worse
//! than the robot it started from must not pass silently with exit 0.
//!
//! What cannot be right (positions a hundred times beyond the robot's reach) is an error,
//! overridden by `--allow-implausible`; what is suspicious is a warning, printed on stderr
//! and recorded in the model file (`calibration.warnings`).

use kincal::Robot;
use kincal::identify::Measurement;

use crate::model_file::ModelFile;

/// Positions whose median distance from the base exceeds this many reaches cannot be the
/// robot's (a 1000× unit error, e.g. millimetres under a metre header).
pub const IMPOSSIBLE_REACH_FACTOR: f64 = 100.0;
/// A measured position farther than this many reaches from the base is out of reach.
pub const OUT_OF_REACH_FACTOR: f64 = 1.5;
/// Positions whose median distance from the base is below this fraction of the reach look
/// like metres written under a millimetre header.
pub const TINY_REACH_FRACTION: f64 = 0.01;
/// An identified length or angle that moved more than this many OPT1 interval half-widths
/// (`--bounds-mm`, `--bounds-deg`) from its nominal value is reported.
pub const CHANGE_BOUND_FACTOR: f64 = 10.0;

/// Findings about the data before the fit.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DataFindings {
    /// Cannot be right: refused unless overridden.
    pub errors: Vec<String>,
    /// Suspicious: printed and recorded.
    pub warnings: Vec<String>,
}

/// The robot's reach [m]: the sum of its link lengths |d| + |a| and its tool offset (an
/// upper bound of the distance from the first joint to the tool).
pub fn reach_m<const N: usize>(robot: &Robot<N>) -> f64 {
    let links: f64 = robot.links().iter().map(|l| l.d.abs() + l.a.abs()).sum();
    let t = robot.tool();
    let tool = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    links + tool
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}

/// Checks the measured positions against the robot's reach. `frames_unknown`: the base
/// frame will be estimated (`--init-frames`), so the positions may lie in an instrument
/// frame anywhere: the distance checks only warn then.
pub fn check_data<const N: usize>(
    robot: &Robot<N>,
    meas: &[Measurement<N>],
    source: &str,
    frames_unknown: bool,
) -> DataFindings {
    let mut f = DataFindings::default();
    let reach = reach_m(robot);
    let b = robot.base();
    let base = nalgebra::Vector3::new(b[0], b[1], b[2]);
    let dist: Vec<f64> = meas
        .iter()
        .filter(|m| m.mask.has(0))
        .map(|m| (m.pose.translation.vector - base).norm())
        .collect();
    let far = dist
        .iter()
        .filter(|&&d| d > OUT_OF_REACH_FACTOR * reach)
        .count();
    let measured = dist.len();
    let (Some(med), true) = (median(dist), reach > 0.0) else {
        return f;
    };
    if med > IMPOSSIBLE_REACH_FACTOR * reach {
        let msg = format!(
            "{source}: the measured positions lie a median {med:.3} m from the base, {:.0}× the robot's reach of {reach:.3} m: millimetres under a metre header (use x_mm, y_mm, z_mm)?",
            med / reach
        );
        if frames_unknown {
            f.warnings.push(msg);
        } else {
            f.errors.push(msg);
        }
    } else if far > 0 {
        f.warnings.push(format!(
            "{source}: {far} of {measured} measured positions lie more than {OUT_OF_REACH_FACTOR}× the robot's reach ({reach:.3} m) from the base: out of reach{}",
            if frames_unknown {
                " (expected if the instrument frame is far from the base)"
            } else {
                ": a wrong base frame or unit?"
            }
        ));
    }
    if med < TINY_REACH_FRACTION * reach && !frames_unknown {
        f.warnings.push(format!(
            "{source}: the measured positions lie a median {:.3} mm from the base, {:.4}× the robot's reach of {reach:.3} m: metres under a millimetre header?",
            med * 1e3,
            med / reach
        ));
    }
    f
}

/// `x` to six decimals, for a message (a tolerance given as 60° is stored as
/// 59.99999999999999° after its round trip through radians).
fn round6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

/// Warnings about a written calibration: a residual worse after than before (position or
/// orientation), identified parameters whose standard error exceeds the OPT1 interval's
/// half-width (the data determine them worse than the manufacturing tolerance does),
/// identified changes far outside the OPT1 intervals.
pub fn check_result(file: &ModelFile) -> Vec<String> {
    let mut w = Vec::new();
    let Some(cal) = &file.calibration else {
        return w;
    };
    let (b, a) = (&cal.residuals.before, &cal.residuals.after);
    // A fit may trade one component for the other; a worse RMS by more than rounding says
    // the fit did not improve that component at all.
    let worse = |after: f64, before: f64| after > before * (1.0 + 1e-6) + 1e-12;
    if worse(a.rms_pos_mm, b.rms_pos_mm) {
        w.push(format!(
            "the position RMS is worse after calibration ({:.4} mm) than before ({:.4} mm): wrong units, weights or data?",
            a.rms_pos_mm, b.rms_pos_mm
        ));
    }
    if worse(a.rms_rot_deg, b.rms_rot_deg) {
        w.push(format!(
            "the orientation RMS is worse after calibration ({:.4}°) than before ({:.4}°): wrong units, weights (--sigma-*) or data?",
            a.rms_rot_deg, b.rms_rot_deg
        ));
    }
    let bound = |unit: &str| match unit {
        "m" => Some(cal.options.bounds_length_mm * 1e-3),
        "rad" => Some(cal.options.bounds_angle_deg.to_radians()),
        _ => None,
    };
    // The identified parameters for which `pick` (given the tolerance) returns an amount,
    // each named with it: a signed change ("d_7 +267.7 mm") or, `spread`, a standard error
    // ("theta0_6 ±63.01°").
    let listed =
        |spread: bool, pick: &dyn Fn(&crate::model_file::ParamJson, f64) -> Option<f64>| {
            file.robot
                .parameters
                .iter()
                .filter(|p| p.identified)
                .filter_map(|p| {
                    let x = pick(p, bound(&p.unit)?)?;
                    let (v, unit, digits) = if p.unit == "m" {
                        (x * 1e3, " mm", 1)
                    } else {
                        (x.to_degrees(), "°", 2)
                    };
                    Some(if spread {
                        format!("{} ±{v:.digits$}{unit}", p.label)
                    } else {
                        format!("{} {v:+.digits$}{unit}", p.label)
                    })
                })
                .collect::<Vec<String>>()
        };
    let far = listed(false, &|p, b| {
        let change = p.value - p.nominal;
        (change.abs() > CHANGE_BOUND_FACTOR * b).then_some(change)
    });
    let vague = listed(true, &|p, b| p.std_error.filter(|&se| se > b));
    if !vague.is_empty() {
        w.push(format!(
            "the data barely determine {}: standard errors above the tolerance (±{} mm, ±{}°), so these estimates may be far off; more poses or measured points, a prior (--prior) or leaving them out of the fit would help",
            vague.join(", "),
            round6(cal.options.bounds_length_mm),
            round6(cal.options.bounds_angle_deg),
        ));
    }
    if !far.is_empty() {
        w.push(format!(
            "identified changes beyond {CHANGE_BOUND_FACTOR}× the tolerance (±{} mm, ±{}°): {}: a wrong nominal model, unit or data?",
            round6(cal.options.bounds_length_mm),
            round6(cal.options.bounds_angle_deg),
            far.join(", ")
        ));
    }
    w
}
