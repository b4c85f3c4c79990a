//! Gaussian priors around the initial model (`IdentifyOptions::prior`): the limits of an
//! infinitely weak and an infinitely strong prior, a rank-deficient case where the prior
//! holds exactly the undetermined direction, and the posterior covariance against a
//! Monte-Carlo over seeds (truth drawn from the prior, data noise as weighted).

mod common;

use common::SplitMix64;
use kincal::identify::{
    Algorithm, Bounds, Identification, IdentifyOptions, Measurement, Prior, PriorSizes, Workspace,
    identify,
};
use kincal::pose::{rotation_exp, transform};
use kincal::{ParamIndex, ParamSet, Robot, aria};
use nalgebra::Vector3;

type Ws = Workspace<64>;

fn normal(rng: &mut SplitMix64) -> f64 {
    // Box–Muller from the test PRNG (independent of the core's generator).
    let u1 = rng.unit().max(1e-300);
    let u2 = rng.unit();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// `n` poses of `truth` at random configurations (seeded), with Gaussian noise of 1σ
/// `sp` [m] and `sr` [rad] per axis.
fn poses(truth: &Robot<6>, n: usize, seed: u64, sp: f64, sr: f64) -> Vec<Measurement<6>> {
    let mut rq = SplitMix64::new(seed);
    let mut rn = SplitMix64::new(seed ^ 0xabcd_ef01);
    (0..n)
        .map(|_| {
            let q = rq.q_within(truth.limits());
            let t = truth.fk_q(&q).unwrap();
            let dp = Vector3::new(normal(&mut rn), normal(&mut rn), normal(&mut rn)) * sp;
            let dr = Vector3::new(normal(&mut rn), normal(&mut rn), normal(&mut rn)) * sr;
            Measurement::new(
                q,
                transform(
                    rotation_exp(&dr) * t.rotation.matrix(),
                    t.translation.vector + dp,
                ),
            )
        })
        .collect()
}

fn params(r: &Robot<6>, set: &ParamSet) -> Vec<f64> {
    set.iter()
        .map(|i| r.param(ParamIndex(i)).unwrap())
        .collect()
}

fn fit(
    nominal: &Robot<6>,
    data: &[Measurement<6>],
    alg: Algorithm,
    prior: Option<&Prior>,
) -> Identification<6> {
    let bounds = Bounds::around(nominal, 0.05, 0.5);
    let mut opts = IdentifyOptions::new(alg, nominal.geometric_param_set());
    opts.bounds = Some(&bounds);
    opts.prior = prior;
    opts.allow_data_deficiency = true;
    let mut ws = Box::<Ws>::default();
    identify(nominal, data, &opts, &mut ws).unwrap()
}

#[test]
fn an_infinitely_weak_prior_is_todays_fit() {
    let nominal = aria::nominal();
    let data = poses(&aria::virtual_truth(), 12, 7, 5e-5, 3e-4);
    let none = Prior::around(&nominal, &PriorSizes::NONE);
    let mut weak = Prior::around(&nominal, &PriorSizes::links(1e9, 1e9));
    weak.data_variance = 5e-5 * 5e-5;
    let set = nominal.geometric_param_set();
    for alg in Algorithm::ALL {
        let today = fit(&nominal, &data, alg, None);
        // No finite σ: no row, bit for bit.
        let inf = fit(&nominal, &data, alg, Some(&none));
        assert_eq!(
            params(&today.robot, &set),
            params(&inf.robot, &set),
            "{alg:?}"
        );
        assert_eq!(today.sigma2, inf.sigma2, "{alg:?}");
        assert_eq!(today.std_errors, inf.std_errors, "{alg:?}");
        assert_eq!(inf.prior_rows, 0);
        // σ = 1e9 m / rad: rows whose weight vanishes next to the data's.
        let w = fit(&nominal, &data, alg, Some(&weak));
        assert_eq!(w.prior_rows, today.analysis.rank, "{alg:?}");
        let d = params(&today.robot, &set)
            .iter()
            .zip(params(&w.robot, &set))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!("{alg:?}: weak prior moves the fit by {d:.2e}");
        assert!(d < 1e-12, "{alg:?}: {d:e}");
        let ds = today
            .std_errors
            .iter()
            .zip(w.std_errors.iter())
            .map(|(a, b)| (a - b).abs() / a.max(1e-300))
            .fold(0.0, f64::max);
        assert!(ds < 1e-9, "{alg:?}: std errors differ by {ds:e} relative");
    }
}

#[test]
fn an_infinitely_strong_prior_keeps_the_nominal_model() {
    let nominal = aria::nominal();
    let data = poses(&aria::virtual_truth(), 12, 8, 5e-5, 3e-4);
    let strong = Prior::around(&nominal, &PriorSizes::links(1e-12, 1e-12));
    let set = nominal.geometric_param_set();
    for alg in Algorithm::ALL {
        let today = fit(&nominal, &data, alg, None);
        let r = fit(&nominal, &data, alg, Some(&strong));
        let moved = params(&r.robot, &set)
            .iter()
            .zip(params(&nominal, &set))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // Without the prior the fit moves by millimetres (the truth differs).
        let free = params(&today.robot, &set)
            .iter()
            .zip(params(&nominal, &set))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!("{alg:?}: strong prior moves {moved:.2e}, no prior {free:.2e}");
        assert!(free > 1e-4, "{alg:?}");
        assert!(moved < 1e-12, "{alg:?}: {moved:e}");
        // The posterior standard errors are the prior's σ.
        for i in r.analysis.identifiable.iter() {
            let s = r.std_errors[i];
            assert!(s < 2e-12 * r.sigma2.sqrt().max(1.0), "{alg:?} {i}: {s:e}");
        }
    }
}

#[test]
fn on_rank_deficient_data_the_prior_holds_exactly_the_undetermined_direction() {
    // Three noise-free poses (18 rows) for 24 parameters: the data leave some directions
    // undetermined. A prior on just those parameters must (a) fit them, (b) keep them at
    // the centre, and (c) leave everything else where the data-only fit puts it: the data
    // fit is exact either way, and only the undetermined direction is the prior's to decide.
    let nominal = aria::nominal();
    let data = poses(&aria::virtual_truth(), 3, 11, 0.0, 0.0);
    for alg in [Algorithm::Ols, Algorithm::Opt2, Algorithm::Opt1] {
        let today = fit(&nominal, &data, alg, None);
        let deficient = today.analysis.data_deficient;
        assert!(deficient.len() >= 6, "{alg:?}: {}", deficient.len());
        let mut prior = Prior::around(&nominal, &PriorSizes::NONE);
        for i in deficient.iter() {
            prior.sigma[i] = 1e-3;
        }
        let r = fit(&nominal, &data, alg, Some(&prior));
        assert_eq!(r.prior_held, deficient, "{alg:?}");
        assert_eq!(r.prior_rows, deficient.len());
        let held = params(&r.robot, &deficient)
            .iter()
            .zip(params(&nominal, &deficient))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let ident = today.analysis.identifiable;
        let rest = params(&r.robot, &ident)
            .iter()
            .zip(params(&today.robot, &ident))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "{alg:?}: {} undetermined held within {held:.1e}, the rest within {rest:.1e}",
            deficient.len()
        );
        // OPT1's damped steps stop on a relative cost reduction (ftol), a little before
        // the Gauss-Newton solvers, which land on rounding level.
        let tol = if alg == Algorithm::Opt1 { 1e-6 } else { 1e-12 };
        assert!(held < tol, "{alg:?}: {held:e}");
        assert!(rest < tol, "{alg:?}: {rest:e}");
        // A prior on every link parameter also fits the undetermined ones: they move now
        // (the prior trades them against the determined ones), but the fit stays exact
        // to the data's noise-free level only up to the prior's pull.
        let all = Prior::around(&nominal, &PriorSizes::DEFAULT);
        let r = fit(&nominal, &data, alg, Some(&all));
        assert_eq!(r.prior_held, deficient);
        assert!(r.prior_chi2 > 0.0 && r.prior_chi2.is_finite());
    }
}

#[test]
fn posterior_covariance_matches_a_monte_carlo_over_seeds() {
    // Truth drawn from the prior around nominal, noise as weighted (whitened rows), few
    // poses so that the prior matters: then the error of the MAP estimate has the posterior
    // covariance the fit reports (the model is close to linear at these sizes).
    let nominal = aria::nominal();
    let (sp, sr) = (5e-5, 3.5e-4);
    let sizes = PriorSizes::links(2e-4, 2e-3);
    let prior = Prior::around(&nominal, &sizes);
    let set = nominal.geometric_param_set();
    let links: Vec<usize> = set.iter().filter(|&i| prior.has(i)).collect();
    let runs = 300;
    let mut err2 = vec![0.0; 121];
    let mut var = vec![0.0; 121];
    let mut prior_var = 0.0;
    let mut mean_sigma2 = 0.0;
    let mut n_fit = 0;
    let mut rng = SplitMix64::new(2024);
    for seed in 0..runs {
        let mut truth = nominal;
        for &i in &links {
            let v = nominal.param(ParamIndex(i)).unwrap() + prior.sigma[i] * normal(&mut rng);
            truth.set_param(ParamIndex(i), v).unwrap();
        }
        // The same configurations every run (a fixed design), new noise.
        let mut data = poses(&truth, 4, 99, 0.0, 0.0);
        let mut rn = SplitMix64::new(1000 + seed);
        for m in &mut data {
            let dp = Vector3::new(normal(&mut rn), normal(&mut rn), normal(&mut rn)) * sp;
            let dr = Vector3::new(normal(&mut rn), normal(&mut rn), normal(&mut rn)) * sr;
            m.pose = transform(
                rotation_exp(&dr) * m.pose.rotation.matrix(),
                m.pose.translation.vector + dp,
            );
        }
        let mut opts = IdentifyOptions::new(Algorithm::Ols, set);
        opts.weight_pos = 1.0 / (sp * sp);
        opts.weight_rot = 1.0 / (sr * sr);
        opts.prior = Some(&prior);
        let mut ws = Box::<Ws>::default();
        let r = identify(&nominal, &data, &opts, &mut ws).unwrap();
        let fitted: Vec<usize> = r
            .analysis
            .identifiable
            .iter()
            .chain(r.prior_held.iter())
            .collect();
        for &i in &fitted {
            let e = r.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap();
            err2[i] += e * e;
            // The reported posterior variance, without the estimated σ² (whose scatter
            // over runs is not the question here).
            var[i] += r.std_errors[i] * r.std_errors[i] / r.sigma2;
        }
        prior_var += r.prior_chi2;
        mean_sigma2 += r.sigma2;
        n_fit += 1;
        if seed == 0 {
            println!(
                "rows {} + prior rows {}, fitted {}, held by the prior {}",
                r.fitted.rows,
                r.prior_rows,
                fitted.len(),
                r.prior_held.len()
            );
        }
    }
    assert_eq!(n_fit, runs);
    let mut worst: f64 = 0.0;
    let mut shrunk = 0;
    for &i in &links {
        if var[i] == 0.0 {
            continue;
        }
        let emp = err2[i] / runs as f64;
        let rep = var[i] / runs as f64;
        let ratio = emp / rep;
        if rep < 0.8 * prior.sigma[i] * prior.sigma[i] {
            shrunk += 1;
        }
        worst = worst.max((ratio.ln()).abs());
        println!(
            "{:>9}: MC σ {:.3e}, posterior σ {:.3e}, prior σ {:.1e}, ratio of variances {ratio:.3}",
            kincal::ParamId::from_index(ParamIndex(i), 6)
                .unwrap()
                .to_string(),
            emp.sqrt(),
            rep.sqrt(),
            prior.sigma[i]
        );
        // 300 runs: a variance is known to ±8 % (1σ); 4σ.
        assert!((0.7..1.43).contains(&ratio), "param {i}: ratio {ratio}");
    }
    println!("worst |ln ratio| {worst:.3}; {shrunk} parameters narrowed by the data");
    // The data narrow some parameters well below the prior, others hardly: both regimes.
    assert!(shrunk >= 5, "{shrunk}");
    assert!(prior_var > 0.0);
    // Whitened rows: σ² = data cost/(rows − n_eff) has expectation 1.
    mean_sigma2 /= runs as f64;
    println!("mean σ² {mean_sigma2:.3}");
    assert!((0.85..1.15).contains(&mean_sigma2), "{mean_sigma2}");
}
