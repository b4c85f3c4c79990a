//! The designs `kincal evaluate-designs` and `kincal.evaluate_designs` compare: the
//! built-in ones (standard, clustering, Table 2, built from the seed) and those from files
//! (tools, commanded configurations), and the `--json` document of the comparison (with
//! the socket plates of [`plate`], when there are any).

use std::path::PathBuf;

use crate::design::Progress;
use crate::design::context::{Context, ScenarioSpec, SelectionSettings};
use crate::design::designs::{self, Design};
use crate::design::plate;
use crate::design::pose_selection::Search;
use crate::design::study::{self, DesignResult, Timing};
use crate::error::Error;

/// A built-in design.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuiltIn {
    Standard,
    Clustering,
    Table2,
}

impl BuiltIn {
    /// By name: `standard`, `clustering`, `table2`.
    pub fn parse(s: &str) -> Option<BuiltIn> {
        match s {
            "standard" => Some(BuiltIn::Standard),
            "clustering" => Some(BuiltIn::Clustering),
            "table2" => Some(BuiltIn::Table2),
            _ => None,
        }
    }
}

/// A design to compare and, for a selected one, how its search went.
#[derive(Debug, Clone)]
pub struct Built<const N: usize> {
    pub design: Design<N>,
    pub search: Option<Search>,
}

/// Where the designs come from: the built-in ones, then `(name, file)` tool files and
/// commanded-configuration files.
#[derive(Debug, Clone, Default)]
pub struct DesignChoice {
    pub builtin: Vec<BuiltIn>,
    pub tools: Vec<(String, PathBuf)>,
    pub commanded: Vec<(String, PathBuf)>,
}

/// Builds the chosen designs: the files first (a bad file should not wait for the selected
/// designs), then the built-in ones, listed built-in first. Names must differ.
pub fn build_designs<const N: usize>(
    ctx: &Context<N>,
    choice: &DesignChoice,
    settings: &SelectionSettings,
    scenario: &ScenarioSpec,
    pb: &dyn Progress,
) -> Result<Vec<Built<N>>, Error> {
    let mut from_files = Vec::new();
    for (name, path) in &choice.tools {
        from_files.push(designs::tool_from_file(ctx, name, path)?);
    }
    for (name, path) in &choice.commanded {
        from_files.push(designs::commanded_from_file(ctx, name, path)?);
    }
    let mut out = Vec::new();
    for b in &choice.builtin {
        out.push(builtin(ctx, *b, settings, scenario, pb)?);
    }
    out.extend(from_files.into_iter().map(|design| Built {
        design,
        search: None,
    }));
    let mut names: Vec<&str> = out.iter().map(|d| d.design.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(Error::usage(format!("two designs are named '{}'", w[0])));
    }
    if out.is_empty() {
        return Err(Error::usage("no design to evaluate"));
    }
    Ok(out)
}

fn builtin<const N: usize>(
    ctx: &Context<N>,
    b: BuiltIn,
    settings: &SelectionSettings,
    scenario: &ScenarioSpec,
    pb: &dyn Progress,
) -> Result<Built<N>, Error> {
    Ok(match b {
        BuiltIn::Standard => {
            pb.stage(
                settings.pool as u64,
                "standard design: sampling the workspace",
            );
            let (design, s, _) = designs::standard_design(ctx, settings, pb)?;
            Built {
                design,
                search: Some(Search::Exchange(s)),
            }
        }
        BuiltIn::Clustering => {
            pb.stage(
                settings.pool as u64,
                "clustering design: robust poses of the working region",
            );
            let study = ctx.study(scenario.scenario(), ctx.seed);
            let (design, c, _) = designs::clustering_design(ctx, settings, &study, pb)?;
            Built {
                design,
                search: Some(Search::Clustering(c)),
            }
        }
        BuiltIn::Table2 => Built {
            design: designs::table2_design(ctx)?,
            search: None,
        },
    })
}

/// The numbers of a comparison (`kincal evaluate-designs --json`), with the plates'
/// comparison (`plates`, [`plate::json`]) when there is one. Run times and the thread count
/// are left out: the document is byte-for-byte reproducible.
pub fn json<const N: usize>(
    ctx: &Context<N>,
    runs: u64,
    scenario: &ScenarioSpec,
    results: &[DesignResult],
    t: &Timing,
    plates: Option<&[plate::Row]>,
) -> serde_json::Value {
    let s = scenario.scenario();
    let mut doc = serde_json::json!({
        "robot": ctx.robot_name,
        "seed": ctx.seed,
        "runs": runs,
        "validation_poses": ctx.validation_q.len(),
        "scenario": {
            "length_error_m": s.length_error_m, "angle_error_rad": s.angle_error_rad,
            "noise_pos_m": s.noise_pos_m, "noise_rot_rad": s.noise_rot_rad,
            "tool_tol_pos_m": s.tool_tol_pos_m, "tool_tol_rot_rad": s.tool_tol_rot_rad,
        },
        "designs": study::results_json(results),
        "calibrations": t.calibrations,
    });
    if let Some(rows) = plates {
        doc["plates"] = plate::json(rows);
    }
    doc
}
