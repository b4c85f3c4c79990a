//! `kincal markers EXPORT --design DESIGN.toml --joints JOINTS.csv --robot ROBOT --out
//! DATA.csv`: motion-capture marker positions to measured end-effector poses (spec/aria.md,
//! Section 5.1), by rigid registration of the base and probe markers in every frame
//! (`kincal::registration`), with per-marker residuals and named outliers.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::Robot;
use kincal::pose::{Transform, matrix_to_quaternion};
use kincal::registration::{
    MarkerBody, MarkerStatus, Markers, Registration, RegistrationOptions, design_symmetry, register,
};
use serde::Deserialize;

use crate::args::positive;
use crate::error::CliError;
use kincal_io::measurements::{
    MeasurementRow, MeasurementSet, Orientation, OrientationForm, ReadOptions, parse_measurements,
    write_measurements_csv,
};
use kincal_io::robot_arg;

pub const LONG_ABOUT: &str = "\
Turns a motion-capture marker export into the measurement CSV. In every frame the base
markers (fixed to the robot base, design positions known in the robot base frame) and the
probe markers (on the end effector, design positions known in the tool frame) are each fitted
by a weighted rigid registration (Horn's method, kincal::registration); the end-effector
pose in the robot base frame is T_base_ee = T_mocap_base⁻¹ · T_mocap_probe (spec/aria.md,
Section 5.1). Without a [base] table the mocap frame is taken as the base frame (calibrate
then with --effects base_frame).

EXPORT (CSV, long format, one row per marker and frame): columns frame, marker, x, y, z
(lengths in m, or x_mm, y_mm, z_mm). A marker not seen in a frame has empty x, y, z or no
row; a marker name not in the design is an error.

DESIGN (TOML):
    units = \"mm\"            # \"m\" (default) or \"mm\", for the positions below
    sigma_mm = 0.2           # the system's noise, 1σ per axis (or --sigma-pos-mm)
    [base]                   # optional: name = [x, y, z] in the robot base frame
    B1 = [300, 0, 0]
    [probe]                  # name = [x, y, z] in the tool frame (at least 3, not collinear)
    P1 = [0, 0, 0]

JOINTS (CSV): a column frame naming the export's frame, then the measurement-CSV columns
q1..qN (and optionally pose_id, s1..sN, temp_c, extra_*), checked as for `calibrate`.

Outliers: a marker whose residual exceeds k·σ (--k-sigma, default 4) is excluded when the
remaining markers then fit (up to --max-outliers per body) and named: swapped (two labels
exchanged), moved (knocked, ghost, wrong label); occluded markers are named as missing.
Frames that cannot be registered (fewer than 3 markers, collinear markers, no consistent
subset, no markers at all) are never dropped silently: by default the command refuses and
lists them (exit 3); with --skip-failed they are left out of DATA.csv, listed on stdout
and in DATA.csv's comment lines. Export frames without joint readings are listed as unused.

Prints per-marker residual statistics (RMS and max over the frames, how often flagged), every
flagged marker with its frame, and how much the base registration moves between frames
(a moved base shows there). --residuals FILE.csv writes every marker of every frame:
frame, body, marker, status, residual dx, dy, dz and distance [mm], threshold [mm].

--points writes position-only rows instead: one row per consistent probe marker and frame,
its measured position in the base frame with point_x, point_y, point_z = its design position
(rows of a frame share the pose_id): for probes too small to give a reliable orientation, or
laser-tracker reflectors. A frame needs only 1 probe marker then; outliers are still
screened where 3 or more are visible.";

pub const EXAMPLE: &str = "\
Example:
  kincal markers mocap.csv --design probe.toml --joints joints.csv --robot aria \\
      --out poses.csv --residuals marker-residuals.csv";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Marker export CSV (frame, marker, x, y, z)
    #[arg(value_name = "EXPORT")]
    pub export: PathBuf,
    /// Marker design (TOML: units, sigma_mm, [base], [probe])
    #[arg(long, value_name = "DESIGN.toml")]
    pub design: PathBuf,
    /// Joint readings per frame (CSV: frame, q1..qN, ...)
    #[arg(long, value_name = "JOINTS.csv")]
    pub joints: PathBuf,
    /// Built-in robot name or robot description file (joint count and limits)
    #[arg(long, value_name = "ROBOT")]
    pub robot: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Measurement CSV to write
    #[arg(long, value_name = "DATA.csv")]
    pub out: PathBuf,
    /// Marker noise, 1σ per axis [mm] (overrides the design's sigma_mm; alias --sigma-mm)
    #[arg(long = "sigma-pos-mm", alias = "sigma-mm", value_name = "S", value_parser = crate::args::sigma_mm)]
    pub sigma_mm: Option<f64>,
    /// Outlier threshold in units of σ on a marker's 3-D residual
    #[arg(long, value_name = "K", default_value = "4", value_parser = positive)]
    pub k_sigma: f64,
    /// Most markers excluded per body and frame (0 to 3)
    #[arg(long, value_name = "N", default_value_t = 2)]
    pub max_outliers: usize,
    /// Leave frames that cannot be registered out of DATA.csv (listed) instead of refusing
    #[arg(long)]
    pub skip_failed: bool,
    /// Position-only rows, one per probe marker (point_x/y/z = its design position)
    #[arg(long)]
    pub points: bool,
    /// Per-marker residuals of every frame (CSV)
    #[arg(long, value_name = "FILE.csv")]
    pub residuals: Option<PathBuf>,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct DesignFile {
    units: Option<String>,
    sigma_mm: Option<f64>,
    base: Option<BTreeMap<String, [f64; 3]>>,
    probe: BTreeMap<String, [f64; 3]>,
}

/// The marker design: names and positions [m] of each body.
struct Design {
    base: Vec<(String, [f64; 3])>,
    probe: Vec<(String, [f64; 3])>,
    sigma_m: Option<f64>,
}

fn read_design(path: &Path) -> Result<Design, CliError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let d: DesignFile =
        toml::from_str(&text).map_err(|e| CliError::input(format!("{name}: {e}")))?;
    let scale = match d.units.as_deref() {
        None | Some("m") => 1.0,
        Some("mm") => 1e-3,
        Some(u) => {
            return Err(CliError::input(format!(
                "{name}: units = {u:?}: expected \"m\" or \"mm\""
            )));
        }
    };
    let conv =
        |body: &str, m: BTreeMap<String, [f64; 3]>| -> Result<Vec<(String, [f64; 3])>, CliError> {
            let mut v = Vec::new();
            for (k, p) in m {
                if p.iter().any(|x| !x.is_finite()) {
                    return Err(CliError::input(format!(
                        "{name}: [{body}] {k}: expected finite numbers"
                    )));
                }
                v.push((k, p.map(|x| x * scale)));
            }
            if v.len() > kincal::registration::MAX_MARKERS {
                return Err(CliError::input(format!(
                    "{name}: [{body}] has {} markers, at most {} supported",
                    v.len(),
                    kincal::registration::MAX_MARKERS
                )));
            }
            Ok(v)
        };
    let base = conv("base", d.base.unwrap_or_default())?;
    let probe = conv("probe", d.probe)?;
    if probe.is_empty() {
        return Err(CliError::input(format!("{name}: [probe] has no markers")));
    }
    if !base.is_empty() && base.len() < 3 {
        return Err(CliError::input(format!(
            "{name}: [base] has {} markers: at least 3 (not collinear) are needed, or none",
            base.len()
        )));
    }
    if let Some(dup) = base.iter().find(|(b, _)| probe.iter().any(|(p, _)| p == b)) {
        return Err(CliError::input(format!(
            "{name}: marker {} is in both [base] and [probe]",
            dup.0
        )));
    }
    let sigma_m = match d.sigma_mm {
        Some(s) if s.is_finite() && s > 0.0 => Some(s * 1e-3),
        Some(s) => {
            return Err(CliError::input(format!(
                "{name}: sigma_mm = {s}: expected a number > 0"
            )));
        }
        None => None,
    };
    Ok(Design {
        base,
        probe,
        sigma_m,
    })
}

/// One frame of the export: positions [m] by marker (None: not seen).
struct Frame {
    markers: HashMap<String, Option<[f64; 3]>>,
}

/// The export's frames in order of first appearance.
fn read_export(path: &Path, design: &Design) -> Result<Vec<(String, Frame)>, CliError> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| CliError::input(format!("{name}:1: {e}")))?
        .iter()
        .map(|h| h.trim().to_string())
        .collect();
    let find = |n: &str| header.iter().position(|h| h == n);
    let need = |n: &str| {
        find(n).ok_or_else(|| {
            CliError::input(format!(
                "{name}: missing column '{n}': expected frame, marker, x, y, z (or x_mm, y_mm, z_mm)"
            ))
        })
    };
    let (fc, mc) = (need("frame")?, need("marker")?);
    let mut xyz = [0usize; 3];
    let mut scale = 1.0;
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        xyz[k] = match (find(a), find(&format!("{a}_m")), find(&format!("{a}_mm"))) {
            (Some(c), None, None) | (None, Some(c), None) => c,
            (None, None, Some(c)) => {
                scale = 1e-3;
                c
            }
            (None, None, None) => need(a)?,
            _ => {
                return Err(CliError::input(format!(
                    "{name}: column '{a}' given in two units: expected one"
                )));
            }
        };
    }
    if header.len() != 5 {
        let extra: Vec<&String> = header
            .iter()
            .enumerate()
            .filter(|(i, _)| ![fc, mc, xyz[0], xyz[1], xyz[2]].contains(i))
            .map(|(_, h)| h)
            .collect();
        return Err(CliError::input(format!(
            "{name}:1: unknown column(s) {extra:?}: expected frame, marker, x, y, z"
        )));
    }
    let known: Vec<&str> = design
        .base
        .iter()
        .chain(&design.probe)
        .map(|(n, _)| n.as_str())
        .collect();
    let mut frames: Vec<(String, Frame)> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| CliError::input(format!("{name}: {e}")))?;
        let line = rec.position().map_or(0, |p| p.line());
        let cell = |c: usize| rec.get(c).unwrap_or("").trim();
        let (frame, marker) = (cell(fc).to_string(), cell(mc).to_string());
        if frame.is_empty() || marker.is_empty() {
            return Err(CliError::input(format!(
                "{name}:{line}: expected a frame label and a marker name, found an empty cell"
            )));
        }
        if !known.contains(&marker.as_str()) {
            return Err(CliError::input(format!(
                "{name}:{line}: column 'marker': {marker:?} is not in the design: expected one of {}",
                known.join(", ")
            )));
        }
        let vals: Vec<&str> = xyz.iter().map(|&c| cell(c)).collect();
        let pos = if vals.iter().all(|v| v.is_empty()) {
            None
        } else {
            let mut p = [0.0; 3];
            for (k, v) in vals.iter().enumerate() {
                p[k] = match v.parse::<f64>() {
                    Ok(x) if x.is_finite() => x * scale,
                    _ => {
                        return Err(CliError::input(format!(
                            "{name}:{line}: column '{}': expected a finite number (or x, y, z all empty for an occluded marker), found {v:?}",
                            header[xyz[k]]
                        )));
                    }
                };
            }
            Some(p)
        };
        let k = *index.entry(frame.clone()).or_insert_with(|| {
            frames.push((
                frame.clone(),
                Frame {
                    markers: HashMap::new(),
                },
            ));
            frames.len() - 1
        });
        if frames[k].1.markers.insert(marker.clone(), pos).is_some() {
            return Err(CliError::input(format!(
                "{name}:{line}: marker {marker} appears twice in frame {frame}"
            )));
        }
    }
    if frames.is_empty() {
        return Err(CliError::input(format!("{name}: no data rows")));
    }
    Ok(frames)
}

/// Reads JOINTS.csv with the measurement reader, its `frame` column carried as an extra.
fn read_joints<const N: usize>(
    path: &Path,
    robot: &Robot<N>,
    allow_out_of_limits: bool,
) -> Result<(MeasurementSet, usize), CliError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    let h = lines
        .iter()
        .position(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .ok_or_else(|| CliError::input(format!("{name}: empty file")))?;
    let ending = if lines[h].ends_with("\r\n") {
        "\r\n"
    } else if lines[h].ends_with('\n') {
        "\n"
    } else {
        ""
    };
    let cells: Vec<String> = lines[h]
        .trim_end_matches(['\r', '\n'])
        .split(',')
        .map(|c| c.trim().to_string())
        .collect();
    let Some(fc) = cells.iter().position(|c| c == "frame") else {
        return Err(CliError::input(format!(
            "{name}:{}: missing column 'frame': expected frame, q1..q{N}",
            h + 1
        )));
    };
    if cells.iter().any(|c| c == "extra_frame") {
        return Err(CliError::input(format!(
            "{name}:{}: column 'extra_frame' is reserved for the frame label",
            h + 1
        )));
    }
    let mut renamed = cells.clone();
    renamed[fc] = "extra_frame".into();
    let header = format!("{}{ending}", renamed.join(","));
    lines[h] = &header;
    let text2: String = lines.concat();
    let mut ro = ReadOptions::new(N);
    ro.joint_limits = Some(robot.limits().iter().map(|l| (l.lower, l.upper)).collect());
    ro.allow_out_of_limits = allow_out_of_limits;
    let set = parse_measurements(text2.as_bytes(), &name, &ro)?;
    if set.has_position {
        return Err(CliError::input(format!(
            "{name}: has pose columns (x, y, z): expected joint readings only, the poses come from the markers"
        )));
    }
    let k = set
        .extra_columns
        .iter()
        .position(|c| c == "extra_frame")
        .unwrap_or(0);
    Ok((set, k))
}

/// One body of one frame: design, measured, visibility, names.
fn body_markers(
    design: &[(String, [f64; 3])],
    frame: Option<&Frame>,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<bool>) {
    let d: Vec<[f64; 3]> = design.iter().map(|(_, p)| *p).collect();
    let mut m = vec![[0.0; 3]; design.len()];
    let mut v = vec![false; design.len()];
    if let Some(f) = frame {
        for (k, (name, _)) in design.iter().enumerate() {
            if let Some(Some(p)) = f.markers.get(name) {
                m[k] = *p;
                v[k] = true;
            }
        }
    }
    (d, m, v)
}

fn status_name(s: MarkerStatus, names: &[(String, [f64; 3])]) -> String {
    match s {
        MarkerStatus::Inlier => "inlier".into(),
        MarkerStatus::Missing => "missing".into(),
        MarkerStatus::Moved => "moved".into(),
        MarkerStatus::Suspect => "suspect".into(),
        MarkerStatus::Swapped { with } => format!(
            "swapped with {}",
            names.get(with).map_or("?", |(n, _)| n.as_str())
        ),
    }
}

/// Per-marker running statistics.
#[derive(Default, Clone)]
struct MarkerStats {
    seen: usize,
    sum_sq: f64,
    max: f64,
    flagged: usize,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.max_outliers > kincal::registration::MAX_OUTLIERS {
        return Err(CliError::usage(format!(
            "--max-outliers {}: at most {}",
            args.max_outliers,
            kincal::registration::MAX_OUTLIERS
        )));
    }
    let spec = robot_arg::resolve_robot(&args.robot, &args.chain)?;
    kincal::with_any_robot!(&spec.robot, r => markers(r, args))
}

fn markers<const N: usize>(robot: &Robot<N>, args: &Args) -> Result<(), CliError> {
    let design = read_design(&args.design)?;
    let sigma_m = args
        .sigma_mm
        .map(|s| s * 1e-3)
        .or(design.sigma_m)
        .ok_or_else(|| {
            CliError::usage(format!(
                "no marker noise stated: give --sigma-pos-mm or sigma_mm in {}",
                args.design.display()
            ))
        })?;
    let opts = RegistrationOptions {
        sigma_m,
        k_sigma: args.k_sigma,
        max_outliers: args.max_outliers,
    };
    let design_notes = symmetry_notes(&design, &opts);
    for note in &design_notes {
        eprintln!("warning: {note}");
    }
    let frames = read_export(&args.export, &design)?;
    let (joints, frame_col) = read_joints::<N>(&args.joints, robot, args.allow_out_of_limits)?;
    check_frame_labels(&joints, frame_col)?;
    let by_label: HashMap<&str, &Frame> = frames.iter().map(|(l, f)| (l.as_str(), f)).collect();
    let outcome = register_frames(&joints, frame_col, &by_label, &design, &opts, args.points);
    let joint_labels: Vec<&str> = joints
        .rows
        .iter()
        .map(|r| r.extras[frame_col].trim())
        .collect();
    let unused: Vec<&str> = frames
        .iter()
        .map(|(l, _)| l.as_str())
        .filter(|l| !joint_labels.contains(l))
        .collect();
    let mut s = report_text(&ReportInputs {
        joints: &joints,
        export_frames: frames.len(),
        sigma_m,
        args,
        design_notes: &design_notes,
        outcome: &outcome,
        unused: &unused,
    });
    let failed = &outcome.failed;
    if !failed.is_empty() && !args.skip_failed {
        crate::report::emit(&s);
        return Err(CliError::input(format!(
            "{} frame(s) could not be registered (listed above); fix the export or the design, or pass --skip-failed to leave them out",
            failed.len()
        )));
    }
    if outcome.rows.is_empty() {
        crate::report::emit(&s);
        return Err(CliError::input(
            "no frame could be registered: nothing to write",
        ));
    }
    write_outputs::<N>(args, &design, &joints, sigma_m, outcome, &mut s)?;
    crate::report::emit(&s);
    Ok(())
}

/// Refuses a joints file with an empty frame label or two rows for one frame.
fn check_frame_labels(joints: &MeasurementSet, frame_col: usize) -> Result<(), CliError> {
    let mut seen = HashMap::new();
    for r in &joints.rows {
        let label = r.extras[frame_col].trim();
        if label.is_empty() {
            return Err(CliError::input(format!(
                "{}:{}: column 'frame': expected a frame label, found an empty cell",
                joints.source, r.line
            )));
        }
        if let Some(prev) = seen.insert(label.to_string(), r.line) {
            return Err(CliError::input(format!(
                "{}:{}: frame {label} already has joint readings (line {prev})",
                joints.source, r.line
            )));
        }
    }
    Ok(())
}

/// Every marker of every registration: the residuals CSV, per-marker statistics and the
/// flagged markers, in the order the frames were registered.
struct MarkerLog {
    residuals_csv: String,
    stats: BTreeMap<(String, String), MarkerStats>,
    flagged: Vec<String>,
}

impl MarkerLog {
    fn new() -> Self {
        MarkerLog {
            residuals_csv: String::from(
                "frame,body,marker,status,dx_mm,dy_mm,dz_mm,distance_mm,threshold_mm\n",
            ),
            stats: BTreeMap::new(),
            flagged: Vec::new(),
        }
    }

    /// Records the markers of one registration of `body` in frame `label`.
    fn record(
        &mut self,
        body: &str,
        names: &[(String, [f64; 3])],
        label: &str,
        reg: &Registration,
    ) {
        for (k, f) in reg.markers().iter().enumerate() {
            let name = &names[k].0;
            let st = self
                .stats
                .entry((body.to_string(), name.clone()))
                .or_default();
            let status = status_name(f.status, names);
            if f.status != MarkerStatus::Missing {
                st.seen += 1;
                st.sum_sq += f.distance_m * f.distance_m;
                st.max = st.max.max(f.distance_m);
            }
            if matches!(
                f.status,
                MarkerStatus::Moved | MarkerStatus::Swapped { .. } | MarkerStatus::Suspect
            ) {
                st.flagged += 1;
                self.flagged.push(format!(
                    "frame {label}: {body} marker {name} {status} (residual {:.3} mm, threshold {:.3} mm)",
                    f.distance_m * 1e3,
                    f.threshold_m * 1e3
                ));
            }
            let _ = writeln!(
                self.residuals_csv,
                "{label},{body},{name},{status},{},{},{},{},{}",
                f.residual_m[0] * 1e3,
                f.residual_m[1] * 1e3,
                f.residual_m[2] * 1e3,
                f.distance_m * 1e3,
                f.threshold_m * 1e3
            );
        }
    }
}

/// What registering every frame produced.
struct Outcome {
    /// The rows of DATA.csv.
    rows: Vec<MeasurementRow>,
    /// Frames left out: label, joints line, why.
    failed: Vec<(String, u64, String)>,
    log: MarkerLog,
    /// The base's registered pose per frame (with base markers).
    base_poses: Vec<(String, Transform)>,
}

/// Registers the base and the probe of every frame with joint readings.
fn register_frames(
    joints: &MeasurementSet,
    frame_col: usize,
    by_label: &HashMap<&str, &Frame>,
    design: &Design,
    opts: &RegistrationOptions,
    points: bool,
) -> Outcome {
    let mut out = Outcome {
        rows: Vec::new(),
        failed: Vec::new(),
        log: MarkerLog::new(),
        base_poses: Vec::new(),
    };
    for r in &joints.rows {
        let label = r.extras[frame_col].trim().to_string();
        let Some(frame) = by_label.get(label.as_str()) else {
            out.failed.push((
                label,
                r.line,
                "no markers in the export for this frame".into(),
            ));
            continue;
        };
        let t_mocap_base = match register_base(design, frame, opts, &label, &mut out) {
            Ok(t) => t,
            Err(why) => {
                out.failed.push((label, r.line, why));
                continue;
            }
        };
        let probe = Probe {
            row: r,
            label: &label,
            design,
            frame,
            to_base: t_mocap_base.inverse(),
            opts,
        };
        let rows = if points {
            probe.point_rows(&mut out.log)
        } else {
            probe.pose_row(&mut out.log).map(|row| vec![row])
        };
        match rows {
            Ok(rows) => out.rows.extend(rows),
            Err(why) => out.failed.push((label, r.line, why)),
        }
    }
    out
}

/// The base's pose in the motion-capture frame (identity without base markers), or why it
/// cannot be registered in this frame.
fn register_base(
    design: &Design,
    frame: &Frame,
    opts: &RegistrationOptions,
    label: &str,
    out: &mut Outcome,
) -> Result<Transform, String> {
    if design.base.is_empty() {
        return Ok(Transform::identity());
    }
    let (d, m, v) = body_markers(&design.base, Some(frame));
    let mk = Markers {
        visible: Some(&v),
        ..Markers::new(&d, &m)
    };
    match register(&mk, opts) {
        Ok(reg) if reg.consistent && reg.ambiguity.is_some() => {
            Err(ambiguous_reason("base", &design.base, &reg))
        }
        Ok(reg) if reg.consistent => {
            out.log.record("base", &design.base, label, &reg);
            out.base_poses.push((label.to_string(), reg.t_mocap_body));
            Ok(reg.t_mocap_body)
        }
        Ok(reg) => {
            out.log.record("base", &design.base, label, &reg);
            Err(format!(
                "base markers inconsistent (RMS {:.3} mm, no exclusion of up to {} markers fits)",
                reg.rms_m * 1e3,
                opts.max_outliers
            ))
        }
        Err(e) => Err(reg_failure(MarkerBody::Base, &e, &v)),
    }
}

/// The probe of one frame, to be registered into the base frame.
struct Probe<'a> {
    row: &'a MeasurementRow,
    label: &'a str,
    design: &'a Design,
    frame: &'a Frame,
    /// Motion-capture frame to robot base.
    to_base: Transform,
    opts: &'a RegistrationOptions,
}

impl Probe<'_> {
    /// `--points`: one position row per consistent (or, with fewer than 3 markers seen,
    /// unscreened) probe marker.
    fn point_rows(&self, log: &mut MarkerLog) -> Result<Vec<MeasurementRow>, String> {
        let probe = &self.design.probe;
        let (d, m, v) = body_markers(probe, Some(self.frame));
        let mk = Markers {
            visible: Some(&v),
            ..Markers::new(&d, &m)
        };
        let usable: Vec<usize> = match &register(&mk, self.opts) {
            Ok(reg) => {
                log.record("probe", probe, self.label, reg);
                if !reg.consistent {
                    return Err("probe markers inconsistent".into());
                }
                if reg.ambiguity.is_some() {
                    return Err(ambiguous_reason("probe", probe, reg));
                }
                (0..d.len())
                    .filter(|&k| reg.markers()[k].status == MarkerStatus::Inlier)
                    .collect()
            }
            Err(_) => (0..d.len()).filter(|&k| v[k]).collect(),
        };
        if usable.is_empty() {
            return Err("no probe marker visible".into());
        }
        Ok(usable
            .into_iter()
            .map(|k| {
                let p = self.to_base.transform_point(&nalgebra::Point3::from(m[k]));
                let mut row = joint_row(self.row, self.label);
                row.position_m = Some([p.x, p.y, p.z]);
                row.point_m = Some(d[k]);
                row.extras.push(probe[k].0.clone());
                row
            })
            .collect())
    }

    /// The probe's pose in the base frame, with its registration RMS [mm] as an extra.
    fn pose_row(&self, log: &mut MarkerLog) -> Result<MeasurementRow, String> {
        let probe = &self.design.probe;
        let (d, m, v) = body_markers(probe, Some(self.frame));
        let mk = Markers {
            visible: Some(&v),
            ..Markers::new(&d, &m)
        };
        match register(&mk, self.opts) {
            Ok(reg) if reg.consistent && reg.ambiguity.is_some() => {
                Err(ambiguous_reason("probe", probe, &reg))
            }
            Ok(reg) if reg.consistent => {
                log.record("probe", probe, self.label, &reg);
                let t = self.to_base * reg.t_mocap_body;
                let p = t.translation.vector;
                let [w, x, y, z] = matrix_to_quaternion(t.rotation.matrix());
                let mut row = joint_row(self.row, self.label);
                row.position_m = Some([p.x, p.y, p.z]);
                row.orientation = Some(Orientation::Quaternion { w, x, y, z });
                row.extras.push(format!("{:?}", reg.rms_m * 1e3));
                Ok(row)
            }
            Ok(reg) => {
                log.record("probe", probe, self.label, &reg);
                Err(format!(
                    "probe markers inconsistent (RMS {:.3} mm, no exclusion of up to {} markers fits)",
                    reg.rms_m * 1e3,
                    self.opts.max_outliers
                ))
            }
            Err(e) => Err(reg_failure(MarkerBody::Probe, &e, &v)),
        }
    }
}

/// What the readable report is made of.
struct ReportInputs<'a> {
    joints: &'a MeasurementSet,
    export_frames: usize,
    sigma_m: f64,
    args: &'a Args,
    design_notes: &'a [String],
    outcome: &'a Outcome,
    /// Export frames without joint readings.
    unused: &'a [&'a str],
}

/// The readable report up to the files written.
fn report_text(r: &ReportInputs<'_>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Marker registration: {} frames with joint readings, {} export frames; σ = {:.3} mm, threshold {}σ, up to {} outliers per body",
        r.joints.rows.len(),
        r.export_frames,
        r.sigma_m * 1e3,
        r.args.k_sigma,
        r.args.max_outliers
    );
    for note in r.design_notes {
        let _ = writeln!(s, "Design: {note}");
    }
    s.push_str("Per marker (residuals of the frames registered, flagged markers included):\n");
    s.push_str(&marker_table(&r.outcome.log.stats));
    let flagged = &r.outcome.log.flagged;
    if flagged.is_empty() {
        s.push_str("Flagged markers: none\n");
    } else {
        let _ = writeln!(s, "Flagged markers ({}):", flagged.len());
        for f in flagged {
            let _ = writeln!(s, "  {f}");
        }
    }
    if let Some(line) = base_drift(&r.outcome.base_poses, r.sigma_m) {
        s.push_str(&line);
    }
    if !r.unused.is_empty() {
        let _ = writeln!(
            s,
            "Export frames without joint readings (not used): {}",
            r.unused.join(", ")
        );
    }
    let failed = &r.outcome.failed;
    if !failed.is_empty() {
        let _ = writeln!(s, "Frames that could not be registered ({}):", failed.len());
        for (label, line, why) in failed {
            let _ = writeln!(s, "  frame {label} ({}:{line}): {why}", r.joints.source);
        }
    }
    s
}

/// The per-marker table: frames seen, RMS and largest residual, times flagged.
fn marker_table(stats: &BTreeMap<(String, String), MarkerStats>) -> String {
    let mut t = crate::report::Table::new(&[
        "body",
        "marker",
        "frames seen",
        "RMS residual [mm]",
        "max [mm]",
        "flagged",
    ]);
    for ((body, name), st) in stats {
        t.row(vec![
            body.clone(),
            name.clone(),
            st.seen.to_string(),
            if st.seen > 0 {
                format!("{:.4}", (st.sum_sq / st.seen as f64).sqrt() * 1e3)
            } else {
                "-".into()
            },
            format!("{:.4}", st.max * 1e3),
            st.flagged.to_string(),
        ]);
    }
    t.render("  ")
}

/// The largest change of the base's registered pose from the first frame (a moved base or
/// base marker shows here), with at least two base registrations.
fn base_drift(base_poses: &[(String, Transform)], sigma_m: f64) -> Option<String> {
    let [(first_label, first), ..] = base_poses else {
        return None;
    };
    if base_poses.len() < 2 {
        return None;
    }
    let (mut dp, mut dr, mut at) = (0.0f64, 0.0f64, String::new());
    for (label, t) in base_poses {
        let e = kincal::pose::pose_error(t, first, kincal::OrientationError::Exact);
        let p = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        if p > dp {
            at = label.clone();
        }
        dp = dp.max(p);
        dr = dr.max((e[3] * e[3] + e[4] * e[4] + e[5] * e[5]).sqrt());
    }
    Some(format!(
        "Base registration: largest change from frame {first_label} is {:.3} mm / {:.4}° (frame {at}){}\n",
        dp * 1e3,
        dr.to_degrees(),
        if dp > 4.0 * sigma_m {
            " — more than 4σ: did the base or its markers move?"
        } else {
            ""
        }
    ))
}

/// Writes DATA.csv (and the residuals CSV with `--residuals`) and says so in `s`.
fn write_outputs<const N: usize>(
    args: &Args,
    design: &Design,
    joints: &MeasurementSet,
    sigma_m: f64,
    outcome: Outcome,
    s: &mut String,
) -> Result<(), CliError> {
    let failed = &outcome.failed;
    let mut comments = joints.comments.clone();
    comments.push(format!(
        " poses from marker registration (kincal markers): design {}, σ {:.3} mm",
        args.design
            .file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
        sigma_m * 1e3
    ));
    if design.base.is_empty() {
        comments.push(" no base markers: poses are in the motion-capture frame".into());
    }
    for (label, line, why) in failed {
        comments.push(format!(
            " left out: frame {label} (joints line {line}): {why}"
        ));
    }
    let mut extra_columns = joints.extra_columns.clone();
    extra_columns.push(if args.points {
        "extra_marker".into()
    } else {
        "extra_probe_rms_mm".into()
    });
    let n_rows = outcome.rows.len();
    let set = MeasurementSet {
        source: args.out.display().to_string(),
        comments,
        n_joints: N,
        rows: outcome.rows,
        extra_columns,
        orientation_form: (!args.points).then_some(OrientationForm::Quaternion),
        has_position: true,
        has_point: args.points,
        has_target: false,
        has_plane: false,
        has_session: false,
        has_approach: joints.has_approach,
        has_temperature: joints.has_temperature,
        sha256: String::new(),
        header_line: 0,
    };
    let inputs: Vec<&Path> = vec![&args.export, &args.design, &args.joints];
    kincal_io::files::write_atomic(&args.out, &inputs, |w| write_measurements_csv(w, &set))?;
    let _ = writeln!(
        s,
        "{n_rows} {} written to {}{}",
        if args.points { "point rows" } else { "poses" },
        args.out.display(),
        if failed.is_empty() {
            String::new()
        } else {
            format!(" ({} frame(s) left out, listed above)", failed.len())
        }
    );
    if let Some(p) = &args.residuals {
        let mut ins = inputs.clone();
        ins.push(&args.out);
        let csv = &outcome.log.residuals_csv;
        kincal_io::files::write_atomic(p, &ins, |w| w.write_all(csv.as_bytes()))?;
        let _ = writeln!(s, "Per-marker residuals written to {}", p.display());
    }
    Ok(())
}

/// The joint part of an output row: the joints file's row, pose_id or the frame label.
fn joint_row(r: &MeasurementRow, label: &str) -> MeasurementRow {
    MeasurementRow {
        line: r.line,
        pose_id: Some(r.pose_id.clone().unwrap_or_else(|| label.to_string())),
        q_rad: r.q_rad.clone(),
        position_m: None,
        orientation: None,
        point_m: None,
        approach: r.approach.clone(),
        temp_c: r.temp_c,
        extras: r.extras.clone(),
        partial_m: None,
        target: None,
        plane: None,
        session: None,
    }
}

fn reg_failure(body: MarkerBody, e: &kincal::Error, visible: &[bool]) -> String {
    let name = match body {
        MarkerBody::Base => "base",
        MarkerBody::Probe => "probe",
    };
    let n = visible.iter().filter(|&&v| v).count();
    match e {
        kincal::Error::TooFewData { .. } => {
            format!("{name}: {n} marker(s) visible, at least 3 needed")
        }
        kincal::Error::RankDeficient { .. } => {
            format!("{name}: the visible markers are (nearly) collinear: rotation undetermined")
        }
        other => format!("{name}: {other}"),
    }
}

/// Names of the markers in a bit mask (bit `j` for marker `j`).
fn marker_names(mask: u32, names: &[(String, [f64; 3])]) -> String {
    let picked: Vec<&str> = names
        .iter()
        .enumerate()
        .filter(|(j, _)| *j < 32 && mask & (1 << j) != 0)
        .map(|(_, (n, _))| n.as_str())
        .collect();
    picked.join("+")
}

/// Why an ambiguous frame is refused: the two exclusions and how far apart their poses are.
fn ambiguous_reason(body: &str, names: &[(String, [f64; 3])], reg: &Registration) -> String {
    let Some(a) = reg.ambiguity else {
        return format!("{body} markers ambiguous");
    };
    format!(
        "{body} markers ambiguous: excluding {} or {} fits equally well, with poses {:.1}° apart \
         (markers {:.1} mm apart): a ghost or knocked marker; the pose is not determined",
        marker_names(a.excluded, names),
        marker_names(a.alternative_excluded, names),
        a.rotation_rad.to_degrees(),
        a.marker_shift_m * 1e3
    )
}

/// Warnings for designs with congruent marker triangles (core `design_symmetry`): closer than
/// the outlier threshold `k·σ`, a ghost or mislabelled marker can make a rotated copy of the
/// body fit; such frames are then refused as ambiguous, and the design should be changed.
fn symmetry_notes(design: &Design, opts: &RegistrationOptions) -> Vec<String> {
    let threshold_m = opts.k_sigma * opts.sigma_m;
    [("base", &design.base), ("probe", &design.probe)]
        .into_iter()
        .filter_map(|(body, markers)| {
            let points: Vec<[f64; 3]> = markers.iter().map(|(_, p)| *p).collect();
            let sym = design_symmetry(&points)?;
            (sym.margin_m <= threshold_m).then(|| {
                let tri = |t: [usize; 3]| {
                    t.iter()
                        .map(|&j| markers.get(j).map_or("?", |(n, _)| n.as_str()))
                        .collect::<Vec<_>>()
                        .join("-")
                };
                let what = if sym.triangles[0] == sym.triangles[1] {
                    format!("triangle {} has two equal sides", tri(sym.triangles[0]))
                } else {
                    format!(
                        "triangles {} and {} are congruent",
                        tri(sym.triangles[0]),
                        tri(sym.triangles[1])
                    )
                };
                format!(
                    "{body} design: {what} within {:.3} mm (outlier threshold {:.3} mm): a ghost, \
                     knocked or mislabelled marker can fit a rotated copy of the body; such frames \
                     are refused as ambiguous. Make every triangle's side lengths differ by more \
                     than the threshold.",
                    sym.margin_m * 1e3,
                    threshold_m * 1e3
                )
            })
        })
        .collect()
}
