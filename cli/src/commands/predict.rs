//! `kincal predict MODEL DATA --out POSES.csv`.

use std::path::{Path, PathBuf};

use kincal::Robot;
use kincal::pose::matrix_to_quaternion;

use crate::error::{CliError, core_error};
use kincal_io::data::{self, DataOptions};
use kincal_io::measurements::{PoseRow, write_poses_csv};
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
    let set = data::read(
        &args.data,
        robot,
        needed,
        DataOptions {
            require_pose: false,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    let with_id = set.has_pose_id();
    let rows = set
        .rows
        .iter()
        .enumerate()
        .map(|(i, row)| {
            // A row naming a measured point (point_x/y/z) predicts that point's frame.
            let mut m = kincal::identify::Measurement::new([0.0; N], kincal::Transform::identity());
            m.state = data::joint_state::<N>(row);
            m.point = row.point_m;
            let t = m
                .model_pose(robot)
                .map_err(|e| core_error(e, &set.source, |_| data::line_of(&set, i)))?;
            let p = t.translation.vector;
            Ok(PoseRow {
                pose_id: if with_id { row.pose_id.clone() } else { None },
                q_rad: row.q_rad.clone(),
                position_m: [p.x, p.y, p.z],
                quaternion_wxyz: matrix_to_quaternion(t.rotation.matrix()),
            })
        })
        .collect::<Result<Vec<_>, CliError>>()?;
    let mut inputs: Vec<&Path> = vec![&args.data];
    let model_path = Path::new(&args.model);
    if model_is_file {
        inputs.push(model_path);
    }
    kincal_io::files::write_atomic(&args.out, &inputs, |w| {
        write_poses_csv(w, N, with_id, &rows)
    })?;
    eprintln!(
        "{} poses predicted, written to {}",
        rows.len(),
        args.out.display()
    );
    Ok(())
}
