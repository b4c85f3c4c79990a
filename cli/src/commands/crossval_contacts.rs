//! The words of `kincal crossval` on data with target/plane rows: the run and its report
//! (data and JSON) are kincal-io's [`kincal_io::crossval_contacts`]; this module writes the
//! readable table.

use std::fmt::Write as _;

use kincal_io::crossval_contacts::{Report, Summary};

/// A mean |distance error| [mm], or a dash when no known distance was scored.
fn distance_text(d: Option<f64>) -> String {
    d.map_or("–".to_string(), |v| format!("{v:.4}"))
}

/// The readable report: one line per fold, then the held-out totals of both models.
pub fn text(report: &Report) -> String {
    let mut text = String::new();
    let _ = writeln!(
        text,
        "Cross-validation of {} by {:?}: {} groups in {} folds (held-out rows scored about their \
         target/plane re-estimated from the held-out rows only); fits: {}",
        report.source,
        report.group_by,
        report.groups,
        report.folds.len(),
        report
            .robust
            .map_or("least squares".to_string(), |l| format!(
                "robust ({} IRLS on the training rows)",
                l.name()
            ))
    );
    if report.instrument_sessions {
        let _ = writeln!(
            text,
            "  (instrument rows in several sessions: each fold fits the model with a frame per \
             training session, and each held-out session is scored after fitting only its frame, \
             6 parameters, no model parameter: one scored group per session, |e_p| [mm])"
        );
    }
    let _ = writeln!(
        text,
        "  fold  held-out groups  nominal mean|e| [mm]  calibrated mean|e| [mm]  nominal |dist err| [mm]  calibrated |dist err| [mm]  fit"
    );
    for f in &report.folds {
        let _ = writeln!(
            text,
            "  {:>4}  {:>15}  {:>20.4}  {:>23.4}  {:>23}  {:>26}  {}",
            f.fold,
            f.held_out.len(),
            f.nominal.mean_mm,
            f.calibrated.mean_mm,
            distance_text(f.nominal.distance_error_mm),
            distance_text(f.calibrated.distance_error_mm),
            f.algorithm
        );
    }
    let _ = writeln!(
        text,
        "\nHeld out, all folds ({} scored groups):\n  model        mean|e| [mm]   RMS [mm]   max [mm]   mean |dist err| [mm]",
        report.scored_groups
    );
    let total = |name: &str, s: &Summary| {
        format!(
            "  {name:<10}  {:>12.4} {:>10.4} {:>10.4} {:>22}",
            s.mean_mm,
            s.rms_mm,
            s.max_mm,
            distance_text(s.distance_error_mm)
        )
    };
    let _ = writeln!(text, "{}", total("nominal", &report.nominal));
    let _ = writeln!(text, "{}", total("calibrated", &report.calibrated));
    text
}
