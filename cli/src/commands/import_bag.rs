//! `kincal import-bag BAG --joints TOPIC (--pose TOPIC | --point TOPIC) [--robot ROBOT]
//! --out DATA.csv`: a ROS 2 bag (MCAP) as a measurement CSV. The reader is
//! `kincal_io::rosbag`; this command parses flags and prints the summary.

use std::path::{Path, PathBuf};

use kincal_io::rosbag::{self, BagOptions, Clock, MeasurementTopic};

use crate::error::CliError;
use kincal_io::measurements::write_measurements_csv;

pub const LONG_ABOUT: &str = "\
Reads a ROS 2 bag in MCAP storage (the ROS 2 default; BAG is the .mcap file or the bag's
folder) and writes the measurement CSV (spec/measurements.md): one row per standstill of the
arm, with the mean joint reading and the mean measurement, pose_id its number.

Topics (CDR-encoded, as ROS 2 records them):
  --joints   sensor_msgs/msg/JointState
  --pose     geometry_msgs/msg/PoseStamped or TransformStamped (x, y, z, qw, qx, qy, qz)
  --point    geometry_msgs/msg/PointStamped (x, y, z: a point tracker, no orientation)
With --robot the joints are mapped by name (the robot file's or URDF's joint names; the
built-in aria's are joint1..joint6), other joints in the readings are ignored and a
reading missing one of the robot's joints is an error. Without --robot every position of
a reading is used, in message order.

A standstill is a run of joint readings that stays within --still-tol of its first reading
[rad, or m for a prismatic joint] for at least --min-still-s. Each measurement is paired
with the joint reading nearest in time; it is dropped when that reading is more than
--max-skew-s away, when the arm was moving, or when it lies outside the standstill's first
and last joint reading. A standstill whose measured positions spread more than
--still-pos-tol-mm from their mean is dropped (the measured frame moved). Times are the
messages' header stamps (--clock header) or the recorder's (--clock receive).

What was read and dropped, and why, is printed on stderr. A bag that is not MCAP or is
truncated, a missing topic, a message type or encoding not listed above, or a clock that
jumps (back by more than --max-skew-s, or a header stamp that moves against the recorder's
clock by more than --max-clock-jump-s) exits 3 with the reason.";

pub const EXAMPLE: &str = "\
Example:
  kincal import-bag session1/ --joints /joint_states --pose /mocap/tool_pose \\
      --robot arm.urdf --out session1.csv
  kincal calibrate session1.csv --robot arm.urdf --effects base_frame,tool_frame \\
      --init-frames --out model.json";

#[derive(clap::Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("measurement").required(true).args(["pose", "point"])))]
pub struct Args {
    /// The bag: an .mcap file or a rosbag2 folder of .mcap files
    #[arg(value_name = "BAG")]
    pub bag: PathBuf,
    /// Topic of the joint readings (sensor_msgs/msg/JointState)
    #[arg(long, value_name = "TOPIC")]
    pub joints: String,
    /// Topic of the measured poses (geometry_msgs/msg/PoseStamped or TransformStamped)
    #[arg(long, value_name = "TOPIC")]
    pub pose: Option<String>,
    /// Topic of the measured points (geometry_msgs/msg/PointStamped)
    #[arg(long, value_name = "TOPIC")]
    pub point: Option<String>,
    /// Map the readings' joints to this robot's joints by name (else by message order)
    #[arg(long, value_name = "ROBOT")]
    pub robot: Option<String>,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Measurement CSV to write
    #[arg(long, value_name = "DATA.csv")]
    pub out: PathBuf,
    /// Largest time between a measurement and its joint reading [s]
    #[arg(long, value_name = "S", default_value_t = rosbag::DEFAULT_MAX_SKEW_S)]
    pub max_skew_s: f64,
    /// Largest deviation of a joint within a standstill [rad, or m for prismatic joints]
    #[arg(long, value_name = "TOL", default_value_t = rosbag::DEFAULT_STILL_TOL)]
    pub still_tol: f64,
    /// Shortest standstill [s]
    #[arg(long, value_name = "S", default_value_t = rosbag::DEFAULT_MIN_STILL_S)]
    pub min_still_s: f64,
    /// Largest spread of the measured positions within a standstill [mm]
    #[arg(long, value_name = "MM", default_value_t = rosbag::DEFAULT_STILL_POS_TOL_MM)]
    pub still_pos_tol_mm: f64,
    /// Largest jump of the header stamps against the recorder's clock [s]
    #[arg(long, value_name = "S", default_value_t = rosbag::DEFAULT_MAX_CLOCK_JUMP_S)]
    pub max_clock_jump_s: f64,
    /// Which time places a message: its header stamp or the recorder's log time
    #[arg(long, value_name = "CLOCK", default_value = "header", value_parser = ["header", "receive"])]
    pub clock: String,
}

impl Args {
    /// The reader's options from the flags (and the robot's joint names, if any).
    fn options(&self) -> Result<BagOptions, CliError> {
        let measurement = match (&self.pose, &self.point) {
            (Some(p), None) => MeasurementTopic::Pose(p.clone()),
            (None, Some(p)) => MeasurementTopic::Point(p.clone()),
            _ => return Err(CliError::usage("give exactly one of --pose and --point")),
        };
        let mut o = BagOptions::new(&self.joints, measurement);
        if let Some(r) = &self.robot {
            let spec = kincal_io::robot_arg::resolve_robot(r, &self.chain)?;
            o.joint_names = Some(spec.joint_names);
            o.robot_name = Some(spec.name);
        } else if self.chain != kincal_io::robot_arg::UrdfChainArgs::default() {
            return Err(CliError::usage(
                "--base-link/--tip-link choose the chain of a URDF --robot; no --robot given",
            ));
        }
        o.clock = if self.clock == "receive" {
            Clock::Receive
        } else {
            Clock::Header
        };
        o.max_skew_s = self.max_skew_s;
        o.still_tol = self.still_tol;
        o.min_still_s = self.min_still_s;
        o.still_pos_tol_m = self.still_pos_tol_mm / 1000.0;
        o.max_clock_jump_s = self.max_clock_jump_s;
        Ok(o)
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let opts = args.options()?;
    let imported = rosbag::import_bag_path(&args.bag, &opts)?;
    for line in imported.summary.lines() {
        eprintln!("kincal: import-bag: {line}");
    }
    if imported.set.rows.is_empty() {
        return Err(CliError::input(format!(
            "{}: no standstill with a measurement: nothing to write (see the counts above; loosen --still-tol, --min-still-s or --max-skew-s?)",
            args.bag.display()
        )));
    }
    let inputs = bag_inputs(&args.bag);
    let input_refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    kincal_io::files::write_atomic(&args.out, &input_refs, |w| {
        write_measurements_csv(w, &imported.set)
    })?;
    crate::report::emit(&format!(
        "{}: {} rows, {} joints -> {}\n",
        args.bag.display(),
        imported.set.rows.len(),
        imported.set.n_joints,
        args.out.display()
    ));
    Ok(())
}

/// The files of BAG (the file itself, or every file of the bag's folder).
pub fn bag_inputs(bag: &Path) -> Vec<PathBuf> {
    if bag.is_dir() {
        std::fs::read_dir(bag)
            .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default()
    } else {
        vec![bag.to_path_buf()]
    }
}
