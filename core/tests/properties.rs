//! Property tests (proptest) for the invariants the rest of the toolkit relies on:
//! FK of composed transforms, the identification Jacobian against central differences, the
//! IK round trip, the rotation conventions (RPY, quaternion, rotation vector), recovery of
//! random parameter perturbations from noise-free data, and invariance under a change of
//! length unit (metres vs millimetres).
//!
//! Every comparison uses a named tolerance and an absolute difference. Failing cases are
//! shrunk and their seeds kept in `proptest-regressions/properties.txt` (commit it).

#![allow(clippy::needless_range_loop)] // numeric loops index several arrays at once

use kincal::identify::{
    Algorithm, Bounds, IdentifyOptions, Measurement, Workspace, analyze, identify,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::pose::{
    Transform, matrix_to_quaternion, matrix_to_rpy, pose_error, pose_from_vector6,
    quaternion_to_matrix, rotation_exp, rotation_log, rpy_to_matrix,
};
use kincal::{
    Effect, EffectSet, JointLimits, JointState, Link, OrientationError, ParamId, ParamIndex, Robot,
    aria,
};
use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// FK against an independent 4×4 product, and FK composition [m] / [1].
const FK_TOL: f64 = 1e-12;
/// Central-difference Jacobian against the analytic one (step 1e-6: truncation ~1e-12,
/// rounding ~1e-10), relative to max(1, |column|).
const JAC_TOL: f64 = 1e-7;
/// Central-difference step.
const FD_STEP: f64 = 1e-6;
/// IK round trip: pose reached vs target [m] / [rad].
const IK_TOL: f64 = 1e-9;
/// Rotation round trips, matrix elements [1].
const ROT_TOL: f64 = 1e-14;
/// Rotation-vector round trip away from π [rad].
const ROTVEC_TOL: f64 = 1e-13;
/// Recovered parameters from noise-free data [m] / [rad] / effect units.
const RECOVERY_TOL: f64 = 1e-8;
/// Agreement of the metre and millimetre fits: relative, plus an absolute floor [m] / [rad]
/// for values near zero (the solvers stop at a relative step of 1e-12; parameter standard
/// errors with this noise are ~1e-4).
const UNIT_TOL: f64 = 1e-9;
const UNIT_ABS_TOL: f64 = 1e-10;

type Ws = Workspace<128>;

// ---------------------------------------------------------------------------------------
// Strategies

/// A rotation vector with angle in [0, π).
fn rotvec() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, 0.0..(PI - 1e-6))
        .prop_filter("non-zero axis", |(x, y, z, _)| x * x + y * y + z * z > 1e-6)
        .prop_map(|(x, y, z, t)| Vector3::new(x, y, z).normalize() * t)
}

fn rotation() -> impl Strategy<Value = Matrix3<f64>> {
    rotvec().prop_map(|v| *Rotation3::from_scaled_axis(v).matrix())
}

/// Six frame parameters `[p (m); rotation vector (rad)]`.
fn frame6() -> impl Strategy<Value = [f64; 6]> {
    (prop::array::uniform3(-0.5..0.5f64), rotvec())
        .prop_map(|(p, r)| [p[0], p[1], p[2], r.x, r.y, r.z])
}

/// Uniform fractions, mapped onto the joint limits by [`within_limits`].
fn fractions() -> impl Strategy<Value = [f64; 6]> {
    prop::array::uniform6(0.0..1.0f64)
}

/// Readings inside the limits (clipped to ±π so that every joint covers one turn).
fn within_limits(robot: &Robot<6>, u: &[f64; 6]) -> [f64; 6] {
    let mut q = [0.0; 6];
    for j in 0..6 {
        let l = robot.limits()[j];
        let (lo, hi) = (l.lower.max(-PI), l.upper.min(PI));
        q[j] = lo + u[j] * (hi - lo);
    }
    q
}

/// Perturbations of the 24 default geometric parameters: θ0/α ±0.02 rad, lengths and β
/// ±3 mm / ±0.003 rad (small enough that the d/β choice of Table 1 stays right).
fn geometric_perturbation() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(-1.0..1.0f64, 24)
}

/// The nominal ARIA with `delta` (from [`geometric_perturbation`]) added to its default
/// geometric parameters.
fn perturbed_aria(delta: &[f64]) -> Robot<6> {
    let mut r = aria::nominal();
    for (k, i) in r.geometric_param_set().iter().enumerate() {
        let id = ParamId::from_index(ParamIndex(i), 6).unwrap();
        let scale = match id {
            ParamId::Link { kind, .. } if kind.is_length() => 3e-3,
            ParamId::Link {
                kind: kincal::params::LinkParam::Beta,
                ..
            } => 3e-3,
            _ => 2e-2,
        };
        let v = r.param(ParamIndex(i)).unwrap() + scale * delta[k];
        r.set_param(ParamIndex(i), v).unwrap();
    }
    r
}

/// Effect parameters of plausible size, in layout order of [`set_effects`].
fn effect_values() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(-1.0..1.0f64, 6 * 7 + 1)
}

/// Sets every effect parameter of `r` from `v` (compliance ≥ 0).
fn set_effects(r: &mut Robot<6>, v: &[f64]) {
    let mut k = 0;
    let mut next = |scale: f64| {
        k += 1;
        scale * v[k - 1]
    };
    for j in 0..6 {
        let c = next(2e-3).abs();
        r.set_param(ParamId::Compliance(j).index(6), c).unwrap();
        r.set_param(ParamId::Scale(j).index(6), next(2e-3)).unwrap();
        for t in kincal::params::CyclicTerm::ALL {
            r.set_param(ParamId::Cyclic(j, t).index(6), next(1e-3))
                .unwrap();
        }
        r.set_param(ParamId::Backlash(j).index(6), next(1e-3))
            .unwrap();
    }
    r.set_param(ParamId::Thermal.index(6), next(5e-5)).unwrap();
}

fn state_with_inputs(q: [f64; 6], s: [bool; 6], temp_c: f64) -> JointState<6> {
    JointState {
        q,
        approach: Some(s.map(|b| if b { 1.0 } else { -1.0 })),
        temp_c: Some(temp_c),
    }
}

fn max_abs(a: &Matrix4<f64>, b: &Matrix4<f64>) -> f64 {
    (a - b).amax()
}

fn homogeneous(t: &Transform) -> Matrix4<f64> {
    t.to_homogeneous()
}

// ---------------------------------------------------------------------------------------
// FK

/// `A_i(q) = Rz(q + θ0)·Tz(d)·Tx(a)·Rx(α)·Ry(β)` written out with nalgebra's own rotations.
fn link_matrix(l: &Link, q: f64) -> Matrix4<f64> {
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), q + l.theta0).to_homogeneous();
    let tz = Matrix4::new_translation(&Vector3::new(0.0, 0.0, l.d));
    let tx = Matrix4::new_translation(&Vector3::new(l.a, 0.0, 0.0));
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), l.alpha).to_homogeneous();
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), l.beta).to_homogeneous();
    rz * tz * tx * rx * ry
}

fn frame_matrix(v: &[f64; 6]) -> Matrix4<f64> {
    let r = Rotation3::from_scaled_axis(Vector3::new(v[3], v[4], v[5])).to_homogeneous();
    Matrix4::new_translation(&Vector3::new(v[0], v[1], v[2])) * r
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// FK equals the plain product `T_base·A_1···A_6·T_tool`, every intermediate frame is the
    /// product up to its link, and a chain split in two composes back: FK of links 1..3
    /// (with the base) times FK of links 4..6 (with the tool) is FK of the whole arm.
    #[test]
    fn fk_is_the_composition_of_its_transforms(
        delta in geometric_perturbation(),
        base in frame6(),
        tool in frame6(),
        u in fractions(),
    ) {
        let r = perturbed_aria(&delta).with_base(base).unwrap().with_tool(tool).unwrap();
        let q = within_limits(&r, &u);
        let mut expected = frame_matrix(&base);
        let mut frames = kincal::Frames::default();
        r.fk_frames(&JointState::new(q), &mut frames).unwrap();
        for i in 0..6 {
            expected *= link_matrix(&r.links()[i], q[i]);
            let e = max_abs(&homogeneous(&frames.t_base_link[i]), &expected);
            prop_assert!(e < FK_TOL, "frame {} off by {e:e}", i + 1);
        }
        expected *= frame_matrix(&tool);
        let fk = homogeneous(&r.fk_q(&q).unwrap());
        prop_assert!(max_abs(&fk, &expected) < FK_TOL, "fk off by {:e}", max_abs(&fk, &expected));
        prop_assert!(max_abs(&homogeneous(&frames.t_base_ee), &fk) == 0.0);

        let l = r.links();
        let lim = [JointLimits::new(-PI, PI); 3];
        let first = Robot::new([l[0], l[1], l[2]], lim).unwrap().with_base(base).unwrap();
        let second = Robot::new([l[3], l[4], l[5]], lim).unwrap().with_tool(tool).unwrap();
        let composed = homogeneous(&first.fk_q(&[q[0], q[1], q[2]]).unwrap())
            * homogeneous(&second.fk_q(&[q[3], q[4], q[5]]).unwrap());
        prop_assert!(max_abs(&composed, &fk) < FK_TOL, "split chain off by {:e}", max_abs(&composed, &fk));

        // A base change acts on the left, a tool change on the right.
        let b2 = r.with_base([0.0; 6]).unwrap().with_tool([0.0; 6]).unwrap();
        let bare = homogeneous(&b2.fk_q(&q).unwrap());
        let lr = frame_matrix(&base) * bare * frame_matrix(&tool);
        prop_assert!(max_abs(&lr, &fk) < FK_TOL);
    }
}

// ---------------------------------------------------------------------------------------
// Jacobian

fn fk_at(r: &Robot<6>, i: usize, v: f64, st: &JointState<6>) -> Transform {
    let mut r = *r;
    r.set_param(ParamIndex(i), v).unwrap();
    r.fk(st).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every one of the 12N+13 columns (links, base, tool, all effects) agrees with central
    /// differences of FK, at random models, configurations, approach directions and
    /// temperatures.
    #[test]
    fn jacobian_matches_central_differences(
        delta in geometric_perturbation(),
        base in frame6(),
        tool in frame6(),
        effects in effect_values(),
        u in fractions(),
        s in prop::array::uniform6(any::<bool>()),
        temp_c in 0.0..45.0f64,
    ) {
        let mut r = perturbed_aria(&delta).with_base(base).unwrap().with_tool(tool).unwrap();
        set_effects(&mut r, &effects);
        let st = state_with_inputs(within_limits(&r, &u), s, temp_c);
        let mut jac = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
        let t = r.jacobian(&st, &mut jac).unwrap();
        prop_assert!(max_abs(&homogeneous(&t), &homogeneous(&r.fk(&st).unwrap())) == 0.0);
        for i in 0..Robot::<6>::NUM_PARAMS {
            let v = r.param(ParamIndex(i)).unwrap();
            let plus = fk_at(&r, i, v + FD_STEP, &st);
            let minus = fk_at(&r, i, v - FD_STEP, &st);
            let e = pose_error(&plus, &minus, OrientationError::Exact);
            let col = &jac[i];
            let norm = col.iter().map(|c| c * c).sum::<f64>().sqrt().max(1.0);
            for k in 0..6 {
                let fd = e[k] / (2.0 * FD_STEP);
                let err = (fd - col[k]).abs() / norm;
                prop_assert!(
                    err < JAC_TOL,
                    "{} row {k}: analytic {} vs differences {fd}",
                    ParamId::from_index(ParamIndex(i), 6).unwrap(),
                    col[k]
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// IK

/// Smallest singular value of the 6×6 joint Jacobian (the θ0 columns) at `q`.
fn joint_sigma_min(r: &Robot<6>, q: &[f64; 6]) -> f64 {
    let mut jac = [[0.0; 6]; Robot::<6>::NUM_GEOMETRIC_PARAMS];
    r.jacobian(&JointState::new(*q), &mut jac).unwrap();
    let m = nalgebra::Matrix6::from_fn(|row, j| {
        jac[ParamId::Link {
            link: j,
            kind: kincal::params::LinkParam::Theta0,
        }
        .index(6)
        .0][row]
    });
    m.singular_values().min()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// A pose FK produces is reachable: IK started a little away from its configuration
    /// returns readings within the limits whose FK is the pose. Near-singular
    /// configurations (σ_min of the joint Jacobian below 0.02) are left out: there the
    /// local descent may legitimately stall; reachability there is a different question.
    #[test]
    fn ik_round_trip_where_reachable(
        delta in geometric_perturbation(),
        effects in effect_values(),
        u in prop::array::uniform6(0.05..0.95f64),
        kick in prop::array::uniform6(-0.15..0.15f64),
    ) {
        let mut r = perturbed_aria(&delta);
        set_effects(&mut r, &effects);
        r.clear_effects(EffectSet::of(Effect::Backlash).with(Effect::Thermal));
        let q = within_limits(&r, &u);
        prop_assume!(joint_sigma_min(&r, &q) > 0.02);
        let target = r.fk_q(&q).unwrap();
        let mut seed = q;
        for j in 0..6 {
            seed[j] += kick[j];
        }
        let opts = IkOptions { first_solution: true, ..IkOptions::default() };
        let sol = solve_ik(&r, &target, &JointState::new(seed), &opts);
        prop_assert!(sol.is_ok(), "IK failed: {:?}", sol);
        let sol = sol.unwrap();
        r.check_limits(&sol.q).unwrap();
        let e = pose_error(&target, &r.fk_q(&sol.q).unwrap(), OrientationError::Exact);
        let ep = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let er = (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]).sqrt();
        prop_assert!(ep < IK_TOL && er < IK_TOL, "residual {ep:e} m, {er:e} rad");
    }
}

// ---------------------------------------------------------------------------------------
// Rotations

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// matrix → RPY → matrix is exact to rounding for every rotation, and RPY → matrix →
    /// RPY returns the angles when pitch is inside (−π/2, π/2).
    #[test]
    fn rpy_round_trips(r in rotation(), roll in -PI..PI, pitch in (-FRAC_PI_2 + 1e-6)..(FRAC_PI_2 - 1e-6), yaw in -PI..PI) {
        let a = matrix_to_rpy(&r);
        prop_assert!(a[1].abs() <= FRAC_PI_2);
        let back = rpy_to_matrix(a[0], a[1], a[2]);
        prop_assert!((back - r).amax() < ROT_TOL, "matrix off by {:e}", (back - r).amax());
        let m = rpy_to_matrix(roll, pitch, yaw);
        let b = matrix_to_rpy(&m);
        let wrap = |x: f64| (x + PI).rem_euclid(2.0 * PI) - PI;
        for (x, y) in [roll, pitch, yaw].iter().zip(b.iter()) {
            // Angle error grows like rounding / cos(pitch) near the lock.
            let tol = 1e-15 / pitch.cos() + 1e-14;
            prop_assert!(wrap(x - y).abs() < tol, "angles {:?} -> {:?}", [roll, pitch, yaw], b);
        }
    }

    /// matrix → quaternion → matrix is exact to rounding; quaternion → matrix → quaternion
    /// returns the normalised quaternion up to its sign (`w >= 0` on output).
    #[test]
    fn quaternion_round_trips(r in rotation(), q in prop::array::uniform4(-1.0..1.0f64)) {
        let qr = matrix_to_quaternion(&r);
        prop_assert!(qr[0] >= 0.0);
        let n = qr.iter().map(|v| v * v).sum::<f64>().sqrt();
        prop_assert!((n - 1.0).abs() < ROT_TOL);
        let back = quaternion_to_matrix(&qr).unwrap();
        prop_assert!((back - r).amax() < ROT_TOL, "matrix off by {:e}", (back - r).amax());

        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        prop_assume!(n > 1e-3);
        let m = quaternion_to_matrix(&q).unwrap();
        let q2 = matrix_to_quaternion(&m);
        let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
        for k in 0..4 {
            prop_assert!((q2[k] - sign * q[k] / n).abs() < 1e-13 || q[0].abs() < 1e-9, "{q:?} -> {q2:?}");
        }
    }

    /// exp(log R) = R for every rotation (also within 1e-6 rad of π), and log(exp v) = v for
    /// rotation vectors with angle below π.
    #[test]
    fn rotation_vector_round_trips(v in rotvec(), near_pi in rotvec(), eps in 0.0..1e-6f64) {
        let r = rotation_exp(&v);
        prop_assert!((r * r.transpose() - Matrix3::identity()).amax() < ROT_TOL);
        prop_assert!((r.determinant() - 1.0).abs() < ROT_TOL);
        let back = rotation_log(&r);
        prop_assert!((back - v).amax() < ROTVEC_TOL * (1.0 + 1.0 / (PI - v.norm())), "{v:?} -> {back:?}");
        let w = near_pi.normalize() * (PI - eps);
        let rw = *Rotation3::from_scaled_axis(w).matrix();
        let again = rotation_exp(&rotation_log(&rw));
        prop_assert!((again - rw).amax() < 1e-12, "near pi off by {:e}", (again - rw).amax());
        // Our exp agrees with nalgebra's.
        let nr = *Rotation3::from_scaled_axis(v).matrix();
        prop_assert!((nr - r).amax() < ROT_TOL);
    }

    /// The base/tool parameterisation round-trips through a transform.
    #[test]
    fn frame_vector_round_trips(f in frame6()) {
        let t = pose_from_vector6(&f);
        let back = kincal::pose::pose_to_vector6(&t);
        for k in 0..6 {
            prop_assert!((back[k] - f[k]).abs() < ROTVEC_TOL * 1e3, "{f:?} -> {back:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Identification

/// Noise-free measurements of `truth` at `n` configurations drawn from `u` (fractions of
/// the limits), with approach directions and temperatures when `inputs`.
fn synthetic(truth: &Robot<6>, u: &[[f64; 6]], inputs: bool) -> Vec<Measurement<6>> {
    u.iter()
        .enumerate()
        .map(|(l, f)| {
            let q = within_limits(truth, f);
            let mut st = JointState::new(q);
            if inputs {
                st.approach = Some(core::array::from_fn(|j| {
                    if (l >> j) & 1 == 0 { 1.0 } else { -1.0 }
                }));
                st.temp_c = Some(15.0 + (l % 7) as f64 * 3.0);
            }
            Measurement {
                state: st,
                pose: truth.fk(&st).unwrap(),
                mask: kincal::identify::ComponentMask::ALL,
                weight: 1.0,
                point: None,
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Noise-free data of a randomly perturbed ARIA: every algorithm recovers the 24
    /// default geometric parameters.
    #[test]
    fn identification_recovers_random_geometric_perturbations(
        delta in geometric_perturbation(),
        u in prop::collection::vec(fractions(), 12),
        alg in prop::sample::select(Algorithm::ALL.to_vec()),
    ) {
        let truth = perturbed_aria(&delta);
        let nominal = aria::nominal();
        let data = synthetic(&truth, &u, false);
        let wide = Bounds::around(&nominal, 0.05, 0.5);
        let mut opts = IdentifyOptions::new(alg, nominal.geometric_param_set());
        opts.bounds = Some(&wide);
        let mut ws = Box::<Ws>::default();
        let r = identify(&nominal, &data, &opts, &mut ws).unwrap();
        prop_assert_eq!(r.analysis.rank, 24);
        for i in nominal.geometric_param_set().iter() {
            let e = (r.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap()).abs();
            prop_assert!(e < RECOVERY_TOL, "{alg:?}: {} off by {e:e}", ParamId::from_index(ParamIndex(i), 6).unwrap());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    /// Noise-free data of a perturbed ARIA with every effect and perturbed base and tool
    /// frames: the identifiable parameters (the structural analysis removes the redundant
    /// ones) are recovered, and the model reproduces the data.
    #[test]
    fn identification_recovers_random_perturbations_with_every_effect(
        delta in geometric_perturbation(),
        effects in effect_values(),
        dbase in prop::array::uniform6(-1.0..1.0f64),
        dtool in prop::array::uniform6(-1.0..1.0f64),
        u in prop::collection::vec(fractions(), 48),
    ) {
        let nominal = aria::nominal();
        let all = EffectSet::NONE;
        let all = Effect::ALL.iter().fold(all, |s, &e| s.with(e));
        let req = nominal.param_set(all);
        let mut ws = Box::<Ws>::default();
        let opts = IdentifyOptions::new(Algorithm::Opt2, req);
        // Perturb only what the data can determine (structurally redundant parameters keep
        // their initial value by design).
        let probe = synthetic(&nominal, &u, true);
        let a = analyze(&nominal, &probe, &opts, &mut ws).unwrap();
        prop_assume!(a.data_deficient.is_empty());
        let mut truth = perturbed_aria(&delta);
        set_effects(&mut truth, &effects);
        for k in 0..6 {
            for (off, d) in [(0, dbase[k]), (6, dtool[k])] {
                let i = 30 + off + k;
                let scale = if k < 3 { 2e-3 } else { 5e-3 };
                truth.set_param(ParamIndex(i), scale * d).unwrap();
            }
        }
        for i in a.structural.iter() {
            truth.set_param(ParamIndex(i), nominal.param(ParamIndex(i)).unwrap()).unwrap();
        }
        let data = synthetic(&truth, &u, true);
        let r = identify(&nominal, &data, &opts, &mut ws).unwrap();
        prop_assert!(r.fitted.max_pos_m < 1e-10 && r.fitted.max_rot_rad < 1e-10, "residual {:?}", r.fitted);
        for i in r.analysis.identifiable.iter() {
            let e = (r.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap()).abs();
            prop_assert!(e < RECOVERY_TOL, "{} off by {e:e}", ParamId::from_index(ParamIndex(i), 6).unwrap());
        }
    }
}

// ---------------------------------------------------------------------------------------
// Units

/// `r` with every length (d, a of the links, base and tool positions) times `s`.
fn scaled_lengths(r: &Robot<6>, s: f64) -> Robot<6> {
    let mut out = *r;
    for i in 0..Robot::<6>::NUM_GEOMETRIC_PARAMS {
        let id = ParamId::from_index(ParamIndex(i), 6).unwrap();
        if id.is_length() {
            out.set_param(ParamIndex(i), s * r.param(ParamIndex(i)).unwrap())
                .unwrap();
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// The same experiment in millimetres (model lengths and measured positions ×1000,
    /// position weight ×1e-6 so the cost is unchanged) gives the same model: lengths ×1000,
    /// angles equal, the same rank and the same number of iterations.
    #[test]
    fn identification_is_invariant_under_a_change_of_length_unit(
        delta in geometric_perturbation(),
        u in prop::collection::vec(fractions(), 12),
        seed in any::<u64>(),
        alg in prop::sample::select(vec![Algorithm::Ols, Algorithm::Opt2]),
    ) {
        let truth = perturbed_aria(&delta);
        let nominal = aria::nominal();
        let mut rng = kincal::rng::SplitMix64::new(seed);
        let mut data = synthetic(&truth, &u, false);
        for m in &mut data {
            // 0.1 mm / 0.01° noise, so the fit has a non-zero residual.
            let dp = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 1e-4;
            let dr = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 1.7e-4;
            m.pose = kincal::pose::transform(rotation_exp(&dr) * m.pose.rotation.matrix(), m.pose.translation.vector + dp);
        }
        let mm = 1000.0;
        let nominal_mm = scaled_lengths(&nominal, mm);
        let data_mm: Vec<_> = data.iter().map(|m| {
            let mut m = *m;
            m.pose.translation.vector *= mm;
            m
        }).collect();
        let mut ws = Box::<Ws>::default();
        let opts = IdentifyOptions::new(alg, nominal.geometric_param_set());
        let mut opts_mm = opts;
        opts_mm.weight_pos = 1.0 / (mm * mm);
        let a = identify(&nominal, &data, &opts, &mut ws).unwrap();
        let b = identify(&nominal_mm, &data_mm, &opts_mm, &mut ws).unwrap();
        prop_assert_eq!(a.analysis.identifiable, b.analysis.identifiable);
        for i in a.analysis.identifiable.iter() {
            let id = ParamId::from_index(ParamIndex(i), 6).unwrap();
            let f = if id.is_length() { mm } else { 1.0 };
            let (va, vb) = (a.robot.param(ParamIndex(i)).unwrap(), b.robot.param(ParamIndex(i)).unwrap() / f);
            prop_assert!((va - vb).abs() <= UNIT_TOL * va.abs() + UNIT_ABS_TOL, "{id}: {va} m vs {vb} (from mm)");
        }
        prop_assert!((a.fitted.cost - b.fitted.cost).abs() <= 1e-6 * a.fitted.cost);
    }
}
