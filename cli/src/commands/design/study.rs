//! The text of a Monte-Carlo comparison of designs ([`kincal_io::design::study`]): the
//! table of the worst-pose errors per design and the timing line.

use kincal::montecarlo::Acquisition;
use kincal_io::design::study::{DesignResult, Summary, Timing};

/// The comparison table: per design, runs, eq. (17) index and the median and p95 of the
/// worst-pose errors. Headers span two lines and the maximum stays in `--json` (the
/// verdicts name the worst run): the table fits 100 columns (issue #19).
pub fn table(results: &[DesignResult]) -> String {
    let mut t = crate::report::Table::new(&[
        "design",
        "measured\nby",
        "poses",
        "O\n(eq. 17)",
        "runs\nok/failed",
        "e_p median\n[mm]",
        "e_p p95\n[mm]",
        "e_φ median\n[deg]",
        "e_φ p95\n[deg]",
    ]);
    for r in results {
        let (p, a) = (r.pos(), r.rot());
        t.row(vec![
            r.name.clone(),
            match r.acquisition {
                Acquisition::Instrument => "instrument".into(),
                Acquisition::Tool => "tool".into(),
            },
            r.poses.to_string(),
            format!("{:.4}", r.o),
            format!("{}/{}", r.runs - r.failed, r.failed),
            format!("{:.3}", p.median),
            format!("{:.3}", p.p95),
            format!("{:.3}", a.median),
            format!("{:.3}", a.p95),
        ]);
    }
    let mut out = t.render("  ");
    if let Some(first) = results.first().filter(|r| !r.before_pos_mm.is_empty()) {
        let (b, c) = (
            Summary::of(&first.before_pos_mm),
            Summary::of(&first.before_rot_deg),
        );
        out.push_str(&format!(
            "  before calibration (nominal model, same robots): worst pose e_p median {:.2} mm, p95 {:.2} mm; e_φ median {:.2}°, p95 {:.2}°\n",
            b.median, b.p95, c.median, c.p95
        ));
    }
    out
}

/// Timing line.
pub fn timing_line(t: &Timing) -> String {
    let per = t.wall_s / t.calibrations.max(1) as f64 * 1e6;
    let cpu = t.cpu_s.map_or(String::new(), |c| {
        format!(
            ", {c:.2} s CPU ({:.0} µs per calibration)",
            c / t.calibrations.max(1) as f64 * 1e6
        )
    });
    format!(
        "{} calibrations in {:.2} s on {} threads ({per:.0} µs each){cpu}",
        t.calibrations, t.wall_s, t.threads
    )
}
