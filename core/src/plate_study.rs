//! Monte-Carlo of instrument-free calibration with a **socket plate** (issue #13, item 6),
//! on the random robots of [`crate::montecarlo`] so it compares with the known-pose tools
//! run for run.
//!
//! A plate carries ball sockets at positions nobody measures; only the distance between a
//! pair of sockets is known (from the drawing, to the plate's tolerance). The robot puts
//! its ball (the tool-frame origin) into a socket with several wrist orientations; each
//! socket is a [`GroupKind::Target`] group, each placement of the plate adds its sockets
//! and one [`Distance`]. The identification is [`identify_constrained`]: the socket
//! positions are eliminated, the base frame is a gauge (no row refers to it), lengths are
//! observable only through the known distances, and the tool orientation is not observed
//! at all (the ball is a point).
//!
//! One run (same robot `run` as every other design, [`random_robot`]):
//! - the plate's distance error `δ` is uniform in ±`tool_tol_pos_m`, one per run (one
//!   plate, placed several times), stream 4 of the run;
//! - socket `b` of every distance sits at the drawing's position moved by `δ` away from
//!   socket `a`; every other socket at its drawing position;
//! - contact `l` reaches its socket with the drawing's orientation, both perturbed by the
//!   seating noise (stream 2 forked by `l`, as a tool's pose `l`); the readings follow from
//!   the true robot's inverse kinematics ([`reach_true`]);
//! - the identified model is compared with the truth at the validation poses twice:
//!   **absolute** ([`validation_errors`], what an instrument would see in the base frame)
//!   and **registered** ([`registered_errors`]: after the rigid motion that best carries
//!   the model's validation tool points onto the truth's). The plate cannot know the base
//!   frame, so only the registered errors are its accuracy; a task that registers its
//!   targets with the calibrated robot (the biopsy: touch fiducials, then reach the lesion
//!   relative to them) sees the registered errors.
//!
//! [`tool_run_both`] gives a known-pose tool's run with both figures, so tools and plates
//! compare on the same footing.

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::identify::{
    ConstraintData, Contact, Distance, Group, GroupKind, Identifiability, Measurement, Workspace,
    identify_constrained, identify_with_analysis,
};
use crate::model::Robot;
use crate::montecarlo::{
    Design, RunResult, Study, identify_options, random_robot, reach_true, simulate_measurements,
    validation_errors,
};
use crate::params::{FrameParam, ParamId};
use crate::pose::{Transform, rotation_exp, transform};
use crate::registration::weighted_rigid_fit;
use crate::rng::SplitMix64;

/// A socket-plate design: contacts grouped by socket, and the known distances.
#[derive(Debug, Clone, Copy)]
pub struct PlateDesign<'a, const N: usize> {
    /// Nominal configurations of the contacts (the start of the true robot's IK).
    pub q: &'a [[f64; N]],
    /// Drawing pose of each contact: the socket's position and the wrist orientation. All
    /// contacts of a group share the socket position of the group's first contact.
    pub reference: &'a [Transform],
    /// Groups over the contacts, one [`GroupKind::Target`] per socket and placement.
    pub groups: &'a [Group],
    /// Known distances (the drawing's, \[m\]) between the sockets of a placement. A group
    /// is the second socket (`b`) of at most one distance.
    pub distances: &'a [Distance],
}

/// Both error figures of one run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BothErrors {
    /// In the base frame ([`validation_errors`]).
    pub absolute: RunResult,
    /// After the best rigid registration of the validation tool points
    /// ([`registered_errors`]; the `before_*` fields are 0).
    pub registered: RunResult,
}

/// Buffers of the registration, one entry per validation pose.
#[derive(Debug)]
pub struct RegistrationScratch<'b> {
    /// The model's validation tool points \[m\].
    pub model: &'b mut [[f64; 3]],
    /// The truth's \[m\].
    pub truth: &'b mut [[f64; 3]],
    /// Weights (set to 1).
    pub weight: &'b mut [f64],
}

fn socket_position<const N: usize>(design: &PlateDesign<'_, N>, g: &Group) -> Result<Vector3<f64>> {
    design
        .reference
        .get(g.start)
        .map(|t| t.translation.vector)
        .ok_or(Error::BadGroup { group: g.start })
}

/// Checks the design: lengths agree, every group is an unknown target tiling the
/// contacts, every distance names two groups and matches their drawing positions (1e-9 m),
/// and no group is the second socket of two distances.
pub fn check_design<const N: usize>(design: &PlateDesign<'_, N>) -> Result<()> {
    if design.q.len() != design.reference.len() {
        return Err(Error::DimensionMismatch {
            expected: design.q.len(),
            found: design.reference.len(),
        });
    }
    let mut next = 0;
    for (gi, g) in design.groups.iter().enumerate() {
        if g.kind != GroupKind::Target || g.start != next || g.len < 2 {
            return Err(Error::BadGroup { group: gi });
        }
        next = g.start + g.len;
    }
    if next != design.q.len() {
        return Err(Error::BadGroup {
            group: design.groups.len(),
        });
    }
    for (k, d) in design.distances.iter().enumerate() {
        let bad = Error::BadDistance { distance: k };
        let (Some(ga), Some(gb)) = (design.groups.get(d.a), design.groups.get(d.b)) else {
            return Err(bad);
        };
        let drawn = (socket_position(design, gb)? - socket_position(design, ga)?).norm();
        let twice_b = design.distances.iter().filter(|o| o.b == d.b).count() > 1;
        let matches = (drawn - d.m).abs() <= 1e-9; // false for NaN too
        if d.a == d.b || twice_b || !matches {
            return Err(bad);
        }
    }
    Ok(())
}

/// The physical socket of group `gi` in run `run`: the drawing's, or for the second
/// socket of a distance moved by the plate's error `delta_m` away from the first.
fn physical_socket<const N: usize>(
    design: &PlateDesign<'_, N>,
    gi: usize,
    delta_m: f64,
) -> Result<Vector3<f64>> {
    let g = design.groups.get(gi).ok_or(Error::BadGroup { group: gi })?;
    let p = socket_position(design, g)?;
    match design.distances.iter().find(|d| d.b == gi) {
        Some(d) => {
            let ga = design
                .groups
                .get(d.a)
                .ok_or(Error::BadGroup { group: d.a })?;
            let u = p - socket_position(design, ga)?;
            let n = u.norm();
            Ok(if n > 0.0 { p + u * (delta_m / n) } else { p })
        }
        None => Ok(p),
    }
}

/// The plate's distance error of run `run` \[m\] (uniform in ±`tool_tol_pos_m`).
#[must_use]
pub fn plate_error_m<const N: usize>(study: &Study<'_, N>, run: u64) -> f64 {
    let h = study.scenario.tool_tol_pos_m;
    SplitMix64::new(study.seed).fork(run).fork(4).range(-h, h)
}

/// Fills `contacts[..m]` with run `run`'s contacts of `design` made by `truth` (see the
/// module doc).
pub fn simulate_plate_contacts<const N: usize>(
    study: &Study<'_, N>,
    design: &PlateDesign<'_, N>,
    truth: &Robot<N>,
    run: u64,
    contacts: &mut [Contact<N>],
) -> Result<()> {
    check_design(design)?;
    if contacts.len() < design.q.len() {
        return Err(Error::CapacityExceeded {
            needed: design.q.len(),
            capacity: contacts.len(),
        });
    }
    let noise = SplitMix64::new(study.seed).fork(run).fork(2);
    let delta = plate_error_m(study, run);
    let s = &study.scenario;
    for (gi, g) in design.groups.iter().enumerate() {
        let socket = physical_socket(design, gi, delta)?;
        for l in g.start..g.start + g.len {
            let (Some(q0), Some(r), Some(slot)) = (
                design.q.get(l),
                design.reference.get(l),
                contacts.get_mut(l),
            ) else {
                return Err(Error::BadGroup { group: gi });
            };
            let mut nr = noise.fork(l as u64);
            let dp = normal3(&mut nr, s.noise_pos_m);
            let dr = normal3(&mut nr, s.noise_rot_rad);
            let physical = transform(rotation_exp(&dr) * r.rotation.matrix(), socket + dp);
            *slot = Contact::new(reach_true(truth, &physical, q0)?);
        }
    }
    Ok(())
}

fn normal3(rng: &mut SplitMix64, s: f64) -> Vector3<f64> {
    Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s
}

/// The contacts the nominal robot makes at the drawing (for the identifiability analysis
/// of a design): readings `design.q`.
pub fn nominal_contacts<const N: usize>(
    design: &PlateDesign<'_, N>,
    contacts: &mut [Contact<N>],
) -> Result<()> {
    if contacts.len() < design.q.len() {
        return Err(Error::CapacityExceeded {
            needed: design.q.len(),
            capacity: contacts.len(),
        });
    }
    for (c, q) in contacts.iter_mut().zip(design.q.iter()) {
        *c = Contact::new(*q);
    }
    Ok(())
}

/// The constraint data of `design` over `contacts`.
#[must_use]
pub fn plate_data<'a, const N: usize>(
    design: &PlateDesign<'a, N>,
    contacts: &'a [Contact<N>],
) -> ConstraintData<'a, N> {
    ConstraintData {
        instrument: &[],
        contacts: contacts.get(..design.q.len()).unwrap_or(contacts),
        groups: design.groups,
        distances: design.distances,
        sessions: &[],
    }
}

/// Pose of `robot` at validation pose `k` (precomputed sines and cosines where present).
fn validation_pose<const N: usize>(
    study: &Study<'_, N>,
    robot: &Robot<N>,
    k: usize,
) -> Result<Transform> {
    let q = study.validation_q.get(k).ok_or(Error::DimensionMismatch {
        expected: k + 1,
        found: study.validation_q.len(),
    })?;
    match study.validation_sincos.get(k) {
        Some(sc) => robot.fk_sincos(sc).or_else(|_| robot.fk_q(q)),
        None => robot.fk_q(q),
    }
}

fn rotation_angle(a: &Transform, b: &Transform) -> f64 {
    let m = a.rotation.matrix() * b.rotation.matrix().transpose();
    let v = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    );
    crate::math::atan2(0.5 * v.norm(), 0.5 * (m.trace() - 1.0))
}

/// The errors of `model` against `truth` at the validation poses after the rigid motion
/// `T` that minimises `Σ_k |T·p_model(q_k) − p_true(q_k)|²` (Horn's method,
/// [`weighted_rigid_fit`]): position errors `|T·p_model − p_true|`, orientation errors
/// the angle of `R_true·(R_T·R_model)ᵀ`. What a base registration with the calibrated
/// model leaves; exactly 0 when the model is the truth in another base frame.
pub fn registered_errors<const N: usize>(
    study: &Study<'_, N>,
    truth: &Robot<N>,
    model: &Robot<N>,
    scratch: &mut RegistrationScratch<'_>,
) -> Result<RunResult> {
    let nv = study.validation_q.len();
    let (Some(pm), Some(pt), Some(w)) = (
        scratch.model.get_mut(..nv),
        scratch.truth.get_mut(..nv),
        scratch.weight.get_mut(..nv),
    ) else {
        return Err(Error::CapacityExceeded {
            needed: nv,
            capacity: scratch.model.len().min(scratch.truth.len()),
        });
    };
    for (k, ((m, t), w)) in pm
        .iter_mut()
        .zip(pt.iter_mut())
        .zip(w.iter_mut())
        .enumerate()
    {
        let a = validation_pose(study, model, k)?.translation.vector;
        let b = validation_pose(study, truth, k)?.translation.vector;
        *m = [a.x, a.y, a.z];
        *t = [b.x, b.y, b.z];
        *w = 1.0;
    }
    let fit = weighted_rigid_fit(pm, pt, w, 1e-9)?;
    let mut r = RunResult::default();
    let (mut sp, mut sr) = (0.0, 0.0);
    for k in 0..nv {
        let t_true = validation_pose(study, truth, k)?;
        let moved = fit * validation_pose(study, model, k)?;
        let ep = (moved.translation.vector - t_true.translation.vector).norm();
        let er = rotation_angle(&t_true, &moved);
        r.max_pos_m = r.max_pos_m.max(ep);
        r.max_rot_rad = r.max_rot_rad.max(er);
        sp += ep * ep;
        sr += er * er;
    }
    let k = nv.max(1) as f64;
    r.rms_pos_m = crate::math::sqrt(sp / k);
    r.rms_rot_rad = crate::math::sqrt(sr / k);
    Ok(r)
}

/// The parameters a plate identifies: `study.params` and the ball centre (the tool
/// translation `Px, Py, Pz`). Needed, not optional: with the ball nominally on the last
/// joint's axis, its position about that axis is the joint offset `θ0` times the true
/// off-axis distance, and the link parameters alone (polar coordinates at radius 0) cannot
/// express it at the nominal model; the Cartesian tool translation can. The analysis
/// drops whatever of the pair duplicates the other.
pub fn plate_params<const N: usize>(study: &Study<'_, N>) -> Result<crate::params::ParamSet> {
    let mut set = study.params;
    for f in [FrameParam::Px, FrameParam::Py, FrameParam::Pz] {
        set.insert(ParamId::Tool(f).index(N).0)?;
    }
    Ok(set)
}

/// One plate run: random robot `run`, its contacts, identification (OLS on the
/// identifiable subset of [`plate_params`]) in two passes, both error figures.
///
/// Two passes because the identifiability analysis linearises at its start: at ARIA's
/// nominal wrist (ball on the last axis, axes 5 and 6 at right angles) the twist and
/// offset of link 5 and the last joint offset duplicate other columns to first order and
/// are set aside, yet a true robot's errors there move the ball by up to ~0.2 mm (second
/// order). The second pass analyses again at the first estimate, where they are
/// distinguishable, and fits noise-free contacts exactly.
/// `contacts` holds at least the design's number of contacts.
pub fn plate_run<const N: usize, const P: usize>(
    study: &Study<'_, N>,
    design: &PlateDesign<'_, N>,
    run: u64,
    ws: &mut Workspace<P>,
    contacts: &mut [Contact<N>],
    scratch: &mut RegistrationScratch<'_>,
) -> Result<BothErrors> {
    let truth = random_robot(study, run)?;
    simulate_plate_contacts(study, design, &truth, run, contacts)?;
    let data = plate_data(design, contacts);
    let mut opts = identify_options(study);
    opts.requested = plate_params(study)?;
    let first = identify_constrained(&study.nominal, &data, &opts, ws)?;
    let id = identify_constrained(&first.robot, &data, &opts, ws)?;
    let mut absolute = validation_errors(study, &truth, &id.robot)?;
    absolute.iterations = first.iterations + id.iterations;
    let registered = registered_errors(study, &truth, &id.robot, scratch)?;
    Ok(BothErrors {
        absolute,
        registered,
    })
}

/// A known-pose tool's (or instrument design's) run as
/// [`crate::montecarlo::simulate_run`], with the registered errors too.
#[allow(clippy::too_many_arguments)] // the run of simulate_run plus the registration buffers
pub fn tool_run_both<const N: usize, const P: usize>(
    study: &Study<'_, N>,
    design: &Design<'_, N>,
    analysis: &Identifiability,
    run: u64,
    ws: &mut Workspace<P>,
    data: &mut [Measurement<N>],
    scratch: &mut RegistrationScratch<'_>,
) -> Result<BothErrors> {
    let truth = random_robot(study, run)?;
    let m = design.q.len();
    simulate_measurements(study, design, &truth, run, data)?;
    let rows = data.get(..m).ok_or(Error::CapacityExceeded {
        needed: m,
        capacity: data.len(),
    })?;
    let id = identify_with_analysis(&study.nominal, rows, &identify_options(study), analysis, ws)?;
    let mut absolute = validation_errors(study, &truth, &id.robot)?;
    absolute.iterations = id.iterations;
    let registered = registered_errors(study, &truth, &id.robot, scratch)?;
    Ok(BothErrors {
        absolute,
        registered,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    //! A noise-free plate recovers every tool point up to the base frame (registered
    //! e_p ~ 1e-9) while the absolute errors keep the unobservable base frame; a model
    //! moved by a rigid motion has registered errors 0.
    use super::*;
    use crate::aria;
    use crate::ik::{IkOptions, solve_ik};
    use crate::model::JointState;
    use crate::montecarlo::Scenario;
    use crate::pose::rpy_to_matrix;
    use std::boxed::Box;
    use std::vec;
    use std::vec::Vec;
    extern crate std;

    fn ik(r: &Robot<6>, t: &Transform) -> [f64; 6] {
        solve_ik(
            r,
            t,
            &JointState::new(aria::TOOL_SEED_Q),
            &IkOptions::default(),
        )
        .unwrap()
        .q
    }

    struct Owned {
        q: Vec<[f64; 6]>,
        reference: Vec<Transform>,
        groups: Vec<Group>,
        distances: Vec<Distance>,
    }

    /// Three placements of a 0.2 m plate, 6 contacts per socket with different wrist
    /// orientations.
    fn plate() -> Owned {
        let nominal = aria::nominal();
        let mut o = Owned {
            q: vec![],
            reference: vec![],
            groups: vec![],
            distances: vec![],
        };
        let centres = [[0.25, 0.3, 0.25], [0.4, 0.45, 0.3], [0.2, 0.5, 0.28]];
        for (s, c) in centres.iter().enumerate() {
            let yaw = 0.7 * s as f64;
            let u = Vector3::new(libm::cos(yaw), libm::sin(yaw), 0.0) * 0.1;
            for side in [-1.0, 1.0] {
                let p = Vector3::new(c[0], c[1], c[2]) + u * side;
                let start = o.q.len();
                for k in 0..6 {
                    let roll = (-160.0 + 5.0 * (k % 3) as f64).to_radians();
                    let spin = (-60.0 + 25.0 * k as f64).to_radians();
                    let r = rpy_to_matrix(roll, 0.0, 0.0) * crate::pose::rot_z(spin);
                    let t = transform(r, p);
                    o.q.push(ik(&nominal, &t));
                    o.reference.push(t);
                }
                o.groups.push(Group {
                    kind: GroupKind::Target,
                    start,
                    len: 6,
                });
            }
            o.distances.push(Distance {
                a: 2 * s,
                b: 2 * s + 1,
                m: 0.2,
                weight: 1.0,
            });
        }
        o
    }

    fn study<'a>(vq: &'a [[f64; 6]], scen: Scenario) -> Study<'a, 6> {
        let nominal = aria::nominal();
        Study {
            nominal,
            params: nominal.geometric_param_set(),
            validation_q: vq,
            validation_sincos: &[],
            validation_nominal: &[],
            scenario: scen,
            seed: 7,
        }
    }

    #[test]
    fn noise_free_plate_recovers_the_tool_points_up_to_the_base_frame() {
        let o = plate();
        let design = PlateDesign {
            q: &o.q,
            reference: &o.reference,
            groups: &o.groups,
            distances: &o.distances,
        };
        check_design(&design).unwrap();
        let vq: Vec<[f64; 6]> = o.q.iter().step_by(5).copied().collect();
        let mut scen = Scenario::paper();
        scen.noise_pos_m = 0.0;
        scen.noise_rot_rad = 0.0;
        scen.tool_tol_pos_m = 0.0;
        let st = study(&vq, scen);
        // The analysis sets the base frame aside: 24 link + 3 tool + 6 base columns.
        // SAFETY: all-zero is a valid Workspace (documented).
        let mut ws = unsafe { Box::<Workspace<48>>::new_zeroed().assume_init() };
        let mut contacts = vec![Contact::new([0.0; 6]); o.q.len()];
        let nv = vq.len();
        let (mut a, mut b, mut w) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv], vec![0.0; nv]);
        let mut scratch = RegistrationScratch {
            model: &mut a,
            truth: &mut b,
            weight: &mut w,
        };
        for run in 0..3 {
            let e = plate_run(&st, &design, run, &mut ws, &mut contacts, &mut scratch).unwrap();
            assert!(e.registered.max_pos_m < 1e-8, "{e:?}");
            // The base frame is not observable: the absolute error stays at millimetres.
            assert!(e.absolute.max_pos_m > 1e-4, "{e:?}");
        }
        // With the plate's tolerance the scale is off by δ/D: a 50 µm error on 0.2 m
        // shows as up to 2.5e-4 of the validation extent after registration.
        scen.tool_tol_pos_m = 5e-5;
        let st = study(&vq, scen);
        let e = plate_run(&st, &design, 0, &mut ws, &mut contacts, &mut scratch).unwrap();
        let delta = plate_error_m(&st, 0);
        assert!(delta.abs() > 1e-6);
        assert!(
            e.registered.max_pos_m > 1e-7 && e.registered.max_pos_m < 1e-3,
            "{e:?}"
        );
    }

    #[test]
    fn a_rigidly_moved_model_has_no_registered_error_and_bad_designs_are_refused() {
        let o = plate();
        let vq: Vec<[f64; 6]> = o.q.clone();
        let st = study(&vq, Scenario::paper());
        let truth = random_robot(&st, 3).unwrap();
        // ARIA's base is the identity: any base frame is a rigid motion of the truth.
        assert_eq!(truth.base(), [0.0; 6]);
        let moved = truth
            .with_base([0.003, -0.002, 0.001, 0.01, -0.02, 0.03])
            .unwrap();
        let nv = vq.len();
        let (mut a, mut b, mut w) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv], vec![0.0; nv]);
        let mut scratch = RegistrationScratch {
            model: &mut a,
            truth: &mut b,
            weight: &mut w,
        };
        let r = registered_errors(&st, &truth, &moved, &mut scratch).unwrap();
        assert!(r.max_pos_m < 1e-12 && r.max_rot_rad < 1e-12, "{r:?}");
        let abs = validation_errors(&st, &truth, &moved).unwrap();
        assert!(abs.max_pos_m > 1e-3);
        // A distance that does not match the drawing, and one naming a missing group.
        let mut d = o.distances.clone();
        d[1].m = 0.21;
        let design = PlateDesign {
            q: &o.q,
            reference: &o.reference,
            groups: &o.groups,
            distances: &d,
        };
        assert_eq!(
            check_design(&design),
            Err(Error::BadDistance { distance: 1 })
        );
        d[1].m = 0.2;
        d[1].b = 99;
        let design = PlateDesign {
            q: &o.q,
            reference: &o.reference,
            groups: &o.groups,
            distances: &d,
        };
        assert_eq!(
            check_design(&design),
            Err(Error::BadDistance { distance: 1 })
        );
    }
}
