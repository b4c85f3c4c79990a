//! `kincal import-dataset NAME DIR --out DATA.csv --robot-out ROBOT.toml`: a public
//! real-robot data set, read as it is published, as a measurement CSV and a robot
//! description (adapters in `datasets.rs`).

use std::path::PathBuf;

use crate::error::CliError;
use kincal_io::datasets::{self, NEEDS, UNUSABLE, USABLE};
use kincal_io::datasets_contact::{self, ContactOptions};
use kincal_io::datasets_tiago;
use kincal_io::measurements::write_measurements_csv;

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
  figaroh-talos-arm       TALOS torso + arm, one mocap marker, positions only; 9 joints
                          (torso 2 + arm 7), all modelled
  ical-2axis-positioner   two-axis positioner, static sensor, 6-D poses; DH of the README
  mukca                   MUKCa ball-in-socket plate, no instrument (--robot-id ID, e.g.
                          panda_1, panda_1_with_sensor, kuka_14, dinova_1): each location a
                          session with targets LOCATION/s0 and /s1, and --constraints-out
                          with their 50 mm distances; robot = the set's URDF up to ball_link
  figaroh-mate-planes     3-joint arm touching three known planes: one coordinate per row,
                          plus the set's 10 full poses
  hilti (hilti-jaibot-stationing)  lifting column + 6R arm, total-station prism positions,
                          each floor a session, accelerometer tilts as sensor joints, temp_c;
                          robot = the set's URDF (base_link -> prism) + 4 sensor joints.
                          CC BY-NC-SA 3.0 (non-commercial). --study prints the held-out
                          study of docs/real-data.md
  tiago (figaroh-tiago-mocap)  TIAGo torso lift (prismatic) + 7R arm, one motion-capture
                          point on the hand, positions only (points 2-4 kept as extra_
                          columns); needs --urdf TIAGO.urdf: PAL's TIAGo URDF is CC BY-NC-ND
                          and not shipped (pal-robotics/tiago_robot, tiago_description).
                          Default chain base_footprint -> arm_7_link
--base-link/--tip-link override the chain of mukca's, MATE's and TIAGo's URDF.

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
    /// Constraints file (TOML) to write: the known geometry of a contact set (mukca)
    #[arg(long, value_name = "CONSTRAINTS.toml")]
    pub constraints_out: Option<PathBuf>,
    /// mukca: the robot whose recordings to import (a folder of the set's data/)
    #[arg(long, value_name = "ID")]
    pub robot_id: Option<String>,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// tiago: the robot's URDF (not shipped with the set: CC BY-NC-ND)
    #[arg(long, value_name = "TIAGO.urdf")]
    pub urdf: Option<PathBuf>,
    /// List the data sets and exit
    #[arg(long)]
    pub list: bool,
    /// hilti: also run the held-out study (docs/real-data.md) and print its table
    #[arg(long)]
    pub study: bool,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.list {
        let mut s = String::from("Data sets with an adapter:\n");
        for (n, d) in USABLE {
            s.push_str(&format!("  {n:<24} {d}\n"));
        }
        s.push_str("Usable with what you add:\n");
        for (n, d) in NEEDS {
            s.push_str(&format!("  {n:<24} {d}\n"));
        }
        if !UNUSABLE.is_empty() {
            s.push_str("Not usable as they are:\n");
            for (n, d) in UNUSABLE {
                s.push_str(&format!("  {n:<24} {d}\n"));
            }
        }
        crate::report::emit(&s);
        return Ok(());
    }
    let (Some(name), Some(dir), Some(out)) = (&args.name, &args.dir, &args.out) else {
        return Err(CliError::usage("NAME, DIR and --out are required"));
    };
    let is_tiago = datasets_tiago::NAMES.contains(&name.as_str());
    if args.urdf.is_some() && !is_tiago {
        return Err(CliError::usage(format!(
            "--urdf applies to the TIAGo set (tiago), whose URDF is not shipped; '{name}' brings its robot"
        )));
    }
    if datasets_contact::CONTACT_SETS.contains(&name.as_str()) {
        return run_contact(args, name, dir, out);
    }
    if args.robot_id.is_some() || args.constraints_out.is_some() {
        return Err(CliError::usage(format!(
            "--robot-id and --constraints-out apply to the contact sets ({}), not to '{name}'",
            datasets_contact::CONTACT_SETS.join(", ")
        )));
    }
    if args.chain != kincal_io::robot_arg::UrdfChainArgs::default() && !is_tiago {
        return Err(CliError::usage(format!(
            "--base-link/--tip-link apply to the contact sets ({}) and tiago; '{name}' has a fixed robot",
            datasets_contact::CONTACT_SETS.join(", ")
        )));
    }
    let imported = if is_tiago {
        datasets_tiago::import(dir, args.urdf.as_deref(), &args.chain)?
    } else {
        datasets::import(name, dir)?
    };
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    inputs.extend(args.urdf.clone());
    let input_refs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    if let (Some(r), o) = (&args.robot_out, out)
        && kincal_io::files::is_same_file(r, o)
    {
        return Err(CliError::usage("--out and --robot-out name the same file"));
    }
    kincal_io::files::write_atomic(out, &input_refs, |w| {
        write_measurements_csv(w, &imported.set)
    })?;
    if let Some(r) = &args.robot_out {
        let text = datasets::robot_text(&imported);
        kincal_io::files::write_atomic(r, &input_refs, |w| w.write_all(text.as_bytes()))?;
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
    if args.study {
        if !matches!(name.as_str(), "hilti" | "hilti-jaibot-stationing") {
            return Err(CliError::usage("--study applies to the hilti set only"));
        }
        s.push_str(&study_text(&kincal_io::hilti_study::study(dir)?));
    }
    crate::report::emit(&s);
    Ok(())
}

/// The Hilti study as the tables docs/real-data.md show (RMS of |Δp| in mm).
fn study_text(st: &kincal_io::hilti_study::Study) -> String {
    let floor = 3f64.sqrt() * kincal_io::datasets_hilti::SIGMA_POS_M * 1e3;
    let fin = &st.final_model;
    let gains: Vec<String> = fin.gains.iter().map(|g| format!("{g:.3}")).collect();
    let mut s = format!(
        "Hilti study (RMS |dp| in mm; noise floor sqrt(3)*0.75 = {floor:.2} mm)\n\
         final model: {}\n\
         flat in-sample: geometry {:.2}, geometry + sensor joints {:.2}\n\
         flat held-out (5 folds): geometry + sensor joints {:.2} ({:.2}x the floor)\n\
         gains 1+k (column bending x, y): {}\n\
         session            CAD+rigid base   geometry (flat)   geometry+sensors (flat)   leave-one-session-out\n",
        fin.variant.name,
        st.geometry.flat_in_sample_mm,
        fin.flat_in_sample_mm,
        fin.flat_held_out_mm,
        fin.flat_held_out_mm / floor,
        gains.join(", "),
    );
    for (name, cad) in &st.cad_mm {
        let loso = st
            .loso_mm
            .iter()
            .find(|l| &l.0 == name)
            .map_or(f64::NAN, |l| l.1);
        let geo = st.geometry.transfer_mm.iter().find(|t| &t.0 == name);
        let sensors = fin.transfer_mm.iter().find(|t| &t.0 == name);
        match (geo, sensors) {
            (Some((_, g)), Some((_, b))) => s.push_str(&format!(
                "{name:<18} {cad:>14.2} {g:>17.2} {b:>24.2} {loso:>23.2}\n"
            )),
            _ => s.push_str(&format!(
                "{name:<18} {cad:>14.2} {:>17} {:>24} {loso:>23.2}\n",
                "(training)", "(training)"
            )),
        }
    }
    s.push_str(
        "variants trained on flat: in-sample, held out (5 folds), then each other floor with a \
         new base only | the variant, its gains 1+k\n",
    );
    for (i, v) in st.variants.iter().enumerate() {
        let transfer: Vec<String> = v
            .transfer_mm
            .iter()
            .map(|t| format!("{:.2}", t.1))
            .collect();
        let gains: Vec<String> = v.gains.iter().map(|g| format!("{g:.2}")).collect();
        s.push_str(&format!(
            "variant {}: {:.2} {:.2} {} | {} ({})\n",
            i + 1,
            v.flat_in_sample_mm,
            v.flat_held_out_mm,
            transfer.join(" "),
            v.variant.name,
            gains.join(", ")
        ));
    }
    s.push_str(
        "level new frame (a turn about the vertical and a shift), trained on flat: each floor's \
         RMS | the variant; then the free frame's tilt about x, y [mrad]\n",
    );
    for (i, l) in st.level.iter().enumerate() {
        let rms: Vec<String> = l.sessions.iter().map(|t| format!("{:.2}", t.1)).collect();
        let tilt: Vec<String> = l
            .sessions
            .iter()
            .map(|t| format!("{} {:+.1} {:+.1}", t.0, t.2[0] * 1e3, t.2[1] * 1e3))
            .collect();
        s.push_str(&format!(
            "level {}: {} | {}\nfree frame tilt {}: {}\n",
            i + 1,
            rms.join(" "),
            l.variant.name,
            i + 1,
            tilt.join(", ")
        ));
    }
    s
}

/// Files that must differ from each other (and from the inputs, checked by `write_atomic`).
fn distinct(paths: &[&std::path::Path]) -> Result<(), CliError> {
    for (i, a) in paths.iter().enumerate() {
        for b in paths.iter().skip(i + 1) {
            if kincal_io::files::is_same_file(a, b) {
                return Err(CliError::usage(format!(
                    "--out, --robot-out and --constraints-out must name different files ({} twice)",
                    a.display()
                )));
            }
        }
    }
    Ok(())
}

/// A contact set (mukca, figaroh-mate-planes): CSV with targets/sessions or partial
/// coordinates, its constraints file, its robot.
fn run_contact(
    args: &Args,
    name: &str,
    dir: &std::path::Path,
    out: &std::path::Path,
) -> Result<(), CliError> {
    let opts = ContactOptions {
        robot_id: args.robot_id.clone(),
        chain: args.chain.clone(),
    };
    if name != "mukca" && args.robot_id.is_some() {
        return Err(CliError::usage("--robot-id applies to mukca only"));
    }
    let imported = datasets_contact::import(name, dir, &opts)?;
    if imported.constraints.is_some() && args.constraints_out.is_none() {
        return Err(CliError::usage(format!(
            "{name}: --constraints-out FILE is required (the set's known distances; calibrate reads it with --constraints)"
        )));
    }
    if imported.constraints.is_none() && args.constraints_out.is_some() {
        return Err(CliError::usage(format!(
            "{name}: the set has no constraints file to write (drop --constraints-out)"
        )));
    }
    let mut outs = vec![out];
    outs.extend(args.robot_out.as_deref());
    outs.extend(args.constraints_out.as_deref());
    distinct(&outs)?;
    let inputs: Vec<PathBuf> = walk_files(dir);
    let input_refs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    kincal_io::files::write_atomic(out, &input_refs, |w| w.write_all(imported.csv.as_bytes()))?;
    if let (Some(c), Some(text)) = (&args.constraints_out, &imported.constraints) {
        kincal_io::files::write_atomic(c, &input_refs, |w| w.write_all(text.as_bytes()))?;
    }
    let mut s = format!(
        "{name}: {} rows ({}), {} joints -> {}",
        imported.rows,
        imported.what,
        datasets::n_joints(&imported.robot),
        out.display()
    );
    if let Some(r) = &args.robot_out {
        let mut text = String::new();
        for c in &imported.robot_comments {
            text.push_str(&format!("#{c}\n"));
        }
        text.push_str(&kincal_io::robot_file::write_robot_description(
            &imported.robot,
        ));
        kincal_io::files::write_atomic(r, &input_refs, |w| w.write_all(text.as_bytes()))?;
        s.push_str(&format!(
            ", robot '{}' -> {}",
            imported.robot.name,
            r.display()
        ));
    }
    if let Some(c) = &args.constraints_out {
        s.push_str(&format!(", constraints -> {}", c.display()));
    }
    s.push('\n');
    for n in &imported.notes {
        s.push_str(&format!("  note: {n}\n"));
    }
    crate::report::emit(&s);
    Ok(())
}

/// Every file below `dir` (the inputs an output must not overwrite).
fn walk_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out
}
