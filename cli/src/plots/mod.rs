//! The CLI's figures, as SVG: per-pose and held-out errors (`validate --plot`, `crossval
//! --plot`), the diagnosis plots, and the design comparison of the Monte-Carlo studies.
//! Every figure refuses non-finite values (see [`require_finite`]).

pub mod diagnosis;
pub mod pose_errors;
pub mod study;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// `top` if finite (see [`require_finite`]).
pub fn finite_top(top: f64) -> Result<f64, String> {
    if top.is_finite() {
        Ok(top)
    } else {
        Err("non-finite values (an overflow upstream): the figure is not drawn".into())
    }
}

/// Refuses to draw non-finite values: plotters' tick computation on an infinite axis range
/// never ends (`validate --plot` spun forever on an overflowed error norm).
pub fn require_finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> Res<()> {
    if values.into_iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err("non-finite values (an overflow upstream): the figure is not drawn".into())
    }
}

/// How a legend entry is drawn: a dot (points), a line (lines and arrows), a dashed line,
/// or a filled box (bars).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    Dot,
    Line,
    Dashed,
    Bar,
}

/// One legend entry.
#[derive(Debug, Clone)]
pub struct LegendEntry {
    pub colour: plotters::style::RGBColor,
    pub mark: Mark,
    pub label: String,
}

/// Height [px] of a legend band holding `rows` rows of entries.
pub const LEGEND_ROW_H: u32 = 22;

/// Draws `entries` left to right in `band`, a strip of the figure reserved for the legend
/// (split off the plotting area), so that a legend never hides a data point; entries wrap
/// to a new row when the band is full.
pub fn legend_band(
    band: &plotters::drawing::DrawingArea<
        plotters::backend::SVGBackend<'_>,
        plotters::coord::Shift,
    >,
    entries: &[LegendEntry],
) -> Res<()> {
    use plotters::prelude::*;
    let (width, _) = band.dim_in_pixel();
    let (mut x, mut y) = (12i32, LEGEND_ROW_H as i32 / 2);
    for e in entries {
        let w = legend_entry_width(&e.label);
        if x > 12 && x + w > width as i32 {
            x = 12;
            y += LEGEND_ROW_H as i32;
        }
        let style = e.colour.stroke_width(2);
        match e.mark {
            Mark::Dot => band.draw(&Circle::new((x + 10, y), 4, e.colour.filled()))?,
            Mark::Line => band.draw(&PathElement::new(vec![(x, y), (x + 20, y)], style))?,
            Mark::Dashed => {
                band.draw(&PathElement::new(vec![(x, y), (x + 7, y)], style))?;
                band.draw(&PathElement::new(vec![(x + 13, y), (x + 20, y)], style))?;
            }
            Mark::Bar => band.draw(&Rectangle::new(
                [(x + 2, y - 6), (x + 18, y + 6)],
                e.colour.filled(),
            ))?,
        }
        band.draw(&Text::new(
            e.label.clone(),
            (x + 26, y - 7),
            ("sans-serif", 13).into_font(),
        ))?;
        x += w;
    }
    Ok(())
}

/// Rows of a legend band of `width` pixels for `entries` (as [`legend_band`] wraps them).
pub fn legend_rows(width: u32, entries: &[LegendEntry]) -> u32 {
    let (mut x, mut rows) = (12i32, 1u32);
    for e in entries {
        let w = legend_entry_width(&e.label);
        if x > 12 && x + w > width as i32 {
            x = 12;
            rows += 1;
        }
        x += w;
    }
    rows
}

/// Pixels an entry takes: mark, gap, the label at about 7 px a character, spacing.
fn legend_entry_width(label: &str) -> i32 {
    26 + 7 * label.chars().count() as i32 + 24
}
