//! `kincal`: the command-line tool of the kincal calibration toolkit (spec/cli.md).

use kincal_cli::commands::{
    calibrate, crossval, demo, design_tool, diagnose, evaluate, export, import, import_bag,
    markers, observed_point, predict, select, validate,
};
use kincal_cli::file_plan;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

const ABOUT: &str = "Kinematic calibration of lightweight robot arms (modified DH / Hayati)";

const LONG_ABOUT: &str = "\
Kinematic calibration of lightweight robot arms (modified DH / Hayati model), after Arent et
al. 2024 (the ARIA arm). Units: metres and radians in files unless a column says _mm/_deg;
millimetres and degrees on screen.

ROBOT is a built-in robot name (aria) or a robot description file. MODEL is a model file
written by `calibrate`, or a ROBOT (its nominal model). DATA is a measurement CSV.

--robot: commands that read measured data (calibrate, crossval, diagnose, markers) require
it, since the data belong to one arm and a default would read them against another; the design
commands, which simulate (select-poses, design-tool, evaluate-designs), default to the paper's
arm, aria; demo always runs aria; predict and validate take a MODEL instead.

Output flags name the kind of file, the same in every command: --out the command's product
(a model: calibrate, diagnose; a measurement or pose CSV: predict, select-poses, markers,
import-dataset, import-bag, observed-point; a tool CSV: design-tool; a folder: demo);
--json the machine-readable report (validate, diagnose, crossval, design-tool,
evaluate-designs); --report diagnose's readable report; --plot (and --plate-plot) an SVG
figure; --robot-out a robot file, --constraints-out a constraints file; export names its
formats (--urdf, --mdh-table, --c-header).
No kind of file has two flag names.

Exit status: 0 success, 1 an output could not be written, 2 usage error, 3 bad input (file,
line, column and reason on stderr), 4 numerical failure (no convergence, rank too low).";

// Help wraps as the reports do (issue #19): clap wraps option descriptions to the terminal,
// to `COLUMNS` without one (a pipe, a CI log), and never wider than TEXT_WIDTH.
#[derive(Parser, Debug)]
#[command(name = "kincal", version, about = ABOUT, long_about = LONG_ABOUT, max_term_width = kincal_cli::report::TEXT_WIDTH)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The paper's simulation study end to end on the built-in ARIA (no files needed)
    #[command(long_about = demo::LONG_ABOUT, after_help = demo::EXAMPLE)]
    Demo(demo::Args),
    /// Identify the parameters from measured poses and write a model file
    #[command(long_about = calibrate::LONG_ABOUT, after_help = calibrate::EXAMPLE)]
    Calibrate(calibrate::Args),
    /// The model's pose for every row of DATA
    #[command(long_about = predict::LONG_ABOUT, after_help = predict::EXAMPLE)]
    Predict(predict::Args),
    /// Per-pose and summary errors of MODEL against measured poses
    #[command(long_about = validate::LONG_ABOUT, after_help = validate::EXAMPLE)]
    Validate(validate::Args),
    /// Observability-optimal calibration poses (standard, local or clustering design)
    #[command(long_about = select::LONG_ABOUT, after_help = select::EXAMPLE)]
    SelectPoses(Box<select::Args>),
    /// An optimised calibration tool beating a baseline tool, as a workshop spec
    #[command(long_about = design_tool::LONG_ABOUT, after_help = design_tool::EXAMPLE)]
    DesignTool(Box<design_tool::Args>),
    /// Monte-Carlo comparison of data-acquisition designs on the same random robots
    #[command(long_about = evaluate::LONG_ABOUT, after_help = evaluate::EXAMPLE)]
    EvaluateDesigns(Box<evaluate::Args>),
    /// Sim-to-real diagnosis: where the residual lies, which effect causes it
    #[command(long_about = diagnose::LONG_ABOUT, after_help = diagnose::EXAMPLE)]
    Diagnose(diagnose::Args),
    /// Held-out residuals of nominal and calibrated model, noise floor, outliers
    #[command(long_about = crossval::LONG_ABOUT, after_help = crossval::EXAMPLE)]
    Crossval(crossval::Args),
    /// Motion-capture markers + marker design + joint readings -> measurement CSV
    // clap does not wrap the usage line: the two with the most required flags are written
    // out on two lines (keep them in step with the arguments).
    #[command(
        long_about = markers::LONG_ABOUT,
        after_help = markers::EXAMPLE,
        override_usage = "kincal markers [OPTIONS] --design <DESIGN.toml> --joints <JOINTS.csv>\n       \
                          --robot <ROBOT> --out <DATA.csv> <EXPORT>"
    )]
    Markers(markers::Args),
    /// A public real-robot data set as measurement CSV and robot file
    #[command(name = "import-dataset", long_about = import::LONG_ABOUT, after_help = import::EXAMPLE)]
    ImportDataset(import::Args),
    /// A ROS 2 bag (MCAP) as measurement CSV, one row per standstill
    #[command(
        name = "import-bag",
        long_about = import_bag::LONG_ABOUT,
        after_help = import_bag::EXAMPLE,
        override_usage = "kincal import-bag [OPTIONS] --joints <TOPIC> --out <DATA.csv>\n       \
                          <--pose <TOPIC>|--point <TOPIC>> <BAG>"
    )]
    ImportBag(Box<import_bag::Args>),
    /// Camera poses re-expressed at the point the camera looks at
    #[command(name = "observed-point", long_about = observed_point::LONG_ABOUT, after_help = observed_point::EXAMPLE)]
    ObservedPoint(observed_point::Args),
    /// The model as a URDF, an mDH/Hayati table (CSV, YAML) or a C header
    #[command(long_about = export::LONG_ABOUT, after_help = export::EXAMPLE)]
    Export(export::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = plan(&cli.command).check().and_then(|()| run(&cli.command));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kincal: error: {}", e.message);
            ExitCode::from(e.kind as u8)
        }
    }
}

/// Every input and output path of the command, checked before any work
/// (`kincal_cli::file_plan`).
fn plan(command: &Command) -> file_plan::FilePlan {
    match command {
        // The demo reads nothing and writes only inside the folder it creates.
        Command::Demo(_) => file_plan::FilePlan::new(),
        Command::Calibrate(a) => file_plan::calibrate(a),
        Command::Predict(a) => file_plan::predict(a),
        Command::Validate(a) => file_plan::validate(a),
        Command::SelectPoses(a) => file_plan::select_poses(a),
        Command::DesignTool(a) => file_plan::design_tool(a),
        Command::EvaluateDesigns(a) => file_plan::evaluate_designs(a),
        Command::Diagnose(a) => file_plan::diagnose(a),
        Command::ImportDataset(a) => file_plan::import_dataset(a),
        Command::ImportBag(a) => file_plan::import_bag(a),
        Command::Crossval(a) => file_plan::crossval(a),
        Command::Markers(a) => file_plan::markers(a),
        Command::ObservedPoint(a) => file_plan::observed_point(a),
        Command::Export(a) => file_plan::export(a),
    }
}

fn run(command: &Command) -> Result<(), kincal_cli::error::CliError> {
    match command {
        Command::Demo(a) => demo::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Predict(a) => predict::run(a),
        Command::Validate(a) => validate::run(a),
        Command::SelectPoses(a) => select::run(a),
        Command::DesignTool(a) => design_tool::run(a),
        Command::EvaluateDesigns(a) => evaluate::run(a),
        Command::Diagnose(a) => diagnose::run(a),
        Command::ImportDataset(a) => import::run(a),
        Command::ImportBag(a) => import_bag::run(a),
        Command::Crossval(a) => crossval::run(a),
        Command::Markers(a) => markers::run(a),
        Command::ObservedPoint(a) => observed_point::run(a),
        Command::Export(a) => export::run(a),
    }
}
