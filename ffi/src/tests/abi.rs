//! The exports called the way C calls them. Where a number is checked it is checked against
//! an independent route (the core called directly, finite differences through the ABI, or
//! literal values shared with tests/cpp/consumer.cpp).

use core::ffi::{CStr, c_char};
use core::ptr::{null, null_mut};

use kincal::aria;
use kincal::ik::{IkOptions, solve_ik};
use kincal::{Error, JointIndex, JointState, ParamIndex, PoseIndex, Quantity};

use crate::aria::*;
use crate::axis_chain::*;
use crate::effects::*;
use crate::ik::*;
use crate::kinematics::*;
use crate::params::*;
use crate::pose::*;
use crate::robot::*;
use crate::status::*;

const TOL: f64 = 1e-12;

/// A configuration away from singularities, inside the ARIA limits.
const Q: [f64; 6] = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9];

fn aria_robot(model: kincal_aria_model) -> kincal_robot {
    let mut r = core::mem::MaybeUninit::<kincal_robot>::uninit();
    let s = unsafe { kincal_robot_aria(r.as_mut_ptr(), model as u32, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    unsafe { r.assume_init() }
}

fn new_err() -> kincal_error {
    // Garbage on purpose: every export must overwrite all of it.
    let mut e = kincal_error::CLEAR;
    e.status = 12345;
    e.index = 7;
    e.value = 3.0;
    e
}

/// The detail of a successful call: everything cleared (NaN compares unequal, so not `==`).
fn assert_clear(e: &kincal_error) {
    let c = kincal_error::CLEAR;
    assert_eq!(
        (
            e.status,
            e.quantity,
            e.argument,
            e.index,
            e.joint,
            e.pose,
            e.expected,
            e.found,
            e.iterations
        ),
        (
            c.status,
            c.quantity,
            c.argument,
            c.index,
            c.joint,
            c.pose,
            c.expected,
            c.found,
            c.iterations
        )
    );
    assert!(
        [
            e.value,
            e.lower,
            e.upper,
            e.residual_pos_m,
            e.residual_rot_rad
        ]
        .iter()
        .all(|v| v.is_nan())
    );
}

fn arg_name(e: &kincal_error) -> &'static str {
    assert!(!e.argument.is_null(), "no argument named in {e:?}");
    unsafe { CStr::from_ptr(e.argument) }.to_str().unwrap()
}

fn fk(r: &kincal_robot, q: &[f64]) -> [f64; 16] {
    let mut t = [0.0; 16];
    let s = unsafe {
        kincal_fk(
            r,
            q.as_ptr(),
            q.len(),
            null(),
            t.as_mut_ptr(),
            16,
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);
    t
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn core_fk_matrix(robot: &kincal::Robot<6>, q: [f64; 6]) -> [f64; 16] {
    crate::pose::to_matrix(&robot.fk(&JointState::new(q)).unwrap())
}

// ---------------------------------------------------------------- status codes

#[test]
fn status_numbers_are_fixed() {
    use kincal_status as S;
    let table = [
        (S::Ok, 0),
        (S::NullPointer, 100),
        (S::BadLength, 101),
        (S::NonFinite, 102),
        (S::OutOfLimits, 103),
        (S::BadJointCount, 104),
        (S::InvalidLimits, 105),
        (S::InvalidParameter, 106),
        (S::MissingInput, 107),
        (S::UnknownLabel, 108),
        (S::IndexOutOfRange, 109),
        (S::InvalidTransform, 110),
        (S::InvalidArgument, 111),
        (S::CapacityExceeded, 112),
        (S::TooFewData, 113),
        (S::BadPose, 114),
        (S::MisalignedPointer, 115),
        (S::DegenerateAxis, 116),
        (S::BadHandle, 117),
        (S::BadGroup, 118),
        (S::DegenerateGroup, 119),
        (S::BadDistance, 120),
        (S::BadFile, 121),
        (S::Unreachable, 200),
        (S::NotConverged, 201),
        (S::RankDeficient, 202),
        (S::BoundViolated, 203),
        (S::NonFiniteResult, 204),
        (S::Internal, 900),
        (S::Panic, 999),
    ];
    assert_eq!(table.len(), S::ALL.len());
    for ((s, n), all) in table.iter().zip(S::ALL) {
        assert_eq!(*s as u32, *n);
        assert_eq!(*s, all, "ALL must list statuses in numeric order");
        assert_eq!(S::from_u32(*n), Some(*s));
    }
    assert_eq!(S::ALL.last(), Some(&S::Panic), "PANIC stays last");
}

#[test]
fn status_str_is_static_and_names_the_code() {
    for s in kincal_status::ALL {
        let p = kincal_status_str(s as u32);
        assert!(!p.is_null());
        let text = unsafe { CStr::from_ptr(p) }.to_str().unwrap();
        assert!(text.starts_with("KINCAL_STATUS_"), "{text}");
        // The C name in the text is the header's enumerator.
        let name = text.split(':').next().unwrap();
        let header = include_str!("../../../include/kincal.h");
        assert!(
            header.contains(&format!("{name} = {}", s as u32)),
            "{name} = {} not in the header",
            s as u32
        );
    }
    for unknown in [1, 99, 122, 205, 901, 1000, u32::MAX] {
        let text = unsafe { CStr::from_ptr(kincal_status_str(unknown)) };
        assert_eq!(text.to_str().unwrap(), "unknown kincal status code");
    }
}

#[test]
fn every_core_error_is_mapped() {
    use kincal_status as S;
    let cases = [
        (
            Error::NonFinite {
                what: Quantity::JointReading,
                index: 2,
            },
            S::NonFinite,
        ),
        (
            Error::DimensionMismatch {
                expected: 6,
                found: 5,
            },
            S::BadLength,
        ),
        (
            Error::OutOfLimits {
                joint: JointIndex(1),
                value: 4.0,
                lower: -1.0,
                upper: 1.0,
            },
            S::OutOfLimits,
        ),
        (
            Error::MissingInput {
                what: Quantity::Temperature,
            },
            S::MissingInput,
        ),
        (
            Error::InvalidLimits {
                joint: JointIndex(3),
            },
            S::InvalidLimits,
        ),
        (
            Error::InvalidParameter {
                index: 4,
                value: -1.0,
            },
            S::InvalidParameter,
        ),
        (
            Error::Unreachable {
                residual_pos_m: 0.1,
                residual_rot_rad: 0.2,
            },
            S::Unreachable,
        ),
        (Error::NotConverged { iterations: 50 }, S::NotConverged),
        (
            Error::RankDeficient {
                rank: 20,
                required: 24,
            },
            S::RankDeficient,
        ),
        (
            Error::CapacityExceeded {
                needed: 9,
                capacity: 8,
            },
            S::CapacityExceeded,
        ),
        (
            Error::TooFewData {
                found: 2,
                needed: 5,
            },
            S::TooFewData,
        ),
        (Error::BadPose { pose: PoseIndex(3) }, S::BadPose),
        (Error::BadGroup { group: 4 }, S::BadGroup),
        (Error::DegenerateGroup { group: 5 }, S::DegenerateGroup),
        (Error::BadDistance { distance: 1 }, S::BadDistance),
        (
            Error::BoundViolated {
                param: ParamIndex(10),
                value: 2.0,
            },
            S::BoundViolated,
        ),
    ];
    let cases = {
        let mut v = cases.to_vec();
        v.push((
            Error::DegenerateAxis {
                joint: JointIndex(2),
            },
            S::DegenerateAxis,
        ));
        v.push((
            Error::InvalidOption {
                option: "extra_seeds",
                value: 1e6,
            },
            S::InvalidArgument,
        ));
        v
    };
    for (e, s) in cases {
        let k = kincal_error::from(e);
        assert_eq!(k.status, s as u32, "{e:?}");
        assert_ne!(s, S::Internal);
    }
    let k = kincal_error::from(Error::OutOfLimits {
        joint: JointIndex(1),
        value: 4.0,
        lower: -1.0,
        upper: 1.0,
    });
    assert_eq!((k.joint, k.value, k.lower, k.upper), (1, 4.0, -1.0, 1.0));
    let k = kincal_error::from(Error::RankDeficient {
        rank: 20,
        required: 24,
    });
    assert_eq!((k.found, k.expected), (20, 24));
    let k = kincal_error::from(Error::NonFinite {
        what: Quantity::Temperature,
        index: 0,
    });
    assert_eq!(k.quantity, kincal_quantity::Temperature as u32);
    let k = kincal_error::from(Error::NotConverged { iterations: 50 });
    assert_eq!(k.iterations, 50);
    let k = kincal_error::from(Error::BadPose { pose: PoseIndex(3) });
    assert_eq!(k.pose, 3);
}

/// `kincal::Error` is `#[non_exhaustive]`, so the mapping needs a catch-all arm and a new core
/// variant would silently become KINCAL_STATUS_INTERNAL. This reads the variant names from the
/// core's source and requires an explicit arm for each.
#[test]
fn every_core_error_variant_has_a_status() {
    let core_src = include_str!("../../../core/src/error.rs");
    let body = core_src
        .split("pub enum Error {")
        .nth(1)
        .and_then(|rest| rest.split("\n}\n").next())
        .expect("core/src/error.rs declares `pub enum Error {`");
    let variants: Vec<&str> = body
        .lines()
        .filter_map(|l| l.strip_prefix("    "))
        .filter(|l| l.starts_with(|c: char| c.is_ascii_uppercase()))
        .map(|l| l.split(|c: char| !c.is_alphanumeric()).next().unwrap())
        .collect();
    assert!(variants.len() >= 14, "parsed {variants:?}");
    let mapping = include_str!("../status.rs");
    for v in variants {
        assert!(
            mapping.contains(&format!("Error::{v} {{"))
                || mapping.contains(&format!("Error::{v} =>")),
            "core Error::{v} has no explicit kincal_status mapping in ffi/src/status.rs"
        );
    }
}

#[test]
fn version_comes_from_cargo() {
    let v = unsafe { CStr::from_ptr(kincal_version()) };
    assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
}

#[test]
fn error_describe_is_snprintf_like() {
    let mut e = kincal_error::new(kincal_status::BadLength)
        .arg(c"q")
        .counts(6, 5);
    e.value = 1e-300;
    let mut buf = [0 as c_char; 512];
    let n = unsafe { kincal_error_describe(&e, buf.as_mut_ptr(), buf.len()) };
    let text = unsafe { CStr::from_ptr(buf.as_ptr()) }.to_str().unwrap();
    assert_eq!(n, text.len());
    assert!(text.starts_with("KINCAL_STATUS_BAD_LENGTH"), "{text}");
    assert!(
        text.contains("argument 'q'") && text.contains("expected 6") && text.contains("found 5")
    );
    assert!(text.contains("1e-300"), "{text}");
    // Truncation: the full length is returned, the buffer is NUL-terminated.
    let mut small = [0x55 as c_char; 10];
    let m = unsafe { kincal_error_describe(&e, small.as_mut_ptr(), small.len()) };
    assert_eq!(m, n);
    assert_eq!(small[9], 0);
    assert_eq!(
        unsafe { CStr::from_ptr(small.as_ptr()) }.to_bytes().len(),
        9
    );
    // Length query and NULL handling.
    assert_eq!(unsafe { kincal_error_describe(&e, null_mut(), 0) }, n);
    assert_eq!(
        unsafe { kincal_error_describe(null(), buf.as_mut_ptr(), 512) },
        0
    );
    assert_eq!(unsafe { kincal_error_describe(&e, null_mut(), 5) }, 0);
    // Worst realistic case fits the documented 512 bytes.
    let mut w = kincal_error::new(kincal_status::OutOfLimits).arg(c"robot->link_masses_kg");
    (w.index, w.joint, w.pose, w.expected, w.found) =
        (usize::MAX - 1, 7, 1 << 40, 1 << 50, 1 << 60);
    (w.value, w.lower, w.upper) = (-1.234_567_890_123_456_7e-300, -f64::MAX, f64::MAX);
    (
        w.residual_pos_m,
        w.residual_rot_rad,
        w.iterations,
        w.quantity,
    ) = (f64::MIN_POSITIVE, -0.1, u32::MAX, 6);
    assert!(unsafe { kincal_error_describe(&w, null_mut(), 0) } < 512);
}

// ---------------------------------------------------------------- the robot struct

#[test]
fn robot_size_matches() {
    assert_eq!(kincal_robot_size(), core::mem::size_of::<kincal_robot>());
}

#[test]
fn aria_models_match_the_core() {
    for (model, core) in [
        (kincal_aria_model::Nominal, aria::nominal()),
        (kincal_aria_model::VirtualTruth, aria::virtual_truth()),
        (kincal_aria_model::RealIdentified, aria::real_identified()),
    ] {
        let r = aria_robot(model);
        assert_eq!(r.n_joints, 6);
        // The round trip is exact: the same numbers give the same model.
        assert_eq!(to_any(&r).unwrap(), kincal::any::AnyRobot::from(core));
        assert_eq!(max_abs_diff(&fk(&r, &Q), &core_fk_matrix(&core, Q)), 0.0);
    }
    let mut e = new_err();
    let s = unsafe { kincal_robot_aria(&mut aria_robot(kincal_aria_model::Nominal), 3, &mut e) };
    assert_eq!(s, kincal_status::InvalidArgument);
    assert_eq!(arg_name(&e), "model");
}

#[test]
fn robot_from_a_parameter_table() {
    let mut table = [0.0; 30];
    for (row, l) in table.chunks_exact_mut(5).zip(aria::NOMINAL_LINKS.iter()) {
        row.copy_from_slice(&[l.theta0, l.d, l.a, l.alpha, l.beta]);
    }
    let limits: Vec<f64> = aria::JOINT_LIMITS
        .iter()
        .flat_map(|l| [l.lower, l.upper])
        .collect();
    let mut r = kincal_robot::ZERO;
    let mut e = new_err();
    let s =
        unsafe { kincal_robot_init(&mut r, 6, table.as_ptr(), 30, limits.as_ptr(), 12, &mut e) };
    assert_eq!(s, kincal_status::Ok);
    assert_clear(&e);
    // Axes 2 and 3 are parallel: link 2 identifies β (Table 4).
    assert_eq!(&r.length_param[..6], &[0, 1, 0, 0, 0, 0]);
    let nominal = aria_robot(kincal_aria_model::Nominal);
    assert_eq!(max_abs_diff(&fk(&r, &Q), &fk(&nominal, &Q)), 0.0);
    // Masses: the table robot has none until set.
    let g = [0.0, 0.0, -9.81];
    let s = unsafe {
        kincal_robot_set_mass(
            &mut r,
            aria::LINK_MASSES_KG.as_ptr(),
            6,
            aria::TOOL_MASS_KG,
            g.as_ptr(),
            3,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(r, nominal);

    // Argument errors, each naming its argument.
    let bad = |n: usize, links: &[f64], lims: &[f64]| {
        let mut e = new_err();
        let mut out = kincal_robot::ZERO;
        let s = unsafe {
            kincal_robot_init(
                &mut out,
                n,
                links.as_ptr(),
                links.len(),
                lims.as_ptr(),
                lims.len(),
                &mut e,
            )
        };
        (s, e)
    };
    let (s, e) = bad(0, &table, &limits);
    assert_eq!(
        (s, arg_name(&e), e.found),
        (kincal_status::BadJointCount, "n_joints", 0)
    );
    let (s, _) = bad(13, &table, &limits);
    assert_eq!(s, kincal_status::BadJointCount);
    let (s, e) = bad(6, &table[..29], &limits);
    assert_eq!(
        (s, arg_name(&e), e.expected, e.found),
        (kincal_status::BadLength, "links", 30, 29)
    );
    let mut nan = table;
    nan[12] = f64::NAN;
    let (s, e) = bad(6, &nan, &limits);
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::NonFinite, "links", 12)
    );
    let mut swapped = limits.clone();
    swapped.swap(2, 3);
    let (s, e) = bad(6, &table, &swapped);
    assert_eq!(
        (s, arg_name(&e), e.joint),
        (kincal_status::InvalidLimits, "limits", 1)
    );
    let mut e = new_err();
    let s = unsafe {
        kincal_robot_init(
            null_mut(),
            6,
            table.as_ptr(),
            30,
            limits.as_ptr(),
            12,
            &mut e,
        )
    };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "robot_out"));
    let s = unsafe { kincal_robot_init(&mut r, 6, null(), 30, limits.as_ptr(), 12, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "links"));
}

#[test]
fn a_corrupt_robot_is_reported_not_trusted() {
    let good = aria_robot(kincal_aria_model::Nominal);
    let check = |r: &kincal_robot| {
        let mut e = new_err();
        let s = unsafe { kincal_robot_validate(r, &mut e) };
        (s, e)
    };
    assert_eq!(check(&good).0, kincal_status::Ok);
    let mut r = good;
    r.n_joints = 0;
    assert_eq!(check(&r).0, kincal_status::BadJointCount);
    r.n_joints = 1000;
    let (s, e) = check(&r);
    assert_eq!(
        (s, e.found, e.expected),
        (kincal_status::BadJointCount, 1000, 12)
    );
    let mut r = good;
    r.params[33] = f64::INFINITY;
    let (s, e) = check(&r);
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::NonFinite, "robot->params", 33)
    );
    let mut r = good;
    r.nominal[3] = f64::NAN;
    assert_eq!(arg_name(&check(&r).1), "robot->nominal");
    let mut r = good;
    r.length_param[2] = 7;
    let (s, e) = check(&r);
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::InvalidArgument, "robot->length_param", 2)
    );
    let mut r = good;
    r.limits_lower[4] = 10.0;
    let (s, e) = check(&r);
    assert_eq!((s, e.joint), (kincal_status::InvalidLimits, 4));
    let mut r = good;
    r.link_masses_kg[1] = -1.0;
    let (s, e) = check(&r);
    assert_eq!(
        (s, e.index, e.value),
        (kincal_status::InvalidParameter, 1, -1.0)
    );
    // Entries beyond the joint count are ignored.
    let mut r = good;
    r.params[108] = f64::NAN;
    r.length_param[7] = 99;
    r.limits_lower[7] = f64::NAN;
    assert_eq!(check(&r).0, kincal_status::Ok);
    // NULL and misaligned pointers.
    assert_eq!(check_ptr_status(null()), kincal_status::NullPointer);
    let mut bytes = [0u8; core::mem::size_of::<kincal_robot>() + 8];
    let odd = unsafe { bytes.as_mut_ptr().add(1) }.cast::<kincal_robot>();
    assert_eq!(check_ptr_status(odd), kincal_status::MisalignedPointer);
}

fn check_ptr_status(p: *const kincal_robot) -> kincal_status {
    unsafe { kincal_robot_validate(p, null_mut()) }
}

#[test]
fn base_tool_limits_and_length_param_setters() {
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let base = [0.1, -0.2, 0.3, 0.01, 0.02, -0.03];
    let tool = [0.0, 0.0, 0.1, 0.0, 0.2, 0.0];
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_robot_set_base(&mut r, base.as_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(
        unsafe { kincal_robot_set_tool(&mut r, tool.as_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    let core = aria::nominal()
        .with_base(base)
        .unwrap()
        .with_tool(tool)
        .unwrap();
    assert_eq!(max_abs_diff(&fk(&r, &Q), &core_fk_matrix(&core, Q)), 0.0);
    // Both current and nominal frames were set.
    assert_eq!(&r.nominal[30..36], &base);
    assert_eq!(&r.params[36..42], &tool);

    let before = r;
    let s = unsafe { kincal_robot_set_base(&mut r, base.as_ptr(), 5, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "base"));
    assert_eq!(r, before, "unchanged on failure");

    let limits = [
        -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0,
    ];
    assert_eq!(
        unsafe { kincal_robot_set_limits(&mut r, limits.as_ptr(), 12, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(&r.limits_upper[..6], &[1.0; 6]);
    let mut bad = limits;
    bad[4] = 2.0;
    let s = unsafe { kincal_robot_set_limits(&mut r, bad.as_ptr(), 12, &mut e) };
    assert_eq!(
        (s, e.joint, arg_name(&e)),
        (kincal_status::InvalidLimits, 2, "limits")
    );

    assert_eq!(
        unsafe {
            kincal_robot_set_length_param(&mut r, 3, kincal_length_param::Beta as u32, &mut e)
        },
        kincal_status::Ok
    );
    assert_eq!(r.length_param[3], 1);
    let s = unsafe { kincal_robot_set_length_param(&mut r, 6, 0, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::IndexOutOfRange, "link"));
    let s = unsafe { kincal_robot_set_length_param(&mut r, 0, 2, &mut e) };
    assert_eq!(
        (s, arg_name(&e)),
        (kincal_status::InvalidArgument, "choice")
    );

    // Joint kinds: the setter equals editing the field, and is checked.
    let mut direct = r;
    direct.joint_kind[2] = kincal_joint_kind::Prismatic as u32;
    assert_eq!(
        unsafe {
            kincal_robot_set_joint_kind(&mut r, 2, kincal_joint_kind::Prismatic as u32, &mut e)
        },
        kincal_status::Ok
    );
    assert_eq!(r.joint_kind, direct.joint_kind);
    assert_eq!(
        crate::robot::to_any(&r).unwrap().joint_kind(2),
        kincal::JointKind::Prismatic
    );
    let s = unsafe { kincal_robot_set_joint_kind(&mut r, 6, 0, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::IndexOutOfRange, "joint"));
    let s = unsafe { kincal_robot_set_joint_kind(&mut r, 0, 3, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::InvalidArgument, "kind"));
    // A sensor joint (KINCAL_JOINT_KIND_SENSOR) is a kind the setter takes.
    let s =
        unsafe { kincal_robot_set_joint_kind(&mut r, 0, kincal_joint_kind::Sensor as u32, &mut e) };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(r.joint_kind[0], kincal_joint_kind::Sensor as u32);
    assert_eq!(
        crate::robot::to_any(&r).unwrap().joint_kind(0),
        kincal::JointKind::Sensor
    );
    let s = unsafe {
        kincal_robot_set_joint_kind(&mut r, 0, kincal_joint_kind::Revolute as u32, &mut e)
    };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(
        unsafe {
            kincal_robot_set_joint_kind(&mut r, 2, kincal_joint_kind::Revolute as u32, &mut e)
        },
        kincal_status::Ok
    );
    assert_eq!(r.joint_kind[2], 0);

    // Adopting the current geometry as nominal.
    let mut t = aria_robot(kincal_aria_model::VirtualTruth);
    assert_eq!(
        unsafe { kincal_robot_adopt_geometry_as_nominal(&mut t, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(&t.nominal[..30], &t.params[..30]);
}

// ---------------------------------------------------------------- parameters

#[test]
fn parameters_by_index_and_label() {
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let mut e = new_err();
    let index = |r: &kincal_robot, label: &CStr| {
        let mut i = usize::MAX;
        let s = unsafe { kincal_robot_param_index(r, label.as_ptr(), &mut i, null_mut()) };
        assert_eq!(s, kincal_status::Ok, "{label:?}");
        i
    };
    // Layout of spec: link i at 5i.., base at 5N, tool at 5N+6, compliance at 5N+12.
    assert_eq!(index(&r, c"theta0_3"), 10);
    assert_eq!(index(&r, c"beta_2"), 9);
    assert_eq!(index(&r, c"base_px"), 30);
    assert_eq!(index(&r, c"tool_rz"), 41);
    assert_eq!(index(&r, c"compliance_2"), 43);
    assert_eq!(index(&r, c"cyclic_sin1_1"), 7 * 6 + 12);
    assert_eq!(index(&r, c"thermal_kappa"), 12 * 6 + 12);

    let mut v = 0.0;
    assert_eq!(
        unsafe { kincal_robot_get_param(&r, 10, &mut v, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(v, core::f64::consts::FRAC_PI_2);
    assert_eq!(
        unsafe { kincal_robot_get_param_by_label(&r, c"d_1".as_ptr(), &mut v, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(v, 0.205);

    assert_eq!(
        unsafe { kincal_robot_set_param_by_label(&mut r, c"alpha_2".as_ptr(), 0.1, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(
        unsafe { kincal_robot_set_param(&mut r, 15, -0.8, &mut e) },
        kincal_status::Ok
    );
    let mut core = aria::nominal();
    core.set_param(ParamIndex(8), 0.1).unwrap();
    core.set_param(ParamIndex(15), -0.8).unwrap();
    assert_eq!(max_abs_diff(&fk(&r, &Q), &core_fk_matrix(&core, Q)), 0.0);
    // Only the current model moves; the nominal one stays Table 1.
    assert_eq!(r.nominal[8], 0.0);

    // Labels of every index round-trip through the index lookup.
    for i in 0..kincal_num_params(6) {
        let mut buf = [0 as c_char; KINCAL_LABEL_CAPACITY];
        let s = unsafe { kincal_robot_param_label(&r, i, buf.as_mut_ptr(), buf.len(), &mut e) };
        assert_eq!(s, kincal_status::Ok);
        let label = unsafe { CStr::from_ptr(buf.as_ptr()) };
        assert_eq!(index(&r, label), i, "{label:?}");
    }
    let mut small = [0 as c_char; 8];
    let s = unsafe { kincal_robot_param_label(&r, 7 * 6 + 12, small.as_mut_ptr(), 8, &mut e) };
    assert_eq!((s, e.expected, e.found), (kincal_status::BadLength, 14, 8)); // "cyclic_sin1_1"

    // Errors.
    let s = unsafe { kincal_robot_get_param(&r, 85, &mut v, &mut e) };
    assert_eq!(
        (s, e.index, e.expected),
        (kincal_status::IndexOutOfRange, 85, 85)
    );
    let s = unsafe { kincal_robot_set_param(&mut r, 0, f64::NAN, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NonFinite, "value"));
    for bad in [
        c"theta0_7",
        c"theta0_0",
        c"theta0_03",
        c"gamma_1",
        c"",
        c"base_qx",
    ] {
        let s = unsafe { kincal_robot_set_param_by_label(&mut r, bad.as_ptr(), 1.0, &mut e) };
        assert_eq!(s, kincal_status::UnknownLabel, "{bad:?}");
    }
    let not_utf8 = [0xffu8 as c_char, 0];
    let s = unsafe { kincal_robot_param_index(&r, not_utf8.as_ptr(), &mut 0, &mut e) };
    assert_eq!(s, kincal_status::UnknownLabel);
    let s = unsafe { kincal_robot_param_index(&r, null(), &mut 0, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "label"));
    let s = unsafe { kincal_robot_get_param(&r, 0, null_mut(), &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "value_out"));
}

#[test]
fn whole_parameter_vector_and_mask() {
    let truth = aria_robot(kincal_aria_model::VirtualTruth);
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let mut p = [0.0; 85];
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_robot_get_params(&truth, p.as_mut_ptr(), 85, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(&p[..], &truth.params[..85]);
    assert_eq!(
        unsafe { kincal_robot_set_params(&mut r, p.as_ptr(), 85, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(max_abs_diff(&fk(&r, &Q), &fk(&truth, &Q)), 0.0);
    let s = unsafe { kincal_robot_get_params(&truth, p.as_mut_ptr(), 84, &mut e) };
    assert_eq!((s, e.expected, e.found), (kincal_status::BadLength, 85, 84));

    let mut mask = [9u8; 85];
    assert_eq!(
        unsafe { kincal_robot_param_mask(&r, 0, mask.as_mut_ptr(), 85, &mut e) },
        kincal_status::Ok
    );
    // 4 per link: θ0, a, α and d (β for link 2).
    assert_eq!(mask.iter().map(|&m| usize::from(m)).sum::<usize>(), 24);
    assert_eq!((mask[5 + 1], mask[5 + 4]), (0, 1), "link 2: β instead of d");
    let compliance = 1 << kincal_effect::JointCompliance as u32;
    assert_eq!(
        unsafe { kincal_robot_param_mask(&r, compliance, mask.as_mut_ptr(), 85, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(mask.iter().map(|&m| usize::from(m)).sum::<usize>(), 30);
    let s = unsafe { kincal_robot_param_mask(&r, 1 << 7, mask.as_mut_ptr(), 85, &mut e) };
    assert_eq!(
        (s, arg_name(&e)),
        (kincal_status::InvalidArgument, "effects")
    );
}

// ---------------------------------------------------------------- kinematics

#[test]
fn fk_forms_agree() {
    let r = aria_robot(kincal_aria_model::VirtualTruth);
    let t = fk(&r, &Q);
    let mut pq = [0.0; 7];
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_fk_pq(&r, Q.as_ptr(), 6, null(), pq.as_mut_ptr(), 7, &mut e) },
        kincal_status::Ok
    );
    let mut t2 = [0.0; 16];
    assert_eq!(
        unsafe { kincal_pose_from_pq(pq.as_ptr(), 7, t2.as_mut_ptr(), 16, &mut e) },
        kincal_status::Ok
    );
    assert!(max_abs_diff(&t, &t2) < TOL);
    assert!(pq[3] >= 0.0);
    // Frames: first is the base, last is the tool pose; frame 6 with identity tool = tool.
    let mut frames = [0.0; 16 * 8];
    assert_eq!(
        unsafe { kincal_fk_frames(&r, Q.as_ptr(), 6, null(), frames.as_mut_ptr(), 128, &mut e) },
        kincal_status::Ok
    );
    let identity = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    assert_eq!(&frames[..16], &identity);
    assert!(max_abs_diff(&frames[112..], &t) < TOL);
    assert!(max_abs_diff(&frames[96..112], &t) < TOL);
    // Frame 1 = Rz(q1 + θ0_1)·Tz(d_1)·Tx(a_1)·Rx(α_1): its origin is (a c, a s, d).
    let (s1, c1) = (Q[0] + r.params[0]).sin_cos();
    let (a1, d1) = (r.params[2], r.params[1]);
    assert!(max_abs_diff(&frames[28..31], &[a1 * c1, a1 * s1, d1]) < TOL);
    let s = unsafe {
        kincal_fk_frames(
            &r,
            Q.as_ptr(),
            6,
            null(),
            frames.as_mut_ptr(),
            16 * 6,
            &mut e,
        )
    };
    assert_eq!((s, e.expected), (kincal_status::BadLength, 128));
}

/// The Jacobian columns through the ABI match central differences of FK through the ABI with
/// each parameter moved by `kincal_robot_set_param`: checks the column order and layout.
#[test]
fn jacobian_matches_finite_differences() {
    let mut r = aria_robot(kincal_aria_model::VirtualTruth);
    let mut e = new_err();
    for (label, v) in [
        (c"compliance_2", 2e-3),
        (c"scale_3", 1e-3),
        (c"cyclic_cos2_4", 1e-3),
        (c"base_rz", 0.1),
        (c"tool_px", 0.05),
    ] {
        assert_eq!(
            unsafe { kincal_robot_set_param_by_label(&mut r, label.as_ptr(), v, &mut e) },
            kincal_status::Ok
        );
    }
    let p = kincal_num_params(6);
    let mut jac = vec![f64::NAN; 6 * p];
    let mut t = [0.0; 16];
    let s = unsafe {
        kincal_jacobian(
            &r,
            Q.as_ptr(),
            6,
            null(),
            jac.as_mut_ptr(),
            jac.len(),
            t.as_mut_ptr(),
            16,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(t, fk(&r, &Q));
    let h = 1e-6;
    for i in 0..p {
        if i == 12 * 6 + 12 || (11 * 6 + 12..12 * 6 + 12).contains(&i) {
            // thermal and backlash: no temperature / approach given, columns are zero.
            assert!(
                jac[6 * i..6 * i + 6].iter().all(|&v| v == 0.0),
                "column {i}"
            );
            continue;
        }
        let moved = |delta: f64| {
            let mut m = r;
            let v = r.params[i] + delta;
            assert_eq!(
                unsafe { kincal_robot_set_param(&mut m, i, v, null_mut()) },
                kincal_status::Ok
            );
            fk(&m, &Q)
        };
        let (tp, tm) = (moved(h), moved(-h));
        let mut err6 = [0.0; 6];
        let s = unsafe {
            kincal_pose_error(
                tp.as_ptr(),
                16,
                tm.as_ptr(),
                16,
                kincal_orientation_error::Exact as u32,
                err6.as_mut_ptr(),
                6,
                null_mut(),
            )
        };
        assert_eq!(s, kincal_status::Ok);
        let fd: Vec<f64> = err6.iter().map(|v| v / (2.0 * h)).collect();
        let diff = max_abs_diff(&fd, &jac[6 * i..6 * i + 6]);
        assert!(diff < 1e-6, "column {i}: {diff}");
    }
    // The geometric size gives the first 5N + 12 columns.
    let g = kincal_num_geometric_params(6);
    let mut jg = vec![0.0; 6 * g];
    let s = unsafe {
        kincal_jacobian(
            &r,
            Q.as_ptr(),
            6,
            null(),
            jg.as_mut_ptr(),
            jg.len(),
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(&jg[..], &jac[..6 * g]);
    let s = unsafe {
        kincal_jacobian(
            &r,
            Q.as_ptr(),
            6,
            null(),
            jg.as_mut_ptr(),
            6 * g - 1,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(
        (s, e.expected, arg_name(&e)),
        (kincal_status::BadLength, 6 * p, "jac_out")
    );
}

#[test]
fn gravity_torques_and_compensated_angles() {
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let mut tau = [0.0; 6];
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_gravity_torques(&r, Q.as_ptr(), 6, tau.as_mut_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(tau, aria::nominal().gravity_torques(&Q));
    // Joint 1 has a vertical axis: no gravity torque.
    assert!(tau[0].abs() < TOL);

    // Compliance on joint 2 shifts the compensated angle by c·τ_2 and changes FK.
    let c = 1e-3;
    assert_eq!(
        unsafe { kincal_robot_set_param_by_label(&mut r, c"compliance_2".as_ptr(), c, &mut e) },
        kincal_status::Ok
    );
    let mut active = 0;
    assert_eq!(
        unsafe { kincal_robot_active_effects(&r, &mut active, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(active, 1 << kincal_effect::JointCompliance as u32);
    let mut angles = [0.0; 6];
    assert_eq!(
        unsafe { kincal_joint_angles(&r, Q.as_ptr(), 6, null(), angles.as_mut_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    assert!((angles[1] - (Q[1] + c * tau[1])).abs() < TOL);
    assert_eq!(angles[0], Q[0]);
    let nominal = aria_robot(kincal_aria_model::Nominal);
    assert!(max_abs_diff(&fk(&r, &Q), &fk(&nominal, &Q)) > 1e-4);
    // FK of the compensated model = FK of the plain model at the compensated angles.
    assert!(max_abs_diff(&fk(&r, &Q), &fk(&nominal, &angles)) < TOL);

    assert_eq!(
        unsafe { kincal_robot_clear_effects(&mut r, KINCAL_EFFECTS_ALL, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(r, nominal);
}

#[test]
fn effects_needing_inputs() {
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_robot_set_param_by_label(&mut r, c"backlash_3".as_ptr(), 0.01, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(
        unsafe { kincal_robot_set_param_by_label(&mut r, c"thermal_kappa".as_ptr(), 1e-5, &mut e) },
        kincal_status::Ok
    );
    let mut t = [0.0; 16];
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, e.quantity),
        (
            kincal_status::MissingInput,
            kincal_quantity::ApproachDirection as u32
        )
    );
    let mut aux = kincal_joint_aux {
        has_approach: 1,
        has_temp: 0,
        approach: [
            1.0,
            -1.0,
            1.0,
            0.0,
            1.0,
            1.0,
            5.0,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
        ],
        temp_c: f64::NAN,
    };
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, &aux, t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, e.quantity),
        (
            kincal_status::MissingInput,
            kincal_quantity::Temperature as u32
        )
    );
    aux.has_temp = 1;
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, &aux, t.as_mut_ptr(), 16, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NonFinite, "aux->temp_c"));
    aux.temp_c = 30.0;
    assert_eq!(
        unsafe { kincal_fk(&r, Q.as_ptr(), 6, &aux, t.as_mut_ptr(), 16, &mut e) },
        kincal_status::Ok
    );
    let mut core = aria::nominal();
    core.set_param(ParamIndex(11 * 6 + 12 + 2), 0.01).unwrap();
    core.set_param(ParamIndex(12 * 6 + 12), 1e-5).unwrap();
    let state = JointState {
        q: Q,
        approach: Some([1.0, -1.0, 1.0, 0.0, 1.0, 1.0]),
        temp_c: Some(30.0),
    };
    assert_eq!(
        max_abs_diff(&t, &crate::pose::to_matrix(&core.fk(&state).unwrap())),
        0.0
    );
    aux.approach[2] = 0.5;
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, &aux, t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::InvalidArgument, "aux->approach", 2)
    );
}

#[test]
fn bad_joint_vectors_are_rejected_and_outputs_untouched() {
    let r = aria_robot(kincal_aria_model::Nominal);
    let mut t = [7.0; 16];
    let mut e = new_err();
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 5, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, arg_name(&e), e.expected, e.found),
        (kincal_status::BadLength, "q", 6, 5)
    );
    let mut q = Q;
    q[4] = f64::NAN;
    let s = unsafe { kincal_fk(&r, q.as_ptr(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::NonFinite, "q", 4)
    );
    let s = unsafe { kincal_fk(&r, null(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "q"));
    let s = unsafe { kincal_fk(null(), Q.as_ptr(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "robot"));
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, null(), t.as_mut_ptr(), 12, &mut e) };
    assert_eq!(
        (s, arg_name(&e), e.expected),
        (kincal_status::BadLength, "t_base_tool_out", 16)
    );
    let s = unsafe { kincal_fk(&r, Q.as_ptr(), 6, null(), null_mut(), 16, null_mut()) };
    assert_eq!(s, kincal_status::NullPointer, "err may be NULL");
    assert_eq!(t, [7.0; 16], "outputs untouched on failure");

    let mut limits_q = Q;
    limits_q[1] = 3.7;
    let s = unsafe { kincal_robot_check_limits(&r, limits_q.as_ptr(), 6, &mut e) };
    assert_eq!(
        (s, e.joint, e.value, e.upper),
        (kincal_status::OutOfLimits, 1, 3.7, 3.615)
    );
    assert_eq!(
        unsafe { kincal_robot_check_limits(&r, Q.as_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    assert_clear(&e);
}

#[test]
fn output_may_alias_input() {
    let mut pq = [0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 2.0];
    let mut t = [0.0; 16];
    assert_eq!(
        unsafe { kincal_pose_from_pq(pq.as_ptr(), 7, t.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    // pq in place: the output overwrites the input.
    let p = pq.as_mut_ptr();
    assert_eq!(
        unsafe { kincal_pose_to_pq(t.as_ptr(), 16, p, 7, null_mut()) },
        kincal_status::Ok
    );
    assert!(max_abs_diff(&pq, &[0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 1.0]) < TOL);
}

// ---------------------------------------------------------------- poses

#[test]
fn pose_error_both_forms() {
    let angle = 0.3;
    let (s, c) = f64::sin_cos(angle);
    // measured = model rotated by 0.3 rad about z and moved by (1, 2, 3) mm.
    let model = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.0, 0.2, 1.0,
    ];
    let measured = [
        c, s, 0.0, 0.0, -s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.501, 0.002, 0.203, 1.0,
    ];
    let mut err6 = [0.0; 6];
    let run = |form: kincal_orientation_error, out: &mut [f64; 6]| unsafe {
        kincal_pose_error(
            measured.as_ptr(),
            16,
            model.as_ptr(),
            16,
            form as u32,
            out.as_mut_ptr(),
            6,
            null_mut(),
        )
    };
    assert_eq!(
        run(kincal_orientation_error::Exact, &mut err6),
        kincal_status::Ok
    );
    assert!(max_abs_diff(&err6, &[0.001, 0.002, 0.003, 0.0, 0.0, angle]) < TOL);
    // Eq. (16) gives sin(angle) about z.
    assert_eq!(
        run(kincal_orientation_error::SmallAngle, &mut err6),
        kincal_status::Ok
    );
    assert!(max_abs_diff(&err6, &[0.001, 0.002, 0.003, 0.0, 0.0, s]) < TOL);

    let mut mpq = [0.0; 7];
    let mut opq = [0.0; 7];
    assert_eq!(
        unsafe { kincal_pose_to_pq(measured.as_ptr(), 16, mpq.as_mut_ptr(), 7, null_mut()) },
        kincal_status::Ok
    );
    assert_eq!(
        unsafe { kincal_pose_to_pq(model.as_ptr(), 16, opq.as_mut_ptr(), 7, null_mut()) },
        kincal_status::Ok
    );
    let mut err_pq = [0.0; 6];
    let st = unsafe {
        kincal_pose_error_pq(
            mpq.as_ptr(),
            7,
            opq.as_ptr(),
            7,
            kincal_orientation_error::Exact as u32,
            err_pq.as_mut_ptr(),
            6,
            null_mut(),
        )
    };
    assert_eq!(st, kincal_status::Ok);
    assert!(max_abs_diff(&err_pq, &[0.001, 0.002, 0.003, 0.0, 0.0, angle]) < TOL);

    let mut e = new_err();
    let st = unsafe {
        kincal_pose_error(
            measured.as_ptr(),
            16,
            model.as_ptr(),
            16,
            2,
            err6.as_mut_ptr(),
            6,
            &mut e,
        )
    };
    assert_eq!((st, arg_name(&e)), (kincal_status::InvalidArgument, "form"));
    let mut skewed = model;
    skewed[0] = 1.001;
    let st = unsafe {
        kincal_pose_error(
            measured.as_ptr(),
            16,
            skewed.as_ptr(),
            16,
            0,
            err6.as_mut_ptr(),
            6,
            &mut e,
        )
    };
    assert_eq!(
        (st, arg_name(&e)),
        (kincal_status::InvalidTransform, "model")
    );
    let mut mirrored = model;
    mirrored[10] = -1.0;
    let st = unsafe {
        kincal_pose_error(
            mirrored.as_ptr(),
            16,
            model.as_ptr(),
            16,
            0,
            err6.as_mut_ptr(),
            6,
            &mut e,
        )
    };
    assert_eq!(
        (st, arg_name(&e)),
        (kincal_status::InvalidTransform, "measured")
    );
    let mut projective = model;
    projective[3] = 0.1;
    let st = unsafe {
        kincal_pose_error(
            projective.as_ptr(),
            16,
            model.as_ptr(),
            16,
            0,
            err6.as_mut_ptr(),
            6,
            &mut e,
        )
    };
    assert_eq!(st, kincal_status::InvalidTransform);
    let zero_q = [0.0; 7];
    let st = unsafe {
        kincal_pose_error_pq(
            zero_q.as_ptr(),
            7,
            opq.as_ptr(),
            7,
            0,
            err6.as_mut_ptr(),
            6,
            &mut e,
        )
    };
    assert_eq!(
        (st, arg_name(&e)),
        (kincal_status::InvalidParameter, "measured")
    );
}

#[test]
fn xyz_rpy_round_trip() {
    let v = [0.566, 0.354, 0.235, (-150.0f64).to_radians(), 0.1, -0.2];
    let mut t = [0.0; 16];
    assert_eq!(
        unsafe { kincal_pose_from_xyz_rpy(v.as_ptr(), 6, t.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    let mut back = [0.0; 6];
    assert_eq!(
        unsafe { kincal_pose_to_xyz_rpy(t.as_ptr(), 16, back.as_mut_ptr(), 6, null_mut()) },
        kincal_status::Ok
    );
    assert!(max_abs_diff(&v, &back) < TOL);
    // Table 2 pose 1 equals the same numbers through the ARIA export.
    let mut tool = [0.0; 16];
    assert_eq!(
        unsafe { kincal_aria_tool_pose(0, tool.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    let p1 = [0.566, 0.354, 0.235, (-150.0f64).to_radians(), 0.0, 0.0];
    assert_eq!(
        unsafe { kincal_pose_from_xyz_rpy(p1.as_ptr(), 6, t.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    assert!(max_abs_diff(&t, &tool) < TOL);
    let mut e = new_err();
    let s = unsafe { kincal_aria_tool_pose(10, tool.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, e.index, e.expected),
        (kincal_status::IndexOutOfRange, 10, 10)
    );
}

// ---------------------------------------------------------------- inverse kinematics

#[test]
fn ik_reaches_every_tool_pose() {
    let r = aria_robot(kincal_aria_model::VirtualTruth);
    let mut seed = [0.0; 6];
    assert_eq!(
        unsafe { kincal_aria_tool_seed(seed.as_mut_ptr(), 6, null_mut()) },
        kincal_status::Ok
    );
    let mut opts = kincal_ik_options {
        max_iterations: 0,
        first_solution: 9,
        extra_seeds: 0,
        tol_pos_m: 0.0,
        tol_rot_rad: 0.0,
    };
    assert_eq!(
        unsafe { kincal_ik_options_default(&mut opts, null_mut()) },
        kincal_status::Ok
    );
    assert_eq!(opts, kincal_ik_options::from(IkOptions::default()));
    let mut presets = opts;
    assert_eq!(
        unsafe { kincal_ik_options_control_loop(&mut presets, null_mut()) },
        kincal_status::Ok
    );
    assert_eq!(presets, kincal_ik_options::from(IkOptions::control_loop()));
    assert_eq!(
        unsafe { kincal_ik_options_global_search(&mut presets, null_mut()) },
        kincal_status::Ok
    );
    assert_eq!(presets, kincal_ik_options::from(IkOptions::global_search()));
    assert_eq!(
        unsafe { kincal_ik_options_control_loop(null_mut(), null_mut()) },
        kincal_status::NullPointer
    );
    for l in 0..KINCAL_ARIA_NUM_TOOL_POSES {
        let mut target = [0.0; 16];
        assert_eq!(
            unsafe { kincal_aria_tool_pose(l, target.as_mut_ptr(), 16, null_mut()) },
            kincal_status::Ok
        );
        let mut q = [0.0; 6];
        let mut info = kincal_ik_info {
            residual_pos_m: -1.0,
            residual_rot_rad: -1.0,
            iterations: 0,
            seed_index: 99,
        };
        let mut e = new_err();
        let s = unsafe {
            kincal_ik(
                &r,
                target.as_ptr(),
                16,
                seed.as_ptr(),
                6,
                null(),
                &opts,
                q.as_mut_ptr(),
                6,
                &mut info,
                &mut e,
            )
        };
        assert_eq!(s, kincal_status::Ok, "pose {l}: {e:?}");
        assert!(info.residual_pos_m < 1e-9 && info.residual_rot_rad < 1e-9);
        assert!(max_abs_diff(&fk(&r, &q), &target) < 1e-9, "pose {l}");
        assert_eq!(
            unsafe { kincal_robot_check_limits(&r, q.as_ptr(), 6, null_mut()) },
            kincal_status::Ok
        );
        // Same answer as the core called directly.
        let core = aria::virtual_truth();
        let sol = solve_ik(
            &core,
            &aria::tool_pose(l).unwrap(),
            &JointState::new(aria::TOOL_SEED_Q),
            &IkOptions::default(),
        )
        .unwrap();
        assert_eq!(q, sol.q);
    }
}

#[test]
fn ik_errors() {
    let r = aria_robot(kincal_aria_model::Nominal);
    let seed = aria::TOOL_SEED_Q;
    let mut far = [0.0; 16];
    assert_eq!(
        unsafe { kincal_aria_tool_pose(0, far.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    far[12] = 5.0;
    let mut q = [0.0; 6];
    let mut e = new_err();
    let mut opts = kincal_ik_options::from(IkOptions::default());
    opts.extra_seeds = 2;
    opts.max_iterations = 50;
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Unreachable);
    assert!(
        e.residual_pos_m > 3.0 && e.residual_pos_m.is_finite(),
        "{e:?}"
    );
    assert_eq!(q, [0.0; 6], "output untouched");
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            seed.as_ptr(),
            5,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "q_seed"));
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            15,
            seed.as_ptr(),
            6,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "target"));
    opts.tol_pos_m = 0.0;
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(
        (s, arg_name(&e)),
        (kincal_status::InvalidArgument, "opts->tol_pos_m")
    );
    opts.tol_pos_m = f64::NAN;
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            &opts,
            q.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(
        (s, arg_name(&e)),
        (kincal_status::NonFinite, "opts->tol_pos_m")
    );
    let s = unsafe {
        kincal_ik(
            &r,
            far.as_ptr(),
            16,
            seed.as_ptr(),
            6,
            null(),
            null(),
            q.as_mut_ptr(),
            3,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "q_out"));
}

// ---------------------------------------------------------------- panic boundary

#[test]
fn panic_boundary_returns_panic_status() {
    fn panicking(err: *mut kincal_error) -> kincal_status {
        ffi_boundary!(err = err; {
            let v: Vec<u32> = Vec::new();
            let _ = v[core::hint::black_box(3)];
            Ok(())
        })
    }
    let mut e = new_err();
    assert_eq!(panicking(&mut e), kincal_status::Panic);
    assert_eq!(e.status, 999);
    assert_eq!(panicking(null_mut()), kincal_status::Panic);
    fn panicking_value() -> usize {
        ffi_boundary!(on_panic = 42; {
            if core::hint::black_box(true) {
                panic!("on purpose");
            }
            0
        })
    }
    assert_eq!(panicking_value(), 42);
}

#[cfg(feature = "test-panic")]
#[test]
fn test_panic_export_is_caught() {
    let mut e = new_err();
    assert_eq!(
        unsafe { crate::panic::kincal_test_panic(&mut e) },
        kincal_status::Panic
    );
    assert_eq!(e.status, kincal_status::Panic as u32);
}

// ---------------------------------------------------------------- misc

#[test]
fn counts_and_effect_names() {
    assert_eq!(kincal_num_params(6), 85);
    assert_eq!(kincal_num_geometric_params(6), 42);
    assert_eq!((kincal_num_params(0), kincal_num_params(13)), (0, 0));
    for (e, name) in [
        (kincal_effect::BaseFrame, "base_frame"),
        (kincal_effect::ToolFrame, "tool_frame"),
        (kincal_effect::JointCompliance, "joint_compliance"),
        (kincal_effect::JointScale, "joint_scale"),
        (kincal_effect::JointCyclic, "joint_cyclic"),
        (kincal_effect::Backlash, "backlash"),
        (kincal_effect::Thermal, "thermal"),
    ] {
        let p = kincal_effect_name(e as u32);
        assert_eq!(unsafe { CStr::from_ptr(p) }.to_str().unwrap(), name);
        let mut back = 99;
        assert_eq!(
            unsafe { kincal_effect_from_name(p, &mut back, null_mut()) },
            kincal_status::Ok
        );
        assert_eq!(back, e as u32);
    }
    assert!(kincal_effect_name(7).is_null());
    let mut e = new_err();
    assert_eq!(
        unsafe { kincal_effect_from_name(c"gravity".as_ptr(), &mut 0, &mut e) },
        kincal_status::UnknownLabel
    );
}

/// Literal results shared with tests/cpp/consumer.cpp (keep the two tables identical): the
/// C++ consumer checks that the C ABI gives these numbers, this test that they are what the
/// library computes; a change of either side shows up as a failure, not as a silent copy.
mod shared_with_cpp {
    /// Nominal ARIA at `Q`: `[px, py, pz, qw, qx, qy, qz]`.
    pub const FK_PQ_NOMINAL: [f64; 7] = [
        0.7141755095975209,
        0.35561149467273084,
        0.6386459078672299,
        0.6930479765324871,
        -0.604655159428662,
        0.3671248824646843,
        -0.13890990272769088,
    ];
    /// Table 3 virtual truth at `Q`.
    pub const FK_PQ_TRUTH: [f64; 7] = [
        0.744165633329287,
        0.34655010957859805,
        0.5634775604690159,
        0.48366787176089576,
        -0.7423793201311939,
        0.2777715990346434,
        -0.37118899988761694,
    ];
    /// Gravity torques of the nominal ARIA at `Q` [N·m].
    pub const TAU_NOMINAL: [f64; 6] = [
        0.0,
        -22.42315448575973,
        -6.734168502227332,
        -0.6950360241046818,
        -0.5196913966683572,
        0.0,
    ];
    /// IK of Table 2 pose 1 on the virtual truth from the ARIA tool seed.
    pub const IK_Q_TRUTH_POSE1: [f64; 6] = [
        0.43454034295052607,
        0.7930473894128408,
        -1.0650469975285652,
        4.382635158022495,
        1.079216589289747,
        -2.813354506099495,
    ];
}

#[test]
fn values_shared_with_cpp() {
    use shared_with_cpp::*;
    for (model, expected) in [
        (kincal_aria_model::Nominal, FK_PQ_NOMINAL),
        (kincal_aria_model::VirtualTruth, FK_PQ_TRUTH),
    ] {
        let r = aria_robot(model);
        let mut pq = [0.0; 7];
        let s = unsafe { kincal_fk_pq(&r, Q.as_ptr(), 6, null(), pq.as_mut_ptr(), 7, null_mut()) };
        assert_eq!(s, kincal_status::Ok);
        assert!(max_abs_diff(&pq, &expected) < TOL, "{model:?}: {pq:?}");
    }
    let r = aria_robot(kincal_aria_model::Nominal);
    let mut tau = [0.0; 6];
    let s = unsafe { kincal_gravity_torques(&r, Q.as_ptr(), 6, tau.as_mut_ptr(), 6, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    assert!(max_abs_diff(&tau, &TAU_NOMINAL) < 1e-10, "{tau:?}");
    let t = aria_robot(kincal_aria_model::VirtualTruth);
    let mut target = [0.0; 16];
    let mut q = [0.0; 6];
    let s = unsafe {
        kincal_aria_tool_pose(0, target.as_mut_ptr(), 16, null_mut());
        kincal_ik(
            &t,
            target.as_ptr(),
            16,
            aria::TOOL_SEED_Q.as_ptr(),
            6,
            null(),
            null(),
            q.as_mut_ptr(),
            6,
            null_mut(),
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);
    assert!(max_abs_diff(&q, &IK_Q_TRUTH_POSE1) < 1e-9, "{q:?}");
}

/// ARIA described by its joint axes at q = 0 (taken from the nominal model's frames) gives a
/// model with the same FK.
#[test]
fn robot_from_axes_matches_the_chain() {
    let nominal = aria_robot(kincal_aria_model::Nominal);
    let zero = [0.0; 6];
    let mut frames = [0.0; 16 * 8];
    assert_eq!(
        unsafe {
            kincal_fk_frames(
                &nominal,
                zero.as_ptr(),
                6,
                null(),
                frames.as_mut_ptr(),
                128,
                null_mut(),
            )
        },
        kincal_status::Ok
    );
    // Joint i's axis is the z axis of frame i-1.
    let (mut points, mut dirs) = (Vec::new(), Vec::new());
    for i in 0..6 {
        let f = &frames[16 * i..16 * i + 16];
        points.extend_from_slice(&f[12..15]);
        dirs.extend_from_slice(&f[8..11]);
    }
    let tool = &frames[16 * 7..];
    let limits: Vec<f64> = aria::JOINT_LIMITS
        .iter()
        .flat_map(|l| [l.lower, l.upper])
        .collect();
    let mut r = kincal_robot::ZERO;
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_robot_from_axes(
            &mut r,
            6,
            points.as_ptr(),
            18,
            dirs.as_ptr(),
            18,
            null(),
            0,
            tool.as_ptr(),
            16,
            limits.as_ptr(),
            12,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    assert_eq!(r.length_param[1], kincal_length_param::Beta as u32);
    for k in 0..5 {
        let q: Vec<f64> = (0..6).map(|j| ((k * 6 + j) as f64 * 0.9).sin()).collect();
        assert!(max_abs_diff(&fk(&r, &q), &fk(&nominal, &q)) < 1e-12);
    }
    dirs[3..6].copy_from_slice(&[0.0, 0.0, 0.0]);
    let s = unsafe {
        kincal_robot_from_axes(
            &mut r,
            6,
            points.as_ptr(),
            18,
            dirs.as_ptr(),
            18,
            null(),
            0,
            null(),
            0,
            limits.as_ptr(),
            12,
            &mut e,
        )
    };
    assert_eq!(
        (s, e.joint, arg_name(&e)),
        (kincal_status::DegenerateAxis, 1, "directions")
    );
}
