//! The d/β choice (spec/aria.md, Section 3.1): a link whose axis is parallel to the next
//! one identifies β instead of d; the last link always identifies d; the choice can be
//! overridden, and the geometric parameter set follows it.

use kincal::model::PARALLEL_AXES_TOL_RAD;
use kincal::params::{LinkParam, ParamId};
use kincal::{Error, JointLimits, LengthParam, Link, Robot, aria};

const D: LengthParam = LengthParam::D;
const B: LengthParam = LengthParam::Beta;

fn idx(link: usize, kind: LinkParam) -> usize {
    ParamId::Link { link, kind }.index(6).0
}

#[test]
fn aria_link2_identifies_beta_the_others_d() {
    let robot = aria::nominal();
    assert_eq!(robot.length_params(), &[D, B, D, D, D, D]);
    assert_eq!(robot.auto_length_params(), [D, B, D, D, D, D]);
    // Table 3 and Table 4 robots keep Table 1's choice (as the paper's Tables 3-4 show).
    assert_eq!(aria::virtual_truth().length_params(), &[D, B, D, D, D, D]);
    assert_eq!(aria::real_identified().length_params(), &[D, B, D, D, D, D]);
    let set = robot.geometric_param_set();
    assert_eq!(set.len(), 4 * 6);
    assert!(set.contains(idx(1, LinkParam::Beta)));
    assert!(!set.contains(idx(1, LinkParam::D)));
    for link in [0, 2, 3, 4, 5] {
        assert!(set.contains(idx(link, LinkParam::D)), "d_{}", link + 1);
        assert!(
            !set.contains(idx(link, LinkParam::Beta)),
            "beta_{}",
            link + 1
        );
    }
    for link in 0..6 {
        for kind in [LinkParam::Theta0, LinkParam::A, LinkParam::Alpha] {
            assert!(set.contains(idx(link, kind)));
        }
    }
}

/// All axes parallel (a planar arm, α = 0 everywhere): every link identifies β except the
/// last, which always identifies d.
#[test]
fn last_link_always_identifies_d() {
    let links = [Link::dh(0.0, 0.1, 0.3, 0.0); 4];
    let robot = Robot::new(links, [JointLimits::new(-3.0, 3.0); 4]).expect("robot");
    assert_eq!(robot.length_params(), &[B, B, B, D]);
    let links = [Link::dh(0.0, 0.1, 0.3, 0.0)];
    let robot = Robot::new(links, [JointLimits::new(-3.0, 3.0)]).expect("robot");
    assert_eq!(robot.length_params(), &[D]);
}

/// Parallel within [`PARALLEL_AXES_TOL_RAD`] (1°), antiparallel counts as parallel, twist
/// by β counts too.
#[test]
fn parallelism_threshold() {
    let lim = [JointLimits::new(-3.0, 3.0); 2];
    let choice = |alpha: f64, beta: f64| {
        let first = Link {
            theta0: 0.0,
            d: 0.1,
            a: 0.2,
            alpha,
            beta,
        };
        Robot::new([first, Link::dh(0.0, 0.1, 0.1, 0.0)], lim)
            .expect("robot")
            .length_params()[0]
    };
    let tol = PARALLEL_AXES_TOL_RAD;
    assert!((tol - 1f64.to_radians()).abs() < 1e-15);
    assert_eq!(choice(0.0, 0.0), B);
    assert_eq!(choice(0.5 * tol, 0.0), B);
    assert_eq!(choice(-0.9 * tol, 0.0), B);
    assert_eq!(choice(1.1 * tol, 0.0), D);
    assert_eq!(choice(0.0, 1.1 * tol), D);
    assert_eq!(choice(std::f64::consts::PI, 0.0), B);
    assert_eq!(choice(std::f64::consts::PI - 0.5 * tol, 0.0), B);
    assert_eq!(choice(std::f64::consts::FRAC_PI_2, 0.0), D);
}

#[test]
fn choice_is_overridable() {
    let mut robot = aria::nominal();
    robot.set_length_param(1, D).expect("override link 2");
    robot.set_length_param(3, B).expect("override link 4");
    assert_eq!(robot.length_params(), &[D, D, D, B, D, D]);
    let set = robot.geometric_param_set();
    assert!(set.contains(idx(1, LinkParam::D)) && !set.contains(idx(1, LinkParam::Beta)));
    assert!(set.contains(idx(3, LinkParam::Beta)) && !set.contains(idx(3, LinkParam::D)));
    // The automatic choice is still available and unchanged.
    assert_eq!(robot.auto_length_params(), [D, B, D, D, D, D]);
    // Out of range.
    assert!(matches!(
        robot.set_length_param(6, D),
        Err(Error::DimensionMismatch { .. })
    ));
    assert_eq!(robot.length_params(), &[D, D, D, B, D, D]);
}
