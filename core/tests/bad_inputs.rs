//! Bad inputs get the documented error, naming the culprit: non-finite numbers (with their
//! index), wrong buffer lengths, invalid limits, missing effect inputs, joint counts out
//! of range, readings outside the limits.

use kincal::any::{AnyRobot, MAX_JOINTS};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::ParamId;
use kincal::{
    Error, JointIndex, JointLimits, JointState, Link, MassModel, ParamIndex, Quantity, Robot, aria,
};

const NON_FINITE: [f64; 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
const Q: [f64; 6] = aria::TOOL_SEED_Q;

fn non_finite(what: Quantity, index: usize) -> Error {
    Error::NonFinite { what, index }
}

#[test]
fn non_finite_joint_readings() {
    let robot = aria::nominal();
    let mut jac = vec![[0.0; 6]; Robot::<6>::NUM_PARAMS];
    for bad in NON_FINITE {
        for j in 0..6 {
            let mut q = Q;
            q[j] = bad;
            let state = JointState::new(q);
            let expected = Err(non_finite(Quantity::JointReading, j));
            assert_eq!(robot.fk(&state).map(|_| ()), expected);
            assert_eq!(robot.fk_q(&q).map(|_| ()), expected);
            assert_eq!(robot.jacobian(&state, &mut jac).map(|_| ()), expected);
            assert_eq!(robot.check_limits(&q), expected);
            assert_eq!(robot.joint_angles(&state).map(|_| ()), expected);
            let target = aria::tool_pose(0).expect("pose");
            assert_eq!(
                solve_ik(&robot, &target, &state, &IkOptions::default()).map(|_| ()),
                expected
            );
        }
    }
}

#[test]
fn non_finite_temperature_and_approach() {
    let robot = aria::nominal();
    for bad in NON_FINITE {
        let state = JointState {
            q: Q,
            approach: None,
            temp_c: Some(bad),
        };
        assert_eq!(
            robot.fk(&state).map(|_| ()),
            Err(non_finite(Quantity::Temperature, 0))
        );
        let mut s = [1.0; 6];
        s[4] = bad;
        let state = JointState {
            q: Q,
            approach: Some(s),
            temp_c: None,
        };
        assert_eq!(
            robot.fk(&state).map(|_| ()),
            Err(non_finite(Quantity::ApproachDirection, 4))
        );
    }
}

/// An approach direction other than −1, 0, +1 is rejected with its index.
#[test]
fn approach_direction_must_be_sign() {
    let robot = aria::nominal();
    let state = JointState {
        q: Q,
        approach: Some([1.0, 0.0, -1.0, 0.5, 1.0, 1.0]),
        temp_c: None,
    };
    match robot.fk(&state) {
        Err(Error::NonFinite {
            what: Quantity::ApproachDirection,
            index: 3,
        }) => {}
        other => panic!("expected approach direction 4 rejected, got {other:?}"),
    }
}

#[test]
fn non_finite_parameters() {
    for bad in NON_FINITE {
        for i in 0..Robot::<6>::NUM_PARAMS {
            let mut robot = aria::nominal();
            let before = robot;
            assert_eq!(
                robot.set_param(ParamIndex(i), bad),
                Err(non_finite(Quantity::Parameter, i))
            );
            assert_eq!(robot, before, "set_param changed the robot on error");
            let mut p = vec![0.0; Robot::<6>::NUM_PARAMS];
            robot.read_params(&mut p).expect("read");
            p[i] = bad;
            assert_eq!(
                robot.write_params(&p),
                Err(non_finite(Quantity::Parameter, i))
            );
            assert_eq!(robot, before, "write_params changed the robot on error");
        }
    }
}

/// `Robot::new` names the exact link parameter (flat index 5·link + kind).
#[test]
fn non_finite_link_in_constructor() {
    for bad in NON_FINITE {
        for link in 0..6 {
            for kind in 0..5 {
                let mut links = aria::NOMINAL_LINKS;
                let l = &mut links[link];
                *[&mut l.theta0, &mut l.d, &mut l.a, &mut l.alpha, &mut l.beta][kind] = bad;
                assert_eq!(
                    Robot::new(links, aria::JOINT_LIMITS).map(|_| ()),
                    Err(non_finite(Quantity::Parameter, 5 * link + kind)),
                    "link {link}, kind {kind}"
                );
            }
        }
    }
}

#[test]
fn non_finite_frames_and_masses() {
    for k in 0..6 {
        let mut v = [0.0; 6];
        v[k] = f64::NAN;
        assert_eq!(
            aria::nominal().with_base(v).map(|_| ()),
            Err(non_finite(Quantity::Parameter, k))
        );
        assert_eq!(
            aria::nominal().with_tool(v).map(|_| ()),
            Err(non_finite(Quantity::Parameter, k))
        );
    }
    let mut m = aria::MASS_MODEL;
    m.link_masses_kg[2] = f64::INFINITY;
    assert_eq!(
        aria::nominal().with_mass(m).map(|_| ()),
        Err(non_finite(Quantity::Parameter, 2))
    );
    let mut m = aria::MASS_MODEL;
    m.link_masses_kg[3] = -0.1;
    assert_eq!(
        aria::nominal().with_mass(m).map(|_| ()),
        Err(Error::InvalidParameter {
            index: 3,
            value: -0.1
        })
    );
    let m = MassModel {
        tool_mass_kg: -1.0,
        ..aria::MASS_MODEL
    };
    assert_eq!(
        aria::nominal().with_mass(m).map(|_| ()),
        Err(Error::InvalidParameter {
            index: 6,
            value: -1.0
        })
    );
}

#[test]
fn non_finite_ik_targets_and_settings() {
    let robot = aria::nominal();
    let seed = JointState::new(Q);
    let opts = IkOptions::default();
    for k in 0..3 {
        let mut target = aria::tool_pose(0).expect("pose");
        target.translation.vector[k] = f64::NAN;
        assert_eq!(
            solve_ik(&robot, &target, &seed, &opts).map(|_| ()),
            Err(non_finite(Quantity::Position, k))
        );
    }
    for k in 0..9 {
        let target = aria::tool_pose(0).expect("pose");
        let mut m = target.rotation.into_inner();
        m.as_mut_slice()[k] = f64::INFINITY;
        let target = kincal::Transform::from_parts(
            target.translation,
            nalgebra::Rotation3::from_matrix_unchecked(m),
        );
        // Index into the column-major rotation matrix.
        assert_eq!(
            solve_ik(&robot, &target, &seed, &opts).map(|_| ()),
            Err(non_finite(Quantity::Orientation, k))
        );
    }
    let target = aria::tool_pose(0).expect("pose");
    let bad = IkOptions {
        tol_rot_rad: f64::NAN,
        ..opts
    };
    assert_eq!(
        solve_ik(&robot, &target, &seed, &bad).map(|_| ()),
        Err(non_finite(Quantity::Setting, 1))
    );
}

#[test]
fn wrong_buffer_lengths() {
    let robot = aria::nominal();
    let state = JointState::new(Q);
    for len in [
        0,
        1,
        Robot::<6>::NUM_GEOMETRIC_PARAMS - 1,
        Robot::<6>::NUM_GEOMETRIC_PARAMS + 1,
        Robot::<6>::NUM_PARAMS + 1,
    ] {
        let mut jac = vec![[0.0; 6]; len];
        assert_eq!(
            robot.jacobian(&state, &mut jac).map(|_| ()),
            Err(Error::DimensionMismatch {
                expected: Robot::<6>::NUM_GEOMETRIC_PARAMS,
                found: len
            })
        );
        let mut p = vec![0.0; len];
        let expected = Err(Error::DimensionMismatch {
            expected: Robot::<6>::NUM_PARAMS,
            found: len,
        });
        assert_eq!(robot.read_params(&mut p), expected);
        assert_eq!(robot.clone().write_params(&p), expected);
    }
    // Both accepted lengths work.
    for len in [Robot::<6>::NUM_GEOMETRIC_PARAMS, Robot::<6>::NUM_PARAMS] {
        let mut jac = vec![[0.0; 6]; len];
        assert!(robot.jacobian(&state, &mut jac).is_ok());
    }
    // Parameter indices past the end.
    let n = Robot::<6>::NUM_PARAMS;
    assert!(matches!(
        aria::nominal().set_param(ParamIndex(n), 0.0),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        robot.param(ParamIndex(n)),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(ParamId::from_index(ParamIndex(n - 1), 6).is_ok());
    assert!(ParamId::from_index(ParamIndex(n), 6).is_err());
}

#[test]
fn invalid_limits() {
    let cases = [
        (2, JointLimits::new(1.0, -1.0)),
        (0, JointLimits::new(f64::NAN, 1.0)),
        (5, JointLimits::new(-1.0, f64::INFINITY)),
        (3, JointLimits::new(f64::NEG_INFINITY, 0.0)),
    ];
    for (j, lim) in cases {
        let mut limits = aria::JOINT_LIMITS;
        limits[j] = lim;
        let expected = Err(Error::InvalidLimits {
            joint: JointIndex(j),
        });
        assert_eq!(
            Robot::new(aria::NOMINAL_LINKS, limits).map(|_| ()),
            expected
        );
        let mut robot = aria::nominal();
        assert_eq!(robot.set_limits(limits), expected);
        assert_eq!(
            robot.limits(),
            &aria::JOINT_LIMITS,
            "limits changed on error"
        );
    }
    // A single admissible value (lower == upper) is valid.
    let mut limits = aria::JOINT_LIMITS;
    limits[1] = JointLimits::new(0.5, 0.5);
    assert!(Robot::new(aria::NOMINAL_LINKS, limits).is_ok());
}

#[test]
fn out_of_limits_readings() {
    let robot = aria::nominal();
    // Inclusive bounds.
    let mut q = Q;
    q[1] = aria::JOINT_LIMITS[1].upper;
    q[2] = aria::JOINT_LIMITS[2].lower;
    assert_eq!(robot.check_limits(&q), Ok(()));
    let mut q = Q;
    q[2] = 1.69 + 1e-12;
    assert_eq!(
        robot.check_limits(&q),
        Err(Error::OutOfLimits {
            joint: JointIndex(2),
            value: 1.69 + 1e-12,
            lower: aria::Q3_LOWER_ASSUMED_RAD,
            upper: 1.69,
        })
    );
    let mut q = Q;
    q[1] = -0.98;
    assert!(matches!(
        robot.check_limits(&q),
        Err(Error::OutOfLimits {
            joint: JointIndex(1),
            ..
        })
    ));
    // FK itself does not police limits (data may be predicted anywhere).
    assert!(robot.fk_q(&q).is_ok());
}

/// A model with backlash refuses data without approach directions; one with thermal
/// expansion refuses data without a temperature. Both in FK, Jacobian and IK.
#[test]
fn missing_effect_inputs() {
    let target = aria::tool_pose(0).expect("pose");
    let state = JointState::new(Q);
    let mut jac = vec![[0.0; 6]; Robot::<6>::NUM_PARAMS];
    for (id, what) in [
        (ParamId::Backlash(3), Quantity::ApproachDirection),
        (ParamId::Thermal, Quantity::Temperature),
    ] {
        let mut robot = aria::nominal();
        robot.set_param(id.index(6), 1e-3).expect("set");
        let expected = Err(Error::MissingInput { what });
        assert_eq!(robot.fk(&state).map(|_| ()), expected);
        assert_eq!(robot.jacobian(&state, &mut jac).map(|_| ()), expected);
        assert_eq!(
            solve_ik(&robot, &target, &state, &IkOptions::default()).map(|_| ()),
            expected
        );
        // With the input, it works.
        let full = JointState {
            q: Q,
            approach: Some([0.0, 1.0, -1.0, 1.0, 0.0, 1.0]),
            temp_c: Some(30.0),
        };
        assert!(robot.fk(&full).is_ok());
    }
}

#[test]
fn any_robot_joint_counts() {
    let link = Link::dh(0.0, 0.1, 0.2, 0.3);
    let lim = JointLimits::new(-1.0, 1.0);
    assert_eq!(
        AnyRobot::new(&[], &[]).map(|_| ()),
        Err(Error::DimensionMismatch {
            expected: 1,
            found: 0
        })
    );
    let ten_links = [link; 13];
    let ten_limits = [lim; 13];
    assert_eq!(
        AnyRobot::new(&ten_links, &ten_limits).map(|_| ()),
        Err(Error::CapacityExceeded {
            needed: 13,
            capacity: MAX_JOINTS
        })
    );
    assert_eq!(
        AnyRobot::new(&ten_links[..12], &ten_limits[..12]).map(|r| r.n_joints()),
        Ok(12)
    );
    assert_eq!(
        AnyRobot::new(&ten_links[..3], &ten_limits[..4]).map(|_| ()),
        Err(Error::DimensionMismatch {
            expected: 3,
            found: 4
        })
    );
    for n in 1..=MAX_JOINTS {
        let any = AnyRobot::new(&ten_links[..n], &ten_limits[..n]).expect("robot");
        assert_eq!(any.n_joints(), n);
    }
    // Errors of the links pass through.
    let mut bad = [link; 7];
    bad[4].alpha = f64::NAN;
    assert_eq!(
        AnyRobot::new(&bad, &ten_limits[..7]).map(|_| ()),
        Err(non_finite(Quantity::Parameter, 5 * 4 + 3))
    );
    let mut bad_lim = [lim; 7];
    bad_lim[6] = JointLimits::new(2.0, 1.0);
    assert_eq!(
        AnyRobot::new(&[link; 7], &bad_lim).map(|_| ()),
        Err(Error::InvalidLimits {
            joint: JointIndex(6)
        })
    );
}

#[test]
fn zero_joint_robot_is_rejected() {
    assert_eq!(
        Robot::<0>::new([], []).map(|_| ()),
        Err(Error::DimensionMismatch {
            expected: 1,
            found: 0
        })
    );
}

/// Errors display without panicking and name the culprit (1-based joint numbers).
#[test]
fn errors_display_their_culprit() {
    let e = Error::OutOfLimits {
        joint: JointIndex(2),
        value: 2.0,
        lower: -1.0,
        upper: 1.69,
    };
    let s = e.to_string();
    assert!(s.contains("joint 3") && s.contains("1.69"), "{s}");
    let s = non_finite(Quantity::JointReading, 4).to_string();
    assert!(s.contains("JointReading") && s.contains('4'), "{s}");
}
