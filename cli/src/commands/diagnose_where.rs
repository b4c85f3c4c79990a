//! Where the gap lies by the data's own labels (`kincal diagnose`), as text: the tables of
//! kincal-io's breakdown ([`kincal_io::diagnose_where`], REPORT.json's `where.by`).

use std::fmt::Write as _;

use kincal_io::diagnose_where::Breakdown;

use crate::report::Table;

/// The readable tables.
pub fn text(b: &[Breakdown]) -> String {
    if b.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\nWHERE BY LABEL — held-out RMS |Δp| of the geometric model and of the verdict's model (mm):\n",
    );
    for g in b {
        let mut t = Table::new(&[&g.by, "rows", "geometric", "verdict"]);
        for bin in &g.bins {
            t.row(vec![
                bin.label.clone(),
                bin.rows.to_string(),
                format!("{:.2}", bin.geometric_mm),
                format!("{:.2}", bin.verdict_mm),
            ]);
        }
        s.push_str(&t.render("  "));
        let _ = writeln!(s);
    }
    s
}
