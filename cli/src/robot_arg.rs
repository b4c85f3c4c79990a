//! ROBOT and MODEL arguments (spec/cli.md): ROBOT is a built-in name or a robot
//! description file; MODEL is a model file or a ROBOT (its nominal model).

use std::path::Path;

use kincal::any::AnyRobot;
use kincal::aria;

use crate::error::CliError;
use crate::model_file::{self, ModelFile};

/// Built-in robots: name and description.
pub const BUILT_IN: &[(&str, &str)] = &[(
    "aria",
    "the ARIA arm of Arent et al. 2024: Table 1 geometry, eq. (2) limits, assumed mass model",
)];

/// A resolved ROBOT.
#[derive(Debug, Clone)]
pub struct RobotSpec {
    /// Name recorded in model files.
    pub name: String,
    pub robot: AnyRobot,
}

/// Resolves a ROBOT argument: a built-in name, else a robot description file. This is the
/// one place robot sources are told apart.
pub fn resolve_robot(arg: &str) -> Result<RobotSpec, CliError> {
    if let Some(spec) = built_in(arg) {
        return Ok(spec);
    }
    let path = Path::new(arg);
    if path.is_file() {
        return load_robot_file(path);
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
            robot: AnyRobot::from(aria::nominal()),
        }),
        _ => None,
    }
}

/// Loads a robot description file. Hook for the robot-description (TOML) and URDF loaders,
/// which land in their own modules; until then only built-in robots resolve.
fn load_robot_file(path: &Path) -> Result<RobotSpec, CliError> {
    Err(CliError::usage(format!(
        "{}: robot description files are not supported by this build yet; use a built-in robot ({})",
        path.display(),
        BUILT_IN
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", ")
    )))
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

/// Resolves a MODEL argument: a model file (JSON with `schema_version`), else a ROBOT.
pub fn resolve_model(arg: &str) -> Result<ModelSpec, CliError> {
    let path = Path::new(arg);
    if built_in(arg).is_none() && path.is_file() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::input(format!("{arg}: cannot read: {e}")))?;
        if model_file::looks_like_json(&text) {
            let file = model_file::parse(&text, arg)?;
            let robot = file
                .robot
                .any_robot()
                .map_err(|m| CliError::input(format!("{arg}: robot: {m}")))?;
            file.effects()
                .map_err(|m| CliError::input(format!("{arg}: robot: {m}")))?;
            return Ok(ModelSpec {
                robot,
                file,
                from_file: true,
            });
        }
    }
    let spec = resolve_robot(arg)?;
    let file = kincal::with_any_robot!(&spec.robot, r => ModelFile::nominal(&spec.name, r));
    Ok(ModelSpec {
        robot: spec.robot,
        file,
        from_file: false,
    })
}
