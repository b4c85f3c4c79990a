//! The noise floor: stated by the user, or pooled from repeated measurements.

use super::{Config, NoiseFloor, PoseDiagnosis};
use crate::error::{Error, Quantity, Result, check_finite};
use crate::identify::Measurement;
use crate::model::Robot;
use crate::pose::{OrientationError, pose_error};

/// Whether measurements `a` and `b` of the same group are repeats of the same physical
/// pose: same measured components, same approach directions (backlash makes
/// opposite-direction repeats differ, spec/effects.md), and — our extension of the same
/// reasoning to thermal expansion — temperatures within `temp_tol_c` (or both absent).
fn same_conditions<const N: usize>(
    a: &Measurement<N>,
    b: &Measurement<N>,
    temp_tol_c: f64,
) -> bool {
    let temp_ok = match (a.state.temp_c, b.state.temp_c) {
        (None, None) => true,
        (Some(x), Some(y)) => (x - y).abs() <= temp_tol_c,
        _ => false,
    };
    a.mask == b.mask && a.state.approach == b.state.approach && temp_ok
}

/// Pooled within-repeat sums of squares from the residuals against `reference` (any model
/// close to the arm: the residual differences between repeats remove the model's
/// prediction exactly when the readings are equal, and to second order otherwise).
/// A subgroup is a measurement and the later measurements of its group whose first match
/// ([`same_conditions`]) it is. Writes each measurement's subgroup leader into `poses`.
/// Returns `(ss_pos, dof_pos, ss_rot, dof_rot, subgroups)`, degrees of freedom counted per
/// axis. O(n²) time.
fn pooled<const N: usize>(
    reference: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    temp_tol_c: f64,
) -> Result<(f64, usize, f64, usize, usize)> {
    let n = data.len();
    for l in 0..n {
        let lead = (0..l)
            .find(|&m| {
                poses[m].leader == poses[l].leader
                    && same_conditions(&data[m], &data[l], temp_tol_c)
            })
            .unwrap_or(l);
        poses[l].sub_leader = lead as u32;
    }
    let (mut ss_p, mut dof_p, mut ss_r, mut dof_r, mut subgroups) = (0.0, 0, 0.0, 0, 0);
    let residual = |l: usize| -> Result<[f64; 6]> {
        let t = data[l].model_pose(reference)?;
        Ok(pose_error(&data[l].pose, &t, OrientationError::Exact))
    };
    for s in 0..n {
        if poses[s].sub_leader as usize != s {
            continue;
        }
        let count = (s..n)
            .filter(|&l| poses[l].sub_leader as usize == s)
            .count();
        if count < 2 {
            continue;
        }
        subgroups += 1;
        let mut mean = [0.0; 6];
        for l in (s..n).filter(|&l| poses[l].sub_leader as usize == s) {
            let e = residual(l)?;
            for k in 0..6 {
                mean[k] += e[k] / count as f64;
            }
        }
        for l in (s..n).filter(|&l| poses[l].sub_leader as usize == s) {
            let e = residual(l)?;
            for k in (0..6).filter(|&k| data[s].mask.has(k)) {
                let d = e[k] - mean[k];
                if k < 3 {
                    ss_p += d * d;
                } else {
                    ss_r += d * d;
                }
            }
        }
        for k in (0..6).filter(|&k| data[s].mask.has(k)) {
            if k < 3 {
                dof_p += count - 1;
            } else {
                dof_r += count - 1;
            }
        }
    }
    Ok((ss_p, dof_p, ss_r, dof_r, subgroups))
}

/// The noise floor of a diagnosis: stated σ where given (infinite degrees of freedom),
/// otherwise pooled from repeats. Fails with [`Error::MissingInput`] (`Quantity::NoiseFloor`)
/// when a measured component has neither.
pub(crate) fn noise_floor<const N: usize>(
    reference: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    cfg: &Config,
) -> Result<NoiseFloor> {
    let any_pos = data.iter().any(|m| (0..3).any(|k| m.mask.has(k)));
    let any_rot = data.iter().any(|m| (3..6).any(|k| m.mask.has(k)));
    let (ss_p, dof_p, ss_r, dof_r, subgroups) =
        pooled(reference, data, poses, cfg.repeat_temp_tol_c)?;
    let pick = |stated: Option<f64>, ss: f64, dof: usize, needed: bool| -> Result<(f64, f64)> {
        match stated {
            Some(s) => {
                check_finite(&[s], Quantity::Setting)?;
                if s <= 0.0 {
                    return Err(Error::InvalidParameter { index: 0, value: s });
                }
                Ok((s, f64::INFINITY))
            }
            None if dof > 0 && ss > 0.0 => Ok((crate::math::sqrt(ss / dof as f64), dof as f64)),
            None if !needed => Ok((1.0, f64::INFINITY)),
            None => Err(Error::MissingInput {
                what: Quantity::NoiseFloor,
            }),
        }
    };
    let (sp, np) = pick(cfg.sigma_pos_m, ss_p, dof_p, any_pos)?;
    let (sr, nr) = pick(cfg.sigma_rot_rad, ss_r, dof_r, any_rot)?;
    Ok(NoiseFloor {
        sigma_pos_m: sp,
        sigma_rot_rad: sr,
        dof_pos: np,
        dof_rot: nr,
        repeat_subgroups: subgroups,
        stated_pos: cfg.sigma_pos_m.is_some(),
        stated_rot: cfg.sigma_rot_rad.is_some(),
    })
}
