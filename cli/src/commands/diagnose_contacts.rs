//! `kincal diagnose` on instrument-free data (rows with `target`/`plane`; docs/constraints.md,
//! "Diagnosis"). The instrument diagnosis (`kincal::diagnosis`) needs measured poses; contact
//! data measure only coincidences, coplanarities and distances, so the verdict is built here
//! from the contact machinery that already exists:
//!
//! - folds hold out whole **sessions** (leave-one-session-out; without a session column,
//!   `--folds` folds of whole targets/planes); every model is fitted on the other sessions
//!   (`crossval_contacts::fit`: geometry + the contacted point as tool translation + the
//!   candidate's effect parameters; gauge and data-deficient parameters held);
//! - a held-out target (plane) is scored about itself **re-estimated from its held-out
//!   contacts only** (as `crossval --group-by session`), per target Σ‖e‖²;
//! - a candidate is compared with the geometric model by the Wilcoxon signed-rank z of the
//!   per-target differences of Σ‖e‖² (core: `diagnosis::contacts::signed_rank_z`), the gap
//!   by a χ² test against a stated σ (`contact_gap_z`).
//!
//! Effects contact data cannot express are not candidates and the report says why: base and
//! tool frames (no external reference: the base is a gauge; the tool translation is already
//! fitted as the contacted point, its rotation moves no point), backlash without `s1..sN`,
//! thermal without `temp_c`, joint compliance without a mass model.

use std::fmt::Write as _;
use std::path::Path;

use kincal::diagnosis::contacts::{contact_gap_z, signed_rank_z};
use kincal::identify::group_estimate;
use kincal::{Effect, EffectSet, Robot};
use serde_json::{Value, json};

use crate::commands::crossval_contacts::{GroupBy, fit, groups_of};
use crate::error::CliError;
use kincal_io::constraints::ContactData;
use kincal_io::measurements::MeasurementSet;

/// What the contact diagnosis takes from `kincal diagnose`'s arguments (the command's
/// `Args` build it, so that this module does not import the command).
#[derive(Debug, Clone, Copy)]
pub struct Options<'a> {
    /// `--candidates` (empty: every effect whose inputs the data have).
    pub candidates: &'a [Effect],
    /// `--no-pairs`: single effects only.
    pub no_pairs: bool,
    /// `--constraints`: known distances, targets and planes.
    pub constraints: Option<&'a Path>,
    /// `--sigma-pos-mm`: instrument position noise, 1σ per axis [mm].
    pub sigma_pos_mm: Option<f64>,
    /// `--folds`: folds of whole targets/planes when there is no session column.
    pub folds: usize,
}

/// Significance threshold of the paired and gap tests (one-sided z), as the instrument
/// diagnosis.
const Z: f64 = 3.0;

/// Held-out score of one model: per scored group (index into `ContactData::info`)
/// Σ‖e‖² \[m²\], Σ‖e‖ \[m\] and contacts; |distance errors| \[m\].
#[derive(Debug, Clone, Default)]
struct Held {
    groups: Vec<(usize, f64, f64, usize)>,
    distances: Vec<f64>,
}

impl Held {
    fn contacts(&self) -> usize {
        self.groups.iter().map(|g| g.3).sum()
    }
    /// (mean |e|, RMS, mean |distance error|) \[mm\].
    fn summary(&self) -> (f64, f64, Option<f64>) {
        let n = self.contacts().max(1) as f64;
        let mean = self.groups.iter().map(|g| g.2).sum::<f64>() / n;
        let rms = (self.groups.iter().map(|g| g.1).sum::<f64>() / n).sqrt();
        let d = (!self.distances.is_empty())
            .then(|| self.distances.iter().sum::<f64>() / self.distances.len() as f64 * 1e3);
        (mean * 1e3, rms * 1e3, d)
    }
    /// Σ‖e‖² of each group, indexed by group (0 where not scored).
    fn per_group(&self, groups: usize) -> Vec<f64> {
        let mut v = vec![0.0; groups];
        for g in &self.groups {
            if let Some(x) = v.get_mut(g.0) {
                *x = g.1;
            }
        }
        v
    }
}

/// Scores `robot` on the held-out (positive-weight) rows of `cd`.
fn score<const N: usize>(robot: &Robot<N>, cd: &ContactData<N>) -> Result<Held, kincal::Error> {
    let d = cd.view();
    let mut h = Held::default();
    for (g, info) in cd.info.iter().enumerate() {
        let Some(group) = d.groups.get(g) else {
            continue;
        };
        let active = d
            .contacts
            .get(group.start..group.start + group.len)
            .map_or(0, |c| c.iter().filter(|c| c.weight > 0.0).count());
        if active < if info.plane { 4 } else { 2 } {
            continue;
        }
        let e = group_estimate(robot, &d, g)?;
        let n = e.contacts as f64;
        h.groups
            .push((g, e.rms_m * e.rms_m * n, e.mean_m * n, e.contacts));
    }
    for (k, spec) in cd.distance_specs.iter().enumerate() {
        if let Some(p) = kincal::identify::distance_estimate(robot, &d, k)? {
            h.distances.push((p - spec.m).abs());
        }
    }
    Ok(h)
}

/// Whether the robot has a mass model (some mass and gravity): compliance needs torques.
fn has_mass_model<const N: usize>(robot: &Robot<N>) -> bool {
    let m = robot.mass();
    let some_mass = m.link_masses_kg.iter().any(|&x| x > 0.0) || m.tool_mass_kg > 0.0;
    some_mass && m.gravity.iter().any(|&g| g != 0.0)
}

/// Effects that are not candidates, with the reason.
type NotTestable = Vec<(Effect, &'static str)>;

/// The candidates and, for every effect that is not one, why.
fn candidates<const N: usize>(
    robot: &Robot<N>,
    set: &MeasurementSet,
    args: &Options<'_>,
) -> Result<(Vec<EffectSet>, NotTestable), CliError> {
    let mut not_testable = vec![
        (
            Effect::BaseFrame,
            "not observable without an instrument row, known target or known plane (a rigid \
             motion of the base moves every contact together)",
        ),
        (
            Effect::ToolFrame,
            "its translation (the contacted point) is fitted in every model; its rotation \
             moves no contacted point",
        ),
    ];
    let mut singles = EffectSet::NONE;
    for e in [
        Effect::JointCompliance,
        Effect::JointScale,
        Effect::JointCyclic,
        Effect::Backlash,
        Effect::Thermal,
    ] {
        let why = match e {
            Effect::JointCompliance if !has_mass_model(robot) => {
                Some("the robot has no mass model (its URDF has no <inertial> masses)")
            }
            Effect::Backlash if !set.has_approach => {
                Some("needs the approach direction of every joint (columns s1..sN), absent")
            }
            Effect::Thermal if !set.has_temperature => Some("needs temp_c, absent"),
            _ => None,
        };
        let asked = args.candidates.is_empty() || args.candidates.contains(&e);
        match why {
            Some(w) if asked => not_testable.push((e, w)),
            None if asked => singles = singles.with(e),
            _ => {}
        }
    }
    if let Some(e) = args
        .candidates
        .iter()
        .find(|e| matches!(e, Effect::BaseFrame | Effect::ToolFrame))
    {
        return Err(CliError::usage(format!(
            "--candidates {e}: not a candidate for data with target/plane rows ({})",
            not_testable
                .iter()
                .find(|(x, _)| x == e)
                .map_or("", |(_, w)| *w)
        )));
    }
    let mut sets: Vec<EffectSet> = singles.iter().map(EffectSet::of).collect();
    if !args.no_pairs {
        for a in singles.iter() {
            for b in singles.iter().filter(|&b| b > a) {
                sets.push(EffectSet::of(a).with(b));
            }
        }
    }
    Ok((sets, not_testable))
}

fn effects_name(s: EffectSet) -> String {
    if s == EffectSet::NONE {
        return "geometric".into();
    }
    s.iter().map(Effect::name).collect::<Vec<_>>().join("+")
}

/// One evaluated model.
struct Model {
    effects: EffectSet,
    held: Held,
    /// Per group Σ‖e‖² (0 where not scored).
    per_group: Vec<f64>,
}

/// Runs the diagnosis on contact data; returns the readable report and its JSON.
pub fn run<const N: usize>(
    nominal: &Robot<N>,
    set: &MeasurementSet,
    args: &Options<'_>,
) -> Result<(String, Value), CliError> {
    let cons = args
        .constraints
        .map(kincal_io::constraints::read_constraints)
        .transpose()?;
    let sigma_m = args.sigma_pos_mm.map(|s| s * 1e-3);
    let weight_pos = sigma_m.map_or(1.0, |s| 1.0 / (s * s));
    let base = kincal_io::constraints::build::<N>(set, cons.as_ref(), nominal, weight_pos)?;
    if !base.instrument.is_empty() {
        return Err(CliError::input(format!(
            "{}: diagnose on data with target/plane rows: instrument rows (x, y, z) in the same \
             file are not supported; diagnose them separately",
            set.source
        )));
    }
    let by = if set.has_session {
        GroupBy::Session
    } else {
        GroupBy::Target
    };
    let (group_of, labels) = groups_of(set, by)?;
    let k = if by == GroupBy::Session {
        labels.len()
    } else {
        args.folds.min(labels.len())
    };
    if k < 2 {
        return Err(CliError::input(format!(
            "{}: {} {:?} group(s): at least 2 are needed to hold one out",
            set.source,
            labels.len(),
            by
        )));
    }
    let fold_of = |row: usize| group_of.get(row).map_or(0, |g| g % k);
    let (sets, not_testable) = candidates(nominal, set, args)?;
    // The link parameters the robot identifies (d or β per link), as calibrate/crossval.
    let mut geometry = nominal.geometric_param_set();
    for t in 0..3 {
        let _ = geometry.insert(5 * N + 6 + t);
    }
    let pb = crate::progress::spinner("diagnosing contact data (every candidate held out)");
    let mut models: Vec<Model> = Vec::new();
    let mut not_evaluated: Vec<(EffectSet, String)> = Vec::new();
    let mut failed = None;
    for effects in std::iter::once(EffectSet::NONE).chain(sets.iter().copied()) {
        let requested = geometry.union(&effects.params(N));
        let mut held = Held::default();
        for f in 0..k {
            let mut train = base.clone();
            train.select(|r| fold_of(r) != f);
            let mut test = base.clone();
            test.select(|r| fold_of(r) == f);
            let fail = |e: String| {
                CliError::numeric(format!(
                    "{}: {} held out, {}: {e}",
                    set.source,
                    labels.get(f).map_or("?", String::as_str),
                    effects_name(effects)
                ))
            };
            let s = fit(nominal, &train, requested, weight_pos, 100, None)
                .and_then(|(cal, _)| score(&cal, &test).map_err(|e| e.to_string()));
            match s {
                Ok(s) => {
                    held.groups.extend(s.groups);
                    held.distances.extend(s.distances);
                }
                // The geometric model must fit; a candidate that does not is reported.
                Err(e) if effects == EffectSet::NONE => return Err(fail(e)),
                Err(e) => {
                    failed = Some(fail(e).to_string());
                    break;
                }
            }
        }
        if let Some(why) = failed.take() {
            not_evaluated.push((effects, why));
            continue;
        }
        let per_group = held.per_group(base.info.len());
        models.push(Model {
            effects,
            held,
            per_group,
        });
    }
    pb.finish_and_clear();
    Ok(verdict(
        set,
        k,
        &labels,
        by,
        sigma_m,
        &models,
        &not_testable,
        &not_evaluated,
    ))
}

/// Paired z of model `b` against model `a` over groups (positive: `b` better).
fn paired(a: &Model, b: &Model) -> f64 {
    let mut d: Vec<f64> = a
        .per_group
        .iter()
        .zip(&b.per_group)
        .map(|(x, y)| x - y)
        .collect();
    signed_rank_z(&mut d)
}

/// Decides and formats.
#[allow(clippy::too_many_arguments)]
fn verdict(
    set: &MeasurementSet,
    folds: usize,
    labels: &[String],
    by: GroupBy,
    sigma_m: Option<f64>,
    models: &[Model],
    not_testable: &[(Effect, &str)],
    not_evaluated: &[(EffectSet, String)],
) -> (String, Value) {
    let Some(geo) = models.first() else {
        return (String::new(), Value::Null);
    };
    // Gap test against the stated floor.
    let dof: usize = geo
        .held
        .groups
        .iter()
        .map(|g| g.3.saturating_sub(1) * 3)
        .sum();
    let sum_sq: f64 = geo.held.groups.iter().map(|g| g.1).sum();
    let gap = sigma_m.map(|s| contact_gap_z(sum_sq, geo.held.contacts(), dof, s));
    let (_, b_rms, _) = geo.held.summary();
    let floor_mm = gap.map(|(_, f)| f * 1e3);
    let closed = |m: &Model| -> Option<f64> {
        let (_, a, _) = m.held.summary();
        floor_mm.map(|n| {
            if b_rms > n {
                ((b_rms - a) / (b_rms - n)).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    };
    let z: Vec<f64> = models.iter().map(|m| paired(geo, m)).collect();
    // Best: the significant candidate with the lowest held-out RMS; the smallest one not
    // significantly worse than it is chosen (as the instrument diagnosis).
    let significant: Vec<usize> = (1..models.len()).filter(|&i| z[i] > Z).collect();
    let best = significant.iter().copied().min_by(|&a, &b| {
        models[a]
            .held
            .summary()
            .1
            .total_cmp(&models[b].held.summary().1)
    });
    let as_good: Vec<usize> = best.map_or_else(Vec::new, |b| {
        significant
            .iter()
            .copied()
            .filter(|&i| i == b || paired(&models[i], &models[b]) < Z)
            .collect()
    });
    let size = |i: usize| models[i].effects.iter().count();
    let chosen = as_good
        .iter()
        .copied()
        .min_by_key(|&i| (size(i), i))
        .or(best);
    let confounded: Vec<usize> = as_good
        .iter()
        .copied()
        .filter(|&i| Some(i) != chosen && chosen.is_some_and(|c| size(i) == size(c)))
        .collect();
    let status = match gap {
        None => None,
        Some((gz, _)) if gz <= Z && chosen.is_none() => Some("no_gap"),
        Some(_) => Some(match chosen.and_then(|c| closed(&models[c])) {
            Some(f) if f >= 0.8 => "explained",
            Some(f) if f >= 0.25 => "partially_explained",
            _ => "unexplained",
        }),
    };
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Diagnosis of {} (contact data: targets/planes; {} held out by {}, {} folds)",
        set.source,
        labels.len(),
        match by {
            GroupBy::Session => "session (leave one session out)",
            _ => "target/plane",
        },
        folds
    );
    let _ = writeln!(
        t,
        "Held-out rows scored about their target re-estimated from the held-out rows only; \
         {} scored targets/planes, {} contacts.",
        geo.held.groups.len(),
        geo.held.contacts()
    );
    match (gap, floor_mm) {
        (Some((gz, _)), Some(n)) => {
            let _ = writeln!(
                t,
                "Noise floor: stated σ = {:.4} mm per axis; held-out RMS at the floor {n:.4} mm \
                 (parameter-estimation error not included); geometric model {b_rms:.4} mm, gap z = {gz:.1}",
                sigma_m.unwrap_or(0.0) * 1e3
            );
        }
        _ => {
            let _ = writeln!(
                t,
                "Noise floor: UNKNOWN (no --sigma-pos-mm; contact data have no repeated \
                 configuration). Whether the geometric model is at the floor cannot be \
                 decided; the paired tests below still say which candidate predicts held-out \
                 placements better."
            );
        }
    }
    let _ = writeln!(
        t,
        "\n  model                               mean|e| [mm]   RMS [mm]  |dist err| [mm]   paired z   gap closed"
    );
    let mut cands = Vec::new();
    for (i, m) in models.iter().enumerate() {
        let (mean, rms, d) = m.held.summary();
        let c = closed(m);
        let _ = writeln!(
            t,
            "  {:<34} {mean:>12.4} {rms:>10.4} {:>16} {:>10} {:>12}{}",
            effects_name(m.effects),
            d.map_or("–".into(), |v| format!("{v:.4}")),
            if i == 0 {
                "–".into()
            } else {
                format!("{:.2}", z[i])
            },
            match c {
                Some(f) if i > 0 => format!("{:.0} %", f * 100.0),
                _ => "–".into(),
            },
            if i > 0 && z[i] > Z {
                "  significant"
            } else {
                ""
            }
        );
        cands.push(json!({
            "effects": m.effects.iter().map(Effect::name).collect::<Vec<_>>(),
            "heldout_mean_mm": mean,
            "heldout_rms_mm": rms,
            "distance_error_mm": d,
            "improvement_z": if i == 0 { 0.0 } else { z[i] },
            "significant": i > 0 && z[i] > Z,
            "gap_closed_fraction": if i == 0 { None } else { c },
        }));
    }
    let chosen_name = chosen.map(|c| effects_name(models[c].effects));
    let confounded_names: Vec<String> = confounded
        .iter()
        .map(|&i| effects_name(models[i].effects))
        .collect();
    for (e, why) in not_evaluated {
        let _ = writeln!(t, "  {:<34} not evaluated: {why}", effects_name(*e));
    }
    let _ = writeln!(t, "\nNot candidates here:");
    for (e, why) in not_testable {
        let _ = writeln!(t, "  {:<18} {why}", e.name());
    }
    let _ = writeln!(
        t,
        "\nVERDICT: {}{}{}",
        status.unwrap_or("undecided (noise floor unknown)"),
        chosen_name.as_ref().map_or(String::new(), |n| format!(
            "; best candidate {n} (paired z {:.2}{})",
            chosen.map_or(0.0, |c| z[c]),
            chosen
                .and_then(|c| closed(&models[c]))
                .map_or(String::new(), |f| format!(
                    ", closes {:.0} % of the gap",
                    f * 100.0
                ))
        )),
        if confounded_names.is_empty() {
            String::new()
        } else {
            format!("; confounded with {}", confounded_names.join(", "))
        }
    );
    if chosen.is_none() {
        let _ = writeln!(
            t,
            "No candidate predicts the held-out placements significantly better than the \
             geometric model (z > {Z})."
        );
    }
    let json = json!({
        "data": set.source,
        "method": "leave_one_group_out_contacts",
        "group_by": format!("{by:?}").to_lowercase(),
        "groups": labels,
        "folds": folds,
        "noise_floor": {
            "sigma_pos_mm": sigma_m.map(|s| s * 1e3),
            "stated": sigma_m.is_some(),
            "heldout_rms_at_floor_mm": floor_mm,
        },
        "gap_z": gap.map(|g| g.0),
        "scored_groups": geo.held.groups.len(),
        "contacts": geo.held.contacts(),
        "candidates": cands,
        "not_evaluated": not_evaluated.iter().map(|(e, w)| json!({"effects": effects_name(*e), "why": w})).collect::<Vec<_>>(),
        "not_candidates": not_testable.iter().map(|(e, w)| json!({"effect": e.name(), "why": w})).collect::<Vec<_>>(),
        "verdict": {
            "status": status,
            "effects": chosen.map(|c| models[c].effects.iter().map(Effect::name).collect::<Vec<_>>()),
            "gap_closed_fraction": chosen.and_then(|c| closed(&models[c])),
            "confounded_with": confounded_names,
        },
    });
    (t, json)
}
