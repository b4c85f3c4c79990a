//! The C ABI of kincal: `include/kincal.h` is generated from this crate by cbindgen.
//!
//! Conventions (see ffi/README.md): every fallible export returns a `kincal_status` (0 = OK)
//! and takes a last `kincal_error *err` out-param (NULL allowed) for the positional detail;
//! arguments come in the order object, inputs, outputs (`*_out`); every buffer is
//! caller-owned and comes with its length (`*_len`, in elements), which must equal what the
//! call needs; nothing is allocated and no pointer is kept after a call returns. Units are
//! metres and radians; 4×4 poses are column-major.
//!
//! Module per capability, each a thin shell over the core: [`status`] (codes, detail, text),
//! [`robot`] (the `kincal_robot` model and its editors), [`axis_chain`] (a robot from joint axes), [`params`] (parameters by index and
//! label), [`effects`], [`kinematics`] (FK, frames, Jacobian, gravity torques), [`ik`],
//! [`prepared`] (a model built once into caller-owned storage, for fast FK and IK),
//! [`pose`] (pose error, conversions), [`identify`] (identifiability, OLS/OPT1/OPT2),
//! [`validation`] (metrics, biopsy requirement), [`registration`] (markers), [`view_point`]
//! (where camera poses look, a pose moved to a point), [`aria`] (built-in arm),
//! [`constraints`] (instrument-free calibration: targets, planes, distances, sessions),
//! [`diagnosis`] (the sim-to-real gap diagnosis and its report); in std builds
//! [`model_read`] (model files, through kincal-io).
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

#[cfg(all(not(feature = "std"), not(feature = "panic-never")))]
compile_error!(
    "kincal-ffi without `std` needs the `panic-never` feature (a no_std staticlib must bring its \
     panic handler; ours proves at link time that it is unreachable)"
);

#[macro_use]
mod panic;
#[macro_use]
mod args;

pub mod aria;
pub mod axis_chain;
pub mod effects;
pub mod identify;
pub mod ik;
pub mod kinematics;
#[cfg(feature = "std")]
pub mod model_read;
pub mod observability;
pub mod params;
pub mod pose;
pub mod prepared;
pub mod registration;
pub mod robot;
pub mod status;
pub mod validation;
pub mod view_point;
// Last, so that cbindgen keeps the header's earlier declarations in place.
pub mod constraints;
pub mod diagnosis;
#[cfg(feature = "std")]
pub mod measurement_read;

#[cfg(test)]
mod tests;
