//! Hard case families for the sim-to-real diagnosis (issue #12, item 7): a measuring
//! instrument for the decision rules, with its own seeded generator (`common/outside.rs`).
//!
//! Each family draws cases of one kind: a random ARIA (manufacturing errors within ±5 mm /
//! ±5°), a hidden effect of realistic size (library effects via
//! [`kincal::sim::add_effect`], size factor log-uniform in [0.05, 5]; effects OUTSIDE the
//! library applied to the measured poses by this test, size factor log-uniform in
//! [0.1, 5]; some of either below detectability), measured by a mocap (0.1 mm, 0.05°,
//! full pose) or a laser tracker (0.02 mm, position only), on 60 random poses (20
//! repeated) or the paper's regime (Table 2 measured ×3, plus 0, 10 or 30 poses), with σ
//! stated truly, stated ×0.5 or ×2, or estimated from repeats, and 1–3 gross outliers.
//!
//! A case's size is its detectability ρ: the RMS residual a noise-free geometric
//! calibration leaves on the same joint states over √3·σ (position; rotation too where
//! measured; the larger). Detectable: ρ ≥ 3 (for a hidden pair: each effect's own ρ);
//! undetectable: ρ < 0.3 (cases in between are reported but not scored).
//!
//! Per family: correct verdicts on detectable in-library cases (the hidden set named or
//! listed as confounded, status explained or partially explained); false positives on
//! undetectable cases (status other than `no_gap`); over-claims on detectable
//! out-of-library cases (status `explained`); silent choices (a winner named while another
//! candidate of as many effects is significant and not significantly worse than it — an
//! independent paired Wilcoxon z < 3 over pose_id groups from the per-pose held-out errors
//! — but not listed as confounded); the share of the gap closed against the truth on 30
//! withheld noise-free poses, (B − A)/B of the RMS position error of the geometric and
//! the final model; and the library-free smooth share (`Diagnosis::explainable`).
//!
//! Over-claims are counted on the first generator (`common/outside.rs`, the target); a
//! second, independent generator (`common/outside2.rs`: other effects and magnitudes,
//! written after the decision rules were fixed) is reported beside it as a check against
//! tuning to one family, not tuned to; so is a third (`common/outside3.rs`: effects that
//! resemble a library effect in one respect: an instrument shear, a joint coupling, a
//! thermal drift of the joint zeros, encoder quantisation of the readings, a random-walk
//! instrument drift, a viewing-angle bias). Below the table, the counts per out-of-library
//! effect: detectable cases, over-claims, false positives and what the diagnosis said.
//! (Their undetectable cases count in the false-positive and silent-choice targets, as
//! every family's do.) `FAM_DEBUG=1` prints every case's detectability (and its hidden
//! out-of-library effect and size) and, per over-claim, the truth, the winner's
//! parameters, amplitudes and gains; `FAM_ONLY=text` runs only the families whose name
//! contains `text` (same seeds; the targets of the families left out read NaN and fail);
//! `FAM_CASES=n` runs `n` cases per family in `families_long` (the first 60 as by default).
//!
//! `families_short` (default run: 10 cases per family, about 2 s in a test build, where
//! the core is optimised) prints the table and asserts the targets that hold today;
//! `families_long` (`#[ignore]`, run in release: `cargo test -p kincal --release --test
//! diagnosis_families -- --ignored --nocapture`, about a minute) prints the table over 60
//! cases per family.

#[path = "common/outside.rs"]
mod outside;
#[path = "common/outside2.rs"]
mod outside2;
#[path = "common/outside3.rs"]
mod outside3;

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};

use kincal::diagnosis::{Config, DiagWorkspace, Diagnosis, PoseDiagnosis, Status, diagnose};
use kincal::rng::SplitMix64;
use kincal::sim::{add_effect, only_effects, perturb_geometry};
use kincal::{Effect, EffectSet, ParamId, Robot, aria};
use outside::{
    Design, Instrument, LASER, MOCAP, Outside, OutsideEffect, PoseEffect, add_outliers,
    detectability, measure, states,
};
use outside2::{Outside2, Outside2Effect};
use outside3::{Outside3, Outside3Effect};

/// An out-of-library effect of any of the three generators.
#[derive(Debug, Clone, Copy)]
enum AnyOutside {
    First(OutsideEffect),
    Second(Outside2Effect),
    Third(Outside3Effect),
}

impl AnyOutside {
    fn name(&self) -> &'static str {
        match self {
            AnyOutside::First(e) => e.kind.name(),
            AnyOutside::Second(e) => e.kind.name(),
            AnyOutside::Third(e) => e.kind.name(),
        }
    }
    fn size(&self) -> f64 {
        match self {
            AnyOutside::First(e) => e.size,
            AnyOutside::Second(e) => e.size,
            AnyOutside::Third(e) => e.size,
        }
    }
}

impl PoseEffect for AnyOutside {
    fn pose(
        &self,
        truth: &Robot<6>,
        st: &kincal::JointState<6>,
        t: Option<f64>,
    ) -> kincal::Transform {
        match self {
            AnyOutside::First(e) => e.pose(truth, st, t),
            AnyOutside::Second(e) => e.pose(truth, st, t),
            AnyOutside::Third(e) => e.pose(truth, st, t),
        }
    }
    fn reported(&self, st: &kincal::JointState<6>) -> kincal::JointState<6> {
        match self {
            AnyOutside::Third(e) => e.reported(st),
            _ => *st,
        }
    }
}

const DETECTABLE: f64 = 3.0;
const UNDETECTABLE: f64 = 0.3;
const WITHHELD: usize = 30;

/// How σ reaches the diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Sigma {
    /// Stated, times this factor (1 = true).
    Stated(f64),
    /// Not stated: estimated from repeats.
    Missing,
}

/// What is hidden in a family's cases (drawn per case from the list, in turn).
#[derive(Debug, Clone)]
enum Hidden {
    None,
    Library(Vec<EffectSet>),
    Outside(Vec<Outside>),
    /// Effects of the second, independent generator (`common/outside2.rs`): measured, not
    /// tuned to.
    Outside2(Vec<Outside2>),
    /// Effects of the third, independent generator (`common/outside3.rs`): measured, not
    /// tuned to.
    Outside3(Vec<Outside3>),
    /// A library effect plus an out-of-library one.
    Mixed(Vec<(Effect, Outside)>),
}

#[derive(Debug, Clone)]
struct Family {
    name: &'static str,
    hidden: Hidden,
    inst: Instrument,
    design: Design,
    sigma: Sigma,
    outliers: usize,
    /// Target group: 0 in-library ≥ 90 %, 1 misstated σ ≥ 85 %, 2 outliers ≥ 75 %.
    group: usize,
}

const RANDOM: Design = Design::Random {
    poses: 60,
    repeated: 20,
};

fn singles(list: &[Effect]) -> Vec<EffectSet> {
    list.iter().map(|&e| EffectSet::of(e)).collect()
}

/// Library effects that need no approach directions or temperatures (the Table 2 sessions
/// record neither).
const PLAIN: [Effect; 5] = [
    Effect::BaseFrame,
    Effect::ToolFrame,
    Effect::JointCompliance,
    Effect::JointScale,
    Effect::JointCyclic,
];

// Long by design: a data table, one entry per family of cases.
fn families() -> Vec<Family> {
    let lib = singles(&Effect::ALL);
    let out = Outside::ALL.to_vec();
    let f = |name, hidden, inst, design, sigma, outliers, group| Family {
        name,
        hidden,
        inst,
        design,
        sigma,
        outliers,
        group,
    };
    let st = Sigma::Stated(1.0);
    vec![
        f("none/mocap", Hidden::None, MOCAP, RANDOM, st, 0, 0),
        f("none/laser", Hidden::None, LASER, RANDOM, st, 0, 0),
        f(
            "library/mocap",
            Hidden::Library(lib.clone()),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "library/laser",
            Hidden::Library(lib.clone()),
            LASER,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "outside/mocap",
            Hidden::Outside(out.clone()),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "outside/laser",
            Hidden::Outside(out.clone()),
            LASER,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "paper/table2x3",
            Hidden::Library(singles(&PLAIN)),
            MOCAP,
            Design::Table2 { times: 3, extra: 0 },
            st,
            0,
            0,
        ),
        f(
            "paper/table2x3+10",
            Hidden::Library(singles(&PLAIN)),
            MOCAP,
            Design::Table2 {
                times: 3,
                extra: 10,
            },
            st,
            0,
            0,
        ),
        f(
            "paper/table2x3+30",
            Hidden::Library(singles(&PLAIN)),
            MOCAP,
            Design::Table2 {
                times: 3,
                extra: 30,
            },
            st,
            0,
            0,
        ),
        f(
            "pairs/mocap",
            Hidden::Library(vec![
                EffectSet::of(Effect::BaseFrame).with(Effect::ToolFrame),
                EffectSet::of(Effect::JointCompliance).with(Effect::JointScale),
                EffectSet::of(Effect::JointCompliance).with(Effect::Backlash),
                EffectSet::of(Effect::JointCyclic).with(Effect::Thermal),
            ]),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "mixed/mocap",
            Hidden::Mixed(vec![
                (Effect::JointCompliance, Outside::QuadraticCompliance),
                (Effect::BaseFrame, Outside::CompliantMount),
                (Effect::JointCyclic, Outside::ThirdHarmonic),
                (Effect::ToolFrame, Outside::ToolFlex),
            ]),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "sigma_x0.5/mocap",
            Hidden::Library(lib.clone()),
            MOCAP,
            RANDOM,
            Sigma::Stated(0.5),
            0,
            1,
        ),
        f(
            "sigma_x2/mocap",
            Hidden::Library(lib.clone()),
            MOCAP,
            RANDOM,
            Sigma::Stated(2.0),
            0,
            1,
        ),
        f(
            "sigma_missing/mocap",
            Hidden::Library(lib.clone()),
            MOCAP,
            RANDOM,
            Sigma::Missing,
            0,
            1,
        ),
        f(
            "outliers/mocap",
            Hidden::Library(lib),
            MOCAP,
            RANDOM,
            st,
            3,
            2,
        ),
        // Last, so the other families keep their seeds.
        f(
            "outside2/mocap",
            Hidden::Outside2(Outside2::ALL.to_vec()),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "outside2/laser",
            Hidden::Outside2(Outside2::ALL.to_vec()),
            LASER,
            RANDOM,
            st,
            0,
            0,
        ),
        // After the second generator's, so the others keep their seeds.
        f(
            "outside3/mocap",
            Hidden::Outside3(Outside3::ALL.to_vec()),
            MOCAP,
            RANDOM,
            st,
            0,
            0,
        ),
        f(
            "outside3/laser",
            Hidden::Outside3(Outside3::ALL.to_vec()),
            LASER,
            RANDOM,
            st,
            0,
            0,
        ),
    ]
}

/// One case's outcome.
#[derive(Debug, Clone, Default)]
struct Outcome {
    crashed: bool,
    error: Option<String>,
    in_library: bool,
    outside: bool,
    /// The out-of-library effect comes from the second generator.
    second: bool,
    /// … from the third.
    third: bool,
    /// The out-of-library effect of a case without library effects, its status (with the
    /// reason) and verdict, for the per-effect counts.
    effect: Option<&'static str>,
    said: Option<(&'static str, String)>,
    /// An `explained` verdict the extrapolation check demoted.
    demoted_extrapolation: bool,
    /// Detectability of everything hidden together.
    rho: f64,
    /// The least detectability of the hidden library effects each alone (pairs).
    rho_each: f64,
    correct: bool,
    positive: bool,
    overclaim: bool,
    named: bool,
    silent: bool,
    closed_truth: f64,
    smooth_share: f64,
    smooth_significant: bool,
}

fn log_uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.uniform() * (hi.ln() - lo.ln())).exp()
}

/// Paired Wilcoxon signed-rank z of models `a` and `b` (positive: a has the larger errors)
/// over `pose_id` groups, from the per-pose held-out errors (independent of the crate's).
fn wilcoxon(poses: &[PoseDiagnosis], groups: &[u32], a: usize, b: usize) -> f64 {
    let mut ids: Vec<u32> = groups.to_vec();
    ids.sort_unstable();
    ids.dedup();
    let d: Vec<f64> = ids
        .iter()
        .map(|&g| {
            poses
                .iter()
                .zip(groups)
                .filter(|(_, h)| **h == g)
                .map(|(p, _)| p.heldout_sq(a) - p.heldout_sq(b))
                .sum::<f64>()
        })
        .filter(|&v| v != 0.0)
        .collect();
    let n = d.len();
    if n == 0 {
        return 0.0;
    }
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()));
    let mut rank = vec![0.0; n];
    let mut ties = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && d[idx[j + 1]].abs() == d[idx[i]].abs() {
            j += 1;
        }
        let r = (i + j) as f64 / 2.0 + 1.0;
        for k in i..=j {
            rank[idx[k]] = r;
        }
        let t = (j - i + 1) as f64;
        ties += (t * t * t - t) / 48.0;
        i = j + 1;
    }
    let w: f64 = (0..n).filter(|&k| d[k] > 0.0).map(|k| rank[k]).sum();
    let nf = n as f64;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - ties;
    if var <= 0.0 {
        return 0.0;
    }
    (w - nf * (nf + 1.0) / 4.0) / var.sqrt()
}

/// The status with its reason, e.g. `partially_explained/form_not_determined`.
fn said(v: &kincal::diagnosis::Verdict) -> &'static str {
    use kincal::diagnosis::Reason as R;
    match (v.status, v.reason) {
        (Status::NoGap, _) => "no_gap",
        (Status::Explained, _) => "explained",
        (Status::Unexplained, R::ConfoundedWithSessions) => "unexplained/sessions",
        (Status::Unexplained, R::SmallShare) => "unexplained/small_share",
        (Status::Unexplained, _) => "unexplained/no_candidate",
        (Status::PartiallyExplained, R::RemainingGap { .. }) => "partial/remaining_gap",
        (Status::PartiallyExplained, R::RemainingStructure { .. }) => "partial/structure",
        (Status::PartiallyExplained, R::DoesNotExtrapolate { .. }) => "partial/extrapolation",
        (Status::PartiallyExplained, R::FormNotDetermined { .. }) => "partial/form",
        (Status::PartiallyExplained, R::Worsens { .. }) => "partial/worsens",
        (Status::PartiallyExplained, _) => "partial/small_share",
    }
}

/// `FAM_DEBUG`: the status, verdict and the noise floor the diagnosis used.
fn print_said(d: &Diagnosis<6>, o: &Outcome) {
    let n = &d.noise;
    let overruled = n
        .overruled_pos
        .map(|s| format!(" (stated {:.3} mm overruled by the repeats)", s * 1e3))
        .unwrap_or_default();
    let (status, verdict) = o
        .said
        .as_ref()
        .map_or(("-", "-"), |(s, v)| (*s, v.as_str()));
    println!(
        "    said {status} {verdict}; floor sigma_pos {:.3} mm{overruled}, repeats {}",
        n.sigma_pos_m * 1e3,
        n.repeat_pos.map_or("-".into(), |(s, dof)| format!(
            "{:.3} mm ({dof:.0} dof)",
            s * 1e3
        ))
    );
}

/// The effects of a set joined by `+` (`-` for none).
fn effect_names(set: EffectSet) -> String {
    let names: Vec<&str> = set.iter().map(|e| e.name()).collect();
    if names.is_empty() {
        "-".into()
    } else {
        names.join("+")
    }
}

/// A winner named while an equally good candidate of as many effects is not listed.
fn silent_choice(d: &Diagnosis<6>, poses: &[PoseDiagnosis], groups: &[u32]) -> bool {
    let Some(w) = d.verdict.candidate else {
        return false;
    };
    let wc = &d.candidates[w];
    d.candidates().iter().enumerate().any(|(c, s)| {
        c != w
            && s.evaluated
            && s.significant
            && s.effects.len() == wc.effects.len()
            && !d.verdict.confounded().contains(&s.effects)
            && wilcoxon(poses, groups, c + 1, w + 1) < 3.0
    })
}

/// RMS position error of `model` at the reported readings against the true poses at the
/// true states `st`.
fn rms_against(
    model: &Robot<6>,
    truth: &Robot<6>,
    out: &[AnyOutside],
    st: &[(kincal::JointState<6>, u32)],
) -> f64 {
    let s: f64 = st
        .iter()
        .map(|(q, _)| {
            let t = outside::true_pose(truth, out, q);
            let m = model.fk(&outside::reported(out, q)).unwrap();
            (t.translation.vector - m.translation.vector).norm_squared()
        })
        .sum();
    (s / st.len() as f64).sqrt()
}

fn run_case(fam: &Family, k: usize, seed: u64, ws: &mut DiagWorkspace<80>) -> Outcome {
    let mut rng = SplitMix64::new(seed);
    let nominal = aria::nominal();
    let mut truth = perturb_geometry(&nominal, 5e-3, 5f64.to_radians(), &mut rng).unwrap();
    let mut out_effects = Vec::new();
    let mut o = Outcome::default();
    let mut hidden_lib = EffectSet::NONE;
    match &fam.hidden {
        Hidden::None => {}
        Hidden::Library(list) => {
            let set = list[k % list.len()];
            for e in set.iter() {
                let size = log_uniform(&mut rng, 0.05, 5.0);
                add_effect(&mut truth, e, size, &mut rng).unwrap();
            }
            hidden_lib = set;
        }
        Hidden::Outside(list) => {
            let kind = list[k % list.len()];
            let size = log_uniform(&mut rng, 0.1, 5.0);
            out_effects.push(AnyOutside::First(OutsideEffect::draw(kind, size, &mut rng)));
        }
        Hidden::Outside2(list) => {
            let kind = list[k % list.len()];
            let size = log_uniform(&mut rng, 0.1, 5.0);
            out_effects.push(AnyOutside::Second(Outside2Effect::draw(
                kind, size, &mut rng,
            )));
            o.second = true;
        }
        Hidden::Outside3(list) => {
            let kind = list[k % list.len()];
            let size = log_uniform(&mut rng, 0.1, 5.0);
            out_effects.push(AnyOutside::Third(Outside3Effect::draw(
                kind, size, &mut rng,
            )));
            o.third = true;
        }
        Hidden::Mixed(list) => {
            let (e, kind) = list[k % list.len()];
            let size = log_uniform(&mut rng, 0.05, 5.0);
            add_effect(&mut truth, e, size, &mut rng).unwrap();
            hidden_lib = EffectSet::of(e);
            let size = log_uniform(&mut rng, 0.1, 5.0);
            out_effects.push(AnyOutside::First(OutsideEffect::draw(kind, size, &mut rng)));
        }
    }
    let st = states(&truth, fam.design, &mut rng);
    let (mut data, groups) = measure(&truth, &out_effects, &st, &fam.inst, true, &mut rng);
    if fam.outliers > 0 {
        let n_out = 1 + rng.below(fam.outliers);
        add_outliers(&mut data, n_out, &mut rng);
    }
    let rho_of = |t: &Robot<6>, oe: &[AnyOutside]| {
        let (p, r) = detectability(t, oe, &st, &fam.inst);
        if fam.inst.mask.has(3) { p.max(r) } else { p }
    };
    o.rho = rho_of(&truth, &out_effects);
    o.rho_each = o.rho;
    if hidden_lib.len() > 1 && out_effects.is_empty() {
        // A set is detectable when each of its effects is (as the blind suite).
        o.rho_each = hidden_lib
            .iter()
            .map(|e| {
                rho_of(
                    &only_effects(&truth, EffectSet::of(e)),
                    &[] as &[AnyOutside],
                )
            })
            .fold(f64::INFINITY, f64::min);
    }
    if std::env::var("FAM_DEBUG").is_ok() {
        let hidden: Vec<String> = out_effects
            .iter()
            .map(|e| format!(" {} size {:.2}", e.name(), e.size()))
            .collect();
        println!(
            "  {} case {k}: rho {:.3}{}",
            fam.name,
            o.rho,
            hidden.concat()
        );
    }
    // The out-of-library part alone (what the library cannot explain).
    let rho_out = if out_effects.is_empty() {
        0.0
    } else {
        rho_of(&only_effects(&truth, EffectSet::NONE), &out_effects)
    };
    o.in_library = out_effects.is_empty() && !hidden_lib.is_empty();
    o.outside = rho_out >= DETECTABLE;
    let cfg = match fam.sigma {
        Sigma::Stated(f) => Config {
            sigma_pos_m: Some(fam.inst.sigma_pos_m * f),
            sigma_rot_rad: Some(fam.inst.sigma_rot_rad * f),
            ..Config::default()
        },
        Sigma::Missing => Config::default(),
    };
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let res = catch_unwind(AssertUnwindSafe(|| {
        diagnose(&nominal, &data, &groups, &cfg, &mut poses, ws)
    }));
    let d = match res {
        Err(_) => {
            o.crashed = true;
            return o;
        }
        Ok(Err(e)) => {
            o.error = Some(format!("{} case {k}: {e:?}", fam.name));
            return o;
        }
        Ok(Ok(d)) => d,
    };
    let status = d.verdict.status;
    if hidden_lib.is_empty() {
        o.effect = out_effects.first().map(AnyOutside::name);
    }
    o.said = Some((said(&d.verdict), effect_names(d.verdict.effects)));
    if std::env::var("FAM_DEBUG").is_ok() {
        print_said(&d, &o);
    }
    o.named = !d.verdict.effects.is_empty();
    o.correct = matches!(status, Status::Explained | Status::PartiallyExplained)
        && (d.verdict.effects == hidden_lib || d.verdict.confounded().contains(&hidden_lib));
    o.positive = status != Status::NoGap;
    o.overclaim = status == Status::Explained;
    o.demoted_extrapolation = matches!(
        d.verdict.reason,
        kincal::diagnosis::Reason::DoesNotExtrapolate { .. }
            | kincal::diagnosis::Reason::FormNotDetermined { .. }
    );
    if std::env::var("FAM_DEBUG").is_ok() && d.form.evaluated {
        println!(
            "    FORM {} rho {:.1} rho_out {rho_out:.1}: {:?}",
            if o.in_library { "LIB" } else { "OUT" },
            o.rho,
            d.form
        );
    }
    if std::env::var("FAM_DEBUG").is_ok() && o.outside && o.overclaim {
        println!(
            "    over-claim: rho_out {rho_out:.2}, {:?}, remaining gap z {:.2}, structure z {:.2}, gap closed {:.2}",
            d.verdict
                .effects
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>(),
            d.remaining.z,
            d.remaining_structure.z,
            d.verdict.gap_closed_fraction
        );
        println!("      extrapolation check: {:?}", d.extrapolation);
        println!("      form check: {:?}", d.form);
        debug_overclaim(&d, &data, &groups, &out_effects, &nominal);
    }
    if std::env::var("FAM_DEBUG").is_ok()
        && status == Status::Explained
        && d.verdict.effects.contains(Effect::JointCyclic)
    {
        let mut line = String::new();
        for j in 0..6 {
            let (mut a2, mut s2) = (0.0, 0.0);
            for t in kincal::params::CyclicTerm::ALL {
                let i = ParamId::Cyclic(j, t).index(6);
                a2 += d.model.param(i).unwrap().powi(2);
                s2 += d.fit.std_errors[i.0].powi(2);
            }
            line += &format!(" {:.1}({:.1})", a2.sqrt() * 1e3, s2.sqrt() * 1e3);
        }
        println!(
            "    CYC {} rho_out {rho_out:.1} rho {:.1}: amplitude mrad (se):{line}",
            if o.in_library { "LIB" } else { "OUT" },
            o.rho
        );
    }
    o.silent = silent_choice(&d, &poses, &groups);
    o.smooth_share = d.explainable.share_of_gap;
    o.smooth_significant = d.explainable.significant;
    // Against the truth on withheld poses.
    let withheld = states(
        &truth,
        Design::Random {
            poses: WITHHELD,
            repeated: 0,
        },
        &mut rng,
    );
    let b = rms_against(&d.geometric, &truth, &out_effects, &withheld);
    let a = rms_against(&d.model, &truth, &out_effects, &withheld);
    o.closed_truth = if b > 0.0 { (b - a) / b } else { 0.0 };
    o
}

/// Per over-claim (`FAM_DEBUG`): the truth, the winner's parameters and amplitudes, its
/// in-sample and held-out gains, and how it extrapolates: fitted (nonlinear, kincal's own
/// identification) on the poses with q_j below the median and judged on those above, and
/// the other way round, for every joint, against the geometric model fitted the same way.
fn debug_overclaim(
    d: &Diagnosis<6>,
    data: &[kincal::identify::Measurement<6>],
    _groups: &[u32],
    out_effects: &[AnyOutside],
    nominal: &Robot<6>,
) {
    use kincal::identify::{Algorithm, IdentifyOptions, Workspace, identify};
    use kincal::params::CyclicTerm;
    let Some(w) = d.verdict.candidate else { return };
    let c = &d.candidates[w];
    for oe in out_effects {
        println!("      truth: {} size {:.2}", oe.name(), oe.size());
    }
    println!(
        "      winner params {} (geometric {}), heldout chi2 base {:.0} -> {:.0}, in-sample cost {:.0} -> {:.0}, rows {}",
        c.fitted_params,
        d.baseline.fitted_params,
        d.baseline.heldout_chi2,
        c.heldout_chi2,
        d.geometric_residuals.cost,
        d.fit.fitted.cost,
        d.geometric_residuals.rows
    );
    let mut amp = String::new();
    for j in 0..6 {
        let a: f64 = CyclicTerm::ALL
            .iter()
            .map(|&t| {
                let i = ParamId::Cyclic(j, t).index(6);
                d.model.param(i).unwrap().powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let (lo, hi) = data.iter().fold((f64::MAX, f64::MIN), |(lo, hi), m| {
            (lo.min(m.state.q[j]), hi.max(m.state.q[j]))
        });
        amp += &format!(
            " j{}:{:.2}mrad[{:.0}..{:.0}deg]",
            j + 1,
            a * 1e3,
            lo.to_degrees(),
            hi.to_degrees()
        );
    }
    println!("      cyclic amplitudes{amp}");
    let sp = d.noise.sigma_pos_m;
    let sr = d.noise.sigma_rot_rad;
    let fit_rms = |set: kincal::ParamSet,
                   train: &[kincal::identify::Measurement<6>],
                   test: &[kincal::identify::Measurement<6>]| {
        let mut o = IdentifyOptions::new(Algorithm::Ols, set);
        o.weight_pos = sp.powi(-2);
        o.weight_rot = sr.powi(-2);
        o.allow_data_deficiency = true;
        let mut ws = Box::<Workspace<80>>::default();
        let Ok(fit) = identify(nominal, train, &o, &mut ws) else {
            return f64::NAN;
        };
        let s: f64 = test
            .iter()
            .map(|m| {
                let e = kincal::pose::pose_error(
                    &m.pose,
                    &fit.robot.fk(&m.state).unwrap(),
                    kincal::OrientationError::Exact,
                );
                (0..6)
                    .filter(|&k| m.mask.has(k))
                    .map(|k| (e[k] / if k < 3 { sp } else { sr }).powi(2))
                    .sum::<f64>()
            })
            .sum();
        let rows: usize = test
            .iter()
            .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
            .sum();
        (s / rows as f64).sqrt()
    };
    let mut line = String::new();
    for j in 0..6 {
        let mut qs: Vec<f64> = data.iter().map(|m| m.state.q[j]).collect();
        qs.sort_by(f64::total_cmp);
        let med = qs[qs.len() / 2];
        let lo: Vec<_> = data
            .iter()
            .filter(|m| m.state.q[j] < med)
            .copied()
            .collect();
        let hi: Vec<_> = data
            .iter()
            .filter(|m| m.state.q[j] >= med)
            .copied()
            .collect();
        let g = nominal.geometric_param_set();
        let wb = fit_rms(g, &lo, &hi);
        let ww = fit_rms(c.identifiable, &lo, &hi);
        let wb2 = fit_rms(g, &hi, &lo);
        let ww2 = fit_rms(c.identifiable, &hi, &lo);
        line += &format!(
            " j{}: {:.1}->{:.1} / {:.1}->{:.1};",
            j + 1,
            wb,
            ww,
            wb2,
            ww2
        );
    }
    println!("      extrapolation whitened rms/row (geometric -> winner, lo->hi / hi->lo):{line}");
}

/// Counts of one family (or a group of families).
#[derive(Debug, Clone, Default)]
struct Tally {
    cases: usize,
    crashes: usize,
    errors: usize,
    det_lib: usize,
    correct: usize,
    undet: usize,
    false_pos: usize,
    det_out: usize,
    overclaim: usize,
    /// The same on the second and third generators' cases (not part of the target).
    det_out2: usize,
    overclaim2: usize,
    det_out3: usize,
    overclaim3: usize,
    /// Detectable in-library cases the extrapolation check demoted from `explained`.
    lib_demoted: usize,
    named: usize,
    silent: usize,
    closed_sum: f64,
    closed_n: usize,
    smooth_sum: f64,
    smooth_sig: usize,
}

impl Tally {
    fn add(&mut self, o: &Outcome) {
        self.cases += 1;
        self.crashes += usize::from(o.crashed);
        if let Some(e) = &o.error {
            println!("  error: {e}");
            self.errors += 1;
            return;
        }
        if o.crashed {
            return;
        }
        let detectable = o.rho >= DETECTABLE;
        if o.in_library && o.rho_each >= DETECTABLE {
            self.det_lib += 1;
            self.correct += usize::from(o.correct);
        }
        if o.rho < UNDETECTABLE {
            self.undet += 1;
            self.false_pos += usize::from(o.positive);
        }
        if o.in_library && o.rho_each >= DETECTABLE {
            self.lib_demoted += usize::from(o.demoted_extrapolation);
        }
        if o.outside {
            let (det, over) = if o.third {
                (&mut self.det_out3, &mut self.overclaim3)
            } else if o.second {
                (&mut self.det_out2, &mut self.overclaim2)
            } else {
                (&mut self.det_out, &mut self.overclaim)
            };
            *det += 1;
            *over += usize::from(o.overclaim);
            self.smooth_sum += o.smooth_share;
            self.smooth_sig += usize::from(o.smooth_significant);
        }
        if o.named {
            self.named += 1;
            self.silent += usize::from(o.silent);
        }
        if detectable {
            self.closed_sum += o.closed_truth;
            self.closed_n += 1;
        }
    }
    fn merge(&mut self, t: &Tally) {
        self.cases += t.cases;
        self.crashes += t.crashes;
        self.errors += t.errors;
        self.det_lib += t.det_lib;
        self.correct += t.correct;
        self.undet += t.undet;
        self.false_pos += t.false_pos;
        self.det_out += t.det_out;
        self.overclaim += t.overclaim;
        self.det_out2 += t.det_out2;
        self.overclaim2 += t.overclaim2;
        self.det_out3 += t.det_out3;
        self.overclaim3 += t.overclaim3;
        self.lib_demoted += t.lib_demoted;
        self.named += t.named;
        self.silent += t.silent;
        self.closed_sum += t.closed_sum;
        self.closed_n += t.closed_n;
        self.smooth_sum += t.smooth_sum;
        self.smooth_sig += t.smooth_sig;
    }
}

/// One out-of-library effect's cases on one instrument: what the diagnosis said.
#[derive(Debug, Clone, Default)]
struct EffectTally {
    cases: usize,
    detectable: usize,
    overclaim: usize,
    undetectable: usize,
    false_pos: usize,
    /// "status verdict" counts over the detectable cases …
    said: BTreeMap<String, usize>,
    /// … and over the undetectable cases with a status other than `no_gap`.
    said_falsely: BTreeMap<String, usize>,
}

impl EffectTally {
    fn add(&mut self, o: &Outcome) {
        self.cases += 1;
        let Some((status, verdict)) = &o.said else {
            return;
        };
        let said = format!("{status} {verdict}");
        if o.outside {
            self.detectable += 1;
            self.overclaim += usize::from(o.overclaim);
            *self.said.entry(said.clone()).or_default() += 1;
        }
        if o.rho < UNDETECTABLE {
            self.undetectable += 1;
            self.false_pos += usize::from(o.positive);
            if o.positive {
                *self.said_falsely.entry(said).or_default() += 1;
            }
        }
    }
}

/// The key of a case's out-of-library effect: generator, effect and instrument.
fn effect_key(o: &Outcome, fam: &Family) -> Option<String> {
    let generator = if o.third {
        3
    } else if o.second {
        2
    } else {
        1
    };
    o.effect
        .map(|e| format!("{generator} {e}/{}", fam.inst.name))
}

fn counts(m: &BTreeMap<String, usize>) -> String {
    let v: Vec<String> = m.iter().map(|(k, n)| format!("{k} x{n}")).collect();
    v.join(", ")
}

/// Prints the per-effect counts (generator number first).
fn print_by_effect(by_effect: &BTreeMap<String, EffectTally>) {
    println!(
        "per out-of-library effect (generator effect/instrument): cases, detectable (rho_out >= {DETECTABLE}) and over-claims, undetectable (rho < {UNDETECTABLE}) and false positives; what was said on the detectable ones (status/reason verdict x count) and on the false positives"
    );
    for (k, t) in by_effect {
        println!(
            "  {k:<34} cases {:>3} | det {:>3} over {:>2} | und {:>3} FP {:>2} | said: {}{}",
            t.cases,
            t.detectable,
            t.overclaim,
            t.undetectable,
            t.false_pos,
            counts(&t.said),
            if t.said_falsely.is_empty() {
                String::new()
            } else {
                format!(" | FP said: {}", counts(&t.said_falsely))
            }
        );
    }
}

fn pct(a: usize, b: usize) -> String {
    if b == 0 {
        "   -  ".into()
    } else {
        format!("{:5.1}%", 100.0 * a as f64 / b as f64)
    }
}

fn frac(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

fn row(name: &str, t: &Tally) -> String {
    // Out-of-library columns over all generators (the target counts the first only).
    let det_out = t.det_out + t.det_out2 + t.det_out3;
    let overclaim = t.overclaim + t.overclaim2 + t.overclaim3;
    format!(
        "{:<20} {:>5} {:>5} {:>4} | {:>4} {} | {:>4} {} | {:>4} {} {:>6} {} | {:>4} {} | {:>6}",
        name,
        t.cases,
        t.crashes,
        t.errors,
        t.det_lib,
        pct(t.correct, t.det_lib),
        t.undet,
        pct(t.false_pos, t.undet),
        det_out,
        pct(overclaim, det_out),
        if det_out > 0 {
            format!("{:.2}", t.smooth_sum / det_out as f64)
        } else {
            "-".into()
        },
        pct(t.smooth_sig, det_out),
        t.named,
        pct(t.silent, t.named),
        if t.closed_n > 0 {
            format!("{:.2}", t.closed_sum / t.closed_n as f64)
        } else {
            "-".into()
        },
    )
}

/// Runs `per_family` cases of every family; prints the table; returns the tallies per
/// target group (0 in-library, 1 misstated σ, 2 outliers) and the total.
/// The seed of case `k` of family `fi` (index in [`families`]) in a suite run with `seed`.
fn case_seed(seed: u64, fi: usize, k: usize) -> u64 {
    seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((fi as u64) << 32 | k as u64)
}

fn suite(per_family: usize, seed: u64) -> ([Tally; 3], Tally) {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    let mut ws: Box<DiagWorkspace<80>> = unsafe { Box::new_zeroed().assume_init() };
    let mut groups: [Tally; 3] = Default::default();
    let mut total = Tally::default();
    println!(
        "{:<20} {:>5} {:>5} {:>4} | {:>4} {:>6} | {:>4} {:>6} | {:>4} {:>6} {:>6} {:>6} | {:>4} {:>6} | {:>6}",
        "family",
        "cases",
        "crash",
        "err",
        "det",
        "right",
        "und",
        "FP",
        "out",
        "over",
        "smooth",
        "sm.sig",
        "named",
        "silent",
        "closed"
    );
    // FAM_ONLY=substring runs only the matching families (same seeds: for investigation).
    let only = std::env::var("FAM_ONLY").ok();
    let mut by_effect: BTreeMap<String, EffectTally> = BTreeMap::new();
    for (fi, fam) in families().iter().enumerate() {
        if only.as_deref().is_some_and(|o| !fam.name.contains(o)) {
            continue;
        }
        let mut t = Tally::default();
        for k in 0..per_family {
            let o = run_case(fam, k, case_seed(seed, fi, k), &mut ws);
            if let Some(key) = effect_key(&o, fam) {
                by_effect.entry(key).or_default().add(&o);
            }
            t.add(&o);
        }
        println!("{}", row(fam.name, &t));
        groups[fam.group].merge(&t);
        total.merge(&t);
    }
    println!("{}", row("TOTAL", &total));
    print_by_effect(&by_effect);
    println!(
        "over-claims: first generator (outside.rs, the target) {}/{} = {}; second generator (outside2.rs, measured only) {}/{} = {}; third generator (outside3.rs, measured only) {}/{} = {}; detectable in-library cases the extrapolation or form check demoted from explained: {}/{}",
        total.overclaim,
        total.det_out,
        pct(total.overclaim, total.det_out),
        total.overclaim2,
        total.det_out2,
        pct(total.overclaim2, total.det_out2),
        total.overclaim3,
        total.det_out3,
        pct(total.overclaim3, total.det_out3),
        total.lib_demoted,
        total.det_lib
    );
    println!(
        "columns: det = detectable in-library cases, right = correct verdicts among them; und = undetectable (rho < {UNDETECTABLE}), FP = status not no_gap; out = detectable out-of-library, over = status explained, smooth = mean library-free share, sm.sig = share of those where it is significant; named = cases with a verdict effect, silent = silent choices among them; closed = gap closed against the truth on withheld poses (detectable cases)"
    );
    (groups, total)
}

/// The targets, printed with their figures; returns (name, figure, target, holds).
fn targets(groups: &[Tally; 3], total: &Tally) -> Vec<(&'static str, f64, f64, bool)> {
    let t = vec![
        ("crashes", total.crashes as f64, 0.0, total.crashes == 0),
        (
            "over-claims <= 5 %",
            frac(total.overclaim, total.det_out),
            0.05,
            frac(total.overclaim, total.det_out) <= 0.05,
        ),
        (
            "false positives <= 5 %",
            frac(total.false_pos, total.undet),
            0.05,
            frac(total.false_pos, total.undet) <= 0.05,
        ),
        (
            "correct in-library >= 90 %",
            frac(groups[0].correct, groups[0].det_lib),
            0.9,
            frac(groups[0].correct, groups[0].det_lib) >= 0.9,
        ),
        (
            "correct misstated sigma >= 85 %",
            frac(groups[1].correct, groups[1].det_lib),
            0.85,
            frac(groups[1].correct, groups[1].det_lib) >= 0.85,
        ),
        (
            "correct with outliers >= 75 %",
            frac(groups[2].correct, groups[2].det_lib),
            0.75,
            frac(groups[2].correct, groups[2].det_lib) >= 0.75,
        ),
        (
            "silent choices <= 20 %",
            frac(total.silent, total.named),
            0.2,
            frac(total.silent, total.named) <= 0.2,
        ),
    ];
    for (name, v, target, ok) in &t {
        println!(
            "TARGET {name:<34} figure {v:.3} (target {target}): {}",
            if *ok { "holds" } else { "FAILS" }
        );
    }
    t
}

/// Position-only cases (of `families_long`'s seed, `FAM_CASES=300`) where the fit of the
/// verdict's model from the geometric calibration crawled without converging, and the
/// whole diagnosis failed with `NotConverged` (13 of 5,700 cases, all laser); the fit now
/// falls back to starting from the description. Each is diagnosed.
#[test]
fn refits_that_crawled_are_diagnosed() {
    let fams = families();
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    let mut ws: Box<DiagWorkspace<80>> = unsafe { Box::new_zeroed().assume_init() };
    for (name, k) in [
        ("library/laser", 14),
        ("outside/laser", 30),
        ("outside2/laser", 224),
        ("outside3/laser", 60),
    ] {
        let fi = fams.iter().position(|f| f.name == name).unwrap();
        let o = run_case(&fams[fi], k, case_seed(2, fi, k), &mut ws);
        assert!(
            !o.crashed && o.error.is_none(),
            "{name} case {k}: {:?}",
            o.error
        );
        assert!(o.said.is_some(), "{name} case {k}");
    }
}

#[test]
fn families_short() {
    let (groups, total) = suite(10, 1);
    let t = targets(&groups, &total);
    assert_eq!(total.errors, 0, "diagnoses that returned an error");
    // Asserted: the targets that hold with today's decision rules in this run and in
    // `families_long` (the others are printed; the decision-rule work of issue #12 is to
    // make them hold, then add them here).
    let asserted = [
        "crashes",
        "correct misstated sigma >= 85 %",
        "silent choices <= 20 %",
    ];
    for (name, _, _, ok) in &t {
        if asserted.contains(name) {
            assert!(ok, "{name}");
        }
    }
    // Over-claims: about a dozen detectable out-of-library cases here, too few for the
    // plain 5 % (one case is 9 %): asserted as "not significantly above 5 %" (exact
    // one-sided binomial test at the 5 % level; today's rate, 23 % before the form check,
    // fails it). `families_long` asserts the plain figure.
    let p = binomial_tail(total.overclaim, total.det_out, 0.05);
    assert!(
        p >= 0.05,
        "over-claims {}/{} significantly above 5 % (p = {p:.3})",
        total.overclaim,
        total.det_out
    );
    // The suite itself must measure something: every target group has scored cases.
    assert!(groups[0].det_lib > 0 && total.det_out > 0 && total.undet > 0);
}

/// P(X ≥ k) for X binomial with `n` trials of probability `p`.
fn binomial_tail(k: usize, n: usize, p: f64) -> f64 {
    (k..=n)
        .map(|i| {
            let ln_choose: f64 = (1..=i).map(|j| ((n - i + j) as f64 / j as f64).ln()).sum();
            (ln_choose + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln()).exp()
        })
        .sum()
}

#[test]
fn binomial_tail_matches_closed_forms() {
    // P(X ≥ 0) = 1; P(X ≥ 1) = 1 − (1 − p)^n; P(X ≥ n) = p^n.
    assert!((binomial_tail(0, 11, 0.05) - 1.0).abs() < 1e-12);
    assert!((binomial_tail(1, 11, 0.05) - (1.0 - 0.95f64.powi(11))).abs() < 1e-12);
    assert!((binomial_tail(11, 11, 0.05) - 0.05f64.powi(11)).abs() < 1e-20);
}

#[test]
#[ignore]
fn families_long() {
    // FAM_CASES=n: n cases per family instead of 60 (the first 60 are the same cases).
    let per_family = std::env::var("FAM_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60);
    let (groups, total) = suite(per_family, 2);
    let t = targets(&groups, &total);
    assert_eq!(total.crashes, 0);
    assert_eq!(total.errors, 0, "diagnoses that returned an error");
    // Asserted since the form check (`kincal::diagnosis::FormCheck`); the other targets
    // are asserted in `families_short` or printed.
    for (name, _, _, ok) in &t {
        if *name == "over-claims <= 5 %" {
            assert!(ok, "{name}");
        }
    }
}
