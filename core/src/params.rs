//! The flat parameter vector of a robot model and the labels of its entries.
//!
//! Layout for `N` joints (all indices zero-based; labels use 1-based link numbers):
//!
//! | range | parameters | labels |
//! |---|---|---|
//! | `5i .. 5i+5` | link `i`: θ0 \[rad\], d \[m\], a \[m\], α \[rad\], β \[rad\] | `theta0_1`, `d_1`, `a_1`, `alpha_1`, `beta_1` |
//! | `5N .. 5N+6` | base frame `Trans(p)·Rot(r)`: px, py, pz \[m\], rx, ry, rz [rad, rotation vector] | `base_px` … `base_rz` |
//! | `5N+6 .. 5N+12` | tool frame, same form | `tool_px` … `tool_rz` |
//! | `5N+12 .. 6N+12` | joint compliance c_j [rad/(N·m)] | `compliance_1` … |
//! | `6N+12 .. 7N+12` | joint scale k_j \[1\] | `scale_1` … |
//! | `7N+12 .. 11N+12` | cyclic error a_j, b_j, c_j, d_j \[rad\] (sin q, cos q, sin 2q, cos 2q) | `cyclic_sin1_1`, `cyclic_cos1_1`, `cyclic_sin2_1`, `cyclic_cos2_1` … |
//! | `11N+12 .. 12N+12` | backlash b_j \[rad\] | `backlash_1` … |
//! | `12N+12` | thermal expansion κ [1/K] | `thermal_kappa` |
//!
//! The names of the effects are those of spec/effects.md.

use core::fmt;

use crate::error::{Error, ParamIndex, Result};

/// One of the five Hayati/mDH link parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LinkParam {
    /// Joint offset θ0 \[rad\].
    Theta0 = 0,
    /// Offset along z, d \[m\].
    D = 1,
    /// Length along x, a \[m\].
    A = 2,
    /// Twist about x, α \[rad\].
    Alpha = 3,
    /// Hayati's twist about y, β \[rad\].
    Beta = 4,
}

impl LinkParam {
    /// All five, in layout order.
    pub const ALL: [LinkParam; 5] = [
        LinkParam::Theta0,
        LinkParam::D,
        LinkParam::A,
        LinkParam::Alpha,
        LinkParam::Beta,
    ];
    /// Label stem (`theta0`, `d`, `a`, `alpha`, `beta`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            LinkParam::Theta0 => "theta0",
            LinkParam::D => "d",
            LinkParam::A => "a",
            LinkParam::Alpha => "alpha",
            LinkParam::Beta => "beta",
        }
    }
    /// Whether the parameter is a length (metres) rather than an angle (radians).
    #[must_use]
    pub const fn is_length(self) -> bool {
        matches!(self, LinkParam::D | LinkParam::A)
    }
}

/// One of the six parameters of a frame `Trans(p)·Rot(r)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameParam {
    /// Translation x \[m\].
    Px = 0,
    /// Translation y \[m\].
    Py = 1,
    /// Translation z \[m\].
    Pz = 2,
    /// Rotation vector x \[rad\].
    Rx = 3,
    /// Rotation vector y \[rad\].
    Ry = 4,
    /// Rotation vector z \[rad\].
    Rz = 5,
}

impl FrameParam {
    /// All six, in layout order.
    pub const ALL: [FrameParam; 6] = [
        FrameParam::Px,
        FrameParam::Py,
        FrameParam::Pz,
        FrameParam::Rx,
        FrameParam::Ry,
        FrameParam::Rz,
    ];
    /// Label suffix (`px` … `rz`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            FrameParam::Px => "px",
            FrameParam::Py => "py",
            FrameParam::Pz => "pz",
            FrameParam::Rx => "rx",
            FrameParam::Ry => "ry",
            FrameParam::Rz => "rz",
        }
    }
}

/// The four terms of the cyclic transmission error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CyclicTerm {
    /// a_j·sin q_j.
    Sin1 = 0,
    /// b_j·cos q_j.
    Cos1 = 1,
    /// c_j·sin 2q_j.
    Sin2 = 2,
    /// d_j·cos 2q_j.
    Cos2 = 3,
}

impl CyclicTerm {
    /// All four, in layout order.
    pub const ALL: [CyclicTerm; 4] = [
        CyclicTerm::Sin1,
        CyclicTerm::Cos1,
        CyclicTerm::Sin2,
        CyclicTerm::Cos2,
    ];
    /// Label stem.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            CyclicTerm::Sin1 => "sin1",
            CyclicTerm::Cos1 => "cos1",
            CyclicTerm::Sin2 => "sin2",
            CyclicTerm::Cos2 => "cos2",
        }
    }
}

/// What a parameter index means. Link and joint numbers are zero-based here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParamId {
    /// A link parameter.
    Link {
        /// Zero-based link.
        link: usize,
        /// Which of the five.
        kind: LinkParam,
    },
    /// A base-frame parameter.
    Base(FrameParam),
    /// A tool-frame parameter.
    Tool(FrameParam),
    /// Joint compliance of a joint.
    Compliance(usize),
    /// Joint scale of a joint.
    Scale(usize),
    /// A cyclic-error term of a joint.
    Cyclic(usize, CyclicTerm),
    /// Backlash of a joint.
    Backlash(usize),
    /// Thermal expansion coefficient.
    Thermal,
}

/// Number of parameters (geometric and effects) of an `n`-joint model.
#[must_use]
pub const fn num_params(n: usize) -> usize {
    12 * n + 13
}

/// Number of geometric parameters (links, base, tool) of an `n`-joint model.
#[must_use]
pub const fn num_geometric_params(n: usize) -> usize {
    5 * n + 12
}

impl ParamId {
    /// Whether this is a link's θ0, α or β: an angle the kinematics see only through its
    /// sine and cosine, so values whole turns apart are the same model.
    #[must_use]
    pub fn is_link_angle(self) -> bool {
        matches!(
            self,
            ParamId::Link {
                kind: LinkParam::Theta0 | LinkParam::Alpha | LinkParam::Beta,
                ..
            }
        )
    }
    /// `d` less the nearest whole number of turns (2π): in [−π, π] \[rad\].
    #[must_use]
    pub fn less_whole_turns(d: f64) -> f64 {
        d - libm::round(d / core::f64::consts::TAU) * core::f64::consts::TAU
    }
    /// Flat index of this parameter in an `n`-joint model.
    // Inlined: the Jacobian computes ~65 column indices per pose, a call each otherwise.
    #[must_use]
    #[inline]
    pub const fn index(self, n: usize) -> ParamIndex {
        ParamIndex(match self {
            ParamId::Link { link, kind } => 5 * link + kind as usize,
            ParamId::Base(k) => 5 * n + k as usize,
            ParamId::Tool(k) => 5 * n + 6 + k as usize,
            ParamId::Compliance(j) => 5 * n + 12 + j,
            ParamId::Scale(j) => 6 * n + 12 + j,
            ParamId::Cyclic(j, t) => 7 * n + 12 + 4 * j + t as usize,
            ParamId::Backlash(j) => 11 * n + 12 + j,
            ParamId::Thermal => 12 * n + 12,
        })
    }

    /// The parameter at flat index `i` of an `n`-joint model.
    pub fn from_index(i: ParamIndex, n: usize) -> Result<ParamId> {
        let out_of_range = Error::DimensionMismatch {
            expected: num_params(n),
            found: i.0.saturating_add(1),
        };
        // Walks the layout block by block, subtracting each block's size: no product that
        // could overflow and no array index the compiler must prove in bounds (a panic path
        // on the firmware target otherwise).
        let mut r = i.0;
        let links = n.saturating_mul(5);
        if r < links {
            let kind = LinkParam::ALL.get(r % 5).copied().ok_or(out_of_range)?;
            return Ok(ParamId::Link { link: r / 5, kind });
        }
        r -= links;
        if r < 6 {
            return FrameParam::ALL
                .get(r)
                .map(|&k| ParamId::Base(k))
                .ok_or(out_of_range);
        }
        r -= 6;
        if r < 6 {
            return FrameParam::ALL
                .get(r)
                .map(|&k| ParamId::Tool(k))
                .ok_or(out_of_range);
        }
        r -= 6;
        if r < n {
            return Ok(ParamId::Compliance(r));
        }
        r -= n;
        if r < n {
            return Ok(ParamId::Scale(r));
        }
        r -= n;
        let cyclic = n.saturating_mul(4);
        if r < cyclic {
            let term = CyclicTerm::ALL.get(r % 4).copied().ok_or(out_of_range)?;
            return Ok(ParamId::Cyclic(r / 4, term));
        }
        r -= cyclic;
        if r < n {
            return Ok(ParamId::Backlash(r));
        }
        r -= n;
        if r == 0 {
            return Ok(ParamId::Thermal);
        }
        Err(out_of_range)
    }

    /// Parses a label such as `theta0_3`, `beta_2`, `base_px`, `compliance_2`,
    /// `cyclic_sin1_4`, `thermal_kappa` for an `n`-joint model.
    pub fn parse(label: &str, n: usize) -> Option<ParamId> {
        if label == "thermal_kappa" {
            return Some(ParamId::Thermal);
        }
        if let Some(rest) = label.strip_prefix("base_") {
            return FrameParam::ALL
                .iter()
                .find(|k| k.name() == rest)
                .map(|&k| ParamId::Base(k));
        }
        if let Some(rest) = label.strip_prefix("tool_") {
            return FrameParam::ALL
                .iter()
                .find(|k| k.name() == rest)
                .map(|&k| ParamId::Tool(k));
        }
        // Not `rsplit_once`: its memrchr keeps slice-index panic paths in the no_std build.
        let split = label.bytes().rposition(|b| b == b'_')?;
        let (stem, num) = (label.get(..split)?, label.get(split + 1..)?);
        let j: usize = num.parse().ok()?;
        if j == 0 || j > n || num.starts_with('0') {
            return None;
        }
        let j = j - 1;
        if let Some(kind) = LinkParam::ALL.iter().find(|k| k.name() == stem) {
            return Some(ParamId::Link {
                link: j,
                kind: *kind,
            });
        }
        match stem {
            "compliance" => Some(ParamId::Compliance(j)),
            "scale" => Some(ParamId::Scale(j)),
            "backlash" => Some(ParamId::Backlash(j)),
            _ => {
                let t = stem.strip_prefix("cyclic_")?;
                CyclicTerm::ALL
                    .iter()
                    .find(|c| c.name() == t)
                    .map(|&c| ParamId::Cyclic(j, c))
            }
        }
    }

    /// Whether the parameter is in metres (lengths) — angles are radians, compliance is
    /// rad/(N·m), scale is dimensionless, thermal is 1/K.
    #[must_use]
    pub const fn is_length(self) -> bool {
        match self {
            ParamId::Link { kind, .. } => kind.is_length(),
            ParamId::Base(k) | ParamId::Tool(k) => (k as usize) < 3,
            _ => false,
        }
    }

    /// The effect this parameter belongs to, or `None` for a link parameter.
    #[must_use]
    pub const fn effect(self) -> Option<crate::effects::Effect> {
        use crate::effects::Effect;
        match self {
            ParamId::Link { .. } => None,
            ParamId::Base(_) => Some(Effect::BaseFrame),
            ParamId::Tool(_) => Some(Effect::ToolFrame),
            ParamId::Compliance(_) => Some(Effect::JointCompliance),
            ParamId::Scale(_) => Some(Effect::JointScale),
            ParamId::Cyclic(..) => Some(Effect::JointCyclic),
            ParamId::Backlash(_) => Some(Effect::Backlash),
            ParamId::Thermal => Some(Effect::Thermal),
        }
    }
}

impl fmt::Display for ParamId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ParamId::Link { link, kind } => write!(f, "{}_{}", kind.name(), link + 1),
            ParamId::Base(k) => write!(f, "base_{}", k.name()),
            ParamId::Tool(k) => write!(f, "tool_{}", k.name()),
            ParamId::Compliance(j) => write!(f, "compliance_{}", j + 1),
            ParamId::Scale(j) => write!(f, "scale_{}", j + 1),
            ParamId::Cyclic(j, t) => write!(f, "cyclic_{}_{}", t.name(), j + 1),
            ParamId::Backlash(j) => write!(f, "backlash_{}", j + 1),
            ParamId::Thermal => write!(f, "thermal_kappa"),
        }
    }
}

/// Capacity of a [`ParamSet`]: enough for every parameter of a 20-joint model.
pub const PARAM_SET_CAPACITY: usize = 256;

/// A set of parameter indices (which parameters are identified, fixed, or unidentifiable).
/// Iterates in increasing index order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct ParamSet {
    bits: [u64; PARAM_SET_CAPACITY / 64],
}

impl ParamSet {
    /// The empty set.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            bits: [0; PARAM_SET_CAPACITY / 64],
        }
    }
    /// Adds index `i`; fails beyond the capacity.
    pub fn insert(&mut self, i: usize) -> Result<()> {
        match self.bits.get_mut(i / 64) {
            Some(w) => {
                *w |= 1u64 << (i % 64);
                Ok(())
            }
            None => Err(Error::CapacityExceeded {
                needed: i + 1,
                capacity: PARAM_SET_CAPACITY,
            }),
        }
    }
    /// Removes index `i` (no-op when absent).
    pub fn remove(&mut self, i: usize) {
        if let Some(w) = self.bits.get_mut(i / 64) {
            *w &= !(1u64 << (i % 64));
        }
    }
    /// Whether index `i` is in the set.
    #[must_use]
    pub fn contains(&self, i: usize) -> bool {
        self.bits
            .get(i / 64)
            .is_some_and(|w| w & (1u64 << (i % 64)) != 0)
    }
    /// Number of members.
    #[must_use]
    pub fn len(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }
    /// Whether the set is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.bits.iter().all(|&w| w == 0)
    }
    /// The membership bits (bit `i % 64` of word `i / 64`): an exact key of the set.
    pub(crate) const fn words(&self) -> &[u64; PARAM_SET_CAPACITY / 64] {
        &self.bits
    }
    /// Members in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..PARAM_SET_CAPACITY).filter(move |&i| self.contains(i))
    }
    /// Union.
    #[must_use]
    pub fn union(&self, other: &ParamSet) -> ParamSet {
        let mut out = *self;
        for (a, b) in out.bits.iter_mut().zip(other.bits.iter()) {
            *a |= *b;
        }
        out
    }
    /// The members of `self` not in `other`.
    ///
    /// ```
    /// use kincal::ParamSet;
    /// let mut a = ParamSet::new();
    /// let mut b = ParamSet::new();
    /// for i in [1, 70, 100] {
    ///     a.insert(i).unwrap();
    /// }
    /// b.insert(70).unwrap();
    /// b.insert(3).unwrap();
    /// assert_eq!(a.difference(&b).iter().collect::<Vec<_>>(), [1, 100]);
    /// ```
    #[must_use]
    pub fn difference(&self, other: &ParamSet) -> ParamSet {
        let mut out = *self;
        for (a, b) in out.bits.iter_mut().zip(other.bits.iter()) {
            *a &= !*b;
        }
        out
    }
}
