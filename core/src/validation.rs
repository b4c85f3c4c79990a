//! Validation metrics (Section 4.4): per-pose position and orientation errors, their
//! summary, and the biopsy accuracy requirement of eq. (3).

use crate::error::{Error, Quantity, Result, check_finite};
use crate::identify::{ComponentMask, Measurement};
use crate::math::{asin, sqrt};
use crate::model::Robot;
use crate::pose::{OrientationError, Transform, pose_error};

/// Errors of one pose, measured minus model, in the base frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseErrors {
    /// Position error e_x, e_y, e_z \[m\].
    pub pos_m: [f64; 3],
    /// Orientation error (rotation vector) \[rad\].
    pub rot_rad: [f64; 3],
    /// |e_p| \[m\].
    pub pos_norm_m: f64,
    /// |e_φ|, the rotation angle \[rad\].
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

    /// Errors of `robot` on measurement `m` ([`Measurement::model_pose`], so a measured
    /// point is honoured), with the components `m` does not measure set to zero and the
    /// norms taken over the measured ones (a kind measured in full keeps the norm of
    /// [`PoseErrors::between`] bit for bit).
    pub fn of_measurement<const N: usize>(robot: &Robot<N>, m: &Measurement<N>) -> Result<Self> {
        let t = m.model_pose(robot)?;
        Ok(Self::between(&m.pose, &t).masked(m.mask))
    }

    /// These errors with the components `mask` does not carry set to zero (norms
    /// recomputed for a kind only partly measured).
    #[must_use]
    pub fn masked(mut self, mask: ComponentMask) -> Self {
        let n = |v: &[f64; 3]| sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if !mask.has_position() {
            for k in (0..3).filter(|&k| !mask.has(k)) {
                self.pos_m[k] = 0.0;
            }
            self.pos_norm_m = n(&self.pos_m);
        }
        if !mask.has_orientation() {
            for k in (0..3).filter(|&k| !mask.has(3 + k)) {
                self.rot_rad[k] = 0.0;
            }
            self.rot_norm_rad = n(&self.rot_rad);
        }
        self
    }
}

/// Streaming summary of pose errors: count, max and RMS of the norms (RMS as
/// sqrt(mean |e|²), the definition of spec/effects.md). [`ErrorSummary::add`] counts every
/// pose for both kinds; [`ErrorSummary::add_measured`] only for the kinds the pose measures,
/// so position-only poses do not dilute the orientation RMS.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorSummary {
    /// Number of poses.
    pub count: usize,
    /// Largest |e_p| \[m\].
    pub max_pos_m: f64,
    /// Largest |e_φ| \[rad\].
    pub max_rot_rad: f64,
    sum_sq_pos: f64,
    sum_sq_rot: f64,
    count_pos: usize,
    count_rot: usize,
}

impl ErrorSummary {
    /// Adds one pose (both kinds).
    pub fn add(&mut self, e: &PoseErrors) {
        self.count += 1;
        self.add_pos(e.pos_norm_m);
        self.add_rot(e.rot_norm_rad);
    }
    /// Adds one pose, each kind only if `mask` measures any of its components.
    pub fn add_measured(&mut self, e: &PoseErrors, mask: ComponentMask) {
        self.count += 1;
        if (0..3).any(|k| mask.has(k)) {
            self.add_pos(e.pos_norm_m);
        }
        if (3..6).any(|k| mask.has(k)) {
            self.add_rot(e.rot_norm_rad);
        }
    }
    fn add_pos(&mut self, e: f64) {
        self.count_pos += 1;
        self.max_pos_m = self.max_pos_m.max(e);
        self.sum_sq_pos += e * e;
    }
    fn add_rot(&mut self, e: f64) {
        self.count_rot += 1;
        self.max_rot_rad = self.max_rot_rad.max(e);
        self.sum_sq_rot += e * e;
    }
    /// Poses that contributed a position error.
    #[must_use]
    pub fn count_pos(&self) -> usize {
        self.count_pos
    }
    /// Poses that contributed an orientation error.
    #[must_use]
    pub fn count_rot(&self) -> usize {
        self.count_rot
    }
    /// RMS of |e_p| \[m\] (0 for no poses).
    #[must_use]
    pub fn rms_pos_m(&self) -> f64 {
        if self.count_pos == 0 {
            0.0
        } else {
            sqrt(self.sum_sq_pos / self.count_pos as f64)
        }
    }
    /// RMS of |e_φ| \[rad\] (0 for no poses).
    #[must_use]
    pub fn rms_rot_rad(&self) -> f64 {
        if self.count_rot == 0 {
            0.0
        } else {
            sqrt(self.sum_sq_rot / self.count_rot as f64)
        }
    }
}

/// Paper's targets used in Section 4.4: every pose error below 1 mm …
pub const TARGET_POS_M: f64 = 1e-3;
/// … and below 0.66° (eq. 3 with r_t = 5 mm, d = √3 mm, l_max = 0.2 m).
pub const TARGET_ROT_RAD: f64 = 0.66 * core::f64::consts::PI / 180.0;

/// Eq. (3): the largest orientation error \[rad\] that keeps the needle tip inside a tumour of
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
    /// Judges a summary against targets \[m\], \[rad\] (the worst pose decides).
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

#[cfg(test)]
mod tests {
    use super::*;

    fn e(p: [f64; 3], r: [f64; 3]) -> PoseErrors {
        let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        PoseErrors {
            pos_m: p,
            rot_rad: r,
            pos_norm_m: n(p),
            rot_norm_rad: n(r),
        }
    }

    #[test]
    fn masked_zeroes_what_is_not_measured() {
        let x = e([3.0, 4.0, 12.0], [0.1, 0.2, 0.2]);
        assert_eq!(x.masked(ComponentMask::ALL), x);
        let p = x.masked(ComponentMask::POSITION);
        assert_eq!(
            (p.pos_norm_m, p.rot_rad, p.rot_norm_rad),
            (13.0, [0.0; 3], 0.0)
        );
        let xy = x.masked(ComponentMask(0b0010_0011));
        assert_eq!(xy.pos_m, [3.0, 4.0, 0.0]);
        assert!((xy.pos_norm_m - 5.0).abs() < 1e-15);
        assert_eq!(xy.rot_rad, [0.0, 0.0, 0.2]);
        assert!((xy.rot_norm_rad - 0.2).abs() < 1e-15);
    }

    /// Poses 3-4-12 (full), 0-0-5 (position only) and 0 with |e_φ| = 0.3 (full): position
    /// RMS √((169 + 25 + 0)/3), orientation RMS over the two full poses √((0.09 + 0.09)/2)
    /// with `add_measured`, √(0.18/3) with `add`.
    #[test]
    fn add_measured_counts_each_kind_over_the_poses_measuring_it() {
        let poses = [
            (e([3.0, 4.0, 12.0], [0.0, 0.3, 0.0]), ComponentMask::ALL),
            (e([0.0, 0.0, 5.0], [0.0; 3]), ComponentMask::POSITION),
            (e([0.0; 3], [0.0, 0.0, 0.3]), ComponentMask::ALL),
        ];
        let (mut m, mut a) = (ErrorSummary::default(), ErrorSummary::default());
        for (x, mask) in &poses {
            m.add_measured(x, *mask);
            a.add(x);
        }
        assert_eq!((m.count, m.count_pos(), m.count_rot()), (3, 3, 2));
        assert_eq!((a.count, a.count_pos(), a.count_rot()), (3, 3, 3));
        assert!((m.rms_pos_m() - (194.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(m.rms_pos_m(), a.rms_pos_m());
        assert!((m.rms_rot_rad() - 0.3).abs() < 1e-15);
        assert!((a.rms_rot_rad() - (0.06f64).sqrt()).abs() < 1e-15);
        assert_eq!((m.max_pos_m, m.max_rot_rad), (13.0, 0.3));
        assert_eq!(ErrorSummary::default().rms_rot_rad(), 0.0);
    }
}
