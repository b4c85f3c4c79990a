//! `kincal crossval` on data with target/plane rows (docs/constraints.md): whole groups
//! held out (`--group-by target|session|pose_id`). With constraint data, training and
//! testing on the same placement overfits (a fit can make the contacts of one placement
//! coincide without the model being right elsewhere), so only held-out placements are an
//! honest test.
//!
//! Scoring: a held-out row of a target is scored by the distance of its predicted tool
//! point from the target **re-estimated from the held-out rows of that target only** (the
//! training rows never tell where a held-out target is); a plane likewise (its plane fitted
//! to the held-out contacts). Groups with fewer than 2 held-out contacts (targets) or 4
//! (planes) say nothing and are not scored. A known distance is scored when both its
//! targets have held-out contacts.

use std::fmt::Write as _;

use kincal::identify::{
    Algorithm, IdentifyOptions, Loss, PoseResidual, RobustOptions, distance_estimate,
    group_estimate, identify_constrained, identify_constrained_robust,
};
use kincal::{ParamSet, Robot};
use serde_json::{Value, json};

use crate::error::CliError;
use kincal_io::calibration::new_workspace;
use kincal_io::constraints::ContactData;
use kincal_io::measurements::MeasurementSet;

/// What a fold holds out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum GroupBy {
    /// Every row of a target or plane.
    Target,
    /// Every row of a session (a placement of the fixture).
    Session,
    /// Rows sharing a pose_id (each row alone without that column).
    PoseId,
}

/// Held-out scores of one model on one fold.
#[derive(Debug, Clone, Default)]
struct Score {
    /// Per scored group: (mean, rms, max) residual distance [m] and contacts.
    groups: Vec<(f64, f64, f64, usize)>,
    /// |predicted − known| of scored distances [m].
    distances: Vec<f64>,
}

impl Score {
    fn add(&mut self, other: &Score) {
        self.groups.extend(other.groups.iter().copied());
        self.distances.extend(other.distances.iter().copied());
    }
    /// Contact-weighted mean |e| [mm], RMS [mm], max [mm], mean |distance error| [mm].
    fn summary(&self) -> (f64, f64, f64, Option<f64>) {
        let n: usize = self.groups.iter().map(|g| g.3).sum();
        let n = n.max(1) as f64;
        let mean = self.groups.iter().map(|g| g.0 * g.3 as f64).sum::<f64>() / n;
        let rms = (self
            .groups
            .iter()
            .map(|g| g.1 * g.1 * g.3 as f64)
            .sum::<f64>()
            / n)
            .sqrt();
        let max = self.groups.iter().map(|g| g.2).fold(0.0, f64::max);
        let d = (!self.distances.is_empty())
            .then(|| self.distances.iter().sum::<f64>() / self.distances.len() as f64 * 1e3);
        (mean * 1e3, rms * 1e3, max * 1e3, d)
    }
}

/// Scores `robot` on the rows of `cd` with a positive weight (the held-out rows).
fn score<const N: usize>(robot: &Robot<N>, cd: &ContactData<N>) -> Result<Score, kincal::Error> {
    let d = cd.view();
    let mut s = Score::default();
    for (g, info) in cd.info.iter().enumerate() {
        let active = d
            .contacts
            .get(d.groups[g].start..d.groups[g].start + d.groups[g].len)
            .map_or(0, |c| c.iter().filter(|c| c.weight > 0.0).count());
        if active < if info.plane { 4 } else { 2 } {
            continue;
        }
        let e = group_estimate(robot, &d, g)?;
        s.groups.push((e.mean_m, e.rms_m, e.max_m, e.contacts));
    }
    for (k, spec) in cd.distance_specs.iter().enumerate() {
        if let Some(p) = distance_estimate(robot, &d, k)? {
            s.distances.push((p - spec.m).abs());
        }
    }
    Ok(s)
}

/// Group label of every row, and the number of groups.
pub(crate) fn groups_of(
    set: &MeasurementSet,
    by: GroupBy,
) -> Result<(Vec<usize>, Vec<String>), CliError> {
    let mut labels: Vec<String> = Vec::new();
    let mut of = Vec::with_capacity(set.rows.len());
    for (i, r) in set.rows.iter().enumerate() {
        let label = match by {
            GroupBy::Target => r
                .target
                .clone()
                .or_else(|| r.plane.clone().map(|p| format!("plane {p}")))
                .unwrap_or_else(|| format!("#row{i}")),
            GroupBy::Session => match &r.session {
                Some(s) => s.clone(),
                None => {
                    return Err(CliError::usage(format!(
                        "--group-by session: {} has no session column",
                        set.source
                    )));
                }
            },
            GroupBy::PoseId => r.pose_id.clone().unwrap_or_else(|| format!("#row{i}")),
        };
        let g = match labels.iter().position(|l| *l == label) {
            Some(g) => g,
            None => {
                labels.push(label);
                labels.len() - 1
            }
        };
        of.push(g);
    }
    Ok((of, labels))
}

/// Fits the requested parameters on the rows of `cd` with a positive weight (OLS, then
/// OPT2 if OLS does not converge; identifiable subset); with `robust`, by IRLS with that
/// loss (core `identify_constrained_robust`, as `calibrate --robust`: held-out rows keep
/// their zero weight).
pub(crate) fn fit<const N: usize>(
    start: &Robot<N>,
    cd: &ContactData<N>,
    requested: ParamSet,
    weight_pos: f64,
    max_iterations: u32,
    robust: Option<Loss>,
) -> Result<(Robot<N>, &'static str), String> {
    let mut ws = new_workspace();
    let mut last = String::new();
    for algorithm in [Algorithm::Ols, Algorithm::Opt2] {
        let mut o = IdentifyOptions::new(algorithm, requested);
        o.weight_pos = weight_pos;
        o.allow_data_deficiency = true;
        o.max_iterations = max_iterations;
        o.covariance = false;
        let result = match robust {
            None => identify_constrained(start, &cd.view(), &o, &mut ws),
            Some(loss) => {
                let (mut inst, mut contacts) = (cd.instrument.clone(), cd.contacts.clone());
                let mut rows = vec![PoseResidual::default(); inst.len() + contacts.len()];
                identify_constrained_robust(
                    start,
                    &mut inst,
                    &mut contacts,
                    &cd.groups,
                    &cd.distances,
                    &o,
                    &RobustOptions::new(loss),
                    &mut rows,
                    &mut ws,
                )
                .map(|r| r.fit)
            }
        };
        match result {
            Ok(id) => return Ok((id.robot, algorithm.name())),
            Err(e @ kincal::Error::NotConverged { .. }) => last = e.to_string(),
            Err(e) => return Err(e.to_string()),
        }
    }
    Err(last)
}

/// Settings of a contact cross-validation.
#[derive(Debug)]
pub struct Plan<'a> {
    pub group_by: GroupBy,
    pub folds: usize,
    pub seed: u64,
    pub requested: ParamSet,
    pub weight_pos: f64,
    pub max_iterations: u32,
    pub constraints: Option<&'a kincal_io::constraints::ConstraintsFile>,
    /// IRLS loss of every fold's fit (`--robust`), or least squares.
    pub robust: Option<Loss>,
}

/// Runs the cross-validation; returns the report text and its JSON.
pub fn run<const N: usize>(
    nominal: &Robot<N>,
    set: &MeasurementSet,
    plan: &Plan<'_>,
) -> Result<(String, Value), CliError> {
    let base = kincal_io::constraints::build::<N>(set, plan.constraints, nominal, plan.weight_pos)?;
    let (group_of, labels) = groups_of(set, plan.group_by)?;
    let k = plan.folds.min(labels.len());
    if k < 2 {
        return Err(CliError::input(format!(
            "{}: {} group(s) by {:?}: expected at least 2 to hold one out",
            set.source,
            labels.len(),
            plan.group_by
        )));
    }
    // Groups shuffled with the seed (SplitMix64), dealt round-robin.
    let mut order: Vec<usize> = (0..labels.len()).collect();
    let mut state = plan.seed;
    for i in (1..order.len()).rev() {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        order.swap(i, (z % (i as u64 + 1)) as usize);
    }
    let mut fold_of_group = vec![0; labels.len()];
    for (pos, &g) in order.iter().enumerate() {
        fold_of_group[g] = pos % k;
    }
    let fold_of = |row: usize| fold_of_group[group_of[row]];
    let mut total_nom = Score::default();
    let mut total_cal = Score::default();
    let mut folds_json = Vec::new();
    let mut text = String::new();
    let _ = writeln!(
        text,
        "Cross-validation of {} by {:?}: {} groups in {k} folds (held-out rows scored about their \
         target/plane re-estimated from the held-out rows only); fits: {}",
        set.source,
        plan.group_by,
        labels.len(),
        plan.robust.map_or("least squares".to_string(), |l| format!(
            "robust ({} IRLS on the training rows)",
            l.name()
        ))
    );
    let _ = writeln!(
        text,
        "  fold  held-out groups  nominal mean|e| [mm]  calibrated mean|e| [mm]  nominal |dist err| [mm]  calibrated |dist err| [mm]  fit"
    );
    for f in 0..k {
        let mut train = base.clone();
        train.select(|r| fold_of(r) != f);
        let mut test = base.clone();
        test.select(|r| fold_of(r) == f);
        let (cal, algorithm) = fit(
            nominal,
            &train,
            plan.requested,
            plan.weight_pos,
            plan.max_iterations,
            plan.robust,
        )
        .map_err(|e| CliError::numeric(format!("{}: fold {}: {e}", set.source, f + 1)))?;
        let fail =
            |e: kincal::Error| CliError::numeric(format!("{}: fold {}: {e}", set.source, f + 1));
        let s_nom = score(nominal, &test).map_err(fail)?;
        let s_cal = score(&cal, &test).map_err(fail)?;
        let (nm, _, _, nd) = s_nom.summary();
        let (cm, _, _, cdist) = s_cal.summary();
        let held: Vec<&str> = labels
            .iter()
            .enumerate()
            .filter(|(g, _)| fold_of_group[*g] == f)
            .map(|(_, l)| l.as_str())
            .collect();
        let fmt_d = |d: Option<f64>| d.map_or("–".to_string(), |v| format!("{v:.4}"));
        let _ = writeln!(
            text,
            "  {:>4}  {:>15}  {nm:>20.4}  {cm:>23.4}  {:>23}  {:>26}  {algorithm}",
            f + 1,
            held.len(),
            fmt_d(nd),
            fmt_d(cdist)
        );
        folds_json.push(json!({
            "fold": f + 1,
            "held_out": held,
            "nominal": {"mean_mm": nm, "distance_error_mm": nd},
            "calibrated": {"mean_mm": cm, "distance_error_mm": cdist},
            "algorithm": algorithm,
        }));
        total_nom.add(&s_nom);
        total_cal.add(&s_cal);
    }
    let (nm, nr, nx, nd) = total_nom.summary();
    let (cm, cr, cx, cdist) = total_cal.summary();
    let _ = writeln!(
        text,
        "\nHeld out, all folds ({} scored groups):\n  model        mean|e| [mm]   RMS [mm]   max [mm]   mean |dist err| [mm]",
        total_cal.groups.len()
    );
    let fmt_d = |d: Option<f64>| d.map_or("–".to_string(), |v| format!("{v:.4}"));
    let _ = writeln!(
        text,
        "  nominal     {nm:>12.4} {nr:>10.4} {nx:>10.4} {:>22}",
        fmt_d(nd)
    );
    let _ = writeln!(
        text,
        "  calibrated  {cm:>12.4} {cr:>10.4} {cx:>10.4} {:>22}",
        fmt_d(cdist)
    );
    let json = json!({
        "group_by": format!("{:?}", plan.group_by).to_lowercase(),
        "robust_loss": plan.robust.map(Loss::name),
        "folds": folds_json,
        "held_out": {
            "scored_groups": total_cal.groups.len(),
            "nominal": {"mean_mm": nm, "rms_mm": nr, "max_mm": nx, "distance_error_mm": nd},
            "calibrated": {"mean_mm": cm, "rms_mm": cr, "max_mm": cx, "distance_error_mm": cdist},
        },
    });
    Ok((text, json))
}
