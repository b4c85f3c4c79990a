//! The one error type of the core: `Copy`, no strings, no allocation.
//!
//! Every variant names its culprit with numbers (which joint, which pose, which parameter,
//! the offending value), so a caller on a controller can report it without a heap and the
//! C ABI can pass it on as plain data.

use core::fmt;

/// Zero-based joint number (joint 1 of the paper is `JointIndex(0)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JointIndex(pub usize);

/// Zero-based index into the flat parameter vector (see [`crate::params`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParamIndex(pub usize);

/// Zero-based index of a pose (a measurement row) in a data set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PoseIndex(pub usize);

/// Which input held a non-finite number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Quantity {
    /// A joint reading `q`.
    JointReading,
    /// A model parameter (link, base, tool or effect).
    Parameter,
    /// A measured or target position.
    Position,
    /// A measured or target orientation.
    Orientation,
    /// A weight, tolerance, bound or other option.
    Setting,
    /// Approach directions `s1..sN` (backlash).
    ApproachDirection,
    /// Arm temperature in °C (thermal effect).
    Temperature,
    /// The measurement noise: neither stated nor estimable from repeated measurements
    /// (diagnosis).
    NoiseFloor,
}

/// Everything that can go wrong in the core.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A number that must be finite was NaN or infinite; `index` is its position within
    /// the input named by `what`.
    NonFinite {
        /// Which input.
        what: Quantity,
        /// Position within that input.
        index: usize,
    },
    /// A length or count disagreed with what the model needs.
    DimensionMismatch {
        /// What was needed.
        expected: usize,
        /// What was given.
        found: usize,
    },
    /// A joint reading lies outside the joint's limits (inclusive), in radians.
    OutOfLimits {
        /// The joint.
        joint: JointIndex,
        /// The reading \[rad\].
        value: f64,
        /// Lower limit \[rad\].
        lower: f64,
        /// Upper limit \[rad\].
        upper: f64,
    },
    /// An input the model needs is missing (e.g. approach directions for a model with
    /// backlash, temperature for a model with thermal expansion).
    MissingInput {
        /// Which input.
        what: Quantity,
    },
    /// Joint limits with `lower > upper` or a non-finite bound.
    InvalidLimits {
        /// The joint.
        joint: JointIndex,
    },
    /// A parameter value that the model cannot use (e.g. a negative mass).
    InvalidParameter {
        /// The parameter (or element) index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Inverse kinematics found no configuration within the limits that reaches the pose;
    /// the best residual found is reported.
    Unreachable {
        /// Best position residual \[m\].
        residual_pos_m: f64,
        /// Best orientation residual \[rad\].
        residual_rot_rad: f64,
    },
    /// An iterative method stopped at its iteration limit before its convergence test held.
    NotConverged {
        /// Iterations performed.
        iterations: u32,
    },
    /// The data do not determine enough parameters (rank below what is asked).
    RankDeficient {
        /// Numerical rank found.
        rank: usize,
        /// Rank required.
        required: usize,
    },
    /// A fixed-capacity buffer is too small.
    CapacityExceeded {
        /// Size needed.
        needed: usize,
        /// Capacity available.
        capacity: usize,
    },
    /// Not enough data (poses, rows) for the requested operation.
    TooFewData {
        /// How many were given.
        found: usize,
        /// How many are needed at least.
        needed: usize,
    },
    /// A pose at `pose` could not be used (e.g. a degenerate measurement).
    BadPose {
        /// The pose.
        pose: PoseIndex,
    },
    /// A parameter fitted under bounds ended outside them (should not happen: reported
    /// rather than hidden).
    BoundViolated {
        /// The parameter.
        param: ParamIndex,
        /// Its value.
        value: f64,
    },
    /// A joint axis given with a zero (or non-normalisable) direction.
    DegenerateAxis {
        /// The joint.
        joint: JointIndex,
    },
    /// A group of constraint rows (target or plane) that cannot be used: rows not
    /// contiguous, too few rows for its kind, or a non-finite / zero known normal.
    BadGroup {
        /// The group (index into the groups).
        group: usize,
    },
    /// A plane whose predicted contact points are collinear (or coincide): its normal is
    /// undetermined.
    DegenerateGroup {
        /// The group.
        group: usize,
    },
    /// A known distance naming a group that does not exist or is not a target, the same
    /// target twice, or a negative / non-finite length or weight.
    BadDistance {
        /// The distance (index into the distances).
        distance: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::BadGroup { group } => write!(f, "constraint group {group} is unusable"),
            Error::DegenerateGroup { group } => {
                write!(f, "plane {group}: contact points are collinear")
            }
            Error::BadDistance { distance } => write!(f, "known distance {distance} is invalid"),
            Error::NonFinite { what, index } => {
                write!(f, "non-finite number in {what:?} at index {index}")
            }
            Error::DimensionMismatch { expected, found } => {
                write!(f, "dimension mismatch: expected {expected}, found {found}")
            }
            Error::OutOfLimits {
                joint,
                value,
                lower,
                upper,
            } => write!(
                f,
                "joint {} reading {value} rad outside its limits [{lower}, {upper}] rad",
                joint.0 + 1
            ),
            Error::MissingInput { what } => write!(f, "missing input: {what:?}"),
            Error::InvalidLimits { joint } => {
                write!(f, "joint {} has invalid limits", joint.0 + 1)
            }
            Error::InvalidParameter { index, value } => {
                write!(f, "invalid parameter value {value} at index {index}")
            }
            Error::Unreachable {
                residual_pos_m,
                residual_rot_rad,
            } => write!(
                f,
                "pose unreachable within the joint limits (best residual {residual_pos_m} m, {residual_rot_rad} rad)"
            ),
            Error::NotConverged { iterations } => {
                write!(f, "no convergence after {iterations} iterations")
            }
            Error::RankDeficient { rank, required } => write!(
                f,
                "rank deficient: numerical rank {rank}, {required} required"
            ),
            Error::CapacityExceeded { needed, capacity } => {
                write!(
                    f,
                    "capacity exceeded: {needed} needed, {capacity} available"
                )
            }
            Error::TooFewData { found, needed } => {
                write!(f, "too few data: {found} given, at least {needed} needed")
            }
            Error::BadPose { pose } => write!(f, "pose {} cannot be used", pose.0 + 1),
            Error::BoundViolated { param, value } => {
                write!(f, "parameter {} = {value} violates its bound", param.0)
            }
            Error::DegenerateAxis { joint } => {
                write!(f, "joint {} axis has a zero direction", joint.0 + 1)
            }
        }
    }
}

impl core::error::Error for Error {}

/// Result type of the core.
pub type Result<T> = core::result::Result<T, Error>;

/// Checks that every element of `values` is finite.
pub(crate) fn check_finite(values: &[f64], what: Quantity) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what, index }),
        None => Ok(()),
    }
}
