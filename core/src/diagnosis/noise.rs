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
        |l| residual(reference, &data[l]),
    )
}

/// A row's residual against `reference`, `[Δp (m); Δφ (rad)]`, as the repeat statistics
/// take it.
fn residual<const N: usize>(reference: &Robot<N>, m: &Measurement<N>) -> Result<[f64; 6]> {
    let t = m.model_pose(reference)?;
    Ok(pose_error(&m.pose, &t, OrientationError::Exact))
}

/// The row after `m` in its group's member list ([`PoseDiagnosis::next`]); `usize::MAX`
/// after the last (what the estimator's walks take as the end).
fn next(poses: &[PoseDiagnosis], m: usize) -> usize {
    poses.get(m).map_or(usize::MAX, |p| match p.next {
        NO_NEXT => usize::MAX,
        k => k as usize,
    })
}

/// Serial z of the repeats' differences in the order of the rows, per part (position,
/// rotation): `None` with fewer than [`super::MIN_DRIFT_PAIRS`] pairs.
///
/// Each repeat subgroup with a second row (its leader `l` and the next member `m`, both not
/// suspect) gives the difference `d = e_m − e_l` of their residuals against `reference`
/// (the same joint state, so the model's error cancels: pure noise when nothing changed
/// between the two). In the order of the leaders' rows, `z = Σ⟨d_k, d_{k+1}⟩ /
/// √Σ⟨d_k, d_{k+1}⟩²`: for independent differences the products have mean zero and are
/// uncorrelated, so z is about standard normal whatever the noise level; when the set-up
/// drifts between first measurements and repeats, neighbouring pairs span nearly the same
/// stretch of the drift and z grows with the number of pairs. Measured components only.
fn repeat_drift<const N: usize>(
    reference: &Robot<N>,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
) -> Result<[Option<f64>; 2]> {
    let mut prev: Option<[f64; 6]> = None;
    let (mut sum, mut sum_sq, mut pairs) = ([0.0; 2], [0.0; 2], 0usize);
    for (l, p) in poses.iter().enumerate().take(data.len()) {
        if p.suspect || p.sub_leader as usize != l {
            continue;
        }
        let second = core::iter::successors(Some(next(poses, l)), |&m| Some(next(poses, m)))
            .take_while(|&m| m < data.len())
            .find(|&m| {
                poses
                    .get(m)
                    .is_some_and(|q| !q.suspect && q.sub_leader as usize == l)
            });
        let Some(m) = second else {
            continue;
        };
        let (el, em) = (
            residual(reference, &data[l])?,
            residual(reference, &data[m])?,
        );
        let mut d = [0.0; 6];
        for (k, slot) in d.iter_mut().enumerate() {
            if data[l].mask.has(k) && data[m].mask.has(k) {
                *slot = em[k] - el[k];
            }
        }
        if let Some(before) = prev {
            for part in 0..2 {
                let dot: f64 = (3 * part..3 * part + 3).map(|k| before[k] * d[k]).sum();
                sum[part] += dot;
                sum_sq[part] += dot * dot;
            }
        }
        prev = Some(d);
        pairs += 1;
    }
    let z = |part: usize| {
        (pairs >= super::MIN_DRIFT_PAIRS && sum_sq[part] > 0.0)
            .then(|| sum[part] / crate::math::sqrt(sum_sq[part]))
    };
    Ok([z(0), z(1)])
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
    let [drift_pos, drift_rot] = repeat_drift(reference, data, poses)?;
    // Repeats that drift with the rows measure the drift too: they do not overrule.
    let (sp, np, overruled_pos) = overrule(
        cfg.sigma_pos_m.is_some() && super::drifting(drift_pos).is_none(),
        sp,
        np,
        repeats(ss_p, dof_p),
    );
    let (sr, nr, overruled_rot) = overrule(
        cfg.sigma_rot_rad.is_some() && super::drifting(drift_rot).is_none(),
        sr,
        nr,
        repeats(ss_r, dof_r),
    );
    Ok(NoiseFloor {
        overruled_pos,
        overruled_rot,
        drift_pos,
        drift_rot,
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

    /// `pairs` poses measured twice, the repeats after all first measurements (rows
    /// `pairs..2·pairs`) or each right after its first (`interleaved`), with 0.1 mm noise
    /// per axis plus `drift(row)` added to the measured position; returns the serial z of
    /// the position differences.
    fn drift_z(
        pairs: usize,
        interleaved: bool,
        rng: &mut SplitMix64,
        mut drift: impl FnMut(usize) -> [f64; 3],
    ) -> Option<f64> {
        let robot = crate::aria::nominal();
        let n = 2 * pairs;
        let groups: Vec<u32> = (0..n)
            .map(|l| if interleaved { l / 2 } else { l % pairs } as u32)
            .collect();
        let data: Vec<Measurement<6>> = (0..n)
            .map(|l| {
                let g = groups[l] as f64;
                let q = [0.05 * g, 0.3, -0.2 + 0.02 * g, 0.4, 0.5 - 0.01 * g, 0.6];
                let mut m = Measurement::new(q, robot.fk_q(&q).unwrap());
                let d = drift(l);
                for (k, dk) in d.iter().enumerate() {
                    m.pose.translation.vector[k] += dk + 1e-4 * rng.normal();
                }
                m
            })
            .collect();
        let mut poses = vec![PoseDiagnosis::default(); n];
        super::super::folds::assign(&groups, 1, 0, &mut poses).unwrap();
        pooled(&robot, &data, &mut poses, 0.5).unwrap();
        repeat_drift(&robot, &data, &poses).unwrap()[0]
    }

    /// The drift test of the repeats: about standard normal without drift (few z above 3
    /// over 300 noise-only sessions), above 3 in nearly every session whose set-up drifts
    /// by a random walk or linearly between first measurements and repeats, and silent
    /// when each repeat follows its first measurement (then the repeats do not span the
    /// drift, and their scatter is the noise's).
    #[test]
    fn repeats_that_drift_with_the_rows_are_told_from_noise() {
        let mut rng = SplitMix64::new(7);
        let count = |rng: &mut SplitMix64, walk: f64, linear: f64, interleaved: bool| {
            let mut hits = 0;
            for _ in 0..300 {
                let mut pos = [0.0; 3];
                let mut steps = SplitMix64::new(rng.below(1 << 30) as u64);
                let z = drift_z(30, interleaved, rng, |l| {
                    for p in pos.iter_mut() {
                        *p += walk * steps.normal();
                    }
                    [pos[0] + linear * l as f64, pos[1], pos[2]]
                })
                .unwrap();
                hits += usize::from(z > super::super::NOISE_CHECK_Z);
            }
            hits
        };
        let noise_only = count(&mut rng, 0.0, 0.0, false);
        assert!(
            noise_only <= 6,
            "noise only: {noise_only} of 300 above z = 3"
        );
        let walk = count(&mut rng, 5e-5, 0.0, false);
        assert!(walk >= 270, "random walk: {walk} of 300");
        let linear = count(&mut rng, 0.0, 2e-5, false);
        assert!(linear >= 285, "linear drift: {linear} of 300");
        let interleaved = count(&mut rng, 5e-5, 0.0, true);
        assert!(
            interleaved <= 9,
            "interleaved repeats: {interleaved} of 300"
        );
        std::println!(
            "z > 3 of 300: noise only {noise_only}, random walk {walk}, linear {linear}, interleaved {interleaved}"
        );
        // Too few pairs: not tested.
        assert_eq!(drift_z(7, false, &mut rng, |_| [0.0; 3]), None);
        assert!(drift_z(8, false, &mut rng, |_| [0.0; 3]).is_some());
    }
}
