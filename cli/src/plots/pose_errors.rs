//! The paper's validation error figure (Fig. 7/11) as SVG: two 4×4 panels, position errors
//! [mm] above and orientation errors [deg] below; columns are the models (NOM, OLS, OPT1,
//! OPT2: those given), rows e_x, e_y, e_z and the norm, against the pose index.

use std::path::Path;

use kincal::validation::PoseErrors;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::CliError;
use crate::plots::{LEGEND_ROW_H, LegendEntry, Mark, legend_band, require_finite};
use crate::report::Targets;

/// One model's per-pose errors.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub errors: Vec<PoseErrors>,
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(90, 90, 90),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];
/// The norm rows draw the target line only when the largest error reaches this fraction
/// of the target: below it the line would press the errors into the bottom fifth.
pub const TARGET_SHOWN_FRACTION: f64 = 0.2;
const CELL_W: u32 = 380;
const CELL_H: u32 = 200;
const TITLE_H: u32 = 50;
const PANEL_TITLE_H: u32 = 40;

/// Tick label: plain for ordinary magnitudes, exponent form for tiny spans.
fn tick(v: f64, span: f64) -> String {
    if v == 0.0 || v.abs() < span * 1e-6 {
        "0".to_string()
    } else if !(1e-2..1e4).contains(&span) {
        format!("{v:.1e}")
    } else if span < 1.0 {
        format!("{v:.3}")
    } else {
        format!("{v:.2}")
    }
}

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    row_names: [&str; 4],
    unit: &str,
    series: &[Series],
    value: &dyn Fn(&PoseErrors, usize) -> f64,
    target: f64,
) -> Res<()> {
    let area = area.titled(title, ("sans-serif", 22).into_font().style(FontStyle::Bold))?;
    let cols = series.len().max(1);
    let cells = area.split_evenly((4, cols));
    for (k, cell) in cells.iter().enumerate() {
        let (row, col) = (k / cols, k % cols);
        let Some(s) = series.get(col) else { continue };
        let n = s.errors.len();
        let vals: Vec<f64> = s.errors.iter().map(|e| value(e, row)).collect();
        let m = vals.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let m = if m > 0.0 { m * 1.15 } else { 1e-9 };
        require_finite(vals.iter().chain([&m, &target]))?;
        // The norm row shows the target when the data stay readable next to it (errors
        // reaching at least TARGET_SHOWN_FRACTION of it); smaller errors are autoscaled and
        // the cell's x-axis label states the target instead of a line that would squash them.
        let show_target = row == 3 && m >= TARGET_SHOWN_FRACTION * target;
        let (lo, hi) = match (row, show_target) {
            (3, true) => (0.0, m.max(1.15 * target)),
            (3, false) => (0.0, m),
            _ => (-m, m),
        };
        let span = hi - lo;
        let colour = COLOURS[col % COLOURS.len()];
        let mut chart = ChartBuilder::on(cell);
        chart
            .margin_top(6)
            .margin_right(14)
            .margin_left(4)
            .x_label_area_size(if row == 3 { 34 } else { 22 })
            .y_label_area_size(if col == 0 { 78 } else { 62 });
        if row == 0 {
            chart.caption(
                &s.name,
                ("sans-serif", 20).into_font().style(FontStyle::Bold),
            );
        }
        let mut chart = chart.build_cartesian_2d(0.5f64..(n as f64 + 0.5), lo..hi)?;
        let x_fmt = |v: &f64| format!("{}", v.round() as i64);
        let y_fmt = |v: &f64| tick(*v, span);
        let mut mesh = chart.configure_mesh();
        mesh.x_labels(n.clamp(2, 10))
            .y_labels(5)
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(("sans-serif", 12))
            .max_light_lines(1)
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(210, 210, 210));
        if col == 0 {
            mesh.y_desc(format!("{} [{unit}]", row_names[row]));
        }
        let x_desc = if show_target {
            "pose".to_string()
        } else {
            format!(
                "pose (target {} {unit}, above this scale)",
                tick(target, target)
            )
        };
        if row == 3 {
            mesh.x_desc(x_desc);
        }
        mesh.axis_desc_style(("sans-serif", 14)).draw()?;
        if row != 3 {
            chart.draw_series(LineSeries::new(
                [(0.5, 0.0), (n as f64 + 0.5, 0.0)],
                RGBColor(160, 160, 160).stroke_width(1),
            ))?;
        }
        chart.draw_series(LineSeries::new(
            vals.iter().enumerate().map(|(i, v)| ((i + 1) as f64, *v)),
            colour.stroke_width(1),
        ))?;
        chart.draw_series(PointSeries::of_element(
            vals.iter().enumerate().map(|(i, v)| ((i + 1) as f64, *v)),
            3,
            colour.filled(),
            &|c, s, st| EmptyElement::at(c) + Circle::new((0, 0), s, st),
        ))?;
        if show_target {
            chart.draw_series(DashedLineSeries::new(
                [(0.5, target), (n as f64 + 0.5, target)],
                6,
                4,
                RED.stroke_width(2),
            ))?;
        }
    }
    Ok(())
}

fn pos_value(e: &PoseErrors, row: usize) -> f64 {
    1e3 * if row < 3 { e.pos_m[row] } else { e.pos_norm_m }
}

fn rot_value(e: &PoseErrors, row: usize) -> f64 {
    (if row < 3 {
        e.rot_rad[row]
    } else {
        e.rot_norm_rad
    })
    .to_degrees()
}

/// Renders the figure to SVG text.
pub fn error_figure_svg(
    title: &str,
    series: &[Series],
    with_orientation: bool,
    targets: Targets,
) -> Res<String> {
    let cols = series.len().max(1) as u32;
    let panels = if with_orientation { 2 } else { 1 };
    let w = 90 + cols * CELL_W;
    let h = TITLE_H + panels * (PANEL_TITLE_H + 4 * CELL_H);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let body = root.titled(title, ("sans-serif", 24))?;
        let parts = if with_orientation {
            body.split_evenly((2, 1))
        } else {
            vec![body]
        };
        panel(
            &parts[0],
            "Position errors e_p [mm] (measured − model)",
            ["e_x", "e_y", "e_z", "|e_p|"],
            "mm",
            series,
            &pos_value,
            targets.pos_m * 1e3,
        )?;
        if with_orientation {
            panel(
                &parts[1],
                "Orientation errors e_φ [deg] (rotation vector of R_meas·R_modelᵀ)",
                ["e_φx", "e_φy", "e_φz", "|e_φ|"],
                "deg",
                series,
                &rot_value,
                targets.rot_rad.to_degrees(),
            )?;
        }
        root.present()?;
    }
    Ok(svg)
}

/// Writes the figure atomically to `path` (never over an input).
pub fn write_error_figure(
    path: &Path,
    inputs: &[&Path],
    title: &str,
    series: &[Series],
    with_orientation: bool,
    targets: Targets,
) -> Result<(), CliError> {
    let svg = error_figure_svg(title, series, with_orientation, targets)
        .map_err(|e| CliError::io(format!("{}: cannot draw the figure: {e}", path.display())))?;
    kincal_io::files::write_atomic(path, inputs, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}

/// Held-out errors of two models per pose on one scale: |e_p| [mm] above, |e_φ| [deg]
/// below (when measured); nominal grey, calibrated blue.
pub fn heldout_svg(
    title: &str,
    nominal: &[PoseErrors],
    calibrated: &[PoseErrors],
    with_orientation: bool,
) -> Res<String> {
    let n = nominal.len();
    let panels = if with_orientation { 2 } else { 1 };
    let (w, h) = (900u32, TITLE_H + LEGEND_ROW_H + panels * 320);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let body = root.titled(title, ("sans-serif", 22))?;
        let legend: Vec<LegendEntry> = ["nominal", "calibrated"]
            .iter()
            .zip(COLOURS)
            .map(|(name, colour)| LegendEntry {
                colour,
                mark: Mark::Dot,
                label: (*name).to_string(),
            })
            .collect();
        let (band, body) = body.split_vertically(LEGEND_ROW_H);
        legend_band(&band, &legend)?;
        let parts = body.split_evenly((panels as usize, 1));
        type Row<'a> = (&'a str, &'a dyn Fn(&PoseErrors) -> f64);
        let rows: [Row<'_>; 2] = [
            ("held-out |e_p| [mm]", &|e: &PoseErrors| e.pos_norm_m * 1e3),
            ("held-out |e_φ| [deg]", &|e: &PoseErrors| {
                e.rot_norm_rad.to_degrees()
            }),
        ];
        for (area, (label, value)) in parts.iter().zip(rows.iter()) {
            let top = nominal
                .iter()
                .chain(calibrated)
                .map(value)
                .fold(0.0f64, f64::max);
            let hi = if top > 0.0 { top * 1.15 } else { 1e-9 };
            require_finite([&hi])?;
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(70)
                .build_cartesian_2d(0.5f64..(n as f64 + 0.5), 0.0..hi)?;
            let y_fmt = |v: &f64| tick(*v, hi);
            chart
                .configure_mesh()
                .x_desc("pose (file order)")
                .y_desc(*label)
                .y_label_formatter(&y_fmt)
                .x_labels(n.clamp(2, 12))
                .x_label_formatter(&|v: &f64| format!("{}", v.round() as i64))
                .label_style(("sans-serif", 12))
                .light_line_style(RGBColor(240, 240, 240))
                .draw()?;
            for (k, data) in [nominal, calibrated].iter().enumerate() {
                let colour = COLOURS[k];
                let pts: Vec<(f64, f64)> = data
                    .iter()
                    .enumerate()
                    .map(|(i, e)| ((i + 1) as f64, value(e)))
                    .collect();
                chart.draw_series(PointSeries::of_element(
                    pts.clone(),
                    3,
                    colour.filled(),
                    &|c, s, st| EmptyElement::at(c) + Circle::new((0, 0), s, st),
                ))?;
                chart.draw_series(LineSeries::new(pts, colour.stroke_width(1)))?;
            }
        }
        root.present()?;
    }
    Ok(svg)
}
