//! The CLI's figures, as SVG: per-pose and held-out errors (`validate --plot`, `crossval
//! --plot`), the diagnosis plots, and the design comparison of the Monte-Carlo studies.
//! Every figure refuses non-finite values (see [`require_finite`]).

pub mod diagnosis;
pub mod pose_errors;
pub mod study;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// `top` if finite (see [`require_finite`]).
pub fn finite_top(top: f64) -> Result<f64, String> {
    if top.is_finite() {
        Ok(top)
    } else {
        Err("non-finite values (an overflow upstream): the figure is not drawn".into())
    }
}

/// Refuses to draw non-finite values: plotters' tick computation on an infinite axis range
/// never ends (`validate --plot` spun forever on an overflowed error norm).
pub fn require_finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> Res<()> {
    if values.into_iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err("non-finite values (an overflow upstream): the figure is not drawn".into())
    }
}
