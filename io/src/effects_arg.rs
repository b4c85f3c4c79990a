//! `--effects E1,E2,…` with a per-joint selector (spec/effects.md names): an item is an
//! effect name, or `joint_scale@JOINT` to give the scale (gain) parameter to that joint only.
//! `JOINT` is a joint name of the robot (its description's or URDF's), `qK` (the data's
//! column, 1-based), or `sensor` (every sensor joint: the gains of inclinometer or
//! accelerometer readings). Several `joint_scale@…` items add up; plain `joint_scale` is
//! every joint and cannot be combined with a selector. Parsed here once for every command
//! that identifies effects (calibrate, crossval) and the studies that fit joint gains.

use kincal::params::ParamId;
use kincal::{Effect, EffectSet, JointKind, ParamSet, Robot};

use crate::error::Error as CliError;

/// Effects that take a joint selector (`EFFECT@JOINT`).
pub const PER_JOINT: [Effect; 1] = [Effect::JointScale];

/// The selector naming every sensor joint.
pub const SENSOR: &str = "sensor";

/// One item of `--effects`, checked for syntax only (the joint is resolved against the
/// robot by [`resolve`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EffectItem {
    pub effect: Effect,
    /// `@JOINT`, if given.
    pub joint: Option<String>,
}

/// Parses one item: `NAME` or `joint_scale@JOINT` (a clap value parser: the message is
/// shown with exit 2).
pub fn parse_effect_item(s: &str) -> Result<EffectItem, String> {
    let s = s.trim();
    let (name, joint) = match s.split_once('@') {
        Some((n, j)) => (n.trim(), Some(j.trim())),
        None => (s, None),
    };
    let effect = Effect::parse(name).ok_or_else(|| {
        format!(
            "unknown effect '{name}': expected one of {} (joint_scale@JOINT for one joint)",
            Effect::ALL.map(|e| e.name()).join(", ")
        )
    })?;
    if let Some(j) = joint {
        if !PER_JOINT.contains(&effect) {
            return Err(format!(
                "'{s}': only joint_scale takes @JOINT (a joint name, qK or sensor)"
            ));
        }
        if j.is_empty() {
            return Err(format!(
                "'{s}': expected a joint after @ (a joint name, qK or sensor)"
            ));
        }
    }
    Ok(EffectItem {
        effect,
        joint: joint.map(str::to_string),
    })
}

/// The effects of a `--effects` list resolved against one robot.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EffectChoice {
    pub effects: EffectSet,
    /// The joints (0-based, ascending) whose scale is identified; `None`: every joint.
    pub scale_joints: Option<Vec<usize>>,
}

impl EffectChoice {
    /// Every joint for each effect (no selector).
    pub fn all(effects: EffectSet) -> Self {
        EffectChoice {
            effects,
            scale_joints: None,
        }
    }

    /// Removes from `set` the scale parameters of the joints not selected.
    pub fn restrict(&self, set: &mut ParamSet, n: usize) {
        if let Some(js) = &self.scale_joints {
            for j in (0..n).filter(|j| !js.contains(j)) {
                set.remove(ParamId::Scale(j).index(n).0);
            }
        }
    }

    /// The geometric parameters plus the chosen effects' parameters that apply to `robot`
    /// (`Robot::param_set`, the scale limited to the selected joints).
    pub fn param_set<const N: usize>(&self, robot: &Robot<N>) -> ParamSet {
        let mut set = robot.param_set(self.effects);
        self.restrict(&mut set, N);
        set
    }

    /// The effects' parameters alone for an `n`-joint model (`EffectSet::params`,
    /// restricted).
    pub fn effect_params(&self, n: usize) -> ParamSet {
        let mut set = self.effects.params(n);
        self.restrict(&mut set, n);
        set
    }

    /// `joint_scale@a+b` style label of the selection for reports (`None` without one).
    pub fn scale_label(&self, joint_names: &[String]) -> Option<String> {
        self.scale_joints.as_ref().map(|js| {
            let names: Vec<&str> = js
                .iter()
                .map(|&j| joint_names.get(j).map_or("?", String::as_str))
                .collect();
            format!("joint_scale@{}", names.join(",joint_scale@"))
        })
    }
}

/// Resolves `items` against a robot's joint names and kinds (one each, in model order). A
/// joint that the robot does not have is a usage error naming it and the robot's joints.
pub fn resolve(
    items: &[EffectItem],
    joint_names: &[String],
    kinds: &[JointKind],
) -> Result<EffectChoice, CliError> {
    let effects = items.iter().fold(EffectSet::NONE, |s, i| s.with(i.effect));
    let plain = items
        .iter()
        .any(|i| i.effect == Effect::JointScale && i.joint.is_none());
    let selectors: Vec<&str> = items.iter().filter_map(|i| i.joint.as_deref()).collect();
    if selectors.is_empty() {
        return Ok(EffectChoice::all(effects));
    }
    if plain {
        return Err(CliError::usage(
            "--effects: joint_scale (every joint) and joint_scale@JOINT together: give one",
        ));
    }
    let mut joints = Vec::new();
    for sel in selectors {
        let found: Vec<usize> = if sel == SENSOR {
            let s: Vec<usize> = (0..kinds.len())
                .filter(|&j| kinds[j] == JointKind::Sensor)
                .collect();
            if s.is_empty() {
                return Err(CliError::usage(
                    "--effects joint_scale@sensor: the robot has no sensor joint",
                ));
            }
            s
        } else if let Some(j) = joint_names.iter().position(|n| n == sel) {
            vec![j]
        } else if let Some(k) = sel
            .strip_prefix('q')
            .and_then(|k| k.parse::<usize>().ok())
            .filter(|&k| (1..=kinds.len()).contains(&k))
        {
            vec![k - 1]
        } else {
            return Err(CliError::usage(format!(
                "--effects joint_scale@{sel}: the robot has no joint '{sel}' (its joints: {}; \
                 or q1..q{}, or sensor)",
                joint_names.join(", "),
                kinds.len()
            )));
        };
        joints.extend(found);
    }
    joints.sort_unstable();
    joints.dedup();
    Ok(EffectChoice {
        effects,
        scale_joints: Some(joints),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn items(s: &str) -> Result<Vec<EffectItem>, String> {
        s.split(',').map(parse_effect_item).collect()
    }

    fn names() -> Vec<String> {
        ["lift", "tilt_x", "tilt_y", "j4"]
            .map(String::from)
            .to_vec()
    }

    const KINDS: [JointKind; 4] = [
        JointKind::Prismatic,
        JointKind::Sensor,
        JointKind::Sensor,
        JointKind::Revolute,
    ];

    #[test]
    fn selectors_resolve_by_name_column_and_kind() {
        let r = |s: &str| resolve(&items(s).unwrap(), &names(), &KINDS);
        assert_eq!(
            r("joint_scale@sensor").unwrap().scale_joints,
            Some(vec![1, 2])
        );
        assert_eq!(
            r("base_frame,joint_scale@j4,joint_scale@q1")
                .unwrap()
                .scale_joints,
            Some(vec![0, 3])
        );
        let c = r("joint_scale@tilt_y,joint_scale@sensor").unwrap();
        assert_eq!(c.scale_joints, Some(vec![1, 2]));
        assert!(c.effects.contains(Effect::JointScale));
        assert_eq!(r("joint_scale,tool_frame").unwrap().scale_joints, None);
        // The parameters: scale of the selected joints only.
        let set = c.effect_params(4);
        let scales: Vec<usize> = (0..4)
            .filter(|&j| set.contains(ParamId::Scale(j).index(4).0))
            .collect();
        assert_eq!(scales, [1, 2]);
    }

    #[test]
    fn bad_selectors_are_usage_errors_naming_them() {
        let r = |s: &str| resolve(&items(s).unwrap(), &names(), &KINDS).unwrap_err();
        let e = r("joint_scale@elbow");
        assert_eq!(e.kind, crate::error::Kind::Usage);
        assert!(e.message.contains("no joint 'elbow'") && e.message.contains("tilt_x"));
        assert!(r("joint_scale@q5").message.contains("'q5'"));
        assert!(r("joint_scale,joint_scale@j4").message.contains("together"));
        let none = resolve(
            &items("joint_scale@sensor").unwrap(),
            &names(),
            &[JointKind::Revolute; 4],
        )
        .unwrap_err();
        assert!(none.message.contains("no sensor joint"));
        assert!(
            parse_effect_item("backlash@j4")
                .unwrap_err()
                .contains("only joint_scale")
        );
        assert!(parse_effect_item("joint_scale@").is_err());
        assert!(
            parse_effect_item("joint_scael")
                .unwrap_err()
                .contains("unknown effect")
        );
    }
}
