//! A robot whose joint count is known only at run time (from a file or a C caller), as one
//! enum over the supported counts, so the shells (C ABI, CLI) dispatch once with
//! [`with_any_robot!`](crate::with_any_robot) and call the generic core. No heap: the enum is
//! as large as its largest variant.

use crate::error::{Error, Result};
use crate::model::{JointKind, JointLimits, Link, Robot};

/// Largest joint count a run-time robot may have.
pub const MAX_JOINTS: usize = 12;

/// A [`Robot`] with 1 to [`MAX_JOINTS`] joints.
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)]
// No heap in the core: the enum is as large as its largest variant, on purpose.
#[allow(clippy::large_enum_variant)]
pub enum AnyRobot {
    J1(Robot<1>),
    J2(Robot<2>),
    J3(Robot<3>),
    J4(Robot<4>),
    J5(Robot<5>),
    J6(Robot<6>),
    J7(Robot<7>),
    J8(Robot<8>),
    J9(Robot<9>),
    J10(Robot<10>),
    J11(Robot<11>),
    J12(Robot<12>),
}

/// Runs `$body` with `$r` bound to the concrete `Robot<N>` inside an [`AnyRobot`] (by value,
/// reference or mutable reference, following the expression given). Inside `$body`, the
/// const `N` is not nameable; use generic helper functions.
///
/// ```
/// use kincal::{any::AnyRobot, aria, with_any_robot};
/// let any = AnyRobot::from(aria::nominal());
/// let n = with_any_robot!(&any, r => r.links().len());
/// assert_eq!(n, 6);
/// ```
#[macro_export]
macro_rules! with_any_robot {
    ($any:expr, $r:ident => $body:expr) => {
        match $any {
            $crate::any::AnyRobot::J1($r) => $body,
            $crate::any::AnyRobot::J2($r) => $body,
            $crate::any::AnyRobot::J3($r) => $body,
            $crate::any::AnyRobot::J4($r) => $body,
            $crate::any::AnyRobot::J5($r) => $body,
            $crate::any::AnyRobot::J6($r) => $body,
            $crate::any::AnyRobot::J7($r) => $body,
            $crate::any::AnyRobot::J8($r) => $body,
            $crate::any::AnyRobot::J9($r) => $body,
            $crate::any::AnyRobot::J10($r) => $body,
            $crate::any::AnyRobot::J11($r) => $body,
            $crate::any::AnyRobot::J12($r) => $body,
        }
    };
}

macro_rules! impl_from {
    ($($v:ident $n:literal),*) => {$(
        impl From<Robot<$n>> for AnyRobot {
            fn from(r: Robot<$n>) -> Self {
                AnyRobot::$v(r)
            }
        }
    )*};
}
impl_from!(J1 1, J2 2, J3 3, J4 4, J5 5, J6 6, J7 7, J8 8, J9 9, J10 10, J11 11, J12 12);

fn build<const N: usize>(links: &[Link], limits: &[JointLimits]) -> Result<Robot<N>> {
    let l: [Link; N] = links.try_into().map_err(|_| Error::DimensionMismatch {
        expected: N,
        found: links.len(),
    })?;
    let m: [JointLimits; N] = limits.try_into().map_err(|_| Error::DimensionMismatch {
        expected: N,
        found: limits.len(),
    })?;
    Robot::new(l, m)
}

impl AnyRobot {
    /// A robot from slices of links and limits of equal length 1..=[`MAX_JOINTS`]: no
    /// joints is a [`Error::DimensionMismatch`] (as for [`Robot::new`]), more than
    /// [`MAX_JOINTS`] a [`Error::CapacityExceeded`].
    pub fn new(links: &[Link], limits: &[JointLimits]) -> Result<Self> {
        if links.len() != limits.len() {
            return Err(Error::DimensionMismatch {
                expected: links.len(),
                found: limits.len(),
            });
        }
        Ok(match links.len() {
            1 => build::<1>(links, limits)?.into(),
            2 => build::<2>(links, limits)?.into(),
            3 => build::<3>(links, limits)?.into(),
            4 => build::<4>(links, limits)?.into(),
            5 => build::<5>(links, limits)?.into(),
            6 => build::<6>(links, limits)?.into(),
            7 => build::<7>(links, limits)?.into(),
            8 => build::<8>(links, limits)?.into(),
            9 => build::<9>(links, limits)?.into(),
            10 => build::<10>(links, limits)?.into(),
            11 => build::<11>(links, limits)?.into(),
            12 => build::<12>(links, limits)?.into(),
            0 => {
                return Err(Error::DimensionMismatch {
                    expected: 1,
                    found: 0,
                });
            }
            n => {
                return Err(Error::CapacityExceeded {
                    needed: n,
                    capacity: MAX_JOINTS,
                });
            }
        })
    }

    /// Number of joints.
    #[must_use]
    pub fn n_joints(&self) -> usize {
        with_any_robot!(self, r => r.links().len())
    }

    /// Sets the kind of joint `j` (zero-based), see [`Robot::set_joint_kind`].
    pub fn set_joint_kind(&mut self, j: usize, kind: JointKind) -> Result<()> {
        with_any_robot!(self, r => r.set_joint_kind(j, kind))
    }

    /// The kind of joint `j` (revolute out of range).
    #[must_use]
    pub fn joint_kind(&self, j: usize) -> JointKind {
        with_any_robot!(self, r => r.joint_kind(j))
    }
}
