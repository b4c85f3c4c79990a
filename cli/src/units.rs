//! Units of the model parameters: SI in files, millimetres and degrees on screen.

use kincal::ParamId;

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

/// Unit shown on screen and the factor from the SI value to it.
pub fn display_unit(id: ParamId) -> (&'static str, f64) {
    match si_unit(id) {
        "m" => ("mm", 1e3),
        "rad" => ("deg", 180.0 / std::f64::consts::PI),
        other => (other, 1.0),
    }
}
