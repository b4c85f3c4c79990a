//! Calibration-tool specification files: the reference poses a workshop manufactures.
//!
//! Layout (the conventions of spec/measurements.md): `#` comment lines, then a header; one
//! row per reference pose. Columns, found by name in any order:
//! - `pose_id` (optional label);
//! - `x`, `y`, `z`: position in the base frame, unit suffix `_m` (default) or `_mm`;
//! - orientation as `roll`, `pitch`, `yaw` (R = Rz(yaw)·Ry(pitch)·Rx(roll), suffix `_rad`
//!   (default) or `_deg`) or as a unit quaternion `qw`, `qx`, `qy`, `qz`;
//! - `extra_*` columns are carried by the writer (the nominal joint configuration) and
//!   ignored by the reader. Any other column is an error.
//!
//! The writer uses millimetres and degrees with full precision.

use std::io::{self, Write};
use std::path::Path;

use kincal::pose::{
    Transform, matrix_to_quaternion, matrix_to_rpy, quaternion_to_matrix, rpy_to_matrix, transform,
};
use nalgebra::Vector3;

use crate::measurements::{InputError, format_f64};

/// One reference pose of a tool file.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolPose {
    pub pose_id: Option<String>,
    pub pose: Transform,
    /// The nominal configuration of the `extra_q1_rad … extra_qN_rad` columns, if the file
    /// has them (the branch to approach the pose on).
    pub q_hint: Vec<f64>,
    /// 1-based line in the file (0 when not read from a file).
    pub line: u64,
}

#[derive(Clone, Copy)]
enum Col {
    Id,
    Pos(usize, f64),
    Rpy(usize, f64),
    Quat(usize),
    /// `extra_q{k}_rad` (zero-based k).
    Hint(usize),
    Extra,
}

fn err(path: &str, line: Option<u64>, column: Option<&str>, reason: String) -> InputError {
    InputError {
        path: path.to_string(),
        line,
        column: column.map(str::to_string),
        reason,
    }
}

/// Classifies a header name.
fn classify(name: &str) -> Option<Col> {
    if name == "pose_id" {
        return Some(Col::Id);
    }
    if let Some(k) = name
        .strip_prefix("extra_q")
        .and_then(|r| r.strip_suffix("_rad"))
        .and_then(|k| k.parse::<usize>().ok())
        .filter(|&k| k >= 1)
    {
        return Some(Col::Hint(k - 1));
    }
    if name.starts_with("extra_") {
        return Some(Col::Extra);
    }
    let (stem, suffix) = match name.rsplit_once('_') {
        Some((s, u)) if ["m", "mm", "rad", "deg"].contains(&u) => (s, Some(u)),
        _ => (name, None),
    };
    let pos = ["x", "y", "z"].iter().position(|&p| p == stem);
    let rpy = ["roll", "pitch", "yaw"].iter().position(|&p| p == stem);
    let quat = ["qw", "qx", "qy", "qz"].iter().position(|&p| p == stem);
    match (pos, rpy, quat, suffix) {
        (Some(k), _, _, None | Some("m")) => Some(Col::Pos(k, 1.0)),
        (Some(k), _, _, Some("mm")) => Some(Col::Pos(k, 1e-3)),
        (_, Some(k), _, None | Some("rad")) => Some(Col::Rpy(k, 1.0)),
        (_, Some(k), _, Some("deg")) => Some(Col::Rpy(k, core::f64::consts::PI / 180.0)),
        (_, _, Some(k), None) => Some(Col::Quat(k)),
        _ => None,
    }
}

/// Reads a tool file. Every rejection names the file, line and column.
pub fn read_tool(path: &Path) -> Result<Vec<ToolPose>, InputError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(&name, None, None, format!("cannot read the file: {e}")))?;
    parse_tool(&text, &name)
}

/// Parses tool-file text; `name` is used in messages.
// Long by design: the tool file's keys in file order, each error naming its line and column.
pub fn parse_tool(text: &str, name: &str) -> Result<Vec<ToolPose>, InputError> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i as u64 + 1, l));
    let (header_line, header) = loop {
        match lines.next() {
            None => return Err(err(name, None, None, "empty file: no header".into())),
            Some((_, l)) if l.trim_start().starts_with('#') || l.trim().is_empty() => continue,
            Some(h) => break h,
        }
    };
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    let mut cols = Vec::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        let c = classify(n).ok_or_else(|| {
            err(
                name,
                Some(header_line),
                Some(n),
                "unknown column: expected pose_id, x/y/z[_m|_mm], roll/pitch/yaw[_rad|_deg], \
                 qw/qx/qy/qz, or extra_*"
                    .into(),
            )
        })?;
        if names[..i].contains(n) {
            return Err(err(
                name,
                Some(header_line),
                Some(n),
                "duplicated column".into(),
            ));
        }
        cols.push(c);
    }
    let count = |f: &dyn Fn(&Col) -> bool| cols.iter().filter(|c| f(c)).count();
    let n_pos = count(&|c| matches!(c, Col::Pos(..)));
    let n_rpy = count(&|c| matches!(c, Col::Rpy(..)));
    let n_quat = count(&|c| matches!(c, Col::Quat(..)));
    for k in 0..3 {
        if count(&|c| matches!(c, Col::Pos(j, _) if *j == k)) != 1 {
            return Err(err(
                name,
                Some(header_line),
                Some(["x", "y", "z"][k]),
                "expected exactly one column for each of x, y, z".into(),
            ));
        }
    }
    let _ = n_pos;
    // Hints count only as a complete extra_q1_rad … extra_qK_rad run.
    let hints: Vec<usize> = cols
        .iter()
        .filter_map(|c| if let Col::Hint(k) = c { Some(*k) } else { None })
        .collect();
    let n_hint = if (0..hints.len()).all(|k| hints.contains(&k)) {
        hints.len()
    } else {
        for c in cols.iter_mut() {
            if matches!(c, Col::Hint(_)) {
                *c = Col::Extra;
            }
        }
        0
    };
    let form_rpy = match (n_rpy, n_quat) {
        (3, 0) => true,
        (0, 4) => false,
        _ => {
            return Err(err(
                name,
                Some(header_line),
                None,
                "expected the orientation as roll, pitch, yaw or as qw, qx, qy, qz (one form, all its columns)".into(),
            ));
        }
    };
    let mut out = Vec::new();
    for (line, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = l.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(err(
                name,
                Some(line),
                None,
                format!("{} fields, expected {}", cells.len(), names.len()),
            ));
        }
        let (mut p, mut rpy, mut quat, mut id) = ([0.0; 3], [0.0; 3], [0.0; 4], None);
        let mut hint = vec![f64::NAN; n_hint];
        for ((c, cell), n) in cols.iter().zip(&cells).zip(&names) {
            let num = || -> Result<f64, InputError> {
                match cell.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(err(
                        name,
                        Some(line),
                        Some(n),
                        format!("'{cell}' is not a finite number"),
                    )),
                }
            };
            match *c {
                Col::Id => id = Some(cell.to_string()),
                Col::Pos(k, s) => p[k] = num()? * s,
                Col::Rpy(k, s) => rpy[k] = num()? * s,
                Col::Quat(k) => quat[k] = num()?,
                Col::Hint(k) => hint[k] = num()?,
                Col::Extra => {}
            }
        }
        let r = if form_rpy {
            rpy_to_matrix(rpy[0], rpy[1], rpy[2])
        } else {
            let norm = quat.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-6 {
                return Err(err(
                    name,
                    Some(line),
                    Some("qw"),
                    format!("not a unit quaternion (norm {norm})"),
                ));
            }
            quaternion_to_matrix(&quat).map_err(|e| {
                err(
                    name,
                    Some(line),
                    Some("qw"),
                    format!("not a unit quaternion: {e}"),
                )
            })?
        };
        out.push(ToolPose {
            pose_id: id,
            pose: transform(r, Vector3::new(p[0], p[1], p[2])),
            q_hint: if hint.iter().all(|v| v.is_finite()) {
                hint
            } else {
                Vec::new()
            },
            line,
        });
    }
    if out.is_empty() {
        return Err(err(
            name,
            Some(header_line),
            None,
            "no reference poses".into(),
        ));
    }
    Ok(out)
}

/// Writes a tool specification: comments, then `pose_id,x_mm,y_mm,z_mm,roll_deg,
/// pitch_deg,yaw_deg` (rounded to 1e-6 mm and 1e-9°) and the nominal configuration as
/// `extra_q1_rad…` (full precision).
pub fn write_tool<const N: usize>(
    out: &mut dyn Write,
    comments: &[String],
    poses: &[Transform],
    configs: &[[f64; N]],
) -> io::Result<()> {
    for c in comments {
        writeln!(out, "# {c}")?;
    }
    let mut header = vec![
        "pose_id".to_string(),
        "x_mm".into(),
        "y_mm".into(),
        "z_mm".into(),
        "roll_deg".into(),
        "pitch_deg".into(),
        "yaw_deg".into(),
    ];
    header.extend((1..=N).map(|k| format!("extra_q{k}_rad")));
    writeln!(out, "{}", header.join(","))?;
    for (l, (t, q)) in poses.iter().zip(configs).enumerate() {
        let p = t.translation.vector * 1e3;
        let rpy = matrix_to_rpy(t.rotation.matrix()).map(f64::to_degrees);
        // A drawing needs no more than nanometres and nano-degrees: rounding there removes
        // the binary noise of metre → millimetre (216.00000000000003) and −0.
        let clean = |v: f64, step: f64| {
            let r = (v / step).round() * step;
            format_f64(if r == 0.0 { 0.0 } else { r })
        };
        let mut row = vec![(l + 1).to_string()];
        row.extend([p.x, p.y, p.z].iter().map(|v| clean(*v, 1e-6)));
        row.extend(rpy.iter().map(|v| clean(*v, 1e-9)));
        row.extend(q.iter().map(|v| format_f64(*v)));
        writeln!(out, "{}", row.join(","))?;
    }
    Ok(())
}

/// The quaternion of a pose (w, x, y, z), for pose outputs.
pub fn quaternion(t: &Transform) -> [f64; 4] {
    matrix_to_quaternion(t.rotation.matrix())
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::aria;

    #[test]
    fn table2_round_trips_through_a_tool_file() {
        let poses: Vec<Transform> = (0..10).map(|l| aria::tool_pose(l).unwrap()).collect();
        let q = vec![[0.5; 6]; 10];
        let mut buf = Vec::new();
        write_tool(&mut buf, &["robot: aria".into()], &poses, &q).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("# robot: aria\npose_id,x_mm,y_mm,z_mm,roll_deg"));
        let back = parse_tool(&text, "t.csv").unwrap();
        assert_eq!(back.len(), 10);
        for (a, b) in back.iter().zip(&poses) {
            assert!((a.pose.translation.vector - b.translation.vector).norm() < 1e-9);
            assert!((a.pose.rotation.matrix() - b.rotation.matrix()).norm() < 1e-10);
        }
        assert_eq!(back[0].line, 3);
        assert_eq!(back[0].q_hint, vec![0.5; 6]);
        assert_eq!(back[9].pose_id.as_deref(), Some("10"));
    }

    #[test]
    fn metres_radians_and_quaternions_are_read() {
        let t = "x,y,z,qw,qx,qy,qz\n0.5,0.1,0.2,1,0,0,0\n";
        let p = parse_tool(t, "q.csv").unwrap();
        assert_eq!(p[0].pose.translation.vector.x, 0.5);
        let t = "y_mm,x_mm,z_mm,yaw_deg,pitch_deg,roll_deg\n100,500,200,0,0,-150\n";
        let p = parse_tool(t, "r.csv").unwrap();
        assert!((p[0].pose.translation.vector.x - 0.5).abs() < 1e-15);
        let want = aria::tool_pose(0).unwrap().rotation;
        assert!((p[0].pose.rotation.matrix() - want.matrix()).norm() < 1e-12);
    }

    #[test]
    fn bad_files_name_line_and_column() {
        let e = parse_tool("x,y,z,roll,pitch\n1,2,3,0,0\n", "a.csv").unwrap_err();
        assert!(e.to_string().contains("a.csv:1"), "{e}");
        let e = parse_tool("x,y,z,roll,pitch,yaw,colour\n", "b.csv").unwrap_err();
        assert!(e.to_string().contains("column 'colour'"), "{e}");
        let e = parse_tool("# c\nx,y,z,roll,pitch,yaw\n1,2,zz,0,0,0\n", "c.csv").unwrap_err();
        assert!(e.to_string().starts_with("c.csv:3: column 'z'"), "{e}");
        let e = parse_tool("x,y,z,qw,qx,qy,qz\n1,2,3,2,0,0,0\n", "d.csv").unwrap_err();
        assert!(e.to_string().contains("d.csv:2"), "{e}");
        let e = parse_tool("x,y,z,roll,pitch,yaw\n", "e.csv").unwrap_err();
        assert!(e.to_string().contains("no reference poses"), "{e}");
        let e = parse_tool("x,x_mm,y,z,roll,pitch,yaw\n", "f.csv").unwrap_err();
        assert!(e.to_string().contains("exactly one"), "{e}");
    }
}
