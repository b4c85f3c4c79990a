//! The instrument-free diagnosis (`kincal diagnose` on target rows) blind: simulated ARIAs
//! whose hidden effect only this test knows, end to end through the command line. Until
//! this file the contact diagnosis was checked on MUKCa's real recordings (truth unknown)
//! and on noise-free data only.
//!
//! Each case: ARIA's nominal arm with manufacturing errors (±2 mm, ±1°) and a ball of
//! unknown centre on the flange, 12 targets (sockets) in 4 sessions (placements), 8 holds
//! per target at orientations tilted up to 0.35 rad, two known distances per session pair,
//! each hold's ball centre off the socket's by N(0, σ) per axis (σ = 0.02 mm, stated), the
//! temperature of each hold recorded (22 → 42 °C over the sessions). Hidden: nothing, a
//! library effect the data can express (joint_scale, joint_cyclic, joint_compliance,
//! thermal) at 1–4 times its realistic size, or an effect outside the library (a
//! third-harmonic transmission error, an upper arm bending with its angle) of a few tenths
//! of a millimetre.
//!
//! Scored: no effect → `no_gap`; a library effect → named (or listed as confounded) when
//! a gap is found; an effect outside the library → never `explained`.
//!
//! These are measuring instruments (`#[ignore]`, about 8 minutes in release: `cargo test
//! --release -p kincal-cli --test diagnose_contacts_blind -- --ignored --nocapture`).
//! Figures of 5 Dec 2026 (σ stated truly):
//! - `noise_only_gap_test_rate` (30 data sets without a hidden effect): 0 false gaps, mean
//!   z −0.67 (slightly conservative), held-out RMS 0.74–1.17× the floor. Before the gap
//!   test included the folds' parameter-estimation error
//!   (`kincal::identify::held_out_estimation_error`) it found a gap in 10/30 (mean z 3.65).
//!   Asserted: at most 2 of 30.
//! - `contacts_blind` (21 cases): no over-claim (the third harmonic is named joint_cyclic
//!   but only `partially_explained`: contact data have no form check, so joint_cyclic is
//!   never `explained`, `io::diagnose_contacts::FORM_NOT_DETERMINED`; bending never named);
//!   every case without an effect `no_gap`; joint_scale and joint_compliance explained at
//!   every size; joint_cyclic at 1 and thermal at 1 and 2.5 below the gap test (`no_gap`);
//!   2 misses, a gap found but no candidate significant: joint_cyclic at 2.5 and thermal at
//!   4 (12 held-out sockets give the paired rank test little power). Asserted: no case
//!   without an effect with a gap, no out-of-library effect `explained`, at most 3 wrong.

use std::fs;
use std::path::Path;

use kincal::ik::{IkOptions, solve_ik};
use kincal::params::LinkParam;
use kincal::rng::SplitMix64;
use kincal::sim::{add_effect, perturb_geometry};
use kincal::{Effect, JointState, ParamId, Robot, Transform, aria};
use serde_json::Value;

mod common;
use common::{kincal, text};

const SIGMA_M: f64 = 2e-5;
const TARGETS: usize = 12;
const SESSIONS: usize = 4;
const HOLDS: usize = 8;

#[derive(Debug, Clone, Copy)]
enum Hidden {
    None,
    Library(Effect, f64),
    /// Δθ_j = s·1 mrad·(sin 3q_j + cos 3q_j)·c_j.
    ThirdHarmonic(f64),
    /// Δα_2 = s·5 mrad·cos q_2.
    Bending(f64),
}

/// The truth at reading `st` as the out-of-library effect moves it.
fn bent(truth: &Robot<6>, hidden: Hidden, q: &[f64; 6]) -> Robot<6> {
    let mut r = *truth;
    let mut bump = |link: usize, kind: LinkParam, d: f64| {
        let i = ParamId::Link { link, kind }.index(6);
        let v = r.param(i).unwrap();
        r.set_param(i, v + d).unwrap();
    };
    match hidden {
        Hidden::ThirdHarmonic(s) => {
            for (j, qj) in q.iter().enumerate() {
                let c = [0.7, -1.1, 0.9, -0.6, 1.2, -0.8][j];
                bump(
                    j,
                    LinkParam::Theta0,
                    s * 1e-3 * c * ((3.0 * qj).sin() + (3.0 * qj).cos()),
                );
            }
        }
        Hidden::Bending(s) => bump(1, LinkParam::Alpha, s * 5e-3 * q[1].cos()),
        _ => {}
    }
    r
}

/// Readings holding the ball centre of `truth` (with `hidden`) at `p` + noise, tilted.
fn hold(
    truth: &Robot<6>,
    hidden: Hidden,
    p: nalgebra::Vector3<f64>,
    seed: &JointState<6>,
    rng: &mut SplitMix64,
) -> Option<JointState<6>> {
    let t0 = truth.fk(seed).ok()?;
    let axis = nalgebra::Vector3::new(
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
    );
    let r = t0.rotation
        * nalgebra::Rotation3::from_scaled_axis(axis.normalize() * rng.range(0.05, 0.35));
    let noisy = p + nalgebra::Vector3::new(rng.normal(), rng.normal(), rng.normal()) * SIGMA_M;
    let opts = IkOptions {
        extra_seeds: 4,
        first_solution: true,
        ..IkOptions::default()
    };
    // The out-of-library effect depends on the readings: a fixed-point iteration.
    let mut st = *seed;
    let mut robot = *truth;
    for _ in 0..6 {
        let pose = Transform::from_parts(nalgebra::Translation3::from(noisy), r);
        let sol = solve_ik(&robot, &pose, &st, &opts).ok()?;
        if sol.residual_pos_m > 1e-9 {
            return None;
        }
        st.q = sol.q;
        robot = bent(truth, hidden, &st.q);
    }
    Some(st)
}

/// One case's files in `dir`; returns nothing (the CLI reads them).
fn write_case(dir: &Path, hidden: Hidden, seed: u64) {
    let rng = SplitMix64::new(seed);
    let nominal = aria::nominal();
    let mut truth = perturb_geometry(&nominal, 2e-3, 1f64.to_radians(), &mut rng.fork(1)).unwrap();
    truth = truth
        .with_tool([0.002, -0.001, 0.03, 0.0, 0.0, 0.0])
        .unwrap();
    if let Hidden::Library(e, size) = hidden {
        add_effect(&mut truth, e, size, &mut rng.fork(2)).unwrap();
    }
    let mut r = rng.fork(3);
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,target,session,temp_c\n");
    let mut centres = Vec::new();
    for t in 0..TARGETS {
        let s = t % SESSIONS;
        let temp = 22.0 + 20.0 * t as f64 / (TARGETS - 1) as f64;
        let mut q0 = aria::TOOL_SEED_Q;
        for v in q0.iter_mut() {
            *v += r.range(-0.5, 0.5);
        }
        let seed_state = JointState {
            q: q0,
            approach: None,
            temp_c: Some(temp),
        };
        let p = truth.fk(&seed_state).unwrap().translation.vector;
        let mut n = 0;
        let mut tries = 0;
        while n < HOLDS && tries < 20 * HOLDS {
            tries += 1;
            if let Some(st) = hold(&truth, hidden, p, &seed_state, &mut r) {
                let cells: Vec<String> = st.q.iter().map(|v| format!("{v}")).collect();
                csv.push_str(&format!("{},t{t},loc{s},{temp}\n", cells.join(",")));
                n += 1;
            }
        }
        assert_eq!(n, HOLDS, "case {seed}: target {t}");
        centres.push(p);
    }
    let mut toml = String::new();
    for s in 0..SESSIONS {
        for (a, b) in [(s, s + SESSIONS), (s + SESSIONS, s + 2 * SESSIONS)] {
            let d = (centres[a] - centres[b]).norm();
            toml.push_str(&format!(
                "[[distance]]\nbetween = [\"t{a}\", \"t{b}\"]\nm = {d}\n\n"
            ));
        }
    }
    fs::write(dir.join("contacts.csv"), csv).unwrap();
    fs::write(dir.join("constraints.toml"), toml).unwrap();
}

/// Writes the case and runs `kincal diagnose` on it with the true σ stated: its JSON.
fn diagnose_case(hidden: Hidden, seed: u64) -> Value {
    let dir = tempfile::tempdir().unwrap();
    write_case(dir.path(), hidden, seed);
    let sigma_mm = format!("{}", SIGMA_M * 1e3);
    let o = kincal(
        &[
            "diagnose",
            "contacts.csv",
            "--robot",
            "aria",
            "--constraints",
            "constraints.toml",
            "--sigma-pos-mm",
            &sigma_mm,
            "--json",
            "d.json",
            "--out",
            "unused.json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{hidden:?} {seed}: {}", text(&o));
    serde_json::from_str(&fs::read_to_string(dir.path().join("d.json")).unwrap()).unwrap()
}

/// The verdict's status, what it named, and whether that is right for `hidden`.
fn run_case(hidden: Hidden, seed: u64) -> (String, String, bool) {
    let v = diagnose_case(hidden, seed);
    let status = v["verdict"]["status"].as_str().unwrap_or("?").to_string();
    let named = v["verdict"]["effects"].to_string();
    let confounded = v["verdict"]["confounded_with"].to_string();
    let right = match hidden {
        Hidden::None => status == "no_gap",
        Hidden::Library(e, _) => {
            status == "no_gap" || named.contains(e.name()) || confounded.contains(e.name())
        }
        Hidden::ThirdHarmonic(_) | Hidden::Bending(_) => status != "explained",
    };
    (
        status,
        format!(
            "{named} confounded {confounded} gap_z {:.1}",
            v["gap_z"].as_f64().unwrap_or(f64::NAN)
        ),
        right,
    )
}

#[test]
#[ignore = "a measuring instrument: run in release with --ignored --nocapture"]
fn contacts_blind() {
    let mut cases = vec![];
    for k in 0..3u64 {
        cases.push((Hidden::None, 100 + k));
        for (i, e) in [
            Effect::JointScale,
            Effect::JointCyclic,
            Effect::JointCompliance,
            Effect::Thermal,
        ]
        .into_iter()
        .enumerate()
        {
            cases.push((
                Hidden::Library(e, 1.0 + k as f64 * 1.5),
                200 + 10 * i as u64 + k,
            ));
        }
        cases.push((Hidden::ThirdHarmonic(0.5 + k as f64), 300 + k));
        cases.push((Hidden::Bending(0.5 + k as f64), 400 + k));
    }
    let mut wrong = 0;
    for (hidden, seed) in cases {
        let (status, said, right) = run_case(hidden, seed);
        if !right {
            wrong += 1;
        }
        // The two errors that mislead: a gap on clean data, a cause outside the library
        // claimed.
        match hidden {
            Hidden::None => assert_eq!(status, "no_gap", "{hidden:?} {seed}: {said}"),
            Hidden::ThirdHarmonic(_) | Hidden::Bending(_) => {
                assert_ne!(status, "explained", "{hidden:?} {seed}: {said}");
            }
            Hidden::Library(..) => {}
        }
        println!(
            "{:40} {:20} {said} {}",
            format!("{hidden:?}"),
            status,
            if right { "" } else { "WRONG" }
        );
    }
    println!("wrong: {wrong}");
    assert!(wrong <= 3, "{wrong} wrong");
}

/// The gap test's rate of false gaps on data without a hidden effect (prints each data
/// set's z, held-out RMS against the floor, and the status).
#[test]
#[ignore = "a measuring instrument: run in release with --ignored --nocapture"]
fn noise_only_gap_test_rate() {
    let mut zs = Vec::new();
    for k in 0..30u64 {
        let v = diagnose_case(Hidden::None, 1000 + k);
        let z = v["gap_z"].as_f64().unwrap();
        let geo = v["candidates"][0]["heldout_rms_mm"].as_f64().unwrap();
        let floor = v["noise_floor"]["heldout_rms_at_floor_mm"]
            .as_f64()
            .unwrap();
        println!(
            "z {z:.2} rms {geo:.5} floor {floor:.5} ratio {:.3} status {}",
            geo / floor,
            v["verdict"]["status"]
        );
        zs.push(z);
    }
    zs.sort_by(f64::total_cmp);
    let mean = zs.iter().sum::<f64>() / zs.len() as f64;
    println!(
        "mean z {mean:.2}, median {:.2}, > 3: {}",
        zs[zs.len() / 2],
        zs.iter().filter(|&&z| z > 3.0).count()
    );
    // At z > 3 one false gap in 740 is expected: more than 2 of 30 is a biased test.
    let false_gaps = zs.iter().filter(|&&z| z > 3.0).count();
    assert!(false_gaps <= 2, "{false_gaps} false gaps in 30");
}
