//! Identification, validation and registration through the ABI: a full calibration of the
//! ARIA simulation study (Table 3 truth measured at the Table 2 tool poses, identified from
//! the Table 1 nominal model).

use core::ffi::c_void;
use core::ptr::{null, null_mut};

use kincal::aria;

use crate::aria::*;
use crate::identify::*;
use crate::ik::*;
use crate::kinematics::*;
use crate::params::*;
use crate::registration::*;
use crate::robot::*;
use crate::status::*;
use crate::validation::*;

fn aria_robot(model: kincal_aria_model) -> kincal_robot {
    let mut r = kincal_robot::ZERO;
    assert_eq!(
        unsafe { kincal_robot_aria(&mut r, model as u32, null_mut()) },
        kincal_status::Ok
    );
    r
}

/// Joint readings and measured poses of the truth at the ten tool poses.
fn tool_data(truth: &kincal_robot) -> (Vec<f64>, Vec<f64>) {
    let (mut q, mut poses) = (Vec::new(), Vec::new());
    for l in 0..10 {
        let mut target = [0.0; 16];
        let mut ql = [0.0; 6];
        unsafe {
            assert_eq!(
                kincal_aria_tool_pose(l, target.as_mut_ptr(), 16, null_mut()),
                kincal_status::Ok
            );
            let s = kincal_ik(
                truth,
                target.as_ptr(),
                16,
                aria::TOOL_SEED_Q.as_ptr(),
                6,
                null(),
                null(),
                ql.as_mut_ptr(),
                6,
                null_mut(),
                null_mut(),
            );
            assert_eq!(s, kincal_status::Ok);
            let mut t = [0.0; 16];
            assert_eq!(
                kincal_fk(
                    truth,
                    ql.as_ptr(),
                    6,
                    null(),
                    t.as_mut_ptr(),
                    16,
                    null_mut()
                ),
                kincal_status::Ok
            );
            poses.extend_from_slice(&t);
        }
        q.extend_from_slice(&ql);
    }
    (q, poses)
}

fn measurements(q: &[f64], poses: &[f64]) -> kincal_measurements {
    kincal_measurements {
        n_poses: q.len() / 6,
        q: q.as_ptr(),
        q_len: q.len(),
        poses: poses.as_ptr(),
        poses_len: poses.len(),
        masks: null(),
        masks_len: 0,
        aux: null(),
        aux_len: 0,
        weights: null(),
        weights_len: 0,
    }
}

/// 16-byte aligned caller memory.
fn workspace(bytes: usize) -> Vec<u128> {
    vec![0u128; bytes.div_ceil(16)]
}

#[test]
fn full_calibration_recovers_table3() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let (q, poses) = tool_data(&truth);
    let data = measurements(&q, &poses);

    // Before: the nominal model misses the paper's targets.
    let mut before = kincal_validation_summary::default();
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_validate(
            &nominal,
            &data,
            KINCAL_TARGET_POS_M,
            KINCAL_TARGET_ROT_RAD,
            null_mut(),
            0,
            &mut before,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    assert_eq!((before.count, before.pos_ok), (10, 0));

    for alg in [
        kincal_algorithm::Ols,
        kincal_algorithm::Opt1,
        kincal_algorithm::Opt2,
    ] {
        let mut opts = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
        let s = unsafe {
            kincal_identify_options_default(&nominal, alg as u32, 0, opts.as_mut_ptr(), &mut e)
        };
        assert_eq!(s, kincal_status::Ok);
        let mut opts = unsafe { opts.assume_init() };
        // Table 3 moves θ0_4 by 0.8 rad: widen OPT1's ±5° intervals (as the core test does).
        for i in 0..85 {
            let v = nominal.params[i];
            if opts.lower[i].is_finite() {
                (opts.lower[i], opts.upper[i]) = (v - 1.0, v + 1.0);
            }
        }
        let n_req = opts.requested.iter().filter(|&&m| m != 0).count();
        assert_eq!(n_req, 24);
        let size = kincal_identify_workspace_size(6, 10, n_req);
        assert!(size > 60_000 && size < 100_000, "{size}");
        let mut ws = workspace(size);
        let mut fitted = kincal_robot::ZERO;
        let mut report = Box::new(core::mem::MaybeUninit::<kincal_identify_report>::uninit());
        let s = unsafe {
            kincal_identify(
                &nominal,
                &data,
                &opts,
                ws.as_mut_ptr().cast::<c_void>(),
                size,
                &mut fitted,
                report.as_mut_ptr(),
                &mut e,
            )
        };
        assert_eq!(s, kincal_status::Ok, "{alg:?}: {e:?}");
        let report = unsafe { report.assume_init() };
        assert_eq!(report.algorithm, alg as u32);
        assert_eq!(report.analysis.rank, 24);
        assert_eq!(report.analysis.n_singular_values, 24);
        assert!(report.analysis.condition_number.is_finite());
        assert!(
            report.initial.rms_pos_m > 1e-2 && report.fitted.rms_pos_m < 1e-9,
            "{alg:?}"
        );
        // The identified parameters are Table 3's.
        for i in (0..85).filter(|&i| report.analysis.identifiable[i] != 0) {
            assert!(
                (fitted.params[i] - truth.params[i]).abs() < 1e-8,
                "{alg:?} param {i}"
            );
        }
        let mut after = kincal_validation_summary::default();
        let mut errors = vec![0.0; 10 * KINCAL_POSE_ERRORS_LEN];
        let s = unsafe {
            kincal_validate(
                &fitted,
                &data,
                KINCAL_TARGET_POS_M,
                KINCAL_TARGET_ROT_RAD,
                errors.as_mut_ptr(),
                errors.len(),
                &mut after,
                &mut e,
            )
        };
        assert_eq!(s, kincal_status::Ok);
        assert_eq!((after.pos_ok, after.rot_ok), (1, 1));
        assert!(errors.iter().all(|v| v.abs() < 1e-9));
    }
}

#[test]
fn identifiability_reports_redundancy() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let (q, poses) = tool_data(&truth);
    let data = measurements(&q, &poses);
    let mut opts = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
    let compliance = 1 << crate::effects::kincal_effect::JointCompliance as u32;
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe {
            kincal_identify_options_default(&nominal, 0, compliance, opts.as_mut_ptr(), &mut e)
        },
        kincal_status::Ok
    );
    let opts = unsafe { opts.assume_init() };
    let size = kincal_identify_workspace_size(6, 10, 30);
    let mut ws = workspace(size);
    let mut a = Box::new(core::mem::MaybeUninit::<kincal_identifiability>::uninit());
    let s = unsafe {
        kincal_analyze_identifiability(
            &nominal,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size,
            a.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    let a = unsafe { a.assume_init() };
    // Joints 1 and 6 carry no gravity torque: their compliance is structurally redundant.
    let c1 = 5 * 6 + 12;
    assert_eq!((a.structural[c1], a.structural[c1 + 5]), (1, 1));
    assert_eq!(a.structural.iter().filter(|&&m| m != 0).count(), 2);
    assert_eq!(a.requested.iter().filter(|&&m| m != 0).count(), 30);
    assert_eq!(
        a.rank + 2 + a.data_deficient.iter().filter(|&&m| m != 0).count(),
        30
    );

    // Identification refuses data-deficient sets unless allowed, naming the rank.
    if a.data_deficient.iter().any(|&m| m != 0) {
        let mut r = kincal_robot::ZERO;
        let s = unsafe {
            kincal_identify(
                &nominal,
                &data,
                &opts,
                ws.as_mut_ptr().cast(),
                size,
                &mut r,
                null_mut(),
                &mut e,
            )
        };
        assert_eq!((s, e.found), (kincal_status::RankDeficient, a.rank));
    }
}

#[test]
fn identification_argument_errors() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let (q, mut poses) = tool_data(&truth);
    let mut opts = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_identify_options_default(&nominal, 0, 0, opts.as_mut_ptr(), &mut e) },
        kincal_status::Ok
    );
    let mut opts = unsafe { opts.assume_init() };
    let size = kincal_identify_workspace_size(6, 10, 24);
    let mut ws = workspace(size + 32);
    let mut r = kincal_robot::ZERO;
    let run = |data: &kincal_measurements,
               opts: &kincal_identify_options,
               ws: *mut c_void,
               len: usize,
               e: &mut kincal_error| unsafe {
        let mut r = kincal_robot::ZERO;
        kincal_identify(&nominal, data, opts, ws, len, &mut r, null_mut(), e)
    };
    let data = measurements(&q, &poses);
    let s = run(&data, &opts, ws.as_mut_ptr().cast(), size - 1, &mut e);
    assert_eq!(
        (s, e.expected, e.found),
        (kincal_status::BadLength, size, size - 1)
    );
    let odd = unsafe { ws.as_mut_ptr().cast::<u8>().add(8) }.cast::<c_void>();
    assert_eq!(
        run(&data, &opts, odd, size, &mut e),
        kincal_status::MisalignedPointer
    );
    assert_eq!(
        run(&data, &opts, null_mut(), size, &mut e),
        kincal_status::NullPointer
    );
    // A wrong q length for the joint count.
    let mut short = data;
    short.q_len -= 1;
    let s = run(&short, &opts, ws.as_mut_ptr().cast(), size, &mut e);
    assert_eq!((s, e.expected), (kincal_status::BadLength, 60));
    // A pose that is not rigid names its pose.
    poses[16 * 7 + 5] = 2.0;
    let data = measurements(&q, &poses);
    let s = run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e);
    assert_eq!((s, e.pose), (kincal_status::InvalidTransform, 7));
    poses[16 * 7 + 5] = f64::NAN;
    let data = measurements(&q, &poses);
    let s = run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e);
    assert_eq!(
        (s, e.pose, e.index),
        (kincal_status::NonFinite, 7, 16 * 7 + 5)
    );
    let (q, poses) = tool_data(&truth);
    let mut data = measurements(&q, &poses);
    let masks = [0x3fu8, 0x3f, 0x40, 0x3f, 0x3f, 0x3f, 0x3f, 0x3f, 0x3f, 0x3f];
    data.masks = masks.as_ptr();
    data.masks_len = 10;
    let s = run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e);
    assert_eq!((s, e.pose), (kincal_status::InvalidArgument, 2));
    let data = measurements(&q, &poses);
    opts.algorithm = 3;
    assert_eq!(
        run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e),
        kincal_status::InvalidArgument
    );
    opts.algorithm = 0;
    opts.requested = [0; KINCAL_MAX_PARAMS];
    assert_eq!(
        run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e),
        kincal_status::TooFewData
    );
    opts.requested[0] = 1;
    opts.lower[0] = f64::NAN;
    assert_eq!(
        run(&data, &opts, ws.as_mut_ptr().cast(), size, &mut e),
        kincal_status::InvalidArgument
    );
    // Unchanged output on failure; robot_out may alias robot.
    let before = r;
    let s = unsafe {
        kincal_identify(
            &nominal,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size,
            &mut r,
            null_mut(),
            &mut e,
        )
    };
    assert_ne!(s, kincal_status::Ok);
    assert_eq!(r, before);
    assert_eq!(kincal_identify_workspace_size(13, 10, 24), 0);
    assert_eq!(kincal_identify_workspace_size(6, 10, 158), 0);
    assert_eq!(kincal_identify_workspace_size(6, usize::MAX, 24), 0);
    assert!(kincal_identify_workspace_size(6, 10, 33) > kincal_identify_workspace_size(6, 10, 32));
}

#[test]
fn registration_of_a_probe() {
    // An asymmetric four-marker probe, rotated and shifted, one marker swapped with another.
    let design = [
        0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.15, 0.0, 0.0, 0.0, 0.07, 0.05, 0.05, 0.02,
    ];
    let (s, c) = f64::sin_cos(0.4);
    let place = |p: &[f64]| {
        [
            c * p[0] - s * p[1] + 1.0,
            s * p[0] + c * p[1] + 2.0,
            p[2] + 0.5,
        ]
    };
    let mut measured: Vec<f64> = design.chunks(3).flat_map(place).collect();
    let mut o = kincal_registration_options {
        sigma_m: 0.0,
        k_sigma: 0.0,
        max_outliers: 0,
    };
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_registration_options_default(1e-4, &mut o, &mut e) },
        kincal_status::Ok
    );
    let mut reg = Box::new(core::mem::MaybeUninit::<kincal_registration>::uninit());
    let st = unsafe {
        kincal_register(
            design.as_ptr(),
            15,
            measured.as_ptr(),
            15,
            null(),
            0,
            null(),
            0,
            &o,
            reg.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(st, kincal_status::Ok, "{e:?}");
    let r = unsafe { reg.assume_init() };
    assert_eq!((r.n_markers, r.n_used, r.consistent), (5, 5, 1));
    let expected = [
        c, s, 0.0, 0.0, -s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 0.5, 1.0,
    ];
    assert!(
        r.t_mocap_body
            .iter()
            .zip(expected)
            .all(|(a, b)| (a - b).abs() < 1e-12)
    );
    // Marker 2 not seen (NaN allowed), marker 4 moved by 5 mm: flagged, fit unaffected.
    measured[6] = f64::NAN;
    measured[12] += 5e-3;
    let visible = [1u8, 1, 0, 1, 1];
    let mut reg = Box::new(core::mem::MaybeUninit::<kincal_registration>::uninit());
    let st = unsafe {
        kincal_register(
            design.as_ptr(),
            15,
            measured.as_ptr(),
            15,
            visible.as_ptr(),
            5,
            null(),
            0,
            &o,
            reg.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(st, kincal_status::Ok, "{e:?}");
    let r = unsafe { reg.assume_init() };
    assert_eq!(r.markers[2].status, kincal_marker_status::Missing as u32);
    assert_eq!(r.markers[4].status, kincal_marker_status::Moved as u32);
    assert_eq!(r.n_used, 3);
    assert!(
        r.t_mocap_body
            .iter()
            .zip(expected)
            .all(|(a, b)| (a - b).abs() < 1e-12)
    );
    // NaN in a visible marker, bad lengths, too many markers.
    let mut reg = core::mem::MaybeUninit::<kincal_registration>::uninit();
    let st = unsafe {
        kincal_register(
            design.as_ptr(),
            15,
            measured.as_ptr(),
            15,
            null(),
            0,
            null(),
            0,
            &o,
            reg.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!((st, e.index), (kincal_status::NonFinite, 6));
    let st = unsafe {
        kincal_register(
            design.as_ptr(),
            14,
            measured.as_ptr(),
            15,
            null(),
            0,
            null(),
            0,
            &o,
            reg.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(st, kincal_status::BadLength);
    let big = [0.0; 3 * 33];
    let st = unsafe {
        kincal_register(
            big.as_ptr(),
            99,
            big.as_ptr(),
            99,
            null(),
            0,
            null(),
            0,
            &o,
            reg.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(st, kincal_status::CapacityExceeded);

    // Base and end effector registrations compose to the end-effector pose.
    let base = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 0.0, 1.0,
    ];
    let mut t = [0.0; 16];
    assert_eq!(
        unsafe {
            kincal_t_base_ee(
                base.as_ptr(),
                16,
                expected.as_ptr(),
                16,
                t.as_mut_ptr(),
                16,
                &mut e,
            )
        },
        kincal_status::Ok
    );
    assert!(
        (t[12] - 0.0).abs() < 1e-15 && (t[13] - 0.0).abs() < 1e-15 && (t[14] - 0.5).abs() < 1e-15
    );
}

#[test]
fn biopsy_requirement() {
    let mut v = 0.0;
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_biopsy_allowed_rotation(5e-3, 3f64.sqrt() * 1e-3, 0.2, &mut v, &mut e) },
        kincal_status::Ok
    );
    assert!((v.to_degrees() - 0.66).abs() < 0.01);
    let s = unsafe { kincal_biopsy_allowed_rotation(5e-3, 6e-3, 0.2, &mut v, &mut e) };
    assert_eq!((s, e.index), (kincal_status::InvalidParameter, 1));
}

#[test]
fn effect_labels_in_the_mask() {
    // The default options of an effect request its parameters by label.
    let r = aria_robot(kincal_aria_model::Nominal);
    let mut o = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
    let backlash = 1 << crate::effects::kincal_effect::Backlash as u32;
    assert_eq!(
        unsafe { kincal_identify_options_default(&r, 2, backlash, o.as_mut_ptr(), null_mut()) },
        kincal_status::Ok
    );
    let o = unsafe { o.assume_init() };
    let mut i = 0;
    assert_eq!(
        unsafe { kincal_robot_param_index(&r, c"backlash_3".as_ptr(), &mut i, null_mut()) },
        kincal_status::Ok
    );
    assert_eq!(o.requested[i], 1);
    assert_eq!(o.algorithm, 2);
}

/// A pose held out with weight 0 does not move the fit: a corrupted pose 4 with weight 0 gives
/// the same model as the clean data.
#[test]
fn held_out_pose_weight_zero() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let (q, mut poses) = tool_data(&truth);
    poses[16 * 4 + 12] += 0.01;
    let mut data = measurements(&q, &poses);
    let mut weights = [1.0; 10];
    weights[4] = 0.0;
    data.weights = weights.as_ptr();
    data.weights_len = 10;
    let mut opts = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_identify_options_default(&nominal, 0, 0, opts.as_mut_ptr(), &mut e) },
        kincal_status::Ok
    );
    let opts = unsafe { opts.assume_init() };
    let size = kincal_identify_workspace_size(6, 10, 24);
    let mut ws = workspace(size);
    let mut fitted = kincal_robot::ZERO;
    let s = unsafe {
        kincal_identify(
            &nominal,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size,
            &mut fitted,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    for i in 0..30 {
        assert!(
            (fitted.params[i] - truth.params[i]).abs() < 1e-8,
            "param {i}"
        );
    }
    weights[4] = -1.0;
    data.weights = weights.as_ptr();
    let s = unsafe {
        kincal_identify(
            &nominal,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size,
            &mut fitted,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, e.index), (kincal_status::InvalidArgument, 4));
}

/// A pose count whose arrays could not exist is refused before any slice is formed.
#[test]
fn absurd_pose_counts_are_refused() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let q = [0.0; 6];
    let poses = [0.0; 16];
    let n = usize::MAX / 8;
    let data = kincal_measurements {
        n_poses: n,
        q: q.as_ptr(),
        q_len: n.wrapping_mul(6),
        poses: poses.as_ptr(),
        poses_len: n.wrapping_mul(16),
        masks: null(),
        masks_len: 0,
        aux: null(),
        aux_len: 0,
        weights: null(),
        weights_len: 0,
    };
    let mut summary = kincal_validation_summary::default();
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_validate(
            &nominal,
            &data,
            1e-3,
            1e-2,
            null_mut(),
            0,
            &mut summary,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::BadLength);
}

/// One OLS identification of the Table 3 truth from the tool poses with `opts`.
fn identify_with(
    nominal: &kincal_robot,
    data: &kincal_measurements,
    opts: &kincal_identify_options,
) -> Result<(kincal_robot, Box<kincal_identify_report>), kincal_error> {
    let n_req = opts.requested.iter().filter(|&&m| m != 0).count();
    let size = kincal_identify_workspace_size(6, 10, n_req);
    let mut ws = workspace(size);
    let mut fitted = kincal_robot::ZERO;
    let mut report = Box::new(core::mem::MaybeUninit::<kincal_identify_report>::uninit());
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_identify(
            nominal,
            data,
            opts,
            ws.as_mut_ptr().cast::<c_void>(),
            size,
            &mut fitted,
            report.as_mut_ptr(),
            &mut e,
        )
    };
    if s != kincal_status::Ok {
        return Err(e);
    }
    // SAFETY: written on OK.
    Ok((fitted, unsafe {
        Box::from_raw(Box::into_raw(report).cast())
    }))
}

#[test]
fn priors_through_the_abi_pin_weak_directions_and_vanish_when_weak() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let (q, poses) = tool_data(&truth);
    let data = measurements(&q, &poses);
    let mut e = kincal_error::CLEAR;
    let mut opts = core::mem::MaybeUninit::<kincal_identify_options>::uninit();
    let s = unsafe {
        kincal_identify_options_default(
            &nominal,
            kincal_algorithm::Ols as u32,
            0,
            opts.as_mut_ptr(),
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok);
    let mut opts = unsafe { opts.assume_init() };
    // The default: no prior anywhere.
    assert!(opts.prior_sigma.iter().all(|s| s.is_infinite()));
    // Whitened rows (0.1 mm, 0.02°), so that the prior's σ means what it says.
    opts.weight_pos = 1.0 / 1e-4f64.powi(2);
    opts.weight_rot = 1.0 / 0.02f64.to_radians().powi(2);
    let (plain, plain_report) = identify_with(&nominal, &data, &opts).expect("no prior");
    assert_eq!(plain_report.prior_rows, 0);
    assert_eq!(plain_report.prior_chi2, 0.0);

    // The setter: link lengths and angles, nothing on frames or effects.
    let mut with = opts;
    let s = unsafe {
        kincal_identify_options_set_prior(&nominal, 5e-3, 1f64.to_radians(), &mut with, &mut e)
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    let n_links = with.prior_sigma.iter().filter(|s| s.is_finite()).count();
    // θ0, d, a, α, β of each joint (d or β is the fitted length parameter: 24 fitted).
    assert_eq!(n_links, 30, "five link parameters per joint");
    let (_, report) = identify_with(&nominal, &data, &with).expect("prior");
    assert_eq!(report.prior_rows, 24);
    assert!(report.prior_chi2 > 0.0);

    // A vanishing prior (σ = 1e9) leaves the fit as it was.
    let mut weak = with;
    for s in weak.prior_sigma.iter_mut().filter(|s| s.is_finite()) {
        *s = 1e9;
    }
    let (fitted, _) = identify_with(&nominal, &data, &weak).expect("weak prior");
    for i in 0..85 {
        assert!(
            (fitted.params[i] - plain.params[i]).abs() < 1e-12,
            "param {i}: {} vs {}",
            fitted.params[i],
            plain.params[i]
        );
    }
    // An overwhelming prior (σ = 1e-12) holds every parameter at the starting model.
    let mut strong = with;
    for s in strong.prior_sigma.iter_mut().filter(|s| s.is_finite()) {
        *s = 1e-12;
    }
    let (fitted, _) = identify_with(&nominal, &data, &strong).expect("strong prior");
    for i in (0..85).filter(|&i| strong.prior_sigma[i].is_finite()) {
        assert!(
            (fitted.params[i] - nominal.params[i]).abs() < 1e-9,
            "param {i}"
        );
    }

    // Bad sizes are refused, naming the argument.
    let mut bad = with;
    bad.prior_sigma[3] = 0.0;
    let err = identify_with(&nominal, &data, &bad).expect_err("σ = 0");
    assert_eq!(err.status, kincal_status::InvalidArgument as u32);
    assert_eq!(err.index, 3);
    let mut o = opts;
    let s = unsafe { kincal_identify_options_set_prior(&nominal, f64::NAN, 0.01, &mut o, &mut e) };
    assert_eq!(s, kincal_status::InvalidArgument);
}
