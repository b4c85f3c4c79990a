//! Simulated calibration sessions: the ground truth the diagnosis is checked against.
//!
//! A session is what a calibration experiment on a real arm produces: commanded poses in a
//! working region, the joint readings at which the (true, unknown) arm reaches them, and
//! the measured poses with instrument noise; some poses are measured again (same
//! `pose_id`) to give the noise floor. The true arm is any [`Robot`], with geometric
//! errors ([`perturb_geometry`]) and hidden effects ([`add_effect`]) of realistic size.
//!
//! Everything is deterministic for a given [`SplitMix64`] seed and writes into caller
//! slices (no heap), so the blind test suite, the benches and the CLI demo share it.

use core::f64::consts::PI;

use nalgebra::{Matrix3, Vector3};

use crate::effects::{Effect, EffectSet};
use crate::error::{Error, ParamIndex, Result};
use crate::identify::Measurement;
use crate::ik::{IkOptions, solve_ik};
use crate::model::{JointKind, JointState, Robot};
use crate::params::{CyclicTerm, FrameParam, ParamId};
use crate::pose::{Transform, rot_x, rotation_exp, transform};
use crate::rng::SplitMix64;

/// Where commanded poses are drawn: positions uniform in a box, orientations uniform within
/// a cone (a rotation of at most `cone_rad` about a uniformly random axis) around
/// `orientation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Lower corner of the position box \[m\].
    pub min_m: [f64; 3],
    /// Upper corner of the position box \[m\].
    pub max_m: [f64; 3],
    /// Central orientation of the tool.
    pub orientation: Matrix3<f64>,
    /// Largest rotation away from `orientation` \[rad\].
    pub cone_rad: f64,
}

/// Half-angle of the orientation cone of the biopsy region: 30°.
pub const BIOPSY_CONE_RAD: f64 = 30.0 * PI / 180.0;

impl Region {
    /// ARIA's biopsy working region ([`crate::aria::WORKING_REGION_MIN_M`] …) with the tool
    /// orientation of Table 2 (roll −155°, midway between its −150° and −160°) and a cone of
    /// [`BIOPSY_CONE_RAD`].
    #[must_use]
    pub fn aria_biopsy() -> Self {
        Region {
            min_m: crate::aria::WORKING_REGION_MIN_M,
            max_m: crate::aria::WORKING_REGION_MAX_M,
            orientation: rot_x(-155.0 * PI / 180.0),
            cone_rad: BIOPSY_CONE_RAD,
        }
    }

    /// A random pose of the region.
    pub fn sample(&self, rng: &mut SplitMix64) -> Transform {
        let p = Vector3::new(
            rng.range(self.min_m[0], self.max_m[0]),
            rng.range(self.min_m[1], self.max_m[1]),
            rng.range(self.min_m[2], self.max_m[2]),
        );
        // Uniform axis on the sphere, angle with density ∝ area of the cone's cap.
        let z = rng.range(-1.0, 1.0);
        let phi = rng.range(0.0, 2.0 * PI);
        let r = crate::math::sqrt((1.0 - z * z).max(0.0));
        let (s, c) = crate::math::sin_cos(phi);
        let axis = Vector3::new(r * c, r * s, z);
        let cos_cone = crate::math::cos(self.cone_rad);
        let cos_a = 1.0 - rng.uniform() * (1.0 - cos_cone);
        let angle = crate::math::atan2(crate::math::sqrt((1.0 - cos_a * cos_a).max(0.0)), cos_a);
        transform(rotation_exp(&(axis * angle)) * self.orientation, p)
    }
}

/// How a session is measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionConfig {
    /// Distinct commanded poses.
    pub poses: usize,
    /// How many of them are measured a second time (the first `repeated` poses, re-approached
    /// right after their first measurement, so at the same temperature).
    pub repeated: usize,
    /// Probability that a repeat approaches from the same directions as the first
    /// measurement (only those repeats show the pure instrument noise when there is
    /// backlash); otherwise every joint's direction is drawn afresh.
    pub same_approach_probability: f64,
    /// Instrument noise, 1σ per position axis \[m\] …
    pub sigma_pos_m: f64,
    /// … and per rotation axis \[rad\] (a rotation vector with this σ per component).
    pub sigma_rot_rad: f64,
    /// Record the approach direction of every joint (random ±1 per pose).
    pub record_approach: bool,
    /// Record the arm temperature: it rises linearly over the session from the first to
    /// the second value [°C] (poses are visited in random order, so temperature is not
    /// tied to position).
    pub temperature_c: Option<[f64; 2]>,
    /// Where the poses are.
    pub region: Region,
    /// Keep the arm on the seed's branch: targets whose inverse-kinematics solution moves
    /// any joint farther than this from the seed are drawn again (a flipped wrist or
    /// shoulder is another arm configuration, not another pose of the same experiment).
    pub branch_travel_rad: f64,
}

impl SessionConfig {
    /// The blind-suite session: 60 poses, 20 of them repeated (80 measurements), half of
    /// the repeats from the same directions, 0.1 mm and 0.02° noise per axis, approach
    /// directions and a 22 → 42 °C temperature ramp recorded, ARIA's biopsy region, joints
    /// within 1.5 rad of the seed.
    #[must_use]
    pub fn blind_training() -> Self {
        SessionConfig {
            poses: 60,
            repeated: 20,
            same_approach_probability: 0.5,
            sigma_pos_m: 1e-4,
            sigma_rot_rad: 0.02 * PI / 180.0,
            record_approach: true,
            temperature_c: Some([22.0, 42.0]),
            region: Region::aria_biopsy(),
            branch_travel_rad: 1.5,
        }
    }
    /// Number of measurements the session writes.
    #[must_use]
    pub fn measurements(&self) -> usize {
        self.poses + self.repeated.min(self.poses)
    }
}

/// Attempts at drawing a reachable target before giving up on a pose.
const MAX_DRAWS_PER_POSE: usize = 200;

/// Inverse-kinematics settings of the simulation: first converging seed (the caller's seed
/// first, so poses stay on its branch), tight tolerances.
fn ik_options() -> IkOptions {
    IkOptions {
        max_iterations: 100,
        tol_pos_m: 1e-11,
        tol_rot_rad: 1e-11,
        extra_seeds: 0,
        first_solution: true,
    }
}

/// Adds instrument noise to a pose: `N(0, σ_p²)` per position axis and a rotation vector
/// `N(0, σ_r²)` per axis applied in the base frame.
pub fn add_noise(
    pose: &Transform,
    sigma_pos_m: f64,
    sigma_rot_rad: f64,
    rng: &mut SplitMix64,
) -> Transform {
    let dp = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sigma_pos_m;
    let dr = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sigma_rot_rad;
    transform(
        rotation_exp(&dr) * pose.rotation.matrix(),
        pose.translation.vector + dp,
    )
}

fn random_approach<const N: usize>(rng: &mut SplitMix64) -> [f64; N] {
    let mut s = [0.0; N];
    for v in s.iter_mut() {
        *v = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    }
    s
}

/// Simulates a session on the true arm `truth`: for each commanded pose, a target drawn in
/// the region is solved by inverse kinematics on `truth` from `seed_q` (effects
/// compensated, so the readings are those at which the true arm reaches the target), and
/// measured with noise; the first `cfg.repeated` poses are measured again right after
/// (the same readings and temperature; new approach directions with probability
/// 1 − `same_approach_probability`). Writes `cfg.measurements()` measurements into `out`
/// and their `pose_id`s (1-based) into `groups`; returns the number written. Stored order:
/// all first measurements, then the repeats, so the row order is not the simulated time
/// order (the temperature ramp follows the first measurements).
pub fn simulate_session<const N: usize>(
    truth: &Robot<N>,
    seed_q: &[f64; N],
    cfg: &SessionConfig,
    rng: &mut SplitMix64,
    out: &mut [Measurement<N>],
    groups: &mut [u32],
) -> Result<usize> {
    let total = cfg.measurements();
    if out.len() < total || groups.len() < total {
        return Err(Error::CapacityExceeded {
            needed: total,
            capacity: out.len().min(groups.len()),
        });
    }
    let ik = ik_options();
    for k in 0..cfg.poses {
        let approach = cfg.record_approach.then(|| random_approach::<N>(rng));
        let temp_c = cfg.temperature_c.map(|[a, b]| {
            let t = if cfg.poses > 1 {
                k as f64 / (cfg.poses - 1) as f64
            } else {
                0.0
            };
            a + (b - a) * t
        });
        let mut state = JointState {
            q: *seed_q,
            approach,
            temp_c,
        };
        let mut found = false;
        for _ in 0..MAX_DRAWS_PER_POSE {
            let target = cfg.region.sample(rng);
            let Ok(sol) = solve_ik(truth, &target, &state, &ik) else {
                continue;
            };
            let travel = sol
                .q
                .iter()
                .zip(seed_q.iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if travel <= cfg.branch_travel_rad {
                state.q = sol.q;
                found = true;
                break;
            }
        }
        if !found {
            return Err(Error::Unreachable {
                residual_pos_m: f64::INFINITY,
                residual_rot_rad: f64::INFINITY,
            });
        }
        let pose = add_noise(&truth.fk(&state)?, cfg.sigma_pos_m, cfg.sigma_rot_rad, rng);
        out[k] = Measurement {
            state,
            pose,
            mask: crate::identify::ComponentMask::ALL,
            weight: 1.0,
            point: None,
        };
        groups[k] = (k + 1) as u32;
    }
    for r in 0..cfg.repeated.min(cfg.poses) {
        let mut state = out[r].state;
        if state.approach.is_some() && rng.uniform() >= cfg.same_approach_probability {
            state.approach = Some(random_approach::<N>(rng));
        }
        let pose = add_noise(&truth.fk(&state)?, cfg.sigma_pos_m, cfg.sigma_rot_rad, rng);
        out[cfg.poses + r] = Measurement {
            state,
            pose,
            mask: crate::identify::ComponentMask::ALL,
            weight: 1.0,
            point: None,
        };
        groups[cfg.poses + r] = (r + 1) as u32;
    }
    Ok(total)
}

/// Random manufacturing errors: every geometric parameter the model identifies
/// ([`Robot::geometric_param_set`]: θ0, a, α and d or β of each link) moved by a uniform
/// amount within ±`length_m` (lengths) or ±`angle_rad` (angles). The parameters the model
/// does not identify stay nominal, so a geometric calibration can represent the result
/// exactly. The paper's tolerances are 5 mm and 5° (Section 2.4).
pub fn perturb_geometry<const N: usize>(
    robot: &Robot<N>,
    length_m: f64,
    angle_rad: f64,
    rng: &mut SplitMix64,
) -> Result<Robot<N>> {
    let mut r = *robot;
    for i in robot.geometric_param_set().iter() {
        let id = ParamId::from_index(ParamIndex(i), N)?;
        let tol = if id.is_length() { length_m } else { angle_rad };
        let v = r.param(ParamIndex(i))?;
        r.set_param(ParamIndex(i), v + rng.range(-tol, tol))?;
    }
    Ok(r)
}

/// Realistic upper magnitudes of each effect's parameters, used by [`add_effect`] at
/// `size = 1`. Sources of the orders of magnitude: motion-capture registration of base and
/// tool markers (millimetres, tenths of a degree), harmonic-drive stiffness (1e3…1e4
/// N·m/rad, i.e. 1e-4…1e-3 rad/(N·m)), encoder/gear-ratio scale errors (1e-4…1e-3),
/// transmission error of strain-wave gears (~1 arcmin), lost motion (1…5 arcmin),
/// aluminium links (2.3e-5 1/K).
pub mod magnitude {
    /// Base/tool frame translation per axis \[m\].
    pub const FRAME_TRANSLATION_M: f64 = 2e-3;
    /// Base/tool frame rotation per axis \[rad\] (0.3°).
    pub const FRAME_ROTATION_RAD: f64 = 0.3 * core::f64::consts::PI / 180.0;
    /// Joint compliance [rad/(N·m)].
    pub const COMPLIANCE: f64 = 1e-3;
    /// Joint scale error \[1\].
    pub const SCALE: f64 = 2e-3;
    /// Cyclic error coefficient, 1σ \[rad\] (~1 arcmin).
    pub const CYCLIC_RAD: f64 = 3e-4;
    /// Backlash \[rad\] (5 arcmin).
    pub const BACKLASH_RAD: f64 = 1.5e-3;
    /// Thermal expansion [1/K] (aluminium).
    pub const THERMAL_PER_K: f64 = 2.3e-5;
    /// Compliance of a prismatic joint along its axis \[m/N\] (a lifting column: 0.4 mm
    /// under 200 N).
    pub const PRISMATIC_COMPLIANCE_M_PER_N: f64 = 2e-6;
    /// Scale error of a prismatic joint's reading \[1\] (screw lead or rack pitch error).
    pub const PRISMATIC_SCALE: f64 = 5e-4;
    /// Lost motion of a prismatic joint \[m\] (a screw drive's 50 µm).
    pub const PRISMATIC_BACKLASH_M: f64 = 5e-5;
}

/// Gives `robot` the effect `effect` with random parameters of realistic size times `size`
/// (see [`magnitude`]): frame translations and rotations uniform in ±magnitude per axis;
/// compliance, backlash uniform in [0.2, 1]·magnitude per joint (non-negative, as
/// physically); scale ±[0.2, 1]·magnitude per joint; cyclic coefficients normal with σ =
/// magnitude; thermal κ = magnitude (times `size`). A prismatic joint takes the
/// magnitudes of a slide (`PRISMATIC_*`: the angular ones would move a column by
/// decimetres) and no cyclic terms; a sensor joint no cyclic or backlash terms (the core
/// does not apply them there: non-zero values would be parameters without a column).
/// The random draws are the same whatever the joint kinds, so a revolute arm's effects do
/// not depend on this. Parameters of the effect already set are replaced.
pub fn add_effect<const N: usize>(
    robot: &mut Robot<N>,
    effect: Effect,
    size: f64,
    rng: &mut SplitMix64,
) -> Result<()> {
    use magnitude as m;
    let kinds = robot.joint_kinds();
    let mut set = |id: ParamId, v: f64| robot.set_param(id.index(N), v * size);
    let signed = |rng: &mut SplitMix64| {
        let v = rng.range(0.2, 1.0);
        if rng.uniform() < 0.5 { -v } else { v }
    };
    match effect {
        Effect::BaseFrame | Effect::ToolFrame => {
            for k in FrameParam::ALL {
                let mag = if (k as usize) < 3 {
                    m::FRAME_TRANSLATION_M
                } else {
                    m::FRAME_ROTATION_RAD
                };
                let id = if effect == Effect::BaseFrame {
                    ParamId::Base(k)
                } else {
                    ParamId::Tool(k)
                };
                set(id, rng.range(-mag, mag))?;
            }
        }
        Effect::JointCompliance => {
            for (j, k) in kinds.iter().enumerate() {
                let mag = match k {
                    JointKind::Prismatic => m::PRISMATIC_COMPLIANCE_M_PER_N,
                    _ => m::COMPLIANCE,
                };
                set(ParamId::Compliance(j), rng.range(0.2, 1.0) * mag)?;
            }
        }
        Effect::JointScale => {
            for (j, k) in kinds.iter().enumerate() {
                let mag = match k {
                    JointKind::Prismatic => m::PRISMATIC_SCALE,
                    _ => m::SCALE,
                };
                set(ParamId::Scale(j), signed(rng) * mag)?;
            }
        }
        Effect::JointCyclic => {
            for (j, k) in kinds.iter().enumerate() {
                let mag = match k {
                    JointKind::Revolute => m::CYCLIC_RAD,
                    _ => 0.0,
                };
                for t in CyclicTerm::ALL {
                    let draw = rng.normal();
                    set(
                        ParamId::Cyclic(j, t),
                        if mag > 0.0 { draw * mag } else { 0.0 },
                    )?;
                }
            }
        }
        Effect::Backlash => {
            for (j, k) in kinds.iter().enumerate() {
                let mag = match k {
                    JointKind::Revolute => m::BACKLASH_RAD,
                    JointKind::Prismatic => m::PRISMATIC_BACKLASH_M,
                    JointKind::Sensor => 0.0,
                };
                set(ParamId::Backlash(j), rng.range(0.2, 1.0) * mag)?;
            }
        }
        Effect::Thermal => set(ParamId::Thermal, m::THERMAL_PER_K)?,
    }
    Ok(())
}

/// Multiplies every parameter of `effect` in `robot` by `factor`.
pub fn scale_effect<const N: usize>(
    robot: &mut Robot<N>,
    effect: Effect,
    factor: f64,
) -> Result<()> {
    for i in effect.params(N).iter() {
        let v = robot.param(ParamIndex(i))?;
        robot.set_param(ParamIndex(i), v * factor)?;
    }
    Ok(())
}

/// `robot` with only the effects in `keep` (the others' parameters set to zero).
#[must_use]
pub fn only_effects<const N: usize>(robot: &Robot<N>, keep: EffectSet) -> Robot<N> {
    let mut r = *robot;
    for e in Effect::ALL.into_iter().filter(|&e| !keep.contains(e)) {
        r.clear_effects(EffectSet::of(e));
    }
    r
}

/// Replaces every measured pose of `data` by the true arm's pose at its joint state, with
/// instrument noise ([`add_noise`]; σ = 0 gives exact poses).
pub fn measure<const N: usize>(
    truth: &Robot<N>,
    data: &mut [Measurement<N>],
    sigma_pos_m: f64,
    sigma_rot_rad: f64,
    rng: &mut SplitMix64,
) -> Result<()> {
    for m in data.iter_mut() {
        m.pose = add_noise(&m.model_pose(truth)?, sigma_pos_m, sigma_rot_rad, rng);
    }
    Ok(())
}

/// The size of a hidden effect in units of the noise floor: the RMS position residual that
/// `truth` leaves after a noise-free geometric calibration (OLS from `nominal`) on the
/// joint states of `data`, divided by √3·`sigma_pos_m` (the RMS position error of pure
/// noise). Overwrites the poses of `data` with `truth`'s exact poses.
pub fn effect_to_noise_ratio<const N: usize, const P: usize>(
    nominal: &Robot<N>,
    truth: &Robot<N>,
    data: &mut [Measurement<N>],
    sigma_pos_m: f64,
    ws: &mut crate::identify::Workspace<P>,
) -> Result<f64> {
    let mut rng = SplitMix64::new(0);
    measure(truth, data, 0.0, 0.0, &mut rng)?;
    let mut opts = crate::identify::IdentifyOptions::new(
        crate::identify::Algorithm::Ols,
        nominal.geometric_param_set(),
    );
    opts.allow_data_deficiency = true;
    let fit = crate::identify::identify(nominal, data, &opts, ws)?;
    Ok(fit.fitted.rms_pos_m / (crate::math::sqrt(3.0) * sigma_pos_m))
}

/// Joint compliance of the demo's "real ARIA" [rad/(N·m)] on every joint: a harmonic-drive
/// stiffness of ~1.7e3 N·m/rad (joints 1 and 6 carry no gravity torque, so theirs has no
/// effect).
pub const REAL_ARIA_COMPLIANCE: f64 = 6e-4;
/// Manufacturing errors of the "real ARIA": uniform within ±0.5 mm …
pub const REAL_ARIA_LENGTH_ERROR_M: f64 = 0.5e-3;
/// … and ±0.1° on every identified geometric parameter.
pub const REAL_ARIA_ANGLE_ERROR_RAD: f64 = 0.1 * PI / 180.0;
/// Seed of the "real ARIA"'s manufacturing errors.
pub const REAL_ARIA_SEED: u64 = 2024;

/// The tool pose at the centre of ARIA's biopsy region (roll −155°), where the "real
/// ARIA"'s encoder zeros were set.
#[must_use]
pub fn aria_region_center() -> Transform {
    let (lo, hi) = (
        crate::aria::WORKING_REGION_MIN_M,
        crate::aria::WORKING_REGION_MAX_M,
    );
    transform(
        rot_x(-155.0 * PI / 180.0),
        Vector3::new(
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ),
    )
}

/// A simulated "real ARIA" for the demo: the nominal arm with small manufacturing errors
/// ([`REAL_ARIA_LENGTH_ERROR_M`], [`REAL_ARIA_ANGLE_ERROR_RAD`], seed
/// [`REAL_ARIA_SEED`]) and joint compliance [`REAL_ARIA_COMPLIANCE`] on every joint, whose
/// encoder zeros were commissioned at the centre of the working region
/// ([`aria_region_center`]): θ0_j is lowered by the static deflection c_j·τ_j there, so
/// the nominal model is right at that posture and the gravity sag shows only as its
/// variation over the region. With 0.1 mm / 0.02° noise, a geometric calibration on the
/// biopsy region brings the validation error from ~2.5 mm to ~0.46 mm RMS (0.85 mm,
/// 0.43° at worst): the paper's ~5× improvement to 0.5 mm and 0.43°, far from the noise
/// floor (0.17 mm) a purely geometric arm reaches.
pub fn real_aria() -> Result<Robot<6>> {
    let nominal = crate::aria::nominal();
    let mut rng = SplitMix64::new(REAL_ARIA_SEED);
    let mut truth = perturb_geometry(
        &nominal,
        REAL_ARIA_LENGTH_ERROR_M,
        REAL_ARIA_ANGLE_ERROR_RAD,
        &mut rng,
    )?;
    let home = solve_ik(
        &nominal,
        &aria_region_center(),
        &JointState::new(crate::aria::TOOL_SEED_Q),
        &IkOptions::default(),
    )?;
    let tau = nominal.gravity_torques(&home.q);
    for j in 0..6 {
        truth.set_param(ParamId::Compliance(j).index(6), REAL_ARIA_COMPLIANCE)?;
        let i = ParamId::Link {
            link: j,
            kind: crate::params::LinkParam::Theta0,
        }
        .index(6);
        let v = truth.param(i)?;
        truth.set_param(i, v - REAL_ARIA_COMPLIANCE * tau[j])?;
    }
    Ok(truth)
}

/// The motion-capture experiment on the "real ARIA": 60 poses of the biopsy region, 20 of
/// them measured twice, 0.1 mm / 0.02° noise, no approach directions or temperatures (the
/// paper's set-up records neither).
#[must_use]
pub fn real_aria_training() -> SessionConfig {
    SessionConfig {
        record_approach: false,
        temperature_c: None,
        ..SessionConfig::blind_training()
    }
}

/// Validation poses of the "real ARIA" study (never used for fitting).
pub const REAL_ARIA_VALIDATION_POSES: usize = 40;

/// Seed of the "real ARIA" sessions.
pub const REAL_ARIA_SESSION_SEED: u64 = 0x0a21_a000;

/// The "real ARIA" study the CLI demo ends with and the tests check: the true arm
/// ([`real_aria`]), a training session ([`real_aria_training`]) written into
/// `train`/`groups` (length at least its `measurements()`), and
/// [`REAL_ARIA_VALIDATION_POSES`] noisy validation poses written into `validation`.
/// Returns the true arm and the number of training measurements.
pub fn real_aria_study(
    train: &mut [Measurement<6>],
    groups: &mut [u32],
    validation: &mut [Measurement<6>],
) -> Result<(Robot<6>, usize)> {
    let truth = real_aria()?;
    let rng = SplitMix64::new(REAL_ARIA_SESSION_SEED);
    let cfg = real_aria_training();
    let n = simulate_session(
        &truth,
        &crate::aria::TOOL_SEED_Q,
        &cfg,
        &mut rng.fork(1),
        train,
        groups,
    )?;
    let vcfg = SessionConfig {
        poses: REAL_ARIA_VALIDATION_POSES,
        repeated: 0,
        ..cfg
    };
    let mut vgroups = [0u32; REAL_ARIA_VALIDATION_POSES];
    simulate_session(
        &truth,
        &crate::aria::TOOL_SEED_Q,
        &vcfg,
        &mut rng.fork(2),
        validation,
        &mut vgroups,
    )?;
    Ok((truth, n))
}
