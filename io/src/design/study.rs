//! Monte-Carlo comparison of designs (Section 4.4, Fig. 7): every design is calibrated on the
//! same random robots (run k of every design uses robot k, see [`kincal::montecarlo`]),
//! in parallel, and the errors of the identified models over the validation grid are
//! summarised per design.

use std::time::Instant;

use kincal::identify::{Measurement, Workspace};
use kincal::montecarlo::{Acquisition, RunResult, Scenario, prepare, simulate_run};
use kincal::pose::Transform;
use rayon::prelude::*;

use crate::design::Progress;
use crate::design::context::{Context, P};
use crate::design::designs::Design;
use crate::error::Error;

/// Median, 95th percentile (nearest rank), maximum and mean of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    pub median: f64,
    pub p95: f64,
    pub max: f64,
    pub mean: f64,
}

impl Summary {
    /// Summary of `v` (NaN-free); all zeros for an empty sample.
    pub fn of(v: &[f64]) -> Summary {
        if v.is_empty() {
            return Summary::default();
        }
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let rank = |p: f64| s[((p * n as f64).ceil() as usize).clamp(1, n) - 1];
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Summary {
            median,
            p95: rank(0.95),
            max: s[n - 1],
            mean: s.iter().sum::<f64>() / n as f64,
        }
    }
}

/// The outcome of one design in a study. Per-run values are per successful run, in run
/// order; errors are the worst pose of the validation grid of each run.
#[derive(Debug, Clone)]
pub struct DesignResult {
    pub name: String,
    pub acquisition: Acquisition,
    pub poses: usize,
    /// Eq. (17) index of the design at the nominal model.
    pub o: f64,
    pub runs: u64,
    pub failed: u64,
    /// The first failure's reason (a tool pose a robot cannot reach, no convergence).
    pub first_failure: Option<String>,
    pub max_pos_mm: Vec<f64>,
    pub max_rot_deg: Vec<f64>,
    pub rms_pos_mm: Vec<f64>,
    pub rms_rot_deg: Vec<f64>,
    pub before_pos_mm: Vec<f64>,
    pub before_rot_deg: Vec<f64>,
    pub mean_iterations: f64,
    /// Wall time of the runs (the analysis excluded).
    pub seconds: f64,
}

impl DesignResult {
    pub fn pos(&self) -> Summary {
        Summary::of(&self.max_pos_mm)
    }
    pub fn rot(&self) -> Summary {
        Summary::of(&self.max_rot_deg)
    }
}

/// Timing of a study.
#[derive(Debug, Clone, Copy)]
pub struct Timing {
    pub calibrations: u64,
    pub wall_s: f64,
    /// Process CPU time over the same span, where the OS reports it (Linux).
    pub cpu_s: Option<f64>,
    pub threads: usize,
}

/// Process CPU time (user + system) from /proc/self/stat, in seconds (10 ms ticks).
pub fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let f: Vec<&str> = s.rsplit(')').next()?.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// The analysis every simulated calibration of design `d` in `study` shares; refused,
/// naming the design, when its poses do not determine the parameters.
pub fn prepare_design<const N: usize>(
    study: &kincal::montecarlo::Study<'_, N>,
    d: &Design<N>,
) -> Result<kincal::identify::Identifiability, Error> {
    let empty = Measurement::new([0.0; N], Transform::identity());
    let mut data = vec![empty; d.q.len()];
    prepare(
        study,
        &d.core(),
        &mut Box::<Workspace<P>>::default(),
        &mut data,
    )
    .map_err(|e| {
        Error::numeric(format!(
            "design {}: the poses do not determine the parameters: {e}",
            d.name
        ))
    })
}

/// Runs `runs` calibrations of every design on the same random robots (`label` names the
/// progress stage).
pub fn run_study<const N: usize>(
    ctx: &Context<N>,
    designs: &[Design<N>],
    scenario: Scenario,
    runs: u64,
    seed: u64,
    label: &str,
    pb: &dyn Progress,
) -> Result<(Vec<DesignResult>, Timing), Error> {
    let with_before = ctx.study(scenario, seed);
    // The errors before calibration depend on the robot only: the first design computes them.
    let without_before = kincal::montecarlo::Study {
        validation_nominal: &[],
        ..with_before
    };
    pb.stage(runs * designs.len() as u64, label);
    let mut out = Vec::with_capacity(designs.len());
    let (t0, c0) = (Instant::now(), cpu_seconds());
    for (k, d) in designs.iter().enumerate() {
        let study = if k == 0 { with_before } else { without_before };
        let m = d.q.len();
        let core = d.core();
        let empty = Measurement::new([0.0; N], Transform::identity());
        let analysis = prepare_design(&study, d)?;
        let o = d.indices(ctx)?.o;
        let t = Instant::now();
        let results: Vec<Result<RunResult, kincal::Error>> = (0..runs as usize)
            .into_par_iter()
            .with_min_len(16)
            .map_init(
                || (Box::<Workspace<P>>::default(), vec![empty; m]),
                |(ws, data), run| {
                    let r = simulate_run(&study, &core, &analysis, run as u64, ws, data);
                    pb.inc(1);
                    r
                },
            )
            .collect();
        let seconds = t.elapsed().as_secs_f64();
        let mut r = DesignResult {
            name: d.name.clone(),
            acquisition: d.acquisition,
            poses: m,
            o,
            runs,
            failed: 0,
            first_failure: None,
            max_pos_mm: Vec::with_capacity(results.len()),
            max_rot_deg: Vec::with_capacity(results.len()),
            rms_pos_mm: Vec::with_capacity(results.len()),
            rms_rot_deg: Vec::with_capacity(results.len()),
            before_pos_mm: Vec::with_capacity(results.len()),
            before_rot_deg: Vec::with_capacity(results.len()),
            mean_iterations: 0.0,
            seconds,
        };
        let mut iters = 0u64;
        for (run, res) in results.into_iter().enumerate() {
            match res {
                Ok(x) => {
                    r.max_pos_mm.push(x.max_pos_m * 1e3);
                    r.max_rot_deg.push(x.max_rot_rad.to_degrees());
                    r.rms_pos_mm.push(x.rms_pos_m * 1e3);
                    r.rms_rot_deg.push(x.rms_rot_rad.to_degrees());
                    if k == 0 {
                        r.before_pos_mm.push(x.before_max_pos_m * 1e3);
                        r.before_rot_deg.push(x.before_max_rot_rad.to_degrees());
                    }
                    iters += u64::from(x.iterations);
                }
                Err(e) => {
                    r.failed += 1;
                    if r.first_failure.is_none() {
                        r.first_failure = Some(format!("run {run}: {e}"));
                    }
                }
            }
        }
        r.mean_iterations = iters as f64 / r.max_pos_mm.len().max(1) as f64;
        out.push(r);
    }
    let wall_s = t0.elapsed().as_secs_f64();
    let cpu_s = match (c0, cpu_seconds()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    Ok((
        out,
        Timing {
            calibrations: runs * designs.len() as u64,
            wall_s,
            cpu_s,
            threads: rayon::current_num_threads(),
        },
    ))
}

fn summary_json(s: Summary) -> serde_json::Value {
    serde_json::json!({"median": s.median, "p95": s.p95, "max": s.max, "mean": s.mean})
}

/// The numbers of a study as JSON.
pub fn results_json(results: &[DesignResult]) -> serde_json::Value {
    serde_json::Value::Array(
        results
            .iter()
            .map(|r| {
                serde_json::json!({
                    "name": r.name,
                    "acquisition": match r.acquisition { Acquisition::Instrument => "instrument", Acquisition::Tool => "tool" },
                    "poses": r.poses,
                    "o_eq17": r.o,
                    "runs": r.runs,
                    "failed": r.failed,
                    "first_failure": r.first_failure,
                    "worst_pose_e_p_mm": summary_json(r.pos()),
                    "worst_pose_e_phi_deg": summary_json(r.rot()),
                    "rms_e_p_mm": summary_json(Summary::of(&r.rms_pos_mm)),
                    "rms_e_phi_deg": summary_json(Summary::of(&r.rms_rot_deg)),
                    "before_worst_pose_e_p_mm": summary_json(Summary::of(&r.before_pos_mm)),
                    "before_worst_pose_e_phi_deg": summary_json(Summary::of(&r.before_rot_deg)),
                    "mean_iterations": r.mean_iterations,
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_uses_nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        let s = Summary::of(&v);
        assert_eq!((s.median, s.p95, s.max, s.mean), (50.5, 95.0, 100.0, 50.5));
        let s = Summary::of(&[3.0, 1.0, 2.0]);
        assert_eq!((s.median, s.p95, s.max), (2.0, 3.0, 3.0));
        assert_eq!(Summary::of(&[]), Summary::default());
    }
}
