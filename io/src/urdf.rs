//! URDF import and export (parsed and written with the `urdf-rs` crate).
//!
//! **Import** picks the serial chain between a base link and a tip link (default: the
//! unique chain from the single root link down to the single leaf; an error names the
//! branches otherwise), composes the joint origins at `q = 0` into joint axes in the base
//! link's frame, and converts them with the core's [`AxisChain`] (see `kincal::axis_chain`
//! for the mDH construction). Fixed joints are folded into the neighbouring transforms;
//! revolute joints keep their limits; continuous joints get ±[`CONTINUOUS_LIMIT_RAD`].
//! A revolute mimic joint collapses into its driver exactly when the driver's joints
//! that lie on the chain are consecutive, turn about one line and add up to a multiplier
//! of ±1 (e.g. a finger that mimics a driver on another branch): the model joint reads the
//! driver, with the mimic offsets folded into the geometry; anything else is an error.
//! Prismatic joints become prismatic model joints (their reading in metres; limits in
//! metres, at most [`MAX_PRISMATIC_LIMIT_M`], and refused when they look like radians:
//! ±π/2, ±π or ±2π); a prismatic mimic collapses into its driver as a revolute one does
//! (same direction, multipliers adding up to ±1). Floating and planar joints on the chain
//! are errors naming the joint; every error names the URDF element and, for text input, its
//! line.
//! The robot's base frame is the base link's frame and its tool frame the tip link's, so
//! `fk(q)` is the tip link in the base link for the URDF's own joint values `q`.
//!
//! Masses (optional in URDF) become the core's point-mass model: link `i` carries the
//! masses of the URDF links rigidly moved by joint `i` up to the next joint (with every
//! subtree hanging off them), the tool the tip link's subtree. Gravity is −9.81 m/s² along
//! the root link's z axis, expressed in the base link when only fixed joints lie between
//! them (otherwise along the base link's −z, with a note).
//!
//! **Export** writes a calibrated model as a URDF a ROS user can load: link `i`'s frame is
//! mDH frame `i−1` turned by `q_i`, so joint `i` rotates about its z axis and the joint
//! origins carry the identified geometry (a prismatic model joint becomes a prismatic URDF
//! joint sliding along that z axis): joint 1's origin is the base transform, joint
//! `i+1`'s is `A_i(0) = Rz(θ0_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)`, and a fixed joint to
//! the tip link carries `A_N(0)·T_tool`. Joint limits and the point masses are written;
//! effort and velocity limits are unknown to the model and written as 0. Non-geometric
//! effects (compliance, backlash, …) have no URDF form: exporting a model that has them is
//! refused unless explicitly allowed (they are then dropped).

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::Path;

use kincal::any::{AnyRobot, MAX_JOINTS};
use kincal::axis_chain::{AxisChain, JointAxis, link_transform_at_zero};
use kincal::model::{JointKind, JointLimits, MassModel, Robot};
use kincal::pose::{Transform, matrix_to_rpy, pose_from_xyz_rpy};
use kincal::{EffectSet, with_any_robot};
use nalgebra::Vector3;
use urdf_rs::JointType;

use crate::robot_file::DescriptionError;

/// Limits given to a continuous joint [rad]: one turn either way.
pub const CONTINUOUS_LIMIT_RAD: f64 = 2.0 * std::f64::consts::PI;

/// Largest magnitude of a prismatic joint limit [m]: a larger one is most likely in another
/// unit (millimetres), and no lifting column, rail or gantry axis kincal calibrates is longer.
pub const MAX_PRISMATIC_LIMIT_M: f64 = 10.0;

/// Why the limits `lo`, `hi` of a prismatic joint are implausible, if they are: beyond
/// ±[`MAX_PRISMATIC_LIMIT_M`], or a bound equal to ±π/2, ±π or ±2π (to 1e-4), which is a
/// revolute joint's range written on a slide.
pub fn implausible_prismatic_limits(lo: f64, hi: f64) -> Option<String> {
    if !(lo.abs() <= MAX_PRISMATIC_LIMIT_M && hi.abs() <= MAX_PRISMATIC_LIMIT_M) {
        return Some(format!(
            "prismatic joint limits [{lo}, {hi}] exceed ±{MAX_PRISMATIC_LIMIT_M} m; give them in metres"
        ));
    }
    let pi = std::f64::consts::PI;
    let radian_like = [pi / 2.0, pi, 2.0 * pi]
        .into_iter()
        .find(|&r| [lo, hi].iter().any(|v| (v.abs() - r).abs() < 1e-4));
    radian_like.map(|r| {
        format!(
            "prismatic joint limits [{lo}, {hi}] look like radians (±{r:.4} rad); a prismatic joint's limits are in metres"
        )
    })
}

/// Which chain of the URDF tree to import.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChainSelection<'a> {
    /// Base link (default: the single root link).
    pub base_link: Option<&'a str>,
    /// Tip link (default: the single leaf below the base).
    pub tip_link: Option<&'a str>,
}

/// A URDF chain converted to a kincal model.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedUrdf {
    /// `<robot name>`.
    pub robot_name: String,
    /// The base link used (the model's base frame).
    pub base_link: String,
    /// The tip link used (the model's tool frame).
    pub tip_link: String,
    /// Names of the revolute/continuous/prismatic joints, in chain order (the model's joints).
    pub joint_names: Vec<String>,
    /// Names of the fixed joints folded into the geometry.
    pub fixed_joints: Vec<String>,
    /// The model (geometry, limits, masses).
    pub robot: AnyRobot,
    /// Assumptions made (continuous joints' limits, gravity direction).
    pub notes: Vec<String>,
}

/// A model that cannot be written as URDF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UrdfExportError(pub String);

impl fmt::Display for UrdfExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "URDF export: {}", self.0)
    }
}

impl std::error::Error for UrdfExportError {}

/// Names and options of [`export_urdf`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UrdfExport<'a> {
    /// `<robot name>`.
    pub robot_name: &'a str,
    /// Name of the base link.
    pub base_link: &'a str,
    /// Name of the tip (tool) link.
    pub tip_link: &'a str,
    /// Joint names (one per joint; `None`: `joint1`, …).
    pub joint_names: Option<&'a [String]>,
    /// Drop non-geometric effects instead of refusing the export.
    pub allow_dropping_effects: bool,
}

/// `Trans(xyz)·Rz(y)·Ry(p)·Rx(r)` of a URDF `<origin>`.
pub fn origin_transform(o: &urdf_rs::Pose) -> Transform {
    pose_from_xyz_rpy(o.xyz.0, o.rpy.0)
}

/// The joints from `base` down to `tip`, in order (the URDF tree walked by link names).
pub fn select_chain<'u>(
    urdf: &'u urdf_rs::Robot,
    file: &str,
    sel: &ChainSelection<'_>,
) -> Result<(String, String, Vec<&'u urdf_rs::Joint>), DescriptionError> {
    let err = |key: Option<String>, reason: String| DescriptionError::new(file, key, reason);
    let links: HashSet<&str> = urdf.links.iter().map(|l| l.name.as_str()).collect();
    let mut parent_joint: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
    let mut children: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
    for j in &urdf.joints {
        for l in [&j.parent.link, &j.child.link] {
            if !links.contains(l.as_str()) {
                return Err(err(
                    Some(format!("joint {}", j.name)),
                    format!("refers to link `{l}`, which the URDF does not define"),
                ));
            }
        }
        if let Some(other) = parent_joint.insert(j.child.link.as_str(), j) {
            return Err(err(
                Some(format!("link {}", j.child.link)),
                format!(
                    "is the child of two joints (`{}` and `{}`): not a tree",
                    other.name, j.name
                ),
            ));
        }
        children.entry(j.parent.link.as_str()).or_default().push(j);
    }
    let base = match sel.base_link {
        Some(b) if links.contains(b) => b,
        Some(b) => {
            return Err(err(
                Some(format!("link {b}")),
                "base link not found in the URDF".into(),
            ));
        }
        None => {
            let roots: Vec<&str> = urdf
                .links
                .iter()
                .map(|l| l.name.as_str())
                .filter(|l| !parent_joint.contains_key(l))
                .collect();
            match roots.as_slice() {
                [r] => *r,
                _ => {
                    return Err(err(
                        None,
                        format!(
                            "{} root links ({}); choose a base link",
                            roots.len(),
                            roots.join(", ")
                        ),
                    ));
                }
            }
        }
    };
    let mut path = Vec::new();
    let tip = match sel.tip_link {
        Some(t) => {
            if !links.contains(t) {
                return Err(err(
                    Some(format!("link {t}")),
                    "tip link not found in the URDF".into(),
                ));
            }
            let mut cur = t;
            while cur != base {
                match parent_joint.get(cur) {
                    Some(j) => {
                        path.push(*j);
                        cur = j.parent.link.as_str();
                    }
                    None => {
                        return Err(err(
                            Some(format!("link {t}")),
                            format!("tip link is not below the base link `{base}`"),
                        ));
                    }
                }
            }
            path.reverse();
            t
        }
        None => {
            let mut cur = base;
            loop {
                match children.get(cur).map(Vec::as_slice) {
                    None | Some([]) => break cur,
                    Some([j]) => {
                        path.push(*j);
                        cur = j.child.link.as_str();
                    }
                    Some(js) => {
                        let leaves = leaves_below(cur, &children);
                        return Err(err(
                            Some(format!("link {cur}")),
                            format!(
                                "branches into {} ({}); no unique serial chain: choose a tip link among the leaves {}",
                                js.len(),
                                js.iter()
                                    .map(|j| j.child.link.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", "),
                                leaves.join(", ")
                            ),
                        ));
                    }
                }
            }
        }
    };
    Ok((base.to_string(), tip.to_string(), path))
}

fn leaves_below<'u>(
    link: &'u str,
    children: &HashMap<&str, Vec<&'u urdf_rs::Joint>>,
) -> Vec<&'u str> {
    let mut out = Vec::new();
    let mut stack = vec![link];
    while let Some(l) = stack.pop() {
        match children.get(l) {
            Some(js) if !js.is_empty() => {
                stack.extend(js.iter().rev().map(|j| j.child.link.as_str()))
            }
            _ => out.push(l),
        }
    }
    out
}

/// Parses and imports a URDF file.
pub fn import_urdf_file(
    path: &Path,
    sel: &ChainSelection<'_>,
) -> Result<ImportedUrdf, DescriptionError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| DescriptionError::new(&file, None, format!("cannot read: {e}")))?;
    import_urdf_str(&text, &file, sel)
}

/// Parses and imports URDF text; `file` names it in errors.
pub fn import_urdf_str(
    text: &str,
    file: &str,
    sel: &ChainSelection<'_>,
) -> Result<ImportedUrdf, DescriptionError> {
    let urdf = urdf_rs::read_from_string(&check_markup(text, file)?)
        .map_err(|e| DescriptionError::new(file, None, format!("not a readable URDF: {e}")))?;
    import_urdf(&urdf, file, sel).map_err(|mut e| {
        if e.line.is_none() {
            e.line = e.key.as_deref().and_then(|k| element_line(text, k));
        }
        e
    })
}

/// The 1-based line of the element an error key names (`joint NAME` or `link NAME`, the
/// first of a comma-separated list), found in the URDF text: `<joint ... name="NAME"`.
fn element_line(text: &str, key: &str) -> Option<usize> {
    let first = key.split(',').next()?.trim();
    let (tag, name) = first.split_once(' ')?;
    let open = format!("<{tag}");
    let quoted = [format!("name=\"{name}\""), format!("name='{name}'")];
    let mut in_tag = false;
    for (i, line) in text.lines().enumerate() {
        if line.contains(&open) {
            in_tag = true;
        }
        if in_tag && quoted.iter().any(|q| line.contains(q.as_str())) {
            return Some(i + 1);
        }
        if line.contains('>') {
            in_tag = false;
        }
    }
    None
}

/// Deepest element nesting accepted in a URDF (real ones nest about 5 deep). The XML reader
/// recurses per level: a file nested 20,000 deep overflowed the stack (exit 134).
pub const MAX_URDF_DEPTH: usize = 64;

/// The URDF text the XML reader may see: what it cannot survive is refused, naming the line
/// and column, and namespace declarations are blanked.
///
/// - Elements nested deeper than [`MAX_URDF_DEPTH`] are refused (the reader recurses per
///   level).
/// - Element and attribute names with a namespace prefix are refused: URDF has none, and
///   the reader urdf-rs uses (RustyXML 0.3) reads `<x:link>` as a `<link>`.
/// - Namespace declarations (`xmlns="…"`, `xmlns:p="…"`: xacro leftovers on `<robot>`)
///   are replaced by spaces, so line and column numbers stay true. With no prefixed name
///   they declare nothing the import uses, and RustyXML panics printing some of them back
///   (`:ixz` under a default namespace, `xmlns:xmlns="…"`: both found by the
///   `urdf_import` fuzz target), so it never sees one.
///
/// A light scan: comments, `<?…?>`, `<!…>` and quoted attribute values are skipped;
/// malformed XML is left to the parser.
pub fn check_markup<'t>(text: &'t str, file: &str) -> Result<Cow<'t, str>, DescriptionError> {
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut declarations = Vec::new();
    let mut i = 0;
    while let Some(off) = b.get(i..).and_then(|r| r.iter().position(|&c| c == b'<')) {
        let start = i + off;
        let rest = &text[start..];
        i = if rest.starts_with("<!--") {
            rest.find("-->").map_or(b.len(), |e| start + e + 3)
        } else if rest.starts_with("<![CDATA[") {
            rest.find("]]>").map_or(b.len(), |e| start + e + 3)
        } else if rest.starts_with("</") {
            depth = depth.saturating_sub(1);
            start + 2
        } else if let Some(pi) = rest.strip_prefix("<?") {
            // The reader ends a processing instruction at the first `>` after a `?`.
            pi.find('?')
                .and_then(|q| pi[q..].find('>').map(|e| start + 2 + q + e + 1))
                .unwrap_or(b.len())
        } else if rest.starts_with("<!") {
            // A DOCTYPE ends at its first `>` (the reader refuses other `<!` forms).
            rest.find('>').map_or(b.len(), |e| start + e + 1)
        } else {
            let end = tag_end(b, start + 1);
            let refuse = |at: usize, reason: String| {
                let (line, column) = crate::robot_file::line_col(text, at);
                Err(DescriptionError {
                    file: file.to_string(),
                    line: Some(line),
                    column: Some(column),
                    key: None,
                    reason,
                })
            };
            let tag = &text[start + 1..end.min(b.len())];
            for (k, attr) in tag_names(tag).into_iter().enumerate() {
                let (at, name) = (start + 1 + attr.name_at, attr.name);
                let is_attribute = k > 0;
                if is_attribute && (name == "xmlns" || name.starts_with("xmlns:")) {
                    declarations.push(at..start + 1 + attr.end);
                } else if name.contains(':') {
                    return refuse(
                        at,
                        format!(
                            "the name '{name}' has a namespace prefix: URDF elements and attributes have none (expand a xacro file first: `xacro robot.urdf.xacro > robot.urdf`)"
                        ),
                    );
                }
            }
            let self_closing = end > 0 && b.get(end - 1) == Some(&b'/');
            if !self_closing {
                depth += 1;
                if depth > MAX_URDF_DEPTH {
                    return refuse(
                        start,
                        format!(
                            "elements nested more than {MAX_URDF_DEPTH} deep: not a URDF (a robot description nests about 5 deep)"
                        ),
                    );
                }
            }
            end + 1
        };
    }
    let mut blanked = Cow::Borrowed(text);
    if !declarations.is_empty() {
        let mut bytes = text.as_bytes().to_vec();
        for span in declarations {
            for c in &mut bytes[span] {
                // A newline inside a quoted value stays, so that lines keep their numbers.
                if *c != b'\n' {
                    *c = b' ';
                }
            }
        }
        // Only whole characters were replaced (a span starts at an ASCII name and ends
        // after an ASCII quote or name), so the text stays UTF-8.
        blanked = Cow::Owned(String::from_utf8_lossy(&bytes).into_owned());
    }
    // The net under the scan: whatever the scan took for a comment or a processing
    // instruction, the reader must find no namespace to bind (the fuzz target's third way
    // in hid `xmlns:xmlns` from an earlier scan behind a `<?`).
    if let Some(at) = ["xmlns", "xml:"]
        .iter()
        .filter_map(|w| blanked.find(w))
        .min()
    {
        let (line, column) = crate::robot_file::line_col(text, at);
        return Err(DescriptionError {
            file: file.to_string(),
            line: Some(line),
            column: Some(column),
            key: None,
            reason: "'xmlns' or 'xml:' outside a start tag's attributes: URDF has no namespaces, and the XML reader cannot take one here (remove it)".into(),
        });
    }
    Ok(blanked)
}

/// A name in a start tag: the element's own (`end` is the name's end) or an attribute's
/// (`end` is past its quoted value, or the name's end when malformed).
struct TagName<'t> {
    name: &'t str,
    name_at: usize,
    end: usize,
}

/// The names of a start tag's text (between `<` and `>`): the element's, then each
/// attribute's, with their byte offsets in `tag`.
fn tag_names(tag: &str) -> Vec<TagName<'_>> {
    let b = tag.as_bytes();
    let is_space = |c: u8| c.is_ascii_whitespace();
    let name_end = |from: usize| {
        (from..b.len())
            .find(|&k| is_space(b[k]) || matches!(b[k], b'=' | b'/' | b'>'))
            .unwrap_or(b.len())
    };
    let end = name_end(0);
    let mut names = vec![TagName {
        name: &tag[..end],
        name_at: 0,
        end,
    }];
    let mut k = end;
    while k < b.len() {
        if is_space(b[k]) || b[k] == b'/' {
            k += 1;
            continue;
        }
        let at = k;
        let end = name_end(k).max(k + 1);
        // Past `=` and the quoted value (malformed text is the parser's to refuse).
        k = end;
        while k < b.len() && (is_space(b[k]) || b[k] == b'=') {
            k += 1;
        }
        if let Some(&q) = b.get(k).filter(|&&q| q == b'"' || q == b'\'') {
            k = tag[k + 1..].find(q as char).map_or(b.len(), |e| k + e + 2);
        } else {
            k = end;
        }
        names.push(TagName {
            name: &tag[at..end],
            name_at: at,
            end: k,
        });
    }
    names
}

/// Index of the `>` closing the tag whose name starts at `from` (quoted values skipped), or
/// the end of the text.
fn tag_end(b: &[u8], from: usize) -> usize {
    let mut quote: Option<u8> = None;
    for (k, &c) in b.iter().enumerate().skip(from) {
        match (quote, c) {
            (Some(q), _) if c == q => quote = None,
            (Some(_), _) => {}
            (None, b'"' | b'\'') => quote = Some(c),
            (None, b'>') => return k,
            (None, _) => {}
        }
    }
    b.len()
}

/// Imports the selected chain of a parsed URDF.
// Long by design: the chain's segments, mimic joints, geometry at q = 0 and masses, in order; each block is commented.
pub fn import_urdf(
    urdf: &urdf_rs::Robot,
    file: &str,
    sel: &ChainSelection<'_>,
) -> Result<ImportedUrdf, DescriptionError> {
    let (base, tip, path) = select_chain(urdf, file, sel)?;
    let jerr = |j: &urdf_rs::Joint, reason: String| {
        DescriptionError::new(file, Some(format!("joint {}", j.name)), reason)
    };
    let mut t = Transform::identity();
    let mut axes = Vec::new();
    let mut limits = Vec::new();
    let mut joint_names = Vec::new();
    let mut kinds = Vec::new();
    let mut fixed_joints = Vec::new();
    let mut notes = Vec::new();
    // Segment of each path link: 0 before joint 1, k after joint k.
    let mut segment_of: Vec<(&str, usize)> = vec![(base.as_str(), 0)];
    // Revolute joints driven by one joint (itself and its mimics), consecutive on the chain.
    let mut groups: Vec<MimicGroup<'_>> = Vec::new();
    for j in &path {
        let o = &j.origin;
        if o.xyz.iter().chain(o.rpy.iter()).any(|v| !v.is_finite()) {
            return Err(jerr(j, "origin has a non-finite number".into()));
        }
        if let Some(why) = o
            .xyz
            .iter()
            .chain(o.rpy.iter())
            .find_map(|&v| crate::units::implausible_si(v))
        {
            return Err(jerr(j, format!("origin: {why}")));
        }
        t *= origin_transform(o);
        match j.joint_type {
            JointType::Fixed => fixed_joints.push(j.name.clone()),
            JointType::Revolute | JointType::Continuous | JointType::Prismatic => {
                let kind = if j.joint_type == JointType::Prismatic {
                    JointKind::Prismatic
                } else {
                    JointKind::Revolute
                };
                let a = Vector3::from(j.axis.xyz.0);
                let n = a.norm();
                if !(n.is_finite() && n > 1e-9) {
                    return Err(jerr(j, format!("axis {:?} has no direction", j.axis.xyz.0)));
                }
                let (driver, multiplier, offset) = mimic_of(urdf, j).map_err(|r| jerr(j, r))?;
                let point = t.translation.vector;
                let direction = t.rotation * (a / n);
                let last_same = groups
                    .last_mut()
                    .filter(|g| g.driver.name == driver.name && g.axis_index + 1 == axes.len());
                if let Some(g) = last_same {
                    g.absorb(j, kind, point, direction, multiplier)
                        .map_err(|r| jerr(j, r))?;
                } else {
                    if let Some(g) = groups.iter().find(|g| g.driver.name == driver.name) {
                        return Err(jerr(
                            j,
                            format!(
                                "is driven by `{}` like `{}`, but other joints move between them: the mimic cannot be collapsed into its driver exactly",
                                driver.name, g.members[0]
                            ),
                        ));
                    }
                    axes.push(JointAxis { point, direction });
                    limits.push(driver_limits(driver, &mut notes).map_err(|r| jerr(driver, r))?);
                    joint_names.push(driver.name.clone());
                    kinds.push(kind);
                    groups.push(MimicGroup {
                        driver,
                        kind,
                        axis_index: axes.len() - 1,
                        point,
                        direction,
                        multiplier_sum: multiplier,
                        members: vec![j.name.clone()],
                    });
                }
                // The geometry at q = 0 of the model joint: the mimic at its offset.
                t *= match kind {
                    JointKind::Revolute | JointKind::Sensor => Transform::from_parts(
                        nalgebra::Translation3::identity(),
                        nalgebra::Rotation3::from_scaled_axis(a / n * offset),
                    ),
                    JointKind::Prismatic => Transform::from_parts(
                        nalgebra::Translation3::from(a / n * offset),
                        nalgebra::Rotation3::identity(),
                    ),
                };
            }
            ref other => {
                let mimic = j
                    .mimic
                    .as_ref()
                    .map(|m| format!(" (it mimics `{}`)", m.joint))
                    .unwrap_or_default();
                return Err(jerr(
                    j,
                    format!(
                        "is {}{mimic} on the chain `{base}` -> `{tip}`; kincal models revolute and prismatic joints only (choose a base link after it)",
                        format!("{other:?}").to_lowercase()
                    ),
                ));
            }
        }
        segment_of.push((j.child.link.as_str(), axes.len()));
    }
    for g in &groups {
        let m = g.multiplier_sum;
        if (m.abs() - 1.0).abs() > 1e-12 {
            return Err(DescriptionError::new(
                file,
                Some(format!("joint {}", g.members.join(", joint "))),
                format!(
                    "driven by `{}` with a total multiplier {m} about one axis; only a total of ±1 collapses into one joint exactly",
                    g.driver.name
                ),
            ));
        }
        if let Some(ax) = axes.get_mut(g.axis_index)
            && m < 0.0
        {
            ax.direction = -ax.direction;
        }
        if g.members.len() > 1 || g.members[0] != g.driver.name {
            notes.push(format!(
                "joint(s) {} collapsed into the joint they follow, `{}` (its reading is the model's joint)",
                g.members.join(", "),
                g.driver.name
            ));
        }
    }
    let n = axes.len();
    if n == 0 || n > MAX_JOINTS {
        return Err(DescriptionError::new(
            file,
            None,
            format!(
                "{n} revolute/prismatic joints between `{base}` and `{tip}`; 1 to {MAX_JOINTS} supported"
            ),
        ));
    }
    // Masses.
    let mass_of: HashMap<&str, f64> = urdf
        .links
        .iter()
        .map(|l| (l.name.as_str(), l.inertial.mass.value))
        .collect();
    let mut children: HashMap<&str, Vec<&str>> = HashMap::new();
    for j in &urdf.joints {
        children
            .entry(j.parent.link.as_str())
            .or_default()
            .push(j.child.link.as_str());
    }
    let subtree = |root: &str, skip: Option<&str>| -> f64 {
        let mut sum = 0.0;
        let mut stack = vec![root];
        while let Some(l) = stack.pop() {
            sum += mass_of
                .get(l)
                .copied()
                .filter(|m| m.is_finite() && *m > 0.0)
                .unwrap_or(0.0);
            for c in children.get(l).into_iter().flatten() {
                if Some(*c) != skip || l != root {
                    stack.push(c);
                }
            }
        }
        sum
    };
    let mut link_masses = vec![0.0; n];
    let mut tool_kg = 0.0;
    for (k, (l, seg)) in segment_of.iter().enumerate() {
        if k + 1 == segment_of.len() {
            tool_kg = subtree(l, None);
        } else if *seg > 0 {
            let next = segment_of.get(k + 1).map(|x| x.0);
            if let Some(m) = link_masses.get_mut(seg - 1) {
                *m += subtree(l, next);
            }
        }
    }
    let gravity = gravity_in(urdf, &base, &mut notes);
    let core_err = |e: kincal::Error| {
        DescriptionError::new(file, None, format!("chain `{base}` -> `{tip}`: {e}"))
    };
    let mut robot =
        build_any(&axes, t, &limits, &link_masses, tool_kg, gravity).map_err(core_err)?;
    for (i, &k) in kinds.iter().enumerate() {
        robot.set_joint_kind(i, k).map_err(core_err)?;
    }
    Ok(ImportedUrdf {
        robot_name: urdf.name.clone(),
        base_link: base,
        tip_link: tip,
        joint_names,
        fixed_joints,
        robot,
        notes,
    })
}

/// Joints of the chain that turn with one driver joint about one line (or, prismatic, slide
/// along one direction): the model's joint for them reads the driver.
struct MimicGroup<'u> {
    driver: &'u urdf_rs::Joint,
    kind: JointKind,
    axis_index: usize,
    point: Vector3<f64>,
    direction: Vector3<f64>,
    /// Σ ±multiplier (sign: the member's axis along or against the first one's).
    multiplier_sum: f64,
    members: Vec<String>,
}

impl MimicGroup<'_> {
    /// Adds a consecutive member: it must turn about the same line (slide along the same
    /// direction) in the base frame.
    fn absorb(
        &mut self,
        j: &urdf_rs::Joint,
        kind: JointKind,
        point: Vector3<f64>,
        direction: Vector3<f64>,
        multiplier: f64,
    ) -> Result<(), String> {
        if kind != self.kind {
            return Err(format!(
                "is {} and driven by `{}` like `{}`, which is {}: the mimic cannot be collapsed into its driver",
                kind.name(),
                self.driver.name,
                self.members[0],
                self.kind.name()
            ));
        }
        let parallel = self.direction.cross(&direction).norm() < 1e-9;
        let on_line = kind == JointKind::Prismatic
            || (point - self.point).cross(&self.direction).norm() < 1e-9;
        if !(parallel && on_line) {
            return Err(format!(
                "is driven by `{}` like `{}` but turns about another line: the mimic cannot be collapsed into its driver exactly",
                self.driver.name, self.members[0]
            ));
        }
        let sign = self.direction.dot(&direction).signum();
        self.multiplier_sum += sign * multiplier;
        self.members.push(j.name.clone());
        Ok(())
    }
}

/// The joint driving `j`, with `j = multiplier·driver + offset` (`j` itself, 1, 0 unless it
/// has a `<mimic>`).
fn mimic_of<'u>(
    urdf: &'u urdf_rs::Robot,
    j: &'u urdf_rs::Joint,
) -> Result<(&'u urdf_rs::Joint, f64, f64), String> {
    let Some(m) = &j.mimic else {
        return Ok((j, 1.0, 0.0));
    };
    let Some(driver) = urdf.joints.iter().find(|d| d.name == m.joint) else {
        return Err(format!(
            "mimics `{}`, which the URDF does not define",
            m.joint
        ));
    };
    if let Some(dm) = &driver.mimic {
        return Err(format!(
            "mimics `{}`, which itself mimics `{}`: a chain or loop of mimic joints has no single driver",
            driver.name, dm.joint
        ));
    }
    let prismatic = |t: &JointType| *t == JointType::Prismatic;
    if !matches!(
        driver.joint_type,
        JointType::Revolute | JointType::Continuous | JointType::Prismatic
    ) || prismatic(&driver.joint_type) != prismatic(&j.joint_type)
    {
        return Err(format!(
            "mimics `{}`, which is {:?} (a mimic must be of its driver's kind, revolute or prismatic)",
            driver.name, driver.joint_type
        ));
    }
    let (mul, off) = (m.multiplier.unwrap_or(1.0), m.offset.unwrap_or(0.0));
    if !(mul.is_finite() && off.is_finite()) {
        return Err("mimic multiplier or offset is not a finite number".into());
    }
    Ok((driver, mul, off))
}

/// The limits of a model joint: its (driver) joint's, ±[`CONTINUOUS_LIMIT_RAD`] when
/// continuous.
fn driver_limits(j: &urdf_rs::Joint, notes: &mut Vec<String>) -> Result<JointLimits, String> {
    if j.joint_type == JointType::Continuous {
        notes.push(format!(
            "joint {}: continuous, limits set to ±{CONTINUOUS_LIMIT_RAD} rad",
            j.name
        ));
        return Ok(JointLimits::new(
            -CONTINUOUS_LIMIT_RAD,
            CONTINUOUS_LIMIT_RAD,
        ));
    }
    let (lo, hi) = (j.limit.lower, j.limit.upper);
    if j.joint_type == JointType::Prismatic {
        if let Some(why) = implausible_prismatic_limits(lo, hi) {
            return Err(why);
        }
        if lo >= hi {
            return Err(format!(
                "prismatic joint without usable limits (lower {lo}, upper {hi}); expected lower < upper in metres"
            ));
        }
        return Ok(JointLimits::new(lo, hi));
    }
    let bound = crate::units::MAX_MAGNITUDE_SI;
    if !(lo.abs() <= bound && hi.abs() <= bound) || lo >= hi {
        return Err(format!(
            "revolute joint without usable limits (lower {lo}, upper {hi}); expected finite lower < upper within ±{bound} rad"
        ));
    }
    Ok(JointLimits::new(lo, hi))
}

/// Gravity (−9.81 m/s² along the root's z) in the base link's frame.
fn gravity_in(urdf: &urdf_rs::Robot, base: &str, notes: &mut Vec<String>) -> [f64; 3] {
    let mut t = Transform::identity();
    let mut cur = base;
    while let Some(j) = urdf.joints.iter().find(|j| j.child.link == cur) {
        if j.joint_type != JointType::Fixed {
            notes.push(format!(
                "gravity assumed along -z of `{base}` (joint {} moves it relative to the root)",
                j.name
            ));
            return [0.0, 0.0, -9.81];
        }
        t = origin_transform(&j.origin) * t;
        cur = j.parent.link.as_str();
    }
    let g = t.rotation.inverse() * Vector3::new(0.0, 0.0, -9.81);
    [g.x, g.y, g.z]
}

fn build_any(
    axes: &[JointAxis],
    t_base_tip: Transform,
    limits: &[JointLimits],
    masses: &[f64],
    tool_kg: f64,
    gravity: [f64; 3],
) -> kincal::Result<AnyRobot> {
    macro_rules! arm {
        ($n:literal) => {
            build::<$n>(axes, t_base_tip, limits, masses, tool_kg, gravity).map(AnyRobot::from)
        };
    }
    match axes.len() {
        1 => arm!(1),
        2 => arm!(2),
        3 => arm!(3),
        4 => arm!(4),
        5 => arm!(5),
        6 => arm!(6),
        7 => arm!(7),
        8 => arm!(8),
        9 => arm!(9),
        10 => arm!(10),
        11 => arm!(11),
        12 => arm!(12),
        n => Err(kincal::Error::CapacityExceeded {
            needed: n,
            capacity: MAX_JOINTS,
        }),
    }
}

fn build<const N: usize>(
    axes: &[JointAxis],
    t_base_tip: Transform,
    limits: &[JointLimits],
    masses: &[f64],
    tool_kg: f64,
    gravity: [f64; 3],
) -> kincal::Result<Robot<N>> {
    let dim = |found: usize| kincal::Error::DimensionMismatch { expected: N, found };
    let axes: [JointAxis; N] = axes.try_into().map_err(|_| dim(axes.len()))?;
    let limits: [JointLimits; N] = limits.try_into().map_err(|_| dim(limits.len()))?;
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes,
        t_ref_tool: t_base_tip,
    };
    let mut mass = MassModel::<N>::massless();
    for (m, v) in mass.link_masses_kg.iter_mut().zip(masses) {
        *m = *v;
    }
    mass.tool_mass_kg = tool_kg;
    mass.gravity = gravity;
    chain.to_robot(limits)?.with_mass(mass)
}

fn pose_of(t: &Transform) -> urdf_rs::Pose {
    let p = t.translation.vector;
    urdf_rs::Pose {
        xyz: urdf_rs::Vec3([p.x, p.y, p.z]),
        rpy: urdf_rs::Vec3(matrix_to_rpy(t.rotation.matrix())),
    }
}

fn urdf_link(name: &str, mass: f64, com: [f64; 3]) -> urdf_rs::Link {
    urdf_rs::Link {
        name: name.to_string(),
        inertial: urdf_rs::Inertial {
            origin: urdf_rs::Pose {
                xyz: urdf_rs::Vec3(com),
                rpy: urdf_rs::Vec3([0.0; 3]),
            },
            mass: urdf_rs::Mass { value: mass },
            inertia: urdf_rs::Inertia::default(),
        },
        visual: Vec::new(),
        collision: Vec::new(),
    }
}

fn urdf_joint(
    name: &str,
    kind: JointType,
    parent: &str,
    child: &str,
    origin: &Transform,
    limits: Option<JointLimits>,
) -> urdf_rs::Joint {
    urdf_rs::Joint {
        name: name.to_string(),
        joint_type: kind,
        origin: pose_of(origin),
        parent: urdf_rs::LinkName {
            link: parent.to_string(),
        },
        child: urdf_rs::LinkName {
            link: child.to_string(),
        },
        axis: urdf_rs::Axis {
            xyz: urdf_rs::Vec3([0.0, 0.0, 1.0]),
        },
        limit: urdf_rs::JointLimit {
            lower: limits.map_or(0.0, |l| l.lower),
            upper: limits.map_or(0.0, |l| l.upper),
            ..urdf_rs::JointLimit::default()
        },
        calibration: None,
        dynamics: None,
        mimic: None,
        safety_controller: None,
    }
}

/// Writes `robot` (its current, e.g. calibrated, geometry) as URDF text (module docs).
pub fn export_urdf(robot: &AnyRobot, spec: &UrdfExport<'_>) -> Result<String, UrdfExportError> {
    let urdf = with_any_robot!(robot, r => export_generic(r, spec))?;
    let body = urdf_rs::write_to_string(&urdf).map_err(|e| UrdfExportError(e.to_string()))?;
    Ok(format!(
        "<?xml version=\"1.0\"?>\n<!-- Written by kincal {}: link i is mDH frame i-1 turned by q_i; joint origins carry the model's geometry. -->\n{body}\n",
        env!("CARGO_PKG_VERSION")
    ))
}

fn export_generic<const N: usize>(
    r: &Robot<N>,
    spec: &UrdfExport<'_>,
) -> Result<urdf_rs::Robot, UrdfExportError> {
    let active = r.active_effects();
    if active != EffectSet::NONE && !spec.allow_dropping_effects {
        let names: Vec<String> = active.iter().map(|e| e.to_string()).collect();
        return Err(UrdfExportError(format!(
            "the model has non-geometric effects ({}) that URDF cannot express; allow dropping them to export the geometry alone",
            names.join(", ")
        )));
    }
    let joint_names: Vec<String> = match spec.joint_names {
        Some(n) if n.len() == N => n.to_vec(),
        Some(n) => {
            return Err(UrdfExportError(format!(
                "{} joint names given for {N} joints",
                n.len()
            )));
        }
        None => (1..=N).map(|i| format!("joint{i}")).collect(),
    };
    let link_names: Vec<String> = (1..=N).map(|i| format!("link{i}")).collect();
    let mut all_names: Vec<&str> = vec![spec.base_link, spec.tip_link];
    all_names.extend(link_names.iter().map(String::as_str));
    let unique: HashSet<&str> = all_names.iter().copied().collect();
    if unique.len() != all_names.len() {
        return Err(UrdfExportError(format!(
            "link names must differ: base `{}`, tip `{}`, and link1..link{N}",
            spec.base_link, spec.tip_link
        )));
    }
    let mass = r.mass();
    let mut links = vec![urdf_link(spec.base_link, 0.0, [0.0; 3])];
    let mut joints = Vec::new();
    let mut parent = spec.base_link.to_string();
    let mut origin = *r.t_base_0();
    for (i, l) in r.links().iter().enumerate() {
        let a = link_transform_at_zero(l);
        let com = a.translation.vector * 0.5;
        links.push(urdf_link(
            &link_names[i],
            mass.link_masses_kg[i],
            [com.x, com.y, com.z],
        ));
        joints.push(urdf_joint(
            &joint_names[i],
            match r.joint_kind(i) {
                // URDF has no sensor joints: a sensor joint is a revolute joint there.
                JointKind::Revolute | JointKind::Sensor => JointType::Revolute,
                JointKind::Prismatic => JointType::Prismatic,
            },
            &parent,
            &link_names[i],
            &origin,
            Some(r.limits()[i]),
        ));
        parent = link_names[i].clone();
        origin = a;
    }
    links.push(urdf_link(spec.tip_link, mass.tool_mass_kg, [0.0; 3]));
    let tool_origin = origin * r.t_n_tool();
    joints.push(urdf_joint(
        &format!("{}_fixed", spec.tip_link),
        JointType::Fixed,
        &parent,
        spec.tip_link,
        &tool_origin,
        None,
    ));
    Ok(urdf_rs::Robot {
        name: spec.robot_name.to_string(),
        version: None,
        links,
        joints,
        materials: Vec::new(),
    })
}

#[cfg(test)]
#[path = "urdf_tests.rs"]
mod tests;
