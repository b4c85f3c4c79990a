//! Gaussian priors around the initial (nominal) model, for directions the data leave weak.
//!
//! A prior on parameter `i` adds one pseudo-observation row to the fit: the parameter
//! itself "measured" at its centre `c_i` with standard deviation `σ_i`. Whitened against
//! the data rows, its term in the cost is `s²·((x_i − c_i)/σ_i)²` with `s²`
//! ([`Prior::data_variance`]) the variance of a data row of unit weight: 1 when the data
//! weights are `1/σ²` of the instrument (the CLI's way), the instrument's variance in the
//! cost's units with the paper's unit weights. The fit is then the maximum a posteriori
//! estimate, and `σ²·(JᵀWJ + s²·Σ_p⁻¹)⁻¹` its posterior covariance (see
//! [`super::Identification::sigma2`]).
//!
//! Every algorithm sees the prior through the same rows: the normal equations, the cost
//! the step is accepted on, and the covariance. An infinite `σ_i` is no prior (no row);
//! with every `σ_i` infinite the fit is today's, bit for bit. Parameters the data leave
//! undetermined (data-deficient, not structural) are fitted when they carry a prior: the
//! prior holds the undetermined direction at its centre.

use super::data::{ResidualStats, RowSource};
use super::{IdentifyOptions, MAX_MODEL_PARAMS, Workspace};
use crate::error::{Error, ParamIndex, Quantity, Result};
use crate::model::Robot;
use crate::params::{ParamId, ParamSet};

/// Default prior σ of link lengths (`d`, `a`) \[m\]: 5 mm, the paper's manufacturing
/// tolerance (Section 2.4) read as one standard deviation — link lengths of a machined arm
/// are within a few millimetres of the drawing, so a fit that moves one by centimetres is
/// fitting noise or an unmodelled effect.
pub const DEFAULT_PRIOR_LENGTH_M: f64 = 5e-3;
/// Default prior σ of link angles (`θ0`, `α`, `β`) \[rad\]: 1°. Joint zero offsets and
/// twist angles of an assembled arm are off by tenths of a degree (encoder mounting,
/// machining); 1° as one σ still lets a fit move 3° at 3σ, but not the tens of degrees a
/// weakly excited direction takes (TALOS θ0_6 +78.6° without a prior). The paper's 5° is an
/// interval for OPT1 (a worst case), not a standard deviation.
pub const DEFAULT_PRIOR_ANGLE_RAD: f64 = core::f64::consts::PI / 180.0;

/// Prior sizes per parameter kind (one σ). Infinite: no prior on that kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorSizes {
    /// Link lengths `d`, `a` \[m\].
    pub length_m: f64,
    /// Link angles `θ0`, `α`, `β` \[rad\].
    pub angle_rad: f64,
    /// Base- and tool-frame translations \[m\]. Default: none — the frames of a set-up are
    /// registered, not manufactured; their starting values are estimates (`--init-frames`)
    /// or guesses, not a nominal to be pulled back to.
    pub frame_length_m: f64,
    /// Base- and tool-frame rotations \[rad\]. Default: none (as the translations).
    pub frame_angle_rad: f64,
    /// Effects (compliance, scale, cyclic, backlash, thermal), in each parameter's own
    /// unit. Default: none — whether an effect is there is what a diagnosis asks; a prior
    /// would decide it. Set individual entries of [`Prior::sigma`] for finer control.
    pub effect: f64,
}

impl PriorSizes {
    /// The documented defaults: [`DEFAULT_PRIOR_LENGTH_M`], [`DEFAULT_PRIOR_ANGLE_RAD`] on
    /// the links, none on the frames and effects.
    pub const DEFAULT: PriorSizes = PriorSizes {
        length_m: DEFAULT_PRIOR_LENGTH_M,
        angle_rad: DEFAULT_PRIOR_ANGLE_RAD,
        frame_length_m: f64::INFINITY,
        frame_angle_rad: f64::INFINITY,
        effect: f64::INFINITY,
    };
    /// Links only: `length_m` and `angle_rad` on the link parameters, none elsewhere.
    #[must_use]
    pub const fn links(length_m: f64, angle_rad: f64) -> Self {
        PriorSizes {
            length_m,
            angle_rad,
            ..Self::DEFAULT
        }
    }
    /// No prior at all (every σ infinite).
    pub const NONE: PriorSizes = PriorSizes {
        length_m: f64::INFINITY,
        angle_rad: f64::INFINITY,
        frame_length_m: f64::INFINITY,
        frame_angle_rad: f64::INFINITY,
        effect: f64::INFINITY,
    };
}

impl Default for PriorSizes {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A Gaussian prior per flat parameter index: centre and one σ (infinite: none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Centre of each parameter's prior (flat index), usually the initial model's value.
    pub center: [f64; MAX_MODEL_PARAMS],
    /// One σ of each parameter's prior, in its own unit (> 0; infinite: no prior).
    pub sigma: [f64; MAX_MODEL_PARAMS],
    /// Variance of a data row of unit weight in the cost's units: 1 when the data weights
    /// are `1/σ²` of the instrument (whitened rows), the instrument's variance (m², rad²)
    /// with unit weights. The prior rows weigh `data_variance/σ_i²`.
    pub data_variance: f64,
}

impl Prior {
    /// A prior centred on `robot`'s parameters with σ per kind from `sizes`; whitened data
    /// rows (`data_variance` 1).
    #[must_use]
    pub fn around<const N: usize>(robot: &Robot<N>, sizes: &PriorSizes) -> Self {
        let mut p = Prior {
            center: [0.0; MAX_MODEL_PARAMS],
            sigma: [f64::INFINITY; MAX_MODEL_PARAMS],
            data_variance: 1.0,
        };
        let n = Robot::<N>::NUM_PARAMS.min(MAX_MODEL_PARAMS);
        for (i, (c, s)) in p
            .center
            .iter_mut()
            .zip(p.sigma.iter_mut())
            .enumerate()
            .take(n)
        {
            let Ok(id) = ParamId::from_index(ParamIndex(i), N) else {
                continue;
            };
            *c = robot.param(ParamIndex(i)).unwrap_or(0.0);
            *s = match id {
                ParamId::Link { .. } if id.is_length() => sizes.length_m,
                ParamId::Link { .. } => sizes.angle_rad,
                ParamId::Base(_) | ParamId::Tool(_) if id.is_length() => sizes.frame_length_m,
                ParamId::Base(_) | ParamId::Tool(_) => sizes.frame_angle_rad,
                _ => sizes.effect,
            };
        }
        p
    }

    /// Whether parameter `i` carries a prior (finite σ).
    #[must_use]
    pub fn has(&self, i: usize) -> bool {
        self.sigma.get(i).is_some_and(|s| s.is_finite())
    }

    /// Weight of parameter `i`'s prior row in the cost: `data_variance/σ_i²` (0 without one).
    #[must_use]
    pub fn weight(&self, i: usize) -> f64 {
        match self.sigma.get(i) {
            Some(&s) if s.is_finite() => self.data_variance / (s * s),
            _ => 0.0,
        }
    }

    /// `Σ ((x_i − c_i)/σ_i)²` over the parameters of `set` with a prior: the prior's χ²
    /// (unitless) at `robot`.
    pub fn chi2<const N: usize>(&self, robot: &Robot<N>, set: &ParamSet) -> Result<f64> {
        let mut c = 0.0;
        for i in set.iter().filter(|&i| self.has(i)) {
            let d = (robot.param(ParamIndex(i))? - self.center.get(i).copied().unwrap_or(0.0))
                / self.sigma.get(i).copied().unwrap_or(f64::INFINITY);
            c += d * d;
        }
        Ok(c)
    }

    /// The prior rows' part of the cost at `robot`: `Σ w_i·(c_i − x_i)²` over the parameters
    /// of `set` with a prior (`w_i` = [`Prior::weight`]), term for term as the solvers fold it.
    pub fn cost<const N: usize>(&self, robot: &Robot<N>, set: &ParamSet) -> Result<f64> {
        let mut c = 0.0;
        for i in set.iter() {
            let w = self.weight(i);
            if w == 0.0 {
                continue;
            }
            let e = self.center.get(i).copied().unwrap_or(0.0) - robot.param(ParamIndex(i))?;
            c += w * e * e;
        }
        Ok(c)
    }

    /// Refuses a NaN, non-positive σ or a non-finite centre (index: the parameter), or a
    /// non-positive or non-finite `data_variance`.
    pub fn validate(&self) -> Result<()> {
        if !(self.data_variance.is_finite() && self.data_variance > 0.0) {
            return Err(Error::NonFinite {
                what: Quantity::Setting,
                index: 0,
            });
        }
        for (i, (&c, &s)) in self.center.iter().zip(self.sigma.iter()).enumerate() {
            if s.is_nan() || s <= 0.0 || (s.is_finite() && !c.is_finite()) {
                return Err(Error::InvalidParameter { index: i, value: s });
            }
        }
        Ok(())
    }
}

/// Data rows plus the prior rows of the fitted parameters: what the solvers fold when
/// [`IdentifyOptions::prior`] is set.
pub(crate) struct WithPrior<'a, D: ?Sized> {
    pub(crate) data: &'a D,
    pub(crate) prior: &'a Prior,
    /// The fitted parameters (the prior rows are theirs).
    pub(crate) fitted: ParamSet,
}

impl<const N: usize, D: RowSource<N> + ?Sized> RowSource<N> for WithPrior<'_, D> {
    fn validate(&self) -> Result<()> {
        self.data.validate()
    }
    fn check_inputs(&self, opts: &IdentifyOptions<'_>) -> Result<()> {
        self.data.check_inputs(opts)
    }
    fn row_count(&self, opts: &IdentifyOptions<'_>) -> usize {
        self.data.row_count(opts) + self.fitted.iter().filter(|&i| self.prior.has(i)).count()
    }
    fn fold<const P: usize>(
        &self,
        robot: &Robot<N>,
        with_rhs: bool,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        ws: &mut Workspace<P>,
    ) -> Result<f64> {
        let mut c = self.data.fold(robot, with_rhs, opts, n_cols, ws)?;
        // The prior row is built in `ws.row` (scratch that no caller holds across a fold),
        // not in a P-sized temporary on the stack.
        let Workspace {
            row,
            cols,
            colscale,
            gram,
            lsq,
            to_gram,
            ..
        } = ws;
        let a = row.get_mut(..n_cols).ok_or(Error::CapacityExceeded {
            needed: n_cols,
            capacity: P,
        })?;
        for (j, (&i, &scale)) in cols.iter().zip(colscale.iter()).enumerate().take(n_cols) {
            let w = self.prior.weight(i);
            if w == 0.0 {
                continue;
            }
            // Residual "measured minus model": the centre minus the parameter; its
            // derivative along the (scaled) column j is the column's scale.
            let e = if with_rhs {
                self.prior.center.get(i).copied().unwrap_or(0.0) - robot.param(ParamIndex(i))?
            } else {
                0.0
            };
            a.fill(0.0);
            if let Some(x) = a.get_mut(j) {
                *x = scale;
            }
            if *to_gram {
                gram.add_row_weighted(a, e, w)?;
            } else {
                lsq.add_row_weighted(a, e, w)?;
            }
            c += w * e * e;
        }
        Ok(c)
    }
    fn cost(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64> {
        Ok(self.data.cost(robot, opts)? + self.prior.cost(robot, &self.fitted)?)
    }
    fn prior(&self) -> Option<&Prior> {
        Some(self.prior)
    }
    fn damped_fallback(&self) -> bool {
        self.data.damped_fallback()
    }
    /// The data's statistics only: residuals are the data's, the prior is not a pose.
    fn stats(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<ResidualStats> {
        self.data.stats(robot, opts)
    }
}
