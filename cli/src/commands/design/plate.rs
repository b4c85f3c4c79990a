//! The wording of `evaluate-designs --plate` (issue #13 item 6): the comparison table, the
//! verdicts and the figure. The plates, their runs and their `--json` part are
//! [`kincal_io::design::plate`]'s.

use std::fmt::Write as _;
use std::path::Path;

use kincal_io::design::plate::{Kind, Row, matching};
use kincal_io::design::study::Summary;

use crate::error::CliError;

/// The comparison table: per design, contacts, placements, and median / p95 of the
/// worst-pose errors, absolute and registered. Headers span three lines and the kind of
/// each design is left to the design list and the table above it (a plate is the row with
/// placements and a distance D): the table fits 100 columns (issue #19); `--json` has every
/// field.
pub fn table(rows: &[Row]) -> String {
    let mut t = crate::report::Table::new(&[
        "design",
        "contacts",
        "place-\nments",
        "D\n[mm]",
        "runs\nok/failed",
        "abs e_p\nmedian\n[mm]",
        "abs e_p\np95\n[mm]",
        "reg e_p\nmedian\n[mm]",
        "reg e_p\np95\n[mm]",
        "reg e_φ\nmedian\n[deg]",
        "reg e_φ\np95\n[deg]",
    ]);
    for r in rows {
        let (ap, rp, rr) = (
            Summary::of(&r.abs_pos_mm),
            Summary::of(&r.reg_pos_mm),
            Summary::of(&r.reg_rot_deg),
        );
        t.row(vec![
            r.name.clone(),
            r.contacts.to_string(),
            if r.kind == Kind::Plate {
                r.placements.to_string()
            } else {
                "-".into()
            },
            r.distance_mm.map_or("-".into(), |d| format!("{d}")),
            format!("{}/{}", r.runs - r.failed, r.failed),
            format!("{:.3}", ap.median),
            format!("{:.3}", ap.p95),
            format!("{:.3}", rp.median),
            format!("{:.3}", rp.p95),
            format!("{:.3}", rr.median),
            format!("{:.3}", rr.p95),
        ]);
    }
    t.render("  ")
}

/// Which plates match `reference` (a tool): registered e_p median and p95 at most the
/// tool's; and the fewest contacts that do, per plate distance.
pub fn verdicts(rows: &[Row], reference: &str) -> String {
    let mut s = String::new();
    let Some(m) = matching(rows, reference) else {
        let _ = writeln!(s, "  (no design named '{reference}' to match)");
        return s;
    };
    let t = m.reference_e_p_mm;
    let _ = writeln!(
        s,
        "  reference {}: registered e_p median {:.3} mm, p95 {:.3} mm",
        m.reference, t.median, t.p95
    );
    for v in &m.plates {
        let p = v.registered_e_p_mm;
        let _ = writeln!(
            s,
            "  {}: {} ({} contacts, {} placements; registered e_p {:.3}/{:.3} mm vs {:.3}/{:.3} mm){}",
            v.name,
            if v.matches {
                "matches"
            } else {
                "does NOT match"
            },
            v.contacts,
            v.placements,
            p.median,
            p.p95,
            t.median,
            t.p95,
            if v.failed > 0 {
                format!("; {} runs failed", v.failed)
            } else {
                String::new()
            }
        );
    }
    for f in &m.fewest {
        let _ = writeln!(
            s,
            "  fewest contacts that match with a {} mm plate: {} ({} placements, {})",
            f.distance_mm, f.contacts, f.placements, f.name
        );
    }
    let _ = writeln!(
        s,
        "  what a plate cannot identify: the base frame (absolute errors keep it), lengths other than through the known distance (its tolerance scales the arm), the tool orientation (a ball is a point: reg e_φ keeps the random robot's last twist)"
    );
    s
}

/// The figure: registered worst-pose e_p (median and p95) of every plate against its
/// number of contacts, one line per plate distance, and the tools as horizontal lines.
pub fn write_plot(
    path: &Path,
    inputs: &[&Path],
    subtitle: &str,
    rows: &[Row],
) -> Result<(), CliError> {
    let svg = plot_svg(subtitle, rows)
        .map_err(|e| CliError::io(format!("{}: cannot draw the figure: {e}", path.display())))?;
    kincal_io::files::write_atomic(path, inputs, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}

const COLOURS: [(u8, u8, u8); 6] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
];

fn plot_svg(subtitle: &str, rows: &[Row]) -> Result<String, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let plates: Vec<&Row> = rows.iter().filter(|r| r.kind == Kind::Plate).collect();
    let others: Vec<&Row> = rows.iter().filter(|r| r.kind != Kind::Plate).collect();
    let mut distances: Vec<f64> = plates.iter().filter_map(|r| r.distance_mm).collect();
    distances.sort_by(f64::total_cmp);
    distances.dedup();
    let (cmin, cmax) = plates
        .iter()
        .chain(others.iter())
        .fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.contacts as f64), b.max(r.contacts as f64))
        });
    let (cmin, cmax) = if cmin.is_finite() {
        (cmin * 0.8, cmax * 1.25)
    } else {
        (1.0, 100.0)
    };
    let top = rows
        .iter()
        .map(|r| Summary::of(&r.reg_pos_mm).p95)
        .fold(0.0f64, f64::max)
        * 1.15;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 640)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            "Socket plate vs known-pose tools: registered position error",
            ("sans-serif", 22),
        )?;
        let (sub, body) = root.split_vertically(26);
        sub.draw(&Text::new(
            subtitle.to_string(),
            (10, 4),
            ("sans-serif", 13).into_font().color(&RGBColor(80, 80, 80)),
        ))?;
        let mut chart = ChartBuilder::on(&body)
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (cmin..cmax).log_scale(),
                0.0..crate::plots::finite_top(top.max(1e-3))?,
            )?;
        chart
            .configure_mesh()
            .x_desc("contacts (plates) / poses (tools)")
            .y_desc("worst validation pose per run, after base registration [mm]")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.2}"))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        for (i, r) in others.iter().enumerate() {
            let (r_, g, b) = COLOURS[(i + 3) % COLOURS.len()];
            let c = RGBColor(r_, g, b);
            let s = Summary::of(&r.reg_pos_mm);
            chart
                .draw_series(DashedLineSeries::new(
                    [(cmin, s.p95), (cmax, s.p95)],
                    8,
                    5,
                    c.stroke_width(2),
                ))?
                .label(format!(
                    "{} ({} poses): p95 (dashed), median (dotted)",
                    r.name, r.contacts
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart.draw_series(DashedLineSeries::new(
                [(cmin, s.median), (cmax, s.median)],
                2,
                4,
                c.stroke_width(2),
            ))?;
        }
        for (i, d) in distances.iter().enumerate() {
            let (r_, g, b) = COLOURS[i % COLOURS.len()];
            let c = RGBColor(r_, g, b);
            let mut pts: Vec<&Row> = plates
                .iter()
                .copied()
                .filter(|r| r.distance_mm == Some(*d))
                .collect();
            pts.sort_by_key(|r| (r.contacts, r.placements));
            let p95: Vec<(f64, f64)> = pts
                .iter()
                .map(|r| (r.contacts as f64, Summary::of(&r.reg_pos_mm).p95))
                .collect();
            let med: Vec<(f64, f64)> = pts
                .iter()
                .map(|r| (r.contacts as f64, Summary::of(&r.reg_pos_mm).median))
                .collect();
            chart
                .draw_series(LineSeries::new(p95.clone(), c.stroke_width(2)))?
                .label(format!("plate {d} mm: p95 (solid), median (thin)"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart.draw_series(p95.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
            chart.draw_series(LineSeries::new(med.clone(), c.stroke_width(1)))?;
            chart.draw_series(med.iter().map(|&p| Circle::new(p, 3, c.stroke_width(1))))?;
            for r in &pts {
                let s = Summary::of(&r.reg_pos_mm);
                chart.draw_series(std::iter::once(Text::new(
                    format!("{}×", r.placements),
                    (r.contacts as f64, s.p95),
                    ("sans-serif", 11).into_font(),
                )))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}
