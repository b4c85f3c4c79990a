//! The numeric core on arbitrary numbers (NaN, ±inf, subnormals, extreme magnitudes):
//! building a robot, FK, the identification Jacobian, gravity torques, IK, identification
//! (plain and robust) and the rotation conversions never panic; they return a value or an
//! error. This is what the C ABI and the CLI pass through to.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use kincal::identify::{
    Algorithm, ComponentMask, IdentifyOptions, Loss, Measurement, PoseResidual, RobustOptions,
    Workspace, identify, identify_robust,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::pose::{
    matrix_to_quaternion, matrix_to_rpy, pose_from_vector6, quaternion_to_matrix, rotation_log,
    rpy_to_matrix,
};
use kincal::{JointLimits, JointState, Link, MassModel, ParamIndex, Robot};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    links: [[f64; 5]; 6],
    limits: [[f64; 2]; 6],
    base: [f64; 6],
    tool: [f64; 6],
    masses: [f64; 7],
    gravity: [f64; 3],
    /// (parameter index, value) set after construction.
    params: [(u8, f64); 6],
    q: [[f64; 6]; 4],
    approach: [i8; 6],
    temp_c: f64,
    poses: [[f64; 6]; 4],
    masks: [u8; 4],
    weights: [f64; 4],
    /// Measured point in the tool frame per pose (used when the pose's bit in `point_set` is
    /// set), exercising the position-of-a-marker path.
    points: [[f64; 3]; 4],
    point_set: u8,
    quaternion: [f64; 4],
    rpy: [f64; 3],
    ops: u8,
}

fuzz_target!(|data: &[u8]| {
    if let Some(inp) = parse_padded(data) {
        exercise(inp);
    }
});

/// `data` zero-padded to `Input`'s size, then parsed. Parsed directly, every input shorter
/// than `Input` (libFuzzer starts from one byte; seeds written before a field was added)
/// is rejected, and a target that rejects every input gains no coverage: this one ran blind
/// that way (10^7 executions, no coverage) until `smoke.sh` learned to fail on it.
fn parse_padded(data: &[u8]) -> Option<Input> {
    let need = Input::size_hint(0).0;
    let mut buf = data.to_vec();
    if buf.len() < need {
        buf.resize(need, 0);
    }
    Input::arbitrary(&mut Unstructured::new(&buf)).ok()
}

fn exercise(inp: Input) {
    let _ = quaternion_to_matrix(&inp.quaternion).map(|r| matrix_to_quaternion(&r));
    let r = rpy_to_matrix(inp.rpy[0], inp.rpy[1], inp.rpy[2]);
    let _ = matrix_to_rpy(&r);
    let _ = rotation_log(&r);

    let links = inp.links.map(|l| Link {
        theta0: l[0],
        d: l[1],
        a: l[2],
        alpha: l[3],
        beta: l[4],
    });
    let limits = inp.limits.map(|l| JointLimits::new(l[0], l[1]));
    let Ok(mut robot) = Robot::new(links, limits) else {
        return;
    };
    if let Ok(r) = robot.with_base(inp.base) {
        robot = r;
    }
    if let Ok(r) = robot.with_tool(inp.tool) {
        robot = r;
    }
    let mass = MassModel {
        link_masses_kg: core::array::from_fn(|j| inp.masses[j]),
        tool_mass_kg: inp.masses[6],
        gravity: inp.gravity,
    };
    if let Ok(r) = robot.with_mass(mass) {
        robot = r;
    }
    for (i, v) in inp.params {
        let _ = robot.set_param(ParamIndex(usize::from(i)), v);
    }
    let approach = inp.approach.map(|s| f64::from(s.signum()));
    let states: Vec<JointState<6>> = inp
        .q
        .iter()
        .map(|q| JointState {
            q: *q,
            approach: (inp.ops & 1 != 0).then_some(approach),
            temp_c: (inp.ops & 2 != 0).then_some(inp.temp_c),
        })
        .collect();
    let mut jac = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
    for st in &states {
        let _ = robot.fk(st);
        let _ = robot.jacobian(st, &mut jac);
        let _ = robot.gravity_torques(&st.q);
        let _ = robot.check_limits(&st.q);
    }
    let target = pose_from_vector6(&inp.poses[0]);
    if inp.ops & 4 != 0 {
        let opts = IkOptions {
            max_iterations: 20,
            extra_seeds: 1,
            ..IkOptions::default()
        };
        let _ = solve_ik(&robot, &target, &states[0], &opts);
    }
    if inp.ops & 8 != 0 {
        let mut data: Vec<Measurement<6>> = states
            .iter()
            .zip(inp.poses.iter())
            .zip(inp.masks.iter().zip(inp.weights.iter()))
            .enumerate()
            .map(|(i, ((st, p), (&mask, &w)))| Measurement {
                state: *st,
                pose: pose_from_vector6(p),
                mask: ComponentMask(mask),
                weight: w,
                point: (inp.point_set >> i & 1 == 1).then_some(inp.points[i]),
            })
            .collect();
        let alg = [Algorithm::Ols, Algorithm::Opt1, Algorithm::Opt2][usize::from(inp.ops >> 4) % 3];
        let bounds = kincal::identify::Bounds::around(&robot, 0.01, 0.1);
        let mut opts = IdentifyOptions::new(alg, robot.geometric_param_set());
        opts.max_iterations = 8;
        opts.bounds = Some(&bounds);
        opts.allow_data_deficiency = inp.ops & 64 != 0;
        let mut ws = Box::<Workspace<32>>::default();
        let _ = identify(&robot, &data, &opts, &mut ws);
        if inp.ops & 128 != 0 {
            let mut report = vec![PoseResidual::default(); data.len()];
            let mut ropts = RobustOptions::new(Loss::Cauchy);
            ropts.max_reweights = 3;
            let before: Vec<f64> = data.iter().map(|m| m.weight).collect();
            let _ = identify_robust(&robot, &mut data, &opts, &ropts, &mut report, &mut ws);
            let after: Vec<f64> = data.iter().map(|m| m.weight).collect();
            assert!(
                before
                    .iter()
                    .zip(&after)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "weights not restored"
            );
        }
    }
}
