//! The prepared-model handle: results bit-identical to the plain exports (ARIA, a 7-joint and
//! a 9-joint arm with every effect), and misuse (NULL, misaligned, uninitialised, corrupted
//! storage) returning a status.

use core::ffi::CStr;
use core::ptr::{null, null_mut};

use crate::aria::*;
use crate::ik::*;
use crate::kinematics::*;
use crate::params::*;
use crate::prepared::*;
use crate::robot::*;
use crate::status::*;

fn aria_robot(model: kincal_aria_model) -> kincal_robot {
    let mut r = kincal_robot::ZERO;
    assert_eq!(
        unsafe { kincal_robot_aria(&mut r, model as u32, null_mut()) },
        kincal_status::Ok
    );
    r
}

fn empty() -> Box<kincal_prepared> {
    Box::new(kincal_prepared {
        opaque: [0; KINCAL_PREPARED_WORDS],
    })
}

fn prepare(r: &kincal_robot) -> Box<kincal_prepared> {
    let mut p = empty();
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_prepare(r, &mut *p, &mut e) },
        kincal_status::Ok,
        "{e:?}"
    );
    assert_eq!(e.status, 0);
    p
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// A 7-joint arm (KUKA iiwa-like table), its geometry perturbed as by a calibration, with base,
/// tool, masses and every effect set.
fn seven_joint_arm() -> kincal_robot {
    use core::f64::consts::FRAC_PI_2 as H;
    let links = [
        0.0, 0.36, 0.0, -H, 0.0, //
        0.0, 0.0, 0.0, H, 0.0, //
        0.0, 0.42, 0.0, H, 0.0, //
        0.0, 0.0, 0.0, -H, 0.0, //
        0.0, 0.40, 0.0, -H, 0.0, //
        0.0, 0.0, 0.0, H, 0.0, //
        0.0, 0.126, 0.0, 0.0, 0.0,
    ];
    arm_with_every_effect(&links, &[4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3])
}

/// A 9-joint arm: a two-joint torso before the 7-joint arm, set up
/// like [`seven_joint_arm`].
fn nine_joint_arm() -> kincal_robot {
    use core::f64::consts::FRAC_PI_2 as H;
    let links = [
        0.0, 0.07, 0.0, 0.0, 0.0, //
        0.0, 0.0, 0.0, -H, 0.0, //
        0.15, 0.36, 0.0, H, 0.0, //
        0.0, 0.0, 0.0, H, 0.0, //
        0.0, 0.42, 0.0, H, 0.0, //
        0.0, 0.0, 0.0, -H, 0.0, //
        0.0, 0.40, 0.0, -H, 0.0, //
        0.0, 0.0, 0.0, H, 0.0, //
        0.0, 0.126, 0.0, 0.0, 0.0,
    ];
    assert_eq!(links.len(), 5 * 9);
    arm_with_every_effect(&links, &[2.3, 17.0, 4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3])
}

/// An arm of `masses.len()` joints from its link table, its geometry perturbed as by a
/// calibration, with base, tool, masses and every effect set.
fn arm_with_every_effect(links: &[f64], masses: &[f64]) -> kincal_robot {
    let n = masses.len();
    assert_eq!(links.len(), 5 * n);
    let mut limits = vec![0.0; 2 * n];
    for (j, l) in limits.chunks_exact_mut(2).enumerate() {
        let m = if j % 2 == 0 { 2.96 } else { 2.09 };
        l.copy_from_slice(&[-m, m]);
    }
    let mut r = kincal_robot::ZERO;
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_robot_init(
            &mut r,
            n,
            links.as_ptr(),
            links.len(),
            limits.as_ptr(),
            limits.len(),
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::Ok, "{e:?}");
    let base = [0.1, -0.05, 0.02, 0.01, -0.02, 0.3];
    let tool = [0.0, 0.01, 0.15, 0.05, 0.0, -0.1];
    assert_eq!(
        unsafe { crate::robot::kincal_robot_set_base(&mut r, base.as_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    assert_eq!(
        unsafe { crate::robot::kincal_robot_set_tool(&mut r, tool.as_ptr(), 6, &mut e) },
        kincal_status::Ok
    );
    let g = [0.0, 0.0, -9.81];
    assert_eq!(
        unsafe { kincal_robot_set_mass(&mut r, masses.as_ptr(), n, 1.2, g.as_ptr(), 3, &mut e) },
        kincal_status::Ok
    );
    let np = kincal_num_params(n);
    let mut p = vec![0.0; np];
    assert_eq!(
        unsafe { kincal_robot_get_params(&r, p.as_mut_ptr(), np, &mut e) },
        kincal_status::Ok
    );
    // Calibrated geometry: every link parameter off its nominal value.
    for (i, v) in p.iter_mut().take(5 * n).enumerate() {
        *v += 1e-4 * ((i % 7) as f64 - 3.0);
    }
    // Effects: compliance, scale, cyclic, backlash (N each, cyclic 4·N), thermal κ.
    for (i, v) in p.iter_mut().skip(5 * n + 12).enumerate() {
        *v = 1e-5 * (1.0 + (i % 5) as f64);
    }
    assert_eq!(
        unsafe { kincal_robot_set_params(&mut r, p.as_ptr(), np, &mut e) },
        kincal_status::Ok,
        "{e:?}"
    );
    r
}

fn aux7() -> kincal_joint_aux {
    kincal_joint_aux {
        has_approach: 1,
        has_temp: 1,
        approach: [1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        temp_c: 31.5,
    }
}

/// FK, FK pq and compensated angles through both routes, bit for bit.
fn assert_fk_identical(
    r: &kincal_robot,
    p: &kincal_prepared,
    q: &[f64],
    aux: *const kincal_joint_aux,
) {
    let n = q.len();
    let (mut t1, mut t2) = ([0.0; 16], [1.0; 16]);
    let (mut e1, mut e2) = (kincal_error::CLEAR, kincal_error::CLEAR);
    unsafe {
        assert_eq!(
            kincal_fk(r, q.as_ptr(), n, aux, t1.as_mut_ptr(), 16, &mut e1),
            kincal_status::Ok,
            "{e1:?}"
        );
        assert_eq!(
            kincal_prepared_fk(p, q.as_ptr(), n, aux, t2.as_mut_ptr(), 16, &mut e2),
            kincal_status::Ok,
            "{e2:?}"
        );
    }
    assert_eq!(bits(&t1), bits(&t2));
    let (mut pq1, mut pq2) = ([0.0; 7], [1.0; 7]);
    unsafe {
        assert_eq!(
            kincal_fk_pq(r, q.as_ptr(), n, aux, pq1.as_mut_ptr(), 7, &mut e1),
            kincal_status::Ok
        );
        assert_eq!(
            kincal_prepared_fk_pq(p, q.as_ptr(), n, aux, pq2.as_mut_ptr(), 7, &mut e2),
            kincal_status::Ok
        );
    }
    assert_eq!(bits(&pq1), bits(&pq2));
    let (mut a1, mut a2) = (vec![0.0; n], vec![1.0; n]);
    unsafe {
        assert_eq!(
            kincal_joint_angles(r, q.as_ptr(), n, aux, a1.as_mut_ptr(), n, &mut e1),
            kincal_status::Ok
        );
        assert_eq!(
            kincal_prepared_joint_angles(p, q.as_ptr(), n, aux, a2.as_mut_ptr(), n, &mut e2),
            kincal_status::Ok
        );
    }
    assert_eq!(bits(&a1), bits(&a2));
    assert_jacobians_identical(r, p, q, aux, &t1);
}

/// The core's joint Jacobian at the C ABI's joint state, columns flattened.
fn core_joint_jacobian<const N: usize>(
    m: &kincal::Robot<N>,
    q: &[f64],
    aux: Option<&kincal_joint_aux>,
) -> Vec<f64> {
    let state = joint_state::<N>(q, aux, CALL_AUX).expect("joint state");
    let mut cols = [[0.0; 6]; N];
    m.joint_jacobian(&state, &mut cols)
        .expect("core joint Jacobian");
    cols.iter().flatten().copied().collect()
}

/// The identification Jacobian through the handle bit-identical to `kincal_jacobian` (both
/// sizes), and the joint Jacobian to the core's `Robot::joint_jacobian`; both poses equal FK's
/// `t_fk`.
fn assert_jacobians_identical(
    r: &kincal_robot,
    p: &kincal_prepared,
    q: &[f64],
    aux: *const kincal_joint_aux,
    t_fk: &[f64; 16],
) {
    let n = q.len();
    for cols in [
        kincal::params::num_geometric_params(n),
        kincal::params::num_params(n),
    ] {
        let (mut j1, mut j2) = (vec![0.0; 6 * cols], vec![1.0; 6 * cols]);
        let (mut t1, mut t2) = ([0.0; 16], [1.0; 16]);
        let mut e = kincal_error::CLEAR;
        unsafe {
            assert_eq!(
                kincal_jacobian(
                    r,
                    q.as_ptr(),
                    n,
                    aux,
                    j1.as_mut_ptr(),
                    j1.len(),
                    t1.as_mut_ptr(),
                    16,
                    &mut e
                ),
                kincal_status::Ok,
                "{e:?}"
            );
            assert_eq!(
                kincal_prepared_jacobian(
                    p,
                    q.as_ptr(),
                    n,
                    aux,
                    j2.as_mut_ptr(),
                    j2.len(),
                    t2.as_mut_ptr(),
                    16,
                    &mut e
                ),
                kincal_status::Ok,
                "{e:?}"
            );
        }
        assert_eq!(bits(&j1), bits(&j2));
        assert_eq!((bits(&t1), bits(&t2)), (bits(t_fk), bits(t_fk)));
    }
    let mut jj = vec![1.0; 6 * n];
    let mut t = [1.0; 16];
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe {
            kincal_prepared_joint_jacobian(
                p,
                q.as_ptr(),
                n,
                aux,
                jj.as_mut_ptr(),
                6 * n,
                t.as_mut_ptr(),
                16,
                &mut e,
            )
        },
        kincal_status::Ok,
        "{e:?}"
    );
    assert_eq!(bits(&t), bits(t_fk));
    let any = to_any(r).expect("valid robot");
    let aux = if aux.is_null() {
        None
    } else {
        Some(unsafe { &*aux })
    };
    let want = kincal::with_any_robot!(&any, m => core_joint_jacobian(m, q, aux));
    assert_eq!(bits(&jj), bits(&want));
}

/// IK through both routes: same status, same readings and info bit for bit.
fn assert_ik_identical(
    r: &kincal_robot,
    p: &kincal_prepared,
    target: &[f64; 16],
    seed: &[f64],
    aux: *const kincal_joint_aux,
) -> Vec<f64> {
    let n = seed.len();
    let (mut q1, mut q2) = (vec![0.0; n], vec![1.0; n]);
    let zero_info = kincal_ik_info {
        residual_pos_m: 0.0,
        residual_rot_rad: 0.0,
        iterations: 0,
        seed_index: 0,
    };
    let (mut i1, mut i2) = (zero_info, zero_info);
    let (mut e1, mut e2) = (kincal_error::CLEAR, kincal_error::CLEAR);
    let (s1, s2) = unsafe {
        (
            kincal_ik(
                r,
                target.as_ptr(),
                16,
                seed.as_ptr(),
                n,
                aux,
                null(),
                q1.as_mut_ptr(),
                n,
                &mut i1,
                &mut e1,
            ),
            kincal_prepared_ik(
                p,
                target.as_ptr(),
                16,
                seed.as_ptr(),
                n,
                aux,
                null(),
                q2.as_mut_ptr(),
                n,
                &mut i2,
                &mut e2,
            ),
        )
    };
    assert_eq!(s1, kincal_status::Ok, "{e1:?}");
    assert_eq!(s2, s1);
    assert_eq!(bits(&q1), bits(&q2));
    assert_eq!(
        (
            i1.residual_pos_m.to_bits(),
            i1.residual_rot_rad.to_bits(),
            i1.iterations,
            i1.seed_index
        ),
        (
            i2.residual_pos_m.to_bits(),
            i2.residual_rot_rad.to_bits(),
            i2.iterations,
            i2.seed_index
        )
    );
    q2
}

#[test]
fn size_and_alignment_are_the_header_constants() {
    assert_eq!(kincal_prepared_size(), KINCAL_PREPARED_SIZE);
    assert_eq!(
        core::mem::size_of::<kincal_prepared>(),
        KINCAL_PREPARED_SIZE
    );
    assert_eq!(
        core::mem::align_of::<kincal_prepared>(),
        KINCAL_PREPARED_ALIGN
    );
}

#[test]
fn aria_results_are_bit_identical() {
    let qs = [
        [0.3, 0.7, -0.4, 1.1, -0.6, 0.9],
        [0.0; 6],
        [-1.2, 0.2, 1.9, -2.5, 0.4, 3.0],
    ];
    for model in [
        kincal_aria_model::Nominal,
        kincal_aria_model::VirtualTruth,
        kincal_aria_model::RealIdentified,
    ] {
        let r = aria_robot(model);
        let p = prepare(&r);
        let mut n = 0;
        assert_eq!(
            unsafe { kincal_prepared_validate(&*p, &mut n, null_mut()) },
            kincal_status::Ok
        );
        assert_eq!(n, 6);
        for q in &qs {
            assert_fk_identical(&r, &p, q, null());
        }
        let mut seed = [0.0; 6];
        assert_eq!(
            unsafe { kincal_aria_tool_seed(seed.as_mut_ptr(), 6, null_mut()) },
            kincal_status::Ok
        );
        for l in 0..KINCAL_ARIA_NUM_TOOL_POSES {
            let mut target = [0.0; 16];
            assert_eq!(
                unsafe { kincal_aria_tool_pose(l, target.as_mut_ptr(), 16, null_mut()) },
                kincal_status::Ok
            );
            assert_ik_identical(&r, &p, &target, &seed, null());
        }
    }
}

/// An arm with every effect: FK bit-identical through the handle at `qs`, IK from a seed
/// near `qs[0]` bit-identical and on target, and the effects' inputs required through the
/// handle as well.
fn assert_arm_with_every_effect_identical(r: &kincal_robot, qs: &[&[f64]]) {
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_robot_validate(r, &mut e) },
        kincal_status::Ok,
        "{e:?}"
    );
    let p = prepare(r);
    let aux = aux7();
    for q in qs {
        assert_fk_identical(r, &p, q, &aux);
    }
    // IK: a reachable target (FK of known readings), seeded nearby.
    let q_true = qs[0];
    let n = q_true.len();
    let mut target = [0.0; 16];
    assert_eq!(
        unsafe { kincal_fk(r, q_true.as_ptr(), n, &aux, target.as_mut_ptr(), 16, &mut e,) },
        kincal_status::Ok
    );
    let seed: Vec<f64> = q_true.iter().map(|q| q + 0.05).collect();
    let q = assert_ik_identical(r, &p, &target, &seed, &aux);
    let mut t = [0.0; 16];
    assert_eq!(
        unsafe { kincal_prepared_fk(&*p, q.as_ptr(), n, &aux, t.as_mut_ptr(), 16, &mut e) },
        kincal_status::Ok
    );
    let d = t
        .iter()
        .zip(&target)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(d < 1e-9, "IK solution misses the target by {d}");

    // The effects need their inputs through the handle as well.
    let s = unsafe { kincal_prepared_fk(&*p, q.as_ptr(), n, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(s, kincal_status::MissingInput);
}

#[test]
fn seven_joint_arm_with_every_effect_is_bit_identical() {
    assert_arm_with_every_effect_identical(
        &seven_joint_arm(),
        &[
            &[0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.2],
            &[-1.0, -0.5, 2.0, -1.5, 2.5, 1.0, -2.0],
        ],
    );
}

#[test]
fn nine_joint_arm_with_every_effect_is_bit_identical() {
    assert_arm_with_every_effect_identical(
        &nine_joint_arm(),
        &[
            &[0.2, -0.1, 0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.2],
            &[-1.0, 0.4, -0.5, 2.0, -1.5, 2.5, 1.0, -2.0, 0.7],
        ],
    );
}

#[test]
fn a_copied_handle_works_and_a_handle_is_a_snapshot() {
    let mut r = aria_robot(kincal_aria_model::Nominal);
    let p = prepare(&r);
    let copy = Box::new(*p);
    let q = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9];
    assert_fk_identical(&r, &copy, &q, null());
    // Editing the robot afterwards does not reach the handle.
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_robot_set_param(&mut r, 2, 0.01, &mut e) },
        kincal_status::Ok
    );
    let (mut t1, mut t2) = ([0.0; 16], [0.0; 16]);
    unsafe {
        kincal_fk(&r, q.as_ptr(), 6, null(), t1.as_mut_ptr(), 16, null_mut());
        kincal_prepared_fk(&*p, q.as_ptr(), 6, null(), t2.as_mut_ptr(), 16, null_mut());
    }
    assert_ne!(bits(&t1), bits(&t2));
}

/// Status of FK through `p`, and whether the output stayed untouched.
fn fk_status(p: *const kincal_prepared) -> (kincal_status, kincal_error) {
    let q = [0.1; 6];
    let mut t = [7.0; 16];
    let mut e = kincal_error::CLEAR;
    let s = unsafe { kincal_prepared_fk(p, q.as_ptr(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    if s != kincal_status::Ok {
        assert_eq!(t, [7.0; 16], "output written on failure");
    }
    assert_eq!(e.status, s as u32);
    (s, e)
}

fn arg(e: &kincal_error) -> &'static str {
    assert!(!e.argument.is_null());
    unsafe { core::ffi::CStr::from_ptr(e.argument) }
        .to_str()
        .unwrap()
}

#[test]
fn null_and_misaligned_handles() {
    let (s, e) = fk_status(null());
    assert_eq!((s, arg(&e)), (kincal_status::NullPointer, "prepared"));
    let r = aria_robot(kincal_aria_model::Nominal);
    let good = prepare(&r);
    let mut buf = vec![0u64; KINCAL_PREPARED_WORDS + 1];
    let mis = unsafe { buf.as_mut_ptr().cast::<u8>().add(4) }.cast::<kincal_prepared>();
    unsafe {
        core::ptr::copy_nonoverlapping(
            (&*good as *const kincal_prepared).cast::<u8>(),
            mis.cast::<u8>(),
            KINCAL_PREPARED_SIZE,
        );
    }
    let (s, e) = fk_status(mis);
    assert_eq!((s, arg(&e)), (kincal_status::MisalignedPointer, "prepared"));
    let mut err = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_prepare(&r, mis, &mut err) },
        kincal_status::MisalignedPointer
    );
    assert_eq!(
        unsafe { kincal_prepare(&r, null_mut(), &mut err) },
        kincal_status::NullPointer
    );
    assert_eq!(
        unsafe { kincal_prepare(null(), &mut *empty(), &mut err) },
        kincal_status::NullPointer
    );
    assert_eq!(arg(&err), "robot");
    assert_eq!(
        unsafe { kincal_prepared_validate(null(), null_mut(), &mut err) },
        kincal_status::NullPointer
    );
}

#[test]
fn uninitialised_storage_is_a_bad_handle() {
    // Zeroed, 0xFF-filled and pseudo-random storage.
    let mut p = empty();
    assert_eq!(fk_status(&*p).0, kincal_status::BadHandle);
    p.opaque = [u64::MAX; KINCAL_PREPARED_WORDS];
    assert_eq!(fk_status(&*p).0, kincal_status::BadHandle);
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    for w in p.opaque.iter_mut() {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        *w = x;
    }
    let (s, e) = fk_status(&*p);
    assert_eq!((s, arg(&e)), (kincal_status::BadHandle, "prepared"));
    // Random storage with the right magic word still fails (header, then checksum).
    let good = prepare(&aria_robot(kincal_aria_model::Nominal));
    p.opaque[0] = good.opaque[0];
    assert_eq!(fk_status(&*p).0, kincal_status::BadHandle);
    p.opaque[1] = good.opaque[1];
    p.opaque[2] = 0;
    assert_eq!(fk_status(&*p).0, kincal_status::BadHandle);
    let mut err = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_prepared_validate(&*p, null_mut(), &mut err) },
        kincal_status::BadHandle
    );
    assert_eq!(
        unsafe { CStr::from_ptr(kincal_status_str(kincal_status::BadHandle as u32)) }
            .to_str()
            .unwrap(),
        "KINCAL_STATUS_BAD_HANDLE: a kincal_prepared was not filled by kincal_prepare or is \
         corrupted"
    );
}

#[test]
fn every_single_bit_flip_of_the_model_is_detected() {
    for r in [
        aria_robot(kincal_aria_model::VirtualTruth),
        seven_joint_arm(),
        nine_joint_arm(),
    ] {
        let good = prepare(&r);
        let n = r.n_joints as usize;
        let (size, lp) = match n {
            6 => (
                core::mem::size_of::<kincal::Robot<6>>(),
                kincal::Robot::<6>::LENGTH_PARAM_OFFSET,
            ),
            7 => (
                core::mem::size_of::<kincal::Robot<7>>(),
                kincal::Robot::<7>::LENGTH_PARAM_OFFSET,
            ),
            9 => (
                core::mem::size_of::<kincal::Robot<9>>(),
                kincal::Robot::<9>::LENGTH_PARAM_OFFSET,
            ),
            _ => unreachable!(),
        };
        // Header (32 bytes) and model; the padding bytes after the N length-param bytes are
        // not part of the model (never read) and the storage tail after the model is unused.
        let padding = 32 + lp + n..32 + lp + 8 * n.div_ceil(8);
        let mut p = Box::new(*good);
        for byte in (0..32 + size).filter(|b| !padding.contains(b)) {
            for bit in 0..8 {
                let bytes = unsafe {
                    core::slice::from_raw_parts_mut(
                        (&mut *p as *mut kincal_prepared).cast::<u8>(),
                        KINCAL_PREPARED_SIZE,
                    )
                };
                bytes[byte] ^= 1 << bit;
                let mut e = kincal_error::CLEAR;
                let s = unsafe { kincal_prepared_validate(&*p, null_mut(), &mut e) };
                assert_eq!(s, kincal_status::BadHandle, "flip of byte {byte} bit {bit}");
                bytes[byte] ^= 1 << bit;
            }
        }
        assert_eq!(
            unsafe { kincal_prepared_validate(&*p, null_mut(), null_mut()) },
            kincal_status::Ok
        );
        // An invalid length-param byte (2) is refused even with a matching checksum word.
        let bytes = unsafe {
            core::slice::from_raw_parts_mut(
                (&mut *p as *mut kincal_prepared).cast::<u8>(),
                KINCAL_PREPARED_SIZE,
            )
        };
        bytes[32 + lp] = 2;
        assert_eq!(fk_status(&*p).0, kincal_status::BadHandle);
        // So is the last one (for N = 9, in the second length-param word).
        bytes[32 + lp] = good.opaque[4 + lp / 8].to_le_bytes()[0];
        let validate =
            |p: &kincal_prepared| unsafe { kincal_prepared_validate(p, null_mut(), null_mut()) };
        assert_eq!(validate(&p), kincal_status::Ok);
        bytes[32 + lp + n - 1] = 2;
        assert_eq!(validate(&p), kincal_status::BadHandle);
    }
}

#[test]
fn a_failed_prepare_leaves_the_handle_intact() {
    let r = aria_robot(kincal_aria_model::Nominal);
    let mut p = prepare(&r);
    let before = *p;
    let mut bad = r;
    bad.n_joints = 13;
    let mut e = kincal_error::CLEAR;
    assert_eq!(
        unsafe { kincal_prepare(&bad, &mut *p, &mut e) },
        kincal_status::BadJointCount
    );
    bad = r;
    bad.params[3] = f64::NAN;
    assert_eq!(
        unsafe { kincal_prepare(&bad, &mut *p, &mut e) },
        kincal_status::NonFinite
    );
    assert_eq!(arg(&e), "robot->params");
    assert_eq!(p.opaque, before.opaque);
    assert_eq!(fk_status(&*p).0, kincal_status::Ok);
}

#[test]
fn argument_errors_through_the_handle() {
    let p = prepare(&aria_robot(kincal_aria_model::Nominal));
    let q = [0.1; 7];
    let mut t = [0.0; 16];
    let mut e = kincal_error::CLEAR;
    let s = unsafe { kincal_prepared_fk(&*p, q.as_ptr(), 7, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!(
        (s, arg(&e), e.expected, e.found),
        (kincal_status::BadLength, "q", 6, 7)
    );
    let s = unsafe { kincal_prepared_fk(&*p, q.as_ptr(), 6, null(), t.as_mut_ptr(), 15, &mut e) };
    assert_eq!((s, arg(&e)), (kincal_status::BadLength, "t_base_tool_out"));
    let s = unsafe { kincal_prepared_fk_pq(&*p, q.as_ptr(), 6, null(), null_mut(), 7, &mut e) };
    assert_eq!((s, arg(&e)), (kincal_status::NullPointer, "pq_out"));
    let nan = [0.1, f64::NAN, 0.0, 0.0, 0.0, 0.0];
    let s = unsafe { kincal_prepared_fk(&*p, nan.as_ptr(), 6, null(), t.as_mut_ptr(), 16, &mut e) };
    assert_eq!((s, arg(&e), e.index), (kincal_status::NonFinite, "q", 1));
    let mut out = [0.0; 6];
    let mut bad_target = [0.0; 16];
    bad_target[0] = 2.0;
    bad_target[15] = 1.0;
    let s = unsafe {
        kincal_prepared_ik(
            &*p,
            bad_target.as_ptr(),
            16,
            q.as_ptr(),
            6,
            null(),
            null(),
            out.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, arg(&e)), (kincal_status::InvalidTransform, "target"));
    let s = unsafe {
        kincal_prepared_ik(
            &*p,
            t.as_ptr(),
            16,
            q.as_ptr(),
            5,
            null(),
            null(),
            out.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!((s, arg(&e)), (kincal_status::BadLength, "q_seed"));
    let opts = kincal_ik_options {
        max_iterations: 10,
        first_solution: 0,
        extra_seeds: 0,
        tol_pos_m: -1.0,
        tol_rot_rad: 1e-9,
    };
    let mut target = [0.0; 16];
    assert_eq!(
        unsafe { kincal_aria_tool_pose(0, target.as_mut_ptr(), 16, null_mut()) },
        kincal_status::Ok
    );
    let s = unsafe {
        kincal_prepared_ik(
            &*p,
            target.as_ptr(),
            16,
            q.as_ptr(),
            6,
            null(),
            &opts,
            out.as_mut_ptr(),
            6,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(
        (s, arg(&e)),
        (kincal_status::InvalidArgument, "opts->tol_pos_m")
    );
}

/// A 12-joint chain with prismatic joints (`joint_kind`): FK through the struct and through
/// a prepared handle equal the core's bit for bit; a slide moves the tool along its axis;
/// a joint kind other than 0/1 is refused.
#[test]
fn twelve_joint_chain_with_prismatic_joints() {
    use core::f64::consts::FRAC_PI_2 as H;
    let mut links = [0.0; 5 * KINCAL_MAX_JOINTS];
    for (i, row) in links.chunks_exact_mut(5).enumerate() {
        row.copy_from_slice(&[
            0.1 * i as f64,
            0.05 + 0.01 * i as f64,
            0.02,
            if i % 2 == 0 { H } else { -H },
            0.0,
        ]);
    }
    let limits: Vec<f64> = (0..KINCAL_MAX_JOINTS).flat_map(|_| [-1.0, 1.0]).collect();
    let mut r = kincal_robot::ZERO;
    let s = unsafe {
        kincal_robot_init(
            &mut r,
            KINCAL_MAX_JOINTS,
            links.as_ptr(),
            links.len(),
            limits.as_ptr(),
            limits.len(),
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);
    for j in [0, 1, 3] {
        r.joint_kind[j] = kincal_joint_kind::Prismatic as u32;
    }
    let p = prepare(&r);
    let core = crate::robot::to_any(&r).unwrap();
    let q: Vec<f64> = (0..KINCAL_MAX_JOINTS)
        .map(|j| 0.3 - 0.05 * j as f64)
        .collect();
    let (mut t1, mut t2) = ([0.0; 16], [0.0; 16]);
    let n = KINCAL_MAX_JOINTS;
    unsafe {
        assert_eq!(
            kincal_fk(&r, q.as_ptr(), n, null(), t1.as_mut_ptr(), 16, null_mut()),
            kincal_status::Ok
        );
        assert_eq!(
            kincal_prepared_fk(&*p, q.as_ptr(), n, null(), t2.as_mut_ptr(), 16, null_mut()),
            kincal_status::Ok
        );
    }
    assert_eq!(t1, t2);
    let kincal::any::AnyRobot::J12(c) = core else {
        panic!("12 joints")
    };
    assert_eq!(c.joint_kind(3), kincal::JointKind::Prismatic);
    let qa: [f64; 12] = q.clone().try_into().unwrap();
    let t = c.fk_q(&qa).unwrap().to_homogeneous();
    for i in 0..4 {
        for k in 0..4 {
            assert_eq!(t[(i, k)].to_bits(), t1[4 * k + i].to_bits(), "({i},{k})");
        }
    }
    // Slide 1 along base z (the first axis; column-major, translation in 12..15): the tool
    // moves by exactly that.
    let mut q2 = q.clone();
    q2[0] += 0.125;
    let mut t3 = [0.0; 16];
    unsafe { kincal_fk(&r, q2.as_ptr(), n, null(), t3.as_mut_ptr(), 16, null_mut()) };
    assert!((t3[14] - t1[14] - 0.125).abs() < 1e-15 && (t3[12] - t1[12]).abs() < 1e-15);
    // Round trip through the struct keeps the kinds.
    let back = crate::robot::from_any(&kincal::any::AnyRobot::from(c)).unwrap();
    assert_eq!(back.joint_kind, r.joint_kind);
    r.joint_kind[5] = 3; // 2 is KINCAL_JOINT_KIND_SENSOR; 3 is no kind
    let mut e = kincal_error::CLEAR;
    let s = unsafe { kincal_fk(&r, q.as_ptr(), n, null(), t1.as_mut_ptr(), 16, &mut e) };
    assert_eq!(s, kincal_status::InvalidArgument);
}

/// The split of checks: damage to the header or guard words (0–3) fails every call; a
/// damaged number of the stored model passes the cheap per-call guard (documented) and is
/// found by `kincal_prepared_validate`'s checksum; the joint Jacobian export refuses a bad
/// handle like FK does.
#[test]
fn per_call_guard_and_full_validation() {
    let r = aria_robot(kincal_aria_model::VirtualTruth);
    let good = prepare(&r);
    let validate =
        |p: &kincal_prepared| unsafe { kincal_prepared_validate(p, null_mut(), null_mut()) };
    for word in 0..4 {
        for bit in [0, 17, 63] {
            let mut p = Box::new(*good);
            p.opaque[word] ^= 1 << bit;
            assert_eq!(
                fk_status(&*p).0,
                kincal_status::BadHandle,
                "word {word} bit {bit}"
            );
            assert_eq!(validate(&p), kincal_status::BadHandle);
            let q = [0.1; 6];
            let mut jac = [0.0; 36];
            let s = unsafe {
                kincal_prepared_joint_jacobian(
                    &*p,
                    q.as_ptr(),
                    6,
                    null(),
                    jac.as_mut_ptr(),
                    36,
                    null_mut(),
                    0,
                    null_mut(),
                )
            };
            assert_eq!(s, kincal_status::BadHandle);
        }
    }
    // A model number (the first word of the stored Robot, an f64) changed in place.
    let mut p = Box::new(*good);
    p.opaque[4] ^= 1 << 40;
    assert_eq!(fk_status(&*p).0, kincal_status::Ok);
    assert_eq!(validate(&p), kincal_status::BadHandle);
    assert_eq!(validate(&good), kincal_status::Ok);
}

/// The joint Jacobian through the C ABI against central differences of `kincal_prepared_fk`
/// (position rows; the nominal ARIA has no joint effects), and its length checks.
#[test]
fn prepared_joint_jacobian_matches_finite_differences() {
    let r = aria_robot(kincal_aria_model::Nominal);
    let p = prepare(&r);
    let q = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9];
    let mut jac = [0.0; 36];
    assert_eq!(
        unsafe {
            kincal_prepared_joint_jacobian(
                &*p,
                q.as_ptr(),
                6,
                null(),
                jac.as_mut_ptr(),
                36,
                null_mut(),
                0,
                null_mut(),
            )
        },
        kincal_status::Ok
    );
    let fk = |q: &[f64; 6]| {
        let mut t = [0.0; 16];
        let s = unsafe {
            kincal_prepared_fk(&*p, q.as_ptr(), 6, null(), t.as_mut_ptr(), 16, null_mut())
        };
        assert_eq!(s, kincal_status::Ok);
        [t[12], t[13], t[14]]
    };
    let h = 1e-6;
    for j in 0..6 {
        let (mut qp, mut qm) = (q, q);
        qp[j] += h;
        qm[j] -= h;
        let (a, b) = (fk(&qp), fk(&qm));
        for k in 0..3 {
            let fd = (a[k] - b[k]) / (2.0 * h);
            assert!(
                (jac[6 * j + k] - fd).abs() < 1e-8,
                "joint {j} row {k}: {} vs {fd}",
                jac[6 * j + k]
            );
        }
        // The angular rows of a revolute joint are its unit axis.
        let w = &jac[6 * j + 3..6 * j + 6];
        assert!(((w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() - 1.0).abs() < 1e-12);
    }
    let mut e = kincal_error::CLEAR;
    let s = unsafe {
        kincal_prepared_joint_jacobian(
            &*p,
            q.as_ptr(),
            6,
            null(),
            jac.as_mut_ptr(),
            35,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!((s, e.expected, e.found), (kincal_status::BadLength, 36, 35));
}
