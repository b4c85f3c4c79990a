//! Socket plates against known-pose tools (issue #13 item 6), on the same random robots
//! ([`kincal::plate_study`]): the run of `kincal evaluate-designs --plate` and of
//! `kincal.evaluate_designs(..., plates=...)`, as data.
//!
//! A plate `NAME=D_MM,PLACEMENTS,CONTACTS` has two ball sockets `D_MM` apart (MUKCa: 50 mm)
//! at positions nobody measures; it is placed `PLACEMENTS` times in the working region
//! (centre uniform in the region with both sockets inside, random yaw, from the seed), and
//! the robot makes `CONTACTS` contacts in all, split evenly over the sockets (at least 2
//! per socket), each with a different wrist orientation of the working cone (a working
//! orientation tilted within half the cone and spun about the approach axis). The plate's
//! tolerance (the scenario's tool tolerance in position) is on the known distance only.
//!
//! Every design is scored twice per run: **absolute** errors (base frame) and
//! **registered** errors (after the best rigid motion of the validation tool points, what
//! a task that registers its targets with the calibrated robot sees). A plate cannot know
//! the base frame, so only its registered errors are its accuracy; the tools are given
//! both so the comparison is like for like. Front ends word the results
//! ([`Row`], [`Matching`], [`json`]); nothing here prints.

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

use crate::design::Progress;
use crate::design::context::{Context, P};
use crate::design::designs::Design;
use crate::design::study::{Summary, prepare_design};
use crate::error::Error;

/// Workspace of the plate identification: the design capacity plus the tool translation
/// and the base frame the analysis sets aside.
const PLATE_P: usize = P + 16;

/// A plate: its name, the distance of its two sockets \[mm\], how often it is placed and
/// how many contacts the robot makes in all.
#[derive(Debug, Clone, PartialEq)]
pub struct PlateSpec {
    pub name: String,
    pub distance_mm: f64,
    pub placements: usize,
    pub contacts: usize,
}

const BAD_NAME: &str = "no NAME=";
const BAD_DISTANCE: &str = "D_MM must be a positive number";
const BAD_PLACEMENTS: &str = "PLACEMENTS must be a whole number >= 1";

impl PlateSpec {
    /// The plate `name` (trimmed), checked: the plate, or why it cannot be built
    /// ([`PlateSpec::problem`]). One check for the CLI's `--plate` and Python's `plates`.
    pub fn checked(
        name: &str,
        distance_mm: f64,
        placements: usize,
        contacts: usize,
    ) -> Result<PlateSpec, String> {
        let spec = PlateSpec {
            name: name.trim().to_string(),
            distance_mm,
            placements,
            contacts,
        };
        match spec.problem() {
            Some(why) => Err(why),
            None => Ok(spec),
        }
    }

    /// Why the plate cannot be built, if it cannot: an empty name, a distance not finite
    /// and > 0, no placement, fewer than 2 contacts per socket.
    pub fn problem(&self) -> Option<String> {
        if self.name.trim().is_empty() {
            Some(BAD_NAME.into())
        } else if !(self.distance_mm.is_finite() && self.distance_mm > 0.0) {
            Some(BAD_DISTANCE.into())
        } else if self.placements < 1 {
            Some(BAD_PLACEMENTS.into())
        } else if self.contacts < 4 * self.placements {
            Some(format!(
                "{} contacts over {} placements leave a socket fewer than 2 (need CONTACTS >= 4 x PLACEMENTS)",
                self.contacts, self.placements
            ))
        } else {
            None
        }
    }
}

/// Parses `NAME=D_MM,PLACEMENTS,CONTACTS` (the value of `--plate`); a usage error naming
/// the flag and the value otherwise.
pub fn parse_plate(arg: &str) -> Result<PlateSpec, Error> {
    let bad = |why: &str| {
        Error::usage(format!(
            "--plate '{arg}': {why} (expected NAME=D_MM,PLACEMENTS,CONTACTS, e.g. mukca=50,1,10)"
        ))
    };
    let (name, rest) = arg
        .split_once('=')
        .filter(|(n, _)| !n.trim().is_empty())
        .ok_or_else(|| bad(BAD_NAME))?;
    let parts: Vec<&str> = rest.split(',').map(str::trim).collect();
    let [d, s, c] = parts.as_slice() else {
        return Err(bad("expected three values after '='"));
    };
    let distance_mm: f64 = d
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| bad(BAD_DISTANCE))?;
    let placements: usize = s
        .parse()
        .ok()
        .filter(|v| *v >= 1)
        .ok_or_else(|| bad(BAD_PLACEMENTS))?;
    let contacts: usize = c
        .parse()
        .map_err(|_| bad("CONTACTS must be a whole number"))?;
    PlateSpec::checked(name, distance_mm, placements, contacts).map_err(|why| bad(&why))
}

/// A plate design with the data it borrows to the core.
#[derive(Debug, Clone)]
pub struct Plate<const N: usize> {
    pub spec: PlateSpec,
    /// Nominal configurations of the contacts \[rad\].
    pub q: Vec<[f64; N]>,
    /// Drawing pose of each contact \[m\]: the socket's position, the wrist orientation.
    pub reference: Vec<Transform>,
    /// One target group per socket and placement.
    pub groups: Vec<Group>,
    /// The known distance of each placement \[m\].
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
) -> Result<Plate<N>, Error> {
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
                Error::numeric(format!(
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
    check_design(&plate.core()).map_err(|e| Error::numeric(format!("plate {}: {e}", spec.name)))?;
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

/// Builds the plates `specs` (each as [`build_plate`], every contact robustly reachable by
/// `robust` random robots of `scenario`), one progress step per plate. Their names must
/// differ from each other and from `designs`' (else a usage error naming `flag`).
pub fn build_plates<const N: usize>(
    ctx: &Context<N>,
    specs: &[PlateSpec],
    designs: &[Design<N>],
    (scenario, robust): (Scenario, u64),
    flag: &str,
    pb: &dyn Progress,
) -> Result<Vec<Plate<N>>, Error> {
    let probe = ctx.study(scenario, ctx.seed);
    // Robustly reachable contacts take a while for large plates: a step per plate.
    pb.stage(
        specs.len() as u64,
        "socket plates: robustly reachable contacts",
    );
    let plates = specs
        .iter()
        .map(|spec| {
            let plate = build_plate(ctx, spec, &probe, robust);
            pb.inc(1);
            plate
        })
        .collect::<Result<Vec<_>, _>>()?;
    for (i, p) in plates.iter().enumerate() {
        let name = &p.spec.name;
        let clash = designs.iter().any(|d| &d.name == name)
            || plates[..i].iter().any(|o| &o.spec.name == name);
        if clash {
            return Err(Error::usage(format!(
                "{flag}: two designs are named '{name}'"
            )));
        }
    }
    Ok(plates)
}

/// What kind of design a row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Tool,
    Instrument,
    Plate,
}

impl Kind {
    /// As in `--json`: `known-pose tool`, `instrument`, `socket plate`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Tool => "known-pose tool",
            Kind::Instrument => "instrument",
            Kind::Plate => "socket plate",
        }
    }
}

/// The outcome of one design: per successful run (in run order) its worst validation pose,
/// in mm and degrees.
#[derive(Debug, Clone)]
pub struct Row {
    pub name: String,
    pub kind: Kind,
    /// Contacts of a plate, poses of a tool.
    pub contacts: usize,
    /// 0 for a tool.
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
}

fn registration_buffers(nv: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<f64>) {
    (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv], vec![0.0; nv])
}

/// The rows of a comparison and its wall time \[s\].
#[derive(Debug, Clone)]
pub struct Comparison {
    pub rows: Vec<Row>,
    pub wall_s: f64,
}

/// Runs `runs` calibrations of every design and every plate on the same robots, in
/// parallel, one progress step per calibration. Rows: the designs, then the plates.
pub fn compare<const N: usize>(
    ctx: &Context<N>,
    designs: &[Design<N>],
    plates: &[Plate<N>],
    scenario: Scenario,
    runs: u64,
    pb: &dyn Progress,
) -> Result<Comparison, Error> {
    let study = kincal::montecarlo::Study {
        validation_nominal: &[],
        ..ctx.study(scenario, ctx.seed)
    };
    let nv = ctx.validation_q.len();
    pb.stage(
        runs * (designs.len() + plates.len()) as u64,
        "plate comparison: calibrations",
    );
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
    Ok(Comparison {
        rows,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// The design the plates must match when none is named: `optimised` if there is one, else
/// `table2`.
pub fn default_reference<const N: usize>(designs: &[Design<N>]) -> String {
    if designs.iter().any(|d| d.name == "optimised") {
        "optimised".into()
    } else {
        "table2".into()
    }
}

/// A plate against the reference: its registered worst-pose e_p \[mm\] and whether it
/// matches (every run converged, median and p95 at most the reference's).
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    pub name: String,
    pub contacts: usize,
    pub placements: usize,
    pub failed: u64,
    pub registered_e_p_mm: Summary,
    pub matches: bool,
}

/// The fewest contacts of a plate of one distance that match.
#[derive(Debug, Clone, PartialEq)]
pub struct Fewest {
    pub distance_mm: f64,
    pub contacts: usize,
    pub placements: usize,
    pub name: String,
}

/// Which plates match the reference design's registered e_p (median and p95, mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Matching {
    pub reference: String,
    pub reference_e_p_mm: Summary,
    /// Every plate, in row order.
    pub plates: Vec<Verdict>,
    /// Per plate distance (in order of the first match), the fewest contacts that match.
    pub fewest: Vec<Fewest>,
}

/// The plates of `rows` against the row named `reference`; `None` without such a row.
pub fn matching(rows: &[Row], reference: &str) -> Option<Matching> {
    let tool = rows.iter().find(|r| r.name == reference)?;
    let t = Summary::of(&tool.reg_pos_mm);
    let mut plates = Vec::new();
    let mut fewest: Vec<Fewest> = Vec::new();
    for r in rows.iter().filter(|r| r.kind == Kind::Plate) {
        let p = Summary::of(&r.reg_pos_mm);
        let ok = r.failed == 0 && p.median <= t.median && p.p95 <= t.p95;
        plates.push(Verdict {
            name: r.name.clone(),
            contacts: r.contacts,
            placements: r.placements,
            failed: r.failed,
            registered_e_p_mm: p,
            matches: ok,
        });
        let d = r.distance_mm.unwrap_or(0.0);
        if ok {
            let new = Fewest {
                distance_mm: d,
                contacts: r.contacts,
                placements: r.placements,
                name: r.name.clone(),
            };
            match fewest.iter_mut().find(|f| f.distance_mm == d) {
                Some(f) if f.contacts <= r.contacts => {}
                Some(f) => *f = new,
                None => fewest.push(new),
            }
        }
    }
    Some(Matching {
        reference: tool.name.clone(),
        reference_e_p_mm: t,
        plates,
        fewest,
    })
}

/// The rows as JSON: the `plates` array of `kincal evaluate-designs --json`.
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
            "x=50,1,b",
        ] {
            let e = parse_plate(bad).unwrap_err();
            assert_eq!(e.kind, crate::Kind::Usage, "{bad}");
            assert!(e.message.starts_with(&format!("--plate '{bad}': ")), "{e}");
        }
        let spec = |d: f64, s: usize, c: usize| PlateSpec {
            name: "p".into(),
            distance_mm: d,
            placements: s,
            contacts: c,
        };
        assert_eq!(spec(50.0, 2, 8).problem(), None);
        assert_eq!(
            spec(f64::NAN, 2, 8).problem().as_deref(),
            Some(BAD_DISTANCE)
        );
        assert_eq!(spec(50.0, 0, 8).problem().as_deref(), Some(BAD_PLACEMENTS));
        assert!(spec(50.0, 2, 7).problem().unwrap().contains("fewer than 2"));
    }

    fn row(name: &str, kind: Kind, contacts: usize, d: Option<f64>, reg: &[f64]) -> Row {
        let mut r = Row::new(name, kind, contacts, reg.len() as u64);
        r.distance_mm = d;
        r.reg_pos_mm = reg.to_vec();
        r
    }

    #[test]
    fn a_plate_matches_when_median_and_p95_are_no_worse_and_no_run_failed() {
        let tool = row("optimised", Kind::Tool, 10, None, &[1.0, 2.0, 3.0]);
        let rows = vec![
            tool,
            // Median 2, p95 3: equal counts as matching.
            row("a", Kind::Plate, 80, Some(200.0), &[3.0, 2.0, 1.0]),
            // Fewer contacts, also matching: the fewest at 200 mm.
            row("b", Kind::Plate, 40, Some(200.0), &[0.5, 0.5, 0.5]),
            // p95 worse.
            row("c", Kind::Plate, 20, Some(200.0), &[0.1, 0.1, 3.5]),
            // Better figures, but a failed run.
            row("d", Kind::Plate, 20, Some(50.0), &[0.1, 0.1, 0.1]),
        ];
        let mut rows = rows;
        rows[4].failed = 1;
        let m = matching(&rows, "optimised").unwrap();
        assert_eq!(m.reference_e_p_mm.median, 2.0);
        let ok: Vec<bool> = m.plates.iter().map(|v| v.matches).collect();
        assert_eq!(ok, [true, true, false, false]);
        assert_eq!(m.fewest.len(), 1);
        assert_eq!((m.fewest[0].contacts, m.fewest[0].name.as_str()), (40, "b"));
        assert!(matching(&rows, "nosuch").is_none());
    }
}
