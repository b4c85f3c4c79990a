//! Human-readable reports: aligned tables of parameters, identifiability, residuals,
//! correlations, the consensus check and validation errors, with the labels, units and
//! targets they are printed against. Formatting only.

use std::fmt::Write as _;

use kincal::identify::{Identifiability, ResidualStats};
use kincal::validation::{TARGET_POS_M, TARGET_ROT_RAD};
use kincal::{ParamId, ParamIndex, ParamSet};

use kincal_io::calibration::{Calibration, Consensus};
use kincal_io::units::display_unit;

/// Writes a report to stdout. A closed pipe (`kincal … | head`) is not an error: the
/// outputs are already written.
/// Prose lines longer than [`TEXT_WIDTH`] are wrapped ([`wrap_prose`]).
pub fn emit(text: &str) {
    use std::io::Write as _;
    let text = wrap_prose(text, TEXT_WIDTH);
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(text.as_bytes()).and_then(|()| out.flush());
}

/// Widest line of the reports on screen (issue #19 item 6): prose wraps here; a table row
/// may be wider only where its cells cannot fit.
pub const TEXT_WIDTH: usize = 100;

/// Wraps each prose line of `text` longer than `width` characters at spaces; continuation
/// lines keep the line's indentation (two more after a leading `- ` or `* ` bullet). A line
/// with a column gap (two spaces after its indentation) or a rule is a table row and is
/// left as it is, as is a single word longer than `width` (a path).
pub fn wrap_prose(text: &str, width: usize) -> std::borrow::Cow<'_, str> {
    if text.lines().all(|l| l.chars().count() <= width) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + text.len() / width);
    for piece in text.split_inclusive('\n') {
        let (line, end) = match piece.strip_suffix('\n') {
            Some(l) => (l, "\n"),
            None => (piece, ""),
        };
        let body = line.trim_start_matches(' ');
        let indent = &line[..line.len() - body.len()];
        let table_row = body.trim_end().contains("  ")
            || body.starts_with('|')
            || body.starts_with("--")
            || body.starts_with("==");
        if line.chars().count() <= width || table_row {
            out.push_str(piece);
            continue;
        }
        let hang = if body.starts_with("- ") || body.starts_with("* ") {
            format!("{indent}  ")
        } else {
            indent.to_string()
        };
        let mut col = 0;
        for word in body.split(' ').filter(|w| !w.is_empty()) {
            let n = word.chars().count();
            if col == 0 {
                out.push_str(indent);
                col = indent.chars().count();
            } else if col + 1 + n > width {
                out.push('\n');
                out.push_str(&hang);
                col = hang.chars().count();
            } else {
                out.push(' ');
                col += 1;
            }
            out.push_str(word);
            col += n;
        }
        out.push_str(end);
    }
    std::borrow::Cow::Owned(out)
}

/// A plain text table: first column left-aligned, the others right-aligned. A header cell
/// may span lines (`"e_p\nmedian\n[mm]"`): a narrow column under a long name keeps a wide
/// table within [`TEXT_WIDTH`] (issue #19).
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(header: &[&str]) -> Self {
        Table {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }
    /// Renders with two spaces between columns, each line indented by `indent`.
    pub fn render(&self, indent: &str) -> String {
        let w = column_widths(&self.header, self.rows.iter().map(Vec::as_slice));
        let mut out = String::new();
        render_head(&mut out, &self.header, &w, indent);
        for r in &self.rows {
            render_line(&mut out, r, &w, indent);
        }
        out
    }
}

/// The width of each column (in characters) over the header (its widest line) and `rows`.
fn column_widths<'a>(header: &'a [String], rows: impl Iterator<Item = &'a [String]>) -> Vec<usize> {
    let mut w: Vec<usize> = header.iter().map(|h| cell_width(h)).collect();
    for r in rows {
        for (wk, c) in w.iter_mut().zip(r) {
            *wk = (*wk).max(cell_width(c));
        }
    }
    w
}

/// Width of a cell: its widest line (a header cell may span lines).
fn cell_width(c: &str) -> usize {
    c.lines().map(|l| l.chars().count()).max().unwrap_or(0)
}

/// The header lines (a cell spanning lines fills them from the top) and the rule under them.
fn render_head(out: &mut String, header: &[String], w: &[usize], indent: &str) {
    let depth = header.iter().map(|h| h.lines().count()).max().unwrap_or(1);
    for k in 0..depth {
        let line: Vec<String> = header
            .iter()
            .map(|h| h.lines().nth(k).unwrap_or("").to_string())
            .collect();
        render_line(out, &line, w, indent);
    }
    let total: usize = w.iter().sum::<usize>() + 2 * w.len().saturating_sub(1);
    out.push_str(indent);
    out.push_str(&"-".repeat(total));
    out.push('\n');
}

/// One line: first cell left-aligned, the others right-aligned, two spaces apart.
fn render_line(out: &mut String, r: &[String], w: &[usize], indent: &str) {
    out.push_str(indent);
    for (k, (c, &wk)) in r.iter().zip(w).enumerate() {
        let pad = wk.saturating_sub(c.chars().count());
        if k == 0 {
            out.push_str(c);
            out.push_str(&" ".repeat(pad));
        } else {
            out.push_str("  ");
            out.push_str(&" ".repeat(pad));
            out.push_str(c);
        }
    }
    while out.ends_with(' ') {
        out.pop();
    }
    out.push('\n');
}

/// A [`Table`] written straight to standard output without keeping its rows: `rows` is
/// called twice (column widths, then the lines), so a table of a row per pose of a
/// million-row file costs the memory of one row (issue #16 item 6). Ignores a closed
/// stdout, as [`emit`] does.
pub fn emit_streamed_table<I: Iterator<Item = Vec<String>>>(
    header: &[&str],
    rows: impl Fn() -> I,
    indent: &str,
) {
    use std::io::Write as _;
    let header: Vec<String> = header.iter().map(|s| s.to_string()).collect();
    let mut w: Vec<usize> = header.iter().map(|h| cell_width(h)).collect();
    for r in rows() {
        for (wk, c) in w.iter_mut().zip(&r) {
            *wk = (*wk).max(cell_width(c));
        }
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut line = String::new();
    render_head(&mut line, &header, &w, indent);
    let mut ok = out.write_all(line.as_bytes()).is_ok();
    for r in rows() {
        if !ok {
            break;
        }
        line.clear();
        render_line(&mut line, &r, &w, indent);
        ok = out.write_all(line.as_bytes()).is_ok();
    }
    let _ = out.flush();
}

/// Label of flat parameter `i` of an `N`-joint model.
pub use kincal_io::units::param_label as label;

fn id<const N: usize>(i: usize) -> Option<ParamId> {
    ParamId::from_index(ParamIndex(i), N).ok()
}

/// Fixed-point with 6 decimals for ordinary magnitudes, exponent form otherwise.
pub fn fmt_value(v: f64) -> String {
    if v.abs() < NOMINAL_ZERO {
        // A nominal zero plus rounding noise (-0.0, -7e-15) is a zero, not a number to read.
        "0".to_string()
    } else if (1e-3..1e6).contains(&v.abs()) {
        format!("{v:.6}")
    } else {
        format!("{v:.4e}")
    }
}

/// Below this magnitude (in display units: mm, degrees, 1) a printed value is a zero:
/// far under any instrument's resolution, it is round-off of a nominal zero.
pub const NOMINAL_ZERO: f64 = 1e-9;

/// A signed value with 6 decimals whose rounding to zero prints as "0.000000", never
/// "-0.000000".
pub fn fmt_signed6(v: f64) -> String {
    if v.abs() < 5e-7 {
        "0.000000".to_string()
    } else {
        format!("{v:+.6}")
    }
}

/// A signed change: fixed-point for ordinary magnitudes, exponent form otherwise.
pub fn fmt_change(v: f64) -> String {
    if v.abs() < NOMINAL_ZERO {
        "0".to_string()
    } else if (1e-3..1e6).contains(&v.abs()) {
        format!("{v:+.6}")
    } else {
        format!("{v:+.4e}")
    }
}

/// Short exponent form (std errors, small quantities).
pub fn fmt_small(v: f64) -> String {
    format!("{v:.2e}")
}

fn unit<const N: usize>(i: usize) -> &'static str {
    id::<N>(i).map_or("", |id| display_unit(id).0)
}

/// One line per member of `set`: its label and partner, and for members of `at_fit` that
/// the partner was found at the fitted model.
fn list<const N: usize>(set: &ParamSet, a: &Identifiability, at_fit: &ParamSet, out: &mut String) {
    for i in set.iter() {
        let _ = write!(out, "    {:<16}", label::<N>(i));
        match a.partner.get(i).copied().flatten() {
            Some(p) => {
                let _ = write!(
                    out,
                    "aligned with {} (|cos| = {:.6})",
                    label::<N>(p.param.0),
                    p.cosine
                );
            }
            None => {
                let _ = write!(out, "no effect on the measured pose");
            }
        }
        let _ = writeln!(
            out,
            "{}",
            if at_fit.contains(i) {
                " at the fitted model (kept at the starting model)"
            } else {
                ""
            }
        );
    }
}

/// The identifiability report: what the data determine, what is redundant and why.
///
/// `found_at_fit`: the data-deficient parameters that the analysis at the starting model
/// kept and the check at the fitted model dropped (`Calibration::found_at_fit`), marked
/// as such.
pub fn identifiability<const N: usize>(
    a: &Identifiability,
    singular_values: &[f64],
    found_at_fit: &ParamSet,
    poses: usize,
    rows: usize,
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Identifiability: {} parameters requested, {poses} poses ({rows} measured components)",
        a.requested.len()
    );
    let cond = if a.condition_number.is_finite() {
        format!("{:.4e}", a.condition_number)
    } else {
        "infinite".to_string()
    };
    let _ = writeln!(
        out,
        "  identifiable:           {} (rank {}, condition number {cond})",
        a.identifiable.len(),
        a.rank
    );
    if let (Some(first), Some(last)) = (singular_values.first(), singular_values.last()) {
        let _ = writeln!(
            out,
            "  singular values (unit-scaled columns): {} … {}",
            fmt_small(*first),
            fmt_small(*last)
        );
    }
    let _ = writeln!(
        out,
        "  structurally redundant: {}{}",
        a.structural.len(),
        if a.structural.is_empty() {
            ""
        } else {
            " (redundant in the model whatever the poses; kept at their values)"
        }
    );
    list::<N>(&a.structural, a, &ParamSet::new(), &mut out);
    let _ = writeln!(
        out,
        "  data-deficient:         {}{}",
        a.data_deficient.len(),
        if a.data_deficient.is_empty() {
            ""
        } else {
            " (identifiable in general, not from these poses)"
        }
    );
    list::<N>(&a.data_deficient, a, found_at_fit, &mut out);
    if !a.gauge.is_empty() {
        let _ = writeln!(
            out,
            "  not observable (gauge): {} (no external reference in the data; kept at their values)",
            a.gauge.len()
        );
        for i in a.gauge.iter() {
            let why = match kincal::params::ParamId::from_index(ParamIndex(i), N) {
                Ok(kincal::params::ParamId::Base(_)) => {
                    "base frame: no instrument row, known target or known plane refers to it"
                }
                Ok(id)
                    if id.is_length()
                        && a.partner[i].is_none_or(|p| {
                            !matches!(
                                kincal::params::ParamId::from_index(p.param, N),
                                Ok(kincal::params::ParamId::Base(_))
                            )
                        }) =>
                {
                    "scale: no known distance, known target or known plane fixes the lengths \
                     (this length is held, the others are relative to it)"
                }
                _ => "duplicates a rigid motion of the unobservable base frame",
            };
            let _ = writeln!(out, "    {:<28} {why}", label::<N>(i));
        }
    }
    out
}

/// Parameter table of run `k`: label, unit, nominal, identified, Δ, std error, notes.
pub fn parameters<const N: usize>(cal: &Calibration<N>, k: usize) -> String {
    let r = &cal.runs[k].ident;
    let mut t = Table::new(&[
        "parameter",
        "unit",
        "nominal",
        "identified",
        "change",
        "std error",
        "",
    ]);
    for i in cal.analysis.requested.iter() {
        let (Ok(v0), Ok(v)) = (cal.start.param(ParamIndex(i)), r.robot.param(ParamIndex(i))) else {
            continue;
        };
        let f = id::<N>(i).map_or(1.0, |id| display_unit(id).1);
        let (se, note) = if cal.analysis.identifiable.contains(i) {
            (
                fmt_small(r.std_errors[i] * f),
                if r.at_bound.contains(i) {
                    "AT BOUND"
                } else {
                    ""
                },
            )
        } else if cal.analysis.structural.contains(i) {
            ("-".to_string(), "redundant (fixed)")
        } else if cal.analysis.gauge.contains(i) {
            ("-".to_string(), "not observable (fixed)")
        } else {
            ("-".to_string(), "data-deficient (fixed)")
        };
        t.row(vec![
            label::<N>(i),
            unit::<N>(i).to_string(),
            fmt_value(v0 * f),
            fmt_value(v * f),
            fmt_change((v - v0) * f),
            se,
            note.to_string(),
        ]);
    }
    t.render("  ")
}

/// Every run side by side (for `--algorithm all`).
pub fn side_by_side<const N: usize>(cal: &Calibration<N>) -> String {
    let mut header = vec!["parameter".to_string(), "unit".into(), "nominal".into()];
    for run in &cal.runs {
        header.push(run.ident.algorithm.name().to_uppercase());
    }
    for run in &cal.runs {
        header.push(format!("se {}", run.ident.algorithm.name().to_uppercase()));
    }
    let mut t = Table {
        header,
        rows: Vec::new(),
    };
    for i in cal.analysis.identifiable.iter() {
        let f = id::<N>(i).map_or(1.0, |id| display_unit(id).1);
        let mut row = vec![
            label::<N>(i),
            unit::<N>(i).to_string(),
            fmt_value(cal.start.param(ParamIndex(i)).unwrap_or(f64::NAN) * f),
        ];
        for run in &cal.runs {
            let v = run.ident.robot.param(ParamIndex(i)).unwrap_or(f64::NAN) * f;
            let mark = if run.ident.at_bound.contains(i) {
                "*"
            } else {
                ""
            };
            row.push(format!("{}{mark}", fmt_value(v)));
        }
        for run in &cal.runs {
            row.push(fmt_small(run.ident.std_errors[i] * f));
        }
        t.row(row);
    }
    let mut s = t.render("  ");
    if cal.runs.iter().any(|r| !r.ident.at_bound.is_empty()) {
        s.push_str("  * ended on its OPT1 interval bound\n");
    }
    s
}

/// Targets of the verdict [m], [rad].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Targets {
    pub pos_m: f64,
    pub rot_rad: f64,
}

impl Default for Targets {
    fn default() -> Self {
        Targets {
            pos_m: TARGET_POS_M,
            rot_rad: TARGET_ROT_RAD,
        }
    }
}

/// An error in mm or degrees: 6 decimals, exponent form below 0.001.
pub fn fmt_err(v: f64) -> String {
    if v == 0.0 || v.abs() >= 1e-3 {
        format!("{v:.6}")
    } else {
        format!("{v:.3e}")
    }
}

pub use kincal_io::units::{quantity_label, quantity_unit};

/// One row of the residual table: each kind over the poses measuring it (a row giving only
/// `x` contributes |e_x|), a dash for a kind no pose measures (not a residual of zero).
fn stats_row(name: &str, s: &ResidualStats) -> Vec<String> {
    let or_dash = |measured: usize, v: f64| {
        if measured == 0 {
            "-".to_string()
        } else {
            fmt_err(v)
        }
    };
    vec![
        name.to_string(),
        or_dash(s.pos_poses, s.rms_pos_m * 1e3),
        or_dash(s.pos_poses, s.max_pos_m * 1e3),
        or_dash(s.rot_poses, s.rms_rot_rad.to_degrees()),
        or_dash(s.rot_poses, s.max_rot_rad.to_degrees()),
        fmt_small(s.cost),
    ]
}

/// Residuals before and after, per run.
pub fn residuals<const N: usize>(cal: &Calibration<N>) -> String {
    let mut t = Table::new(&[
        "model",
        "RMS e_p [mm]",
        "max e_p [mm]",
        "RMS e_φ [deg]",
        "max e_φ [deg]",
        "cost",
    ]);
    if let Some(first) = cal.runs.first() {
        t.row(stats_row("before (initial)", &first.ident.initial));
    }
    for run in &cal.runs {
        t.row(stats_row(
            &format!(
                "after {} ({} it, {:.2} s)",
                run.ident.algorithm.name().to_uppercase(),
                run.ident.iterations,
                run.seconds
            ),
            &run.ident.fitted,
        ));
    }
    t.render("  ")
}

/// Strongly correlated estimates of every run, printed once: runs whose list names the
/// same pairs as the first run's are named in its heading instead of repeating the list.
pub fn correlations_all<const N: usize>(cal: &Calibration<N>) -> String {
    let pairs = |k: usize| -> Vec<(usize, usize)> {
        cal.runs.get(k).map_or(Vec::new(), |r| {
            r.ident
                .correlations()
                .iter()
                .map(|c| (c.a.0, c.b.0))
                .collect()
        })
    };
    let first = pairs(0);
    let (same, differ): (Vec<usize>, Vec<usize>) = (1..cal.runs.len()).partition(|&k| {
        pairs(k) == first && cal.runs[k].ident.n_correlated == cal.runs[0].ident.n_correlated
    });
    let mut out = correlations::<N>(cal, 0);
    if !same.is_empty() && cal.runs[0].ident.n_correlated > 0 {
        let names: Vec<String> = same
            .iter()
            .map(|&k| cal.runs[k].ident.algorithm.name().to_uppercase())
            .collect();
        let _ = writeln!(
            out,
            "    (the same pairs for {}; ρ as above within the runs' differences)",
            names.join(", ")
        );
    }
    for k in differ {
        out.push_str(&correlations::<N>(cal, k));
    }
    out
}

/// Strongly correlated estimates of run `k`.
pub fn correlations<const N: usize>(cal: &Calibration<N>, k: usize) -> String {
    let r = &cal.runs[k].ident;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Correlations above {} ({}): {}",
        kincal::identify::CORRELATION_REPORT_THRESHOLD,
        r.algorithm.name().to_uppercase(),
        if r.n_correlated == 0 {
            "none".to_string()
        } else {
            r.n_correlated.to_string()
        }
    );
    for c in r.correlations() {
        let _ = writeln!(
            out,
            "    {:<14} ~ {:<14} ρ = {:+.4}",
            label::<N>(c.a.0),
            label::<N>(c.b.0),
            c.rho
        );
    }
    if r.n_correlated > r.correlations().len() {
        let _ = writeln!(
            out,
            "    … {} more",
            r.n_correlated - r.correlations().len()
        );
    }
    out
}

/// A run with at least this fraction of its identified parameters on an OPT1 interval
/// bound is judged by its bounds, not by the data: its pairwise disagreements are not listed.
pub const BOUND_DOMINATED_FRACTION: f64 = 0.25;

/// The consensus check of `cal`'s runs, saying once when a run ended on its bounds (its
/// intervals exclude the data's optimum) and comparing only the other runs pairwise.
pub fn consensus_of<const N: usize>(cal: &Calibration<N>, c: &Consensus) -> String {
    let identified = cal.analysis.identifiable.len().max(1);
    let bounded: Vec<_> = cal
        .runs
        .iter()
        .filter(|r| r.ident.at_bound.len() as f64 >= BOUND_DOMINATED_FRACTION * identified as f64)
        .map(|r| (r.ident.algorithm, r.ident.at_bound.len()))
        .collect();
    if bounded.is_empty() {
        return consensus::<N>(c);
    }
    let mut out = String::new();
    for (a, nb) in &bounded {
        let _ = writeln!(
            out,
            "{} ended on its bounds ({nb} of {} identified parameters at ±{} mm / ±{}°):\n  \
             its intervals exclude the data's optimum; widen --bounds-mm/--bounds-deg to compare\n  \
             it (its {} pairwise disagreement(s) are not listed).",
            a.name().to_uppercase(),
            cal.analysis.identifiable.len(),
            cal.settings.bounds_length_m * 1e3,
            cal.settings.bounds_angle_rad.to_degrees(),
            c.disagreeing
                .iter()
                .filter(|d| d.a == *a || d.b == *a)
                .count()
        );
    }
    let involved = |x: &kincal::identify::Algorithm| bounded.iter().any(|(a, _)| a == x);
    let others = Consensus {
        largest: c.largest.filter(|d| !involved(&d.a) && !involved(&d.b)),
        disagreeing: c
            .disagreeing
            .iter()
            .filter(|d| !involved(&d.a) && !involved(&d.b))
            .copied()
            .collect(),
        ..c.clone()
    };
    if cal.runs.len() - bounded.len() >= 2 {
        out.push_str(&consensus::<N>(&others));
    }
    out
}

/// The consensus check.
pub fn consensus<const N: usize>(c: &Consensus) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Consensus: two algorithms disagree on a parameter when |difference| > {} combined std errors\n  + {:e} (SI units; std errors rescaled to the smallest residual variance of the runs)",
        c.k_sigma, c.floor_si
    );
    if let Some(l) = &c.largest {
        let f = id::<N>(l.param.0).map_or(1.0, |id| display_unit(id).1);
        let _ = writeln!(
            out,
            "  largest disagreement: {} {} vs {}: {} {} ({:.3}× its tolerance {} {})",
            label::<N>(l.param.0),
            l.a.name().to_uppercase(),
            l.b.name().to_uppercase(),
            fmt_small(l.difference * f),
            unit::<N>(l.param.0),
            l.ratio(),
            fmt_small(l.tolerance * f),
            unit::<N>(l.param.0),
        );
    }
    if c.agree() {
        let _ = writeln!(
            out,
            "  verdict: the algorithms agree on every identified parameter"
        );
    } else {
        let mut params: Vec<usize> = c.disagreeing.iter().map(|d| d.param.0).collect();
        params.sort_unstable();
        params.dedup();
        let _ = writeln!(
            out,
            "  verdict: disagreement on {} parameter(s) ({} pair comparisons):",
            params.len(),
            c.disagreeing.len()
        );
        for p in params {
            let f = id::<N>(p).map_or(1.0, |id| display_unit(id).1);
            let pairs: Vec<String> = c
                .disagreeing
                .iter()
                .filter(|d| d.param.0 == p)
                .map(|d| {
                    format!(
                        "{}−{} {} > {}",
                        d.a.name().to_uppercase(),
                        d.b.name().to_uppercase(),
                        fmt_small(d.difference * f),
                        fmt_small(d.tolerance * f)
                    )
                })
                .collect();
            let _ = writeln!(
                out,
                "    {:<12} {:<6} {}",
                label::<N>(p),
                format!("[{}]", unit::<N>(p)),
                pairs.join("; ")
            );
        }
    }
    out
}

#[cfg(test)]
mod wrap_tests {
    use super::wrap_prose;

    #[test]
    fn prose_wraps_at_the_width_and_tables_stay() {
        let words: Vec<String> = (0..60).map(|i| format!("w{i}")).collect();
        let prose = format!("  - {}\n", words.join(" "));
        let table = format!("  {}\n", words.join("  "));
        let text = format!("{prose}{table}short\n");
        let out = wrap_prose(&text, 40);
        let lines: Vec<&str> = out.lines().collect();
        // The prose: every line within 40, continuation lines hang under the bullet's text.
        let wrapped: Vec<&str> = lines
            .iter()
            .take_while(|l| !l.contains("  w1  "))
            .copied()
            .collect();
        assert!(wrapped.len() > 3, "{out}");
        assert!(wrapped.iter().all(|l| l.chars().count() <= 40), "{out}");
        assert!(wrapped[1..].iter().all(|l| l.starts_with("    w")), "{out}");
        // No word lost or reordered.
        let back: Vec<&str> = wrapped.iter().flat_map(|l| l.split_whitespace()).collect();
        assert_eq!(
            back[1..],
            words.iter().map(String::as_str).collect::<Vec<_>>()[..]
        );
        // The table row and the short line untouched.
        assert!(out.ends_with(&format!("{table}short\n")), "{out}");
        // A single word longer than the width stays whole.
        let long = "x".repeat(50);
        assert_eq!(wrap_prose(&long, 40), long);
        assert_eq!(wrap_prose("a b\n", 40), "a b\n");
    }
}

#[cfg(test)]
mod table_tests {
    use super::Table;

    /// A header cell spanning lines fills the header from the top; the column is as wide as
    /// its widest line or cell, not as the joined name.
    #[test]
    fn header_cells_may_span_lines() {
        let mut t = Table::new(&["design", "e_p\nmedian\n[mm]", "runs"]);
        t.row(vec!["table2".into(), "0.123".into(), "20".into()]);
        let text = t.render("  ");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "  design     e_p  runs",
                "          median",
                "            [mm]",
                "  --------------------",
                "  table2   0.123    20",
            ],
            "{text}"
        );
    }
}
