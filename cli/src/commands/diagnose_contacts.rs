//! The words of `kincal diagnose` on data with target/plane rows: the run, its decisions
//! and its REPORT.json are kincal-io's [`kincal_io::diagnose_contacts`]; this module writes
//! the readable report.

use std::fmt::Write as _;

use kincal_io::crossval_contacts::GroupBy;
use kincal_io::diagnose_contacts::{FORM_NOT_DETERMINED, ModelReport, Report, Z, effects_name};

/// The readable report: the noise floor, one line per model, what is not a candidate and
/// the verdict.
pub fn text(r: &Report) -> String {
    let mut t = String::new();
    heading(&mut t, r);
    noise_floor(&mut t, r);
    let _ = writeln!(
        t,
        "\n  model                               mean|e| [mm]   RMS [mm]  |dist err| [mm]   paired z   gap closed"
    );
    for m in &r.models {
        model_line(&mut t, m);
    }
    for (e, why) in &r.not_evaluated {
        let _ = writeln!(t, "  {:<34} not evaluated: {why}", effects_name(*e));
    }
    let _ = writeln!(t, "\nNot candidates here:");
    for (e, why) in &r.not_candidates {
        let _ = writeln!(t, "  {:<18} {why}", e.name());
    }
    verdict(&mut t, r);
    t
}

/// What was held out and scored.
fn heading(t: &mut String, r: &Report) {
    let _ = writeln!(
        t,
        "Diagnosis of {} (contact data: targets/planes; {} held out by {}, {} folds)",
        r.source,
        r.groups.len(),
        match r.group_by {
            GroupBy::Session => "session (leave one session out)",
            _ => "target/plane",
        },
        r.folds
    );
    let _ = writeln!(
        t,
        "Held-out rows scored about their target re-estimated from the held-out rows only; \
         {} scored targets/planes, {} contacts.",
        r.scored_groups, r.contacts
    );
}

/// The stated noise floor and the gap test, or why there is none.
fn noise_floor(t: &mut String, r: &Report) {
    match (r.gap_z, r.floor_mm) {
        (Some(gz), Some(n)) => {
            let _ = writeln!(
                t,
                "Noise floor: stated σ = {:.4} mm per axis; held-out RMS at the floor {n:.4} mm \
                 (the folds' parameter-estimation error included); geometric model {:.4} mm, \
                 gap z = {gz:.1}",
                r.sigma_m.unwrap_or(0.0) * 1e3,
                r.geometric_rms_mm()
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
}

/// One row of the model table.
fn model_line(t: &mut String, m: &ModelReport) {
    let _ = writeln!(
        t,
        "  {:<34} {:>12.4} {:>10.4} {:>16} {:>10} {:>12}{}",
        effects_name(m.effects),
        m.heldout_mean_mm,
        m.heldout_rms_mm,
        m.distance_error_mm
            .map_or("–".into(), |v| format!("{v:.4}")),
        m.improvement_z.map_or("–".into(), |z| format!("{z:.2}")),
        m.gap_closed_fraction
            .map_or("–".into(), |f| format!("{:.0} %", f * 100.0)),
        if m.significant { "  significant" } else { "" }
    );
}

/// The verdict line, and why there is no candidate when there is none.
fn verdict(t: &mut String, r: &Report) {
    let chosen = r.chosen_model();
    let best = chosen.map_or(String::new(), |m| {
        format!(
            "; best candidate {} (paired z {:.2}{})",
            effects_name(m.effects),
            m.improvement_z.unwrap_or(0.0),
            m.gap_closed_fraction.map_or(String::new(), |f| format!(
                ", closes {:.0} % of the gap",
                f * 100.0
            ))
        )
    });
    // What the chosen model leaves, held out, against the floor: above it, the verdict is
    // at most partially_explained.
    let rest = chosen
        .and_then(|m| m.remaining_gap_z)
        .map_or(String::new(), |z| {
            format!(
                "; remaining gap z = {z:.1}{}",
                if z > Z { " (above the noise)" } else { "" }
            )
        });
    let confounded = r.confounded_names();
    let _ = writeln!(
        t,
        "\nVERDICT: {}{best}{rest}{}",
        r.status.unwrap_or("undecided (noise floor unknown)"),
        if confounded.is_empty() {
            String::new()
        } else {
            format!("; confounded with {}", confounded.join(", "))
        }
    );
    if chosen.is_none() {
        let _ = writeln!(
            t,
            "No candidate predicts the held-out placements significantly better than the \
             geometric model (z > {Z})."
        );
    }
    if r.reason == Some(FORM_NOT_DETERMINED) {
        let _ = writeln!(
            t,
            "Not `explained`: joint_cyclic's terms (sin/cos of q and 2q per joint) fit most \
             smooth joint errors over the narrow ranges of contact data, and contact data \
             have no check of the form (the instrument diagnosis tests it against the next \
             harmonics): a cyclic transmission error or another smooth function of the \
             joints."
        );
    }
}
