//! The C ABI's FK and IK with the parameter table (`kincal_fk`, `kincal_ik`: the model is
//! converted and validated on every call) against the prepared handle (`kincal_prepared_fk`,
//! `kincal_prepared_ik`: built once by `kincal_prepare`), with the core's FK for reference.
//!
//! Run: `cargo bench -p kincal-ffi --bench prepared -- --noplot`. The build machine is shared:
//! wall-clock figures grow with its load, so read them as upper bounds.
//!
//! The crate builds only a staticlib and a cdylib (no rlib to link against), so this benchmark
//! compiles the crate's sources itself, module for module as in src/lib.rs, and calls the
//! exports exactly as C does (raw pointers, lengths, status codes).
#![allow(dead_code, missing_docs, clippy::all)]

#[macro_use]
#[path = "../src/panic.rs"]
mod panic;
#[macro_use]
#[path = "../src/args.rs"]
mod args;
#[path = "../src/aria.rs"]
mod aria;
#[path = "../src/axis_chain.rs"]
mod axis_chain;
#[path = "../src/effects.rs"]
mod effects;
#[path = "../src/identify.rs"]
mod identify;
#[path = "../src/ik.rs"]
mod ik;
#[path = "../src/kinematics.rs"]
mod kinematics;
#[path = "../src/observability.rs"]
mod observability;
#[path = "../src/params.rs"]
mod params;
#[path = "../src/pose.rs"]
mod pose;
#[path = "../src/prepared.rs"]
mod prepared;
#[path = "../src/registration.rs"]
mod registration;
#[path = "../src/robot.rs"]
mod robot;
#[path = "../src/status.rs"]
mod status;
#[path = "../src/validation.rs"]
mod validation;

use std::hint::black_box;
use std::ptr::{null, null_mut};

use criterion::{Criterion, criterion_group, criterion_main};

use aria::{kincal_aria_model, kincal_aria_tool_pose, kincal_aria_tool_seed, kincal_robot_aria};
use ik::{kincal_ik, kincal_ik_info};
use kinematics::{kincal_fk, kincal_fk_pq, kincal_joint_aux};
use prepared::{
    KINCAL_PREPARED_WORDS, kincal_prepare, kincal_prepared, kincal_prepared_fk,
    kincal_prepared_fk_pq, kincal_prepared_ik, kincal_prepared_jacobian,
    kincal_prepared_joint_jacobian, kincal_prepared_validate,
};
use robot::kincal_robot;
use status::kincal_status;

const Q6: [f64; 6] = [0.3, 0.9, -0.7, 1.2, 0.8, -0.4];
const Q7: [f64; 7] = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.2];

fn ok(s: kincal_status) {
    assert_eq!(s, kincal_status::Ok);
}

fn aria_truth() -> kincal_robot {
    let mut r = std::mem::MaybeUninit::<kincal_robot>::uninit();
    ok(unsafe {
        kincal_robot_aria(
            r.as_mut_ptr(),
            kincal_aria_model::VirtualTruth as u32,
            null_mut(),
        )
    });
    unsafe { r.assume_init() }
}

/// A 7-joint arm with base, tool, masses and every effect (needs approach and temperature).
fn seven_joint_arm() -> kincal_robot {
    use std::f64::consts::FRAC_PI_2 as H;
    let links: [f64; 35] = [
        0.0, 0.36, 0.0, -H, 0.0, 0.0, 0.0, 0.0, H, 0.0, 0.0, 0.42, 0.0, H, 0.0, 0.0, 0.0, 0.0, -H,
        0.0, 0.0, 0.40, 0.0, -H, 0.0, 0.0, 0.0, 0.0, H, 0.0, 0.0, 0.126, 0.0, 0.0, 0.0,
    ];
    let limits = [-2.9, 2.9].repeat(7);
    let mut r = std::mem::MaybeUninit::<kincal_robot>::uninit();
    ok(unsafe {
        robot::kincal_robot_init(
            r.as_mut_ptr(),
            7,
            links.as_ptr(),
            35,
            limits.as_ptr(),
            14,
            null_mut(),
        )
    });
    let mut r = unsafe { r.assume_init() };
    let tool = [0.0, 0.01, 0.15, 0.05, 0.0, -0.1];
    ok(unsafe { robot::kincal_robot_set_tool(&mut r, tool.as_ptr(), 6, null_mut()) });
    let masses = [4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3];
    let g = [0.0, 0.0, -9.81];
    ok(unsafe {
        robot::kincal_robot_set_mass(&mut r, masses.as_ptr(), 7, 1.2, g.as_ptr(), 3, null_mut())
    });
    let np = robot::kincal_num_params(7);
    for (i, v) in r.params.iter_mut().take(5 * 7).enumerate() {
        *v += 1e-4 * ((i % 7) as f64 - 3.0);
    }
    for (i, v) in r.params.iter_mut().take(np).skip(5 * 7 + 12).enumerate() {
        *v = 1e-5 * (1.0 + (i % 5) as f64);
    }
    ok(unsafe { robot::kincal_robot_validate(&r, null_mut()) });
    r
}

fn prepare(r: &kincal_robot) -> Box<kincal_prepared> {
    let mut p = Box::new(kincal_prepared {
        opaque: [0; KINCAL_PREPARED_WORDS],
    });
    ok(unsafe { kincal_prepare(r, &mut *p, null_mut()) });
    p
}

fn fk(c: &mut Criterion) {
    let aria = aria_truth();
    let prepared = prepare(&aria);
    let core = kincal::aria::virtual_truth();
    let state = kincal::JointState::new(Q6);
    let mut t = [0.0; 16];
    let mut pq = [0.0; 7];
    let mut g = c.benchmark_group("fk_aria");
    g.bench_function("core_robot_fk", |b| {
        b.iter(|| black_box(&core).fk(black_box(&state)))
    });
    g.bench_function("kincal_fk", |b| {
        b.iter(|| unsafe {
            kincal_fk(
                black_box(&aria),
                Q6.as_ptr(),
                6,
                null(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_fk", |b| {
        b.iter(|| unsafe {
            kincal_prepared_fk(
                black_box(&*prepared),
                Q6.as_ptr(),
                6,
                null(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_fk_pq", |b| {
        b.iter(|| unsafe {
            kincal_fk_pq(
                black_box(&aria),
                Q6.as_ptr(),
                6,
                null(),
                pq.as_mut_ptr(),
                7,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_fk_pq", |b| {
        b.iter(|| unsafe {
            kincal_prepared_fk_pq(
                black_box(&*prepared),
                Q6.as_ptr(),
                6,
                null(),
                pq.as_mut_ptr(),
                7,
                null_mut(),
            )
        })
    });
    // The full handle check (magic, shape, guard, length params, checksum of the stored
    // model): no longer part of every call.
    g.bench_function("kincal_prepared_validate", |b| {
        b.iter(|| unsafe {
            kincal_prepared_validate(black_box(&*prepared), null_mut(), null_mut())
        })
    });
    g.bench_function("kincal_prepare", |b| {
        let mut p = Box::new(kincal_prepared {
            opaque: [0; KINCAL_PREPARED_WORDS],
        });
        b.iter(|| unsafe { kincal_prepare(black_box(&aria), &mut *p, null_mut()) })
    });
    g.finish();

    let arm = seven_joint_arm();
    let prepared7 = prepare(&arm);
    let aux = kincal_joint_aux {
        has_approach: 1,
        has_temp: 1,
        approach: [1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        temp_c: 31.5,
    };
    let mut g = c.benchmark_group("fk_7joint_all_effects");
    g.bench_function("kincal_fk", |b| {
        b.iter(|| unsafe {
            kincal_fk(
                black_box(&arm),
                Q7.as_ptr(),
                7,
                &aux,
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_fk", |b| {
        b.iter(|| unsafe {
            kincal_prepared_fk(
                black_box(&*prepared7),
                Q7.as_ptr(),
                7,
                &aux,
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.finish();
}

fn ik(c: &mut Criterion) {
    let aria = aria_truth();
    let prepared = prepare(&aria);
    let mut target = [0.0; 16];
    let mut seed = [0.0; 6];
    ok(unsafe { kincal_aria_tool_pose(2, target.as_mut_ptr(), 16, null_mut()) });
    ok(unsafe { kincal_aria_tool_seed(seed.as_mut_ptr(), 6, null_mut()) });
    let mut q = [0.0; 6];
    let mut info = kincal_ik_info {
        residual_pos_m: 0.0,
        residual_rot_rad: 0.0,
        iterations: 0,
        seed_index: 0,
    };
    let mut g = c.benchmark_group("ik_aria_table2_pose3");
    g.sample_size(20);
    g.bench_function("kincal_ik", |b| {
        b.iter(|| unsafe {
            kincal_ik(
                black_box(&aria),
                target.as_ptr(),
                16,
                seed.as_ptr(),
                6,
                null(),
                null(),
                q.as_mut_ptr(),
                6,
                &mut info,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_ik", |b| {
        b.iter(|| unsafe {
            kincal_prepared_ik(
                black_box(&*prepared),
                target.as_ptr(),
                16,
                seed.as_ptr(),
                6,
                null(),
                null(),
                q.as_mut_ptr(),
                6,
                &mut info,
                null_mut(),
            )
        })
    });
    g.finish();
}

/// The controller's path over 1,024 random configurations within the ARIA limits (one per
/// iteration; a fixed configuration reads faster than a controller sees): FK and Jacobians
/// through the handle against the core and against the plain-struct identification Jacobian a
/// controller had to call before `kincal_prepared_joint_jacobian` existed.
fn firmware_path(c: &mut Criterion) {
    let aria = aria_truth();
    let prepared = prepare(&aria);
    let core = kincal::aria::virtual_truth();
    let mut rng = kincal::rng::SplitMix64::new(0x6b69_6e63_616c);
    let qs: Vec<[f64; 6]> = (0..1024)
        .map(|_| {
            core::array::from_fn(|j| {
                let l = core.limits()[j];
                rng.range(l.lower, l.upper)
            })
        })
        .collect();
    let mut k = 0usize;
    let mut next = move || {
        k = (k + 1) & 1023;
        k
    };
    let mut t = [0.0; 16];
    let mut jj = [0.0; 36];
    let mut joint = [[0.0; 6]; 6];
    let geo = kincal::params::num_geometric_params(6);
    let mut jg = vec![0.0; 6 * geo];
    let mut g = c.benchmark_group("firmware_random_q");
    g.bench_function("core_fk", |b| {
        b.iter(|| black_box(&core).fk(&kincal::JointState::new(qs[next()])))
    });
    g.bench_function("kincal_prepared_fk", |b| {
        b.iter(|| unsafe {
            let q = &qs[next()];
            kincal_prepared_fk(
                black_box(&*prepared),
                q.as_ptr(),
                6,
                null(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("core_joint_jacobian", |b| {
        b.iter(|| black_box(&core).joint_jacobian(&kincal::JointState::new(qs[next()]), &mut joint))
    });
    g.bench_function("kincal_prepared_joint_jacobian_and_fk", |b| {
        b.iter(|| unsafe {
            let q = &qs[next()];
            kincal_prepared_joint_jacobian(
                black_box(&*prepared),
                q.as_ptr(),
                6,
                null(),
                jj.as_mut_ptr(),
                36,
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_jacobian_geometric", |b| {
        b.iter(|| unsafe {
            let q = &qs[next()];
            kincal_prepared_jacobian(
                black_box(&*prepared),
                q.as_ptr(),
                6,
                null(),
                jg.as_mut_ptr(),
                jg.len(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_jacobian_geometric_plain_struct", |b| {
        b.iter(|| unsafe {
            let q = &qs[next()];
            kinematics::kincal_jacobian(
                black_box(&aria),
                q.as_ptr(),
                6,
                null(),
                jg.as_mut_ptr(),
                jg.len(),
                t.as_mut_ptr(),
                16,
                null_mut(),
            )
        })
    });
    g.bench_function("kincal_prepared_validate", |b| {
        b.iter(|| unsafe {
            kincal_prepared_validate(black_box(&*prepared), null_mut(), null_mut())
        })
    });
    g.finish();
}

criterion_group!(benches, firmware_path, fk, ik);
criterion_main!(benches);
