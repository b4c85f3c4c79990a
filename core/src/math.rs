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

/// Column `k` (0, 1 or 2) of a 3×3 matrix, read from its column-major array; zeros for any
/// other `k`. nalgebra's `column(k)` asserts `k < 3` at run time, and where the optimiser does
/// not inline it (opt-level s/z, the firmware target) that assertion is a panic path.
#[inline]
pub(crate) fn column3(m: &nalgebra::Matrix3<f64>, k: usize) -> nalgebra::Vector3<f64> {
    m.data.0.get(k).map_or_else(nalgebra::Vector3::zeros, |c| {
        nalgebra::Vector3::new(c[0], c[1], c[2])
    })
}
