//! Where camera poses look (`kincal_view_point`) and a pose moved to a point
//! (`kincal_moved_to_point`): the core's results bit for bit, and every argument error.

use core::ffi::CStr;
use core::ptr::{null, null_mut};

use kincal::pose::{Transform, rotation_exp, transform};
use kincal::view_point::{Axis, moved_to_point, view_point};
use nalgebra::{Matrix3, Vector3};

use crate::pose::to_matrix;
use crate::status::*;
use crate::view_point::*;

/// A camera at `eye` looking (z) at `target`, rolled by `roll` about its axis.
fn look_at(eye: [f64; 3], target: [f64; 3], roll: f64) -> Transform {
    let e = Vector3::from(eye);
    let z = (Vector3::from(target) - e).normalize();
    let helper = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let x = helper.cross(&z).normalize();
    let y = z.cross(&x);
    let r = Matrix3::from_columns(&[x, y, z]) * rotation_exp(&(Vector3::z() * roll));
    transform(r, e)
}

const TARGET: [f64; 3] = [1.2, -0.3, 0.4];
const EYES: [[f64; 3]; 5] = [
    [1.0, 0.0, 0.8],
    [1.6, -0.2, 0.7],
    [1.1, -0.7, 0.9],
    [1.3, 0.1, 0.95],
    [0.8, -0.4, 0.85],
];

/// Five cameras looking at `TARGET`, the last one's axis offset by 3 mm sideways.
fn cameras() -> Vec<Transform> {
    let mut poses: Vec<Transform> = EYES
        .iter()
        .enumerate()
        .map(|(i, &e)| look_at(e, TARGET, 0.3 * i as f64))
        .collect();
    let x = poses[4].rotation * Vector3::x();
    poses[4].translation.vector += x * 3e-3;
    poses
}

fn stack(poses: &[Transform]) -> Vec<f64> {
    poses.iter().flat_map(to_matrix).collect()
}

fn call(
    poses: &[f64],
    n: usize,
    axis: u32,
) -> (kincal_status, kincal_view_point_result, kincal_error) {
    let mut v = kincal_view_point_result {
        point_m: [f64::NAN; 3],
        mean_distance_m: f64::NAN,
        min_distance_m: f64::NAN,
        max_distance_m: f64::NAN,
        miss_rms_m: f64::NAN,
        miss_max_m: f64::NAN,
        miss_max_pose: 77,
    };
    let mut e = kincal_error::CLEAR;
    e.status = 12345;
    let ptr = if poses.is_empty() {
        null()
    } else {
        poses.as_ptr()
    };
    let s = unsafe { kincal_view_point(ptr, poses.len(), n, axis, &mut v, &mut e) };
    (s, v, e)
}

fn arg_name(e: &kincal_error) -> &'static str {
    assert!(!e.argument.is_null(), "no argument named in {e:?}");
    unsafe { CStr::from_ptr(e.argument) }.to_str().unwrap()
}

#[test]
fn view_point_equals_the_core_bit_for_bit() {
    let poses = cameras();
    let m = stack(&poses);
    // The core's result from the matrices as the ABI reads them (a round trip through 16
    // doubles is exact for the translation, and the rotation is taken as given).
    let parsed: Vec<Transform> = m
        .chunks(16)
        .map(|c| crate::pose::from_matrix(c, c"poses").unwrap())
        .collect();
    for (axis, core_axis) in [
        (kincal_axis::X, Axis::X),
        (kincal_axis::Y, Axis::Y),
        (kincal_axis::Z, Axis::Z),
    ] {
        let (s, v, e) = call(&m, 5, axis as u32);
        assert_eq!(s, kincal_status::Ok, "{e:?}");
        assert_eq!(e.status, 0);
        let c = view_point(&parsed, core_axis).unwrap();
        assert_eq!(v.point_m.map(f64::to_bits), c.point_m.map(f64::to_bits));
        for (a, b) in [
            (v.mean_distance_m, c.mean_distance_m),
            (v.min_distance_m, c.min_distance_m),
            (v.max_distance_m, c.max_distance_m),
            (v.miss_rms_m, c.miss_rms_m),
            (v.miss_max_m, c.miss_max_m),
        ] {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        assert_eq!(v.miss_max_pose, c.miss_max_pose);
    }
    // The z axes converge near the target; the offset camera misses most.
    let (_, v, _) = call(&m, 5, kincal_axis::Z as u32);
    assert_eq!(v.miss_max_pose, 4);
    assert!(v.miss_max_m > 1e-3 && v.miss_max_m < 3e-3, "{v:?}");
    for (p, t) in v.point_m.iter().zip(TARGET) {
        assert!((p - t).abs() < 2e-3, "{v:?}");
    }
    // Exact convergence without the offset camera.
    let (s, v, _) = call(&m[..64], 4, kincal_axis::Z as u32);
    assert_eq!(s, kincal_status::Ok);
    for (p, t) in v.point_m.iter().zip(TARGET) {
        assert!((p - t).abs() < 1e-12, "{v:?}");
    }
    assert!(v.miss_max_m < 1e-12);
}

#[test]
fn moved_to_point_equals_the_core_bit_for_bit() {
    let poses = cameras();
    for t in &poses[..4] {
        let d = (t.translation.vector - Vector3::from(TARGET)).norm();
        let m = to_matrix(t);
        let point = [0.0, 0.0, d];
        let mut out = [0.0; 16];
        let mut e = kincal_error::CLEAR;
        let s = unsafe {
            kincal_moved_to_point(
                m.as_ptr(),
                16,
                point.as_ptr(),
                3,
                out.as_mut_ptr(),
                16,
                &mut e,
            )
        };
        assert_eq!(s, kincal_status::Ok, "{e:?}");
        let parsed = crate::pose::from_matrix(&m, c"t").unwrap();
        let c = to_matrix(&moved_to_point(&parsed, &point));
        assert_eq!(out.map(f64::to_bits), c.map(f64::to_bits));
        for k in 0..3 {
            assert!((out[12 + k] - TARGET[k]).abs() < 1e-12);
        }
        assert_eq!(out[..12], m[..12]);
    }
    // In place: the output may overlap the input.
    let mut m = to_matrix(&poses[0]);
    let expected = to_matrix(&moved_to_point(&poses[0], &[0.1, 0.2, 0.3]));
    let point = [0.1, 0.2, 0.3];
    let p = m.as_mut_ptr();
    let s = unsafe { kincal_moved_to_point(p, 16, point.as_ptr(), 3, p, 16, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    let d = m
        .iter()
        .zip(expected)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(d < 1e-15);
}

#[test]
fn view_point_errors() {
    let poses = cameras();
    let m = stack(&poses);
    // NULL poses, NULL output.
    let (s, _, e) = call(&[], 5, 2);
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "poses"));
    let mut e = kincal_error::CLEAR;
    let s = unsafe { kincal_view_point(m.as_ptr(), 80, 5, 2, null_mut(), &mut e) };
    assert_eq!(
        (s, arg_name(&e)),
        (kincal_status::NullPointer, "view_point_out")
    );
    // Bad lengths and counts.
    let (s, _, e) = call(&m[..79], 5, 2);
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "poses"));
    assert_eq!((e.expected, e.found), (80, 79));
    let (s, _, e) = call(&m[..16], 1, 2);
    assert_eq!((s, arg_name(&e)), (kincal_status::TooFewData, "n_poses"));
    assert_eq!((e.expected, e.found), (2, 1));
    let (s, _, e) = call(&m, usize::MAX, 2);
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "poses"));
    // Axis out of its domain.
    let (s, _, e) = call(&m, 5, 3);
    assert_eq!(
        (s, arg_name(&e), e.value),
        (kincal_status::InvalidArgument, "axis", 3.0)
    );
    // A non-finite value in pose 3: the pose and the element within `poses`.
    let mut bad = m.clone();
    bad[16 * 3 + 13] = f64::NAN;
    let (s, _, e) = call(&bad, 5, 2);
    assert_eq!((s, arg_name(&e)), (kincal_status::NonFinite, "poses"));
    assert_eq!((e.pose, e.index), (3, 16 * 3 + 13));
    // A non-rigid matrix in pose 2 (scaled rotation) and a bad bottom row in pose 4.
    let mut bad = m.clone();
    bad[16 * 2] *= 1.01;
    let (s, _, e) = call(&bad, 5, 2);
    assert_eq!(
        (s, arg_name(&e), e.pose),
        (kincal_status::InvalidTransform, "poses", 2)
    );
    let mut bad = m.clone();
    bad[16 * 4 + 3] = 0.5;
    let (s, _, e) = call(&bad, 5, 2);
    assert_eq!((s, e.pose), (kincal_status::InvalidTransform, 4));
    // Parallel axes: no point is determined.
    let par = stack(&[
        look_at([0.0, 0.0, 1.0], [0.0; 3], 0.0),
        look_at([0.1, 0.0, 1.0], [0.1, 0.0, 0.0], 0.2),
        look_at([0.0, 0.3, 1.0], [0.0, 0.3, 0.0], 0.4),
    ]);
    let (s, v, e) = call(&par, 3, 2);
    assert_eq!(s, kincal_status::RankDeficient, "{e:?}");
    assert_eq!(e.expected, 3);
    assert!(e.found < 3);
    // Written on success only.
    assert_eq!(v.miss_max_pose, 77);
}

#[test]
fn moved_to_point_errors() {
    let t = to_matrix(&cameras()[0]);
    let point = [0.0, 0.0, 0.5];
    let mut out = [0.0; 16];
    let mut e = kincal_error::CLEAR;
    let run = |t: *const f64, tl, p: *const f64, pl, o: *mut f64, ol, e: &mut kincal_error| unsafe {
        kincal_moved_to_point(t, tl, p, pl, o, ol, e)
    };
    let o = out.as_mut_ptr();
    let s = run(null(), 16, point.as_ptr(), 3, o, 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "t"));
    let s = run(t.as_ptr(), 16, null(), 3, o, 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "point"));
    let s = run(t.as_ptr(), 16, point.as_ptr(), 3, null_mut(), 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::NullPointer, "t_out"));
    let s = run(t.as_ptr(), 15, point.as_ptr(), 3, o, 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "t"));
    let s = run(t.as_ptr(), 16, point.as_ptr(), 2, o, 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "point"));
    let s = run(t.as_ptr(), 16, point.as_ptr(), 3, o, 12, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::BadLength, "t_out"));
    let nan_point = [0.0, f64::INFINITY, 0.0];
    let s = run(t.as_ptr(), 16, nan_point.as_ptr(), 3, o, 16, &mut e);
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::NonFinite, "point", 1)
    );
    let mut bad = t;
    bad[5] = 2.0;
    let s = run(bad.as_ptr(), 16, point.as_ptr(), 3, o, 16, &mut e);
    assert_eq!((s, arg_name(&e)), (kincal_status::InvalidTransform, "t"));
    bad = t;
    bad[14] = f64::NAN;
    let s = run(bad.as_ptr(), 16, point.as_ptr(), 3, o, 16, &mut e);
    assert_eq!(
        (s, arg_name(&e), e.index),
        (kincal_status::NonFinite, "t", 14)
    );
    assert_eq!(out, [0.0; 16], "written on success only");
}
