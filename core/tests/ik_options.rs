//! IK options are bounded (issue #16 item 7): `solve_ik` refuses an option outside its
//! documented bounds with `Error::InvalidOption` before doing any work, so no front end can
//! ask for a call that never returns; the bounds themselves are accepted.

use kincal::ik::{IkOptions, solve_ik};
use kincal::{Error, JointState, aria};

fn solve(opts: &IkOptions) -> kincal::Result<[f64; 6]> {
    let robot = aria::nominal();
    let target = aria::tool_pose(0).unwrap();
    solve_ik(&robot, &target, &JointState::new(aria::TOOL_SEED_Q), opts).map(|s| s.q)
}

#[test]
fn every_field_outside_its_bounds_is_refused() {
    let d = IkOptions::default();
    let cases = [
        (
            IkOptions {
                extra_seeds: usize::MAX,
                ..d
            },
            "extra_seeds",
        ),
        (
            IkOptions {
                extra_seeds: IkOptions::MAX_EXTRA_SEEDS + 1,
                ..d
            },
            "extra_seeds",
        ),
        (
            IkOptions {
                max_iterations: 0,
                ..d
            },
            "max_iterations",
        ),
        (
            IkOptions {
                max_iterations: IkOptions::MAX_ITERATIONS + 1,
                ..d
            },
            "max_iterations",
        ),
        (
            IkOptions {
                tol_pos_m: 0.0,
                ..d
            },
            "tol_pos_m",
        ),
        (
            IkOptions {
                tol_pos_m: f64::NAN,
                ..d
            },
            "tol_pos_m",
        ),
        (
            IkOptions {
                tol_pos_m: 1.0 + 1e-9,
                ..d
            },
            "tol_pos_m",
        ),
        (
            IkOptions {
                tol_rot_rad: -1.0,
                ..d
            },
            "tol_rot_rad",
        ),
        (
            IkOptions {
                tol_rot_rad: f64::INFINITY,
                ..d
            },
            "tol_rot_rad",
        ),
        (
            IkOptions {
                tol_rot_rad: 3.2,
                ..d
            },
            "tol_rot_rad",
        ),
        // Each field within its bound, the budget (1 + seeds)·iterations not.
        (
            IkOptions {
                max_iterations: 1000,
                extra_seeds: 20,
                ..d
            },
            "extra_seeds",
        ),
        (
            IkOptions {
                max_iterations: 78,
                extra_seeds: 256,
                ..d
            },
            "extra_seeds",
        ),
    ];
    for (opts, field) in cases {
        match opts.validate() {
            Err(Error::InvalidOption { option, .. }) => assert_eq!(option, field, "{opts:?}"),
            other => panic!("{opts:?}: {other:?}"),
        }
        // solve_ik reports a NaN or infinite tolerance as NonFinite, like every other input.
        let non_finite = !(opts.tol_pos_m.is_finite() && opts.tol_rot_rad.is_finite());
        let r = solve(&opts);
        assert!(
            matches!(r, Err(Error::InvalidOption { option, .. }) if option == field)
                || (non_finite && matches!(r, Err(Error::NonFinite { .. }))),
            "{opts:?}: {r:?}"
        );
    }
}

#[test]
fn the_bounds_themselves_are_accepted_and_the_default_is_within_them() {
    let d = IkOptions::default();
    assert_eq!(d.validate(), Ok(()));
    let at_bounds = IkOptions {
        max_iterations: IkOptions::MAX_ITERATIONS,
        extra_seeds: 19,
        tol_pos_m: IkOptions::MAX_TOL_POS_M,
        tol_rot_rad: IkOptions::MAX_TOL_ROT_RAD,
        first_solution: true,
    };
    assert_eq!(at_bounds.validate(), Ok(()));
    assert!(solve(&at_bounds).is_ok());
    // 257 · 77 = 19,789 <= 20,000.
    let most_seeds = IkOptions {
        max_iterations: 77,
        extra_seeds: IkOptions::MAX_EXTRA_SEEDS,
        ..d
    };
    assert_eq!(most_seeds.validate(), Ok(()));
    assert_eq!(IkOptions::MAX_TOTAL_ITERATIONS, 20_000);
    let tight = IkOptions {
        max_iterations: 1,
        extra_seeds: 0,
        ..d
    };
    assert_eq!(tight.validate(), Ok(()));
}
