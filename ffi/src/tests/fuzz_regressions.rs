//! Inputs `fuzz/fuzz_targets/c_abi.rs` found returning OK with NaN outputs: finite but
//! absurd parameters (every one 8.7e245, or -9e307) overflowed inside FK and the gravity
//! torques. Both now return `KINCAL_STATUS_NON_FINITE`.

use core::ptr::null_mut;

use crate::aria::*;
use crate::kinematics::*;
use crate::params::*;
use crate::robot::*;
use crate::status::*;

fn absurd_aria(value: f64) -> kincal_robot {
    let mut r = core::mem::MaybeUninit::<kincal_robot>::uninit();
    let s = unsafe { kincal_robot_aria(r.as_mut_ptr(), 0, null_mut()) };
    assert_eq!(s, kincal_status::Ok);
    let mut r = unsafe { r.assume_init() };
    // Geometry (links, base, tool) absurd; effects off, so no auxiliary input is needed.
    let mut p = vec![0.0; 12 * 6 + 13];
    p[..5 * 6 + 12].fill(value);
    let s = unsafe { kincal_robot_set_params(&mut r, p.as_ptr(), p.len(), null_mut()) };
    assert_eq!(s, kincal_status::Ok, "finite parameters are accepted");
    r
}

#[test]
fn fk_of_absurd_parameters_is_a_non_finite_error() {
    let q = [0.0; 6];
    for value in [8.739899877464282e245, -8.988328521209859e307] {
        let r = absurd_aria(value);
        let mut t = [0.0; 16];
        let s = unsafe {
            kincal_fk(
                &r,
                q.as_ptr(),
                6,
                core::ptr::null(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        };
        assert_eq!(s, kincal_status::NonFinite, "fk with {value}");
    }
}

/// Gravity torques use the description's (nominal) geometry: absurd links given to
/// `kincal_robot_init` overflowed them.
#[test]
fn gravity_of_an_absurd_description_is_a_non_finite_error() {
    let links = [-8.988328521209859e307; 10];
    let limits = [-1.0, 1.0, -1.0, 1.0];
    let mut r = core::mem::MaybeUninit::<kincal_robot>::uninit();
    let s = unsafe {
        kincal_robot_init(
            r.as_mut_ptr(),
            2,
            links.as_ptr(),
            10,
            limits.as_ptr(),
            4,
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok, "finite links are accepted");
    let r = unsafe { r.assume_init() };
    let q = [0.0; 2];
    let mut tau = [0.0; 2];
    let s = unsafe { kincal_gravity_torques(&r, q.as_ptr(), 2, tau.as_mut_ptr(), 2, null_mut()) };
    assert_eq!(s, kincal_status::NonFinite);
}
