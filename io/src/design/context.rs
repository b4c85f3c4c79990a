//! What every design run shares: the user's setting ([`Setup`], [`ScenarioSpec`]), the
//! settings of the pose selections, and the resolved [`Context`] (robot, working region and
//! orientations, validation grid) built from them.

use kincal::aria;
use kincal::ik::{IkOptions, solve_ik};
use kincal::montecarlo::Scenario;
use kincal::pose::{Transform, rpy_to_matrix, transform};
use kincal::selection::{Cone, Constraints, Region, reach};
use kincal::{JointState, ParamSet, Robot};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::error::Error;

/// Workspace capacity of the design commands: 4 geometric parameters per joint for up to
/// eight joints.
pub const P: usize = 4 * kincal::any::MAX_JOINTS;

/// The user's setting of a design run, in the units the user gives: the working region,
/// its orientations, the validation grid, the joint margin and the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Working region `[x0, y0, z0, x1, y1, z1]` [m] (`None`: the robot's built-in one).
    pub region: Option<[f64; 6]>,
    /// Working orientations, roll, pitch, yaw [deg] each (R = Rz(yaw)·Ry(pitch)·Rx(roll));
    /// empty: the robot's built-in ones.
    pub working_rpy_deg: Vec<[f64; 3]>,
    /// Half-angle of the local designs' approach cone about the mean working axis [deg].
    pub cone_deg: f64,
    /// Validation grid: positions along x, y, z over the region.
    pub grid: [usize; 3],
    /// Joint-limit margin of selected poses [deg].
    pub margin_deg: f64,
    /// Seed of every random choice.
    pub seed: u64,
}

impl Default for Setup {
    /// The command line's defaults.
    fn default() -> Self {
        Setup {
            region: None,
            working_rpy_deg: Vec::new(),
            cone_deg: 20.0,
            grid: [4, 4, 2],
            margin_deg: 5.0,
            seed: 1,
        }
    }
}

/// The Monte-Carlo scenario in the user's units (defaults: [`Scenario::paper`]): the random
/// robots' errors and the measurement and tool noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScenarioSpec {
    /// Each identified length of a random robot off by up to ± this [mm] (uniform).
    pub length_error_mm: f64,
    /// Each identified angle off by up to ± this [deg].
    pub angle_error_deg: f64,
    /// Measurement (instrument) or seating (tool) noise, 1σ per position axis [mm].
    pub noise_pos_mm: f64,
    /// … and per rotation axis [deg].
    pub noise_rot_deg: f64,
    /// Manufacturing error of each tool reference pose, uniform ± per position axis [mm].
    pub tool_tol_mm: f64,
    /// … and per rotation axis [deg].
    pub tool_tol_deg: f64,
}

impl Default for ScenarioSpec {
    /// The paper's scenario (the command line's defaults).
    fn default() -> Self {
        ScenarioSpec {
            length_error_mm: 5.0,
            angle_error_deg: 5.0,
            noise_pos_mm: 0.05,
            noise_rot_deg: 0.02,
            tool_tol_mm: 0.05,
            tool_tol_deg: 0.02,
        }
    }
}

impl ScenarioSpec {
    /// The core's scenario: these robot errors, noise and tool tolerance.
    pub fn scenario(&self) -> Scenario {
        Scenario {
            noise_pos_m: self.noise_pos_mm * 1e-3,
            noise_rot_rad: self.noise_rot_deg.to_radians(),
            tool_tol_pos_m: self.tool_tol_mm * 1e-3,
            tool_tol_rot_rad: self.tool_tol_deg.to_radians(),
            ..self.robot_errors()
        }
    }
    /// The paper's scenario with only these robot errors (for the robust-reach test of the
    /// pose selection, which simulates no measurement).
    pub fn robot_errors(&self) -> Scenario {
        Scenario {
            length_error_m: self.length_error_mm * 1e-3,
            angle_error_rad: self.angle_error_deg.to_radians(),
            ..Scenario::paper()
        }
    }
    /// One line for reports and tool files.
    pub fn describe(&self) -> String {
        format!(
            "random robots ±{} mm / ±{}° per identified parameter; noise σ {} mm / {}° per axis; \
             tool tolerance ±{} mm / ±{}° per axis",
            self.length_error_mm,
            self.angle_error_deg,
            self.noise_pos_mm,
            self.noise_rot_deg,
            self.tool_tol_mm,
            self.tool_tol_deg
        )
    }
}

/// The number of poses m of a design, checked (1..=48); `flag` names it in the error.
pub fn pose_count(m: usize, flag: &str) -> Result<usize, Error> {
    if m == 0 || m > 48 {
        return Err(Error::usage(format!("{flag}: expected 1..=48")));
    }
    Ok(m)
}

/// The box `[x0, y0, z0, x1, y1, z1]` [m] as a region; `flag` names it in the error.
pub fn region(b: [f64; 6], flag: &str) -> Result<Region, Error> {
    Region::new([b[0], b[1], b[2]], [b[3], b[4], b[5]])
        .map_err(|e| Error::usage(format!("{flag}: {e}")))
}

/// An observability index by name (`o`, `o1` … `o5`, `aopt`, `dopt`).
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

impl SelectionSettings {
    /// These settings with m checked (`flag` names it in the error), the pool at least m
    /// and at least one start.
    pub fn checked(self, flag: &str) -> Result<Self, Error> {
        let m = pose_count(self.m, flag)?;
        Ok(SelectionSettings {
            m,
            pool: self.pool.max(m),
            starts: self.starts.max(1),
            ..self
        })
    }
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
    pub fn new(robot: Robot<N>, name: &str, a: &Setup) -> Result<Self, Error> {
        let is_aria = name == "aria";
        let region = match (a.region, is_aria) {
            (Some(b), _) => Region::new([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
            (None, true) => Region::new(aria::WORKING_REGION_MIN_M, aria::WORKING_REGION_MAX_M),
            (None, false) => {
                return Err(Error::usage(format!(
                    "robot '{name}' has no built-in working region: give --region X0,Y0,Z0,X1,Y1,Z1"
                )));
            }
        }
        .map_err(|e| Error::usage(format!("--region: {e}")))?;
        let rpy: Vec<[f64; 3]> = match (a.working_rpy_deg.is_empty(), is_aria) {
            (false, _) => a.working_rpy_deg.clone(),
            (true, true) => vec![[-150.0, 0.0, 0.0], [-160.0, 0.0, 0.0]],
            (true, false) => {
                return Err(Error::usage(format!(
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
            return Err(Error::usage(
                "--working-rpy-deg: the working orientations have no common approach axis",
            ));
        }
        let cone = Cone::new([mean.x, mean.y, mean.z], a.cone_deg.min(180.0).to_radians())
            .map_err(|e| Error::usage(format!("--cone-deg: {e}")))?;
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
            return Err(Error::numeric(
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
        let a = ScenarioSpec::default().scenario();
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
    fn checks_name_the_flag() {
        assert!(pose_count(10, "m").is_ok());
        assert_eq!(
            pose_count(0, "m").unwrap_err().message,
            "m: expected 1..=48"
        );
        assert!(pose_count(49, "m").is_err());
        assert!(region([0.0, 0.0, 0.0, 1.0, 1.0, 1.0], "r").is_ok());
        assert!(region([0.0, 0.0, 1.0, 1.0, 1.0, 0.0], "r").is_err());
        assert!(parse_index("dopt").is_ok());
        assert!(parse_index("x").unwrap_err().contains("expected one of"));
    }
}
