#![doc = include_str!("../README.md")]
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]
// Numerical kernels index several same-length arrays by one loop counter; iterator chains
// would hide that structure.
#![allow(clippy::needless_range_loop)]

#[cfg(test)]
extern crate std;

pub mod any;
pub mod aria;
pub mod axis_chain;
mod cache_key;
pub mod diagnosis;
pub mod effects;
pub mod error;
#[doc(hidden)]
pub mod fixed3;
pub mod frames;
pub mod identify;
pub mod ik;
pub mod kinematics;
pub mod linalg;
mod math;
pub mod model;
pub mod montecarlo;
pub mod noise;
pub mod observability;
pub mod params;
pub mod plate_study;
pub mod pose;
pub mod registration;
pub mod rng;
pub mod selection;
pub mod sim;
pub mod validation;
pub mod view_point;

pub use effects::{Effect, EffectSet};
pub use error::{Error, JointIndex, ParamIndex, PoseIndex, Quantity, Result};
pub use kinematics::{Frames, JacobianColumn};
pub use math::{sin_cos, sin_cos_lanes};
pub use model::{JointKind, JointLimits, JointState, LengthParam, Link, MassModel, Robot};
pub use params::{ParamId, ParamSet};
pub use pose::{OrientationError, PoseError, Transform};
