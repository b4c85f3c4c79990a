//! The diagnosis plots (SVG): residual vectors over the working region, the residual against
//! the most correlated quantity, and the held-out RMS of every candidate.

use std::path::{Path, PathBuf};

use kincal::EffectSet;
use kincal::diagnosis::{Diagnosis, PoseDiagnosis, QuantityKind};
use kincal::identify::Measurement;
use plotters::prelude::*;

use crate::error::CliError;
use crate::plots::{LEGEND_ROW_H, LegendEntry, Mark, legend_band, legend_rows};
use crate::report::{quantity_label, quantity_unit};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Where `diagnose` writes: REPORT.json, the readable report, the model, and the three plots
/// named after REPORT.json.
#[derive(Debug, Clone)]
pub struct Outputs {
    pub json: PathBuf,
    pub report: PathBuf,
    pub model: PathBuf,
    pub plot_residuals: PathBuf,
    pub plot_correlate: PathBuf,
    pub plot_candidates: PathBuf,
}

impl Outputs {
    /// Outputs named after REPORT.json (plots `<stem>_residuals.svg` … beside it).
    pub fn new(json: &Path, report: Option<&Path>, model: &Path) -> Self {
        let stem = json
            .file_stem()
            .map_or_else(|| "REPORT".into(), |s| s.to_string_lossy().into_owned());
        let dir = json.parent().unwrap_or(Path::new(""));
        Outputs {
            json: json.to_path_buf(),
            report: report.map_or_else(|| json.with_extension("txt"), Path::to_path_buf),
            model: model.to_path_buf(),
            plot_residuals: dir.join(format!("{stem}_residuals.svg")),
            plot_correlate: dir.join(format!("{stem}_correlate.svg")),
            plot_candidates: dir.join(format!("{stem}_candidates.svg")),
        }
    }
}

const POSITION_DOT: RGBColor = RGBColor(120, 120, 120);
const GEOMETRIC: RGBColor = RGBColor(230, 120, 20);
const FINAL: RGBColor = RGBColor(31, 119, 180);
const AXES: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
];

fn effects_text(s: EffectSet) -> String {
    if s.is_empty() {
        "geometric only".into()
    } else {
        s.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
    }
}

fn norm3(v: &[f64]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Residual vectors over the working region: top view (x, y) and side view (x, z).
/// Positions in mm; arrows are the position residuals magnified by a common factor.
pub fn residual_vectors_svg<const N: usize>(
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
    poses: &[PoseDiagnosis],
) -> Res<String> {
    let pts: Vec<[f64; 3]> = meas
        .iter()
        .map(|m| {
            let p = m.pose.translation.vector * 1e3;
            [p.x, p.y, p.z]
        })
        .collect();
    let lo = |k: usize| pts.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
    let hi = |k: usize| pts.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
    let span = (0..3).map(|k| hi(k) - lo(k)).fold(1.0f64, f64::max);
    let largest = poses
        .iter()
        .map(|p| norm3(&p.residual))
        .fold(0.0f64, f64::max)
        * 1e3;
    // The largest arrow is 8 % of the data's largest extent.
    let factor = if largest > 0.0 {
        0.08 * span / largest
    } else {
        1.0
    };
    let with_final = !d.verdict.effects.is_empty();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1300, 680)).into_drawing_area();
        root.fill(&WHITE)?;
        let title = format!(
            "Position residuals over the working region (arrows ×{factor:.0}: 1 mm drawn as {factor:.0} mm)"
        );
        let body = root.titled(&title, ("sans-serif", 22))?;
        let mut legend = vec![
            LegendEntry {
                colour: POSITION_DOT,
                mark: Mark::Dot,
                label: "measured position".to_string(),
            },
            LegendEntry {
                colour: GEOMETRIC,
                mark: Mark::Line,
                label: "geometric calibration (in-sample)".to_string(),
            },
        ];
        if with_final {
            legend.push(LegendEntry {
                colour: FINAL,
                mark: Mark::Line,
                label: format!("{} (held-out)", effects_text(d.verdict.effects)),
            });
        }
        let (band, body) = body.split_vertically(LEGEND_ROW_H * legend_rows(1300, &legend));
        legend_band(&band, &legend)?;
        let panels = body.split_evenly((1, 2));
        for (panel, (a, b, name)) in panels.iter().zip([(0, 1, "top view"), (0, 2, "side view")]) {
            let pad = 0.12 * span;
            let axis = |k: usize| ["x", "y", "z"][k];
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!("{name}: {} – {} [mm]", axis(a), axis(b)),
                    ("sans-serif", 18),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d((lo(a) - pad)..(hi(a) + pad), (lo(b) - pad)..(hi(b) + pad))?;
            chart
                .configure_mesh()
                .x_desc(format!("{} [mm]", axis(a)))
                .y_desc(format!("{} [mm]", axis(b)))
                .label_style(("sans-serif", 12))
                .light_line_style(RGBColor(240, 240, 240))
                .draw()?;
            let mut series: Vec<(RGBColor, Vec<[f64; 3]>)> = vec![(
                GEOMETRIC,
                poses
                    .iter()
                    .map(|p| [p.residual[0], p.residual[1], p.residual[2]])
                    .collect(),
            )];
            if with_final {
                series.push((
                    FINAL,
                    poses
                        .iter()
                        .map(|p| [p.heldout_final[0], p.heldout_final[1], p.heldout_final[2]])
                        .collect(),
                ));
            }
            chart.draw_series(
                pts.iter()
                    .map(|p| Circle::new((p[a], p[b]), 2, POSITION_DOT.filled())),
            )?;
            for (colour, vecs) in series {
                chart.draw_series(pts.iter().zip(&vecs).map(|(p, v)| {
                    let end = (p[a] + factor * v[a] * 1e3, p[b] + factor * v[b] * 1e3);
                    PathElement::new(vec![(p[a], p[b]), end], colour.stroke_width(2))
                }))?;
            }
        }
        root.present()?;
    }
    Ok(svg)
}

/// The geometric residual (position above, orientation below) against the quantity that
/// explains the largest share of it (the pose index when nothing varies).
pub fn residual_vs_quantity_svg<const N: usize>(
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
    poses: &[PoseDiagnosis],
) -> Res<String> {
    let loc = &d.location;
    let best = loc.most_correlated.map(|k| loc.correlates()[k]);
    let xs: Vec<f64> = match best.map(|c| c.quantity) {
        Some(q) => meas
            .iter()
            .map(|m| match q {
                QuantityKind::JointAngle(j) => m.state.q[j],
                QuantityKind::GravityTorque(j) => d.geometric.gravity_torques(&m.state.q)[j],
                QuantityKind::Approach(j) => m.state.approach.map_or(0.0, |s| s[j]),
                QuantityKind::Temperature => m.state.temp_c.unwrap_or(0.0),
            })
            .collect(),
        None => (1..=meas.len()).map(|i| i as f64).collect(),
    };
    let (xname, xunit) = best.map_or(("pose".to_string(), ""), |c| {
        (quantity_label(c.quantity), quantity_unit(c.quantity))
    });
    let (xlo, xhi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let xpad = ((xhi - xlo) * 0.05).max(1e-9);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 860)).into_drawing_area();
        root.fill(&WHITE)?;
        let title = match best {
            Some(c) => format!(
                "Geometric residual against {xname}: explains {:.0} % of the residual variance ({:.0} % position, {:.0} % rotation)",
                100.0 * c.explained,
                100.0 * c.explained_pos,
                100.0 * c.explained_rot
            ),
            None => "Geometric residual per pose".to_string(),
        };
        let body = root.titled(&title, ("sans-serif", 16))?;
        let panels = body.split_evenly((2, 1));
        for (p, panel) in panels.iter().enumerate() {
            let (names, unit, scale, off) = if p == 0 {
                (["Δx", "Δy", "Δz"], "mm", 1e3, 0)
            } else {
                (
                    ["Δφx", "Δφy", "Δφz"],
                    "deg",
                    180.0 / std::f64::consts::PI,
                    3,
                )
            };
            let ys: Vec<[f64; 3]> = poses
                .iter()
                .map(|q| {
                    [
                        q.residual[off] * scale,
                        q.residual[off + 1] * scale,
                        q.residual[off + 2] * scale,
                    ]
                })
                .collect();
            let m = ys
                .iter()
                .flat_map(|y| y.iter())
                .fold(0.0f64, |a, v| a.max(v.abs()))
                .max(1e-9)
                * 1.1;
            let legend: Vec<LegendEntry> = names
                .iter()
                .enumerate()
                .map(|(k, name)| LegendEntry {
                    colour: AXES[k],
                    mark: Mark::Dot,
                    label: format!(
                        "{name}{}",
                        best.map_or(String::new(), |c| format!(" (r = {:+.2})", c.corr[off + k]))
                    ),
                })
                .collect();
            let (band, panel) = panel.split_vertically(LEGEND_ROW_H);
            legend_band(&band, &legend)?;
            let mut chart = ChartBuilder::on(&panel)
                .margin(14)
                .x_label_area_size(44)
                .y_label_area_size(70)
                .build_cartesian_2d((xlo - xpad)..(xhi + xpad), -m..m)?;
            chart
                .configure_mesh()
                .x_desc(if xunit.is_empty() {
                    xname.clone()
                } else {
                    format!("{xname} [{xunit}]")
                })
                .y_desc(format!(
                    "{} residual [{unit}]",
                    if p == 0 { "position" } else { "orientation" }
                ))
                .label_style(("sans-serif", 12))
                .light_line_style(RGBColor(240, 240, 240))
                .draw()?;
            for (k, colour) in AXES.iter().enumerate() {
                chart.draw_series(
                    xs.iter()
                        .zip(&ys)
                        .map(|(x, y)| Circle::new((*x, y[k]), 3, colour.filled())),
                )?;
            }
        }
        root.present()?;
    }
    Ok(svg)
}

/// Held-out RMS position error of every evaluated candidate (bars), with the geometric
/// model's and the noise floor's as lines; the verdict green, confounded candidates yellow.
pub fn candidates_svg<const N: usize>(d: &Diagnosis<N>) -> Res<String> {
    let mut cands: Vec<_> = d.candidates().iter().filter(|c| c.evaluated).collect();
    cands.sort_by(|a, b| a.heldout_rms_pos_m.total_cmp(&b.heldout_rms_pos_m));
    let n = cands.len().max(1);
    let base = d.baseline.heldout_rms_pos_m * 1e3;
    let floor = d.noise.rms_pos_m() * 1e3;
    let xmax = cands
        .iter()
        .map(|c| c.heldout_rms_pos_m * 1e3)
        .fold(base.max(floor), f64::max)
        * 1.1;
    let labels: Vec<String> = cands.iter().map(|c| effects_text(c.effects)).collect();
    let legend = candidate_legend(base, floor);
    let legend_h = LEGEND_ROW_H * legend_rows(1000, &legend) + 8;
    let mut svg = String::new();
    {
        let h = 120 + 24 * n as u32 + legend_h;
        let root = SVGBackend::with_string(&mut svg, (1000, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot, band) = root.split_vertically(h - legend_h);
        legend_band(&band, &legend)?;
        let mut chart = ChartBuilder::on(&plot)
            .caption(
                "Held-out RMS position error per candidate (k-fold by pose_id)",
                ("sans-serif", 18),
            )
            .margin(14)
            .x_label_area_size(40)
            .y_label_area_size(300)
            .build_cartesian_2d(0.0..xmax, -0.5..(n as f64 - 0.5))?;
        let label_of = |v: &f64| {
            let k = v.round();
            if (v - k).abs() < 1e-6 && k >= 0.0 {
                labels.get(k as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .y_labels(n)
            .y_label_formatter(&label_of)
            .x_desc("held-out RMS |Δp| [mm]")
            .label_style(("sans-serif", 12))
            .disable_y_mesh()
            .light_line_style(RGBColor(240, 240, 240))
            .draw()?;
        chart.draw_series(cands.iter().enumerate().map(|(i, c)| {
            let colour = if c.effects == d.verdict.effects {
                BAR_VERDICT
            } else if d.verdict.confounded().contains(&c.effects) {
                BAR_CONFOUNDED
            } else if c.significant {
                BAR_SIGNIFICANT
            } else {
                BAR_OTHER
            };
            let y = i as f64;
            Rectangle::new(
                [(0.0, y - 0.35), (c.heldout_rms_pos_m * 1e3, y + 0.35)],
                colour.filled(),
            )
        }))?;
        for (x, colour) in [(base, LINE_GEOMETRIC), (floor, LINE_FLOOR)] {
            chart.draw_series(DashedLineSeries::new(
                [(x, -0.5), (x, n as f64 - 0.5)],
                6,
                4,
                colour.stroke_width(2),
            ))?;
        }
        root.present()?;
    }
    Ok(svg)
}

const BAR_VERDICT: RGBColor = RGBColor(44, 160, 44);
const BAR_CONFOUNDED: RGBColor = RGBColor(230, 190, 30);
const BAR_SIGNIFICANT: RGBColor = RGBColor(120, 160, 210);
const BAR_OTHER: RGBColor = RGBColor(190, 190, 190);
const LINE_GEOMETRIC: RGBColor = RGBColor(90, 90, 90);
const LINE_FLOOR: RGBColor = RGBColor(214, 39, 40);

/// The candidate chart's legend: what each bar colour means and the two reference lines.
fn candidate_legend(base_mm: f64, floor_mm: f64) -> Vec<LegendEntry> {
    let e = |colour, mark, label: String| LegendEntry {
        colour,
        mark,
        label,
    };
    vec![
        e(BAR_VERDICT, Mark::Bar, "the verdict".into()),
        e(
            BAR_CONFOUNDED,
            Mark::Bar,
            "confounded with the verdict".into(),
        ),
        e(BAR_SIGNIFICANT, Mark::Bar, "significant".into()),
        e(BAR_OTHER, Mark::Bar, "not significant".into()),
        e(
            LINE_GEOMETRIC,
            Mark::Dashed,
            format!("geometric only ({base_mm:.3} mm)"),
        ),
        e(
            LINE_FLOOR,
            Mark::Dashed,
            format!("noise floor √3σ ({floor_mm:.3} mm)"),
        ),
    ]
}

fn drawn(path: &Path, svg: Res<String>) -> Result<(PathBuf, String), CliError> {
    let svg =
        svg.map_err(|e| CliError::io(format!("{}: cannot draw the plot: {e}", path.display())))?;
    Ok((path.to_path_buf(), svg))
}

/// The three plots as (path, SVG text).
pub fn render_all<const N: usize>(
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    outputs: &Outputs,
) -> Result<Vec<(PathBuf, String)>, CliError> {
    Ok(vec![
        drawn(
            &outputs.plot_residuals,
            residual_vectors_svg(d, meas, poses),
        )?,
        drawn(
            &outputs.plot_correlate,
            residual_vs_quantity_svg(d, meas, poses),
        )?,
        drawn(&outputs.plot_candidates, candidates_svg(d))?,
    ])
}
