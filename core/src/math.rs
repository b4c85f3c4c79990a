//! The one floating-point shim: `core` has no `f64::sin`, so every transcendental call in the
//! crate goes through here (backed by `libm`, deterministic across targets).

#[inline(always)]
pub(crate) fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline(always)]
pub(crate) fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline(always)]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}
#[inline(always)]
pub(crate) fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}
#[inline(always)]
pub(crate) fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
#[inline(always)]
pub(crate) fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}
#[inline(always)]
pub(crate) fn asin(x: f64) -> f64 {
    libm::asin(x)
}
#[inline(always)]
pub(crate) fn ln(x: f64) -> f64 {
    libm::log(x)
}
#[inline(always)]
pub(crate) fn exp(x: f64) -> f64 {
    libm::exp(x)
}
#[inline(always)]
pub(crate) fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}
