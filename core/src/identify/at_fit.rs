//! The data step of the identifiability analysis, confirmed at the fitted model.
//!
//! Why: [`super::analyze`] runs at the starting model, but data can make parameters
//! redundant through the measured values themselves. ARIA's ten tool poses all hold the
//! flange's x axis along the base's x, so once a model reproduces them, link 6's `a` and
//! the base's x move every pose alike. At the starting model, the model's errors tilt the
//! predicted axes apart by milliradians and hide the dependency (condition number 102).
//! The fit then picked an arbitrary split, all at zero residual: base x at −0.1, −11 and
//! −6 mm for OLS, OPT1 and OPT2 (`core/tests/identifiable_at_fit.rs`).
//!
//! So the fitted parameters are tested again at the model the solver returns, with the
//! same greedy test and tolerance. Usually a cheap screen settles it: the Cholesky factor
//! of the normal equations at the fit, which the covariance needs anyway, gives every
//! column's distance from the ones before it ([`all_kept_by_factor`]). Only when that is
//! near the tolerance, the Givens factor at the fit is formed and tested
//! ([`dropped_at`]). A parameter dropped there is reported as data-deficient and held at
//! its starting value, and the others are refitted from the start (in
//! `solvers::solve_confirmed`).

use super::data::{RowSource, accumulate_jacobian};
use super::identifiability::{Partner, ZERO_COLUMN_REL, greedy};
use super::{IdentifyOptions, MAX_MODEL_PARAMS, Workspace};
use crate::error::Result;
use crate::math::sqrt;
use crate::model::Robot;
use crate::params::ParamSet;

/// Factor by which the screen's residuals must clear the greedy test's tolerance: they
/// come from the normal equations, whose pivots carry a rounding error of about
/// `n·ε` relative to the column's squared norm (6e-3 of the squared tolerance 1e-12 at 28
/// columns).
const SCREEN_MARGIN: f64 = 4.0;

/// Whether the Cholesky factor `ws.mat` of the Gram matrix `ws.gram` (columns
/// `ws.cols[..n]`, unit column scale) proves that the greedy test with tolerance `tol`
/// keeps every column. While every column before it is kept, the greedy test's residual
/// of column k is its distance from their span over its norm, which the factor gives as
/// `r_kk/sqrt(G_kk)`. Columns must also clear the zero-column threshold.
pub(super) fn all_kept_by_factor<const P: usize>(ws: &Workspace<P>, n: usize, tol: f64) -> bool {
    let n = n.min(P);
    let g = ws.gram.gram();
    let longest = sqrt((0..n).map(|k| g[k][k]).fold(0.0, f64::max));
    (0..n).all(|k| {
        let norm = sqrt(g[k][k]);
        let r_kk = ws.mat[k][k];
        norm > SCREEN_MARGIN * ZERO_COLUMN_REL * longest
            && r_kk.is_finite()
            && r_kk >= SCREEN_MARGIN * tol * norm
    })
}

/// The fitted columns `ws.cols[..n]` (flat indices) that the greedy test drops at `robot`;
/// each dropped one gets its partner in `partner`. Overwrites the Givens factor, `ws.mat`
/// and `ws.tmp`.
pub(super) fn dropped_at<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
    partner: &mut [Option<Partner>; MAX_MODEL_PARAMS],
) -> Result<ParamSet> {
    let n = n.min(P);
    ws.colscale[..n].fill(1.0);
    accumulate_jacobian(robot, data, opts, n, ws)?;
    let kept = greedy(ws, n, opts.rank_tol, partner)?;
    let mut dropped = ParamSet::new();
    for (k, &col) in ws.cols[..n].iter().enumerate() {
        if !kept.contains(k) {
            dropped.insert(col)?;
        }
    }
    Ok(dropped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::gram::cholesky_upper_in_place;
    use crate::rng::SplitMix64;

    /// Folds `m` random rows whose last column is a combination of the others plus `eps`
    /// times noise (columns of very different lengths, as lengths and angles are) into
    /// both factors, as the fit does, and returns the screen's verdict and the columns the
    /// greedy test keeps.
    fn screen_and_greedy(eps: f64, seed: u64) -> (bool, ParamSet) {
        const N: usize = 6;
        let mut ws = Workspace::<8>::new();
        let mut rng = SplitMix64::new(seed);
        let scales = [1.0, 0.3, 2.0, 0.05, 1.5, 1.0];
        ws.gram.reset(N).expect("gram");
        ws.lsq.reset(N).expect("lsq");
        for _ in 0..30 {
            let mut a = [0.0; N];
            for (x, s) in a.iter_mut().zip(scales) {
                *x = s * rng.range(-1.0, 1.0);
            }
            a[N - 1] = 0.7 * a[0] - 2.0 * a[3] + 0.4 * a[4] + eps * rng.range(-1.0, 1.0);
            ws.gram.add_row_weighted(&a, 0.0, 1.0).expect("fold");
            ws.lsq.add_row(&a, 0.0).expect("fold");
        }
        for (r, g) in ws.mat.iter_mut().zip(ws.gram.gram().iter()) {
            *r = *g;
        }
        let factored = cholesky_upper_in_place(&mut ws.mat, N, 1e-14).is_ok();
        let screen = factored && all_kept_by_factor(&ws, N, 1e-6);
        for (k, c) in ws.cols.iter_mut().enumerate() {
            *c = k;
        }
        let mut partner = [None; MAX_MODEL_PARAMS];
        let kept = greedy(&mut ws, N, 1e-6, &mut partner).expect("greedy");
        (screen, kept)
    }

    /// The screen passes only where the greedy test keeps every column, and it does pass
    /// where the dependency is far from the tolerance (1e-6): the greedy test's own
    /// residual of the last column is about `eps` relative to its norm.
    #[test]
    fn screen_agrees_with_the_greedy_test() {
        for seed in 1..=20 {
            for (eps, all_kept) in [(1e-2, true), (1e-4, true), (1e-8, false), (0.0, false)] {
                let (screen, kept) = screen_and_greedy(eps, seed);
                assert_eq!(
                    kept.len() == 6,
                    all_kept,
                    "eps {eps}, seed {seed}: {kept:?}"
                );
                assert_eq!(screen, all_kept, "eps {eps}, seed {seed}");
            }
        }
    }
}
