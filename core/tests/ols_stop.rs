//! When OLS stops: a fit at its exact minimum ends converged, at once (it must not keep
//! accepting rounding-level "gains"), and a fit whose Gauss–Newton step is abnormal is not
//! declared converged short of its minimum (solvers.rs, `gauss_newton`).

mod common;

use common::aria_tool_data;
use kincal::aria;
use kincal::identify::{Algorithm, IdentifyOptions, Workspace, identify};

/// Octave `matlab/tests/test_identify.m`, `too_few_poses`, in Rust: the gateway's default
/// options (OLS, ARIA's geometric parameters, `kincal_identify_options_default`) on the
/// first two tool poses with `allow_data_deficiency`; 12 combinations are identifiable.
///
/// Not an exact fit: the two poses are not reproduced exactly by the identifiable subset.
/// Plain Gauss–Newton crawled there (38 iterations, the accepted share of the step falling
/// to 2⁻³⁰ while its length grew to 17,700 times the parameters' norm and the model kept
/// predicting the whole cost as gain) and stopped "converged" at cost 0.0714 when every cut
/// failed. A damped rescue (commit 387882d, reverted) ran from there into `NotConverged`
/// after 200 iterations. OLS now hands such a fit to OPT2's trust region: it must end
/// converged, within the iteration cap, at the minimum OPT2 finds on its own (the
/// independent check), far below the old stop. At that minimum (12 rows, non-zero cost)
/// the Jacobian is singular: both fits also hold alpha_4, found data-deficient there
/// (`core/src/identify/at_fit.rs`), and refit the other 11.
#[test]
fn two_poses_reach_the_minimum_opt2_finds() {
    let nominal = aria::nominal();
    let data = &aria_tool_data()[..2];
    let mut opts = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
    let mut ws = Box::<Workspace<32>>::default();
    // Without the flag: refused as rank deficient.
    assert!(identify(&nominal, data, &opts, &mut ws).is_err());
    opts.allow_data_deficiency = true;
    let r = identify(&nominal, data, &opts, &mut ws).expect("OLS converges");
    assert!(r.analysis.rank <= 12, "rank {}", r.analysis.rank);
    assert!(!r.analysis.data_deficient.is_empty());
    assert!(r.iterations < opts.max_iterations, "{}", r.iterations);
    let mut o2 = opts;
    o2.algorithm = Algorithm::Opt2;
    let lm = identify(&nominal, data, &o2, &mut ws).expect("OPT2 converges");
    assert_eq!(r.analysis.data_deficient, lm.analysis.data_deficient);
    assert_eq!(r.analysis.rank, 11);
    let (c, c_lm) = (r.fitted.cost, lm.fitted.cost);
    assert!((c - c_lm).abs() <= 1e-6 * c_lm, "OLS {c} vs OPT2 {c_lm}");
    assert!(c < 0.1 * 0.0714, "{c}");
}
