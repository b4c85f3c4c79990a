//! `matrix_to_rpy` must reproduce the matrix to rounding, also near gimbal lock (URDF
//! export writes every joint origin through it).

use kincal::pose::{matrix_to_rpy, rpy_to_matrix};

/// Matrix agreement after a round trip [1].
const TOL: f64 = 5e-15;

#[test]
fn rpy_round_trip_near_and_at_gimbal_lock() {
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut worst: f64 = 0.0;
    for &dp in &[0.0, 1e-16, 1e-15, 1e-14, 1e-13, 1e-11, 3.7e-6, 1e-3, 0.5] {
        for &sign in &[1.0, -1.0] {
            for &(roll, yaw) in &[(0.3, -2.0), (-3.0, 1.0), (1.57, 3.1), (0.0, 0.0)] {
                let pitch = sign * (half_pi - dp);
                let r = rpy_to_matrix(roll, pitch, yaw);
                let a = matrix_to_rpy(&r);
                assert!(a[1].abs() <= half_pi, "pitch out of range: {a:?}");
                let back = rpy_to_matrix(a[0], a[1], a[2]);
                worst = worst.max((back - r).amax());
            }
        }
    }
    assert!(worst < TOL, "round trip error {worst:e}");
}
