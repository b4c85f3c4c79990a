//! The blind diagnosis on arms that are not ARIA: every other diagnosis suite draws a
//! random ARIA, and a user's arm is rarely one. Three arms:
//! - a UR-like 6R arm (UR5's standard DH, masses of its links): joints 2–4 are parallel,
//!   so links 2 and 3 identify β instead of d, a parameter path ARIA never takes;
//! - the Panda-like 7R arm of the other tests (`common::arm7`), N = 7;
//! - the UR-like arm on a lifting column (a prismatic joint first), N = 7.
//!
//! Each case, written for this file and not tuned to: the nominal arm with manufacturing
//! errors (±2 mm, ±1°), a hidden effect or none, 60 random joint states within ±1 rad
//! (±0.2 m for the slide) of a working posture (not IK targets, unlike the ARIA suites), the
//! first 20 measured twice (half from the same approach directions), approach directions
//! and a 22 → 42 °C ramp recorded, σ estimated from the repeats. Even cases are measured by
//! a motion-capture system (full poses, 0.1 mm and 0.02° per axis), odd ones by a laser
//! tracker (a reflector 5 cm off the flange's axis, positions only, 0.02 mm). Hidden: one
//! library effect ([`kincal::sim::add_effect`]), or one of five effects outside the library
//! (third-harmonic transmission error, a coupling of each joint's angle into the next, an
//! anisotropic instrument scale, an upper arm bending with its angle, a hardening
//! compliance), scaled to a detectability ρ drawn log-uniformly in [0.7, 12] (ρ: the RMS
//! residual a noise-free geometric calibration leaves, over √3·σ, position or rotation,
//! the larger; measured after scaling; a tool-frame error is invisible to the reflector's
//! positions, ρ = 0, and scored as such).
//!
//! Scored as the ARIA suites: strong (ρ ≥ 3) library cases right (the hidden effect chosen
//! or listed as confounded, status explained or partially explained); no-effect cases
//! `no_gap`; strong out-of-library cases not `explained` (an over-claim otherwise).
//!
//! `other_arms_short` (default, 3 cases per kind and arm) asserts the targets;
//! `other_arms_long` (`#[ignore]`, 10 per kind: `cargo test -p kincal --release --test
//! diagnosis_other_arms -- --ignored --nocapture`, a few seconds) prints every case and the
//! table. Figures (5 Dec 2026, 390 cases): no effect → `no_gap` 30/30; strong library
//! effects right 107/108 (the miss: the Panda-like arm, laser, joint_cyclic at ρ 10.9,
//! `unexplained` because the cyclic model's 28 parameters close too small a share held
//! out); strong out-of-library effects never `explained`, 75/75 (`partially_explained`
//! with a library effect absorbing part, or `unexplained` for the bending). Weaker ones
//! (ρ 0.7–1.9, not scored) are sometimes `explained` by base_frame or joint_compliance: what
//! is left after those is within the noise. With the reflector on the flange's axis
//! (0, 0, 0.06) m instead, no diagnosis failed either (strong library effects 106/106,
//! no over-claim 75/75), though some of this file's ρ fits, started from the truth's
//! geometry, then crawl past 1,000 iterations in both solvers (ρ left NaN there).
//! A diagnosis that fails counts against the suite (`ERROR`).
//!
//! Found on the way: `sim::add_effect` drew an angle's magnitudes for a slide (1e-3 m/N of
//! compliance: decimetres on a column), now a slide's (`add_effect_draws_slide_magnitudes_…`).

mod common;

use kincal::diagnosis::{Config, DiagWorkspace, PoseDiagnosis, Status, diagnose};
use kincal::identify::{
    Algorithm, ComponentMask, IdentifyOptions, Measurement, Workspace, identify,
};
use kincal::params::LinkParam;
use kincal::pose::transform;
use kincal::rng::SplitMix64;
use kincal::sim::{add_effect, add_noise, only_effects, perturb_geometry, scale_effect};
use kincal::{
    Effect, EffectSet, JointKind, JointLimits, JointState, Link, MassModel, ParamId, Robot,
    Transform,
};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// A measuring instrument.
#[derive(Debug, Clone, Copy)]
struct Inst {
    name: &'static str,
    sigma_pos_m: f64,
    sigma_rot_rad: f64,
    mask: ComponentMask,
    /// The measured point in the tool frame (`None`: the tool frame's pose).
    point: Option<[f64; 3]>,
}

/// Motion capture: full poses, 0.1 mm and 0.02° per axis.
const MOCAP: Inst = Inst {
    name: "mocap",
    sigma_pos_m: 1e-4,
    sigma_rot_rad: 0.02 * PI / 180.0,
    mask: ComponentMask::ALL,
    point: None,
};
/// Laser tracker: positions of a reflector ([`REFLECTOR_M`]), 0.02 mm per axis.
const LASER: Inst = Inst {
    name: "laser",
    sigma_pos_m: 2e-5,
    sigma_rot_rad: 0.02 * PI / 180.0,
    mask: ComponentMask::POSITION,
    point: Some(REFLECTOR_M),
};
const POSES: usize = 60;
const REPEATED: usize = 20;
const WITHHELD: usize = 40;
const STRONG: f64 = 3.0;
const RHO_RANGE: [f64; 2] = [0.7, 12.0];
/// Parameter capacity of the diagnosis workspace (the 7R arm's full set is 97).
const CAP: usize = 112;

/// Where the laser tracker's reflector sits in the tool frame [m] (`Measurement::point`):
/// off the last joint's axis, as mounted in practice (on the axis, position-only rows leave
/// θ0 of the last link practically unobservable: a UR-like arm's geometric fit then moved it
/// by radians).
const REFLECTOR_M: [f64; 3] = [0.04, 0.03, 0.06];

/// A UR5-like arm: standard DH (`A = Rz(q)·Tz(d)·Tx(a)·Rx(α)`, the first four factors of
/// kincal's link transform), the published UR5 geometry and link masses.
fn ur_like() -> Robot<6> {
    let h = PI / 2.0;
    let links = [
        Link::dh(0.0, 0.089159, 0.0, h),
        Link::dh(0.0, 0.0, -0.425, 0.0),
        Link::dh(0.0, 0.0, -0.39225, 0.0),
        Link::dh(0.0, 0.10915, 0.0, h),
        Link::dh(0.0, 0.09465, 0.0, -h),
        Link::dh(0.0, 0.0823, 0.0, 0.0),
    ];
    let limits = [JointLimits::new(-2.0 * PI, 2.0 * PI); 6];
    Robot::new(links, limits)
        .and_then(|r| {
            r.with_mass(MassModel {
                link_masses_kg: [3.7, 8.393, 2.275, 1.219, 1.219, 0.1879],
                tool_mass_kg: 0.5,
                gravity: [0.0, 0.0, -9.81],
            })
        })
        .expect("UR-like arm")
}

/// The UR-like arm on a lifting column (a vertical slide, 0–0.6 m): P+6R, N = 7.
fn column_ur() -> Robot<7> {
    let ur = ur_like();
    let mut links = [Link::dh(0.0, 0.3, 0.0, 0.0); 7];
    links[1..].copy_from_slice(ur.links());
    let mut limits = [JointLimits::new(0.0, 0.6); 7];
    limits[1..].copy_from_slice(ur.limits());
    let mut kinds = [JointKind::Revolute; 7];
    kinds[0] = JointKind::Prismatic;
    Robot::new(links, limits)
        .and_then(|r| r.with_joint_kinds(&kinds))
        .and_then(|r| {
            r.with_mass(MassModel {
                link_masses_kg: [20.0, 3.7, 8.393, 2.275, 1.219, 1.219, 0.1879],
                tool_mass_kg: 0.5,
                gravity: [0.0, 0.0, -9.81],
            })
        })
        .expect("column + UR-like arm")
}

/// Effects outside the library, generic in the number of joints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outside {
    /// Δθ_j = s·1 mrad·(a_j·sin 3q_j + b_j·cos 3q_j).
    ThirdHarmonic,
    /// Δθ_{j+1} = s·2 mrad·c_j·q_j: each joint's angle leaks into the next one's.
    Coupling,
    /// Positions scaled about (−1, 0.5, 0) m by 1 + s·1.5e-3·n_k per axis.
    InstrumentScale,
    /// Δα_2 = s·5 mrad·cos q_2 (link 2 bends out of plane with its angle to gravity).
    Bending,
    /// Δθ_j = s·2e-5 rad/(N·m)²·τ_j·|τ_j| (revolute joints).
    HardeningCompliance,
}

const OUTSIDE: [Outside; 5] = [
    Outside::ThirdHarmonic,
    Outside::Coupling,
    Outside::InstrumentScale,
    Outside::Bending,
    Outside::HardeningCompliance,
];

/// A drawn out-of-library effect: kind, size and random coefficients.
#[derive(Debug, Clone, Copy)]
struct Drawn {
    kind: Outside,
    size: f64,
    coef: [f64; 16],
}

impl Drawn {
    fn draw(kind: Outside, rng: &mut SplitMix64) -> Self {
        Drawn {
            kind,
            size: 1.0,
            coef: std::array::from_fn(|_| rng.normal()),
        }
    }

    /// The pose the instrument sees of `truth` (no library effect) at `st`.
    fn pose<const N: usize>(&self, truth: &Robot<N>, st: &JointState<N>) -> Transform {
        let (s, c, q) = (self.size, &self.coef, &st.q);
        let mut r = *truth;
        let bump = |r: &mut Robot<N>, link: usize, kind: LinkParam, d: f64| {
            let i = ParamId::Link { link, kind }.index(N);
            let v = r.param(i).unwrap();
            r.set_param(i, v + d).unwrap();
        };
        match self.kind {
            Outside::ThirdHarmonic => {
                for j in 0..N {
                    let d = s * 1e-3 * (c[j] * (3.0 * q[j]).sin() + c[8 + j] * (3.0 * q[j]).cos());
                    bump(&mut r, j, LinkParam::Theta0, d);
                }
            }
            Outside::Coupling => {
                for j in 0..N - 1 {
                    bump(&mut r, j + 1, LinkParam::Theta0, s * 2e-3 * c[j] * q[j]);
                }
            }
            Outside::Bending => bump(&mut r, 1, LinkParam::Alpha, s * 5e-3 * q[1].cos()),
            Outside::HardeningCompliance => {
                let tau = truth.gravity_torques(q);
                for (j, t) in tau.iter().enumerate() {
                    if truth.joint_kind(j) == JointKind::Prismatic {
                        continue; // a force, not a torque
                    }
                    bump(&mut r, j, LinkParam::Theta0, s * 2e-5 * t * t.abs());
                }
            }
            Outside::InstrumentScale => {
                let t = truth.fk(st).unwrap();
                let centre = Vector3::new(-1.0, 0.5, 0.0);
                let d = t.translation.vector - centre;
                let scaled = Vector3::from_fn(|k, _| d[k] * (1.0 + s * 1.5e-3 * c[k]));
                return transform(*t.rotation.matrix(), centre + scaled);
            }
        }
        r.fk(st).unwrap()
    }
}

/// What a case hides.
#[derive(Debug, Clone, Copy)]
enum Hidden {
    None,
    Library(Effect),
    Outside(Outside),
}

/// The joint states of a session: `POSES` random states within ±1 rad (±0.2 m for a slide)
/// of `posture` (inside the limits), the first `REPEATED` measured again (half from the same approach), with
/// approach directions and a temperature ramp over the first measurements. Pose ids 1-based.
fn session<const N: usize>(
    robot: &Robot<N>,
    posture: &[f64; N],
    poses: usize,
    repeated: usize,
    rng: &mut SplitMix64,
) -> Vec<(JointState<N>, u32)> {
    let sign = |rng: &mut SplitMix64| if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let mut out = Vec::new();
    for k in 0..poses {
        let q = std::array::from_fn(|j| {
            let l = robot.limits()[j];
            let spread = match robot.joint_kind(j) {
                JointKind::Prismatic => 0.2,
                _ => 1.0,
            };
            (posture[j] + rng.range(-spread, spread)).clamp(l.lower, l.upper)
        });
        let temp = 22.0 + 20.0 * k as f64 / (poses.max(2) - 1) as f64;
        let st = JointState {
            q,
            approach: Some(std::array::from_fn(|_| sign(rng))),
            temp_c: Some(temp),
        };
        out.push((st, k as u32 + 1));
    }
    for k in 0..repeated.min(poses) {
        let (mut st, g) = out[k];
        if rng.uniform() >= 0.5 {
            st.approach = Some(std::array::from_fn(|_| sign(rng)));
        }
        out.push((st, g));
    }
    out
}

/// Measurements of `states`: the truth's poses (through `outside` when given), with noise
/// when `noisy`.
fn measure<const N: usize>(
    truth: &Robot<N>,
    outside: Option<&Drawn>,
    states: &[(JointState<N>, u32)],
    inst: &Inst,
    noisy: bool,
    rng: &mut SplitMix64,
) -> Vec<Measurement<N>> {
    states
        .iter()
        .map(|(st, _)| {
            let tool_pose = match outside {
                Some(o) => o.pose(truth, st),
                None => truth.fk(st).unwrap(),
            };
            let pose = match inst.point {
                Some(p) => {
                    let at = tool_pose.rotation * Vector3::from(p);
                    transform(
                        *tool_pose.rotation.matrix(),
                        tool_pose.translation.vector + at,
                    )
                }
                None => tool_pose,
            };
            let pose = if noisy {
                add_noise(&pose, inst.sigma_pos_m, inst.sigma_rot_rad, rng)
            } else {
                pose
            };
            let mut m = Measurement::new(st.q, pose);
            m.state = *st;
            m.mask = inst.mask;
            m.point = inst.point;
            m
        })
        .collect()
}

/// ρ: the RMS residual of a noise-free geometric calibration (from the truth's own
/// geometry, its global optimum without effects) over √3·σ, position or (where measured)
/// rotation, the larger.
fn detectability<const N: usize>(
    truth: &Robot<N>,
    outside: Option<&Drawn>,
    states: &[(JointState<N>, u32)],
    inst: &Inst,
) -> f64 {
    let data = measure(truth, outside, states, inst, false, &mut SplitMix64::new(0));
    let start = only_effects(truth, EffectSet::NONE);
    // An effect at its realistic size on a heavy arm leaves centimetres before scaling,
    // where the solvers converge slowly (the column arm's compliance, position only: OLS
    // 460 iterations, OPT2 93, same minimum): up to 1,000 iterations, then OPT2.
    let mut opts = IdentifyOptions::new(Algorithm::Ols, start.geometric_param_set());
    opts.max_iterations = 1000;
    opts.weight_pos = inst.sigma_pos_m.powi(-2);
    opts.weight_rot = inst.sigma_rot_rad.powi(-2);
    opts.allow_data_deficiency = true;
    let mut ws = Box::<Workspace<64>>::default();
    let fit = identify(&start, &data, &opts, &mut ws).or_else(|_| {
        opts.algorithm = Algorithm::Opt2;
        identify(&start, &data, &opts, &mut ws)
    });
    let fit = fit.unwrap_or_else(|e| {
        panic!(
            "geometric fit: {e:?}; start rms {:?}; outside {outside:?}",
            rms(&start, &data)
        )
    });
    let (p, r) = rms(&fit.robot, &data);
    let floor = 3f64.sqrt();
    let rot = if inst.mask.has(3) {
        r / (floor * inst.sigma_rot_rad)
    } else {
        0.0
    };
    (p / (floor * inst.sigma_pos_m)).max(rot)
}

/// RMS position [m] and rotation [rad] error of `robot` on `data`.
fn rms<const N: usize>(robot: &Robot<N>, data: &[Measurement<N>]) -> (f64, f64) {
    let (mut p2, mut r2) = (0.0, 0.0);
    for m in data {
        let e = kincal::pose::pose_error(
            &m.pose,
            &m.model_pose(robot).unwrap(),
            kincal::OrientationError::Exact,
        );
        p2 += e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        r2 += e[3] * e[3] + e[4] * e[4] + e[5] * e[5];
    }
    let n = data.len() as f64;
    ((p2 / n).sqrt(), (r2 / n).sqrt())
}

#[derive(Debug)]
struct Outcome {
    arm: &'static str,
    inst: &'static str,
    hidden: Hidden,
    rho: f64,
    status: Status,
    said: String,
    /// The verdict's reason (printed for wrong strong cases).
    reason: String,
    right: bool,
    closed_withheld: f64,
}

fn run_case<const N: usize>(
    arm: &'static str,
    nominal: &Robot<N>,
    posture: &[f64; N],
    hidden: Hidden,
    inst: &Inst,
    seed: u64,
    ws: &mut DiagWorkspace<CAP>,
) -> Outcome {
    if std::env::var("ARMS_DEBUG").is_ok() {
        eprintln!("case {arm} {hidden:?} {} seed {seed}", inst.name);
    }
    let rng = SplitMix64::new(seed);
    let mut truth =
        perturb_geometry(nominal, 2e-3, 1f64.to_radians(), &mut rng.fork(1)).expect("perturb");
    let states = session(&truth, posture, POSES, REPEATED, &mut rng.fork(2));
    let withheld = session(&truth, posture, WITHHELD, 0, &mut rng.fork(3));
    let target = RHO_RANGE[0] * (RHO_RANGE[1] / RHO_RANGE[0]).powf(rng.fork(4).uniform());
    let mut outside = None;
    match hidden {
        Hidden::None => {}
        Hidden::Library(e) => {
            add_effect(&mut truth, e, 1.0, &mut rng.fork(5)).expect("effect");
            let rho1 = detectability(&truth, None, &states, inst);
            // An effect the instrument cannot see at all (ρ at the fit's rounding) stays at
            // its realistic size: an undetectable case.
            if rho1 > 1e-6 {
                scale_effect(&mut truth, e, target / rho1).expect("scale");
            } else {
                eprintln!("{arm} {e:?} {}: invisible (rho {rho1:.1e})", inst.name);
            }
        }
        Hidden::Outside(kind) => {
            let mut d = Drawn::draw(kind, &mut rng.fork(5));
            let rho1 = detectability(&truth, Some(&d), &states, inst);
            if rho1 > 1e-6 {
                d.size = target / rho1;
            }
            outside = Some(d);
        }
    }
    let rho = match hidden {
        Hidden::None => 0.0,
        _ => detectability(&truth, outside.as_ref(), &states, inst),
    };
    let mut mrng = rng.fork(6);
    let data = measure(&truth, outside.as_ref(), &states, inst, true, &mut mrng);
    let groups: Vec<u32> = states.iter().map(|(_, g)| *g).collect();
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let d = match diagnose(nominal, &data, &groups, &Config::default(), &mut poses, ws) {
        Ok(d) => d,
        Err(e) => {
            return Outcome {
                arm,
                inst: inst.name,
                reason: format!("diagnosis failed: {e}"),
                hidden,
                rho,
                status: Status::Unexplained,
                said: "ERROR".into(),
                right: false,
                closed_withheld: 0.0,
            };
        }
    };
    let status = d.verdict.status;
    let right = match hidden {
        Hidden::None => status == Status::NoGap,
        Hidden::Library(e) => {
            matches!(status, Status::Explained | Status::PartiallyExplained)
                && (d.verdict.effects == EffectSet::of(e)
                    || d.verdict.confounded().contains(&EffectSet::of(e)))
        }
        Hidden::Outside(_) => status != Status::Explained,
    };
    let held = measure(&truth, outside.as_ref(), &withheld, inst, false, &mut mrng);
    let (before, after) = (rms(&d.geometric, &held).0, rms(&d.model, &held).0);
    let said = d
        .verdict
        .effects
        .iter()
        .map(|e| e.name())
        .collect::<Vec<_>>()
        .join("+");
    Outcome {
        arm,
        inst: inst.name,
        reason: format!("{:?}", d.verdict.reason),
        hidden,
        rho,
        status,
        said,
        right,
        closed_withheld: if before > 0.0 {
            (before - after) / before
        } else {
            0.0
        },
    }
}

fn kinds() -> Vec<Hidden> {
    let mut k = vec![Hidden::None];
    k.extend(Effect::ALL.iter().map(|&e| Hidden::Library(e)));
    k.extend(OUTSIDE.iter().map(|&o| Hidden::Outside(o)));
    k
}

fn suite(per_kind: usize, print_cases: bool) -> Vec<Outcome> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented); avoids a large stack value.
    let mut ws: Box<DiagWorkspace<CAP>> = unsafe { Box::new_zeroed().assume_init() };
    let ur = ur_like();
    let ur_posture = [0.0, -1.2, 1.5, -1.9, -1.57, 0.0];
    let panda = common::arm7();
    let panda_posture = [0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8];
    let column = column_ur();
    let column_posture = [0.3, 0.0, -1.2, 1.5, -1.9, -1.57, 0.0];
    let mut out = Vec::new();
    for (ki, hidden) in kinds().into_iter().enumerate() {
        for s in 0..per_kind {
            let seed = 0xa2a5_0000 + 100 * ki as u64 + s as u64;
            let inst = if s % 2 == 0 { &MOCAP } else { &LASER };
            let w = &mut *ws;
            out.push(run_case("ur", &ur, &ur_posture, hidden, inst, seed, w));
            out.push(run_case(
                "panda",
                &panda,
                &panda_posture,
                hidden,
                inst,
                seed,
                w,
            ));
            out.push(run_case(
                "col",
                &column,
                &column_posture,
                hidden,
                inst,
                seed,
                w,
            ));
        }
    }
    if print_cases {
        for o in &out {
            println!(
                "{:5} {:5} {:32} rho {:6.2} {:20} {:24} closed {:5.2} {}",
                o.arm,
                o.inst,
                format!("{:?}", o.hidden),
                o.rho,
                format!("{:?}", o.status),
                o.said,
                o.closed_withheld,
                if o.right { "" } else { "WRONG" }
            );
            if !o.right && o.rho >= STRONG {
                println!("      reason: {}", o.reason);
            }
        }
    }
    out
}

/// (right, scored) over the outcomes `pick` selects.
fn share(out: &[Outcome], pick: impl Fn(&Outcome) -> bool) -> (usize, usize) {
    let scored: Vec<_> = out.iter().filter(|o| pick(o)).collect();
    (scored.iter().filter(|o| o.right).count(), scored.len())
}

fn report_and_check(out: &[Outcome], per_kind: usize) {
    let none = share(out, |o| matches!(o.hidden, Hidden::None));
    let lib = share(out, |o| {
        matches!(o.hidden, Hidden::Library(_)) && o.rho >= STRONG
    });
    let outside = share(out, |o| {
        matches!(o.hidden, Hidden::Outside(_)) && o.rho >= STRONG
    });
    println!(
        "other arms, {per_kind} cases per kind and arm: no effect -> no_gap {}/{}; strong \
         library effects right {}/{}; strong out-of-library effects not over-claimed {}/{}",
        none.0, none.1, lib.0, lib.1, outside.0, outside.1
    );
    let failed: Vec<_> = out.iter().filter(|o| o.said == "ERROR").collect();
    assert!(failed.is_empty(), "diagnoses that failed: {failed:?}");
    let frac = |(r, n): (usize, usize)| if n == 0 { 1.0 } else { r as f64 / n as f64 };
    assert!(lib.1 > 0 && outside.1 > 0, "no strong cases scored");
    assert!(frac(none) >= 0.9, "no_gap without an effect: {none:?}");
    assert!(frac(lib) >= 0.9, "strong library effects right: {lib:?}");
    assert!(
        frac(outside) >= 0.9,
        "over-claims on strong outside effects: {outside:?}"
    );
}

#[test]
fn other_arms_short() {
    let out = suite(3, std::env::var("ARMS_DEBUG").is_ok());
    report_and_check(&out, 3);
}

#[test]
#[ignore = "390 cases, a few seconds in release: run with --ignored"]
fn other_arms_long() {
    let out = suite(10, true);
    report_and_check(&out, 10);
}

/// `sim::add_effect` on a slide: a slide's magnitudes (not an angle's: 1e-3 rad/(N·m) of
/// compliance moved the column by decimetres and the geometric fit never converged), no
/// cyclic terms, and the revolute joints' parameters what an all-revolute arm draws, bit
/// for bit.
#[test]
fn add_effect_draws_slide_magnitudes_on_a_prismatic_joint() {
    use kincal::sim::magnitude as m;
    let column = column_ur();
    let mut revolute = column;
    revolute.set_joint_kind(0, JointKind::Revolute).unwrap();
    for e in [
        Effect::JointCompliance,
        Effect::JointScale,
        Effect::JointCyclic,
        Effect::Backlash,
    ] {
        let (mut a, mut b) = (column, revolute);
        add_effect(&mut a, e, 1.0, &mut SplitMix64::new(9)).unwrap();
        add_effect(&mut b, e, 1.0, &mut SplitMix64::new(9)).unwrap();
        for i in e.params(7).iter() {
            let id = kincal::ParamIndex(i);
            let (va, vb) = (a.param(id).unwrap(), b.param(id).unwrap());
            let slide_ids = [
                ParamId::Compliance(0),
                ParamId::Scale(0),
                ParamId::Backlash(0),
                ParamId::Cyclic(0, kincal::params::CyclicTerm::ALL[0]),
                ParamId::Cyclic(0, kincal::params::CyclicTerm::ALL[1]),
                ParamId::Cyclic(0, kincal::params::CyclicTerm::ALL[2]),
                ParamId::Cyclic(0, kincal::params::CyclicTerm::ALL[3]),
            ];
            if !slide_ids.iter().any(|p| p.index(7).0 == i) {
                assert_eq!(va.to_bits(), vb.to_bits(), "{e:?} parameter {i}");
                continue;
            }
            let bound = match e {
                Effect::JointCompliance => m::PRISMATIC_COMPLIANCE_M_PER_N,
                Effect::JointScale => m::PRISMATIC_SCALE,
                Effect::Backlash => m::PRISMATIC_BACKLASH_M,
                _ => 0.0,
            };
            assert!(va.abs() <= bound, "{e:?} on the slide: {va} > {bound}");
            assert!(
                e == Effect::JointCyclic || va != 0.0,
                "{e:?} on the slide is zero"
            );
        }
    }
}
