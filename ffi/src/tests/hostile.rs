//! Issue #16 items 7 and 8: IK options outside their documented bounds are refused before any
//! work (a control loop gets INVALID_ARGUMENT, not a call that never returns), and no call
//! returns OK with a NaN or infinity in an output (finite inputs that overflow are
//! NON_FINITE_RESULT).

use core::ffi::CStr;
use core::ptr::{null, null_mut};
use std::time::{Duration, Instant};

use kincal::aria;
use kincal::ik::IkOptions;

use crate::aria::*;
use crate::identify::kincal_measurements;
use crate::ik::*;
use crate::kinematics::*;
use crate::params::*;
use crate::prepared::*;
use crate::robot::*;
use crate::status::*;
use crate::validation::*;

fn aria_robot() -> kincal_robot {
    let mut r = kincal_robot::ZERO;
    let s = unsafe { kincal_robot_aria(&mut r, kincal_aria_model::Nominal as u32, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    r
}

fn tool_pose(l: usize) -> [f64; 16] {
    let mut t = [0.0; 16];
    let s = unsafe { kincal_aria_tool_pose(l, t.as_mut_ptr(), 16, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    t
}

fn arg_name(e: &kincal_error) -> &'static str {
    assert!(!e.argument.is_null(), "no argument named in {e:?}");
    unsafe { CStr::from_ptr(e.argument) }.to_str().unwrap()
}

/// `kincal_ik` and `kincal_prepared_ik` of tool pose 0 with `opts`: both statuses, the error
/// detail of the plain call, and the longer of the two run times.
fn ik_both(opts: &kincal_ik_options) -> (kincal_status, kincal_status, kincal_error, Duration) {
    let r = aria_robot();
    let target = tool_pose(0);
    let seed = aria::TOOL_SEED_Q;
    let (mut q, mut e) = ([0.0; 6], kincal_error::CLEAR);
    let start = Instant::now();
    let plain = unsafe {
        kincal_ik(
            &r,
            target.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    let t_plain = start.elapsed();
    let mut h = kincal_prepared {
        opaque: [0; KINCAL_PREPARED_WORDS],
    };
    assert_eq!(
        unsafe { kincal_prepare(&r, &mut h, null_mut()) },
        kincal_status::Ok
    );
    let start = Instant::now();
    let prepared = unsafe {
        kincal_prepared_ik(
            &h,
            target.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            null_mut(),
        )
    };
    (plain, prepared, e, t_plain.max(start.elapsed()))
}

#[test]
fn ik_options_outside_their_bounds_are_refused_at_once() {
    let default = kincal_ik_options::from(IkOptions::default());
    let with = |f: &dyn Fn(&mut kincal_ik_options)| {
        let mut o = default;
        f(&mut o);
        o
    };
    let cases: [(kincal_ik_options, &str, f64, kincal_status); 12] = [
        // SIZE_MAX seeds looped (practically) forever before.
        (
            with(&|o| o.extra_seeds = usize::MAX),
            "opts->extra_seeds",
            usize::MAX as f64,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.extra_seeds = 1_000_000),
            "opts->extra_seeds",
            1e6,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.extra_seeds = KINCAL_IK_MAX_EXTRA_SEEDS + 1),
            "opts->extra_seeds",
            257.0,
            kincal_status::InvalidArgument,
        ),
        // Both fields within their bounds, the budget (1 + seeds)·iterations not.
        (
            with(&|o| {
                o.max_iterations = KINCAL_IK_MAX_ITERATIONS;
                o.extra_seeds = 20;
            }),
            "opts->extra_seeds",
            20.0,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.max_iterations = u32::MAX),
            "opts->max_iterations",
            f64::from(u32::MAX),
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.max_iterations = KINCAL_IK_MAX_ITERATIONS + 1),
            "opts->max_iterations",
            1001.0,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.max_iterations = 0),
            "opts->max_iterations",
            0.0,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.first_solution = 2),
            "opts->first_solution",
            2.0,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.tol_pos_m = 1.5),
            "opts->tol_pos_m",
            1.5,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.tol_rot_rad = -1e-9),
            "opts->tol_rot_rad",
            -1e-9,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.tol_rot_rad = 4.0),
            "opts->tol_rot_rad",
            4.0,
            kincal_status::InvalidArgument,
        ),
        (
            with(&|o| o.tol_pos_m = f64::INFINITY),
            "opts->tol_pos_m",
            f64::INFINITY,
            kincal_status::NonFinite,
        ),
    ];
    for (opts, name, value, status) in cases {
        let (plain, prepared, e, took) = ik_both(&opts);
        assert_eq!((plain, prepared), (status, status), "{opts:?}");
        assert_eq!(arg_name(&e), name, "{opts:?}");
        assert_eq!(e.value, value, "{opts:?}");
        assert!(took < Duration::from_millis(50), "{opts:?} took {took:?}");
    }
}

#[test]
fn ik_options_at_their_bounds_are_accepted() {
    let mut opts = kincal_ik_options::from(IkOptions::default());
    opts.max_iterations = 77;
    opts.extra_seeds = KINCAL_IK_MAX_EXTRA_SEEDS;
    opts.first_solution = 1;
    opts.tol_pos_m = 1e-9;
    let (plain, prepared, _, _) = ik_both(&opts);
    assert_eq!((plain, prepared), (kincal_status::Ok, kincal_status::Ok));
    opts.max_iterations = 1;
    opts.extra_seeds = 0;
    opts.first_solution = 0;
    opts.tol_pos_m = 1.0;
    opts.tol_rot_rad = core::f64::consts::PI;
    // One iteration from the seed with the loosest tolerances: converged at once.
    let (plain, prepared, _, _) = ik_both(&opts);
    assert_eq!((plain, prepared), (kincal_status::Ok, kincal_status::Ok));
}

#[test]
fn ik_at_the_bounds_finishes_in_bounded_time() {
    // The largest budget the bounds allow, 20 seeds x 1000 iterations, on an unreachable
    // target (every seed runs until it stalls). It must end, with UNREACHABLE.
    let mut opts = kincal_ik_options::from(IkOptions::default());
    opts.max_iterations = KINCAL_IK_MAX_ITERATIONS;
    opts.extra_seeds = 19;
    let r = aria_robot();
    let mut far = tool_pose(0);
    far[12] = 5.0;
    let mut q = [0.0; 6];
    let start = Instant::now();
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            aria::TOOL_SEED_Q.as_ptr(),
            6,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            null_mut(),
        )
    };
    let took = start.elapsed();
    assert_eq!(s, kincal_status::Unreachable);
    println!("IK at the largest budget, unreachable target: {took:?}");
    assert!(took < Duration::from_secs(30), "took {took:?}");
}

/// ARIA with parameter `index` set to `value` (finite, so accepted).
fn aria_with(index: usize, value: f64) -> kincal_robot {
    let mut r = aria_robot();
    let s = unsafe { kincal_robot_set_param(&mut r, index, value, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    r
}

#[test]
fn jacobian_never_returns_ok_with_an_overflowed_column() {
    // Lengths d and a of every link near the largest double: FK may still be finite while the
    // Jacobian's columns (lever arm times axis) overflow.
    let p = 12 * 6 + 13;
    let mut refused = 0;
    for link in 0..6 {
        for kind in [1, 2] {
            for value in [1e307, 1e308, 1.7e308, -1.7e308] {
                let r = aria_with(5 * link + kind, value);
                let mut jac = vec![0.0; 6 * p];
                let mut t = [0.0; 16];
                let mut e = kincal_error::CLEAR;
                let s = unsafe {
                    kincal_jacobian(
                        &r,
                        aria::TOOL_SEED_Q.as_ptr(),
                        6,
                        null(),
                        jac.as_mut_ptr(),
                        jac.len(),
                        t.as_mut_ptr(),
                        16,
                        &mut e,
                    )
                };
                match s {
                    kincal_status::Ok => {
                        assert!(jac.iter().chain(&t).all(|v| v.is_finite()));
                    }
                    kincal_status::NonFiniteResult => {
                        assert_eq!(arg_name(&e), "jac_out");
                        assert!(!e.value.is_finite());
                        assert!(!jac[e.index].is_finite());
                        refused += 1;
                    }
                    // FK itself overflowed (the core reports it).
                    kincal_status::NonFinite => {}
                    other => panic!("link {link} kind {kind} value {value}: {other:?}"),
                }
            }
        }
    }
    // The case of the issue is reached, not only FK's own refusal.
    assert!(refused > 0, "no overflowed Jacobian was produced");
}

#[test]
fn validate_never_returns_ok_with_an_overflowed_summary() {
    let r = aria_robot();
    let q = aria::TOOL_SEED_Q;
    let mut refused = 0;
    for x in [1e100, 1e155, 1e200, 1e300, -1.7e308] {
        let mut pose = [0.0; 16];
        assert_eq!(
            unsafe { kincal_fk(&r, q.as_ptr(), 6, null(), pose.as_mut_ptr(), 16, null_mut()) },
            kincal_status::Ok
        );
        pose[12] = x;
        // Two poses: the rows may be finite while the sum of squares overflows.
        let qs: Vec<f64> = q.iter().chain(q.iter()).copied().collect();
        let poses: Vec<f64> = pose.iter().chain(pose.iter()).copied().collect();
        let data = kincal_measurements {
            n_poses: 2,
            q: qs.as_ptr(),
            q_len: qs.len(),
            poses: poses.as_ptr(),
            poses_len: poses.len(),
            masks: null(),
            masks_len: 0,
            aux: null(),
            aux_len: 0,
            weights: null(),
            weights_len: 0,
        };
        let mut rows = [0.0; 2 * KINCAL_POSE_ERRORS_LEN];
        let mut summary = kincal_validation_summary::default();
        let mut e = kincal_error::CLEAR;
        let s = unsafe {
            kincal_validate(
                &r,
                &data,
                KINCAL_TARGET_POS_M,
                KINCAL_TARGET_ROT_RAD,
                rows.as_mut_ptr(),
                rows.len(),
                &mut summary,
                &mut e,
            )
        };
        match s {
            kincal_status::Ok => {
                assert!(rows.iter().all(|v| v.is_finite()), "x = {x}");
                let s = summary;
                assert!(
                    [s.rms_pos_m, s.max_pos_m, s.rms_rot_rad, s.max_rot_rad]
                        .iter()
                        .all(|v| v.is_finite()),
                    "x = {x}: {s:?}"
                );
                assert!(s.max_pos_m >= x.abs() * 0.5, "x = {x}: {s:?}");
            }
            kincal_status::NonFiniteResult => {
                assert!(
                    ["errors_out", "summary_out"].contains(&arg_name(&e)),
                    "{e:?}"
                );
                refused += 1;
            }
            other => panic!("x = {x}: {other:?}"),
        }
    }
    assert!(refused > 0, "no overflowed summary was produced");
}

#[test]
fn every_status_has_distinct_text() {
    let text = kincal_status_str(kincal_status::NonFiniteResult as u32);
    let text = unsafe { CStr::from_ptr(text) }.to_str().unwrap();
    assert!(
        text.starts_with("KINCAL_STATUS_NON_FINITE_RESULT"),
        "{text}"
    );
}
