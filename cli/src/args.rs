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

/// Parses a number within `[lo, hi]` (both finite, > 0), naming the plausible range.
fn within(s: &str, lo: f64, hi: f64, unit: &str) -> Result<f64, String> {
    let v = positive(s)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v:e} {unit} is implausible: expected a value within [{lo:e}, {hi:e}] {unit}"
        ))
    }
}

/// Parses an instrument's position noise, 1σ [mm]: 1 nm to 10 m. Its weight 1/σ² stays
/// finite (a σ of 1e-200 mm would make it infinite and the fit meaningless).
pub fn sigma_mm(s: &str) -> Result<f64, String> {
    within(s, 1e-6, 1e4, "mm")
}

/// Parses an instrument's orientation noise, 1σ [deg]: 1e-6° to 180°.
pub fn sigma_deg(s: &str) -> Result<f64, String> {
    within(s, 1e-6, 180.0, "deg")
}

/// Parses a least-squares weight [1/m² or 1/rad²] within 1e-30..1e30, so that weighted
/// squared residuals stay finite.
pub fn weight(s: &str) -> Result<f64, String> {
    within(s, 1e-30, 1e30, "")
}

/// Parses a non-negative length [mm] of noise or error: 0 to 1e4 mm (10 m).
pub fn amount_mm(s: &str) -> Result<f64, String> {
    let v = non_negative(s)?;
    if v <= 1e4 {
        Ok(v)
    } else {
        Err(format!(
            "{v:e} mm is implausible: expected a value within [0, 1e4] mm"
        ))
    }
}

/// Parses a non-negative angle [deg] of noise or error: 0 to 180°.
pub fn amount_deg(s: &str) -> Result<f64, String> {
    let v = non_negative(s)?;
    if v <= 180.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v:e}° is implausible: expected a value within [0, 180]°"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_and_weights_are_bounded() {
        assert_eq!(sigma_mm("0.1"), Ok(0.1));
        assert!(sigma_mm("1e-200").unwrap_err().contains("implausible"));
        assert!(sigma_mm("1e5").is_err());
        assert_eq!(sigma_deg("0.02"), Ok(0.02));
        assert!(sigma_deg("1e-200").is_err());
        assert!(sigma_deg("360").is_err());
        assert_eq!(weight("2"), Ok(2.0));
        assert!(weight("1e300").is_err());
        assert!(weight("0").is_err());
        assert_eq!(amount_mm("0"), Ok(0.0));
        assert!(amount_mm("1e300").is_err());
        assert_eq!(amount_deg("5"), Ok(5.0));
        assert!(amount_deg("1e300").is_err());
    }
}

/// `--prior [MM,DEG|auto]`: Gaussian priors around the initial model on the link
/// parameters (one σ for lengths in mm, one for angles in degrees; the core's
/// `kincal::identify::Prior`), or `auto` (crossval: chosen from [`PRIOR_AUTO_GRID`] by
/// held-out error).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PriorArg {
    /// One σ for link lengths [mm] and link angles [deg].
    Sizes { length_mm: f64, angle_deg: f64 },
    /// Chosen by held-out error (crossval only).
    Auto,
}

/// The default prior: 5 mm, 1° (`kincal::identify::DEFAULT_PRIOR_LENGTH_M`, `_ANGLE_RAD`).
pub const PRIOR_DEFAULT: PriorArg = PriorArg::Sizes {
    length_mm: kincal::identify::DEFAULT_PRIOR_LENGTH_M * 1e3,
    angle_deg: 1.0,
};

/// The sizes `crossval --prior auto` tries (mm, deg; kincal-io's).
pub use kincal_io::crossval::PRIOR_AUTO_GRID;

impl PriorArg {
    /// The core's sizes (links only; frames and effects without a prior).
    pub fn sizes(self) -> Option<kincal::identify::PriorSizes> {
        match self {
            PriorArg::Sizes {
                length_mm,
                angle_deg,
            } => Some(kincal::identify::PriorSizes::links(
                length_mm * 1e-3,
                angle_deg.to_radians(),
            )),
            PriorArg::Auto => None,
        }
    }
}

/// `--prior-frames MM,DEG` and `--prior-effects SIGMA`: prior sizes for the kinds that have
/// none by default (`kincal::identify::PriorSizes`: the frames of a set-up are registered,
/// not manufactured; effects are what a diagnosis asks about). They refine `--prior`, so
/// they require it. The one place every command with `--prior` parses them.
#[derive(clap::Args, Debug, Clone, Copy, Default, PartialEq)]
pub struct PriorKinds {
    /// With --prior: one σ for the base- and tool-frame translations [mm] and rotations
    /// [deg] [default: no prior on the frames]
    #[arg(long, value_name = "MM,DEG", value_parser = prior_pair, requires = "prior")]
    pub prior_frames: Option<(f64, f64)>,
    /// With --prior: one σ for every effect parameter, in the parameter's SI unit
    /// (rad/(N·m), 1, rad, 1/K; m/N and m on prismatic joints) [default: none]
    #[arg(long, value_name = "SIGMA", value_parser = prior_effect, requires = "prior")]
    pub prior_effects: Option<f64>,
}

impl PriorKinds {
    /// `sizes` with these kinds' σ set (given ones only).
    #[must_use]
    pub fn apply(self, mut sizes: kincal::identify::PriorSizes) -> kincal::identify::PriorSizes {
        if let Some((mm, deg)) = self.prior_frames {
            sizes.frame_length_m = mm * 1e-3;
            sizes.frame_angle_rad = deg.to_radians();
        }
        if let Some(s) = self.prior_effects {
            sizes.effect = s;
        }
        sizes
    }

    /// The core's sizes of `--prior` (links) refined by these flags; `None` without a
    /// `--prior` size (none, or `auto`).
    pub fn sizes(self, prior: Option<PriorArg>) -> Option<kincal::identify::PriorSizes> {
        prior.and_then(PriorArg::sizes).map(|s| self.apply(s))
    }
}

/// Parses `--prior-frames MM,DEG` (both > 0 and finite).
pub fn prior_pair(s: &str) -> Result<(f64, f64), String> {
    let Some((mm, deg)) = s.trim().split_once(',') else {
        return Err(format!(
            "expected MM,DEG (one σ for frame translations and rotations, e.g. 2,0.5), found '{s}'"
        ));
    };
    Ok((within(mm, 1e-6, 1e6, "mm")?, within(deg, 1e-6, 1e4, "deg")?))
}

/// Parses `--prior-effects SIGMA` (> 0 and finite).
pub fn prior_effect(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a number, found '{s}'"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("expected a finite σ > 0, found '{s}'"))
    }
}

/// Parses `MM,DEG` (both > 0 and finite) or `auto`.
pub fn prior(s: &str) -> Result<PriorArg, String> {
    let s = s.trim();
    if s.eq_ignore_ascii_case("auto") {
        return Ok(PriorArg::Auto);
    }
    let Some((mm, deg)) = s.split_once(',') else {
        return Err(format!(
            "expected MM,DEG (one σ for link lengths and angles, e.g. 5,1) or auto, found '{s}'"
        ));
    };
    let length_mm = within(mm, 1e-6, 1e6, "mm")?;
    let angle_deg = within(deg, 1e-6, 1e4, "deg")?;
    Ok(PriorArg::Sizes {
        length_mm,
        angle_deg,
    })
}

#[cfg(test)]
mod prior_kind_tests {
    use super::*;

    #[test]
    fn prior_kinds_refine_the_link_sizes_only_where_given() {
        let links = PriorArg::Sizes {
            length_mm: 5.0,
            angle_deg: 1.0,
        };
        let none = PriorKinds::default().sizes(Some(links)).unwrap();
        assert_eq!(none, links.sizes().unwrap());
        assert!(none.frame_length_m.is_infinite() && none.effect.is_infinite());
        let k = PriorKinds {
            prior_frames: Some(prior_pair("2,0.5").unwrap()),
            prior_effects: Some(prior_effect("1e-4").unwrap()),
        };
        let s = k.sizes(Some(links)).unwrap();
        assert!((s.frame_length_m - 2e-3).abs() < 1e-18);
        assert!((s.frame_angle_rad - 0.5f64.to_radians()).abs() < 1e-18);
        assert_eq!(s.effect, 1e-4);
        assert_eq!((s.length_m, s.angle_rad), (none.length_m, none.angle_rad));
        assert_eq!(k.sizes(Some(PriorArg::Auto)), None);
        assert!(prior_pair("2").is_err() && prior_pair("0,1").is_err());
        assert!(prior_effect("-1").is_err() && prior_effect("inf").is_err());
    }
}
