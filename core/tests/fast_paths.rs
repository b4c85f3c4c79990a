//! The fast paths used by Monte-Carlo studies agree with the general ones.

use kincal::identify::{Algorithm, IdentifyOptions, Measurement, Workspace, identify};
use kincal::montecarlo::joint_sincos;
use kincal::rng::SplitMix64;
use kincal::{Effect, EffectSet, Error, JointState, ParamIndex, Robot, aria};

fn perturbed(seed: u64) -> Robot<6> {
    let mut r = aria::nominal();
    let mut rng = SplitMix64::new(seed);
    for i in r.geometric_param_set().iter() {
        let v = r.param(ParamIndex(i)).unwrap();
        r.set_param(ParamIndex(i), v + rng.range(-0.05, 0.05))
            .unwrap();
    }
    r
}

fn random_q(rng: &mut SplitMix64) -> [f64; 6] {
    let mut q = [0.0; 6];
    for v in q.iter_mut() {
        *v = rng.range(-3.0, 3.0);
    }
    q
}

#[test]
fn fk_from_sines_and_cosines_equals_fk() {
    let r = perturbed(1);
    let mut rng = SplitMix64::new(2);
    for _ in 0..50 {
        let q = random_q(&mut rng);
        let a = r.fk_q(&q).unwrap();
        let b = r.fk_sincos(&joint_sincos(&q)).unwrap();
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-14);
        assert!((a.rotation.matrix() - b.rotation.matrix()).norm() < 1e-14);
    }
    // θ0 changes are picked up.
    let mut r2 = r;
    r2.set_param(ParamIndex(15), 0.3).unwrap();
    let q = random_q(&mut rng);
    let a = r2.fk_q(&q).unwrap();
    let b = r2.fk_sincos(&joint_sincos(&q)).unwrap();
    assert!((a.translation.vector - b.translation.vector).norm() < 1e-14);
    // A model with a joint effect is refused, naming the parameter.
    let mut e = r;
    let idx = e
        .param_set(EffectSet::NONE.with(Effect::JointScale))
        .iter()
        .last()
        .unwrap();
    e.set_param(ParamIndex(idx), 1e-3).unwrap();
    assert_eq!(
        e.fk_sincos(&joint_sincos(&q)).map(|_| ()),
        Err(Error::InvalidParameter {
            index: idx,
            value: 1e-3
        })
    );
}

#[test]
fn link_only_jacobian_is_the_leading_block_of_the_geometric_one() {
    let r = perturbed(3);
    let mut rng = SplitMix64::new(4);
    let mut full = vec![[0.0; 6]; Robot::<6>::NUM_GEOMETRIC_PARAMS];
    let mut links = vec![[0.0; 6]; 30];
    for _ in 0..20 {
        let st = JointState::new(random_q(&mut rng));
        r.jacobian(&st, &mut full).unwrap();
        r.jacobian(&st, &mut links).unwrap();
        assert_eq!(&full[..30], &links[..]);
    }
    let mut bad = vec![[0.0; 6]; 29];
    assert!(r.jacobian(&JointState::new([0.0; 6]), &mut bad).is_err());
}

#[test]
fn covariance_off_gives_the_same_fit_without_standard_errors() {
    let nominal = aria::nominal();
    let truth = perturbed(5);
    let mut rng = SplitMix64::new(6);
    let data: Vec<Measurement<6>> = (0..12)
        .map(|_| {
            let q = random_q(&mut rng);
            let mut t = truth.fk_q(&q).unwrap();
            t.translation.vector.x += 1e-5 * rng.normal();
            Measurement::new(q, t)
        })
        .collect();
    let mut ws = Box::<Workspace<24>>::default();
    let mut opts = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
    let with = identify(&nominal, &data, &opts, &mut ws).unwrap();
    opts.covariance = false;
    let without = identify(&nominal, &data, &opts, &mut ws).unwrap();
    assert_eq!(with.robot, without.robot);
    assert!(with.std_errors.iter().any(|&s| s > 0.0));
    assert!(without.std_errors.iter().all(|&s| s == 0.0));
    assert_eq!(without.sigma2, 0.0);
}
