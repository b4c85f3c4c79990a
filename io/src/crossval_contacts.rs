//! The cross-validation of data with target/plane rows (docs/constraints.md), shared by
//! `kincal crossval` and Python's `kincal.crossval`: whole groups held out (`GroupBy`). With
//! constraint data, training and testing on the same placement overfits (a fit can make the
//! contacts of one placement coincide without the model being right elsewhere), so only
//! held-out placements are an honest test. The result is a [`Report`] (data); [`json`] is
//! `kincal crossval --json`; the front ends word it.
//!
//! Scoring: a held-out row of a target is scored by the distance of its predicted tool
//! point from the target **re-estimated from the held-out rows of that target only** (the
//! training rows never tell where a held-out target is); a plane likewise (its plane fitted
//! to the held-out contacts). Groups with fewer than 2 held-out contacts (targets) or 4
//! (planes) say nothing and are not scored. A known distance is scored when both its
//! targets have held-out contacts.
//!
//! Instrument rows in several sessions (each later session in a frame of its own, calibrate's
//! session-frame path): with `--group-by session` every held-out session is scored after
//! fitting only its frame ([`crate::session_scores`], the function `kincal validate` uses),
//! one scored group per session (mean, RMS, max of |e_p| over its rows). Other groupings of
//! such data without contact rows are refused: a held-out row of a framed session has no
//! frame to be scored in.

use kincal::identify::{
    Algorithm, Identification, IdentifyOptions, Loss, PoseResidual, RobustOptions,
    distance_estimate, group_estimate, identify_constrained, identify_constrained_robust,
};
use kincal::{ParamSet, Robot};
use serde_json::{Value, json};

use crate::calibration::new_workspace;
use crate::constraints::{ConstraintsFile, ContactData};
use crate::effects_arg::EffectChoice;
use crate::error::Error;
use crate::measurements::MeasurementSet;

/// What a fold holds out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum GroupBy {
    /// Every row of a target or plane.
    Target,
    /// Every row of a session (a placement of the fixture).
    Session,
    /// Rows sharing a pose_id (each row alone without that column).
    PoseId,
}

impl GroupBy {
    /// By session when the data have a session column, else by target/plane.
    pub fn default_for(set: &MeasurementSet) -> GroupBy {
        if set.has_session {
            GroupBy::Session
        } else {
            GroupBy::Target
        }
    }
    /// The name in the JSON report (`target`, `session`, `poseid`).
    pub fn json_name(self) -> String {
        format!("{self:?}").to_lowercase()
    }
}

/// Held-out scores of one model on one fold.
#[derive(Debug, Clone, Default)]
struct Score {
    /// Per scored group: (mean, rms, max) residual distance [m] and contacts.
    groups: Vec<(f64, f64, f64, usize)>,
    /// |predicted − known| of scored distances [m].
    distances: Vec<f64>,
}

/// A held-out score summarised (contact-weighted over the scored groups).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Mean residual distance [mm].
    pub mean_mm: f64,
    /// RMS residual distance [mm].
    pub rms_mm: f64,
    /// Largest residual distance [mm].
    pub max_mm: f64,
    /// Mean |predicted − known| of the scored known distances [mm]; `None` without any.
    pub distance_error_mm: Option<f64>,
}

impl Score {
    fn add(&mut self, other: &Score) {
        self.groups.extend(other.groups.iter().copied());
        self.distances.extend(other.distances.iter().copied());
    }
    fn summary(&self) -> Summary {
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
        Summary {
            mean_mm: mean * 1e3,
            rms_mm: rms * 1e3,
            max_mm: max * 1e3,
            distance_error_mm: d,
        }
    }
}

/// Scores `robot` on the rows of `cd` with a positive weight (the held-out rows); with
/// `sessions`, each held-out instrument session too, after fitting only its frame.
fn score<const N: usize>(
    robot: &Robot<N>,
    cd: &ContactData<N>,
    sessions: bool,
) -> Result<Score, kincal::Error> {
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
    if sessions {
        let scored = crate::session_scores::score_sessions(
            robot,
            cd,
            crate::session_scores::BaseSession::FitFrame,
        )
        .map_err(|(_, e)| e)?;
        for x in scored.iter().filter(|x| x.summary.count_pos() > 0) {
            s.groups.push((
                x.mean_pos_m,
                x.summary.rms_pos_m(),
                x.summary.max_pos_m,
                x.summary.count_pos(),
            ));
        }
    }
    Ok(s)
}

/// Group label of every row, and the labels of the groups in order of first appearance.
pub fn groups_of(set: &MeasurementSet, by: GroupBy) -> Result<(Vec<usize>, Vec<String>), Error> {
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
                    return Err(Error::usage(format!(
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
/// their zero weight). Returns the identification (model, fitted set) and the algorithm's
/// name.
pub fn fit<const N: usize>(
    start: &Robot<N>,
    cd: &ContactData<N>,
    requested: ParamSet,
    weight_pos: f64,
    max_iterations: u32,
    robust: Option<Loss>,
) -> Result<(Box<Identification<N>>, &'static str), String> {
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
            Ok(id) => return Ok((Box::new(id), algorithm.name())),
            Err(e @ kincal::Error::NotConverged { .. }) => last = e.to_string(),
            Err(e) => return Err(e.to_string()),
        }
    }
    Err(last)
}

/// The parameters every fold fits: the chosen geometry (`crossval::geometry_subset`'s
/// kinds), the chosen effects' parameters and the contacted point (ball centre) as the
/// tool translation.
pub fn requested_params<const N: usize>(
    nominal: &Robot<N>,
    geometry: &[String],
    effects: &EffectChoice,
) -> ParamSet {
    let mut requested =
        crate::crossval::geometry_subset(nominal, geometry).union(&effects.effect_params(N));
    for k in 0..3 {
        let _ = requested.insert(5 * N + 6 + k);
    }
    requested
}

/// The weight of a contact residual from the stated position noise `sigma_pos_mm` (1σ per
/// axis [mm]): 1/σ² with σ in metres, 1 when none is stated.
pub fn weight_pos(sigma_pos_mm: Option<f64>) -> f64 {
    sigma_pos_mm.map_or(1.0, |s| 1.0 / (s * 1e-3).powi(2))
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
    pub constraints: Option<&'a ConstraintsFile>,
    /// IRLS loss of every fold's fit (`--robust`), or least squares.
    pub robust: Option<Loss>,
}

/// One fold: the labels of its held-out groups and both models' scores on them.
#[derive(Debug, Clone)]
pub struct FoldReport {
    /// 1-based.
    pub fold: usize,
    pub held_out: Vec<String>,
    pub nominal: Summary,
    pub calibrated: Summary,
    /// The algorithm that fitted the fold (`OLS`, or `OPT2` when OLS did not converge).
    pub algorithm: &'static str,
}

/// A contact cross-validation's result (its JSON: [`json`]).
#[derive(Debug, Clone)]
pub struct Report {
    /// The data's name (file path).
    pub source: String,
    pub group_by: GroupBy,
    /// Number of groups dealt into the folds.
    pub groups: usize,
    pub robust: Option<Loss>,
    pub folds: Vec<FoldReport>,
    /// Scored groups over all folds (held-out instrument sessions included).
    pub scored_groups: usize,
    /// Held-out instrument sessions were scored after fitting their frames (instrument rows
    /// in several sessions, `--group-by session`).
    pub instrument_sessions: bool,
    /// Held out, all folds.
    pub nominal: Summary,
    pub calibrated: Summary,
}

/// The fold (0-based) of every group: groups shuffled with the seed (SplitMix64), dealt
/// round-robin into `k` folds.
fn deal_groups(groups: usize, k: usize, seed: u64) -> Vec<usize> {
    let mut order: Vec<usize> = (0..groups).collect();
    let mut state = seed;
    for i in (1..order.len()).rev() {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        order.swap(i, (z % (i as u64 + 1)) as usize);
    }
    let mut fold_of_group = vec![0; groups];
    for (pos, &g) in order.iter().enumerate() {
        fold_of_group[g] = pos % k;
    }
    fold_of_group
}

/// Runs the cross-validation.
pub fn run<const N: usize>(
    nominal: &Robot<N>,
    set: &MeasurementSet,
    plan: &Plan<'_>,
) -> Result<Report, Error> {
    let base = crate::constraints::build::<N>(set, plan.constraints, nominal, plan.weight_pos)?;
    let sessions = base.base_session.is_some();
    if sessions && base.contacts.is_empty() && plan.group_by != GroupBy::Session {
        return Err(Error::usage(format!(
            "--group-by {}: {} has instrument rows in several sessions, each later session in \
             a frame of its own: expected --group-by session (a held-out session is scored \
             after fitting only its frame; a held-out row has no frame to be scored in)",
            match plan.group_by {
                GroupBy::Target => "target",
                GroupBy::Session => "session",
                GroupBy::PoseId => "pose-id",
            },
            set.source
        )));
    }
    let sessions = sessions && plan.group_by == GroupBy::Session;
    let (group_of, labels) = groups_of(set, plan.group_by)?;
    let k = plan.folds.min(labels.len());
    if k < 2 {
        return Err(Error::input(format!(
            "{}: {} group(s) by {:?}: expected at least 2 to hold one out",
            set.source,
            labels.len(),
            plan.group_by
        )));
    }
    let fold_of_group = deal_groups(labels.len(), k, plan.seed);
    let fold_of = |row: usize| fold_of_group[group_of[row]];
    let mut total_nom = Score::default();
    let mut total_cal = Score::default();
    let mut folds = Vec::with_capacity(k);
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
        .map(|(id, algorithm)| (id.robot, algorithm))
        .map_err(|e| Error::numeric(format!("{}: fold {}: {e}", set.source, f + 1)))?;
        let fail =
            |e: kincal::Error| Error::numeric(format!("{}: fold {}: {e}", set.source, f + 1));
        let s_nom = score(nominal, &test, sessions).map_err(fail)?;
        let s_cal = score(&cal, &test, sessions).map_err(fail)?;
        let held_out = labels
            .iter()
            .zip(&fold_of_group)
            .filter(|(_, fold)| **fold == f)
            .map(|(l, _)| l.clone())
            .collect();
        folds.push(FoldReport {
            fold: f + 1,
            held_out,
            nominal: s_nom.summary(),
            calibrated: s_cal.summary(),
            algorithm,
        });
        total_nom.add(&s_nom);
        total_cal.add(&s_cal);
    }
    Ok(Report {
        source: set.source.clone(),
        group_by: plan.group_by,
        groups: labels.len(),
        robust: plan.robust,
        folds,
        scored_groups: total_cal.groups.len(),
        instrument_sessions: sessions,
        nominal: total_nom.summary(),
        calibrated: total_cal.summary(),
    })
}

/// The report as `kincal crossval --json` writes it (and Python's `kincal.crossval`
/// returns it).
pub fn json(report: &Report) -> Value {
    let folds: Vec<Value> = report
        .folds
        .iter()
        .map(|f| {
            json!({
                "fold": f.fold,
                "held_out": f.held_out,
                "nominal": {"mean_mm": f.nominal.mean_mm, "distance_error_mm": f.nominal.distance_error_mm},
                "calibrated": {"mean_mm": f.calibrated.mean_mm, "distance_error_mm": f.calibrated.distance_error_mm},
                "algorithm": f.algorithm,
            })
        })
        .collect();
    let all = |s: &Summary| json!({"mean_mm": s.mean_mm, "rms_mm": s.rms_mm, "max_mm": s.max_mm, "distance_error_mm": s.distance_error_mm});
    let mut v = json!({
        "group_by": report.group_by.json_name(),
        "robust_loss": report.robust.map(Loss::name),
        "folds": folds,
        "held_out": {
            "scored_groups": report.scored_groups,
            "nominal": all(&report.nominal),
            "calibrated": all(&report.calibrated),
        },
    });
    // Only with instrument sessions, so the reports of other data keep their bytes.
    if report.instrument_sessions {
        v["instrument_sessions"] =
            json!("each held-out session scored after fitting only its frame");
    }
    v
}

/// Whether a cross-validation of `set` takes this module's route: a constraints file given,
/// target/plane rows, or instrument rows in several sessions (frames eliminated as calibrate
/// does; the pose path has one base frame).
pub fn takes_this_route(set: &MeasurementSet, constraints_given: bool) -> bool {
    constraints_given
        || crate::constraints::has_contacts(set)
        || crate::constraints::has_instrument_sessions(set)
}
