//! The robot model: Hayati/mDH links, base and tool frames, joint limits, a point-mass
//! model for gravity, and the parameters of the non-geometric effects.
//!
//! Link transform (spec/aria.md, Section 3.1):
//! `A_i(q_i) = Rz(q_i + θ0_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)` and
//! `T_e^b(q) = T_0^b·A_1(q_1)···A_N(q_N)·T_e^N`.
//! Units: metres, radians, kilograms, seconds.

use nalgebra::Vector3;

use crate::effects::{Effect, EffectSet};
use crate::error::{Error, JointIndex, ParamIndex, Quantity, Result, check_finite};
use crate::params::{CyclicTerm, LinkParam, ParamId, ParamSet, num_geometric_params, num_params};
use crate::pose::{Transform, pose_from_vector6};

/// Two consecutive joint axes count as parallel when the angle between them is below this
/// (1°). For such links Hayati's β replaces d, because d (the distance along the axis to
/// the common normal) is ill-conditioned: it grows like 1/sin(angle) for nearly parallel
/// axes.
pub const PARALLEL_AXES_TOL_RAD: f64 = 0.017_453_292_519_943_295;

/// The five Hayati/mDH parameters of one link.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Link {
    /// Joint offset θ0 \[rad\].
    pub theta0: f64,
    /// Offset along the previous z axis, d \[m\].
    pub d: f64,
    /// Length along the common normal, a \[m\].
    pub a: f64,
    /// Twist about x, α \[rad\].
    pub alpha: f64,
    /// Hayati's twist about y, β \[rad\].
    pub beta: f64,
}

impl Link {
    /// A link with β = 0.
    #[must_use]
    pub const fn dh(theta0: f64, d: f64, a: f64, alpha: f64) -> Self {
        Link {
            theta0,
            d,
            a,
            alpha,
            beta: 0.0,
        }
    }
    fn get(&self, k: LinkParam) -> f64 {
        match k {
            LinkParam::Theta0 => self.theta0,
            LinkParam::D => self.d,
            LinkParam::A => self.a,
            LinkParam::Alpha => self.alpha,
            LinkParam::Beta => self.beta,
        }
    }
    fn get_mut(&mut self, k: LinkParam) -> &mut f64 {
        match k {
            LinkParam::Theta0 => &mut self.theta0,
            LinkParam::D => &mut self.d,
            LinkParam::A => &mut self.a,
            LinkParam::Alpha => &mut self.alpha,
            LinkParam::Beta => &mut self.beta,
        }
    }
}

/// Which of d and β a link identifies (they never both matter for a revolute joint).
///
/// One byte, 0 or 1 (`repr(u8)`): the C ABI's prepared-model handle checks these bytes of a
/// stored [`Robot`] before it reads it (see [`Robot::LENGTH_PARAM_OFFSET`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum LengthParam {
    /// Identify d, keep β at its nominal value (non-parallel axes).
    D = 0,
    /// Identify β, keep d at its nominal value (parallel axes).
    Beta = 1,
}

/// What a joint's reading moves: a rotation about its axis (revolute, sensor) or a
/// translation along it (prismatic).
///
/// Revolute joint i: `A_i(q) = Rz(q + θ0_i)·Tz(d_i)·…`, q in radians, the joint offset is
/// θ0_i. Prismatic joint i: `A_i(q) = Rz(θ0_i)·Tz(d_i + q)·…`, q in metres, the joint offset
/// is d_i and θ0_i is a fixed (still identifiable) rotation about the axis.
///
/// A sensor joint is a passive revolute joint: nothing commands it, a sensor reads it (an
/// inclinometer or an accelerometer's tilt, e.g. a column bending under the arm's weight),
/// so a measured deflection enters the chain as data. Its kinematics are a revolute
/// joint's; its reading is a column of the measurement rows like any other joint's. What
/// differs: inverse kinematics holds it at the seed's reading, and it has no transmission
/// (its cyclic and backlash terms do not apply). The sensor's gain is the `joint_scale`
/// effect on that joint (`θ = (1 + k_j)·q + θ0_j`: a bending gain or a sensor scale), its
/// zero offset is θ0_j.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum JointKind {
    /// Rotation about the joint axis, reading in radians.
    #[default]
    Revolute = 0,
    /// Translation along the joint axis, reading in metres.
    Prismatic = 1,
    /// A passive revolute joint read by a sensor (inclinometer, accelerometer tilt), reading
    /// in radians; not commanded.
    Sensor = 2,
}

impl JointKind {
    /// `"revolute"`, `"prismatic"` or `"sensor"` (the robot file's `type`; URDF has no
    /// sensor joints: they are exported as `revolute`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Prismatic => "prismatic",
            JointKind::Sensor => "sensor",
        }
    }

    /// Whether the reading is an angle (revolute and sensor joints).
    #[must_use]
    pub const fn turns(self) -> bool {
        !matches!(self, JointKind::Prismatic)
    }
}

/// Inclusive joint limits \[rad\] (\[m\] for a prismatic joint).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower limit \[rad\] (\[m\] for a prismatic joint).
    pub lower: f64,
    /// Upper limit \[rad\] (\[m\] for a prismatic joint).
    pub upper: f64,
}

impl JointLimits {
    /// Limits `[lower, upper]`.
    #[must_use]
    pub const fn new(lower: f64, upper: f64) -> Self {
        JointLimits { lower, upper }
    }
    /// Whether `q` lies within the limits (inclusive).
    #[must_use]
    pub fn contains(&self, q: f64) -> bool {
        q >= self.lower && q <= self.upper
    }
}

/// Point-mass model for gravity-dependent effects. Link k's mass sits at the midpoint
/// between the origins of frames k−1 and k; the tool's at the end-effector origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassModel<const N: usize> {
    /// Mass of each link \[kg\].
    pub link_masses_kg: [f64; N],
    /// Mass of the tool \[kg\].
    pub tool_mass_kg: f64,
    /// Gravity in the base frame [m/s²].
    pub gravity: [f64; 3],
}

impl<const N: usize> MassModel<N> {
    /// No masses (gravity torques are zero).
    #[must_use]
    pub const fn massless() -> Self {
        MassModel {
            link_masses_kg: [0.0; N],
            tool_mass_kg: 0.0,
            gravity: [0.0, 0.0, -9.81],
        }
    }
}

/// Joint readings and the auxiliary data some effects need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointState<const N: usize> {
    /// Joint readings as the controller reports them \[rad\] (\[m\] for prismatic joints).
    pub q: [f64; N],
    /// Direction from which each joint approached the pose (−1, 0, +1), for backlash.
    pub approach: Option<[f64; N]>,
    /// Arm temperature [°C], for thermal expansion.
    pub temp_c: Option<f64>,
}

impl<const N: usize> JointState<N> {
    /// Readings only.
    #[must_use]
    pub const fn new(q: [f64; N]) -> Self {
        JointState {
            q,
            approach: None,
            temp_c: None,
        }
    }
    /// Checks that every number is finite and approach directions are −1, 0 or +1.
    pub fn validate(&self) -> Result<()> {
        check_finite(&self.q, Quantity::JointReading)?;
        if let Some(index) = self
            .approach
            .as_ref()
            .and_then(|s| s.iter().position(|&v| v != -1.0 && v != 0.0 && v != 1.0))
        {
            return Err(Error::NonFinite {
                what: Quantity::ApproachDirection,
                index,
            });
        }
        if let Some(t) = self.temp_c {
            check_finite(&[t], Quantity::Temperature)?;
        }
        Ok(())
    }
}

/// Parameters of the non-geometric joint effects (all zero: the geometric model).
///
/// On a prismatic joint the same parameters act on the slide instead of the angle, in
/// metres: compliance Δd = c·F with F the gravity force along the axis \[m/N\], scale
/// Δd = k·q, backlash Δd = b·s \[m\]. The cyclic terms (periodic in the angle) do not apply
/// to a prismatic joint: they stay zero ([`Robot::set_param`] refuses a non-zero value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectParams<const N: usize> {
    /// Joint compliance c_j [rad/(N·m)] (\[m/N\] for a prismatic joint).
    pub compliance: [f64; N],
    /// Joint scale k_j \[1\].
    pub scale: [f64; N],
    /// Cyclic error [a_j, b_j, c_j, d_j] \[rad\] on sin q, cos q, sin 2q, cos 2q.
    pub cyclic: [[f64; 4]; N],
    /// Backlash b_j \[rad\] (\[m\] for a prismatic joint).
    pub backlash: [f64; N],
    /// Thermal expansion κ [1/K].
    pub thermal_kappa: f64,
}

impl<const N: usize> Default for EffectParams<N> {
    fn default() -> Self {
        EffectParams {
            compliance: [0.0; N],
            scale: [0.0; N],
            cyclic: [[0.0; 4]; N],
            backlash: [0.0; N],
            thermal_kappa: 0.0,
        }
    }
}

/// Where the sensor-joint bits start in [`Robot`]'s kind word (bit `SENSOR_BIT + j`).
const SENSOR_BIT: usize = 32;

/// Reference temperature of the thermal effect [°C].
pub const THERMAL_REFERENCE_C: f64 = 20.0;

/// The geometry of a chain with its constant link parts precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Geometry<const N: usize> {
    pub(crate) links: [Link; N],
    pub(crate) base: [f64; 6],
    pub(crate) tool: [f64; 6],
    /// `[cos α_i, sin α_i, cos β_i, sin β_i]`: the constant rotation `Rx(α_i)·Ry(β_i)` of
    /// each link, applied in FK as two plane rotations of column pairs.
    pub(crate) link_cs: [[f64; 4]; N],
    /// `[cos θ0_i, sin θ0_i]`, for FK from precomputed joint sines and cosines.
    pub(crate) theta0_cs: [[f64; 2]; N],
    pub(crate) t_base: Transform,
    pub(crate) t_tool: Transform,
}

impl<const N: usize> Geometry<N> {
    fn new(links: [Link; N], base: [f64; 6], tool: [f64; 6]) -> Self {
        let mut g = Geometry {
            links,
            base,
            tool,
            link_cs: [[1.0, 0.0, 1.0, 0.0]; N],
            theta0_cs: [[1.0, 0.0]; N],
            t_base: pose_from_vector6(&base),
            t_tool: pose_from_vector6(&tool),
        };
        for i in 0..N {
            g.refresh_link(i);
            g.refresh_theta0(i);
        }
        g
    }
    fn refresh_theta0(&mut self, i: usize) {
        if let (Some(cs), Some(l)) = (self.theta0_cs.get_mut(i), self.links.get(i)) {
            let (s, c) = crate::math::sin_cos(l.theta0);
            *cs = [c, s];
        }
    }
    fn refresh_link(&mut self, i: usize) {
        if let (Some(cs), Some(l)) = (self.link_cs.get_mut(i), self.links.get(i)) {
            let (sa, ca) = crate::math::sin_cos(l.alpha);
            let (sb, cb) = crate::math::sin_cos(l.beta);
            *cs = [ca, sa, cb, sb];
        }
    }
}

/// A robot model with `N` joints, each revolute or prismatic ([`JointKind`]): geometry (links, base, tool), joint limits, mass
/// model, and effect parameters. Plain data; every algorithm is a method or a free function
/// taking it by reference, so there is no hidden state.
///
/// Layout contract with the C ABI (ffi/src/prepared.rs keeps a built model byte for byte in
/// caller-owned storage and validates it before use): every field except `length_param` is
/// made of `f64` (or, for `kind_bits`, one `u64`) only, so any bit pattern of them is a valid
/// value; `length_param` is the only field with invalid bit patterns and sits at
/// [`Robot::LENGTH_PARAM_OFFSET`]. A field of
/// another type breaks that contract: update ffi/src/prepared.rs with it (its size assertion
/// catches most such changes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Robot<const N: usize> {
    pub(crate) geom: Geometry<N>,
    /// The description's nominal geometry: gravity torques are evaluated with it
    /// (spec/effects.md), so calibrating the geometry does not move the mass model.
    pub(crate) nominal: Geometry<N>,
    pub(crate) length_param: [LengthParam; N],
    /// Bit j set: joint j is prismatic; bit `SENSOR_BIT + j` set: joint j is a sensor joint
    /// ([`JointKind`]; both set reads as prismatic); other bits are zero. A `u64` rather than
    /// `[JointKind; N]` so that every bit pattern is a valid value (the C ABI's prepared
    /// handle; it limits the joints that may have a kind other than revolute to 32).
    pub(crate) kind_bits: u64,
    pub(crate) limits: [JointLimits; N],
    pub(crate) mass: MassModel<N>,
    pub(crate) effects: EffectParams<N>,
}

impl<const N: usize> Robot<N> {
    /// Total number of parameters (geometric and effects).
    pub const NUM_PARAMS: usize = num_params(N);
    /// Number of geometric parameters (links, base, tool).
    pub const NUM_GEOMETRIC_PARAMS: usize = num_geometric_params(N);
    /// Byte offset of the `[LengthParam; N]` field inside `Robot<N>` (layout introspection
    /// for the C ABI's prepared-model handle, which checks those bytes of a stored model; see
    /// the layout contract on [`Robot`]).
    #[doc(hidden)]
    pub const LENGTH_PARAM_OFFSET: usize = core::mem::offset_of!(Robot<N>, length_param);

    /// A robot from its links and joint limits, with identity base and tool frames, no
    /// masses and no effects. The d/β choice of every link is made from axis parallelism
    /// ([`PARALLEL_AXES_TOL_RAD`]); the last link always identifies d.
    pub fn new(links: [Link; N], limits: [JointLimits; N]) -> Result<Self> {
        if N == 0 {
            return Err(Error::DimensionMismatch {
                expected: 1,
                found: 0,
            });
        }
        for (i, l) in links.iter().enumerate() {
            // Flat parameter index 5·i + k (θ0, d, a, α, β), as in [`crate::params`].
            check_finite(&[l.theta0, l.d, l.a, l.alpha, l.beta], Quantity::Parameter).map_err(
                |e| match e {
                    Error::NonFinite { what, index } => Error::NonFinite {
                        what,
                        index: 5 * i + index,
                    },
                    other => other,
                },
            )?;
        }
        for (j, lim) in limits.iter().enumerate() {
            if !lim.lower.is_finite() || !lim.upper.is_finite() || lim.lower > lim.upper {
                return Err(Error::InvalidLimits {
                    joint: JointIndex(j),
                });
            }
        }
        Ok(Self::new_unchecked(links, limits, MassModel::massless()))
    }

    /// Construction without validation, for built-in constant data.
    pub(crate) fn new_unchecked(
        links: [Link; N],
        limits: [JointLimits; N],
        mass: MassModel<N>,
    ) -> Self {
        let geom = Geometry::new(links, [0.0; 6], [0.0; 6]);
        let mut robot = Robot {
            geom,
            nominal: geom,
            length_param: [LengthParam::D; N],
            kind_bits: 0,
            limits,
            mass,
            effects: EffectParams::default(),
        };
        robot.length_param = robot.auto_length_params();
        robot
    }

    /// This robot with base frame `[px, py, pz, rx, ry, rz]` (`Trans(p)·Rot(r)`, metres and
    /// a rotation vector in radians); also becomes the nominal base.
    pub fn with_base(mut self, base: [f64; 6]) -> Result<Self> {
        check_finite(&base, Quantity::Parameter)?;
        self.geom = Geometry::new(self.geom.links, base, self.geom.tool);
        self.nominal = Geometry::new(self.nominal.links, base, self.nominal.tool);
        Ok(self)
    }

    /// This robot with tool frame `[px, py, pz, rx, ry, rz]` relative to the last link
    /// frame; also becomes the nominal tool.
    pub fn with_tool(mut self, tool: [f64; 6]) -> Result<Self> {
        check_finite(&tool, Quantity::Parameter)?;
        self.geom = Geometry::new(self.geom.links, self.geom.base, tool);
        self.nominal = Geometry::new(self.nominal.links, self.nominal.base, tool);
        Ok(self)
    }

    /// This robot with a mass model; masses must be finite and non-negative.
    pub fn with_mass(mut self, mass: MassModel<N>) -> Result<Self> {
        check_finite(&mass.link_masses_kg, Quantity::Parameter)?;
        check_finite(&[mass.tool_mass_kg], Quantity::Parameter)?;
        check_finite(&mass.gravity, Quantity::Parameter)?;
        for (index, &m) in mass
            .link_masses_kg
            .iter()
            .chain(core::iter::once(&mass.tool_mass_kg))
            .enumerate()
        {
            if m < 0.0 {
                return Err(Error::InvalidParameter { index, value: m });
            }
        }
        self.mass = mass;
        Ok(self)
    }

    /// The d/β choice from axis parallelism: link i < N identifies β when the axes of
    /// joints i and i+1 are parallel within [`PARALLEL_AXES_TOL_RAD`], d otherwise.
    #[must_use]
    pub fn auto_length_params(&self) -> [LengthParam; N] {
        let mut out = [LengthParam::D; N];
        let links = out.iter_mut().zip(self.geom.link_cs.iter());
        for (lp, &[ca, _, cb, _]) in links.take(N.saturating_sub(1)) {
            // Angle between z_{i-1} and z_i: z_i = Rx(α)Ry(β)·e_z in frame i−1 (after Rz),
            // whose z component is cos α·cos β.
            let cos_angle = (ca * cb).abs().min(1.0);
            let angle =
                crate::math::atan2(crate::math::sqrt(1.0 - cos_angle * cos_angle), cos_angle);
            if angle < PARALLEL_AXES_TOL_RAD {
                *lp = LengthParam::Beta;
            }
        }
        out
    }

    /// Which of d/β each link identifies.
    #[must_use]
    pub fn length_params(&self) -> &[LengthParam; N] {
        &self.length_param
    }

    /// Overrides the d/β choice of `link` (zero-based).
    pub fn set_length_param(&mut self, link: usize, choice: LengthParam) -> Result<()> {
        match self.length_param.get_mut(link) {
            Some(lp) => {
                *lp = choice;
                Ok(())
            }
            None => Err(Error::DimensionMismatch {
                expected: N,
                found: link + 1,
            }),
        }
    }

    /// The kind of joint `j` (zero-based; revolute out of range).
    #[must_use]
    pub fn joint_kind(&self, j: usize) -> JointKind {
        if j >= N || j >= SENSOR_BIT {
            JointKind::Revolute
        } else if (self.kind_bits >> j) & 1 == 1 {
            JointKind::Prismatic
        } else if (self.kind_bits >> (SENSOR_BIT + j)) & 1 == 1 {
            JointKind::Sensor
        } else {
            JointKind::Revolute
        }
    }

    /// The kind of every joint.
    #[must_use]
    pub fn joint_kinds(&self) -> [JointKind; N] {
        let mut out = [JointKind::Revolute; N];
        for (j, k) in out.iter_mut().enumerate() {
            *k = self.joint_kind(j);
        }
        out
    }

    /// Whether any joint is prismatic.
    #[must_use]
    pub fn has_prismatic(&self) -> bool {
        self.kind_bits & ((1u64 << SENSOR_BIT) - 1) != 0
    }

    /// Whether any joint is a sensor joint.
    #[must_use]
    pub fn has_sensor_joints(&self) -> bool {
        self.kind_bits >> SENSOR_BIT != 0
    }

    /// Sets the kind of joint `j` (zero-based). Making a joint prismatic or a sensor joint is
    /// refused ([`Error::InvalidParameter`] naming the parameter) while it has a non-zero
    /// cyclic term, which has no meaning on a slide or without a transmission (nor has a
    /// sensor joint's backlash: refused likewise). Limits are not converted: give a
    /// prismatic joint's in metres. Only the first 32 joints may be other than revolute.
    pub fn set_joint_kind(&mut self, j: usize, kind: JointKind) -> Result<()> {
        if j >= N || j >= SENSOR_BIT {
            return Err(Error::DimensionMismatch {
                expected: N,
                found: j + 1,
            });
        }
        if kind != JointKind::Revolute {
            for t in CyclicTerm::ALL {
                let v = self.effects.cyclic[j][t as usize];
                if v != 0.0 {
                    return Err(Error::InvalidParameter {
                        index: ParamId::Cyclic(j, t).index(N).0,
                        value: v,
                    });
                }
            }
        }
        let backlash = self.effects.backlash.get(j).copied().unwrap_or(0.0);
        if kind == JointKind::Sensor && backlash != 0.0 {
            return Err(Error::InvalidParameter {
                index: ParamId::Backlash(j).index(N).0,
                value: backlash,
            });
        }
        self.kind_bits &= !((1u64 << j) | (1u64 << (SENSOR_BIT + j)));
        match kind {
            JointKind::Revolute => {}
            JointKind::Prismatic => self.kind_bits |= 1 << j,
            JointKind::Sensor => self.kind_bits |= 1 << (SENSOR_BIT + j),
        }
        Ok(())
    }

    /// This robot with the joint kinds `kinds` (see [`Robot::set_joint_kind`]).
    pub fn with_joint_kinds(mut self, kinds: &[JointKind; N]) -> Result<Self> {
        for (j, &k) in kinds.iter().enumerate() {
            self.set_joint_kind(j, k)?;
        }
        Ok(self)
    }

    /// `[1 or 0; N]`: 1.0 where the joint is revolute, 0.0 where prismatic. FK takes each
    /// displacement into the angle (times the mask) or the slide (times 1 − mask) without a
    /// branch.
    pub(crate) fn turn_mask(&self) -> [f64; N] {
        let mut m = [1.0; N];
        for (j, v) in m.iter_mut().enumerate() {
            if !self.joint_kind(j).turns() {
                *v = 0.0;
            }
        }
        m
    }

    /// The links (current geometry).
    #[must_use]
    pub fn links(&self) -> &[Link; N] {
        &self.geom.links
    }
    /// The nominal links (the description's, used for gravity torques).
    #[must_use]
    pub fn nominal_links(&self) -> &[Link; N] {
        &self.nominal.links
    }
    /// The base frame parameters `[px, py, pz, rx, ry, rz]`.
    #[must_use]
    pub fn base(&self) -> [f64; 6] {
        self.geom.base
    }
    /// The tool frame parameters `[px, py, pz, rx, ry, rz]`.
    #[must_use]
    pub fn tool(&self) -> [f64; 6] {
        self.geom.tool
    }
    /// The base transform `T_0^b`.
    #[must_use]
    pub fn t_base_0(&self) -> &Transform {
        &self.geom.t_base
    }
    /// The tool transform `T_e^N`.
    #[must_use]
    pub fn t_n_tool(&self) -> &Transform {
        &self.geom.t_tool
    }
    /// Joint limits.
    #[must_use]
    pub fn limits(&self) -> &[JointLimits; N] {
        &self.limits
    }
    /// Replaces the joint limits.
    pub fn set_limits(&mut self, limits: [JointLimits; N]) -> Result<()> {
        for (j, lim) in limits.iter().enumerate() {
            if !lim.lower.is_finite() || !lim.upper.is_finite() || lim.lower > lim.upper {
                return Err(Error::InvalidLimits {
                    joint: JointIndex(j),
                });
            }
        }
        self.limits = limits;
        Ok(())
    }
    /// The mass model.
    #[must_use]
    pub fn mass(&self) -> &MassModel<N> {
        &self.mass
    }
    /// The effect parameters.
    #[must_use]
    pub fn effect_params(&self) -> &EffectParams<N> {
        &self.effects
    }

    /// Checks that every reading lies within the joint limits (inclusive).
    pub fn check_limits(&self, q: &[f64; N]) -> Result<()> {
        check_finite(q, Quantity::JointReading)?;
        for (j, (&v, lim)) in q.iter().zip(self.limits.iter()).enumerate() {
            if !lim.contains(v) {
                return Err(Error::OutOfLimits {
                    joint: JointIndex(j),
                    value: v,
                    lower: lim.lower,
                    upper: lim.upper,
                });
            }
        }
        Ok(())
    }

    /// The value of parameter `i` (layout in [`crate::params`]).
    pub fn param(&self, i: ParamIndex) -> Result<f64> {
        Ok(match ParamId::from_index(i, N)? {
            ParamId::Link { link, kind } => self.geom.links.get(link).map_or(0.0, |l| l.get(kind)),
            ParamId::Base(k) => self.geom.base.get(k as usize).copied().unwrap_or(0.0),
            ParamId::Tool(k) => self.geom.tool.get(k as usize).copied().unwrap_or(0.0),
            ParamId::Compliance(j) => self.effects.compliance.get(j).copied().unwrap_or(0.0),
            ParamId::Scale(j) => self.effects.scale.get(j).copied().unwrap_or(0.0),
            ParamId::Cyclic(j, t) => self
                .effects
                .cyclic
                .get(j)
                .and_then(|c| c.get(t as usize))
                .copied()
                .unwrap_or(0.0),
            ParamId::Backlash(j) => self.effects.backlash.get(j).copied().unwrap_or(0.0),
            ParamId::Thermal => self.effects.thermal_kappa,
        })
    }

    /// Sets parameter `i` (must be finite) and refreshes the precomputed link constants. A
    /// non-zero cyclic term of a prismatic joint is refused ([`Error::InvalidParameter`]).
    pub fn set_param(&mut self, i: ParamIndex, value: f64) -> Result<()> {
        if !value.is_finite() {
            return Err(Error::NonFinite {
                what: Quantity::Parameter,
                index: i.0,
            });
        }
        match ParamId::from_index(i, N)? {
            ParamId::Link { link, kind } => {
                if let Some(l) = self.geom.links.get_mut(link) {
                    *l.get_mut(kind) = value;
                }
                if matches!(kind, LinkParam::Alpha | LinkParam::Beta) {
                    self.geom.refresh_link(link);
                }
                if kind == LinkParam::Theta0 {
                    self.geom.refresh_theta0(link);
                }
            }
            ParamId::Base(k) => {
                set_at(&mut self.geom.base, k as usize, value);
                self.geom.t_base = pose_from_vector6(&self.geom.base);
            }
            ParamId::Tool(k) => {
                set_at(&mut self.geom.tool, k as usize, value);
                self.geom.t_tool = pose_from_vector6(&self.geom.tool);
            }
            ParamId::Compliance(j) => set_at(&mut self.effects.compliance, j, value),
            ParamId::Scale(j) => set_at(&mut self.effects.scale, j, value),
            ParamId::Cyclic(j, t) => {
                if value != 0.0 && self.joint_kind(j) != JointKind::Revolute {
                    return Err(Error::InvalidParameter { index: i.0, value });
                }
                if let Some(c) = self.effects.cyclic.get_mut(j) {
                    set_at(c, t as usize, value);
                }
            }
            ParamId::Backlash(j) => {
                if value != 0.0 && self.joint_kind(j) == JointKind::Sensor {
                    return Err(Error::InvalidParameter { index: i.0, value });
                }
                set_at(&mut self.effects.backlash, j, value);
            }
            ParamId::Thermal => self.effects.thermal_kappa = value,
        }
        Ok(())
    }

    /// Writes every parameter into `out` (`out.len() == NUM_PARAMS`).
    pub fn read_params(&self, out: &mut [f64]) -> Result<()> {
        if out.len() != Self::NUM_PARAMS {
            return Err(Error::DimensionMismatch {
                expected: Self::NUM_PARAMS,
                found: out.len(),
            });
        }
        for (i, v) in out.iter_mut().enumerate() {
            *v = self.param(ParamIndex(i))?;
        }
        Ok(())
    }

    /// Sets every parameter from `p` (`p.len() == NUM_PARAMS`, all finite). On error the
    /// robot is unchanged.
    pub fn write_params(&mut self, p: &[f64]) -> Result<()> {
        if p.len() != Self::NUM_PARAMS {
            return Err(Error::DimensionMismatch {
                expected: Self::NUM_PARAMS,
                found: p.len(),
            });
        }
        check_finite(p, Quantity::Parameter)?;
        for (i, &v) in p.iter().enumerate() {
            self.set_param(ParamIndex(i), v)?;
        }
        Ok(())
    }

    /// The geometric parameters identified by default: θ0, a, α and (d or β) of every link,
    /// 4N in all. Base and tool frames are fixed unless their effects are asked for.
    #[must_use]
    pub fn geometric_param_set(&self) -> ParamSet {
        let mut set = ParamSet::new();
        for (link, lp) in self.length_param.iter().enumerate() {
            let kinds = [
                LinkParam::Theta0,
                match lp {
                    LengthParam::D => LinkParam::D,
                    LengthParam::Beta => LinkParam::Beta,
                },
                LinkParam::A,
                LinkParam::Alpha,
            ];
            for kind in kinds {
                // Indices below 5N <= capacity for N <= 20.
                let _ = set.insert(ParamId::Link { link, kind }.index(N).0);
            }
        }
        set
    }

    /// Geometric parameters plus every parameter of `effects` that applies (the cyclic
    /// terms of prismatic and sensor joints and the backlash of sensor joints do not).
    #[must_use]
    pub fn param_set(&self, effects: EffectSet) -> ParamSet {
        let mut set = self.geometric_param_set().union(&effects.params(N));
        self.remove_inapplicable(&mut set);
        set
    }

    /// Removes from `set` the parameters that do not apply to this robot: the cyclic terms
    /// of its prismatic and sensor joints, the backlash of its sensor joints.
    pub fn remove_inapplicable(&self, set: &mut ParamSet) {
        for j in 0..N {
            let kind = self.joint_kind(j);
            if kind != JointKind::Revolute {
                for t in CyclicTerm::ALL {
                    set.remove(ParamId::Cyclic(j, t).index(N).0);
                }
            }
            if kind == JointKind::Sensor {
                set.remove(ParamId::Backlash(j).index(N).0);
            }
        }
    }

    /// Which effects have a non-zero parameter in this model.
    #[must_use]
    pub fn active_effects(&self) -> EffectSet {
        let e = &self.effects;
        let mut set = EffectSet::NONE;
        let nz = |s: &[f64]| s.iter().any(|&v| v != 0.0);
        if nz(&e.compliance) {
            set = set.with(Effect::JointCompliance);
        }
        if nz(&e.scale) {
            set = set.with(Effect::JointScale);
        }
        if e.cyclic.iter().any(|c| nz(c)) {
            set = set.with(Effect::JointCyclic);
        }
        if nz(&e.backlash) {
            set = set.with(Effect::Backlash);
        }
        if e.thermal_kappa != 0.0 {
            set = set.with(Effect::Thermal);
        }
        set
    }

    /// The joint displacements the geometry sees, `q_j + Δθ_j` (without θ0; an angle in
    /// radians for a revolute joint, a slide in metres added to d for a prismatic one),
    /// after the joint effects: compliance, scale, cyclic, backlash. Fails with [`Error::MissingInput`] when
    /// the model has backlash but `state` has no approach directions.
    pub fn joint_angles(&self, state: &JointState<N>) -> Result<[f64; N]> {
        self.joint_angles_and_torques(state)
            .map(|(angles, _)| angles)
    }

    /// [`Robot::joint_angles`], and the gravity torques at the readings when the model's
    /// compliance needed them (`None` otherwise): the identification Jacobian's compliance
    /// columns use the same torques, computed once.
    pub(crate) fn joint_angles_and_torques(
        &self,
        state: &JointState<N>,
    ) -> Result<([f64; N], Option<[f64; N]>)> {
        self.joint_angles_with_torques(state, None)
    }

    /// [`Robot::joint_angles_and_torques`] with the gravity torques at the readings already
    /// `known` (from a cache: [`Robot::gravity_torques`]'s values bit for bit, so the angles
    /// are too), computed only when not given.
    pub(crate) fn joint_angles_with_torques(
        &self,
        state: &JointState<N>,
        known: Option<&[f64; N]>,
    ) -> Result<([f64; N], Option<[f64; N]>)> {
        state.validate()?;
        let e = &self.effects;
        let mut out = state.q;
        let has_compliance = any_non_zero(&e.compliance);
        let tau = match (has_compliance, known) {
            (false, _) => [0.0; N],
            (true, Some(t)) => *t,
            (true, None) => self.gravity_torques(&state.q),
        };
        let has_backlash = any_non_zero(&e.backlash);
        let approach = match (has_backlash, state.approach) {
            (true, None) => {
                return Err(Error::MissingInput {
                    what: Quantity::ApproachDirection,
                });
            }
            (_, s) => s.unwrap_or([0.0; N]),
        };
        let has_scale = any_non_zero(&e.scale);
        let has_cyclic = any_non_zero(e.cyclic.as_flattened());
        let torques = has_compliance.then_some(tau);
        if !(has_compliance || has_backlash || has_scale || has_cyclic) {
            // The geometric model: the readings are the angles.
            return Ok((state.q, torques));
        }
        for j in 0..N {
            let q = state.q[j];
            let c = &e.cyclic[j];
            let mut dtheta =
                e.compliance[j] * tau[j] + e.scale[j] * q + e.backlash[j] * approach[j];
            // The cyclic terms cost a sine and cosine: only where they are in the model
            // (FK without effects is dominated by its trigonometry).
            if c.iter().any(|&v| v != 0.0) {
                let (s1, c1) = crate::math::sin_cos(q);
                let (s2, c2) = (2.0 * s1 * c1, c1 * c1 - s1 * s1);
                dtheta += c[CyclicTerm::Sin1 as usize] * s1
                    + c[CyclicTerm::Cos1 as usize] * c1
                    + c[CyclicTerm::Sin2 as usize] * s2
                    + c[CyclicTerm::Cos2 as usize] * c2;
            }
            out[j] = q + dtheta;
        }
        // Finite but absurd effect parameters can overflow (fuzzing): never pass NaN on.
        check_finite(&out, Quantity::Parameter)?;
        Ok((out, torques))
    }

    /// The factor `1 + κ·(T − 20 °C)` applied to every d and a. Fails when κ ≠ 0 and the
    /// state carries no temperature.
    pub fn length_scale(&self, state: &JointState<N>) -> Result<f64> {
        let kappa = self.effects.thermal_kappa;
        match state.temp_c {
            Some(t) => Ok(1.0 + kappa * (t - THERMAL_REFERENCE_C)),
            None if kappa == 0.0 => Ok(1.0),
            None => Err(Error::MissingInput {
                what: Quantity::Temperature,
            }),
        }
    }

    /// Sets every parameter of `effects` to zero (the model without those effects).
    pub fn clear_effects(&mut self, effects: EffectSet) {
        for i in effects.params(N).iter() {
            // Indices come from the model's own layout.
            let _ = self.set_param(ParamIndex(i), 0.0);
        }
    }

    /// The nominal geometry's base and tool frame vectors (for resetting).
    #[must_use]
    pub fn nominal_frames(&self) -> ([f64; 6], [f64; 6]) {
        (self.nominal.base, self.nominal.tool)
    }

    /// Makes the current geometry the nominal one (e.g. a calibrated model used as the
    /// description of a new calibration).
    pub fn adopt_geometry_as_nominal(&mut self) {
        self.nominal = self.geom;
    }

    /// The gravity vector as a nalgebra vector.
    pub(crate) fn gravity(&self) -> Vector3<f64> {
        Vector3::new(
            self.mass.gravity[0],
            self.mass.gravity[1],
            self.mass.gravity[2],
        )
    }
}

/// Number of words [`Robot::for_each_key_word`] gives for `n` joints.
pub(crate) const fn key_words(n: usize) -> usize {
    2 * (11 * n + 36) + n + 1 + 2 * n + (n + 4) + (7 * n + 1)
}

impl<const N: usize> Robot<N> {
    /// Feeds every number of the model to `f`, bit for bit (`f64::to_bits`), in a fixed
    /// order: two robots give the same words exactly when every field is bitwise equal, so
    /// the words are an exact key for work that depends only on the model (the structural
    /// step of the identifiability analysis, see `identify::memo`). The destructuring names
    /// every field: adding one to `Robot`, `Geometry`, `MassModel` or `EffectParams`
    /// without adding it here does not compile.
    pub(crate) fn for_each_key_word(&self, f: &mut impl FnMut(u64)) {
        let Robot {
            geom,
            nominal,
            length_param,
            kind_bits,
            limits,
            mass,
            effects,
        } = self;
        geom.for_each_key_word(f);
        nominal.for_each_key_word(f);
        for l in length_param {
            f(*l as u64);
        }
        f(*kind_bits);
        for l in limits {
            let JointLimits { lower, upper } = l;
            f(lower.to_bits());
            f(upper.to_bits());
        }
        let MassModel {
            link_masses_kg,
            tool_mass_kg,
            gravity,
        } = mass;
        link_masses_kg.iter().for_each(|v| f(v.to_bits()));
        f(tool_mass_kg.to_bits());
        gravity.iter().for_each(|v| f(v.to_bits()));
        let EffectParams {
            compliance,
            scale,
            cyclic,
            backlash,
            thermal_kappa,
        } = effects;
        compliance.iter().for_each(|v| f(v.to_bits()));
        scale.iter().for_each(|v| f(v.to_bits()));
        cyclic.iter().flatten().for_each(|v| f(v.to_bits()));
        backlash.iter().for_each(|v| f(v.to_bits()));
        f(thermal_kappa.to_bits());
    }
}

/// Number of words [`Robot::for_each_gravity_key_word`] gives for `n` joints.
pub(crate) const fn gravity_key_words(n: usize) -> usize {
    (11 * n + 36) + 1 + (n + 4)
}

impl<const N: usize> Robot<N> {
    /// Feeds every number [`Robot::gravity_torques`] depends on to `f`, bit for bit: the
    /// nominal geometry, the joint kinds and the mass model. Two robots giving the same
    /// words have the same gravity torques at every reading, whatever their calibrated
    /// geometry and effects: the key of the per-row torque cache of a fit, whose models
    /// change every iteration while their torques do not (`identify::torques`).
    pub(crate) fn for_each_gravity_key_word(&self, f: &mut impl FnMut(u64)) {
        self.nominal.for_each_key_word(f);
        f(self.kind_bits);
        let MassModel {
            link_masses_kg,
            tool_mass_kg,
            gravity,
        } = &self.mass;
        link_masses_kg.iter().for_each(|v| f(v.to_bits()));
        f(tool_mass_kg.to_bits());
        gravity.iter().for_each(|v| f(v.to_bits()));
    }
}

impl<const N: usize> Geometry<N> {
    /// The geometry's part of [`Robot::for_each_key_word`]: `11·N + 36` words.
    fn for_each_key_word(&self, f: &mut impl FnMut(u64)) {
        let Geometry {
            links,
            base,
            tool,
            link_cs,
            theta0_cs,
            t_base,
            t_tool,
        } = self;
        for l in links {
            let Link {
                theta0,
                d,
                a,
                alpha,
                beta,
            } = l;
            [theta0, d, a, alpha, beta]
                .into_iter()
                .for_each(|v| f(v.to_bits()));
        }
        base.iter().chain(tool.iter()).for_each(|v| f(v.to_bits()));
        link_cs.iter().flatten().for_each(|v| f(v.to_bits()));
        theta0_cs.iter().flatten().for_each(|v| f(v.to_bits()));
        for t in [t_base, t_tool] {
            t.rotation
                .matrix()
                .iter()
                .chain(t.translation.vector.iter())
                .for_each(|v| f(v.to_bits()));
        }
    }
}

fn set_at<const N: usize>(arr: &mut [f64; N], j: usize, value: f64) {
    if let Some(v) = arr.get_mut(j) {
        *v = value;
    }
}

/// Whether any value is `!= 0.0` (NaN included), without a branch per value: FK asks it of
/// every effect's parameters on every call, and the usual model has none.
#[inline(always)]
pub(crate) fn any_non_zero(values: &[f64]) -> bool {
    // The bits without the sign are zero exactly for ±0.
    values.iter().fold(0, |acc, v| acc | (v.to_bits() << 1)) != 0
}
