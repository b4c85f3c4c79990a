//! A seeded generator of measurement sessions with effects OUTSIDE kincal's library, applied
//! to the simulated true poses by this test code (the library never sees the model), and of
//! the harder session types of issue #12: instruments (mocap, laser tracker), the paper's
//! Table 2 regime, misstated σ, outliers.
#![allow(dead_code)]

use kincal::identify::{
    Algorithm, ComponentMask, IdentifyOptions, Measurement, Workspace, identify,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::LinkParam;
use kincal::pose::{rotation_exp, transform};
use kincal::rng::SplitMix64;
use kincal::sim::{SessionConfig, add_noise, simulate_session};
use kincal::{JointState, ParamId, Robot, Transform, aria};
use nalgebra::Vector3;

/// Effects outside the library, each a smooth function of the joint readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outside {
    /// Out-of-plane bending of the upper arm with its angle to gravity: Δβ_2 = b·cos q2
    /// (b ≈ 5 mrad).
    LinkBending,
    /// Hardening joint compliance: Δθ_j = c·τ_j·|τ_j| (c ≈ 2e-5 rad/(N·m)²).
    QuadraticCompliance,
    /// A compliant mount: the base tilts with the arm's load moment, ε = k·(−y, x, 0)·W
    /// (x, y the tool position as a proxy of the arm's centre of mass, W = 76 N, k ≈ 3e-4
    /// rad/(N·m), a mobile cart).
    CompliantMount,
    /// Anisotropic scale error of the instrument about its origin (−1, 0.5, 0) m:
    /// p ← c + S·(p − c), S = diag(1 + s) (|s| ≈ 1.5e-3).
    InstrumentScale,
    /// A tool that flexes under its weight: tip displaced along gravity's component normal
    /// to the tool axis by f ≈ 1 mm, rotated by 1.5·f/0.1 m towards gravity.
    ToolFlex,
    /// Bearing wobble of joint 3: Δα_3 = w·sin(q3 + φ) (w ≈ 4 mrad).
    AxisWobble,
    /// Third-harmonic transmission error (the library's cyclic model stops at the second):
    /// Δθ_j = a_j·sin 3q_j + b_j·cos 3q_j (σ ≈ 1 mrad).
    ThirdHarmonic,
}

impl Outside {
    pub const ALL: [Outside; 7] = [
        Outside::LinkBending,
        Outside::QuadraticCompliance,
        Outside::CompliantMount,
        Outside::InstrumentScale,
        Outside::ToolFlex,
        Outside::AxisWobble,
        Outside::ThirdHarmonic,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Outside::LinkBending => "link_bending",
            Outside::QuadraticCompliance => "quadratic_compliance",
            Outside::CompliantMount => "compliant_mount",
            Outside::InstrumentScale => "instrument_scale",
            Outside::ToolFlex => "tool_flex",
            Outside::AxisWobble => "axis_wobble",
            Outside::ThirdHarmonic => "third_harmonic",
        }
    }
}

/// One drawn out-of-library effect: kind, size factor (1 = realistic upper size) and its
/// random coefficients.
#[derive(Debug, Clone, Copy)]
pub struct OutsideEffect {
    pub kind: Outside,
    pub size: f64,
    coef: [f64; 12],
}

fn link_param(link: usize, kind: LinkParam) -> kincal::ParamIndex {
    ParamId::Link { link, kind }.index(6)
}

impl OutsideEffect {
    pub fn draw(kind: Outside, size: f64, rng: &mut SplitMix64) -> Self {
        let mut coef = [0.0; 12];
        for c in &mut coef {
            *c = rng.normal();
        }
        OutsideEffect { kind, size, coef }
    }

    /// The true pose of the arm `truth` with this effect at `state`, as the instrument
    /// reports it (before noise).
    pub fn true_pose(&self, truth: &Robot<6>, state: &JointState<6>) -> Transform {
        let q = state.q;
        let s = self.size;
        let c = &self.coef;
        let mut r = *truth;
        let bump = |r: &mut Robot<6>, i: kincal::ParamIndex, d: f64| {
            let v = r.param(i).unwrap();
            r.set_param(i, v + d).unwrap();
        };
        match self.kind {
            Outside::LinkBending => {
                let d = s * 5e-3 * q[1].cos();
                bump(&mut r, link_param(1, LinkParam::Beta), d);
            }
            Outside::QuadraticCompliance => {
                let tau = truth.gravity_torques(&q);
                for (j, t) in tau.iter().enumerate() {
                    let d = s * 2e-5 * t * t.abs();
                    bump(&mut r, link_param(j, LinkParam::Theta0), d);
                }
            }
            Outside::AxisWobble => {
                bump(
                    &mut r,
                    link_param(2, LinkParam::Alpha),
                    s * 4e-3 * (q[2] + c[0]).sin(),
                );
            }
            Outside::ThirdHarmonic => {
                for j in 0..6 {
                    let d = s * 1e-3 * (c[j] * (3.0 * q[j]).sin() + c[6 + j] * (3.0 * q[j]).cos());
                    bump(&mut r, link_param(j, LinkParam::Theta0), d);
                }
            }
            _ => {}
        }
        let t = r.fk(state).unwrap();
        let p = t.translation.vector;
        let rot = *t.rotation.matrix();
        match self.kind {
            Outside::CompliantMount => {
                let k = s * 3e-4 * 76.0;
                let eps = Vector3::new(-p.y, p.x, 0.0) * k;
                let rm = rotation_exp(&eps);
                transform(rm * rot, rm * p)
            }
            Outside::InstrumentScale => {
                let origin = Vector3::new(-1.0, 0.5, 0.0);
                let sc = Vector3::new(c[0], c[1], c[2]) * (s * 1.5e-3);
                let d = p - origin;
                transform(rot, p + d.component_mul(&sc))
            }
            Outside::ToolFlex => {
                let f = s * 1e-3 * (1.0 + 0.3 * c[0].abs());
                let z = rot.column(2).into_owned();
                let g = Vector3::new(0.0, 0.0, -1.0);
                let g_perp = g - z * g.dot(&z);
                let axis = z.cross(&g) * (1.5 * f / 0.1);
                transform(rotation_exp(&axis) * rot, p + g_perp * f)
            }
            _ => t,
        }
    }
}

/// An effect the test applies to the true pose (the library never sees it).
pub trait PoseEffect {
    /// The pose the instrument reports (before noise) at `state` on `truth` with this
    /// effect; `t` is the row's place in the session in [0, 1] (`None`: mid-session).
    fn pose(&self, truth: &Robot<6>, state: &JointState<6>, t: Option<f64>) -> Transform;
    /// The joint state the controller reports when the arm's true state is `state` (a
    /// readings-side effect, such as encoder quantisation, changes it; the pose is always
    /// that of the true state). Default: `state` itself.
    fn reported(&self, state: &JointState<6>) -> JointState<6> {
        *state
    }
}

/// The joint state reported at the true state `st` with every effect in `outside`.
pub fn reported<E: PoseEffect>(outside: &[E], st: &JointState<6>) -> JointState<6> {
    outside.iter().fold(*st, |s, e| e.reported(&s))
}

impl PoseEffect for OutsideEffect {
    fn pose(&self, truth: &Robot<6>, state: &JointState<6>, _t: Option<f64>) -> Transform {
        self.true_pose(truth, state)
    }
}

/// The instrument.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instrument {
    pub name: &'static str,
    pub sigma_pos_m: f64,
    pub sigma_rot_rad: f64,
    pub mask: ComponentMask,
}

/// Optical motion capture: 0.1 mm and 0.05° per axis, full pose.
pub const MOCAP: Instrument = Instrument {
    name: "mocap",
    sigma_pos_m: 1e-4,
    sigma_rot_rad: 0.05 * std::f64::consts::PI / 180.0,
    mask: ComponentMask::ALL,
};
/// Laser tracker: 0.02 mm per axis, position only.
pub const LASER: Instrument = Instrument {
    name: "laser",
    sigma_pos_m: 2e-5,
    sigma_rot_rad: 0.05 * std::f64::consts::PI / 180.0,
    mask: ComponentMask::POSITION,
};

/// How the poses of a session are chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Design {
    /// `poses` random poses of the biopsy region, the first `repeated` measured twice.
    Random { poses: usize, repeated: usize },
    /// The paper's ten Table 2 tool poses, each measured `times` times, plus `extra`
    /// random poses measured once.
    Table2 { times: usize, extra: usize },
}

/// Joint states of a session on `truth` (IK on the arm the library can describe; the
/// out-of-library effect only changes what is measured there) with their `pose_id`s.
pub fn states(truth: &Robot<6>, design: Design, rng: &mut SplitMix64) -> Vec<(JointState<6>, u32)> {
    let random = |n: usize, rep: usize, rng: &mut SplitMix64| {
        let cfg = SessionConfig {
            poses: n,
            repeated: rep,
            sigma_pos_m: 0.0,
            sigma_rot_rad: 0.0,
            ..SessionConfig::blind_training()
        };
        let total = cfg.measurements();
        let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); total];
        let mut groups = vec![0u32; total];
        simulate_session(truth, &aria::TOOL_SEED_Q, &cfg, rng, &mut data, &mut groups).unwrap();
        data.iter()
            .zip(&groups)
            .map(|(m, &g)| (m.state, g))
            .collect::<Vec<_>>()
    };
    match design {
        Design::Random { poses, repeated } => random(poses, repeated, rng),
        Design::Table2 { times, extra } => {
            let ik = IkOptions {
                max_iterations: 100,
                tol_pos_m: 1e-11,
                tol_rot_rad: 1e-11,
                extra_seeds: 0,
                first_solution: true,
            };
            // Commanded as in the paper: readings from the nominal model's inverse kinematics.
            let nominal = aria::nominal();
            let mut out = Vec::new();
            for l in 0..10 {
                let target = aria::tool_pose(l).unwrap();
                let seed = JointState::new(aria::TOOL_SEED_Q);
                let sol = solve_ik(&nominal, &target, &seed, &ik).unwrap();
                let mut st = seed;
                st.q = sol.q;
                for _ in 0..times {
                    out.push((st, l as u32 + 1));
                }
            }
            if extra > 0 {
                for (st, g) in random(extra, 0, rng) {
                    out.push((st, g + 100));
                }
            }
            out
        }
    }
}

/// Measured poses at `states` (the arm's true states) on `truth` with the out-of-library
/// effects `outside`, instrument noise and mask, with the readings the effects report.
pub fn measure<E: PoseEffect>(
    truth: &Robot<6>,
    outside: &[E],
    states: &[(JointState<6>, u32)],
    inst: &Instrument,
    noisy: bool,
    rng: &mut SplitMix64,
) -> (Vec<Measurement<6>>, Vec<u32>) {
    let mut data = Vec::with_capacity(states.len());
    let mut groups = Vec::with_capacity(states.len());
    let last = states.len().saturating_sub(1).max(1) as f64;
    for (l, (st, g)) in states.iter().enumerate() {
        let pose = true_pose_at(truth, outside, st, Some(l as f64 / last));
        let pose = if noisy {
            add_noise(&pose, inst.sigma_pos_m, inst.sigma_rot_rad, rng)
        } else {
            pose
        };
        data.push(Measurement {
            state: reported(outside, st),
            pose,
            mask: inst.mask,
            weight: 1.0,
            point: None,
        });
        groups.push(*g);
    }
    (data, groups)
}

/// The true (noise-free) pose with every effect in `outside` (composed: each changes
/// what the previous one produced only through the pose, so apply at most one robot-level
/// and any number of pose-level effects).
pub fn true_pose<E: PoseEffect>(truth: &Robot<6>, outside: &[E], st: &JointState<6>) -> Transform {
    true_pose_at(truth, outside, st, None)
}

/// [`true_pose`] at place `t` of the session.
pub fn true_pose_at<E: PoseEffect>(
    truth: &Robot<6>,
    outside: &[E],
    st: &JointState<6>,
    t: Option<f64>,
) -> Transform {
    match outside {
        [] => truth.fk(st).unwrap(),
        [one] => one.pose(truth, st, t),
        [first, rest @ ..] => {
            // Add the other effects' pose changes to the first one's pose.
            let base = truth.fk(st).unwrap();
            let mut pose = first.pose(truth, st, t);
            for e in rest {
                let te = e.pose(truth, st, t);
                let dp = te.translation.vector - base.translation.vector;
                let dr = te.rotation.matrix() * base.rotation.matrix().transpose();
                pose = transform(dr * pose.rotation.matrix(), pose.translation.vector + dp);
            }
            pose
        }
    }
}

/// Size of what the geometric calibration cannot absorb, in units of the noise floor: the
/// RMS residual of a noise-free geometric calibration on the session's joint states, over
/// √3·σ, for position and (when measured) rotation. The fit starts from the truth's own
/// geometry (its global optimum without effects), so ρ measures the effect, not a local
/// minimum of a fit from the nominal arm (position-only data with ±5° errors can stall in
/// one: the diagnosis starts from the nominal arm and may see such a stall as a gap).
pub fn detectability<E: PoseEffect>(
    truth: &Robot<6>,
    outside: &[E],
    states: &[(JointState<6>, u32)],
    inst: &Instrument,
) -> (f64, f64) {
    let mut rng = SplitMix64::new(0);
    let (data, _) = measure(truth, outside, states, inst, false, &mut rng);
    let start = kincal::sim::only_effects(truth, kincal::EffectSet::NONE);
    let mut opts = IdentifyOptions::new(Algorithm::Ols, start.geometric_param_set());
    opts.weight_pos = inst.sigma_pos_m.powi(-2);
    opts.weight_rot = inst.sigma_rot_rad.powi(-2);
    opts.allow_data_deficiency = true;
    let mut ws = Box::<Workspace<64>>::default();
    let Ok(fit) = identify(&start, &data, &opts, &mut ws) else {
        return (f64::NAN, f64::NAN);
    };
    let (mut p2, mut r2) = (0.0, 0.0);
    for m in &data {
        let e = kincal::pose::pose_error(
            &m.pose,
            &fit.robot.fk(&m.state).unwrap(),
            kincal::OrientationError::Exact,
        );
        p2 += e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        r2 += e[3] * e[3] + e[4] * e[4] + e[5] * e[5];
    }
    let n = data.len() as f64;
    let rp = (p2 / n).sqrt() / (3f64.sqrt() * inst.sigma_pos_m);
    let rr = if inst.mask.has(3) {
        (r2 / n).sqrt() / (3f64.sqrt() * inst.sigma_rot_rad)
    } else {
        0.0
    };
    (rp, rr)
}

/// Replaces `k` rows by gross outliers: a 3–6 mm jump in a random direction, or (every
/// third) the joint row of another pose.
pub fn add_outliers(data: &mut [Measurement<6>], k: usize, rng: &mut SplitMix64) -> Vec<usize> {
    let mut rows = Vec::new();
    while rows.len() < k.min(data.len()) {
        let l = rng.below(data.len());
        if rows.contains(&l) {
            continue;
        }
        if rows.len() % 3 == 2 {
            let other = (l + 1 + rng.below(data.len() - 1)) % data.len();
            data[l].state.q = data[other].state.q;
        } else {
            let dir = Vector3::new(rng.normal(), rng.normal(), rng.normal()).normalize();
            let t = data[l].pose;
            data[l].pose = transform(
                *t.rotation.matrix(),
                t.translation.vector + dir * rng.range(3e-3, 6e-3),
            );
        }
        rows.push(l);
    }
    rows
}
