//! The arguments the design commands (`select-poses`, `design-tool`, `evaluate-designs`)
//! share: the robot, the working region and its orientations, the validation grid, the
//! Monte-Carlo scenario and the selection sizes, each turned into kincal-io's
//! [`kincal_io::design`] settings, which run the designs.

use kincal::montecarlo::Scenario;
use kincal_io::design::context::{ScenarioSpec, SelectionSettings, Setup, pose_count, region};

use crate::error::CliError;

/// Parses `a,b,c` (finite numbers).
pub fn parse_triple(s: &str) -> Result<[f64; 3], String> {
    let v = parse_list(s)?;
    v.try_into()
        .map_err(|v: Vec<f64>| format!("expected 3 comma-separated numbers, found {}", v.len()))
}

/// Parses `x0,y0,z0,x1,y1,z1` with every lower corner below the upper one.
pub fn parse_box(s: &str) -> Result<[f64; 6], String> {
    let v = parse_list(s)?;
    let b: [f64; 6] = v
        .try_into()
        .map_err(|v: Vec<f64>| format!("expected 6 comma-separated numbers, found {}", v.len()))?;
    if (0..3).any(|k| b[k] >= b[k + 3]) {
        return Err("expected X0,Y0,Z0,X1,Y1,Z1 with X0 < X1, Y0 < Y1, Z0 < Z1".into());
    }
    Ok(b)
}

/// Parses `nx,ny,nz` (each 1..=50).
pub fn parse_grid(s: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected NX,NY,NZ (3 counts), found {} values",
            parts.len()
        ));
    }
    let mut g = [0usize; 3];
    for (slot, p) in g.iter_mut().zip(parts) {
        *slot = p
            .trim()
            .parse::<usize>()
            .map_err(|e| format!("'{p}': expected a count: {e}"))?;
        if !(1..=50).contains(slot) {
            return Err(format!("'{p}': expected a count in 1..=50"));
        }
    }
    Ok(g)
}

/// Parses one finite number.
pub fn finite(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("expected a finite number, found {v}")),
        Err(e) => Err(format!("expected a number: {e}")),
    }
}

/// Parses a comma-separated list of finite numbers.
pub fn parse_list(s: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|p| match p.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(format!("'{p}': expected a finite number, found {v}")),
            Err(e) => Err(format!("'{p}': expected a number: {e}")),
        })
        .collect()
}

/// Robot, region and validation set.
#[derive(clap::Args, Debug, Clone)]
pub struct SetupArgs {
    /// ROBOT: a built-in robot (aria) or a robot description file
    #[arg(long, default_value = "aria", value_name = "ROBOT")]
    pub robot: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Working region [m], the box the validation grid and the local designs live in
    /// [ARIA default: the assumed biopsy region 0.066,0.116,0.235,0.566,0.592,0.335]
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", value_parser = parse_box)]
    pub region: Option<[f64; 6]>,
    /// A working orientation, roll,pitch,yaw [deg] (R = Rz(yaw)·Ry(pitch)·Rx(roll));
    /// repeat for several [ARIA default: -150,0,0 and -160,0,0, as the Table 2 tool]
    #[arg(long = "working-rpy-deg", value_name = "R,P,Y", value_parser = parse_triple, allow_hyphen_values = true)]
    pub working_rpy_deg: Vec<[f64; 3]>,
    /// Local designs keep the approach (z) axis within this angle [deg] of the mean working
    /// axis
    #[arg(long, default_value_t = 20.0, value_name = "DEG", value_parser = crate::args::non_negative)]
    pub cone_deg: f64,
    /// Validation grid: NX,NY,NZ positions over the region, each with every working
    /// orientation (poses the nominal robot cannot reach are skipped)
    #[arg(long, default_value = "4,4,2", value_parser = parse_grid, value_name = "NX,NY,NZ")]
    pub grid: [usize; 3],
    /// Joint-limit margin of selected poses [deg]
    #[arg(long, default_value_t = 5.0, value_name = "DEG", value_parser = crate::args::non_negative)]
    pub margin_deg: f64,
    /// Seed of every random choice (pools, starts, Monte-Carlo runs)
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl SetupArgs {
    /// The setting as kincal-io takes it.
    pub fn setup(&self) -> Setup {
        Setup {
            region: self.region,
            working_rpy_deg: self.working_rpy_deg.clone(),
            cone_deg: self.cone_deg,
            grid: self.grid,
            margin_deg: self.margin_deg,
            seed: self.seed,
        }
    }
}

/// The Monte-Carlo scenario (defaults: [`Scenario::paper`]): the random robots' errors and
/// the measurement and tool noise. `select-poses` takes only [`RobotErrorArgs`] (its random
/// robots test reachability; it simulates no measurement).
#[derive(clap::Args, Debug, Clone)]
pub struct ScenarioArgs {
    #[command(flatten)]
    pub errors: RobotErrorArgs,
    #[command(flatten)]
    pub noise: NoiseArgs,
}

/// The random robots of the Monte-Carlo runs and of the robust-reach test.
#[derive(clap::Args, Debug, Clone)]
pub struct RobotErrorArgs {
    /// Random robots: each identified length off by up to ± this [mm] (uniform)
    #[arg(long, default_value_t = 5.0, value_name = "MM", value_parser = crate::args::amount_mm)]
    pub length_error_mm: f64,
    /// … and each identified angle off by up to ± this [deg]
    #[arg(long, default_value_t = 5.0, value_name = "DEG", value_parser = crate::args::amount_deg)]
    pub angle_error_deg: f64,
}

impl RobotErrorArgs {
    /// The paper's scenario with these robot errors (its noise unused by the caller).
    pub fn scenario(&self) -> Scenario {
        ScenarioSpec {
            length_error_mm: self.length_error_mm,
            angle_error_deg: self.angle_error_deg,
            ..ScenarioSpec::default()
        }
        .robot_errors()
    }
}

/// The simulated measurement noise and tool tolerance.
#[derive(clap::Args, Debug, Clone)]
pub struct NoiseArgs {
    /// Measurement noise (instrument) or seating noise (tool), 1σ per position axis [mm]
    #[arg(long, default_value_t = 0.05, value_name = "MM", value_parser = crate::args::amount_mm)]
    pub noise_pos_mm: f64,
    /// … and per rotation axis [deg]
    #[arg(long, default_value_t = 0.02, value_name = "DEG", value_parser = crate::args::amount_deg)]
    pub noise_rot_deg: f64,
    /// Tool designs: manufacturing error of each reference pose, uniform in ± this per
    /// position axis [mm]
    #[arg(long, default_value_t = 0.05, value_name = "MM", value_parser = crate::args::amount_mm)]
    pub tool_tol_mm: f64,
    /// … and per rotation axis [deg]
    #[arg(long, default_value_t = 0.02, value_name = "DEG", value_parser = crate::args::amount_deg)]
    pub tool_tol_deg: f64,
}

impl ScenarioArgs {
    /// The scenario in the user's units, as kincal-io takes it.
    pub fn spec(&self) -> ScenarioSpec {
        let (e, n) = (&self.errors, &self.noise);
        ScenarioSpec {
            length_error_mm: e.length_error_mm,
            angle_error_deg: e.angle_error_deg,
            noise_pos_mm: n.noise_pos_mm,
            noise_rot_deg: n.noise_rot_deg,
            tool_tol_mm: n.tool_tol_mm,
            tool_tol_deg: n.tool_tol_deg,
        }
    }
    pub fn scenario(&self) -> Scenario {
        self.spec().scenario()
    }
    /// One line for reports.
    pub fn describe(&self) -> String {
        self.spec().describe()
    }
}

/// Parses an observability index name.
pub fn parse_index(s: &str) -> Result<kincal::observability::Index, String> {
    kincal_io::design::context::parse_index(s)
}

/// How the selection-based designs are built: the sizes every design command uses
/// ([`DesignSizeArgs`]) and the candidate pool of the pose selections ([`PoolArgs`]), which
/// `design-tool` (candidates from its plate grid, objectives from --objectives) does not take.
#[derive(clap::Args, Debug, Clone)]
pub struct SelectionArgs {
    #[command(flatten)]
    pub size: DesignSizeArgs,
    #[command(flatten)]
    pub pool: PoolArgs,
}

/// What every design command uses to build a design.
#[derive(clap::Args, Debug, Clone)]
pub struct DesignSizeArgs {
    /// Number of poses m of every design
    #[arg(short = 'm', long = "poses", default_value_t = 10, value_name = "M")]
    pub poses: usize,
    /// Starts of the exchange (run in parallel; the best is kept)
    #[arg(long, default_value_t = 8)]
    pub starts: usize,
    /// Tool poses: smallest distance from singularity (smallest singular value of the
    /// joint Jacobian, m/rad and rad/rad rows)
    #[arg(long, default_value_t = 0.08, value_parser = crate::args::non_negative)]
    pub min_dexterity: f64,
    /// Tool poses: random robots (of the scenario's errors) that must all reach each pose
    /// within the joint limits (0: no test)
    #[arg(long, default_value_t = 32)]
    pub robust_robots: u64,
}

impl DesignSizeArgs {
    /// The number of poses m, checked (1..=48).
    pub fn m(&self) -> Result<usize, CliError> {
        pose_count(self.poses, "--poses")
    }
}

/// The candidate pool and objective of the pose selections (standard, local, clustering).
#[derive(clap::Args, Debug, Clone)]
pub struct PoolArgs {
    /// Observability index to maximise: o (eq. 17), o1 … o5, aopt, dopt
    #[arg(long, default_value = "o", value_parser = parse_index)]
    pub index: kincal::observability::Index,
    /// Candidate configurations in the pool
    #[arg(long, default_value_t = 2000)]
    pub pool: usize,
    /// Joint-space refinement trials per start (standard design)
    #[arg(long, default_value_t = 200)]
    pub refine: usize,
    /// The standard design's whole workspace: a box above the base plate [m]
    #[arg(long, default_value = "-1,-1,0.05,1,1,1.5", value_parser = parse_box, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true)]
    pub workspace: [f64; 6],
    /// Workspace clustering: cube side L [mm]
    #[arg(long, default_value_t = 100.0, value_parser = crate::args::positive)]
    pub cube_mm: f64,
    /// Workspace clustering: accepted spread of the per-pose singular values (ln ratio,
    /// 0.1 ≈ 10 %)
    #[arg(long, default_value_t = 0.1, value_parser = crate::args::non_negative)]
    pub tolerance: f64,
}

impl SelectionArgs {
    pub fn settings(&self) -> Result<SelectionSettings, CliError> {
        let (size, pool) = (&self.size, &self.pool);
        let m = size.m()?;
        SelectionSettings {
            m,
            index: pool.index,
            pool: pool.pool,
            starts: size.starts,
            refine_trials: pool.refine,
            workspace: region(pool.workspace, "--workspace")?,
            cube_m: pool.cube_mm * 1e-3,
            tolerance: pool.tolerance,
            min_dexterity: size.min_dexterity,
            robust_robots: size.robust_robots,
        }
        .checked("--poses")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenario_defaults_are_the_core_paper_scenario() {
        use clap::Parser;
        #[derive(Parser)]
        struct T {
            #[command(flatten)]
            s: ScenarioArgs,
        }
        let t = T::parse_from(["t"]);
        let a = t.s.scenario();
        let b = Scenario::paper();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-15 * y.abs().max(1e-300);
        assert!(close(a.length_error_m, b.length_error_m));
        assert!(close(a.angle_error_rad, b.angle_error_rad));
        assert!(close(a.noise_pos_m, b.noise_pos_m));
        assert!(close(a.noise_rot_rad, b.noise_rot_rad));
        assert!(close(a.tool_tol_pos_m, b.tool_tol_pos_m));
        assert!(close(a.tool_tol_rot_rad, b.tool_tol_rot_rad));
    }

    #[test]
    fn parsers_reject_bad_lists() {
        assert!(parse_box("0,0,0,1,1,1").is_ok());
        assert!(parse_box("0,0,1,1,1,0").is_err());
        assert!(parse_box("0,0,0,1,1").is_err());
        assert_eq!(parse_grid("4,4,2").unwrap(), [4, 4, 2]);
        assert!(parse_grid("4,0,2").is_err());
        assert!(parse_triple("1,nan,2").is_err());
    }
}
