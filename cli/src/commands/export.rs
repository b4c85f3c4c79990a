//! `kincal export MODEL [--urdf OUT.urdf] [--mdh-table OUT.csv|OUT.yaml] [--c-header OUT.h]`:
//! the calibrated model in the forms ROS, a controller, firmware or the Matlab Robotics
//! Toolbox reads.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use kincal::{Effect, EffectSet, ParamId};

use crate::error::CliError;
use kincal_io::measurements::format_f64;
use kincal_io::model_file::{LengthChoice, ModelFile, ParamJson};
use kincal_io::robot_arg;
use kincal_io::urdf::{ChainSelection, UrdfExport, export_urdf};
use kincal_io::urdf_update::update_urdf;

pub const LONG_ABOUT: &str = "\
Writes MODEL (a model file written by `kincal calibrate`, or a ROBOT for its nominal model)
in other forms. Give at least one target.

--urdf OUT.urdf: a standalone URDF of the kinematic chain. Link i's frame is mDH frame i-1
turned by q_i, so joint i turns about its z axis and the joint origins carry the identified
geometry: joint 1's origin is the base frame, joint i+1's is A_i(0) = Rz(theta0_i)·Tz(d_i)·
Tx(a_i)·Rx(alpha_i)·Ry(beta_i), and a fixed joint `<tip>_fixed` to the tip link carries
A_N(0)·T_tool, so the tip link in the base link is the model's end-effector pose for the
same joint values q. Links are named --base-link (default base_link), link1..linkN and
--tip-link (default tool0); joints joint1..jointN. Joint limits and point masses are
written; effort and velocity limits are unknown to the model and written as 0. Effects
(joint compliance, scale, cyclic errors, backlash, thermal) have no URDF form: a model with
effects is refused unless --drop-effects is given (they are then left out, so the URDF is
the model's geometry alone).

--urdf OUT.urdf --from ROBOT.urdf [--base-link L --tip-link T]: your own URDF (the one the
model was calibrated from) with the calibrated geometry: each chain link keeps its offset
from the model's joint frame as in the nominal model, so meshes, inertials and branches
move with the identified axes; only the <origin> of the chain's revolute and prismatic
joints and of the last fixed joint before the tip link (the tool frame) change, everything
else is kept byte for byte. Refused (exit 3) when the chain's moving joints differ from the
model's in count or kind, or a URDF joint axis is not the nominal model's axis.

--mdh-table OUT.csv | OUT.yaml: the identified mDH/Hayati table. The CSV has one row per
frame: `base`, links 1..N, `tool`, then one row per effect parameter (its label). Columns
(SI units in their names; empty where a column does not apply): theta0_rad, d_m, a_m,
alpha_rad, beta_rad, length_param (d or beta: which of the two is identified), joint_type (revolute, prismatic or sensor)
(revolute: q adds to theta; prismatic: q adds to d), lower_rad, upper_rad (joint limits,
in metres for a prismatic joint), px_m, py_m, pz_m, rx_rad, ry_rad, rz_rad (base and tool frames:
Trans(p)·Rot(r), r a rotation vector), value, unit (effect parameters), then std_<column>
for every value column: the standard error of an identified parameter (empty when the
model file has none). The YAML holds the same numbers as lists and maps. Every number is
written in the shortest decimal form that reads back to the same double.

--c-header OUT.h: a C header defining the model (effects included) as
`static const kincal_robot IDENT = {…}` (C11 designated initializers over include/kincal.h;
IDENT from --c-name), for firmware without a file system: pass &IDENT to kincal_fk, or
to kincal_prepare once at start-up and the handle to kincal_prepared_fk/_ik in the loop.
There is no --c-blob (an image of a prepared handle): a kincal_prepared holds the core's
Robot<N> byte for byte, a layout that is not an ABI and changes between library builds, so
a compiled-in image would be refused (KINCAL_STATUS_BAD_HANDLE) or, worse, tied to one
build; kincal_prepare validates the header's plain C struct in microseconds instead.

Outputs are written atomically and never overwrite MODEL.";

pub const EXAMPLE: &str = "\
Examples:
  kincal export aria-model.json --urdf aria-calibrated.urdf
  kincal export aria-model.json --mdh-table aria-mdh.csv --urdf aria.urdf --drop-effects
  kincal export aria-model.json --c-header aria_model.h --c-name aria_model";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Model file, or ROBOT for the nominal model
    #[arg(value_name = "MODEL")]
    pub model: String,
    /// Write the chain as a standalone URDF
    #[arg(long, value_name = "OUT.urdf")]
    pub urdf: Option<PathBuf>,
    /// Your own URDF (the one the model was calibrated from): its chain joints' origins are
    /// updated, everything else kept
    #[arg(long, value_name = "ROBOT.urdf", requires = "urdf")]
    pub from: Option<PathBuf>,
    /// Base link: of the written URDF (default base_link), or of the --from chain (default:
    /// its root)
    #[arg(long, value_name = "L")]
    pub base_link: Option<String>,
    /// Tip (tool) link: of the written URDF (default tool0), or of the --from chain
    /// (default: its single leaf)
    #[arg(long, value_name = "T")]
    pub tip_link: Option<String>,
    /// Leave the model's effects out of the URDF instead of refusing the export
    #[arg(long)]
    pub drop_effects: bool,
    /// Write the mDH/Hayati table (.csv or .yaml/.yml)
    #[arg(long, value_name = "OUT.csv|OUT.yaml")]
    pub mdh_table: Option<PathBuf>,
    /// Write a C header defining the model as a `static const kincal_robot`
    #[arg(long, value_name = "OUT.h")]
    pub c_header: Option<PathBuf>,
    /// Name of the C variable in --c-header (a C identifier)
    #[arg(long, value_name = "IDENT", default_value = "kincal_calibrated_robot")]
    pub c_name: String,
}

/// Format of `--mdh-table`, from its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    Csv,
    Yaml,
}

/// The table format of `path`, or a usage error naming the accepted extensions.
pub fn table_format(path: &Path) -> Result<TableFormat, CliError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("csv") => Ok(TableFormat::Csv),
        Some("yaml" | "yml") => Ok(TableFormat::Yaml),
        _ => Err(CliError::usage(format!(
            "--mdh-table '{}': the extension must be .csv, .yaml or .yml",
            path.display()
        ))),
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.urdf.is_none() && args.mdh_table.is_none() && args.c_header.is_none() {
        return Err(CliError::usage(
            "nothing to export: give --urdf OUT.urdf, --mdh-table OUT.csv|OUT.yaml and/or --c-header OUT.h",
        ));
    }
    if args.c_header.is_some() && !is_c_identifier(&args.c_name) {
        return Err(CliError::usage(format!(
            "--c-name '{}': not a C identifier (letters, digits and _, not starting with a digit)",
            args.c_name
        )));
    }
    let format = args.mdh_table.as_deref().map(table_format).transpose()?;
    let model = robot_arg::resolve_model(&args.model, &robot_arg::UrdfChainArgs::default())?;
    let model_path = Path::new(&args.model);
    let inputs: Vec<&Path> = if model.from_file {
        vec![model_path]
    } else {
        Vec::new()
    };
    // Build every output before writing any, so a refused target leaves no partial export.
    let urdf_text = match &args.urdf {
        Some(_) => Some(urdf_text(&model.robot, &model.file, args)?),
        None => None,
    };
    let table_text = match format {
        Some(f) => Some(mdh_table_text(&model.file, f, &args.model)?),
        None => None,
    };
    let header_text = match &args.c_header {
        Some(_) => Some(c_header_text(
            &model.robot,
            &model.file,
            &args.c_name,
            &args.model,
        )?),
        None => None,
    };
    if let (Some(out), Some(text)) = (&args.c_header, &header_text) {
        kincal_io::files::write_atomic(out, &inputs, |w| w.write_all(text.as_bytes()))?;
        eprintln!("C header written to {}", out.display());
    }
    if let (Some(out), Some(text)) = (&args.urdf, &urdf_text) {
        kincal_io::files::write_atomic(out, &inputs, |w| w.write_all(text.as_bytes()))?;
        eprintln!("URDF written to {}", out.display());
    }
    if let (Some(out), Some(text)) = (&args.mdh_table, &table_text) {
        kincal_io::files::write_atomic(out, &inputs, |w| w.write_all(text.as_bytes()))?;
        eprintln!("mDH table written to {}", out.display());
    }
    Ok(())
}

/// The standalone URDF of the model (effects refused unless `--drop-effects`).
fn urdf_text(
    robot: &kincal::any::AnyRobot,
    file: &ModelFile,
    args: &Args,
) -> Result<String, CliError> {
    let listed = file
        .effects()
        .map_err(|m| CliError::input(format!("{}: robot: {m}", args.model)))?;
    let active = kincal::with_any_robot!(robot, r => r.active_effects());
    let inexpressible: Vec<String> = Effect::ALL
        .iter()
        .filter(|&&e| !is_frame(e) && (listed.contains(e) || active.contains(e)))
        .map(|e| e.to_string())
        .collect();
    if !inexpressible.is_empty() && !args.drop_effects {
        let names = inexpressible;
        return Err(CliError::input(format!(
            "{}: the model has effects ({}) that URDF cannot express; add --drop-effects to export its geometry alone",
            args.model,
            names.join(", ")
        )));
    }
    if let Some(from) = &args.from {
        let text = std::fs::read_to_string(from)
            .map_err(|e| CliError::input(format!("{}: cannot read: {e}", from.display())))?;
        let sel = ChainSelection {
            base_link: args.base_link.as_deref(),
            tip_link: args.tip_link.as_deref(),
        };
        let shown = from.display().to_string();
        return kincal::with_any_robot!(robot, r => {
            let nominal = file
                .robot
                .nominal_robot()
                .map_err(|m| CliError::input(format!("{}: robot: {m}", args.model)))?;
            update_urdf(&text, &shown, &sel, &nominal, r)
                .map_err(|e| CliError::input(e.to_string()))
        });
    }
    export_urdf(
        robot,
        &UrdfExport {
            robot_name: &file.robot.name,
            base_link: args.base_link.as_deref().unwrap_or("base_link"),
            tip_link: args.tip_link.as_deref().unwrap_or("tool0"),
            joint_names: None,
            allow_dropping_effects: args.drop_effects,
        },
    )
    .map_err(|e| CliError::input(format!("{}: {e}", args.model)))
}

/// Base and tool frames are "effects" of the identification but plain geometry here.
fn is_frame(e: Effect) -> bool {
    matches!(e, Effect::BaseFrame | Effect::ToolFrame)
}

/// Whether an effect parameter belongs in the table: its effect is one of the model's, or
/// its value is not zero (a model file lists every effect parameter, mostly zeros).
fn effect_param_shown(id: ParamId, value: f64, n: usize, listed: EffectSet) -> bool {
    let i = id.index(n).0;
    value != 0.0
        || Effect::ALL
            .iter()
            .any(|&e| listed.contains(e) && e.params(n).contains(i))
}

/// Row of the table a parameter belongs to and its value column.
fn place(id: ParamId, unit: &str) -> (Row, String) {
    let suffix = match unit {
        "m" => "m",
        _ => "rad",
    };
    match id {
        ParamId::Link { link, kind } => (Row::Link(link), format!("{}_{suffix}", kind.name())),
        ParamId::Base(k) => (Row::Base, format!("{}_{suffix}", k.name())),
        ParamId::Tool(k) => (Row::Tool, format!("{}_{suffix}", k.name())),
        other => (Row::Effect(other.to_string()), "value".to_string()),
    }
}

/// A row of the table, in output order.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
enum Row {
    Base,
    Link(usize),
    Tool,
    Effect(String),
}

/// CSV value columns, in order (each also has a `std_` column).
pub const VALUE_COLUMNS: [&str; 11] = [
    "theta0_rad",
    "d_m",
    "a_m",
    "alpha_rad",
    "beta_rad",
    "px_m",
    "py_m",
    "pz_m",
    "rx_rad",
    "ry_rad",
    "rz_rad",
];

/// One row's cells: value columns and standard errors by column name.
#[derive(Debug, Default)]
struct Cells {
    values: BTreeMap<String, f64>,
    std_errors: BTreeMap<String, f64>,
    unit: Option<String>,
}

/// The parameters grouped by row; an unknown label is bad input.
fn rows(file: &ModelFile, source: &str) -> Result<BTreeMap<Row, Cells>, CliError> {
    let n = file.robot.n_joints;
    let listed = file
        .effects()
        .map_err(|m| CliError::input(format!("{source}: robot: {m}")))?;
    let mut out: BTreeMap<Row, Cells> = BTreeMap::new();
    for n_link in 0..n {
        out.entry(Row::Link(n_link)).or_default();
    }
    for ParamJson {
        label,
        value,
        unit,
        std_error,
        ..
    } in &file.robot.parameters
    {
        let id = ParamId::parse(label, n).ok_or_else(|| {
            CliError::input(format!(
                "{source}: robot: unknown parameter label \"{label}\""
            ))
        })?;
        let (row, column) = place(id, unit);
        if matches!(row, Row::Effect(_)) && !effect_param_shown(id, *value, n, listed) {
            continue;
        }
        let cells = out.entry(row.clone()).or_default();
        cells.values.insert(column.clone(), *value);
        if let Some(s) = std_error {
            cells.std_errors.insert(column, *s);
        }
        if matches!(row, Row::Effect(_)) {
            cells.unit = Some(unit.clone());
        }
    }
    Ok(out)
}

fn length_param_name(c: LengthChoice) -> &'static str {
    match c {
        LengthChoice::D => "d",
        LengthChoice::Beta => "beta",
    }
}

/// The mDH table as CSV or YAML text (module docs, `LONG_ABOUT`).
pub fn mdh_table_text(
    file: &ModelFile,
    format: TableFormat,
    source: &str,
) -> Result<String, CliError> {
    let rows = rows(file, source)?;
    let mut buf = Vec::new();
    match format {
        TableFormat::Csv => write_csv(&mut buf, file, &rows),
        TableFormat::Yaml => write_yaml(&mut buf, file, &rows),
    }
    .map_err(|e| CliError::io(format!("mDH table: {e}")))?;
    String::from_utf8(buf).map_err(|e| CliError::io(format!("mDH table: {e}")))
}

/// `revolute`, `prismatic` or `sensor` (a passive revolute joint read by a tilt sensor):
/// what joint `i`'s reading is (a model file without `joint_types` is all revolute).
fn joint_type_name(file: &ModelFile, i: usize) -> &'static str {
    match file.robot.joint_types.get(i) {
        Some(kincal_io::model_file::JointTypeJson::Prismatic) => "prismatic",
        Some(kincal_io::model_file::JointTypeJson::Sensor) => "sensor",
        _ => "revolute",
    }
}

fn row_name(row: &Row) -> String {
    match row {
        Row::Base => "base".into(),
        Row::Link(i) => (i + 1).to_string(),
        Row::Tool => "tool".into(),
        Row::Effect(label) => label.clone(),
    }
}

fn csv_cell(v: Option<f64>) -> String {
    v.map(format_f64).unwrap_or_default()
}

/// Quotes a CSV field when it holds a comma, quote or line break.
fn csv_text_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn write_csv(w: &mut dyn Write, file: &ModelFile, rows: &BTreeMap<Row, Cells>) -> io::Result<()> {
    let mut header: Vec<String> = vec!["frame".into()];
    header.extend(VALUE_COLUMNS[..5].iter().map(|c| c.to_string()));
    header.extend(["length_param", "joint_type", "lower_rad", "upper_rad"].map(String::from));
    header.extend(VALUE_COLUMNS[5..].iter().map(|c| c.to_string()));
    header.extend(["value", "unit"].map(String::from));
    header.extend(VALUE_COLUMNS.iter().map(|c| format!("std_{c}")));
    header.push("std_value".into());
    writeln!(w, "{}", header.join(","))?;
    for (row, cells) in rows {
        let mut line = vec![csv_text_field(&row_name(row))];
        let value = |c: &str| csv_cell(cells.values.get(c).copied());
        line.extend(VALUE_COLUMNS[..5].iter().map(|c| value(c)));
        match row {
            Row::Link(i) => {
                line.push(
                    file.robot
                        .length_params
                        .get(*i)
                        .map(|c| length_param_name(*c).to_string())
                        .unwrap_or_default(),
                );
                line.push(joint_type_name(file, *i).to_string());
                let lim = file.robot.joint_limits.get(*i);
                line.push(csv_cell(lim.map(|l| l.lower)));
                line.push(csv_cell(lim.map(|l| l.upper)));
            }
            _ => line.extend([String::new(), String::new(), String::new(), String::new()]),
        }
        line.extend(VALUE_COLUMNS[5..].iter().map(|c| value(c)));
        line.push(value("value"));
        line.push(csv_text_field(cells.unit.as_deref().unwrap_or("")));
        line.extend(
            VALUE_COLUMNS
                .iter()
                .chain(["value"].iter())
                .map(|c| csv_cell(cells.std_errors.get(*c).copied())),
        );
        writeln!(w, "{}", line.join(","))?;
    }
    Ok(())
}

/// A number as a YAML float that YAML 1.1 readers (PyYAML) also take for a float: an
/// exponent form gets a decimal point and a signed exponent. Reads back to the same double.
pub fn yaml_number(v: f64) -> String {
    let s = format_f64(v);
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let mantissa = if mantissa.contains('.') {
                mantissa.to_string()
            } else {
                format!("{mantissa}.0")
            };
            let exp = if exp.starts_with('-') {
                exp.to_string()
            } else {
                format!("+{exp}")
            };
            format!("{mantissa}e{exp}")
        }
        None => s,
    }
}

/// A YAML double-quoted string (JSON's escaping is valid YAML).
fn yaml_string(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

/// `{ col: value, …, std_error: { col: value, … } }` of one row.
fn yaml_map(cells: &Cells, extra: &[(&str, String)]) -> String {
    let mut parts: Vec<String> = extra.iter().map(|(k, v)| format!("{k}: {v}")).collect();
    let in_order = |m: &BTreeMap<String, f64>| -> Vec<String> {
        VALUE_COLUMNS
            .iter()
            .filter_map(|c| m.get(*c).map(|v| format!("{c}: {}", yaml_number(*v))))
            .collect()
    };
    parts.extend(in_order(&cells.values));
    if !cells.std_errors.is_empty() {
        let std = in_order(&cells.std_errors);
        parts.push(format!("std_error: {{{}}}", std.join(", ")));
    }
    format!("{{{}}}", parts.join(", "))
}

fn write_yaml(w: &mut dyn Write, file: &ModelFile, rows: &BTreeMap<Row, Cells>) -> io::Result<()> {
    writeln!(
        w,
        "# kincal mDH/Hayati table: A_i = Rz(theta0_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(alpha_i)·Ry(beta_i);"
    )?;
    writeln!(
        w,
        "# pose = T_base · A_1 ··· A_N · T_tool, frames Trans(p)·Rot(r) with r a rotation vector. SI units."
    )?;
    writeln!(w, "format: kincal-mdh-table")?;
    writeln!(w, "robot: {}", yaml_string(&file.robot.name))?;
    writeln!(w, "n_joints: {}", file.robot.n_joints)?;
    let empty = Cells::default();
    writeln!(w, "links:")?;
    for i in 0..file.robot.n_joints {
        let cells = rows.get(&Row::Link(i)).unwrap_or(&empty);
        let mut extra = vec![("link", (i + 1).to_string())];
        if let Some(c) = file.robot.length_params.get(i) {
            extra.push(("length_param", length_param_name(*c).to_string()));
        }
        extra.push(("joint_type", joint_type_name(file, i).to_string()));
        if let Some(l) = file.robot.joint_limits.get(i) {
            extra.push(("lower_rad", yaml_number(l.lower)));
            extra.push(("upper_rad", yaml_number(l.upper)));
        }
        writeln!(w, "  - {}", yaml_map(cells, &extra))?;
    }
    for (key, row) in [("base", Row::Base), ("tool", Row::Tool)] {
        writeln!(
            w,
            "{key}: {}",
            yaml_map(rows.get(&row).unwrap_or(&empty), &[])
        )?;
    }
    let effects: Vec<(&String, &Cells)> = rows
        .iter()
        .filter_map(|(r, c)| match r {
            Row::Effect(label) => Some((label, c)),
            _ => None,
        })
        .collect();
    if effects.is_empty() {
        writeln!(w, "effects: []")?;
    } else {
        writeln!(w, "effects:")?;
        for (label, cells) in effects {
            let mut parts = vec![format!("label: {}", yaml_string(label))];
            if let Some(v) = cells.values.get("value") {
                parts.push(format!("value: {}", yaml_number(*v)));
            }
            parts.push(format!(
                "unit: {}",
                yaml_string(cells.unit.as_deref().unwrap_or(""))
            ));
            if let Some(s) = cells.std_errors.get("value") {
                parts.push(format!("std_error: {}", yaml_number(*s)));
            }
            writeln!(w, "  - {{{}}}", parts.join(", "))?;
        }
    }
    Ok(())
}

/// Whether `s` is a C identifier (ASCII letters, digits, `_`; no leading digit).
pub fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A double as a C literal that strtod reads back to the same value.
fn c_number(v: f64) -> String {
    let s = format_f64(v);
    if s.contains(['.', 'e']) {
        s
    } else {
        format!("{s}.0")
    }
}

fn c_list(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| c_number(*v))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A C header defining the model as a `static const kincal_robot` initializer
/// (`include/kincal.h`; C11 designated initializers, entries beyond N are zero).
pub fn c_header_text(
    robot: &kincal::any::AnyRobot,
    file: &ModelFile,
    name: &str,
    source: &str,
) -> Result<String, CliError> {
    kincal::with_any_robot!(robot, r => c_header_generic(r, file, name, source))
}

fn c_header_generic<const N: usize>(
    r: &kincal::Robot<N>,
    file: &ModelFile,
    name: &str,
    source: &str,
) -> Result<String, CliError> {
    let bad = |m: String| CliError::input(format!("{source}: robot: {m}"));
    let mut params = vec![0.0; kincal::Robot::<N>::NUM_PARAMS];
    r.read_params(&mut params).map_err(|e| bad(e.to_string()))?;
    let nominal_robot = file.robot.nominal_robot::<N>().map_err(bad)?;
    let mut nominal = vec![0.0; kincal::Robot::<N>::NUM_PARAMS];
    nominal_robot
        .read_params(&mut nominal)
        .map_err(|e| bad(e.to_string()))?;
    nominal.truncate(kincal::Robot::<N>::NUM_GEOMETRIC_PARAMS);
    let length: Vec<String> = r
        .length_params()
        .iter()
        .map(|lp| match lp {
            kincal::model::LengthParam::D => "KINCAL_LENGTH_PARAM_D".to_string(),
            kincal::model::LengthParam::Beta => "KINCAL_LENGTH_PARAM_BETA".to_string(),
        })
        .collect();
    // Written only for a model with a prismatic joint (a zeroed entry is revolute), so the
    // headers of revolute models are unchanged.
    let kinds = if r.has_prismatic() || r.has_sensor_joints() {
        let k: Vec<&str> = r
            .joint_kinds()
            .iter()
            .map(|k| match k {
                kincal::JointKind::Revolute => "KINCAL_JOINT_KIND_REVOLUTE",
                kincal::JointKind::Prismatic => "KINCAL_JOINT_KIND_PRISMATIC",
                kincal::JointKind::Sensor => "KINCAL_JOINT_KIND_SENSOR",
            })
            .collect();
        format!("\n    .joint_kind = {{{}}},", k.join(", "))
    } else {
        String::new()
    };
    let lower: Vec<f64> = r.limits().iter().map(|l| l.lower).collect();
    let upper: Vec<f64> = r.limits().iter().map(|l| l.upper).collect();
    let mass = r.mass();
    let guard = format!("{}_H", name.to_ascii_uppercase());
    let model_name = serde_json::to_string(&file.robot.name).unwrap_or_default();
    Ok(format!(
        "/* Generated by kincal {version} (`kincal export --c-header`) from the model {model_name}.
   The calibrated model as a kincal_robot initializer (include/kincal.h): pass &{name} to
   kincal_fk & co. Units: metres, radians, kilograms. Every number reads back to the
   model file's double. Do not edit: export again after a new calibration. */
#ifndef {guard}
#define {guard}

#include \"kincal.h\"

static const kincal_robot {name} = {{
    .n_joints = {N},
    .length_param = {{{length}}},{kinds}
    .params = {{{params}}},
    .nominal = {{{nominal}}},
    .limits_lower = {{{lower}}},
    .limits_upper = {{{upper}}},
    .link_masses_kg = {{{masses}}},
    .tool_mass_kg = {tool_mass},
    .gravity = {{{gravity}}},
}};

#endif /* {guard} */
",
        version = env!("CARGO_PKG_VERSION"),
        length = length.join(", "),
        params = c_list(&params),
        nominal = c_list(&nominal),
        lower = c_list(&lower),
        upper = c_list(&upper),
        masses = c_list(&mass.link_masses_kg),
        tool_mass = c_number(mass.tool_mass_kg),
        gravity = c_list(&mass.gravity),
    ))
}
