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

/// The label of parameter `i` of an `N`-joint robot (`a2`, `base_x`), or `#i` for an index
/// the robot has not.
pub fn param_label<const N: usize>(i: usize) -> String {
    kincal::ParamId::from_index(kincal::ParamIndex(i), N)
        .map_or_else(|_| format!("#{i}"), |id| id.to_string())
}

/// The labels of a parameter set, in index order.
pub fn param_labels<const N: usize>(set: &kincal::ParamSet) -> Vec<String> {
    set.iter().map(param_label::<N>).collect()
}

/// The label of a quantity the diagnosis correlates residuals with (`q2`, `tau2`, `s2`,
/// `temp_c`).
pub fn quantity_label(q: kincal::diagnosis::QuantityKind) -> String {
    let mut s = String::new();
    let _ = q.write_label(&mut s);
    s
}

/// The unit of such a quantity (joint angles in radians).
pub fn quantity_unit(q: kincal::diagnosis::QuantityKind) -> &'static str {
    use kincal::diagnosis::QuantityKind;
    match q {
        QuantityKind::JointAngle(_) => "rad",
        QuantityKind::GravityTorque(_) => "N·m",
        QuantityKind::Approach(_) => "",
        QuantityKind::Temperature => "°C",
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
