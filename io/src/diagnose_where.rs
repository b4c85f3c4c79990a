//! Where the gap lies by the data's own labels (the diagnosis, REPORT.json's `where.by`):
//! the held-out RMS |Δp| of the geometric model and of the verdict's model by session, by
//! each `extra_` column (its values when there are at most [`MAX_LEVELS`], else quartiles
//! of a numeric column) and by quartiles of each prismatic joint's reading. Suspect rows are
//! left out.

use kincal::diagnosis::PoseDiagnosis;
use kincal::{JointKind, Robot};
use serde::Serialize;

use crate::diagnose_sessions::Sessions;
use crate::measurements::MeasurementSet;

/// Largest number of distinct values shown one by one.
pub const MAX_LEVELS: usize = 12;

/// One grouping of the rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Breakdown {
    /// What the rows are grouped by (`session`, an `extra_` column, `q3 [m]`).
    pub by: String,
    /// The groups in order.
    pub bins: Vec<Bin>,
}

/// One group of rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bin {
    pub label: String,
    pub rows: usize,
    /// Held-out RMS |Δp| of the geometric model [mm].
    pub geometric_mm: f64,
    /// Held-out RMS |Δp| of the verdict's model [mm] (the geometric one without effects).
    pub verdict_mm: f64,
}

/// The JSON form.
#[derive(Debug, Clone, Serialize)]
pub struct BreakdownJson {
    pub by: String,
    pub bins: Vec<Bin>,
}

impl Breakdown {
    pub fn json(&self) -> BreakdownJson {
        BreakdownJson {
            by: self.by.clone(),
            bins: self.bins.clone(),
        }
    }
}

/// Every grouping the data offer.
pub fn breakdown<const N: usize>(
    robot: &Robot<N>,
    set: &MeasurementSet,
    poses: &[PoseDiagnosis],
    sessions: Option<&Sessions<N>>,
) -> Vec<Breakdown> {
    let mut out = Vec::new();
    if let Some(s) = sessions {
        let labels: Vec<String> = s
            .index
            .iter()
            .map(|&k| s.names.get(usize::from(k)).cloned().unwrap_or_default())
            .collect();
        out.push(categorical("session", &labels, &s.names, poses));
    }
    for (c, name) in set.extra_columns.iter().enumerate() {
        let values: Vec<String> = set
            .rows
            .iter()
            .map(|r| r.extras.get(c).cloned().unwrap_or_default())
            .collect();
        if let Some(b) = by_values(name, &values, poses) {
            out.push(b);
        }
    }
    for j in (0..N).filter(|&j| robot.joint_kind(j) == JointKind::Prismatic) {
        let q: Vec<f64> = set
            .rows
            .iter()
            .map(|r| r.q_rad.get(j).copied().unwrap_or(f64::NAN))
            .collect();
        if let Some(b) = quartiles(&format!("q{} [m]", j + 1), &q, poses) {
            out.push(b);
        }
    }
    out
}

/// Groups by the distinct values (numeric order when all are numbers), or by quartiles of
/// a numeric column with more values; `None` for one value or many non-numeric ones.
fn by_values(name: &str, values: &[String], poses: &[PoseDiagnosis]) -> Option<Breakdown> {
    let mut levels: Vec<String> = Vec::new();
    for v in values {
        if !levels.contains(v) {
            levels.push(v.clone());
            if levels.len() > MAX_LEVELS {
                break;
            }
        }
    }
    let numbers: Option<Vec<f64>> = values.iter().map(|v| v.parse::<f64>().ok()).collect();
    if levels.len() <= 1 {
        return None;
    }
    if levels.len() <= MAX_LEVELS {
        match &numbers {
            Some(_) => levels.sort_by(|a, b| {
                let (x, y) = (a.parse::<f64>(), b.parse::<f64>());
                x.unwrap_or(0.0).total_cmp(&y.unwrap_or(0.0))
            }),
            None => levels.sort(),
        }
        return Some(categorical(name, values, &levels, poses));
    }
    quartiles(name, &numbers?, poses)
}

fn categorical(
    name: &str,
    labels: &[String],
    levels: &[String],
    poses: &[PoseDiagnosis],
) -> Breakdown {
    Breakdown {
        by: name.to_string(),
        bins: levels
            .iter()
            .map(|lv| bin(lv.clone(), poses, |l| labels.get(l) == Some(lv)))
            .collect(),
    }
}

/// Four bins at the quartiles of `x`.
fn quartiles(name: &str, x: &[f64], poses: &[PoseDiagnosis]) -> Option<Breakdown> {
    let mut sorted: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if sorted.len() < 8 {
        return None;
    }
    sorted.sort_by(f64::total_cmp);
    let at = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    let edges = [
        sorted[0],
        at(0.25),
        at(0.5),
        at(0.75),
        sorted[sorted.len() - 1],
    ];
    if edges[0] == edges[4] {
        return None;
    }
    let bins = (0..4)
        .filter(|&k| edges[k] < edges[k + 1] || k == 3)
        .map(|k| {
            let (lo, hi) = (edges[k], edges[k + 1]);
            let last = k == 3;
            let inside = |v: f64| v >= lo && (v < hi || (last && v <= hi));
            bin(format!("{lo:.4} – {hi:.4}"), poses, |l| {
                x.get(l).is_some_and(|&v| inside(v))
            })
        })
        .filter(|b| b.rows > 0)
        .collect();
    Some(Breakdown {
        by: format!("{name} (quartiles)"),
        bins,
    })
}

fn bin(label: String, poses: &[PoseDiagnosis], member: impl Fn(usize) -> bool) -> Bin {
    let (mut g, mut v, mut n) = (0.0, 0.0, 0usize);
    for (l, p) in poses.iter().enumerate() {
        if p.suspect || !member(l) {
            continue;
        }
        g += p.heldout_baseline[..3].iter().map(|x| x * x).sum::<f64>();
        v += p.heldout_final[..3].iter().map(|x| x * x).sum::<f64>();
        n += 1;
    }
    let rms = |s: f64| {
        if n == 0 {
            0.0
        } else {
            (s / n as f64).sqrt() * 1e3
        }
    };
    Bin {
        label,
        rows: n,
        geometric_mm: rms(g),
        verdict_mm: rms(v),
    }
}
