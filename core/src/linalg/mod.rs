//! Numerical linear-algebra kernels for calibration by nonlinear least squares.
//!
//! Why: identification needs streaming least squares, rank analysis and damped
//! (Levenberg–Marquardt) steps without heap, panics or randomness.
//!
//! Conventions shared by every kernel:
//! - Fixed capacity `P` (const generic) and a runtime dimension `n <= P`; `n > P` gives
//!   [`Error::CapacityExceeded`](crate::error::Error::CapacityExceeded).
//! - Matrices are `[[f64; P]; P]`, row-major (`a[i][j]` = row `i`, column `j`); only the
//!   leading `n`×`n` block (or `n` entries of a vector) is read or written unless a
//!   function says otherwise.
//! - Slices must have length exactly `n`, else
//!   [`Error::DimensionMismatch`](crate::error::Error::DimensionMismatch).
//! - A NaN or infinite input gives `NonFinite { what: Quantity::Parameter, index }`, where
//!   `index` is the slice position, or `i * n + j` for matrix entry (`i`, `j`); an invalid
//!   tuning value (weight, damping, tolerance, radius) gives
//!   `NonFinite { what: Quantity::Setting, index: 0 }`.
//! - Large structs are valid when all-zero (so they can be `static` or `Box::new_zeroed`)
//!   and are re-initialised in place with `reset`.

pub mod bidiag;
pub mod gram;
pub mod lm;
pub mod lsq;
pub mod minnorm;
pub mod qr;
pub mod svd;
pub mod symeig;
#[cfg(test)]
mod testutil;
pub mod tri;
mod util;

pub(crate) use util::dot;
