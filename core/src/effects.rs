//! Non-geometric effects (spec/effects.md): their public names and which parameters each
//! one adds to the model. The effect parameters live in [`crate::Robot`]; how they change the
//! joint angles is in [`crate::Robot::joint_angles`], their Jacobian columns in
//! [`crate::Robot::jacobian`].

use core::fmt;

use crate::params::{CyclicTerm, FrameParam, ParamId, ParamSet};

/// A candidate cause of the sim-to-real gap. The names are part of the public interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Measured poses are expressed in a base frame off by a small rigid transform.
    BaseFrame = 0,
    /// The probe/tool frame is off.
    ToolFrame = 1,
    /// Joints deflect under gravity: Δθ_j = c_j·τ_j(q).
    JointCompliance = 2,
    /// Gear-ratio / encoder scale error: Δθ_j = k_j·q_j.
    JointScale = 3,
    /// Periodic transmission error, first and second harmonic.
    JointCyclic = 4,
    /// Lost motion depending on approach direction: Δθ_j = b_j·s_j.
    Backlash = 5,
    /// Link lengths grow with temperature: d_i, a_i times (1 + κ·(T − 20 °C)).
    Thermal = 6,
}

impl Effect {
    /// All effects, in a fixed order.
    pub const ALL: [Effect; 7] = [
        Effect::BaseFrame,
        Effect::ToolFrame,
        Effect::JointCompliance,
        Effect::JointScale,
        Effect::JointCyclic,
        Effect::Backlash,
        Effect::Thermal,
    ];

    /// The public name (`base_frame`, `joint_compliance`, …).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Effect::BaseFrame => "base_frame",
            Effect::ToolFrame => "tool_frame",
            Effect::JointCompliance => "joint_compliance",
            Effect::JointScale => "joint_scale",
            Effect::JointCyclic => "joint_cyclic",
            Effect::Backlash => "backlash",
            Effect::Thermal => "thermal",
        }
    }

    /// Parses a public name.
    #[must_use]
    pub fn parse(name: &str) -> Option<Effect> {
        Effect::ALL.iter().copied().find(|e| e.name() == name)
    }

    /// Every parameter of this effect in an `n`-joint model.
    #[must_use]
    pub fn params(self, n: usize) -> ParamSet {
        let mut set = ParamSet::new();
        let mut add = |id: ParamId| {
            // Indices of a model with n <= 20 joints always fit the set's capacity.
            let _ = set.insert(id.index(n).0);
        };
        match self {
            Effect::BaseFrame => FrameParam::ALL.iter().for_each(|&k| add(ParamId::Base(k))),
            Effect::ToolFrame => FrameParam::ALL.iter().for_each(|&k| add(ParamId::Tool(k))),
            Effect::JointCompliance => (0..n).for_each(|j| add(ParamId::Compliance(j))),
            Effect::JointScale => (0..n).for_each(|j| add(ParamId::Scale(j))),
            Effect::JointCyclic => (0..n).for_each(|j| {
                CyclicTerm::ALL
                    .iter()
                    .for_each(|&t| add(ParamId::Cyclic(j, t)))
            }),
            Effect::Backlash => (0..n).for_each(|j| add(ParamId::Backlash(j))),
            Effect::Thermal => add(ParamId::Thermal),
        }
        set
    }

    /// Whether the effect needs the approach directions `s1..sN`.
    #[must_use]
    pub const fn needs_approach(self) -> bool {
        matches!(self, Effect::Backlash)
    }
    /// Whether the effect needs the temperature `temp_c`.
    #[must_use]
    pub const fn needs_temperature(self) -> bool {
        matches!(self, Effect::Thermal)
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of effects (bit mask), iterated in [`Effect::ALL`] order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, PartialOrd, Ord)]
pub struct EffectSet(u8);

impl EffectSet {
    /// No effect: the geometric model.
    pub const NONE: EffectSet = EffectSet(0);
    /// A set of one effect.
    #[must_use]
    pub const fn of(e: Effect) -> Self {
        EffectSet(1 << e as u8)
    }
    /// This set with `e` added.
    #[must_use]
    pub const fn with(self, e: Effect) -> Self {
        EffectSet(self.0 | (1 << e as u8))
    }
    /// Whether `e` is in the set.
    #[must_use]
    pub const fn contains(self, e: Effect) -> bool {
        self.0 & (1 << e as u8) != 0
    }
    /// Number of effects in the set.
    #[must_use]
    pub const fn len(self) -> usize {
        self.0.count_ones() as usize
    }
    /// Whether the set is empty.
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
    /// Members in [`Effect::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Effect> {
        Effect::ALL.into_iter().filter(move |&e| self.contains(e))
    }
    /// Raw bits (bit k = `Effect::ALL[k]`), for the C ABI.
    #[must_use]
    pub const fn bits(self) -> u8 {
        self.0
    }
    /// From raw bits; `None` if an unknown bit is set.
    #[must_use]
    pub const fn from_bits(bits: u8) -> Option<Self> {
        if bits & !0x7f != 0 {
            None
        } else {
            Some(EffectSet(bits))
        }
    }
    /// Every parameter of every effect in the set for an `n`-joint model.
    #[must_use]
    pub fn params(self, n: usize) -> ParamSet {
        self.iter()
            .fold(ParamSet::new(), |acc, e| acc.union(&e.params(n)))
    }
}
