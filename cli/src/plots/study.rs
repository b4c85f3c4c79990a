//! The design comparison figure (the paper's Fig. 7 as a Monte-Carlo distribution): per
//! design, a box plot of the worst-pose position error [mm] (left) and orientation error
//! [deg] (right) over the runs — box 25–75 %, thick line the median, whiskers 5–95 %, dot the
//! maximum — with the paper's targets (1 mm, 0.66°) dashed.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::CliError;
use kincal_io::design::study::DesignResult;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

/// Nearest-rank quantile of sorted `s` (non-empty).
fn quantile(s: &[f64], p: f64) -> f64 {
    let n = s.len();
    s[((p * n as f64).ceil() as usize).clamp(1, n) - 1]
}

fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    unit: &str,
    results: &[DesignResult],
    values: &dyn Fn(&DesignResult) -> &[f64],
    target: f64,
) -> Res<()> {
    let n = results.len().max(1);
    let sorted: Vec<Vec<f64>> = results
        .iter()
        .map(|r| {
            let mut v = values(r).to_vec();
            v.sort_by(f64::total_cmp);
            v
        })
        .collect();
    let top = sorted
        .iter()
        .filter_map(|v| v.last().copied())
        .fold(0.0f64, f64::max)
        .max(target)
        * 1.12;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20).into_font().style(FontStyle::Bold))
        .margin(12)
        .margin_bottom(40)
        .x_label_area_size(10)
        .y_label_area_size(64)
        .build_cartesian_2d(
            0.4f64..(n as f64 + 0.6),
            0.0..crate::plots::finite_top(top)?,
        )?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_labels(8)
        .y_desc(format!("worst validation pose per run [{unit}]"))
        .y_label_formatter(&|v| format!("{v:.2}"))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .max_light_lines(1)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
    chart.draw_series(DashedLineSeries::new(
        [(0.4, target), (n as f64 + 0.6, target)],
        8,
        5,
        RED.stroke_width(2),
    ))?;
    chart.draw_series(std::iter::once(
        EmptyElement::at((0.45, target))
            + Text::new(
                format!("target {target} {unit}"),
                (2, -16),
                ("sans-serif", 13).into_font().color(&RED),
            ),
    ))?;
    for (i, (r, s)) in results.iter().zip(&sorted).enumerate() {
        let x = (i + 1) as f64;
        let c = COLOURS[i % COLOURS.len()];
        let name_style = TextStyle::from(("sans-serif", 15).into_font().style(FontStyle::Bold))
            .pos(Pos::new(HPos::Center, VPos::Top));
        chart.draw_series(std::iter::once(
            EmptyElement::at((x, 0.0)) + Text::new(r.name.clone(), (0, 8), name_style),
        ))?;
        if s.is_empty() {
            continue;
        }
        let (p5, q1, q2, q3, p95, max) = (
            quantile(s, 0.05),
            quantile(s, 0.25),
            quantile(s, 0.5),
            quantile(s, 0.75),
            quantile(s, 0.95),
            s[s.len() - 1],
        );
        let w = 0.22;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - w, q1), (x + w, q3)],
            c.mix(0.3).filled(),
        )))?;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - w, q1), (x + w, q3)],
            c.stroke_width(2),
        )))?;
        for seg in [
            [(x - w, q2), (x + w, q2)],
            [(x, p5), (x, q1)],
            [(x, q3), (x, p95)],
            [(x - w / 2.0, p5), (x + w / 2.0, p5)],
            [(x - w / 2.0, p95), (x + w / 2.0, p95)],
        ] {
            let width = if seg[0].1 == seg[1].1 && seg[0].0 == x - w {
                4
            } else {
                2
            };
            chart.draw_series(LineSeries::new(seg, c.stroke_width(width)))?;
        }
        chart.draw_series(std::iter::once(Circle::new((x, max), 4, c.filled())))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((x, max))
                + Text::new(
                    format!("med {q2:.3}, p95 {p95:.3}, max {max:.3}"),
                    (-70, -20),
                    ("sans-serif", 12).into_font(),
                ),
        ))?;
    }
    Ok(())
}

/// The figure as SVG text.
pub fn comparison_svg(
    title: &str,
    subtitle: &str,
    results: &[DesignResult],
    target_mm: f64,
    target_deg: f64,
) -> Res<String> {
    let w = 260 + 230 * results.len().max(2) as u32 * 2;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, ("sans-serif", 24))?;
        let (sub, body) = root.split_vertically(28);
        sub.draw(&Text::new(
            subtitle.to_string(),
            (10, 4),
            ("sans-serif", 14).into_font().color(&RGBColor(80, 80, 80)),
        ))?;
        let parts = body.split_evenly((1, 2));
        panel(
            &parts[0],
            "position error e_p",
            "mm",
            results,
            &|r| &r.max_pos_mm,
            target_mm,
        )?;
        panel(
            &parts[1],
            "orientation error e_φ",
            "deg",
            results,
            &|r| &r.max_rot_deg,
            target_deg,
        )?;
        root.present()?;
    }
    Ok(svg)
}

/// Writes the figure atomically (never over an input).
pub fn write_comparison(
    path: &Path,
    inputs: &[&Path],
    title: &str,
    subtitle: &str,
    results: &[DesignResult],
) -> Result<(), CliError> {
    let svg = comparison_svg(title, subtitle, results, 1.0, 0.66)
        .map_err(|e| CliError::io(format!("{}: cannot draw the figure: {e}", path.display())))?;
    kincal_io::files::write_atomic(path, inputs, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}
