//! `evaluate-designs --plate`: socket plates (instrument-free calibration, issue #13 item
//! 6) against known-pose tools, on the same random robots ([`kincal::plate_study`]).
//!
//! A plate `NAME=D_MM,PLACEMENTS,CONTACTS` has two ball sockets `D_MM` apart (MUKCa: 50 mm)
//! at positions nobody measures; it is placed `PLACEMENTS` times in the working region
//! (centre uniform in the region with both sockets inside, random yaw, from the seed), and
//! the robot makes `CONTACTS` contacts in all, split evenly over the sockets (at least 2
//! per socket), each with a different wrist orientation of the working cone (a working
//! orientation tilted within half the cone and spun about the approach axis). The plate's
//! tolerance (the scenario's `--tool-tol-mm`) is on the known distance only.
//!
//! Every design is scored twice per run: **absolute** errors (base frame) and
//! **registered** errors (after the best rigid motion of the validation tool points, what
//! a task that registers its targets with the calibrated robot sees). A plate cannot know
//! the base frame, so only its registered errors are its accuracy; the tools are given
//! both so the comparison is like for like.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use kincal::identify::{Contact, Distance, Group, GroupKind, Measurement, Workspace};
use kincal::montecarlo::{Acquisition, Scenario};
use kincal::plate_study::{
    BothErrors, PlateDesign, RegistrationScratch, check_design, plate_run, tool_run_both,
};
use kincal::pose::{Transform, rotation_exp, transform};
use kincal::rng::SplitMix64;
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::error::CliError;
use kincal_io::design::context::{Context, P};
use kincal_io::design::designs::Design;
use kincal_io::design::study::{DesignResult, Summary, prepare_design};

/// Workspace of the plate identification: the design capacity plus the tool translation
/// and the base frame the analysis sets aside.
const PLATE_P: usize = P + 16;

/// A plate as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct PlateSpec {
    pub name: String,
    pub distance_mm: f64,
    pub placements: usize,
    pub contacts: usize,
}

/// Parses `NAME=D_MM,PLACEMENTS,CONTACTS`.
pub fn parse_plate(arg: &str) -> Result<PlateSpec, CliError> {
    let bad = |why: &str| {
        CliError::usage(format!(
            "--plate '{arg}': {why} (expected NAME=D_MM,PLACEMENTS,CONTACTS, e.g. mukca=50,1,10)"
        ))
    };
    let (name, rest) = arg
        .split_once('=')
        .filter(|(n, _)| !n.trim().is_empty())
        .ok_or_else(|| bad("no NAME="))?;
    let parts: Vec<&str> = rest.split(',').map(str::trim).collect();
    let [d, s, c] = parts.as_slice() else {
        return Err(bad("expected three values after '='"));
    };
    let distance_mm: f64 = d
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| bad("D_MM must be a positive number"))?;
    let placements: usize = s
        .parse()
        .ok()
        .filter(|v| *v >= 1)
        .ok_or_else(|| bad("PLACEMENTS must be a whole number >= 1"))?;
    let contacts: usize = c
        .parse()
        .map_err(|_| bad("CONTACTS must be a whole number"))?;
    if contacts < 4 * placements {
        return Err(bad(&format!(
            "{contacts} contacts over {placements} placements leave a socket fewer than 2 (need CONTACTS >= 4 x PLACEMENTS)"
        )));
    }
    Ok(PlateSpec {
        name: name.trim().to_string(),
        distance_mm,
        placements,
        contacts,
    })
}

/// A plate design with the data it borrows to the core.
#[derive(Debug, Clone)]
pub struct Plate<const N: usize> {
    pub spec: PlateSpec,
    pub q: Vec<[f64; N]>,
    pub reference: Vec<Transform>,
    pub groups: Vec<Group>,
    pub distances: Vec<Distance>,
    pub note: String,
}

impl<const N: usize> Plate<N> {
    pub fn core(&self) -> PlateDesign<'_, N> {
        PlateDesign {
            q: &self.q,
            reference: &self.reference,
            groups: &self.groups,
            distances: &self.distances,
        }
    }
}

/// Attempts to find one reachable wrist orientation at a socket.
const ORIENTATION_ATTEMPTS: usize = 100;

/// Builds plate `spec` in the working region of `ctx` (deterministic from the seed and the
/// plate's name, so adding a plate does not move the others).
///
/// Every contact is reached within the joint limits by `robust` random robots of `study`
/// (as the tools' poses), so runs do not fail on unreachable contacts.
pub fn build_plate<const N: usize>(
    ctx: &Context<N>,
    spec: &PlateSpec,
    study: &kincal::montecarlo::Study<'_, N>,
    robust: u64,
) -> Result<Plate<N>, CliError> {
    let name_hash = spec.name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    let root = SplitMix64::new(ctx.seed ^ 0x0050_C4E7_u64).fork(name_hash);
    let c = ctx.local_constraints(0.0);
    let half_tilt = 0.5 * ctx.cone.half_angle_rad;
    let sockets = 2 * spec.placements;
    let mut plate = Plate {
        spec: spec.clone(),
        q: Vec::with_capacity(spec.contacts),
        reference: Vec::with_capacity(spec.contacts),
        groups: Vec::with_capacity(sockets),
        distances: Vec::with_capacity(spec.placements),
        note: String::new(),
    };
    for s in 0..spec.placements {
        let mut rng = root.fork(s as u64);
        let placed = (0..PLACEMENT_ATTEMPTS)
            .find_map(|_| {
                let reach = Reach { study, robust, half_tilt };
                place(ctx, &c, spec, &mut rng, plate.groups.len(), &reach)
            })
            .ok_or_else(|| {
                CliError::numeric(format!(
                    "plate {}: placement {} found no position in the working region where both sockets are reachable ({PLACEMENT_ATTEMPTS} tries, {ORIENTATION_ATTEMPTS} wrist orientations each)",
                    spec.name,
                    s + 1
                ))
            })?;
        let first = plate.groups.len();
        for (n, (q, t)) in placed {
            let start = plate.q.len();
            plate.groups.push(Group {
                kind: GroupKind::Target,
                start,
                len: n,
            });
            for (qk, tk) in q.into_iter().zip(t) {
                plate.q.push(qk);
                plate.reference.push(tk);
            }
        }
        let (a, b) = (first, first + 1);
        // The drawing's distance, exactly as the sockets were placed.
        let drawn = (plate.reference[plate.groups[b].start].translation.vector
            - plate.reference[plate.groups[a].start].translation.vector)
            .norm();
        plate.distances.push(Distance {
            a,
            b,
            m: drawn,
            // Only the distances carry the scale; their weight only trades them against
            // each other (all equal here).
            weight: 1.0,
        });
    }
    check_design(&plate.core())
        .map_err(|e| CliError::numeric(format!("plate {}: {e}", spec.name)))?;
    plate.note = format!(
        "socket plate: 2 sockets {} mm apart at unknown positions, {} placement(s) in the working region, {} contacts ({} per socket or one more), known distance only (tolerance as --tool-tol-mm)",
        spec.distance_mm,
        spec.placements,
        spec.contacts,
        spec.contacts / sockets
    );
    Ok(plate)
}

/// How contacts must be reachable.
struct Reach<'s, 'a, const N: usize> {
    study: &'s kincal::montecarlo::Study<'a, N>,
    robust: u64,
    half_tilt: f64,
}

/// Tries of a placement (centre and yaw) before giving up.
const PLACEMENT_ATTEMPTS: usize = 50;

/// Sockets of one placement: per socket, its contact count and contacts.
type Placed<const N: usize> = [(usize, (Vec<[f64; N]>, Vec<Transform>)); 2];

/// One try of a placement: a random centre (both sockets inside the region) and yaw, and
/// the contacts of both sockets; `None` when a socket has no reachable orientation.
fn place<const N: usize>(
    ctx: &Context<N>,
    c: &kincal::selection::Constraints,
    spec: &PlateSpec,
    rng: &mut SplitMix64,
    first_group: usize,
    reach: &Reach<'_, '_, N>,
) -> Option<Placed<N>> {
    let d = spec.distance_mm * 1e-3;
    let (lo, hi) = (ctx.region.min_m, ctx.region.max_m);
    let sockets = 2 * spec.placements;
    let yaw = rng.range(0.0, std::f64::consts::PI);
    let u = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
    // Both sockets inside the region: the centre keeps half the span from each side.
    let mut pick = |k: usize, half: f64| {
        let (a, b) = (lo[k] + half, hi[k] - half);
        if a < b {
            rng.range(a, b)
        } else {
            0.5 * (lo[k] + hi[k])
        }
    };
    let centre = Vector3::new(
        pick(0, 0.5 * d * u.x.abs()),
        pick(1, 0.5 * d * u.y.abs()),
        pick(2, 0.0),
    );
    let mut out: Placed<N> = [(0, (Vec::new(), Vec::new())), (0, (Vec::new(), Vec::new()))];
    for (i, (side, slot)) in [-0.5, 0.5].into_iter().zip(out.iter_mut()).enumerate() {
        let g = first_group + i;
        let socket = centre + u * (side * d);
        let n = spec.contacts / sockets + usize::from(g < spec.contacts % sockets);
        slot.0 = n;
        for k in 0..n {
            let (q, t) = reachable_contact(ctx, c, rng, socket, k, reach)?;
            slot.1.0.push(q);
            slot.1.1.push(t);
        }
    }
    Some(out)
}

/// Contact `k` at `socket`: a working orientation (cycled), tilted at random within
/// `half_tilt` and spun about its approach axis, reachable by the nominal robot under `c`.
fn reachable_contact<const N: usize>(
    ctx: &Context<N>,
    c: &kincal::selection::Constraints,
    rng: &mut SplitMix64,
    socket: Vector3<f64>,
    k: usize,
    reach: &Reach<'_, '_, N>,
) -> Option<([f64; N], Transform)> {
    let half_tilt = reach.half_tilt;
    let w = ctx.working.get(k % ctx.working.len().max(1))?;
    for _ in 0..ORIENTATION_ATTEMPTS {
        let tilt = Vector3::new(rng.normal(), rng.normal(), 0.0);
        let tilt = if tilt.norm() > 0.0 {
            tilt * (rng.range(0.0, half_tilt) / tilt.norm())
        } else {
            tilt
        };
        let spin = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        let r = rotation_exp(&tilt) * w * kincal::pose::rot_z(spin);
        let t = transform(r, socket);
        if let Some(q) = ctx.nominal_ik(&t, c) {
            let robust = kincal::montecarlo::robustly_reachable(reach.study, &t, &q, reach.robust);
            if robust.unwrap_or(false) {
                return Some((q, t));
            }
        }
    }
    None
}

/// What kind of design a row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Tool,
    Instrument,
    Plate,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Tool => "known-pose tool",
            Kind::Instrument => "instrument",
            Kind::Plate => "socket plate",
        }
    }
}

/// The outcome of one design: per successful run, mm and degrees.
#[derive(Debug, Clone)]
pub struct Row {
    pub name: String,
    pub kind: Kind,
    pub contacts: usize,
    pub placements: usize,
    pub distance_mm: Option<f64>,
    pub runs: u64,
    pub failed: u64,
    pub first_failure: Option<String>,
    pub abs_pos_mm: Vec<f64>,
    pub abs_rot_deg: Vec<f64>,
    pub reg_pos_mm: Vec<f64>,
    pub reg_rot_deg: Vec<f64>,
}

impl Row {
    fn new(name: &str, kind: Kind, contacts: usize, runs: u64) -> Row {
        Row {
            name: name.to_string(),
            kind,
            contacts,
            placements: 0,
            distance_mm: None,
            runs,
            failed: 0,
            first_failure: None,
            abs_pos_mm: Vec::new(),
            abs_rot_deg: Vec::new(),
            reg_pos_mm: Vec::new(),
            reg_rot_deg: Vec::new(),
        }
    }
    fn collect(&mut self, results: Vec<Result<BothErrors, kincal::Error>>) {
        for (run, r) in results.into_iter().enumerate() {
            match r {
                Ok(e) => {
                    self.abs_pos_mm.push(e.absolute.max_pos_m * 1e3);
                    self.abs_rot_deg.push(e.absolute.max_rot_rad.to_degrees());
                    self.reg_pos_mm.push(e.registered.max_pos_m * 1e3);
                    self.reg_rot_deg.push(e.registered.max_rot_rad.to_degrees());
                }
                Err(e) => {
                    self.failed += 1;
                    if self.first_failure.is_none() {
                        self.first_failure = Some(format!("run {run}: {e}"));
                    }
                }
            }
        }
    }
    /// The registered figures as a [`DesignResult`] (for the box-plot figure).
    pub fn registered_result(&self) -> DesignResult {
        DesignResult {
            name: self.name.clone(),
            acquisition: Acquisition::Tool,
            poses: self.contacts,
            o: 0.0,
            runs: self.runs,
            failed: self.failed,
            first_failure: self.first_failure.clone(),
            max_pos_mm: self.reg_pos_mm.clone(),
            max_rot_deg: self.reg_rot_deg.clone(),
            rms_pos_mm: Vec::new(),
            rms_rot_deg: Vec::new(),
            before_pos_mm: Vec::new(),
            before_rot_deg: Vec::new(),
            mean_iterations: 0.0,
            seconds: 0.0,
        }
    }
}

fn registration_buffers(nv: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<f64>) {
    (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv], vec![0.0; nv])
}

/// Runs `runs` calibrations of every tool design and every plate on the same robots, in
/// parallel, with a progress bar. Returns the rows and the wall time.
pub fn compare<const N: usize>(
    ctx: &Context<N>,
    designs: &[Design<N>],
    plates: &[Plate<N>],
    scenario: Scenario,
    runs: u64,
) -> Result<(Vec<Row>, f64), CliError> {
    let study = kincal::montecarlo::Study {
        validation_nominal: &[],
        ..ctx.study(scenario, ctx.seed)
    };
    let nv = ctx.validation_q.len();
    let total = runs * (designs.len() + plates.len()) as u64;
    let pb = crate::progress::counter(total, "plate comparison: calibrations");
    let t0 = Instant::now();
    let mut rows = Vec::new();
    for d in designs {
        let core = d.core();
        let empty = Measurement::new([0.0; N], Transform::identity());
        let analysis = prepare_design(&study, d)?;
        let results: Vec<_> = (0..runs as usize)
            .into_par_iter()
            .with_min_len(8)
            .map_init(
                || {
                    (
                        Box::<Workspace<P>>::default(),
                        vec![empty; d.q.len()],
                        registration_buffers(nv),
                    )
                },
                |(ws, data, (a, b, w)), run| {
                    let mut scratch = RegistrationScratch {
                        model: a,
                        truth: b,
                        weight: w,
                    };
                    let r =
                        tool_run_both(&study, &core, &analysis, run as u64, ws, data, &mut scratch);
                    pb.inc(1);
                    r
                },
            )
            .collect();
        let kind = match d.acquisition {
            Acquisition::Tool => Kind::Tool,
            Acquisition::Instrument => Kind::Instrument,
        };
        let mut row = Row::new(&d.name, kind, d.q.len(), runs);
        row.collect(results);
        rows.push(row);
    }
    for p in plates {
        let core = p.core();
        let m = p.q.len();
        let results: Vec<_> = (0..runs as usize)
            .into_par_iter()
            .with_min_len(4)
            .map_init(
                || {
                    (
                        Box::<Workspace<PLATE_P>>::default(),
                        vec![Contact::new([0.0; N]); m],
                        registration_buffers(nv),
                    )
                },
                |(ws, contacts, (a, b, w)), run| {
                    let mut scratch = RegistrationScratch {
                        model: a,
                        truth: b,
                        weight: w,
                    };
                    let r = plate_run(&study, &core, run as u64, ws, contacts, &mut scratch);
                    pb.inc(1);
                    r
                },
            )
            .collect();
        let mut row = Row::new(&p.spec.name, Kind::Plate, m, runs);
        row.placements = p.spec.placements;
        row.distance_mm = Some(p.spec.distance_mm);
        row.collect(results);
        rows.push(row);
    }
    pb.finish_and_clear();
    Ok((rows, t0.elapsed().as_secs_f64()))
}

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
    let Some(tool) = rows.iter().find(|r| r.name == reference) else {
        let _ = writeln!(s, "  (no design named '{reference}' to match)");
        return s;
    };
    let t = Summary::of(&tool.reg_pos_mm);
    let _ = writeln!(
        s,
        "  reference {}: registered e_p median {:.3} mm, p95 {:.3} mm",
        tool.name, t.median, t.p95
    );
    let mut fewest: Vec<(f64, usize, usize, String)> = Vec::new();
    for r in rows.iter().filter(|r| r.kind == Kind::Plate) {
        let p = Summary::of(&r.reg_pos_mm);
        let ok = r.failed == 0 && p.median <= t.median && p.p95 <= t.p95;
        let _ = writeln!(
            s,
            "  {}: {} ({} contacts, {} placements; registered e_p {:.3}/{:.3} mm vs {:.3}/{:.3} mm){}",
            r.name,
            if ok { "matches" } else { "does NOT match" },
            r.contacts,
            r.placements,
            p.median,
            p.p95,
            t.median,
            t.p95,
            if r.failed > 0 {
                format!("; {} runs failed", r.failed)
            } else {
                String::new()
            }
        );
        let d = r.distance_mm.unwrap_or(0.0);
        if ok {
            match fewest.iter_mut().find(|f| f.0 == d) {
                Some(f) if f.1 <= r.contacts => {}
                Some(f) => *f = (d, r.contacts, r.placements, r.name.clone()),
                None => fewest.push((d, r.contacts, r.placements, r.name.clone())),
            }
        }
    }
    for (d, c, p, n) in &fewest {
        let _ = writeln!(
            s,
            "  fewest contacts that match with a {d} mm plate: {c} ({p} placements, {n})"
        );
    }
    let _ = writeln!(
        s,
        "  what a plate cannot identify: the base frame (absolute errors keep it), lengths other than through the known distance (its tolerance scales the arm), the tool orientation (a ball is a point: reg e_φ keeps the random robot's last twist)"
    );
    s
}

/// The rows as JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    let sj = |v: &[f64]| {
        let s = Summary::of(v);
        serde_json::json!({"median": s.median, "p95": s.p95, "max": s.max, "mean": s.mean})
    };
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "name": r.name,
                    "kind": r.kind.name(),
                    "contacts": r.contacts,
                    "placements": r.placements,
                    "distance_mm": r.distance_mm,
                    "runs": r.runs,
                    "failed": r.failed,
                    "first_failure": r.first_failure,
                    "absolute_worst_pose_e_p_mm": sj(&r.abs_pos_mm),
                    "absolute_worst_pose_e_phi_deg": sj(&r.abs_rot_deg),
                    "registered_worst_pose_e_p_mm": sj(&r.reg_pos_mm),
                    "registered_worst_pose_e_phi_deg": sj(&r.reg_rot_deg),
                })
            })
            .collect(),
    )
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plate_specs_parse_and_refuse_bad_input() {
        assert_eq!(
            parse_plate("mukca=50,1,10").unwrap(),
            PlateSpec {
                name: "mukca".into(),
                distance_mm: 50.0,
                placements: 1,
                contacts: 10
            }
        );
        for bad in [
            "=50,1,10",
            "x=50,1",
            "x=-5,1,10",
            "x=50,0,10",
            "x=50,3,11",
            "x=a,1,10",
        ] {
            let e = parse_plate(bad).unwrap_err();
            assert_eq!(e.kind, crate::error::Exit::Usage, "{bad}");
        }
    }
}
