//! A SECOND, independent generator of effects outside kincal's library (issue #12, item 7),
//! written after the decision rules were fixed against `outside.rs`, to measure the
//! over-claim rate on effects and magnitudes the rules were not developed on. It is a
//! measuring instrument only: do not tune the diagnosis to it.
//!
//! Different kinds from `outside.rs` (which has link bending, quadratic compliance, a
//! compliant mount, an instrument scale error, a flexing tool, an axis wobble and a third
//! harmonic): a gravity sag of the forearm, a drift over the session (not a function of
//! q), a cable spring tilting an axis, motor-side encoder eccentricity (a gear-ratio
//! harmonic), a periodic nonlinearity of the instrument's x scale, and a gravity-loaded
//! lost motion with a dead band.
#![allow(dead_code)]

use kincal::params::LinkParam;
use kincal::pose::transform;
use kincal::rng::SplitMix64;
use kincal::{JointState, ParamId, Robot, Transform};
use nalgebra::Vector3;

use crate::outside::PoseEffect;

/// The second family of out-of-library effects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outside2 {
    /// The forearm sags under its weight: the tool point drops by f·|cos(q2 + q3)|
    /// (f ≈ 0.4 mm), largest with the forearm horizontal.
    GravitySag,
    /// A thermal drift of the set-up over the session, not recorded: the measured position
    /// moves linearly with the pose's place in the session, v·(t − ½), |v| ≈ 0.5 mm.
    SessionDrift,
    /// A cable loom acts as a torsion spring on joint 1 and tilts the joint-2 axis:
    /// Δα_2 = k·(q1 − q_c), k ≈ 2 mrad/rad.
    CableSpring,
    /// Motor-side encoder eccentricity seen through a 50:1 gear: Δθ_j = e_j·sin(50·q_j + φ_j),
    /// e_j ≈ 0.15 mrad (a pose-to-pose scatter, no smooth function of q).
    MotorEccentricity,
    /// A periodic nonlinearity of the instrument's x scale (interpolation error of a
    /// linear scale): x ← x + a·sin(2π·x/λ + φ), λ = 0.25 m, a ≈ 0.2 mm.
    ScaleNonlinearity,
    /// Gravity-loaded lost motion with a dead band: the gear lash falls to the side gravity
    /// loads it, linearly within |τ_j| < 3 N·m, saturated beyond: Δθ_j = b_j·clamp(τ_j/3,
    /// −1, 1), b_j ≈ 0.6 mrad.
    GravityLash,
}

impl Outside2 {
    pub const ALL: [Outside2; 6] = [
        Outside2::GravitySag,
        Outside2::SessionDrift,
        Outside2::CableSpring,
        Outside2::MotorEccentricity,
        Outside2::ScaleNonlinearity,
        Outside2::GravityLash,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Outside2::GravitySag => "gravity_sag",
            Outside2::SessionDrift => "session_drift",
            Outside2::CableSpring => "cable_spring",
            Outside2::MotorEccentricity => "motor_eccentricity",
            Outside2::ScaleNonlinearity => "scale_nonlinearity",
            Outside2::GravityLash => "gravity_lash",
        }
    }
}

/// One drawn effect of the second family.
#[derive(Debug, Clone, Copy)]
pub struct Outside2Effect {
    pub kind: Outside2,
    pub size: f64,
    coef: [f64; 12],
}

fn link_param(link: usize, kind: LinkParam) -> kincal::ParamIndex {
    ParamId::Link { link, kind }.index(6)
}

impl Outside2Effect {
    pub fn draw(kind: Outside2, size: f64, rng: &mut SplitMix64) -> Self {
        let mut coef = [0.0; 12];
        for c in &mut coef {
            *c = rng.normal();
        }
        Outside2Effect { kind, size, coef }
    }
}

impl PoseEffect for Outside2Effect {
    fn pose(&self, truth: &Robot<6>, state: &JointState<6>, t: Option<f64>) -> Transform {
        let q = state.q;
        let s = self.size;
        let c = &self.coef;
        let mut r = *truth;
        let bump = |r: &mut Robot<6>, i: kincal::ParamIndex, d: f64| {
            let v = r.param(i).unwrap();
            r.set_param(i, v + d).unwrap();
        };
        match self.kind {
            Outside2::CableSpring => {
                bump(
                    &mut r,
                    link_param(1, LinkParam::Alpha),
                    s * 2e-3 * (q[0] - 0.3 * c[0]),
                );
            }
            Outside2::MotorEccentricity => {
                for j in 0..6 {
                    let d = s * 1.5e-4 * c[j] * (50.0 * q[j] + 3.0 * c[6 + j]).sin();
                    bump(&mut r, link_param(j, LinkParam::Theta0), d);
                }
            }
            Outside2::GravityLash => {
                let tau = truth.gravity_torques(&q);
                for (j, tj) in tau.iter().enumerate() {
                    let b = s * 6e-4 * (0.5 + 0.5 * c[j].abs());
                    let d = b * (tj / 3.0).clamp(-1.0, 1.0);
                    bump(&mut r, link_param(j, LinkParam::Theta0), d);
                }
            }
            _ => {}
        }
        let pose = r.fk(state).unwrap();
        let p = pose.translation.vector;
        let rot = *pose.rotation.matrix();
        match self.kind {
            Outside2::GravitySag => {
                let f = s * 4e-4 * (1.0 + 0.2 * c[0].abs());
                transform(rot, p - Vector3::z() * (f * (q[1] + q[2]).cos().abs()))
            }
            Outside2::SessionDrift => {
                let v = Vector3::new(c[0], c[1], c[2]).normalize() * (s * 5e-4);
                transform(rot, p + v * (t.unwrap_or(0.5) - 0.5))
            }
            Outside2::ScaleNonlinearity => {
                let a = s * 2e-4;
                let phase = c[0];
                let dx = a * (2.0 * std::f64::consts::PI * p.x / 0.25 + phase).sin();
                transform(rot, p + Vector3::x() * dx)
            }
            _ => pose,
        }
    }
}
