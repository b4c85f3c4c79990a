//! `kincal export --urdf OUT --from ROBOT.urdf`: the calibrated geometry written into the
//! user's own URDF, everything else kept byte for byte.
//!
//! Each chain joint's child link keeps its place on its body: with `G_k(0)` the frame of
//! joint k in the model (mDH frame k−1 at q = 0, see `urdf.rs`) and `P_k` the URDF child
//! link's pose at q = 0, the offset `C_k = G⁰_k(0)⁻¹·P_k` is taken from the model's
//! **nominal** geometry and kept, so the calibrated link pose is `G_k(0)·C_k`: meshes,
//! inertials and branches hanging off a link move with the identified joint axis. Only the
//! `<origin>` of the chain's revolute and prismatic joints changes (axes are unchanged, since `C_k` is),
//! plus the last fixed joint before the tip link, which carries the calibrated tool frame.
//! Fixed joints elsewhere, limits, other branches, comments and unknown tags are untouched.
//!
//! The nominal model must be this URDF's chain (the model was calibrated from it): the
//! moving (revolute, continuous, prismatic) joint count and kinds must match and every URDF
//! joint axis must lie on the nominal model's joint axis (same line and direction, 1e-9),
//! else the export is refused.

use kincal::Robot;
use kincal::axis_chain::link_transform_at_zero;
use kincal::pose::{Transform, matrix_to_rpy};
use nalgebra::Vector3;
use urdf_rs::JointType;

use crate::robot_file::DescriptionError;
use crate::urdf::{ChainSelection, check_markup, origin_transform, select_chain};

/// Agreement required between the URDF's joint axes and the nominal model's [m, cosine].
pub const AXIS_TOLERANCE: f64 = 1e-9;

/// Joint k's frame at q = 0 for every joint (`G_1 = T_base`, `G_{k+1} = G_k·A_k(0)`), and
/// `A_N(0)·T_tool`.
fn joint_frames<const N: usize>(r: &Robot<N>) -> ([Transform; N], Transform) {
    let mut frames = [Transform::identity(); N];
    let mut g = *r.t_base_0();
    let mut last = Transform::identity();
    for (f, l) in frames.iter_mut().zip(r.links()) {
        *f = g;
        last = link_transform_at_zero(l);
        g *= last;
    }
    (frames, last * r.t_n_tool())
}

/// The updated URDF text (module docs).
pub fn update_urdf<const N: usize>(
    text: &str,
    file: &str,
    sel: &ChainSelection<'_>,
    nominal: &Robot<N>,
    model: &Robot<N>,
) -> Result<String, DescriptionError> {
    let urdf = urdf_rs::read_from_string(&check_markup(text, file)?)
        .map_err(|e| DescriptionError::new(file, None, format!("not a readable URDF: {e}")))?;
    let (base, tip, path) = select_chain(&urdf, file, sel)?;
    let err = |key: Option<String>, reason: String| DescriptionError::new(file, key, reason);
    let moving = path
        .iter()
        .filter(|j| j.joint_type != JointType::Fixed)
        .count();
    if let Some(j) = path.iter().find(|j| {
        !matches!(
            j.joint_type,
            JointType::Revolute | JointType::Continuous | JointType::Prismatic | JointType::Fixed
        )
    }) {
        return Err(err(
            Some(format!("joint {}", j.name)),
            "is neither revolute, continuous, prismatic nor fixed: kincal models chains of those"
                .into(),
        ));
    }
    if moving != N {
        return Err(err(
            None,
            format!(
                "the chain from `{base}` to `{tip}` has {moving} revolute/prismatic joints, the model has {N}: choose --base-link/--tip-link of the chain the model was calibrated from"
            ),
        ));
    }
    let (g_nom, _) = joint_frames(nominal);
    let (g_cal, tool_cal) = joint_frames(model);
    // Nominal URDF poses of the moving joints' child links, and the offsets C_k.
    let mut offsets = [Transform::identity(); N];
    let mut t = Transform::identity();
    let mut k = 0;
    for j in &path {
        t *= origin_transform(&j.origin);
        if j.joint_type == JointType::Fixed {
            continue;
        }
        let (Some(g), Some(c)) = (g_nom.get(k), offsets.get_mut(k)) else {
            break;
        };
        let urdf_prismatic = j.joint_type == JointType::Prismatic;
        if urdf_prismatic != (nominal.joint_kind(k) == kincal::JointKind::Prismatic) {
            return Err(err(
                Some(format!("joint {}", j.name)),
                format!(
                    "is {:?} but the model's joint {} is {}: the model was not calibrated from this URDF",
                    j.joint_type,
                    k + 1,
                    nominal.joint_kind(k).name()
                ),
            ));
        }
        let a = Vector3::from(j.axis.xyz.0);
        let axis = t.rotation * (a / a.norm());
        let z = g.rotation * Vector3::z();
        let gap = (t.translation.vector - g.translation.vector)
            .cross(&z)
            .norm();
        if !(axis.dot(&z) > 1.0 - AXIS_TOLERANCE && gap < AXIS_TOLERANCE) {
            return Err(err(
                Some(format!("joint {}", j.name)),
                format!(
                    "its axis is not the model's nominal joint {} axis (direction cosine {:.12}, {:.3e} m apart): the model was not calibrated from this URDF",
                    k + 1,
                    axis.dot(&z),
                    gap
                ),
            ));
        }
        *c = g.inverse() * t;
        k += 1;
    }
    // The calibrated origins, walking the chain with the new link poses.
    let last_moving = path
        .iter()
        .rposition(|j| j.joint_type != JointType::Fixed)
        .unwrap_or(0);
    let tool_fixed = path
        .iter()
        .rposition(|j| j.joint_type == JointType::Fixed)
        .filter(|&i| i > last_moving);
    let mut edits: Vec<(String, Transform)> = Vec::new();
    let mut cur = Transform::identity();
    let mut k = 0;
    let mut since_last = Transform::identity();
    for (i, j) in path.iter().enumerate() {
        if j.joint_type == JointType::Fixed {
            if Some(i) == tool_fixed {
                let c_n = offsets.last().copied().unwrap_or_else(Transform::identity);
                let origin = since_last.inverse() * c_n.inverse() * tool_cal;
                edits.push((j.name.clone(), origin));
                cur *= origin;
            } else {
                let o = origin_transform(&j.origin);
                cur *= o;
                since_last *= o;
            }
            continue;
        }
        let (Some(g), Some(c)) = (g_cal.get(k), offsets.get(k)) else {
            break;
        };
        let link = g * c;
        edits.push((j.name.clone(), cur.inverse() * link));
        cur = link;
        since_last = Transform::identity();
        k += 1;
    }
    if tool_fixed.is_none() {
        let c_n = offsets.last().copied().unwrap_or_else(Transform::identity);
        let residual = c_n.inverse() * tool_cal;
        let moved = residual.translation.vector.norm() + residual.rotation.angle();
        if moved > AXIS_TOLERANCE {
            return Err(err(
                Some(format!("link {tip}")),
                "the tip link is the last joint's child, so the calibrated tool frame has no joint to go in: choose a tip link below a fixed joint".into(),
            ));
        }
    }
    let mut out = text.to_string();
    for (name, origin) in &edits {
        out = set_joint_origin(&out, name, origin)
            .map_err(|reason| DescriptionError::new(file, Some(format!("joint {name}")), reason))?;
    }
    Ok(out)
}

/// `<origin xyz="…" rpy="…"/>` of a transform, every number in the shortest round-trip form.
fn origin_tag(t: &Transform) -> String {
    let p = t.translation.vector;
    let [r, pi, y] = matrix_to_rpy(t.rotation.matrix());
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
        p.x, p.y, p.z, r, pi, y
    )
}

/// Whether the start tag at `tag` (text from `<joint`) names the joint `name`.
fn names_joint(tag: &str, name: &str) -> bool {
    [format!("name=\"{name}\""), format!("name='{name}'")]
        .iter()
        .any(|a| {
            tag.match_indices(a.as_str())
                .any(|(i, _)| tag[..i].ends_with(char::is_whitespace))
        })
}

/// The text with the `<origin>` of joint `name` replaced (or inserted when absent).
fn set_joint_origin(text: &str, name: &str, origin: &Transform) -> Result<String, String> {
    let mut from = 0;
    while let Some(off) = text[from..].find("<joint") {
        let start = from + off;
        let after = &text[start + 6..];
        from = start + 6;
        if !after.starts_with(char::is_whitespace) {
            continue;
        }
        let Some(tag_len) = after.find('>') else {
            break;
        };
        let tag = &text[start..start + 6 + tag_len + 1];
        // A transmission's `<joint name="…">` has no type: only the kinematic joint counts.
        if !names_joint(tag, name) || !tag.contains("type=") {
            continue;
        }
        let body_start = start + tag.len();
        let Some(end) = text[body_start..].find("</joint>").map(|e| body_start + e) else {
            return Err("the element has no </joint>".into());
        };
        let body = &text[body_start..end];
        let new_tag = origin_tag(origin);
        return match body.find("<origin") {
            Some(o) => {
                let o_start = body_start + o;
                let Some(close) = text[o_start..end].find('>').map(|c| o_start + c) else {
                    return Err("its <origin> is not closed".into());
                };
                if !text[..close].ends_with('/') {
                    return Err("its <origin> is not a self-closing element".into());
                }
                Ok(format!(
                    "{}{new_tag}{}",
                    &text[..o_start],
                    &text[close + 1..]
                ))
            }
            None => Ok(format!(
                "{}\n    {new_tag}{}",
                &text[..body_start],
                &text[body_start..]
            )),
        };
    }
    Err("not found in the text".into())
}
