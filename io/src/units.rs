//! Units of the model parameters: SI in files, millimetres and degrees on screen.

use kincal::ParamId;

/// Largest magnitude a reader accepts for a length [m], a position [m] or an angle [rad]
/// (joint readings, frames, mDH parameters, limits). Real arms and instruments stay far
/// below it; beyond it a number is a unit or export error, and its square or product with
/// another (error norms, transforms) could overflow to infinity downstream.
pub const MAX_MAGNITUDE_SI: f64 = 1e3;

/// Why `v` [m or rad, SI] is implausible, if it is.
pub fn implausible_si(v: f64) -> Option<String> {
    (v.abs() > MAX_MAGNITUDE_SI).then(|| {
        format!(
            "{v:e} is implausibly large: expected a magnitude of at most {MAX_MAGNITUDE_SI} (metres or radians)"
        )
    })
}

/// SI unit of a parameter as written in model files.
pub fn si_unit(id: ParamId) -> &'static str {
    match id {
        ParamId::Link { kind, .. } => {
            if kind.is_length() {
                "m"
            } else {
                "rad"
            }
        }
        ParamId::Base(_) | ParamId::Tool(_) => {
            if id.is_length() {
                "m"
            } else {
                "rad"
            }
        }
        ParamId::Compliance(_) => "rad/(N·m)",
        ParamId::Scale(_) => "1",
        ParamId::Cyclic(..) | ParamId::Backlash(_) => "rad",
        ParamId::Thermal => "1/K",
    }
}

/// SI unit of a parameter of a model whose joint `j` is prismatic when
/// `prismatic(j)`: a prismatic joint's effects act on a length, so its compliance is in
/// m/N (Δd = c·F along the axis), its backlash and cyclic terms in m. Every other
/// parameter as [`si_unit`].
pub fn si_unit_for(id: ParamId, prismatic: impl Fn(usize) -> bool) -> &'static str {
    match id {
        ParamId::Compliance(j) if prismatic(j) => "m/N",
        ParamId::Cyclic(j, _) | ParamId::Backlash(j) if prismatic(j) => "m",
        _ => si_unit(id),
    }
}

/// Unit shown on screen and the factor from the SI value to it.
pub fn display_unit(id: ParamId) -> (&'static str, f64) {
    match si_unit(id) {
        "m" => ("mm", 1e3),
        "rad" => ("deg", 180.0 / std::f64::consts::PI),
        other => (other, 1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prismatic_joint_labels_its_effects_as_lengths() {
        let prismatic = |j: usize| j == 1;
        assert_eq!(si_unit_for(ParamId::Compliance(1), prismatic), "m/N");
        assert_eq!(si_unit_for(ParamId::Backlash(1), prismatic), "m");
        assert_eq!(si_unit_for(ParamId::Compliance(0), prismatic), "rad/(N·m)");
        assert_eq!(si_unit_for(ParamId::Backlash(0), prismatic), "rad");
        assert_eq!(si_unit_for(ParamId::Scale(1), prismatic), "1");
    }
}
