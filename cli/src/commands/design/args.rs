//! What the design commands (`select-poses`, `design-tool`, `evaluate-designs`) share: the
//! robot, the working region and its orientations, the validation grid, the Monte-Carlo
//! scenario, and the resolved context built from them.

use kincal::aria;
use kincal::ik::{IkOptions, solve_ik};
use kincal::montecarlo::Scenario;
use kincal::pose::{Transform, rpy_to_matrix, transform};
use kincal::selection::{Cone, Constraints, Region, reach};
use kincal::{JointState, ParamSet, Robot};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::error::CliError;

/// Workspace capacity of the design commands: 4 geometric parameters per joint for up to
/// eight joints.
pub const P: usize = 4 * kincal::any::MAX_JOINTS;

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
        Scenario {
            length_error_m: self.length_error_mm * 1e-3,
            angle_error_rad: self.angle_error_deg.to_radians(),
            ..Scenario::paper()
        }
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
    pub fn scenario(&self) -> Scenario {
        let n = &self.noise;
        Scenario {
            noise_pos_m: n.noise_pos_mm * 1e-3,
            noise_rot_rad: n.noise_rot_deg.to_radians(),
            tool_tol_pos_m: n.tool_tol_mm * 1e-3,
            tool_tol_rot_rad: n.tool_tol_deg.to_radians(),
            ..self.errors.scenario()
        }
    }
    /// One line for reports.
    pub fn describe(&self) -> String {
        let (e, n) = (&self.errors, &self.noise);
        format!(
            "random robots ±{} mm / ±{}° per identified parameter; noise σ {} mm / {}° per axis; \
             tool tolerance ±{} mm / ±{}° per axis",
            e.length_error_mm,
            e.angle_error_deg,
            n.noise_pos_mm,
            n.noise_rot_deg,
            n.tool_tol_mm,
            n.tool_tol_deg
        )
    }
}

/// Parses an observability index name.
pub fn parse_index(s: &str) -> Result<kincal::observability::Index, String> {
    kincal::observability::Index::parse(s.trim()).ok_or_else(|| {
        format!(
            "unknown index '{s}': expected one of {}",
            kincal::observability::Index::ALL
                .map(|i| i.name())
                .join(", ")
        )
    })
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
        if self.poses == 0 || self.poses > 48 {
            return Err(CliError::usage("--poses: expected 1..=48"));
        }
        Ok(self.poses)
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
        let w = pool.workspace;
        Ok(SelectionSettings {
            m,
            index: pool.index,
            pool: pool.pool.max(m),
            starts: size.starts.max(1),
            refine_trials: pool.refine,
            workspace: Region::new([w[0], w[1], w[2]], [w[3], w[4], w[5]])
                .map_err(|e| CliError::usage(format!("--workspace: {e}")))?,
            cube_m: pool.cube_mm * 1e-3,
            tolerance: pool.tolerance,
            min_dexterity: size.min_dexterity,
            robust_robots: size.robust_robots,
        })
    }
}

/// Settings of the selection-based designs.
#[derive(Debug, Clone)]
pub struct SelectionSettings {
    pub m: usize,
    pub index: kincal::observability::Index,
    pub pool: usize,
    pub starts: usize,
    pub refine_trials: usize,
    /// The standard design's whole-workspace box (above the base plate).
    pub workspace: Region,
    pub cube_m: f64,
    pub tolerance: f64,
    pub min_dexterity: f64,
    pub robust_robots: u64,
}

/// The resolved setting of a design command.
#[derive(Debug, Clone)]
pub struct Context<const N: usize> {
    pub robot_name: String,
    pub robot: Robot<N>,
    pub params: ParamSet,
    pub region: Region,
    /// Working orientations.
    pub working: Vec<Matrix3<f64>>,
    /// Mean working approach axis and the cone of the local designs.
    pub cone: Cone,
    pub margin_rad: f64,
    /// Inverse-kinematics seed (ARIA: the Table 2 branch).
    pub seed_q: [f64; N],
    pub validation_q: Vec<[f64; N]>,
    pub validation_sincos: Vec<[[f64; 2]; N]>,
    pub validation_nominal: Vec<Transform>,
    /// Grid poses skipped as unreachable.
    pub validation_skipped: usize,
    pub seed: u64,
    pub is_aria: bool,
}

impl<const N: usize> Context<N> {
    /// Resolves the arguments for `robot` (named `name`).
    pub fn new(robot: Robot<N>, name: &str, a: &SetupArgs) -> Result<Self, CliError> {
        let is_aria = name == "aria";
        let region = match (a.region, is_aria) {
            (Some(b), _) => Region::new([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
            (None, true) => Region::new(aria::WORKING_REGION_MIN_M, aria::WORKING_REGION_MAX_M),
            (None, false) => {
                return Err(CliError::usage(format!(
                    "robot '{name}' has no built-in working region: give --region X0,Y0,Z0,X1,Y1,Z1"
                )));
            }
        }
        .map_err(|e| CliError::usage(format!("--region: {e}")))?;
        let rpy: Vec<[f64; 3]> = match (a.working_rpy_deg.is_empty(), is_aria) {
            (false, _) => a.working_rpy_deg.clone(),
            (true, true) => vec![[-150.0, 0.0, 0.0], [-160.0, 0.0, 0.0]],
            (true, false) => {
                return Err(CliError::usage(format!(
                    "robot '{name}' has no built-in working orientations: give --working-rpy-deg R,P,Y"
                )));
            }
        };
        let working: Vec<Matrix3<f64>> = rpy
            .iter()
            .map(|r| rpy_to_matrix(r[0].to_radians(), r[1].to_radians(), r[2].to_radians()))
            .collect();
        let mean: Vector3<f64> = working.iter().map(|r| r.column(2).into_owned()).sum();
        if mean.norm() < 1e-9 {
            return Err(CliError::usage(
                "--working-rpy-deg: the working orientations have no common approach axis",
            ));
        }
        let cone = Cone::new([mean.x, mean.y, mean.z], a.cone_deg.min(180.0).to_radians())
            .map_err(|e| CliError::usage(format!("--cone-deg: {e}")))?;
        let seed_q = if is_aria && N == 6 {
            let mut q = [0.0; N];
            q.copy_from_slice(&aria::TOOL_SEED_Q);
            q
        } else {
            [0.0; N]
        };
        let mut ctx = Context {
            robot_name: name.to_string(),
            params: robot.geometric_param_set(),
            robot,
            region,
            working,
            cone,
            margin_rad: a.margin_deg.to_radians(),
            seed_q,
            validation_q: Vec::new(),
            validation_sincos: Vec::new(),
            validation_nominal: Vec::new(),
            validation_skipped: 0,
            seed: a.seed,
            is_aria,
        };
        ctx.build_validation(a.grid);
        if ctx.validation_q.is_empty() {
            return Err(CliError::numeric(
                "no validation pose of the working region is reachable: check --region and \
                 --working-rpy-deg",
            ));
        }
        Ok(ctx)
    }

    /// The grid poses of the region with every working orientation, solved by IK.
    fn build_validation(&mut self, grid: [usize; 3]) {
        let lin = |k: usize, n: usize, lo: f64, hi: f64| {
            if n <= 1 {
                0.5 * (lo + hi)
            } else {
                lo + (hi - lo) * k as f64 / (n - 1) as f64
            }
        };
        let r = self.region;
        let mut targets = Vec::new();
        for ix in 0..grid[0] {
            for iy in 0..grid[1] {
                for iz in 0..grid[2] {
                    let p = Vector3::new(
                        lin(ix, grid[0], r.min_m[0], r.max_m[0]),
                        lin(iy, grid[1], r.min_m[1], r.max_m[1]),
                        lin(iz, grid[2], r.min_m[2], r.max_m[2]),
                    );
                    for rot in &self.working {
                        targets.push(transform(*rot, p));
                    }
                }
            }
        }
        let solved: Vec<Option<[f64; N]>> = targets
            .par_iter()
            .map(|t| self.nominal_ik(t, &Constraints::none()))
            .collect();
        for (t, q) in targets.iter().zip(solved) {
            match q {
                Some(q) => {
                    self.validation_q.push(q);
                    self.validation_sincos
                        .push(kincal::montecarlo::joint_sincos(&q));
                    self.validation_nominal.push(*t);
                }
                None => self.validation_skipped += 1,
            }
        }
    }

    /// The nominal robot's configuration for `target` nearest the seed (the working
    /// branch: of all converging IK seeds, the solution nearest [`Context::seed_q`]),
    /// admissible under `c` (joint limits always), or `None`.
    pub fn nominal_ik(&self, target: &Transform, c: &Constraints) -> Option<[f64; N]> {
        self.nominal_ik_from(target, None, c)
    }

    /// As [`Context::nominal_ik`] from `seed` instead of [`Context::seed_q`] when given.
    pub fn nominal_ik_from(
        &self,
        target: &Transform,
        seed: Option<&[f64; N]>,
        c: &Constraints,
    ) -> Option<[f64; N]> {
        let sol = solve_ik(
            &self.robot,
            target,
            &JointState::new(*seed.unwrap_or(&self.seed_q)),
            &IkOptions::default(),
        )
        .ok()?;
        c.admits(&self.robot, &sol.q)
            .ok()
            .and_then(|ok| ok.then_some(sol.q))
    }

    /// As [`Context::nominal_ik`] but the first converging seed (faster, for pools).
    pub fn quick_ik(&self, target: &Transform, c: &Constraints) -> Option<[f64; N]> {
        reach(&self.robot, target, &self.seed_q, c).ok().flatten()
    }

    /// Constraints of the local designs: region, cone, joint margin, dexterity.
    pub fn local_constraints(&self, min_dexterity: f64) -> Constraints {
        Constraints {
            region: Some(self.region),
            cone: Some(self.cone),
            joint_margin_rad: self.margin_rad,
            min_dexterity,
        }
    }

    /// The Monte-Carlo study of this context (with the errors before calibration).
    pub fn study(&self, scenario: Scenario, seed: u64) -> kincal::montecarlo::Study<'_, N> {
        kincal::montecarlo::Study {
            nominal: self.robot,
            params: self.params,
            validation_q: &self.validation_q,
            validation_sincos: &self.validation_sincos,
            validation_nominal: &self.validation_nominal,
            scenario,
            seed,
        }
    }

    /// One line for reports.
    pub fn describe(&self) -> String {
        let r = self.region;
        format!(
            "robot {}; working region x {:.3}..{:.3}, y {:.3}..{:.3}, z {:.3}..{:.3} m; {} validation poses ({} unreachable skipped)",
            self.robot_name,
            r.min_m[0],
            r.max_m[0],
            r.min_m[1],
            r.max_m[1],
            r.min_m[2],
            r.max_m[2],
            self.validation_q.len(),
            self.validation_skipped
        )
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
