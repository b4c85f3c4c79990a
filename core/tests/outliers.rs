//! Bad data: outliers are named by the residual test and kept from pulling the model by the
//! robust fit; degenerate data sets give the identifiability report and a clear error.

use kincal::identify::{
    Algorithm, IdentifyOptions, Loss, Measurement, PoseResidual, RobustOptions, Workspace, analyze,
    identify, identify_robust,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::pose::{Transform, rotation_exp, transform};
use kincal::rng::SplitMix64;
use kincal::validation::{ErrorSummary, PoseErrors};
use kincal::{Error, JointState, ParamId, ParamIndex, Robot, aria};
use nalgebra::Vector3;

type Ws = Workspace<64>;

/// Instrument noise of the simulated data (1σ per axis).
const SIGMA_POS_M: f64 = 1e-4;
const SIGMA_ROT_RAD: f64 = 0.02 * std::f64::consts::PI / 180.0;

/// Configurations: the Table 2 tool poses and the working-region grid, solved on `truth`.
fn configs(truth: &Robot<6>) -> Vec<[f64; 6]> {
    let mut poses = [Transform::identity(); 64];
    let n = aria::working_region_grid(4, 4, 2, &mut poses);
    let opts = IkOptions {
        first_solution: true,
        ..IkOptions::default()
    };
    (0..10)
        .map(|l| aria::tool_pose(l).unwrap())
        .chain(poses[..n].iter().copied())
        .filter_map(|p| solve_ik(truth, &p, &JointState::new(aria::TOOL_SEED_Q), &opts).ok())
        .map(|s| s.q)
        .collect()
}

fn noisy_data(truth: &Robot<6>, configs: &[[f64; 6]], seed: u64) -> Vec<Measurement<6>> {
    let mut rng = SplitMix64::new(seed);
    configs
        .iter()
        .map(|q| {
            let t = truth.fk_q(q).unwrap();
            let dp = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * SIGMA_POS_M;
            let dr = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * SIGMA_ROT_RAD;
            Measurement::new(
                *q,
                transform(
                    rotation_exp(&dr) * t.rotation.matrix(),
                    t.translation.vector + dp,
                ),
            )
        })
        .collect()
}

/// Worst position [m] and orientation [rad] difference between two models over `configs`.
fn model_difference(a: &Robot<6>, b: &Robot<6>, configs: &[[f64; 6]]) -> (f64, f64) {
    let mut s = ErrorSummary::default();
    for q in configs {
        s.add(&PoseErrors::between(
            &a.fk_q(q).unwrap(),
            &b.fk_q(q).unwrap(),
        ));
    }
    (s.max_pos_m, s.max_rot_rad)
}

#[derive(Debug, Clone, Copy)]
enum Bad {
    /// The pose was recorded with the joint readings of another row.
    WrongJointRow,
    /// The measured position is off by 5 mm along x.
    Glitch5mm,
    /// The measured x and y are swapped.
    SwappedAxis,
}

fn corrupt(data: &mut [Measurement<6>], row: usize, bad: Bad) {
    match bad {
        Bad::WrongJointRow => {
            let other = (row + 1) % data.len();
            data[row].state = data[other].state;
        }
        Bad::Glitch5mm => data[row].pose.translation.vector.x += 5e-3,
        Bad::SwappedAxis => {
            let v = &mut data[row].pose.translation.vector;
            let x = v.x;
            v.x = v.y;
            v.y = x;
        }
    }
}

/// The robust model is "close" to the model fitted to the clean data when the two predict
/// every configuration of the data within this [m] …
const CLOSE_POS_M: f64 = 1e-4;
/// … and this [rad].
const CLOSE_ROT_RAD: f64 = 0.015 * std::f64::consts::PI / 180.0;
/// The plain fit is "not close" when it is off by more than this [m] somewhere.
const FAR_POS_M: f64 = 2.5 * CLOSE_POS_M;
/// A bad row stands out far above the suspect threshold (d ≈ 5.3): at least this.
const BAD_ROW_MIN_DISTANCE: f64 = 20.0;
/// A clean pose may be named only as a borderline case (at most one per data set).
const BORDERLINE_DISTANCE: f64 = 6.5;

fn ols() -> IdentifyOptions<'static> {
    IdentifyOptions::new(Algorithm::Ols, aria::nominal().geometric_param_set())
}

fn suspects(report: &[PoseResidual]) -> Vec<usize> {
    (0..report.len()).filter(|&l| report[l].suspect).collect()
}

#[test]
fn each_kind_of_bad_data_is_named_and_does_not_pull_the_robust_fit() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    assert!(cfg.len() >= 60, "only {} configurations", cfg.len());
    let mut ws = Box::<Ws>::default();
    let cases: [(&[Bad], &[usize]); 4] = [
        (&[Bad::WrongJointRow], &[5]),
        (&[Bad::Glitch5mm], &[17]),
        (&[Bad::SwappedAxis], &[30]),
        (
            &[Bad::WrongJointRow, Bad::Glitch5mm, Bad::SwappedAxis],
            &[3, 21, 40],
        ),
    ];
    let mut worst_robust: (f64, f64) = (0.0, 0.0);
    let mut least_plain = f64::INFINITY;
    for seed in 0..5 {
        let clean = noisy_data(&truth, &cfg, seed);
        let clean_fit = identify(&nominal, &clean, &ols(), &mut ws).unwrap();
        for (bad, rows) in cases {
            let mut data = clean.clone();
            for (&b, &r) in bad.iter().zip(rows) {
                corrupt(&mut data, r, b);
            }
            let plain = identify(&nominal, &data, &ols(), &mut ws).unwrap();
            let dp = model_difference(&plain.robot, &clean_fit.robot, &cfg);
            assert!(
                dp.0 > FAR_POS_M,
                "seed {seed} {bad:?}: plain fit only {} m off",
                dp.0
            );
            least_plain = least_plain.min(dp.0);
            for loss in Loss::ALL {
                let what = format!("seed {seed} {bad:?} {loss:?}");
                let mut report = vec![PoseResidual::default(); data.len()];
                let before = data.clone();
                let r = identify_robust(
                    &nominal,
                    &mut data,
                    &ols(),
                    &RobustOptions::new(loss),
                    &mut report,
                    &mut ws,
                )
                .unwrap();
                assert_eq!(data, before, "{what}: data changed");
                let found = suspects(&report);
                for &row in rows {
                    assert!(
                        found.contains(&row),
                        "{what}: row {row} not named: {found:?}"
                    );
                    assert!(
                        report[row].distance > BAD_ROW_MIN_DISTANCE,
                        "{what}: row {row}"
                    );
                    assert!(
                        report[row].robust_weight < 0.15,
                        "{what}: row {row} weight {}",
                        report[row].robust_weight
                    );
                }
                let others: Vec<usize> = found
                    .iter()
                    .copied()
                    .filter(|l| !rows.contains(l))
                    .collect();
                assert!(others.len() <= 1, "{what}: clean poses named: {others:?}");
                for &l in &others {
                    assert!(
                        report[l].distance < BORDERLINE_DISTANCE,
                        "{what}: clean pose {l} d = {}",
                        report[l].distance
                    );
                }
                assert_eq!(r.test.n_suspect, found.len());
                let dr = model_difference(&r.fit.robot, &clean_fit.robot, &cfg);
                assert!(
                    dr.0 < CLOSE_POS_M && dr.1 < CLOSE_ROT_RAD,
                    "{what}: robust fit off by {} m, {} rad",
                    dr.0,
                    dr.1
                );
                worst_robust = (worst_robust.0.max(dr.0), worst_robust.1.max(dr.1));
                // The scales are the noise's, not the outliers'.
                assert!(
                    (0.8e-4..1.25e-4).contains(&r.test.scale_pos_m),
                    "{what}: {:?}",
                    r.test
                );
            }
        }
    }
    println!(
        "robust fits within {:.4} mm / {:.5} deg of the clean fit; plain fits at least {:.3} mm off",
        worst_robust.0 * 1e3,
        worst_robust.1.to_degrees(),
        least_plain * 1e3
    );
}

#[test]
fn clean_data_rarely_names_a_pose_and_the_robust_fit_stays_with_least_squares() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    let mut ws = Box::<Ws>::default();
    let (mut named, mut tested) = (0, 0);
    let mut worst: f64 = 0.0;
    for seed in 100..130 {
        let mut data = noisy_data(&truth, &cfg, seed);
        let plain = identify(&nominal, &data, &ols(), &mut ws).unwrap();
        let mut report = vec![PoseResidual::default(); data.len()];
        let r = identify_robust(
            &nominal,
            &mut data,
            &ols(),
            &RobustOptions::new(Loss::Huber),
            &mut report,
            &mut ws,
        )
        .unwrap();
        named += r.test.n_suspect;
        tested += data.len();
        worst = worst.max(model_difference(&r.fit.robot, &plain.robot, &cfg).0);
    }
    println!(
        "{named} of {tested} clean poses named; robust vs plain at most {:.4} mm",
        worst * 1e3
    );
    // Nominal rate 1e-4 per pose; the estimated scales add some: allow 2e-3.
    assert!(
        named as f64 <= 2e-3 * tested as f64,
        "{named} of {tested} clean poses named"
    );
    assert!(
        worst < 0.5 * CLOSE_POS_M,
        "Huber moved clean data's fit by {worst} m"
    );
}

#[test]
fn position_only_data_and_a_fixed_scale() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    let mut data = noisy_data(&truth, &cfg, 9);
    for m in &mut data {
        m.mask = kincal::identify::ComponentMask::POSITION;
    }
    let clean = data.clone();
    corrupt(&mut data, 12, Bad::Glitch5mm);
    let mut ws = Box::<Ws>::default();
    let clean_fit = identify(&nominal, &clean, &ols(), &mut ws).unwrap();
    for scale in [None, Some((SIGMA_POS_M, SIGMA_ROT_RAD))] {
        let mut ropts = RobustOptions::new(Loss::Cauchy);
        ropts.scale = scale;
        let mut report = vec![PoseResidual::default(); data.len()];
        let r = identify_robust(&nominal, &mut data, &ols(), &ropts, &mut report, &mut ws).unwrap();
        assert_eq!(suspects(&report), vec![12], "{scale:?}");
        assert_eq!(report[12].components, 3);
        let dr = model_difference(&r.fit.robot, &clean_fit.robot, &cfg);
        // Position-only data determine the model less well: twice the tolerance.
        assert!(dr.0 < 2.0 * CLOSE_POS_M, "{scale:?}: {dr:?}");
        if let Some((sp, _)) = scale {
            assert_eq!(r.test.scale_pos_m, sp);
        }
    }
}

#[test]
fn held_out_poses_stay_out_and_are_still_tested() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    let mut data = noisy_data(&truth, &cfg, 3);
    corrupt(&mut data, 8, Bad::SwappedAxis);
    data[8].weight = 0.0;
    let mut ws = Box::<Ws>::default();
    let plain = identify(&nominal, &data, &ols(), &mut ws).unwrap();
    let mut report = vec![PoseResidual::default(); data.len()];
    let r = identify_robust(
        &nominal,
        &mut data,
        &ols(),
        &RobustOptions::new(Loss::Huber),
        &mut report,
        &mut ws,
    )
    .unwrap();
    assert_eq!(data[8].weight, 0.0);
    assert_eq!(report[8].prior_weight, 0.0);
    assert!(report[8].suspect, "the held-out bad pose is not named");
    assert_eq!(r.fit.fitted.poses, data.len() - 1);
    // Without the bad pose in the fit, plain and robust agree.
    assert!(model_difference(&r.fit.robot, &plain.robot, &cfg).0 < 0.5 * CLOSE_POS_M);
}

#[test]
fn robust_options_and_report_are_checked() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    let mut data = noisy_data(&truth, &cfg, 4);
    let mut ws = Box::<Ws>::default();
    let mut short = vec![PoseResidual::default(); data.len() - 1];
    assert!(matches!(
        identify_robust(
            &nominal,
            &mut data,
            &ols(),
            &RobustOptions::new(Loss::Huber),
            &mut short,
            &mut ws
        ),
        Err(Error::DimensionMismatch { .. })
    ));
    let mut report = vec![PoseResidual::default(); data.len()];
    let mut bad = RobustOptions::new(Loss::Huber);
    bad.tuning_chi2[5] = f64::NAN;
    assert!(matches!(
        identify_robust(&nominal, &mut data, &ols(), &bad, &mut report, &mut ws),
        Err(Error::NonFinite { .. })
    ));
    let mut bad = RobustOptions::new(Loss::Huber);
    bad.scale = Some((0.0, 1e-4));
    assert!(matches!(
        identify_robust(&nominal, &mut data, &ols(), &bad, &mut report, &mut ws),
        Err(Error::InvalidParameter { .. })
    ));
    let mut few = RobustOptions::new(Loss::Cauchy);
    few.max_reweights = 1;
    corrupt(&mut data, 2, Bad::Glitch5mm);
    let before = data.clone();
    assert!(matches!(
        identify_robust(&nominal, &mut data, &ols(), &few, &mut report, &mut ws),
        Err(Error::NotConverged { .. })
    ));
    assert_eq!(data, before, "weights not restored after an error");
    assert_eq!(Loss::parse("cauchy"), Some(Loss::Cauchy));
    assert_eq!(Loss::parse("l1"), None);
}

// ---------------------------------------------------------------------------------------
// Degenerate data sets

fn label(i: usize) -> String {
    ParamId::from_index(ParamIndex(i), 6).unwrap().to_string()
}

/// 40 random configurations with joint `joint` (zero-based) held at one reading.
fn with_joint_held(nominal: &Robot<6>, joint: usize, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = SplitMix64::new(seed);
    (0..40)
        .map(|_| {
            core::array::from_fn(|j| {
                let l = nominal.limits()[j];
                let v = rng.range(l.lower.max(-3.0), l.upper.min(3.0));
                if j == joint { 0.3 } else { v }
            })
        })
        .collect()
}

#[test]
fn a_joint_that_never_moved_gives_the_report_and_a_clear_error() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let mut ws = Box::<Ws>::default();
    // With the base frame fixed, joint 1's constant rotation is still determined (rank 24);
    // for the others, the parameters of the link before and after the held joint describe
    // one fixed transform with more parameters than it has degrees of freedom.
    for joint in 0..6 {
        let cfg = with_joint_held(&nominal, joint, 11 + joint as u64);
        let data = noisy_data(&truth, &cfg, joint as u64);
        let a = analyze(&nominal, &data, &ols(), &mut ws).unwrap();
        let lost: Vec<String> = a.data_deficient.iter().map(label).collect();
        println!(
            "joint {} never moved: rank {}, data-deficient {lost:?}",
            joint + 1,
            a.rank
        );
        if joint == 0 {
            assert_eq!(a.rank, 24, "joint 1: {lost:?}");
            continue;
        }
        assert!(
            !a.data_deficient.is_empty(),
            "joint {}: nothing reported",
            joint + 1
        );
        for i in a.data_deficient.iter() {
            assert!(
                a.partner[i].is_some(),
                "joint {}: {} has no partner",
                joint + 1,
                label(i)
            );
        }
        match identify(&nominal, &data, &ols(), &mut ws) {
            Err(e @ Error::RankDeficient { rank, required }) => {
                assert_eq!((rank, required), (a.rank, 24));
                assert!(e.to_string().contains("rank deficient"), "{e}");
            }
            other => panic!("joint {}: expected RankDeficient, got {other:?}", joint + 1),
        }
        let mut d = data.clone();
        let mut report = vec![PoseResidual::default(); d.len()];
        assert!(matches!(
            identify_robust(
                &nominal,
                &mut d,
                &ols(),
                &RobustOptions::new(Loss::Huber),
                &mut report,
                &mut ws
            ),
            Err(Error::RankDeficient { .. })
        ));
    }
}

#[test]
fn empty_single_and_identical_pose_sets_give_clear_errors() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let cfg = configs(&truth);
    let data = noisy_data(&truth, &cfg, 1);
    let mut ws = Box::<Ws>::default();
    let identical = vec![data[0]; 30];
    let mut held_out = data.clone();
    for m in &mut held_out {
        m.weight = 0.0;
    }
    for set in [&data[..0], &held_out[..]] {
        let e = Error::TooFewData {
            found: 0,
            needed: 24,
        };
        assert_eq!(analyze(&nominal, set, &ols(), &mut ws).unwrap_err(), e);
        assert_eq!(identify(&nominal, set, &ols(), &mut ws).unwrap_err(), e);
        assert_eq!(e.to_string(), "too few data: 0 given, at least 24 needed");
    }
    for (name, set) in [("one pose", &data[..1]), ("30 equal poses", &identical[..])] {
        let a = analyze(&nominal, set, &ols(), &mut ws).unwrap();
        assert!(
            a.rank < 24 && a.rank + a.data_deficient.len() == 24,
            "{name}: {a:?}"
        );
        let e = identify(&nominal, set, &ols(), &mut ws).unwrap_err();
        assert_eq!(
            e,
            Error::RankDeficient {
                rank: a.rank,
                required: 24
            },
            "{name}"
        );
        let mut d = set.to_vec();
        let mut report = vec![PoseResidual::default(); d.len()];
        assert_eq!(
            identify_robust(
                &nominal,
                &mut d,
                &ols(),
                &RobustOptions::new(Loss::Cauchy),
                &mut report,
                &mut ws
            )
            .unwrap_err(),
            e,
            "{name}"
        );
    }
}
