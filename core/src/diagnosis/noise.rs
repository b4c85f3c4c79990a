//! The noise floor: stated by the user, or pooled from repeated measurements.

use super::folds::NO_NEXT;
use super::{Config, NoiseFloor, PoseDiagnosis};
use crate::error::{Error, Quantity, Result, check_finite};
use crate::identify::Measurement;
use crate::model::Robot;
use crate::noise::{RepeatScatter, pooled_repeat_scatter_linked, repeat_leader_among};
use crate::pose::{OrientationError, pose_error};

/// Pooled within-repeat sums of squares from the residuals against `reference` (any model
/// close to the arm), by the shared [`crate::noise`] estimator: writes each measurement's
/// repeat-subgroup leader ([`crate::noise::repeat_leader`] within its group) into `poses`
/// and pools the scatter ([`crate::noise::pooled_repeat_scatter`]), walking each group's
/// member list ([`PoseDiagnosis::next`]): O(n × largest group) time.
fn pooled<const N: usize>(
    reference: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    temp_tol_c: f64,
) -> Result<RepeatScatter> {
    let next = |poses: &[PoseDiagnosis], m: usize| {
        poses.get(m).map_or(usize::MAX, |p| match p.next {
            NO_NEXT => usize::MAX,
            k => k as usize,
        })
    };
    for l in 0..data.len() {
        let first = poses[l].leader as usize;
        let members = core::iter::successors(Some(first), |&m| Some(next(poses, m)));
        let lead = repeat_leader_among(data, l, members, temp_tol_c);
        poses[l].sub_leader = lead as u32;
    }
    let poses = &*poses;
    pooled_repeat_scatter_linked(
        data.len(),
        // Suspect rows (gross outliers) belong to no subgroup.
        |l| {
            if poses[l].suspect {
                usize::MAX
            } else {
                poses[l].sub_leader as usize
            }
        },
        |l| next(poses, l),
        |l| data[l].mask,
        |l| {
            let t = data[l].model_pose(reference)?;
            Ok(pose_error(&data[l].pose, &t, OrientationError::Exact))
        },
    )
}

/// A stated σ the repeats show significantly too small (their σ over 1.25× the stated one
/// at z > 3, z of ln ratio² with the repeats' degrees of freedom) gives way to the repeats':
/// the floor cannot lie below the repeatability. Returns σ, its degrees of freedom and the
/// overruled stated σ.
fn overrule(
    stated: bool,
    sigma: f64,
    dof: f64,
    repeats: Option<(f64, f64)>,
) -> (f64, f64, Option<f64>) {
    match repeats {
        Some((s_rep, n_rep)) if stated && sigma > 0.0 => {
            let ratio = s_rep / sigma;
            let z = crate::math::ln(ratio * ratio) / crate::math::sqrt(2.0 / n_rep);
            if ratio > super::NOISE_CHECK_RATIO && z > super::NOISE_CHECK_Z {
                (s_rep, n_rep, Some(sigma))
            } else {
                (sigma, dof, None)
            }
        }
        _ => (sigma, dof, None),
    }
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
    let RepeatScatter {
        ss_pos: ss_p,
        dof_pos: dof_p,
        ss_rot: ss_r,
        dof_rot: dof_r,
        subgroups,
    } = pooled(reference, data, poses, cfg.repeat_temp_tol_c)?;
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
    let repeats = |ss: f64, dof: usize| {
        (dof > 0 && ss > 0.0).then(|| (crate::math::sqrt(ss / dof as f64), dof as f64))
    };
    let (sp, np, overruled_pos) = overrule(cfg.sigma_pos_m.is_some(), sp, np, repeats(ss_p, dof_p));
    let (sr, nr, overruled_rot) =
        overrule(cfg.sigma_rot_rad.is_some(), sr, nr, repeats(ss_r, dof_r));
    Ok(NoiseFloor {
        overruled_pos,
        overruled_rot,
        repeat_pos: repeats(ss_p, dof_p),
        repeat_rot: repeats(ss_r, dof_r),
        sigma_pos_m: sp,
        sigma_rot_rad: sr,
        dof_pos: np,
        dof_rot: nr,
        repeat_subgroups: subgroups,
        stated_pos: cfg.sigma_pos_m.is_some(),
        stated_rot: cfg.sigma_rot_rad.is_some(),
        measured_pos: any_pos,
        measured_rot: any_rot,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::ComponentMask;
    use crate::rng::SplitMix64;
    use std::vec;
    use std::vec::Vec;

    /// The group-list walk gives the subgroup leaders and the pooled scatter of the former
    /// scans over all rows ([`crate::noise::repeat_leader`], the unlinked
    /// [`crate::noise::pooled_repeat_scatter`]) exactly: groups in any order, repeats with
    /// and without matching temperatures, masks and approach directions, suspect rows.
    #[test]
    fn group_lists_pool_as_the_full_scans() {
        let robot = crate::aria::nominal();
        let mut rng = SplitMix64::new(41);
        let mut subgroups = 0;
        for case in 0..40 {
            let n = 20 + rng.below(120);
            let ids = 1 + rng.below(n / 2);
            let groups: Vec<u32> = (0..n).map(|_| rng.below(ids) as u32).collect();
            let data: Vec<Measurement<6>> = (0..n)
                .map(|l| {
                    let g = groups[l] as f64;
                    let q = [0.1 * g, 0.2, -0.3 + 0.01 * g, 0.4, 0.5, 0.6];
                    let mut m = Measurement::new(q, crate::Transform::identity());
                    m.pose.translation.vector.x += 1e-3 * rng.uniform();
                    m.state.temp_c = Some(20.0 + rng.below(3) as f64 * 0.4);
                    if rng.uniform() < 0.2 {
                        m.mask = ComponentMask::POSITION;
                    }
                    if rng.uniform() < 0.3 {
                        m.state.approach = Some([1.0; 6]);
                    }
                    m
                })
                .collect();
            let mut poses = vec![PoseDiagnosis::default(); n];
            super::super::folds::assign(&groups, 1, 0, &mut poses).unwrap();
            for p in poses.iter_mut() {
                p.suspect = rng.uniform() < 0.05;
            }
            let got = pooled(&robot, &data, &mut poses, 0.5).unwrap();
            let lead = |l: usize| poses[l].leader as usize;
            let subs: Vec<usize> = (0..n)
                .map(|l| crate::noise::repeat_leader(&data, l, lead, 0.5))
                .collect();
            for l in 0..n {
                assert_eq!(poses[l].sub_leader as usize, subs[l], "case {case} row {l}");
            }
            let want = crate::noise::pooled_repeat_scatter(
                n,
                |l| {
                    if poses[l].suspect {
                        usize::MAX
                    } else {
                        subs[l]
                    }
                },
                |l| data[l].mask,
                |l| {
                    let t = data[l].model_pose(&robot)?;
                    Ok::<_, crate::Error>(pose_error(&data[l].pose, &t, OrientationError::Exact))
                },
            )
            .unwrap();
            assert_eq!(got, want, "case {case}");
            subgroups += want.subgroups;
        }
        // The cases hold repeats to pool (the comparison is not of empty sums).
        assert!(subgroups > 100, "{subgroups}");
    }
}
