//! ROBOT and MODEL arguments (spec/cli.md): ROBOT is a built-in name or a robot
//! description file; MODEL is a model file or a ROBOT (its nominal model).

use std::path::Path;

use kincal::any::AnyRobot;
use kincal::aria;

use crate::error::Error as CliError;
use crate::model_file::{self, ModelFile};

/// Built-in robots: name and description.
pub const BUILT_IN: &[(&str, &str)] = &[(
    "aria",
    "the ARIA arm of Arent et al. 2024: Table 1 geometry, eq. (2) limits, assumed mass model",
)];

/// `--base-link` / `--tip-link`: which chain of a URDF robot to use (any tree; the
/// default is the unique chain from the single root to the single leaf).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct UrdfChainArgs {
    /// URDF robot only: the link that becomes the base frame [default: the single root link]
    #[cfg_attr(feature = "clap", arg(long, value_name = "LINK"))]
    pub base_link: Option<String>,
    /// URDF robot only: the link that becomes the tool frame [default: the single leaf
    /// below the base link]
    #[cfg_attr(feature = "clap", arg(long, value_name = "LINK"))]
    pub tip_link: Option<String>,
}

impl UrdfChainArgs {
    /// The chain selection of these flags.
    pub fn selection(&self) -> crate::urdf::ChainSelection<'_> {
        crate::urdf::ChainSelection {
            base_link: self.base_link.as_deref(),
            tip_link: self.tip_link.as_deref(),
        }
    }

    fn is_set(&self) -> bool {
        self.base_link.is_some() || self.tip_link.is_some()
    }
}

/// A resolved ROBOT.
#[derive(Debug, Clone)]
pub struct RobotSpec {
    /// Name recorded in model files.
    pub name: String,
    /// Joint names in model order (`joint1`, … where the source names none).
    pub joint_names: Vec<String>,
    pub robot: AnyRobot,
}

/// Resolves a ROBOT argument: a built-in name, else a robot description file. This is the
/// one place robot sources are told apart. `chain` picks the chain of a URDF; it is a usage
/// error for any other robot.
pub fn resolve_robot(arg: &str, chain: &UrdfChainArgs) -> Result<RobotSpec, CliError> {
    let path = Path::new(arg);
    let is_urdf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    if chain.is_set() && !is_urdf {
        return Err(CliError::usage(format!(
            "--base-link/--tip-link choose a chain of a URDF robot; '{arg}' is not a .urdf file"
        )));
    }
    if let Some(spec) = built_in(arg) {
        return Ok(spec);
    }
    if path.is_file() {
        return load_robot_file(path, chain);
    }
    let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
    Err(CliError::usage(format!(
        "unknown robot '{arg}': expected a built-in robot ({}) or an existing robot description file",
        names.join(", ")
    )))
}

fn built_in(name: &str) -> Option<RobotSpec> {
    match name {
        "aria" => Some(RobotSpec {
            name: "aria".to_string(),
            joint_names: (1..=6).map(|k| format!("joint{k}")).collect(),
            robot: AnyRobot::from(aria::nominal()),
        }),
        _ => None,
    }
}

/// Loads a robot description file: URDF (`.urdf`, the chain `chain` selects) or the TOML
/// description of docs/robot-description.md (anything else).
fn load_robot_file(path: &Path, chain: &UrdfChainArgs) -> Result<RobotSpec, CliError> {
    let is_urdf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    if is_urdf {
        let imported = crate::urdf::import_urdf_file(path, &chain.selection())
            .map_err(|e| CliError::input(e.to_string()))?;
        for note in &imported.notes {
            eprintln!("kincal: note: {}: {note}", path.display());
        }
        return Ok(RobotSpec {
            name: imported.robot_name,
            joint_names: imported.joint_names,
            robot: imported.robot,
        });
    }
    let desc =
        crate::robot_file::load_robot_file(path).map_err(|e| CliError::input(e.to_string()))?;
    Ok(RobotSpec {
        name: desc.name,
        joint_names: desc.joint_names,
        robot: desc.robot,
    })
}

/// A resolved MODEL.
#[derive(Debug, Clone)]
pub struct ModelSpec {
    /// The model itself.
    pub robot: AnyRobot,
    /// The model file (a nominal one for a ROBOT argument).
    pub file: ModelFile,
    /// Whether MODEL was a model file (rather than a ROBOT).
    pub from_file: bool,
}

/// Refuses MODEL text that is neither a model file nor a robot description, rather than
/// reporting TOML errors for it: an empty file, or JSON that is not an object.
pub(crate) fn refuse_what_is_neither(text: &str, arg: &str) -> Result<(), CliError> {
    let body = text.trim_start_matches('\u{feff}');
    if body.trim().is_empty() {
        return Err(CliError::input(format!(
            "{arg}:1:1: empty file: expected a model file (a JSON object) or a robot description (TOML or .urdf)"
        )));
    }
    if !model_file::looks_like_json(body)
        && let Ok(v) = serde_json::from_str::<serde_json::Value>(body)
    {
        let kind = match v {
            serde_json::Value::Array(_) => "a JSON array",
            serde_json::Value::String(_) => "a JSON string",
            serde_json::Value::Number(_) => "a JSON number",
            _ => "a JSON literal",
        };
        return Err(CliError::input(format!(
            "{arg}:1:1: the file is {kind}: expected a model file (a JSON object with \"schema_version\") or a robot description"
        )));
    }
    Ok(())
}

/// Resolves a MODEL argument: a model file (JSON with `schema_version`), else a ROBOT
/// (`chain` as in [`resolve_robot`]).
pub fn resolve_model(arg: &str, chain: &UrdfChainArgs) -> Result<ModelSpec, CliError> {
    let path = Path::new(arg);
    if built_in(arg).is_none() && path.is_file() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::input(format!("{arg}: cannot read: {e}")))?;
        refuse_what_is_neither(&text, arg)?;
        // A UTF-8 byte-order mark is not part of the JSON.
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        if model_file::looks_like_json(text) {
            let crate::model_read::Model { file, robot, .. } =
                crate::model_read::model_from_json(text, arg)?;
            return Ok(ModelSpec {
                robot,
                file,
                from_file: true,
            });
        }
    }
    let spec = resolve_robot(arg, chain)?;
    let file = kincal::with_any_robot!(&spec.robot, r => ModelFile::nominal(&spec.name, r));
    Ok(ModelSpec {
        robot: spec.robot,
        file,
        from_file: false,
    })
}
