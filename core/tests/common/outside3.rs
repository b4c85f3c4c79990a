//! A THIRD, independent generator of effects outside kincal's library (issue #12, item 7),
//! written after the decision rules were fixed, beside `outside.rs` (the target) and
//! `outside2.rs`, to measure the over-claim rate on effects aimed at the hard cases: effects
//! that resemble a library effect in one respect and differ in another. It is a measuring
//! instrument only: do not tune the diagnosis to it.
//!
//! Its kinds: a shear of the instrument's axes (an instrument error that is linear in the
//! position, as `base_frame` is, but not rigid), a transmission coupling of joint 3 to joint
//! 2 (linear in a joint angle, as `joint_scale` is, but in another joint's), a thermal drift
//! of the joint zeros (driven by the recorded temperature, as `thermal` is, but turning
//! angles instead of scaling lengths), encoder quantisation (on the readings, not on the
//! arm), a random-walk drift of the instrument over the session (not linear in the session
//! order as `outside2.rs`'s drift) and a viewing-angle bias of a camera-based instrument.
//!
//! Magnitudes are realistic at size factor 1 (the families test draws it log-uniform in
//! [0.1, 5]); the random coefficients come from the case's seeded [`SplitMix64`].
#![allow(dead_code)]

use std::f64::consts::PI;

use kincal::params::LinkParam;
use kincal::pose::{rotation_exp, transform};
use kincal::rng::SplitMix64;
use kincal::{JointState, ParamId, Robot, Transform};
use nalgebra::{Matrix3, Vector3};

use crate::outside::PoseEffect;

/// The third family of out-of-library effects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outside3 {
    /// The instrument's axes are not orthogonal (a camera system's calibration wand, a
    /// tracker's axis errors): positions are reported through a shear, y ← y + s·x and
    /// z ← z + s'·y, s and s' ≈ 1 mrad (1σ). A rigid-body fit of markers seen through the
    /// shear turns the orientation by the shear's antisymmetric part (a constant rotation,
    /// as a base-frame error); the symmetric part deforms the positions, which no rigid
    /// frame can absorb.
    InstrumentShear,
    /// A cable/belt of joint 3's drive runs over joint 2's axis: when joint 2 turns, the
    /// loop winds and turns joint 3 behind its encoder, Δθ3 = k·q2, k ≈ 1 mrad/rad (1σ).
    /// `joint_scale` would be k·q3 (joint 3's own angle).
    TransmissionCoupling,
    /// The joints' zeros drift with temperature (the encoder mount and the gear housing
    /// expand differently as the arm warms): Δθ_j = k_j·(T − 20 °C) with the pose's recorded
    /// temperature, k_j ≈ 20 µrad/K (1σ), i.e. about 0.4 mrad over the session's 22 → 42 °C
    /// ramp. The library's `thermal` scales link lengths, not angles.
    ThermalJointZero,
    /// Each joint's absolute encoder has 12–14 bits per turn: the controller reports the
    /// reading rounded to the encoder's step (1.5, 0.77 or 0.38 mrad, times the size
    /// factor), from a zero offset anywhere within a step; the arm stands at the true,
    /// unrounded angle. A pose-to-pose scatter of ±step/2 on the readings.
    EncoderQuantisation,
    /// The instrument wanders over the session (its stand settles, the air's temperature
    /// and refraction fluctuate): the measured position moves by an AR(1) process over the
    /// session's order, stationary σ ≈ 0.2 mm per axis (≈ 0.35 mm in norm), correlation
    /// time a fifth of the session. Not a function of q, nor linear in the session order.
    RandomWalkDrift,
    /// A camera-based instrument sees the tool's marker obliquely: its centroid is biased
    /// along the camera's line of sight by b·(1 − |cos a|), a the angle between the tool's
    /// z axis and the line of sight, b ≈ 0.3 mm, the camera 2.5 m from the working region's
    /// centre, 30–70° above the horizon at a random azimuth. Position only (the markers of
    /// a rigid body shift alike).
    ViewingAngleBias,
}

impl Outside3 {
    pub const ALL: [Outside3; 6] = [
        Outside3::InstrumentShear,
        Outside3::TransmissionCoupling,
        Outside3::ThermalJointZero,
        Outside3::EncoderQuantisation,
        Outside3::RandomWalkDrift,
        Outside3::ViewingAngleBias,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Outside3::InstrumentShear => "instrument_shear",
            Outside3::TransmissionCoupling => "transmission_coupling",
            Outside3::ThermalJointZero => "thermal_joint_zero",
            Outside3::EncoderQuantisation => "encoder_quantisation",
            Outside3::RandomWalkDrift => "random_walk_drift",
            Outside3::ViewingAngleBias => "viewing_angle_bias",
        }
    }
}

/// Shear of the instrument's axes at size 1, 1σ \[1\].
const SHEAR: f64 = 1e-3;
/// Coupling of joint 3 to joint 2 at size 1, 1σ \[rad/rad\].
const COUPLING: f64 = 1e-3;
/// Thermal drift of a joint zero at size 1, 1σ \[rad/K\].
const ZERO_DRIFT_PER_K: f64 = 2e-5;
/// Reference temperature of the zero drift \[°C\] (the library's thermal reference).
const REFERENCE_C: f64 = 20.0;
/// Stationary σ of the instrument's wander per axis at size 1 \[m\].
const WANDER_M: f64 = 2e-4;
/// Correlation time of the wander, as a share of the session.
const WANDER_TIME: f64 = 0.2;
/// Steps of the wander over the session (interpolated linearly between them).
const WANDER_STEPS: usize = 200;
/// Viewing-angle bias at size 1 \[m\].
const VIEW_BIAS_M: f64 = 3e-4;
/// Distance of the camera from the working region's centre \[m\].
const CAMERA_DISTANCE_M: f64 = 2.5;

/// One drawn effect of the third family: kind, size factor and its random coefficients
/// (standard normals, uniforms in [0, 1), and a seed of the wander's stream).
#[derive(Debug, Clone, Copy)]
pub struct Outside3Effect {
    pub kind: Outside3,
    pub size: f64,
    normal: [f64; 12],
    uniform: [f64; 12],
    seed: u64,
}

fn theta0(link: usize) -> kincal::ParamIndex {
    ParamId::Link {
        link,
        kind: LinkParam::Theta0,
    }
    .index(6)
}

/// `truth` with every joint turned by `dtheta` (the true angle behind the reading).
fn turned(truth: &Robot<6>, dtheta: &[f64; 6]) -> Robot<6> {
    let mut r = *truth;
    for (j, d) in dtheta.iter().enumerate() {
        let v = r.param(theta0(j)).unwrap();
        r.set_param(theta0(j), v + d).unwrap();
    }
    r
}

/// The working region's centre (ARIA's biopsy region).
fn region_centre() -> Vector3<f64> {
    let lo = Vector3::from(kincal::aria::WORKING_REGION_MIN_M);
    let hi = Vector3::from(kincal::aria::WORKING_REGION_MAX_M);
    (lo + hi) / 2.0
}

impl Outside3Effect {
    pub fn draw(kind: Outside3, size: f64, rng: &mut SplitMix64) -> Self {
        let mut normal = [0.0; 12];
        for c in &mut normal {
            *c = rng.normal();
        }
        let mut uniform = [0.0; 12];
        for u in &mut uniform {
            *u = rng.uniform();
        }
        let seed = rng.next_u64();
        Outside3Effect {
            kind,
            size,
            normal,
            uniform,
            seed,
        }
    }

    /// The shear's coefficients (s, s'): y ← y + s·x, z ← z + s'·y.
    fn shear(&self) -> (f64, f64) {
        let s = self.size * SHEAR;
        (s * self.normal[0], s * self.normal[1])
    }

    /// Joint 3's coupling to joint 2 [rad/rad].
    fn coupling(&self) -> f64 {
        self.size * COUPLING * self.normal[0]
    }

    /// The joints' zero shifts at temperature `temp_c` (none without a recorded one).
    fn zero_drift(&self, temp_c: Option<f64>) -> [f64; 6] {
        let dt = temp_c.map_or(0.0, |t| t - REFERENCE_C);
        std::array::from_fn(|j| self.size * ZERO_DRIFT_PER_K * self.normal[j] * dt)
    }

    /// Joint `j`'s encoder step and zero offset [rad].
    fn encoder(&self, j: usize) -> (f64, f64) {
        let bits = 12 + (3.0 * self.uniform[j]) as i32;
        let step = self.size * 2.0 * PI / 2f64.powi(bits);
        (step, self.uniform[6 + j] * step)
    }

    /// The instrument's wander at place `t` of the session (none off the session).
    fn wander(&self, t: Option<f64>) -> Vector3<f64> {
        let Some(t) = t else {
            return Vector3::zeros();
        };
        let x = t.clamp(0.0, 1.0) * WANDER_STEPS as f64;
        let k = (x.floor() as usize).min(WANDER_STEPS - 1);
        let phi = (-1.0 / (WANDER_TIME * WANDER_STEPS as f64)).exp();
        let sigma = self.size * WANDER_M;
        let mut rng = SplitMix64::new(self.seed);
        let mut draw = || Vector3::new(rng.normal(), rng.normal(), rng.normal());
        let mut v = draw() * sigma;
        for _ in 0..k {
            v = v * phi + draw() * (sigma * (1.0 - phi * phi).sqrt());
        }
        let next = v * phi + draw() * (sigma * (1.0 - phi * phi).sqrt());
        v + (next - v) * (x - k as f64)
    }

    /// The camera's position.
    fn camera(&self) -> Vector3<f64> {
        let azimuth = 2.0 * PI * self.uniform[0];
        let elevation = (30.0 + 40.0 * self.uniform[1]).to_radians();
        let dir = Vector3::new(
            elevation.cos() * azimuth.cos(),
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
        );
        region_centre() + dir * CAMERA_DISTANCE_M
    }

    /// The viewing-angle bias of a marker at `p` whose tool z axis is `z`.
    fn viewing_bias(&self, p: &Vector3<f64>, z: &Vector3<f64>) -> Vector3<f64> {
        let b = self.size * VIEW_BIAS_M * (1.0 + 0.2 * self.normal[0].abs());
        let sight = (p - self.camera()).normalize();
        sight * (b * (1.0 - z.dot(&sight).abs()))
    }

    /// The readings reported with encoder quantisation.
    fn quantised(&self, state: &JointState<6>) -> JointState<6> {
        let mut s = *state;
        for (j, q) in s.q.iter_mut().enumerate() {
            let (step, zero) = self.encoder(j);
            *q = zero + step * ((*q - zero) / step).round();
        }
        s
    }
}

/// A rotation vector's matrix of the antisymmetric part of a shear with `y += s·x`,
/// `z += s'·y`: the rotation a rigid-body fit of sheared markers reports.
fn shear_rotation(s: f64, s2: f64) -> Matrix3<f64> {
    rotation_exp(&Vector3::new(s2 / 2.0, 0.0, s / 2.0))
}

impl PoseEffect for Outside3Effect {
    fn pose(&self, truth: &Robot<6>, state: &JointState<6>, t: Option<f64>) -> Transform {
        let q = state.q;
        let arm = match self.kind {
            Outside3::TransmissionCoupling => {
                let mut d = [0.0; 6];
                d[2] = self.coupling() * q[1];
                turned(truth, &d)
            }
            Outside3::ThermalJointZero => turned(truth, &self.zero_drift(state.temp_c)),
            _ => *truth,
        };
        let pose = arm.fk(state).unwrap();
        let p = pose.translation.vector;
        let rot = *pose.rotation.matrix();
        match self.kind {
            Outside3::InstrumentShear => {
                let (s, s2) = self.shear();
                let sheared = Vector3::new(p.x, p.y + s * p.x, p.z + s2 * p.y);
                transform(shear_rotation(s, s2) * rot, sheared)
            }
            Outside3::RandomWalkDrift => transform(rot, p + self.wander(t)),
            Outside3::ViewingAngleBias => {
                let z = rot.column(2).into_owned();
                transform(rot, p + self.viewing_bias(&p, &z))
            }
            _ => pose,
        }
    }

    fn reported(&self, state: &JointState<6>) -> JointState<6> {
        match self.kind {
            Outside3::EncoderQuantisation => self.quantised(state),
            _ => *state,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::aria;

    /// An effect of `kind` at size 1 with every normal coefficient `c` and every uniform `u`.
    fn effect(kind: Outside3, c: f64, u: f64) -> Outside3Effect {
        Outside3Effect {
            kind,
            size: 1.0,
            normal: [c; 12],
            uniform: [u; 12],
            seed: 7,
        }
    }

    fn seed_state() -> JointState<6> {
        JointState::new(aria::TOOL_SEED_Q)
    }

    /// Random joint states around the seed configuration.
    fn random_states(n: usize) -> Vec<JointState<6>> {
        let mut rng = SplitMix64::new(11);
        (0..n)
            .map(|_| {
                let q = std::array::from_fn(|j| aria::TOOL_SEED_Q[j] + rng.range(-1.0, 1.0));
                JointState::new(q)
            })
            .collect()
    }

    fn moved(e: &Outside3Effect, st: &JointState<6>, t: Option<f64>) -> Transform {
        e.pose(&aria::nominal(), st, t)
    }

    fn plain(st: &JointState<6>) -> Transform {
        aria::nominal().fk(st).unwrap()
    }

    fn rotation_between(a: &Transform, b: &Transform) -> f64 {
        kincal::pose::rotation_log(&(a.rotation.matrix() * b.rotation.matrix().transpose())).norm()
    }

    #[test]
    fn instrument_shear_moves_y_by_s_x_and_z_by_s2_y() {
        let e = effect(Outside3::InstrumentShear, 1.0, 0.5);
        let st = seed_state();
        let (a, b) = (plain(&st).translation.vector, moved(&e, &st, None));
        let d = b.translation.vector - a;
        // s = s' = 1 mrad: y moves by 1e-3·x, z by 1e-3·y (tenths of a millimetre here).
        assert!(a.x.abs() > 0.05 && a.y.abs() > 0.05, "{a:?}");
        assert!(d.x.abs() < 1e-15, "{d:?}");
        assert!((d.y - 1e-3 * a.x).abs() < 1e-12, "{d:?}");
        assert!((d.z - 1e-3 * a.y).abs() < 1e-12, "{d:?}");
        // The reported orientation turns by the shear's antisymmetric part, √2/2 mrad.
        let angle = rotation_between(&b, &plain(&st));
        assert!((angle - 0.5e-3 * 2f64.sqrt()).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn transmission_coupling_turns_joint_3_by_k_q2() {
        let e = effect(Outside3::TransmissionCoupling, 1.0, 0.5);
        let st = seed_state();
        // The tool turns by exactly k·q2 = 1 mrad · 0.775 (k·q3 would be 1.04 mrad).
        let angle = rotation_between(&moved(&e, &st, None), &plain(&st));
        assert!((angle - 1e-3 * st.q[1].abs()).abs() < 1e-9, "{angle}");
        // The same as the arm read with q3 + k·q2.
        let mut read = st;
        read.q[2] += 1e-3 * st.q[1];
        let d = moved(&e, &st, None).translation.vector - plain(&read).translation.vector;
        assert!(d.norm() < 1e-12, "{d:?}");
    }

    #[test]
    fn thermal_joint_zero_turns_the_joints_by_k_times_the_warming() {
        let mut e = effect(Outside3::ThermalJointZero, 0.0, 0.5);
        e.normal[0] = 1.0;
        let mut st = seed_state();
        // No recorded temperature, or the reference one: no drift.
        assert_eq!(moved(&e, &st, None), plain(&st));
        st.temp_c = Some(REFERENCE_C);
        assert!(rotation_between(&moved(&e, &st, None), &plain(&st)) < 1e-15);
        // 20 K warmer: joint 1 turns by 20 µrad/K · 20 K = 0.4 mrad.
        st.temp_c = Some(40.0);
        let angle = rotation_between(&moved(&e, &st, None), &plain(&st));
        assert!((angle - 4e-4).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn encoder_quantisation_rounds_the_readings_to_the_step() {
        let e = effect(Outside3::EncoderQuantisation, 0.0, 0.1);
        // uniform 0.1: 12 bits, a step of 2π/4096 = 1.53 mrad, zero at a tenth of a step.
        let step = 2.0 * PI / 4096.0;
        let states = random_states(2000);
        let (mut max, mut sq) = (0.0f64, 0.0);
        for st in &states {
            let r = e.reported(st);
            for j in 0..6 {
                let d = r.q[j] - st.q[j];
                max = max.max(d.abs());
                sq += d * d;
                let k = (r.q[j] - 0.1 * step) / step;
                assert!((k - k.round()).abs() < 1e-6, "off the grid: {k}");
            }
            // The arm stands at the true angle: the pose is unchanged.
            assert_eq!(moved(&e, st, None), plain(st));
        }
        let rms = (sq / (6 * states.len()) as f64).sqrt();
        assert!(
            max <= step / 2.0 + 1e-15 && max > 0.45 * step,
            "{max} vs {step}"
        );
        let uniform_rms = step / 12f64.sqrt();
        assert!(
            (rms / uniform_rms - 1.0).abs() < 0.1,
            "{rms} vs {uniform_rms}"
        );
    }

    #[test]
    fn encoder_quantisation_reaches_the_measured_readings_not_the_poses() {
        let e = effect(Outside3::EncoderQuantisation, 0.0, 0.1);
        let states: Vec<_> = random_states(20).into_iter().map(|s| (s, 1)).collect();
        let truth = aria::nominal();
        let mut rng = SplitMix64::new(3);
        let (data, _) = crate::outside::measure(
            &truth,
            &[e],
            &states,
            &crate::outside::MOCAP,
            false,
            &mut rng,
        );
        for (m, (st, _)) in data.iter().zip(&states) {
            assert_eq!(m.state, e.quantised(st));
            assert_ne!(m.state.q, st.q);
            assert_eq!(m.pose, truth.fk(st).unwrap());
        }
    }

    #[test]
    fn encoder_steps_span_12_to_14_bits() {
        let bits = |u: f64| {
            let (step, _) = effect(Outside3::EncoderQuantisation, 0.0, u).encoder(0);
            (2.0 * PI / step).log2().round()
        };
        assert_eq!([bits(0.0), bits(0.5), bits(0.99)], [12.0, 13.0, 14.0]);
    }

    /// The wander of `e` at `n` evenly spaced places of the session.
    fn wander_path(e: &Outside3Effect, n: usize) -> Vec<Vector3<f64>> {
        let st = seed_state();
        let p0 = plain(&st).translation.vector;
        (0..n)
            .map(|l| {
                moved(e, &st, Some(l as f64 / (n - 1) as f64))
                    .translation
                    .vector
                    - p0
            })
            .collect()
    }

    /// RMS distance of `path` from its least-squares line over the session order.
    fn off_line_rms(path: &[Vector3<f64>]) -> f64 {
        let n = path.len() as f64;
        let t: Vec<f64> = (0..path.len()).map(|l| l as f64 / (n - 1.0)).collect();
        let tm = t.iter().sum::<f64>() / n;
        let pm = path.iter().sum::<Vector3<f64>>() / n;
        let stt: f64 = t.iter().map(|x| (x - tm).powi(2)).sum();
        let slope = t
            .iter()
            .zip(path)
            .map(|(x, p)| (p - pm) * (x - tm))
            .sum::<Vector3<f64>>()
            / stt;
        let ss: f64 = t
            .iter()
            .zip(path)
            .map(|(x, p)| (p - pm - slope * (x - tm)).norm_squared())
            .sum();
        (ss / n).sqrt()
    }

    #[test]
    fn random_walk_drift_wanders_a_few_tenths_of_a_mm_not_along_a_line() {
        let (mut sq, mut off, runs) = (0.0, 0.0, 40);
        for seed in 0..runs {
            let mut e = effect(Outside3::RandomWalkDrift, 0.0, 0.5);
            e.seed = seed;
            let path = wander_path(&e, 80);
            sq += path.iter().map(|d| d.norm_squared()).sum::<f64>() / 80.0;
            off += off_line_rms(&path);
            // Off the session (withheld poses, the arm's truth): no wander.
            assert_eq!(moved(&e, &seed_state(), None), plain(&seed_state()));
        }
        // Stationary σ 0.2 mm per axis: about 0.35 mm in norm.
        let rms = (sq / runs as f64).sqrt();
        assert!((rms / (WANDER_M * 3f64.sqrt()) - 1.0).abs() < 0.25, "{rms}");
        // A straight line over the session leaves a good part of it.
        let off = off / runs as f64;
        assert!(off > 0.4 * WANDER_M, "{off}");
    }

    /// Mean correlation of the wander's components `lag` of the session apart.
    fn wander_correlation(lag: usize, n: usize, runs: u64) -> f64 {
        let (mut cross, mut sq) = (0.0, 0.0);
        for seed in 0..runs {
            let mut e = effect(Outside3::RandomWalkDrift, 0.0, 0.5);
            e.seed = 100 + seed;
            let path = wander_path(&e, n);
            cross += path
                .windows(lag + 1)
                .map(|w| w[0].dot(&w[lag]))
                .sum::<f64>();
            sq += path
                .windows(lag + 1)
                .map(|w| w[0].norm_squared())
                .sum::<f64>();
        }
        cross / sq
    }

    #[test]
    fn random_walk_drift_forgets_over_a_fifth_of_the_session() {
        // AR(1) with a correlation time of a fifth of the session: e^-1 = 0.37 a fifth
        // apart, e^-0.05 = 0.95 a hundredth apart, e^-3 = 0.05 three fifths apart.
        let (near, fifth, far) = (
            wander_correlation(1, 101, 40),
            wander_correlation(20, 101, 40),
            wander_correlation(60, 101, 40),
        );
        assert!(near > 0.9, "{near}");
        assert!((0.2..0.55).contains(&fifth), "{fifth}");
        assert!(far < 0.2, "{far}");
    }

    #[test]
    fn viewing_bias_is_b_side_on_and_nothing_head_on() {
        let e = effect(Outside3::ViewingAngleBias, 0.0, 0.5);
        let b = VIEW_BIAS_M;
        let p = region_centre();
        let sight = (p - e.camera()).normalize();
        // Tool z along the line of sight (either way): no bias.
        assert!(e.viewing_bias(&p, &sight).norm() < 1e-15);
        assert!(e.viewing_bias(&p, &-sight).norm() < 1e-15);
        // Side on: b along the line of sight, away from the camera.
        let side = sight.cross(&Vector3::x()).normalize();
        let d = e.viewing_bias(&p, &side);
        assert!((d - sight * b).norm() < 1e-15, "{d:?}");
        // At 60°: b·(1 − cos 60°) = b/2.
        let z = sight * 0.5 + side * 0.75f64.sqrt();
        assert!((e.viewing_bias(&p, &z).norm() - b / 2.0).abs() < 1e-15);
    }

    #[test]
    fn viewing_bias_moves_the_arms_poses_by_up_to_b_along_the_sight() {
        let e = effect(Outside3::ViewingAngleBias, 0.0, 0.3);
        let mut largest = 0.0f64;
        for st in random_states(200) {
            let (a, m) = (plain(&st), moved(&e, &st, None));
            let d = m.translation.vector - a.translation.vector;
            let sight = (a.translation.vector - e.camera()).normalize();
            assert!(
                d.cross(&sight).norm() < 1e-15 && d.dot(&sight) >= 0.0,
                "{d:?}"
            );
            assert!(d.norm() <= VIEW_BIAS_M + 1e-15);
            assert_eq!(m.rotation, a.rotation);
            largest = largest.max(d.norm());
        }
        assert!(largest > 0.5 * VIEW_BIAS_M, "{largest}");
    }
}
