//! Robot description files (TOML): the mDH table, joint limits, base and tool frames and the
//! point-mass model of a robot, read into an [`AnyRobot`]. The format is documented with an
//! example in `docs/robot-description.md`; `docs/robots/aria.toml` is the built-in ARIA.
//!
//! Units follow the measurement CSV: lengths in metres unless the key ends in `_mm`, angles
//! in radians unless it ends in `_deg`; a quantity given in both forms is an error. `x_mm`
//! converts as `x / 1000` (so an integer number of millimetres gives exactly the double
//! nearest the metre value), `x_deg` as `x·π/180` (exact for ±90, ±180, ±360).
//!
//! Every error names the file, the line and column (from toml's spans) and the key, e.g.
//! `aria.toml:14:5: joint[2].upper: upper limit -1 rad is below the lower limit 0.5 rad`.

use std::fmt;
use std::ops::Range;
use std::path::Path;

use kincal::any::AnyRobot;
use kincal::model::{JointKind, JointLimits, LengthParam, Link, MassModel, Robot};
use kincal::pose::{pose_from_xyz_rpy, pose_to_vector6};
use kincal::with_any_robot;
use serde::Deserialize;
use toml::Spanned;

/// A robot description: what a file gives besides the numbers the core holds.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotDescription {
    /// Robot name.
    pub name: String,
    /// Joint names, one per joint (`joint1`, … when the file gives none).
    pub joint_names: Vec<String>,
    /// The model (nominal geometry, limits, masses; no effects).
    pub robot: AnyRobot,
}

/// A rejected description file or URDF: file, position, key and reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DescriptionError {
    /// The file (as given by the caller).
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// 1-based column (characters), when known.
    pub column: Option<usize>,
    /// The key or element, e.g. `joint[2].d_mm` or `joint shoulder_pan_joint`.
    pub key: Option<String>,
    /// What is wrong and what was expected.
    pub reason: String,
}

impl fmt::Display for DescriptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
            if let Some(c) = self.column {
                write!(f, ":{c}")?;
            }
        }
        if let Some(k) = &self.key {
            write!(f, ": {k}")?;
        }
        write!(f, ": {}", self.reason)
    }
}

impl std::error::Error for DescriptionError {}

impl DescriptionError {
    /// An error without a position.
    pub fn new(file: &str, key: Option<String>, reason: impl Into<String>) -> Self {
        DescriptionError {
            file: file.to_string(),
            line: None,
            column: None,
            key,
            reason: reason.into(),
        }
    }
    fn at(
        src: &Source<'_>,
        span: Option<Range<usize>>,
        key: Option<String>,
        reason: impl Into<String>,
    ) -> Self {
        let (line, column) = match span {
            Some(s) => {
                let (l, c) = line_col(src.text, s.start);
                (Some(l), Some(c))
            }
            None => (None, None),
        };
        DescriptionError {
            file: src.file.to_string(),
            line,
            column,
            key,
            reason: reason.into(),
        }
    }
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let upto = text.get(..offset.min(text.len())).unwrap_or(text);
    let line = upto.matches('\n').count() + 1;
    let col = upto.rsplit('\n').next().map_or(0, |s| s.chars().count()) + 1;
    (line, col)
}

struct Source<'a> {
    file: &'a str,
    text: &'a str,
}

type SF = Option<Spanned<f64>>;
/// A 3-vector as written: any length, so that `[0, 0, 0, 0.05]` is refused by [`pick3`]
/// instead of silently truncated to three elements by the deserialiser.
type SV3 = Option<Spanned<Vec<f64>>>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    name: Spanned<String>,
    #[serde(default)]
    base: Option<Spanned<RawFrame>>,
    #[serde(default)]
    tool: Option<Spanned<RawFrame>>,
    #[serde(default)]
    mass: Option<Spanned<RawMass>>,
    joint: Spanned<Vec<Spanned<RawJoint>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    xyz: SV3,
    xyz_mm: SV3,
    rpy: SV3,
    rpy_deg: SV3,
    rotvec: SV3,
    rotvec_deg: SV3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMass {
    tool_kg: SF,
    gravity: SV3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawJoint {
    name: Option<Spanned<String>>,
    theta0: SF,
    theta0_deg: SF,
    d: SF,
    d_mm: SF,
    a: SF,
    a_mm: SF,
    alpha: SF,
    alpha_deg: SF,
    beta: SF,
    beta_deg: SF,
    lower: SF,
    lower_deg: SF,
    lower_mm: SF,
    upper: SF,
    upper_deg: SF,
    upper_mm: SF,
    mass_kg: SF,
    length_param: Option<Spanned<String>>,
    /// `"revolute"` (default) or `"prismatic"`.
    #[serde(rename = "type")]
    kind: Option<Spanned<String>>,
}

#[derive(Clone, Copy)]
enum Unit {
    Length,
    Angle,
    /// Masses [kg] and gravity [m/s²]: no suffixed form, a looser magnitude bound.
    Plain,
}

/// Why the value `x` (SI) of a quantity in `unit` is implausible, if it is.
fn implausible(x: f64, unit: Unit) -> Option<String> {
    match unit {
        Unit::Length | Unit::Angle => crate::units::implausible_si(x),
        Unit::Plain => (x.abs() > 1e6)
            .then(|| format!("{x:e} is implausibly large: expected a magnitude of at most 1e6")),
    }
}

/// One quantity given in base units or suffixed units (`_mm` / `_deg`), at most one form.
fn pick(
    src: &Source<'_>,
    key: &str,
    plain: &SF,
    suffixed: &SF,
    unit: Unit,
    required: bool,
) -> Result<Option<f64>, DescriptionError> {
    let suffix = match unit {
        Unit::Length => "_mm",
        Unit::Angle => "_deg",
        Unit::Plain => "",
    };
    let (name, v) = match (plain, suffixed) {
        (Some(p), Some(s)) => {
            // Point at whichever of the two comes later in the file.
            let (name, span) = if p.span().start > s.span().start {
                (key.to_string(), p.span())
            } else {
                (format!("{key}{suffix}"), s.span())
            };
            return Err(DescriptionError::at(
                src,
                Some(span),
                Some(name),
                format!(
                    "`{0}` and `{0}{suffix}` both given; give one",
                    key.rsplit('.').next().unwrap_or(key)
                ),
            ));
        }
        (Some(p), None) => (key.to_string(), p),
        (None, Some(s)) => (format!("{key}{suffix}"), s),
        (None, None) if required => {
            return Err(DescriptionError::at(
                src,
                None,
                Some(key.to_string()),
                format!(
                    "missing; give `{0}` or `{0}{suffix}`",
                    key.rsplit('.').next().unwrap_or(key)
                ),
            ));
        }
        (None, None) => return Ok(None),
    };
    let x = *v.get_ref();
    if !x.is_finite() {
        return Err(DescriptionError::at(
            src,
            Some(v.span()),
            Some(name),
            format!("{x} is not a finite number"),
        ));
    }
    let si = match (unit, suffixed.is_some()) {
        (Unit::Length, true) => x / 1000.0,
        (Unit::Angle, true) => x.to_radians(),
        _ => x,
    };
    if let Some(why) = implausible(si, unit) {
        return Err(DescriptionError::at(src, Some(v.span()), Some(name), why));
    }
    Ok(Some(si))
}

/// A 3-vector picked from one of its forms: key used, its span, value in SI units.
type Picked3 = (String, Range<usize>, [f64; 3]);

fn pick3(
    src: &Source<'_>,
    key: &str,
    plain: &SV3,
    suffixed: &SV3,
    unit: Unit,
) -> Result<Option<Picked3>, DescriptionError> {
    let suffix = match unit {
        Unit::Length => "_mm",
        Unit::Angle => "_deg",
        Unit::Plain => "",
    };
    let (name, v) = match (plain, suffixed) {
        (Some(p), Some(s)) => {
            let (name, span) = if p.span().start > s.span().start {
                (key.to_string(), p.span())
            } else {
                (format!("{key}{suffix}"), s.span())
            };
            return Err(DescriptionError::at(
                src,
                Some(span),
                Some(name),
                format!("`{key}` and `{key}{suffix}` both given; give one"),
            ));
        }
        (Some(p), None) => (key.to_string(), p),
        (None, Some(s)) => (format!("{key}{suffix}"), s),
        (None, None) => return Ok(None),
    };
    let x: [f64; 3] = v.get_ref().as_slice().try_into().map_err(|_| {
        DescriptionError::at(
            src,
            Some(v.span()),
            Some(name.clone()),
            format!("expected 3 numbers [x, y, z], found {}", v.get_ref().len()),
        )
    })?;
    if x.iter().any(|c| !c.is_finite()) {
        return Err(DescriptionError::at(
            src,
            Some(v.span()),
            Some(name),
            "every element must be a finite number",
        ));
    }
    let conv = |c: f64| match (unit, suffixed.is_some()) {
        (Unit::Length, true) => c / 1000.0,
        (Unit::Angle, true) => c.to_radians(),
        _ => c,
    };
    let si = x.map(conv);
    if let Some(why) = si.iter().find_map(|&c| implausible(c, unit)) {
        return Err(DescriptionError::at(src, Some(v.span()), Some(name), why));
    }
    Ok(Some((name, v.span(), si)))
}

/// `[px, py, pz, rx, ry, rz]` of a frame table (identity when absent).
fn frame(
    src: &Source<'_>,
    key: &str,
    raw: &Option<Spanned<RawFrame>>,
) -> Result<[f64; 6], DescriptionError> {
    let Some(raw) = raw else {
        return Ok([0.0; 6]);
    };
    let f = raw.get_ref();
    let xyz = pick3(src, &format!("{key}.xyz"), &f.xyz, &f.xyz_mm, Unit::Length)?;
    let rpy = pick3(src, &format!("{key}.rpy"), &f.rpy, &f.rpy_deg, Unit::Angle)?;
    let rv = pick3(
        src,
        &format!("{key}.rotvec"),
        &f.rotvec,
        &f.rotvec_deg,
        Unit::Angle,
    )?;
    let p = xyz.map_or([0.0; 3], |x| x.2);
    let r = match (rpy, rv) {
        (Some(_), Some((name, span, _))) => {
            return Err(DescriptionError::at(
                src,
                Some(span),
                Some(name),
                "orientation given both as rpy and as a rotation vector; give one",
            ));
        }
        (Some((_, _, rpy)), None) => {
            let v = pose_to_vector6(&pose_from_xyz_rpy([0.0; 3], rpy));
            [v[3], v[4], v[5]]
        }
        (None, Some((_, _, r))) => r,
        (None, None) => [0.0; 3],
    };
    Ok([p[0], p[1], p[2], r[0], r[1], r[2]])
}

/// Parses a description from `text`; `file` names it in errors.
// Long by design: the description's keys in file order, each error naming its line and column.
pub fn parse_robot_description(
    text: &str,
    file: &str,
) -> Result<RobotDescription, DescriptionError> {
    let src = Source { file, text };
    let raw: RawFile = toml::from_str(text).map_err(|e| {
        DescriptionError::at(&src, e.span(), None, e.message().trim_end().to_string())
    })?;
    let name = raw.name.get_ref().trim().to_string();
    if name.is_empty() {
        return Err(DescriptionError::at(
            &src,
            Some(raw.name.span()),
            Some("name".into()),
            "must not be empty",
        ));
    }
    let joints = raw.joint.get_ref();
    let n = joints.len();
    if n == 0 || n > kincal::any::MAX_JOINTS {
        return Err(DescriptionError::at(
            &src,
            Some(raw.joint.span()),
            Some("joint".into()),
            format!(
                "{n} joints given; 1 to {} supported",
                kincal::any::MAX_JOINTS
            ),
        ));
    }
    let mut links = Vec::with_capacity(n);
    let mut limits = Vec::with_capacity(n);
    let mut masses = Vec::with_capacity(n);
    let mut overrides = Vec::with_capacity(n);
    let mut joint_names = Vec::with_capacity(n);
    let mut kinds = Vec::with_capacity(n);
    for (i, js) in joints.iter().enumerate() {
        let j = js.get_ref();
        let k = |s: &str| format!("joint[{}].{s}", i + 1);
        let req = |key: &str, p: &SF, s: &SF, u: Unit| -> Result<f64, DescriptionError> {
            // `required` makes `pick` return Some or an error.
            pick(&src, &k(key), p, s, u, true).map(|v| v.unwrap_or(0.0))
        };
        let theta0 = req("theta0", &j.theta0, &j.theta0_deg, Unit::Angle)?;
        let d = req("d", &j.d, &j.d_mm, Unit::Length)?;
        let a = req("a", &j.a, &j.a_mm, Unit::Length)?;
        let alpha = req("alpha", &j.alpha, &j.alpha_deg, Unit::Angle)?;
        let beta = pick(&src, &k("beta"), &j.beta, &j.beta_deg, Unit::Angle, false)?.unwrap_or(0.0);
        let kind = match &j.kind {
            None => JointKind::Revolute,
            Some(t) => match t.get_ref().as_str() {
                "revolute" => JointKind::Revolute,
                "prismatic" => JointKind::Prismatic,
                "sensor" => JointKind::Sensor,
                other => {
                    return Err(DescriptionError::at(
                        &src,
                        Some(t.span()),
                        Some(k("type")),
                        format!(
                            "`{other}` is not a joint type; expected \"revolute\", \"prismatic\" or \"sensor\""
                        ),
                    ));
                }
            },
        };
        let (lower, upper) = limits_of(&src, j, kind, &k)?;
        if lower > upper {
            let span = j
                .upper
                .as_ref()
                .or(j.upper_deg.as_ref())
                .or(j.upper_mm.as_ref())
                .map(Spanned::span);
            let unit = match kind {
                JointKind::Revolute | JointKind::Sensor => "rad",
                JointKind::Prismatic => "m",
            };
            return Err(DescriptionError::at(
                &src,
                span,
                Some(k("upper")),
                format!("upper limit {upper} {unit} is below the lower limit {lower} {unit}"),
            ));
        }
        let mass = pick(&src, &k("mass_kg"), &j.mass_kg, &None, Unit::Plain, false)?.unwrap_or(0.0);
        kinds.push(kind);
        if mass < 0.0 {
            return Err(DescriptionError::at(
                &src,
                j.mass_kg.as_ref().map(Spanned::span),
                Some(k("mass_kg")),
                format!("mass {mass} kg is negative"),
            ));
        }
        let lp = match &j.length_param {
            None => None,
            Some(s) => match s.get_ref().as_str() {
                "d" => Some(LengthParam::D),
                "beta" => Some(LengthParam::Beta),
                other => {
                    return Err(DescriptionError::at(
                        &src,
                        Some(s.span()),
                        Some(k("length_param")),
                        format!("`{other}` is not a length parameter; expected \"d\" or \"beta\""),
                    ));
                }
            },
        };
        joint_names.push(
            j.name
                .as_ref()
                .map_or_else(|| format!("joint{}", i + 1), |s| s.get_ref().clone()),
        );
        links.push(Link {
            theta0,
            d,
            a,
            alpha,
            beta,
        });
        limits.push(JointLimits::new(lower, upper));
        masses.push(mass);
        overrides.push(lp);
    }
    for (i, name) in joint_names.iter().enumerate() {
        if joint_names[..i].contains(name) {
            let span = joints
                .get(i)
                .and_then(|j| j.get_ref().name.as_ref())
                .map(Spanned::span);
            return Err(DescriptionError::at(
                &src,
                span,
                Some(format!("joint[{}].name", i + 1)),
                format!("duplicate joint name `{name}`"),
            ));
        }
    }
    let base = frame(&src, "base", &raw.base)?;
    let tool = frame(&src, "tool", &raw.tool)?;
    let (tool_kg, gravity) = match &raw.mass {
        None => (0.0, [0.0, 0.0, -9.81]),
        Some(m) => {
            let m = m.get_ref();
            let t =
                pick(&src, "mass.tool_kg", &m.tool_kg, &None, Unit::Plain, false)?.unwrap_or(0.0);
            if t < 0.0 {
                return Err(DescriptionError::at(
                    &src,
                    m.tool_kg.as_ref().map(Spanned::span),
                    Some("mass.tool_kg".into()),
                    format!("mass {t} kg is negative"),
                ));
            }
            let g = pick3(&src, "mass.gravity", &m.gravity, &None, Unit::Plain)?
                .map_or([0.0, 0.0, -9.81], |g| g.2);
            (t, g)
        }
    };
    let core_err = |e: kincal::Error| {
        DescriptionError::at(
            &src,
            Some(raw.joint.span()),
            Some("joint".into()),
            e.to_string(),
        )
    };
    let mut robot = AnyRobot::new(&links, &limits).map_err(core_err)?;
    for (i, &kind) in kinds.iter().enumerate() {
        robot.set_joint_kind(i, kind).map_err(core_err)?;
    }
    let robot = with_any_robot!(robot, r => finish(r, base, tool, &masses, tool_kg, gravity, &overrides).map(AnyRobot::from))
        .map_err(core_err)?;
    Ok(RobotDescription {
        name,
        joint_names,
        robot,
    })
}

/// The limits of a joint: radians (`lower`/`upper` or `_deg`) for a revolute joint, metres
/// (`lower`/`upper` or `_mm`) for a prismatic one, whose limits must also pass
/// [`crate::urdf::implausible_prismatic_limits`] (at most 10 m, not ±π-like).
fn limits_of(
    src: &Source<'_>,
    j: &RawJoint,
    kind: JointKind,
    k: &dyn Fn(&str) -> String,
) -> Result<(f64, f64), DescriptionError> {
    let req = |key: &str, p: &SF, s: &SF, u: Unit| -> Result<f64, DescriptionError> {
        pick(src, &k(key), p, s, u, true).map(|v| v.unwrap_or(0.0))
    };
    let wrong_unit = |key: &str, v: &SF, why: &str| match v {
        Some(v) => Err(DescriptionError::at(
            src,
            Some(v.span()),
            Some(k(key)),
            why.to_string(),
        )),
        None => Ok(()),
    };
    match kind {
        JointKind::Revolute | JointKind::Sensor => {
            for (key, v) in [("lower_mm", &j.lower_mm), ("upper_mm", &j.upper_mm)] {
                wrong_unit(
                    key,
                    v,
                    "a revolute joint's limits are angles: give `lower`/`upper` in radians or `_deg`",
                )?;
            }
            Ok((
                req("lower", &j.lower, &j.lower_deg, Unit::Angle)?,
                req("upper", &j.upper, &j.upper_deg, Unit::Angle)?,
            ))
        }
        JointKind::Prismatic => {
            for (key, v) in [("lower_deg", &j.lower_deg), ("upper_deg", &j.upper_deg)] {
                wrong_unit(
                    key,
                    v,
                    "a prismatic joint's limits are lengths: give `lower`/`upper` in metres or `_mm`",
                )?;
            }
            let lower = req("lower", &j.lower, &j.lower_mm, Unit::Length)?;
            let upper = req("upper", &j.upper, &j.upper_mm, Unit::Length)?;
            if let Some(why) = crate::urdf::implausible_prismatic_limits(lower, upper) {
                let span = [&j.lower, &j.lower_mm, &j.upper, &j.upper_mm]
                    .into_iter()
                    .flatten()
                    .next()
                    .map(Spanned::span);
                return Err(DescriptionError::at(src, span, Some(k("lower")), why));
            }
            Ok((lower, upper))
        }
    }
}

fn finish<const N: usize>(
    r: Robot<N>,
    base: [f64; 6],
    tool: [f64; 6],
    masses: &[f64],
    tool_kg: f64,
    gravity: [f64; 3],
    overrides: &[Option<LengthParam>],
) -> kincal::Result<Robot<N>> {
    let mut mass = MassModel::<N>::massless();
    for (m, v) in mass.link_masses_kg.iter_mut().zip(masses) {
        *m = *v;
    }
    mass.tool_mass_kg = tool_kg;
    mass.gravity = gravity;
    let mut r = r.with_base(base)?.with_tool(tool)?.with_mass(mass)?;
    for (i, lp) in overrides.iter().enumerate() {
        if let Some(lp) = lp {
            r.set_length_param(i, *lp)?;
        }
    }
    Ok(r)
}

/// Reads a description file.
pub fn load_robot_file(path: &Path) -> Result<RobotDescription, DescriptionError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| DescriptionError::new(&file, None, format!("cannot read: {e}")))?;
    parse_robot_description(&text, &file)
}

/// A float in TOML with full precision (shortest form that reads back to the same double).
fn num(x: f64) -> String {
    // `{:?}` is Rust's shortest round-trip form and always has a `.` or an exponent.
    format!("{x:?}")
}

fn arr(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| num(*x)).collect();
    format!("[{}]", items.join(", "))
}

/// Writes a description file (SI units, radians, rotation vectors; full precision) that
/// [`parse_robot_description`] reads back to the same robot. Effect parameters are not part
/// of a description and are not written.
pub fn write_robot_description(desc: &RobotDescription) -> String {
    with_any_robot!(&desc.robot, r => write_generic(&desc.name, &desc.joint_names, r))
}

/// [`write_robot_description`] for a robot of known joint count.
pub fn write_generic<const N: usize>(name: &str, joint_names: &[String], r: &Robot<N>) -> String {
    let mut s = String::new();
    s.push_str(&format!("name = {}\n", toml_str(name)));
    for (key, f) in [("base", r.base()), ("tool", r.tool())] {
        if f != [0.0; 6] {
            s.push_str(&format!(
                "\n[{key}]\nxyz = {}\nrotvec = {}\n",
                arr(&f[..3]),
                arr(&f[3..])
            ));
        }
    }
    let m = r.mass();
    s.push_str(&format!(
        "\n[mass]\ntool_kg = {}\ngravity = {}\n",
        num(m.tool_mass_kg),
        arr(&m.gravity)
    ));
    let auto = r.auto_length_params();
    for (i, (l, lim)) in r.links().iter().zip(r.limits()).enumerate() {
        s.push_str("\n[[joint]]\n");
        if let Some(n) = joint_names.get(i) {
            s.push_str(&format!("name = {}\n", toml_str(n)));
        }
        if r.joint_kind(i) != JointKind::Revolute {
            s.push_str(&format!("type = \"{}\"\n", r.joint_kind(i).name()));
        }
        s.push_str(&format!(
            "theta0 = {}\nd = {}\na = {}\nalpha = {}\nbeta = {}\nlower = {}\nupper = {}\nmass_kg = {}\n",
            num(l.theta0),
            num(l.d),
            num(l.a),
            num(l.alpha),
            num(l.beta),
            num(lim.lower),
            num(lim.upper),
            num(m.link_masses_kg[i]),
        ));
        let lp = r.length_params()[i];
        if lp != auto[i] {
            s.push_str(match lp {
                LengthParam::D => "length_param = \"d\"\n",
                LengthParam::Beta => "length_param = \"beta\"\n",
            });
        }
    }
    s
}

fn toml_str(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => {
                out.push_str(&format!("\\u{:04X}", c as u32))
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
#[path = "robot_file_tests.rs"]
mod tests;
