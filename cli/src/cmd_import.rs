//! `kincal import-dataset NAME DIR --out DATA.csv --robot-out ROBOT.toml`: a public
//! real-robot data set, read as it is published, as a measurement CSV and a robot
//! description (adapters in `datasets.rs`).

use std::path::PathBuf;

use crate::datasets::{self, UNUSABLE, USABLE};
use crate::error::CliError;
use crate::measurements::write_measurements_csv;

pub const LONG_ABOUT: &str = "\
Reads one of the public real-robot calibration data sets in its published layout (DIR is
the set's folder, e.g. ../shared/realdata/figaroh-ur10e) and writes the measurement CSV
(spec/measurements.md; comment lines give the source files with their SHA-256, the robot,
and every assumption) and the nominal robot description (docs/robot-description.md) for it.
Nothing of the set is changed: rows keep their order, pose_id is the set's sample label
(row number, sample number or time stamp), units are converted to m / rad only.

Sets (--list prints them with what they measure):
  figaroh-ur10e           UR10e, eye-in-hand camera, 6-D poses; robot from the set's URDF
  robotkinecal-fr3        FR3, eye-in-hand camera, 6-D poses; Franka's published kinematics
                          (docs/robots/fr3.toml) with the set's camera mount as the tool
  figaroh-talos-arm       TALOS torso + arm, one mocap marker, positions only; 9 joints, of
                          which arm_left_5_joint (|q| < 0.026 rad here) is held at 0, with
                          the bound of what that changes printed
  ical-2axis-positioner   two-axis positioner, static sensor, 6-D poses; DH of the README
figaroh-tiago-mocap, figaroh-mate-planes, mukca and hilti-jaibot-stationing are refused with
the reason (prismatic joints, unclear provenance, no external instrument, licence).

In every set the frame of the measurements and the measured frame on the robot are unknown:
calibrate with --effects base_frame,tool_frame --init-frames (see `kincal help calibrate`),
or cross-validate with `kincal crossval` (it does the same in every fold).";

pub const EXAMPLE: &str = "\
Example:
  kincal import-dataset figaroh-ur10e ../shared/realdata/figaroh-ur10e \\
      --out ur10e.csv --robot-out ur10e.toml
  kincal calibrate ur10e.csv --robot ur10e.toml --effects base_frame,tool_frame \\
      --init-frames --out ur10e-model.json";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Data set name (its folder name under realdata)
    #[arg(value_name = "NAME", required_unless_present = "list")]
    pub name: Option<String>,
    /// The data set's folder
    #[arg(value_name = "DIR", required_unless_present = "list")]
    pub dir: Option<PathBuf>,
    /// Measurement CSV to write
    #[arg(long, value_name = "DATA.csv", required_unless_present = "list")]
    pub out: Option<PathBuf>,
    /// Robot description (TOML) to write
    #[arg(long, value_name = "ROBOT.toml")]
    pub robot_out: Option<PathBuf>,
    /// List the data sets and exit
    #[arg(long)]
    pub list: bool,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.list {
        let mut s = String::from("Data sets with an adapter:\n");
        for (n, d) in USABLE {
            s.push_str(&format!("  {n:<24} {d}\n"));
        }
        s.push_str("Not usable as they are:\n");
        for (n, d) in UNUSABLE {
            s.push_str(&format!("  {n:<24} {d}\n"));
        }
        crate::report::emit(&s);
        return Ok(());
    }
    let (Some(name), Some(dir), Some(out)) = (&args.name, &args.dir, &args.out) else {
        return Err(CliError::usage("NAME, DIR and --out are required"));
    };
    let imported = datasets::import(name, dir)?;
    let inputs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    let input_refs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    if let (Some(r), o) = (&args.robot_out, out)
        && crate::files::is_same_file(r, o)
    {
        return Err(CliError::usage("--out and --robot-out name the same file"));
    }
    crate::files::write_atomic(out, &input_refs, |w| {
        write_measurements_csv(w, &imported.set)
    })?;
    if let Some(r) = &args.robot_out {
        let text = datasets::robot_text(&imported);
        crate::files::write_atomic(r, &input_refs, |w| w.write_all(text.as_bytes()))?;
    }
    let mut s = format!(
        "{name}: {} poses, {} joints, {} -> {}",
        imported.set.rows.len(),
        datasets::n_joints(&imported.robot),
        if imported.set.orientation_form.is_some() {
            "full poses"
        } else {
            "positions only"
        },
        out.display()
    );
    if let Some(r) = &args.robot_out {
        s.push_str(&format!(
            ", robot '{}' -> {}",
            imported.robot.name,
            r.display()
        ));
    }
    s.push('\n');
    for n in &imported.notes {
        s.push_str(&format!("  note: {n}\n"));
    }
    crate::report::emit(&s);
    Ok(())
}
