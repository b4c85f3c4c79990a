//! Validation metrics (Section 4.4): per-pose position and orientation errors, their
//! summary, and the biopsy accuracy requirement of eq. (3).

use crate::error::{Error, Quantity, Result, check_finite};
use crate::math::{asin, sqrt};
use crate::pose::{OrientationError, Transform, pose_error};

/// Errors of one pose, measured minus model, in the base frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseErrors {
    /// Position error e_x, e_y, e_z [m].
    pub pos_m: [f64; 3],
    /// Orientation error (rotation vector) [rad].
    pub rot_rad: [f64; 3],
    /// |e_p| [m].
    pub pos_norm_m: f64,
    /// |e_φ|, the rotation angle [rad].
    pub rot_norm_rad: f64,
}

impl PoseErrors {
    /// Errors of `measured` against `model` with the exact rotation-vector orientation error.
    #[must_use]
    pub fn between(measured: &Transform, model: &Transform) -> Self {
        let e = pose_error(measured, model, OrientationError::Exact);
        let pos_m = [e[0], e[1], e[2]];
        let rot_rad = [e[3], e[4], e[5]];
        let n = |v: &[f64; 3]| sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        PoseErrors {
            pos_norm_m: n(&pos_m),
            rot_norm_rad: n(&rot_rad),
            pos_m,
            rot_rad,
        }
    }
}

/// Streaming summary of pose errors: count, max and RMS of the norms (RMS as
/// sqrt(mean |e|²), the definition of spec/effects.md).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorSummary {
    /// Number of poses.
    pub count: usize,
    /// Largest |e_p| [m].
    pub max_pos_m: f64,
    /// Largest |e_φ| [rad].
    pub max_rot_rad: f64,
    sum_sq_pos: f64,
    sum_sq_rot: f64,
}

impl ErrorSummary {
    /// Adds one pose.
    pub fn add(&mut self, e: &PoseErrors) {
        self.count += 1;
        self.max_pos_m = self.max_pos_m.max(e.pos_norm_m);
        self.max_rot_rad = self.max_rot_rad.max(e.rot_norm_rad);
        self.sum_sq_pos += e.pos_norm_m * e.pos_norm_m;
        self.sum_sq_rot += e.rot_norm_rad * e.rot_norm_rad;
    }
    /// RMS of |e_p| [m] (0 for no poses).
    #[must_use]
    pub fn rms_pos_m(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            sqrt(self.sum_sq_pos / self.count as f64)
        }
    }
    /// RMS of |e_φ| [rad] (0 for no poses).
    #[must_use]
    pub fn rms_rot_rad(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            sqrt(self.sum_sq_rot / self.count as f64)
        }
    }
}

/// Paper's targets used in Section 4.4: every pose error below 1 mm …
pub const TARGET_POS_M: f64 = 1e-3;
/// … and below 0.66° (eq. 3 with r_t = 5 mm, d = √3 mm, l_max = 0.2 m).
pub const TARGET_ROT_RAD: f64 = 0.66 * core::f64::consts::PI / 180.0;

/// Eq. (3): the largest orientation error [rad] that keeps the needle tip inside a tumour of
/// radius `r_t_m` when the puncture point is off by `d_m` and the insertion is at most
/// `l_max_m` long: `2·asin((r_t − d) / (2·√2·l_max))`.
///
/// With r_t = 5 mm, d = |(1, 1, 1)| mm and l_max = 0.2 m this gives 0.66°:
/// ```
/// use kincal::validation::biopsy_allowed_rotation_rad;
/// let d = (3.0f64).sqrt() * 1e-3;
/// let allowed = biopsy_allowed_rotation_rad(5e-3, d, 0.2).unwrap();
/// assert!((allowed.to_degrees() - 0.66).abs() < 0.01);
/// ```
/// Fails with [`Error::InvalidParameter`] when `d_m >= r_t_m` (no orientation error is
/// allowed at all) or the inputs are not positive and finite.
pub fn biopsy_allowed_rotation_rad(r_t_m: f64, d_m: f64, l_max_m: f64) -> Result<f64> {
    check_finite(&[r_t_m, d_m, l_max_m], Quantity::Setting)?;
    if r_t_m <= 0.0 {
        return Err(Error::InvalidParameter {
            index: 0,
            value: r_t_m,
        });
    }
    if d_m < 0.0 || d_m >= r_t_m {
        return Err(Error::InvalidParameter {
            index: 1,
            value: d_m,
        });
    }
    if l_max_m <= 0.0 {
        return Err(Error::InvalidParameter {
            index: 2,
            value: l_max_m,
        });
    }
    let x = (r_t_m - d_m) / (2.0 * sqrt(2.0) * l_max_m);
    if x > 1.0 {
        // The tumour is larger than the reach of any orientation error.
        return Ok(core::f64::consts::PI);
    }
    Ok(2.0 * asin(x))
}

/// Pass/fail of one set of errors against position and orientation targets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// Every pose's |e_p| below the position target.
    pub pos_ok: bool,
    /// Every pose's |e_φ| below the orientation target.
    pub rot_ok: bool,
}

impl Verdict {
    /// Judges a summary against targets [m], [rad] (the worst pose decides).
    #[must_use]
    pub fn judge(summary: &ErrorSummary, target_pos_m: f64, target_rot_rad: f64) -> Self {
        Verdict {
            pos_ok: summary.max_pos_m < target_pos_m,
            rot_ok: summary.max_rot_rad < target_rot_rad,
        }
    }
    /// Both targets met.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.pos_ok && self.rot_ok
    }
}
