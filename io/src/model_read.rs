//! The one model-file reader of every front end: the CLI's MODEL argument, the C ABI's
//! `kincal_model_read` and Octave's `kincal_load_model` all read a model file here, so a file
//! one refuses every one refuses, with the same message and position.

use std::path::Path;

use kincal::any::AnyRobot;
use kincal::{EffectSet, Robot};

use crate::error::Error;
use crate::model_file::{self, ModelFile};

/// Largest model file read [bytes]: a calibrated 9-joint model with every effect and its
/// report takes well under 1 MB; anything far larger is not a model file.
pub const MAX_MODEL_FILE_BYTES: u64 = 64 << 20;

/// A model file as read and checked: the file, the model it defines and its effects.
#[derive(Debug, Clone)]
pub struct Model {
    pub file: ModelFile,
    pub robot: AnyRobot,
    pub effects: EffectSet,
}

/// Checks parsed model-file text (no byte-order mark; JSON) and builds its model: the
/// schema, every parameter by label, the joint count and the effects, as the CLI does.
pub fn model_from_json(text: &str, source: &str) -> Result<Model, Error> {
    let file = model_file::parse(text, source)?;
    let robot = file
        .robot
        .any_robot()
        .map_err(|m| Error::input(format!("{source}: robot: {m}")))?;
    let effects = file
        .effects()
        .map_err(|m| Error::input(format!("{source}: robot: {m}")))?;
    Ok(Model {
        file,
        robot,
        effects,
    })
}

/// Reads model-file text named `source` in messages: refuses what is not a model file (empty,
/// a JSON array, a robot description) with a position, then [`model_from_json`].
pub fn read_model_str(text: &str, source: &str) -> Result<Model, Error> {
    crate::robot_arg::refuse_what_is_neither(text, source)?;
    let body = text.strip_prefix('\u{feff}').unwrap_or(text);
    if !model_file::looks_like_json(body) {
        return Err(Error::input(format!(
            "{source}:1:1: not a model file: expected a JSON object with \"schema_version\" (a robot description is not a model file)"
        )));
    }
    model_from_json(body, source)
}

/// Reads model-file bytes (UTF-8) named `source` in messages.
pub fn read_model_bytes(bytes: &[u8], source: &str) -> Result<Model, Error> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let (line, column) = line_column(bytes, e.valid_up_to());
        Error::input(format!("{source}:{line}:{column}: not UTF-8 text"))
    })?;
    read_model_str(text, source)
}

/// Reads the model file at `path`.
pub fn read_model_file(path: &Path) -> Result<Model, Error> {
    let source = path.display().to_string();
    let size = std::fs::metadata(path)
        .map_err(|e| Error::input(format!("{source}: cannot read: {e}")))?
        .len();
    if size > MAX_MODEL_FILE_BYTES {
        return Err(Error::input(format!(
            "{source}: {size} bytes: larger than any model file ({MAX_MODEL_FILE_BYTES} bytes at most)"
        )));
    }
    let bytes =
        std::fs::read(path).map_err(|e| Error::input(format!("{source}: cannot read: {e}")))?;
    read_model_bytes(&bytes, &source)
}

/// The names [`variant`] accepts besides the calibrated runs: the stored model and `NOM`.
pub const STORED: &str = "";

/// One model of the file: `""` ([`STORED`]) the model it stores; `NOM` every parameter at
/// its nominal value (the model the calibration started from); `OLS`, `OPT1`, `OPT2` the
/// stored model with that algorithm's identified parameters (as `kincal validate` compares
/// them; case-insensitive). A name the file does not hold is a usage error listing those it
/// holds.
pub fn variant(model: &Model, name: &str, source: &str) -> Result<AnyRobot, Error> {
    if name == STORED {
        return Ok(model.robot.clone());
    }
    kincal::with_any_robot!(&model.robot, r => pick_variant(r, &model.file, name, source).map(AnyRobot::from))
}

fn pick_variant<const N: usize>(
    _shape: &Robot<N>,
    file: &ModelFile,
    name: &str,
    source: &str,
) -> Result<Robot<N>, Error> {
    let variants = file
        .variants::<N>()
        .map_err(|m| Error::input(format!("{source}: {m}")))?;
    let names: Vec<&str> = variants.iter().map(|(n, _)| n.as_str()).collect();
    let list = names.join(", ");
    variants
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, r)| *r)
        .ok_or_else(|| {
            Error::usage(format!(
                "{source}: no model \"{name}\" in this file (it holds the stored model and {list})"
            ))
        })
}

/// 1-based line and column (in bytes) of byte `offset`.
fn line_column(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = bytes.get(..offset).unwrap_or(bytes);
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let column = 1 + before.iter().rev().take_while(|&&b| b != b'\n').count();
    (line, column)
}

/// Where in `source` a message of this crate places the error: `source:LINE:COLUMN: …` or
/// `source:LINE: …` give the line (and column); `None` when the message names no line.
pub fn position(message: &str, source: &str) -> (Option<u64>, Option<u64>) {
    let Some(rest) = message
        .strip_prefix(source)
        .and_then(|r| r.strip_prefix(':'))
    else {
        return (None, None);
    };
    let mut parts = rest.splitn(3, ':');
    let number = |p: Option<&str>| p.and_then(|s| s.parse::<u64>().ok());
    match number(parts.next()) {
        Some(line) => (Some(line), number(parts.next())),
        None => (None, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn aria_model_text() -> String {
        let file = ModelFile::nominal("aria", &kincal::aria::nominal());
        serde_json::to_string_pretty(&file).unwrap()
    }

    #[test]
    fn a_nominal_model_reads_back_with_its_parameters() {
        let m = read_model_str(&aria_model_text(), "m.json").unwrap();
        let aria = kincal::any::AnyRobot::from(kincal::aria::nominal());
        assert_eq!(m.robot, aria);
        assert_eq!(m.effects, EffectSet::NONE);
    }

    #[test]
    fn refusals_carry_the_position_of_the_fault() {
        let e = read_model_str("{\n  \"schema_version\": 1,,\n}", "m.json").unwrap_err();
        assert_eq!(position(&e.message, "m.json"), (Some(2), Some(23)), "{e}");
        let e = read_model_str("", "m.json").unwrap_err();
        assert_eq!(position(&e.message, "m.json"), (Some(1), Some(1)), "{e}");
        let e = read_model_str("[1, 2]", "m.json").unwrap_err();
        assert!(e.message.contains("JSON array"), "{e}");
        let e = read_model_str("name = \"x\"\n", "m.json").unwrap_err();
        assert!(e.message.contains("not a model file"), "{e}");
        let e = read_model_bytes(b"{\n \xff}", "m.json").unwrap_err();
        assert_eq!(position(&e.message, "m.json"), (Some(2), Some(2)), "{e}");
        assert_eq!(position("m.json: no line here", "m.json"), (None, None));
        assert_eq!(position("m.json:7: line only", "m.json"), (Some(7), None));
    }

    #[test]
    fn a_missing_parameter_is_refused_like_the_cli_refuses_it() {
        let text = aria_model_text();
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let params = v["robot"]["parameters"].as_array_mut().unwrap();
        let before = params.len();
        params.retain(|p| p["label"] != "theta0_4");
        assert_eq!(params.len(), before - 1);
        let e = read_model_str(&v.to_string(), "m.json").unwrap_err();
        assert_eq!(e.kind, crate::Kind::Input);
        assert!(e.message.contains("theta0_4"), "{e}");
    }

    #[test]
    fn variants_of_an_uncalibrated_file_are_the_stored_model_and_nom() {
        let m = read_model_str(&aria_model_text(), "m.json").unwrap();
        assert_eq!(variant(&m, STORED, "m.json").unwrap(), m.robot);
        assert_eq!(variant(&m, "nom", "m.json").unwrap(), m.robot);
        let e = variant(&m, "OLS", "m.json").unwrap_err();
        assert_eq!(e.kind, crate::Kind::Usage);
        assert!(e.message.contains("NOM"), "{e}");
    }
}
