//! A serial chain of revolute joints described by its joint axes, and its conversion into
//! the Hayati/mDH model of [`Robot`].
//!
//! Robot descriptions such as URDF, CAD exports or a measured "circle point analysis" give a
//! revolute chain as joint *axes* at the zero configuration: for joint `i` a point `p_i` on
//! the axis and a direction `u_i` (the positive sense of rotation by the right-hand rule),
//! all in one reference frame `ref`, plus the pose of the robot's base frame and of the
//! tool (flange) frame in `ref` at `q = 0`. Its forward kinematics is the product of
//! exponentials
//!
//! ```text
//! T_base_tool(q) = T_ref_base⁻¹ · Rot(p_1, u_1, q_1) ··· Rot(p_N, u_N, q_N) · T_ref_tool
//! ```
//!
//! with `Rot(p, u, θ)` the rotation by `θ` about the line through `p` along `u`
//! ([`AxisChain::fk`]).
//!
//! # The construction ([`AxisChain::to_mdh`])
//! mDH frame `i−1` must have its z axis on joint axis `i`, pointing along `u_i` (so the
//! joint readings keep their sign), and `A_i(q) = Rz(q + θ0)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`
//! must carry frame `i−1` into frame `i`. Everything is computed in the base frame, one
//! link at a time, with the previous frame built from the parameters already chosen (so
//! rounding does not accumulate unseen):
//!
//! 1. **Frame 0** (folded into the base transform): origin at the point of axis 1 nearest
//!    the base origin; rotation the smallest one taking the base z axis onto `u_1` (for
//!    `u_1·z < 0`, a half turn about the base x axis followed by the smallest rotation). An
//!    axis 1 along the base z axis through the base origin gives an identity base.
//! 2. **Links 1..N−1**, from frame `i−1` and axis `i+1`, in frame `i−1` coordinates:
//!    - *Not parallel* (angle between the axes ≥ [`PARALLEL_AXES_TOL_RAD`]; β = 0): classic
//!      DH along the common normal. `d` is the position along z of its foot on axis `i`,
//!      `a ≥ 0` its length, `θ0` the angle of its direction (from axis `i` towards axis
//!      `i+1`), `α` the angle from `z_{i−1}` to `u_{i+1}` about it. **Intersecting** axes
//!      (|a| ≤ [`SNAP_LENGTH_M`]): `a = 0` and the normal `±(z_{i−1} × u_{i+1})` with the
//!      sign that keeps `|θ0| ≤ π/2`.
//!    - *Parallel* within the tolerance (Hayati, the same test as
//!      [`Robot::auto_length_params`]; the link identifies β): `d = 0`; frame `i` sits where
//!      axis `i+1` pierces the plane through the origin of frame `i−1` normal to `z_{i−1}`;
//!      `a ≥ 0` and `θ0` are the distance and direction to that point; `α`, `β` tilt
//!      `z_{i−1}` onto `u_{i+1}` exactly (`Rx(α)·Ry(β)·e_z = u_{i+1}`).
//!      **Coincident** axes (`a ≤` [`SNAP_LENGTH_M`]): `a = 0`, `θ0 = 0`. Anti-parallel
//!      axes are parallel too (α ≈ π).
//! 3. **Link N** (no axis after it): `a = α = β = 0`, `d` the position along axis N of the
//!    foot of the tool origin, `θ0` the direction of the tool's x axis projected normal to
//!    the axis (its y axis if x lies along the axis).
//! 4. **Tool**: the rest, `T_N_tool = (T_ref_base⁻¹·F_N)⁻¹·T_ref_tool` at `q = 0`.
//!
//! The result's FK equals the chain's for every `q`, up to rounding (~1e-15 m for a
//! metre-sized arm). The d/β choice of every link is set to the one the construction made.
//! Coincident or parallel axes make some parameters redundant for identification (e.g.
//! θ0 of two coincident joints); that is for the identifiability analysis to report.

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, JointIndex, Quantity, Result, check_finite};
use crate::fixed3::{
    IDENTITY, IDENTITY_TRANSFORM, ZERO, compose, dot, inverse, mat_mul, mat_vec, norm,
    transform_point,
};
use crate::math::{atan2, column3, hypot, sin_cos, sqrt};
use crate::model::{JointLimits, LengthParam, Link, PARALLEL_AXES_TOL_RAD, Robot};
use crate::pose::{
    Transform, pose_from_vector6, pose_to_vector6, rot_x, rot_y, rotation_exp, transform,
};

/// Lengths below this \[m\] count as zero when classifying axes: intersecting axes (common
/// normal shorter than this) and coincident axes. Snapping changes the FK by less than it.
pub const SNAP_LENGTH_M: f64 = 1e-14;

/// A direction shorter than this cannot be normalised: [`Error::DegenerateAxis`].
pub const MIN_DIRECTION_NORM: f64 = 1e-9;

/// One revolute joint axis at the zero configuration, in the chain's reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointAxis {
    /// A point on the axis \[m\].
    pub point: Vector3<f64>,
    /// Direction of the axis; positive joint rotation is right-handed about it. Need not be
    /// unit length (it is normalised) but must be longer than [`MIN_DIRECTION_NORM`].
    pub direction: Vector3<f64>,
}

impl JointAxis {
    /// An axis through `point` \[m\] along `direction`.
    #[must_use]
    pub fn new(point: [f64; 3], direction: [f64; 3]) -> Self {
        JointAxis {
            point: Vector3::from(point),
            direction: Vector3::from(direction),
        }
    }
}

/// A serial revolute chain given by its joint axes at `q = 0` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisChain<const N: usize> {
    /// The robot's base frame in the reference frame.
    pub t_ref_base: Transform,
    /// Joint axes 1..N in the reference frame, at `q = 0`.
    pub axes: [JointAxis; N],
    /// The tool (flange) frame in the reference frame, at `q = 0`.
    pub t_ref_tool: Transform,
}

/// The mDH description of an [`AxisChain`]: what [`Robot`] needs besides limits and masses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MdhChain<const N: usize> {
    /// Links 1..N.
    pub links: [Link; N],
    /// Which of d/β each link identifies (β where axes `i`, `i+1` are parallel).
    pub length_params: [LengthParam; N],
    /// Base frame `[px, py, pz, rx, ry, rz]` (`T_0^b`, see [`Robot::with_base`]).
    pub base: [f64; 6],
    /// Tool frame `[px, py, pz, rx, ry, rz]` (`T_e^N`, see [`Robot::with_tool`]).
    pub tool: [f64; 6],
}

/// Points, unit directions and the tool, all in the base frame.
type InBase<const N: usize> = ([Vector3<f64>; N], [Vector3<f64>; N], Transform);

/// The constant part `A_i(0) = Rz(θ0)·Tz(d)·Tx(a)·Rx(α)·Ry(β)` of a link, computed as
/// [`Robot`]'s FK computes it.
#[must_use]
pub fn link_transform_at_zero(l: &Link) -> Transform {
    let (s, c) = sin_cos(l.theta0);
    let rz = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    let p = column3(&rz, 0) * l.a + column3(&rz, 2) * l.d;
    transform(mat_mul(&rz, &mat_mul(&rot_x(l.alpha), &rot_y(l.beta))), p)
}

/// The rotation by `angle` \[rad\] about the line through `point` along the unit vector
/// `unit_dir`, as a rigid transform.
#[must_use]
pub fn rotation_about_line(point: &Vector3<f64>, unit_dir: &Vector3<f64>, angle: f64) -> Transform {
    let r = rotation_exp(&(unit_dir * angle));
    transform(r, point - mat_vec(&r, point))
}

/// The smallest rotation taking `e_z` onto the unit vector `u` (Rodrigues with the
/// `1/(1 + cos)` form, exact and division-free for `u_z ≥ 0`); for `u_z < 0` a half turn
/// about x first.
fn rotation_z_onto(u: &Vector3<f64>) -> Matrix3<f64> {
    let minimal = |v: &Vector3<f64>| {
        let k = Vector3::new(-v.y, v.x, 0.0);
        let kx = crate::pose::skew(&k);
        IDENTITY + kx + mat_mul(&kx, &kx) * (1.0 / (1.0 + v.z))
    };
    if u.z >= 0.0 {
        minimal(u)
    } else {
        let flip = rot_x(core::f64::consts::PI);
        mat_mul(&flip, &minimal(&mat_vec(&flip.transpose(), u)))
    }
}

impl<const N: usize> AxisChain<N> {
    /// Checks finiteness and returns the unit directions, in the base frame, with the
    /// points in the base frame and the tool in the base frame.
    fn in_base(&self) -> Result<InBase<N>> {
        // fixed3 rather than nalgebra's operators (same bits): theirs keep panic paths at
        // opt-level z.
        let t_base_ref = inverse(&self.t_ref_base);
        let mut pts = [ZERO; N];
        let mut dirs = [ZERO; N];
        let slots = pts.iter_mut().zip(dirs.iter_mut());
        for ((j, ax), (pt, dir)) in self.axes.iter().enumerate().zip(slots) {
            check_finite(ax.point.as_slice(), Quantity::Position).map_err(|_| {
                Error::NonFinite {
                    what: Quantity::Position,
                    index: j,
                }
            })?;
            check_finite(ax.direction.as_slice(), Quantity::Orientation).map_err(|_| {
                Error::NonFinite {
                    what: Quantity::Orientation,
                    index: j,
                }
            })?;
            let n = norm(&ax.direction);
            if n <= MIN_DIRECTION_NORM {
                return Err(Error::DegenerateAxis {
                    joint: JointIndex(j),
                });
            }
            *pt = transform_point(&t_base_ref, &nalgebra::Point3::from(ax.point)).coords;
            *dir = mat_vec(t_base_ref.rotation.matrix(), &(ax.direction / n));
        }
        for (k, t) in [&self.t_ref_base, &self.t_ref_tool].into_iter().enumerate() {
            if !t.translation.vector.iter().all(|v| v.is_finite())
                || !t.rotation.matrix().iter().all(|v| v.is_finite())
            {
                return Err(Error::NonFinite {
                    what: Quantity::Position,
                    index: N + k,
                });
            }
        }
        Ok((pts, dirs, compose(&t_base_ref, &self.t_ref_tool)))
    }

    /// The chain's own forward kinematics `T_base_tool(q)` by the product of exponentials
    /// (module docs): the reference the conversion is checked against.
    pub fn fk(&self, q: &[f64; N]) -> Result<Transform> {
        check_finite(q, Quantity::JointReading)?;
        let (pts, dirs, t_base_tool0) = self.in_base()?;
        let mut t = IDENTITY_TRANSFORM;
        for ((p, u), &qi) in pts.iter().zip(dirs.iter()).zip(q.iter()) {
            t = compose(&t, &rotation_about_line(p, u, qi));
        }
        Ok(compose(&t, &t_base_tool0))
    }

    /// The Hayati/mDH links, d/β choices, base and tool frames of this chain (the
    /// construction in the module docs).
    ///
    /// Fails with [`Error::NonFinite`] (index = joint, or N / N+1 for the base / tool
    /// transform) or [`Error::DegenerateAxis`] for a zero direction.
    pub fn to_mdh(&self) -> Result<MdhChain<N>> {
        let (pts, dirs, t_base_tool0) = self.in_base()?;
        let mut out = MdhChain {
            links: [Link::default(); N],
            length_params: [LengthParam::D; N],
            base: [0.0; 6],
            tool: [0.0; 6],
        };
        // Frame 0.
        let (Some(p1), Some(u1)) = (pts.first(), dirs.first()) else {
            return Err(Error::DimensionMismatch {
                expected: 1,
                found: 0,
            });
        };
        let o0 = p1 - u1 * dot(p1, u1);
        out.base = pose_to_vector6(&transform(rotation_z_onto(u1), o0));
        // Continue from the frame the robot will actually compute.
        let mut frame = pose_from_vector6(&out.base);
        for i in 0..N {
            let link_and_lp = match (pts.get(i + 1), dirs.get(i + 1)) {
                (Some(p_next), Some(u_next)) => {
                    let inv = inverse(&frame);
                    let p = transform_point(&inv, &nalgebra::Point3::from(*p_next)).coords;
                    let u = mat_vec(inv.rotation.matrix(), u_next);
                    middle_link(&p, &u)
                }
                _ => (
                    last_link(&compose(&inverse(&frame), &t_base_tool0)),
                    LengthParam::D,
                ),
            };
            if let (Some(l), Some(lp)) = (out.links.get_mut(i), out.length_params.get_mut(i)) {
                *l = link_and_lp.0;
                *lp = link_and_lp.1;
            }
            frame = compose(&frame, &link_transform_at_zero(&link_and_lp.0));
        }
        out.tool = pose_to_vector6(&compose(&inverse(&frame), &t_base_tool0));
        Ok(out)
    }

    /// A [`Robot`] whose FK equals this chain's ([`AxisChain::to_mdh`]), with the given joint
    /// limits, no masses and no effects.
    pub fn to_robot(&self, limits: [JointLimits; N]) -> Result<Robot<N>> {
        let m = self.to_mdh()?;
        let mut robot = Robot::new(m.links, limits)?
            .with_base(m.base)?
            .with_tool(m.tool)?;
        for (i, lp) in m.length_params.iter().enumerate() {
            robot.set_length_param(i, *lp)?;
        }
        Ok(robot)
    }
}

/// Link `i` from axis `i+1` given in frame `i−1` coordinates (axis `i` is the z axis).
fn middle_link(p: &Vector3<f64>, u: &Vector3<f64>) -> (Link, LengthParam) {
    let sin_angle = hypot(u.x, u.y);
    let angle = atan2(sin_angle, u.z.abs());
    if angle < PARALLEL_AXES_TOL_RAD {
        // Hayati: d = 0, frame i where axis i+1 pierces the plane z = 0.
        let c = p - u * (p.z / u.z);
        let mut a = hypot(c.x, c.y);
        let theta0 = if a <= SNAP_LENGTH_M {
            a = 0.0;
            0.0
        } else {
            atan2(c.y, c.x)
        };
        let (alpha, beta) = tilt_onto(u, theta0);
        (
            Link {
                theta0,
                d: 0.0,
                a,
                alpha,
                beta,
            },
            LengthParam::Beta,
        )
    } else {
        // Common normal of the z axis and the line (p, u).
        let b = u.z;
        let denom = 1.0 - b * b;
        let d = (p.z - b * dot(u, p)) / denom;
        let mut n = Vector3::new(-u.y, u.x, 0.0) / sin_angle;
        let a_signed = dot(p, &n);
        let a = if a_signed.abs() <= SNAP_LENGTH_M {
            if n.x < 0.0 || (n.x == 0.0 && n.y < 0.0) {
                n = -n;
            }
            0.0
        } else if a_signed < 0.0 {
            n = -n;
            -a_signed
        } else {
            a_signed
        };
        let theta0 = atan2(n.y, n.x);
        let (alpha, _) = tilt_onto(u, theta0);
        (
            Link {
                theta0,
                d,
                a,
                alpha,
                beta: 0.0,
            },
            LengthParam::D,
        )
    }
}

/// `(α, β)` with `Rx(α)·Ry(β)·e_z = Rz(−θ)·u`: the tilt of the link after its Rz(θ).
fn tilt_onto(u: &Vector3<f64>, theta: f64) -> (f64, f64) {
    let (s, c) = sin_cos(theta);
    let ux = c * u.x + s * u.y;
    let uy = -s * u.x + c * u.y;
    let alpha = atan2(-uy, u.z);
    let beta = atan2(ux, hypot(uy, u.z));
    (alpha, beta)
}

/// Link N from the tool frame in frame N−1 coordinates.
fn last_link(t_prev_tool: &Transform) -> Link {
    let r = t_prev_tool.rotation.matrix();
    let x = column3(r, 0);
    let y = column3(r, 1);
    let (vx, vy) = if hypot(x.x, x.y) > 1e-9 {
        (x.x, x.y)
    } else {
        // Tool x along the axis: use y, x_N = y × z.
        (y.y, -y.x)
    };
    let n = sqrt(vx * vx + vy * vy);
    let theta0 = if n > 0.0 { atan2(vy, vx) } else { 0.0 };
    Link {
        theta0,
        d: t_prev_tool.translation.vector.z,
        a: 0.0,
        alpha: 0.0,
        beta: 0.0,
    }
}
