//! `kincal predict MODEL DATA --out POSES.csv`.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use kincal::Robot;
use kincal::pose::matrix_to_quaternion;

use crate::error::{CliError, core_error};
use kincal_io::data::{self, DataOptions};
use kincal_io::measurements::{MeasurementRow, PoseRow, PosesCsvWriter};
use kincal_io::robot_arg;

pub const LONG_ABOUT: &str = "\
Computes the model's end-effector pose T_e^b (forward kinematics, effects included) for the
joint readings of every row of DATA. Pose columns of DATA, if any, are ignored; a file with
joint columns only is enough (plus s1..sN / temp_c when the model has backlash / thermal
effects). A row with point_x, point_y, point_z (a measured point in the tool frame, see
`kincal help calibrate`) predicts that point: T_e^b·Trans(point).

POSES.csv has one row per DATA row: pose_id (if DATA has it), q1..qN [rad], x,y,z [m] and
the unit quaternion qw,qx,qy,qz (qw >= 0) of the orientation, every number with full
precision (the shortest decimal form that reads back to the same double).

MODEL is a model file written by `kincal calibrate`, or a ROBOT (built-in name or robot
description file) for its nominal model.";

pub const EXAMPLE: &str = "\
Example:
  kincal predict aria-model.json joints.csv --out poses.csv";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Model file, or ROBOT for the nominal model
    #[arg(value_name = "MODEL")]
    pub model: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// CSV with joint readings q1..qN
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Output CSV of predicted poses
    #[arg(long, value_name = "POSES.csv")]
    pub out: PathBuf,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let model = robot_arg::resolve_model(&args.model, &args.chain)?;
    let effects = model
        .file
        .effects()
        .map_err(|m| CliError::input(format!("{}: {m}", args.model)))?;
    kincal::with_any_robot!(&model.robot, r => predict(r, effects, args, model.from_file))
}

fn predict<const N: usize>(
    robot: &Robot<N>,
    effects: kincal::EffectSet,
    args: &Args,
    model_is_file: bool,
) -> Result<(), CliError> {
    let needed = effects
        .iter()
        .chain(robot.active_effects().iter())
        .fold(kincal::EffectSet::NONE, kincal::EffectSet::with);
    let opts = DataOptions {
        require_pose: false,
        allow_out_of_limits: args.allow_out_of_limits,
    };
    let mut inputs: Vec<&Path> = vec![&args.data];
    let model_path = Path::new(&args.model);
    if model_is_file {
        inputs.push(model_path);
    }
    // One pass, row by row: each row is read, predicted and written before the next is
    // read, so memory does not grow with the file (issue #16 item 6).
    let mut refused: Option<CliError> = None;
    let mut count = 0usize;
    let written = kincal_io::files::write_atomic(&args.out, &inputs, |w| {
        // The writer is made at the first row, which says whether there are pose ids.
        let mut target = Some(w);
        let mut out: Option<PosesCsvWriter<&mut dyn Write>> = None;
        let mut write_failure: Option<io::Error> = None;
        let streamed = data::stream(&args.data, robot, needed, opts, |set, row| {
            let pose = predicted_row(robot, row, &set.source)?;
            let mut put = || -> io::Result<()> {
                let writer = match (&mut out, target.take()) {
                    (Some(o), _) => o,
                    (None, Some(t)) => {
                        out.insert(PosesCsvWriter::new(t, N, pose.pose_id.is_some())?)
                    }
                    (None, None) => return Err(io::Error::other("the output was lost")),
                };
                writer.write(&pose)
            };
            put().map_err(|e| {
                write_failure = Some(e);
                CliError::io("write failed")
            })
        });
        if let Some(e) = write_failure {
            return Err(e);
        }
        if let Err(e) = streamed {
            refused = Some(e);
            return Err(io::Error::other("the data were refused"));
        }
        match out {
            Some(o) => {
                count = o.rows();
                o.finish()
            }
            None => Ok(()),
        }
    });
    if let Some(e) = refused {
        return Err(e);
    }
    written?;
    eprintln!("{count} poses predicted, written to {}", args.out.display());
    Ok(())
}

/// The model's pose for one row: the row's joint state (a row naming a measured point,
/// point_x/y/z, predicts that point's frame); the row's pose_id and readings move into it.
fn predicted_row<const N: usize>(
    robot: &Robot<N>,
    row: MeasurementRow,
    source: &str,
) -> Result<PoseRow, CliError> {
    let mut m = kincal::identify::Measurement::new([0.0; N], kincal::Transform::identity());
    m.state = data::joint_state::<N>(&row);
    m.point = row.point_m;
    let t = m
        .model_pose(robot)
        .map_err(|e| core_error(e, source, |_| Some(row.line)))?;
    let p = t.translation.vector;
    Ok(PoseRow {
        pose_id: row.pose_id,
        q_rad: row.q_rad,
        position_m: [p.x, p.y, p.z],
        quaternion_wxyz: matrix_to_quaternion(t.rotation.matrix()),
    })
}
