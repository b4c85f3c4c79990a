//! What the parameter-estimation error of a fit adds to a held-out score.
//!
//! A model fitted on training rows differs from the truth by `δ`, with covariance
//! `C = (JₜᵀWJₜ)⁻¹` when the model is right and the weights are the inverse noise
//! variances. Rows held out and scored at the fit then carry, besides their own noise,
//! the error `J_h·δ` of the prediction, reduced as the rows are (a target's contacts about
//! their own mean, a plane's about their own plane): whitened, their sum of squares is
//! `Q = ‖ε̃ + K^{1/2}δ̃‖²` with `K = J_hᵀWJ_h` the reduced rows' normal matrix. Since the
//! held-out noise is independent of the training fit,
//!
//! - `E[Q] = dof + tr(KC)`,
//! - `Var[Q] = 2·dof + 2·tr((KC)²) + 4·tr(KC)` (Gaussian noise, linearised model),
//!
//! where `dof` is what the held-out rows alone leave (`3(n − 1)` for a target of `n`
//! contacts, `n − 3` for a plane). A gap test that ignores `tr(KC)` calls a model that
//! extrapolates to a held-out session worse than it fits it "a gap" on pure noise.
//! Both traces are invariant to a common scale of the weights, so they hold whatever σ
//! the fit was weighted with.

use super::constraints::ConstraintData;
use super::data::accumulate_gram;
use super::workspace::Workspace;
use super::{Identification, IdentifyOptions};
use crate::error::{Error, Result};
use crate::linalg::gram::cholesky_upper;
use crate::linalg::tri::upper_inverse_gram;

/// The estimation-error terms of one fold's held-out score (see the module doc): `tr(KC)`
/// and `tr((KC)²)`, in units of the noise variance.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EstimationError {
    /// `tr(KC)`: the expected excess of the whitened held-out sum of squares.
    pub trace: f64,
    /// `tr((KC)²)`: its contribution to the variance (`2·tr((KC)²) + 4·tr(KC)`).
    pub trace_sq: f64,
}

impl EstimationError {
    /// The sum over independent folds (the folds' fits share rows, so this neglects their
    /// correlation: a second-order term when the traces are small against `dof`).
    #[must_use]
    pub fn plus(self, other: Self) -> Self {
        EstimationError {
            trace: self.trace + other.trace,
            trace_sq: self.trace_sq + other.trace_sq,
        }
    }
}

/// The estimation-error terms of scoring `test` at `fit` (fitted on `train` with the same
/// `opts`): `C` from the normal equations of `train` at the fitted model over the fitted
/// parameters `fit.analysis.identifiable`, `K` from those of `test` (reduced rows, as the
/// fit folds them). Gauge and held parameters are not fitted and carry no error here.
///
/// Errors: [`Error::CapacityExceeded`] beyond `P` fitted parameters,
/// [`Error::RankDeficient`] when the training normal equations are numerically singular
/// at the fit, and what folding the data reports.
pub fn held_out_estimation_error<const N: usize, const P: usize>(
    fit: &Identification<N>,
    train: &ConstraintData<'_, N>,
    test: &ConstraintData<'_, N>,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<EstimationError> {
    let fitted = fit.analysis.identifiable;
    let n = fitted.len();
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    if n == 0 {
        return Ok(EstimationError::default());
    }
    for (k, col) in fitted.iter().enumerate() {
        ws.cols[k] = col;
        ws.colscale[k] = 1.0;
    }
    let opts = IdentifyOptions {
        prior: None,
        ..*opts
    };
    // C = (JₜᵀWJₜ)⁻¹ into `ws.v`.
    accumulate_gram(&fit.robot, train, &opts, n, ws)?;
    {
        let Workspace { gram, mat, v, .. } = ws;
        cholesky_upper(gram.gram(), n, 1e-14, mat)?;
        upper_inverse_gram(mat, n, v)?;
    }
    // KC into `ws.mat` (K symmetric, its upper triangle stored).
    accumulate_gram(&fit.robot, test, &opts, n, ws)?;
    let Workspace { gram, mat, v, .. } = ws;
    let k = gram.gram();
    let sym = |m: &[[f64; P]; P], a: usize, b: usize| m[a.min(b)][a.max(b)];
    for a in 0..n {
        for b in 0..n {
            mat[a][b] = (0..n).map(|c| sym(k, a, c) * sym(v, c, b)).sum();
        }
    }
    let mut out = EstimationError::default();
    for a in 0..n {
        out.trace += mat[a][a];
        for b in 0..n {
            out.trace_sq += mat[a][b] * mat[b][a];
        }
    }
    Ok(out)
}
