//! `kincal observed-point DATA --out DATA2.csv`: camera poses re-expressed at the point the
//! camera looks at (core: `kincal::view_point`).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use kincal::view_point::{Axis, ViewPoint, moved_to_point, view_point};

use crate::error::{CliError, core_error};
use kincal_io::data;
use kincal_io::measurements::{ReadOptions, read_measurements, write_measurements_csv};

pub const LONG_ABOUT: &str = "\
Re-expresses measured camera poses at the point the camera looks at. A camera that gets
its pose from a board (or any target) seen at distance s knows the target's position in
its own frame well and its orientation less well; its own position then carries the
orientation error times s (0.2° at 0.5 m: 1.7 mm), correlated with the orientation error.
Calibrating on those positions reads that noise as geometry.

Each row's pose T is replaced by T·Trans(s·e), e the viewing axis (--axis, default z: the
optical axis of OpenCV and ROS optical frames), and the row gets point_x, point_y,
point_z = s·e: it measures that point of the camera's rigid body, the orientation is
unchanged (spec/measurements.md; `kincal help calibrate`). Nothing is lost: the original
pose is T = T'·Trans(−s·e). Held-out position errors of `crossval` are then errors at the
observed point.

--distance auto (default) takes s from the data: the point nearest (least squares) to all
viewing axes, s the mean distance to it along the axes. The command refuses when the axes
do not converge (RMS miss above --max-miss-fraction × s, default 0.25: the camera did not
look at one place; the miss is the lever arm left) or the point lies behind a camera; --distance METRES forces s.

DATA must hold full poses (position and orientation in every row) and no point columns.
The report gives the point, the distances and how closely every axis passes it.";

pub const EXAMPLE: &str = "\
Example:
  kincal import-dataset figaroh-ur10e ../shared/realdata/figaroh-ur10e --out ur10e.csv \\
      --robot-out ur10e.toml
  kincal observed-point ur10e.csv --out ur10e-at-board.csv
  kincal crossval ur10e-at-board.csv --robot ur10e.toml --effects base_frame,tool_frame \\
      --init-frames";

/// Default of --max-miss-fraction: the viewing axes must pass the point within a quarter
/// of the viewing distance (RMS). The lever arm left between the re-expressed point and
/// what the camera saw is about that miss, so the orientation noise then reaches the
/// position at most a quarter as much as at the camera.
pub const DEFAULT_MAX_MISS_FRACTION: f64 = 0.25;

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Measurement CSV with full camera poses
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Measurement CSV to write (poses at the observed point, point_x/y/z columns)
    #[arg(long, value_name = "DATA2.csv")]
    pub out: PathBuf,
    /// Distance s along the viewing axis [m], or `auto` (from where the axes converge)
    #[arg(long, value_name = "auto|METRES", default_value = "auto")]
    pub distance: String,
    /// The camera frame's viewing axis
    #[arg(long, value_name = "x|y|z", default_value = "z")]
    pub axis: String,
    /// With --distance auto: largest RMS distance of the axes from the point, as a
    /// fraction of the viewing distance
    #[arg(long, value_name = "F", default_value_t = DEFAULT_MAX_MISS_FRACTION)]
    pub max_miss_fraction: f64,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let axis = match args.axis.as_str() {
        "x" => Axis::X,
        "y" => Axis::Y,
        "z" => Axis::Z,
        other => {
            return Err(CliError::usage(format!(
                "--axis: '{other}' is not one of x, y, z"
            )));
        }
    };
    let forced = match args.distance.as_str() {
        "auto" => None,
        s => match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Some(v),
            _ => {
                return Err(CliError::usage(format!(
                    "--distance: '{s}' is neither 'auto' nor a positive distance in metres"
                )));
            }
        },
    };
    if !(args.max_miss_fraction.is_finite() && args.max_miss_fraction > 0.0) {
        return Err(CliError::usage(format!(
            "--max-miss-fraction: {} must be a positive number",
            args.max_miss_fraction
        )));
    }

    let n_joints = joint_columns(&args.data)?;
    let mut opts = ReadOptions::new(n_joints);
    opts.require_pose = true;
    let mut set = read_measurements(&args.data, &opts)?;
    let src = set.source.clone();
    if set.has_point {
        return Err(CliError::input(format!(
            "{src}: the file already has point_x, point_y, point_z: its rows measure points, \
             not camera frames"
        )));
    }
    let mut poses = Vec::with_capacity(set.rows.len());
    for row in &set.rows {
        match (row.orientation, data::measured_pose(row, &src)?) {
            (Some(_), Some((t, _))) => poses.push(t),
            _ => {
                return Err(CliError::input(format!(
                    "{src}:{}: no orientation: a camera pose needs x, y, z and an orientation \
                     in every row",
                    row.line
                )));
            }
        }
    }
    let lines: Vec<u64> = set.rows.iter().map(|r| r.line).collect();
    let line_of = |i: usize| lines.get(i).copied();
    let seen = view_point(&poses, axis).map_err(|e| match e {
        kincal::Error::RankDeficient { .. } if forced.is_none() => CliError::input(format!(
            "{src}: the viewing axes are parallel: they converge on no point; give \
             --distance METRES"
        )),
        e => core_error(e, &src, line_of),
    });
    let s = match (forced, &seen) {
        (Some(s), _) => s,
        (None, Ok(v)) => {
            check_convergence(v, args.max_miss_fraction, &src, line_of)?;
            v.mean_distance_m
        }
        (None, Err(e)) => return Err(e.clone()),
    };

    let u = axis.unit();
    let point = [s * u[0], s * u[1], s * u[2]];
    for (row, t) in set.rows.iter_mut().zip(&poses) {
        let m = moved_to_point(t, &point);
        let p = m.translation.vector;
        row.position_m = Some([p.x, p.y, p.z]);
        row.point_m = Some(point);
    }
    set.has_point = true;
    set.comments.push(format!(
        " observed-point: poses moved by s = {s} m along their {} axis (kincal observed-point); \
         point_x..z = that point in the camera (tool) frame; the original pose is \
         T'·Trans(-point)",
        args.axis
    ));
    kincal_io::files::write_atomic(&args.out, &[&args.data], |w| {
        write_measurements_csv(w, &set)
    })?;

    let mut r = format!(
        "{}: {} camera poses re-expressed {:.1} mm along {} ({}) -> {}\n",
        src,
        poses.len(),
        s * 1e3,
        args.axis,
        if forced.is_some() { "given" } else { "auto" },
        args.out.display()
    );
    if let Ok(v) = &seen {
        r.push_str(&format!(
            "  viewing axes converge at ({:.4}, {:.4}, {:.4}) m (frame of the poses): \
             distance {:.1}..{:.1} mm (mean {:.1}), miss RMS {:.1} mm, max {:.1} mm (line {})\n",
            v.point_m[0],
            v.point_m[1],
            v.point_m[2],
            v.min_distance_m * 1e3,
            v.max_distance_m * 1e3,
            v.mean_distance_m * 1e3,
            v.miss_rms_m * 1e3,
            v.miss_max_m * 1e3,
            line_of(v.miss_max_pose).unwrap_or(0),
        ));
    }
    crate::report::emit(&r);
    Ok(())
}

/// Refuses axes that do not look at one place, or a point behind a camera.
fn check_convergence(
    v: &ViewPoint,
    max_fraction: f64,
    src: &str,
    line_of: impl Fn(usize) -> Option<u64>,
) -> Result<(), CliError> {
    if v.min_distance_m <= 0.0 {
        return Err(CliError::input(format!(
            "{src}: the point where the viewing axes converge lies behind a camera (distance \
             {:.1} mm): wrong --axis, or the poses are not camera poses",
            v.min_distance_m * 1e3
        )));
    }
    if v.miss_rms_m > max_fraction * v.mean_distance_m {
        return Err(CliError::input(format!(
            "{src}: the viewing axes do not converge: they pass the nearest point at {:.1} mm \
             RMS (worst {:.1} mm, line {}) for a viewing distance of {:.1} mm, above \
             --max-miss-fraction {} of it: the camera did not look at one place; give \
             --distance METRES to re-express anyway",
            v.miss_rms_m * 1e3,
            v.miss_max_m * 1e3,
            line_of(v.miss_max_pose).unwrap_or(0),
            v.mean_distance_m * 1e3,
            max_fraction
        )));
    }
    Ok(())
}

/// The number of joint columns q1..qN in the header of `path` (comment lines skipped): the
/// command needs no robot, the full reader then checks the file against that N.
fn joint_columns(path: &Path) -> Result<usize, CliError> {
    let shown = path.display();
    let f = std::fs::File::open(path)
        .map_err(|e| CliError::input(format!("{shown}: cannot open the file: {e}")))?;
    for (i, line) in BufReader::new(f).lines().enumerate() {
        let line = line.map_err(|e| CliError::input(format!("{shown}:{}: {e}", i + 1)))?;
        let line = line.trim_start_matches('\u{feff}');
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let n = line
            .split(',')
            .map(str::trim)
            .filter(|c| {
                c.strip_prefix('q')
                    .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
            })
            .count();
        if n == 0 {
            return Err(CliError::input(format!(
                "{shown}:{}: the header has no joint columns q1..qN",
                i + 1
            )));
        }
        return Ok(n);
    }
    Err(CliError::input(format!("{shown}: no header line")))
}
