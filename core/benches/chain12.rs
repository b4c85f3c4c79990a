//! Criterion benchmarks of the 12-joint chains (#14 item 4) next to the 6R ARIA in the same
//! run: FK of a mobile manipulator (base x and y slides, base yaw, lifting column, 7R arm,
//! tool roll: P+P+R+P+8R) and of a lifting column with two tilt sensor joints under a 9R
//! arm (P+2S+9R); and a noise-free OLS calibration of the mobile manipulator's 44
//! identifiable geometric parameters from 60 full poses (identifiability analysis included,
//! and done once beforehand).
//!
//! FK cycles through a table of random configurations within the limits, as
//! `kinematics.rs` does. Run: `cargo bench -p kincal --bench chain12 -- --noplot
//! --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::identify::{
    Algorithm, IdentifyOptions, Measurement, Workspace, analyze, identify, identify_with_analysis,
};
use kincal::params::ParamId;
use kincal::rng::SplitMix64;
use kincal::{JointKind, JointLimits, Link, ParamIndex, Robot, aria};

const P: JointKind = JointKind::Prismatic;
const R: JointKind = JointKind::Revolute;
const S: JointKind = JointKind::Sensor;
const H: f64 = core::f64::consts::FRAC_PI_2;
/// Configurations in the FK table (a power of two).
const TABLE: usize = 1024;

fn lim(lo: f64, hi: f64) -> JointLimits {
    JointLimits::new(lo, hi)
}

/// Base slides x, y, yaw, column, 7R arm, tool roll.
fn mobile_12() -> Robot<12> {
    let links = [
        Link::dh(0.0, 0.0, 0.0, H),
        Link::dh(-H, 0.0, 0.0, -H),
        Link::dh(0.0, 0.3, 0.1, 0.0),
        Link::dh(0.2, 0.4, 0.05, 0.0),
        Link::dh(0.0, 0.333, 0.0, -H),
        Link::dh(0.0, 0.0, 0.0, H),
        Link::dh(0.0, 0.316, 0.0825, H),
        Link::dh(0.0, 0.0, -0.0825, -H),
        Link::dh(0.0, 0.384, 0.0, H),
        Link::dh(0.0, 0.0, 0.088, H),
        Link::dh(0.0, 0.107, 0.0, -H),
        Link::dh(0.0, 0.05, 0.01, 0.0),
    ];
    let limits = [
        lim(-2.0, 2.0),
        lim(-2.0, 2.0),
        lim(-3.0, 3.0),
        lim(0.0, 0.8),
        lim(-2.8, 2.8),
        lim(-1.7, 1.7),
        lim(-2.8, 2.8),
        lim(-3.0, -0.1),
        lim(-2.8, 2.8),
        lim(0.0, 3.7),
        lim(-2.8, 2.8),
        lim(-3.0, 3.0),
    ];
    Robot::new(links, limits)
        .and_then(|r| r.with_joint_kinds(&[P, P, R, P, R, R, R, R, R, R, R, R]))
        .and_then(|r| r.with_tool([0.01, 0.02, 0.08, 0.1, -0.2, 0.05]))
        .and_then(|r| r.with_base([0.0, 0.0, 0.1, 0.0, H, 0.0]))
        .expect("12-joint chain")
}

/// A lifting column, its top's tilt about x and y (sensor joints), a 9R arm.
fn column_tilt_9r() -> Robot<12> {
    let mut links = [Link::dh(0.0, 0.12, 0.03, H); 12];
    links[0] = Link::dh(0.1, 0.3, 0.05, H);
    links[1] = Link::dh(0.0, 0.0, 0.0, -H);
    links[2] = Link::dh(0.0, 0.2, 0.0, 0.0);
    for (k, l) in links.iter_mut().enumerate().skip(3) {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        *l = Link::dh(0.0, 0.1 + 0.01 * k as f64, 0.02 * sign, sign * H);
    }
    let mut limits = [lim(-2.8, 2.8); 12];
    limits[0] = lim(0.0, 1.5);
    limits[1] = lim(-0.03, 0.03);
    limits[2] = lim(-0.03, 0.03);
    let kinds = [P, S, S, R, R, R, R, R, R, R, R, R];
    Robot::new(links, limits)
        .and_then(|r| r.with_joint_kinds(&kinds))
        .expect("P+2S+9R chain")
}

/// A reading uniform within the limits.
fn q_within<const N: usize>(rng: &mut SplitMix64, robot: &Robot<N>) -> [f64; N] {
    core::array::from_fn(|j| {
        let l = robot.limits()[j];
        rng.range(l.lower, l.upper)
    })
}

fn states<const N: usize>(robot: &Robot<N>, seed: u64) -> Vec<[f64; N]> {
    let mut rng = SplitMix64::new(seed);
    (0..TABLE).map(|_| q_within(&mut rng, robot)).collect()
}

fn fk_bench<const N: usize>(c: &mut Criterion, name: &str, robot: &Robot<N>) {
    let qs = states(robot, 0x6b69_6e63);
    let mut k = 0usize;
    c.bench_function(name, |b| {
        b.iter(|| {
            k = (k + 1) & (TABLE - 1);
            black_box(robot.fk_q(black_box(&qs[k])).expect("fk"))
        })
    });
}

fn fk(c: &mut Criterion) {
    fk_bench(c, "fk/aria_6r", &aria::nominal());
    fk_bench(c, "fk/mobile_12 (P+P+R+P+8R)", &mobile_12());
    fk_bench(c, "fk/column_tilt_12 (P+2S+9R)", &column_tilt_9r());
}

fn calibration(c: &mut Criterion) {
    let nominal = mobile_12();
    let mut ws = Box::<Workspace<64>>::default();
    let mut rng = SplitMix64::new(34);
    let probe: Vec<Measurement<12>> = (0..60)
        .map(|_| {
            let q = q_within(&mut rng, &nominal);
            Measurement::new(q, nominal.fk_q(&q).expect("fk"))
        })
        .collect();
    let opts = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
    let a = analyze(&nominal, &probe, &opts, &mut ws).expect("analysis");
    // The truth: every identifiable parameter off by up to 5 mm / 0.02 rad.
    let mut truth = nominal;
    for i in a.identifiable.iter() {
        let v = truth.param(ParamIndex(i)).expect("param");
        let id = ParamId::from_index(ParamIndex(i), 12).expect("id");
        let size = if id.is_length() { 0.005 } else { 0.02 };
        truth
            .set_param(ParamIndex(i), v + rng.range(-size, size))
            .expect("set");
    }
    let data: Vec<Measurement<12>> = (0..60)
        .map(|_| {
            let q = q_within(&mut rng, &nominal);
            Measurement::new(q, truth.fk_q(&q).expect("fk"))
        })
        .collect();
    let opts = IdentifyOptions::new(Algorithm::Ols, a.identifiable);
    let fit = identify(&nominal, &data, &opts, &mut ws).expect("fit");
    assert!(fit.fitted.max_pos_m < 1e-9, "{:?}", fit.fitted);
    let full = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
    c.bench_function(
        "calibrate_12_joints_60_poses_44_params/ols/with_analysis",
        |b| {
            b.iter(|| black_box(identify(&nominal, black_box(&data), &full, &mut ws).expect("fit")))
        },
    );
    c.bench_function(
        "calibrate_12_joints_60_poses_44_params/ols/analysis_reused",
        |b| {
            b.iter(|| {
                black_box(
                    identify_with_analysis(&nominal, black_box(&data), &opts, &a, &mut ws)
                        .expect("fit"),
                )
            })
        },
    );
}

criterion_group!(benches, fk, calibration);
criterion_main!(benches);
