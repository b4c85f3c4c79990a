//! Argument types shared by several commands.

use clap::ValueEnum;
use kincal::Effect;
use kincal::identify::{Algorithm, Loss};
use kincal::pose::OrientationError;

/// `--algorithm`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AlgorithmArg {
    /// Gauss–Newton with the minimum-norm step (the paper's OLS, Matlab lsqminnorm).
    Ols,
    /// Bounded fit inside the prior intervals --bounds-mm/--bounds-deg (the paper's fmincon).
    Opt1,
    /// Levenberg–Marquardt trust region (the paper's lsqnonlin).
    Opt2,
    /// All three in parallel; the model file stores OLS and records OPT1, OPT2 and their
    /// consensus.
    All,
}

impl AlgorithmArg {
    pub fn algorithms(self) -> Vec<Algorithm> {
        match self {
            AlgorithmArg::Ols => vec![Algorithm::Ols],
            AlgorithmArg::Opt1 => vec![Algorithm::Opt1],
            AlgorithmArg::Opt2 => vec![Algorithm::Opt2],
            AlgorithmArg::All => Algorithm::ALL.to_vec(),
        }
    }
}

/// `--robust LOSS`: the loss of the robust (IRLS) fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LossArg {
    /// Huber: weight min(1, c/d); convex, started from the least-squares fit.
    Huber,
    /// Cauchy: weight 1/(1 + d²/c²); a gross outlier ends near weight 0; started from Huber.
    Cauchy,
}

impl From<LossArg> for Loss {
    fn from(l: LossArg) -> Self {
        match l {
            LossArg::Huber => Loss::Huber,
            LossArg::Cauchy => Loss::Cauchy,
        }
    }
}

/// `--orientation-error`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OrientationArg {
    /// The exact rotation vector log(R_meas·R_modelᵀ): right for any error size.
    Exact,
    /// The paper's eq. (16), first order in the error.
    SmallAngle,
}

impl From<OrientationArg> for OrientationError {
    fn from(o: OrientationArg) -> Self {
        match o {
            OrientationArg::Exact => OrientationError::Exact,
            OrientationArg::SmallAngle => OrientationError::SmallAngle,
        }
    }
}

/// Parses an effect name of spec/effects.md.
pub fn parse_effect(s: &str) -> Result<Effect, String> {
    Effect::parse(s.trim()).ok_or_else(|| {
        format!(
            "unknown effect '{s}': expected one of {}",
            Effect::ALL.map(|e| e.name()).join(", ")
        )
    })
}

/// Parses a finite number > 0.
pub fn positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("expected a finite number > 0, found {v}")),
        Err(e) => Err(format!("expected a number: {e}")),
    }
}

/// Parses a finite number >= 0.
pub fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("expected a finite number >= 0, found {v}")),
        Err(e) => Err(format!("expected a number: {e}")),
    }
}
