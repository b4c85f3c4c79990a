//! Instrument-free calibration from C (issue #13, `docs/constraints.md`): rows that hold the
//! tool point at a target or on a plane, optional partial coordinates, known targets, planes
//! and distances, sessions. A thin shell over `kincal::identify::identify_constrained`: the
//! rows are checked (every refusal names the row in `kincal_error.pose`), grouped into the
//! core's contiguous groups inside the caller's workspace (a counting sort: no heap), and
//! identified; the report adds the gauge (what the data cannot see at all) and every
//! target's, plane's and distance's estimate at the identified model.
//!
//! Sessions: one set-up of the robot (a placement of the plate). Each target and plane
//! belongs to one session, a session holds at least `KINCAL_MIN_SESSION_ROWS` rows, and
//! instrument rows lie in one session (a frame per session, `kincal::identify::InstrumentSession`,
//! is not in the C ABI yet); sessions change nothing else. These rules are the core's
//! (`kincal::identify::check_sessions`), the same the CSV reader applies.

use core::ffi::{CStr, c_void};

use kincal::identify::{
    ComponentMask, ConstraintData, Contact, Distance, Group, GroupKind, Measurement, RowRole,
    SessionFault, SessionLayout, SessionScratch, Workspace, check_sessions, distance_estimate,
    group_estimate, identify_constrained,
};
use kincal::pose::Transform;
use kincal::{Error, Robot, with_any_robot};

use crate::identify::{
    KINCAL_WORKSPACE_ALIGN, capacity_for, kincal_identify_options, kincal_identify_report, mask_of,
    options, report_of, round_up,
};
use crate::kinematics::{DATA_AUX, joint_state, kincal_joint_aux};
use crate::robot::{KINCAL_MAX_PARAMS, from_robot, kincal_robot, to_any};
use crate::status::{FfiResult, KINCAL_NO_INDEX, kincal_error, kincal_status};

/// "No target / no plane" in `kincal_constraint_data.target` and `.plane`.
pub const KINCAL_NO_GROUP: u32 = 0xFFFF_FFFF;

/// A session needs at least this many rows (as `kincal calibrate`): fewer fix nothing a
/// set-up adds.
pub const KINCAL_MIN_SESSION_ROWS: usize = 3;

/// Plane contacts whose spread across their best-fit line, at the starting model, is below
/// this fraction of their extent along it are collinear (`KINCAL_STATUS_DEGENERATE_GROUP`):
/// the plane's tilt about that line is undetermined. The CLI's threshold.
pub const KINCAL_PLANE_MIN_ASPECT: f64 = 0.1;
// The header needs literals (cbindgen); the values are core's, checked at compile time.
const _: () = assert!(KINCAL_PLANE_MIN_ASPECT == kincal::identify::USABLE_PLANE_MIN_ASPECT);
const _: () = assert!(KINCAL_MIN_SESSION_ROWS == kincal::identify::MIN_SESSION_ROWS);

/// A target of `kincal_constraint_data`: unknown (3 nuisance coordinates, eliminated) or
/// known in the base frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_target {
    /// Non-zero: the target's position is known (`xyz_m`, an external reference).
    pub known: u32,
    /// Known position in the base frame [m] (ignored when not known).
    pub xyz_m: [f64; 3],
}

/// A plane of `kincal_constraint_data`: unknown or known as `normal·p = offset_m`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_plane {
    /// Non-zero: the plane is known (`normal`, `offset_m`).
    pub known: u32,
    /// Normal in the base frame (any non-zero length).
    pub normal: [f64; 3],
    /// `normal·p` on the plane with the normal normalised [m].
    pub offset_m: f64,
}

/// A known distance between two targets.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_distance {
    /// First target (index into the targets).
    pub a: u32,
    /// Second target (≠ `a`).
    pub b: u32,
    /// The distance [m] (> 0).
    pub m: f64,
    /// Weight relative to one position coordinate (≥ 0): 1 normally,
    /// `(σ_data/σ_distance)²` when the distance's uncertainty is known.
    pub weight: f64,
}

/// Instrument-free (or mixed) data: caller-owned arrays viewed for one call. L = `n_rows`,
/// N = the robot's joint count. Every row is exactly one of: a contact of target `target[l]`,
/// a contact of plane `plane[l]`, or an instrument row with the coordinates `coord_mask[l]`
/// of `coords`. Rows need not be sorted.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct kincal_constraint_data {
    /// Number of rows L (≥ 1).
    pub n_rows: usize,
    /// Joint readings [rad], L × N row-major; `q_len` = L·N.
    pub q: *const f64,
    /// Length of `q`.
    pub q_len: usize,
    /// Target of each row (< `n_targets`) or `KINCAL_NO_GROUP`; NULL: no target rows.
    pub target: *const u32,
    /// Length of `target` (L; ignored when NULL).
    pub target_len: usize,
    /// Plane of each row (< `n_planes`) or `KINCAL_NO_GROUP`; NULL: no plane rows.
    pub plane: *const u32,
    /// Length of `plane` (L; ignored when NULL).
    pub plane_len: usize,
    /// Session of each row (< `n_sessions`); NULL: one session.
    pub session: *const u32,
    /// Length of `session` (L; ignored when NULL).
    pub session_len: usize,
    /// Number of sessions (ignored when `session` is NULL).
    pub n_sessions: usize,
    /// Tool point of each row in the tool frame [m], L × 3 (the ball centre, the probe tip);
    /// NULL: the tool-frame origin.
    pub point: *const f64,
    /// Length of `point` (3·L; ignored when NULL).
    pub point_len: usize,
    /// Measured coordinates of the tool point in the base frame [m], L × 3 (only the
    /// components in `coord_mask` are read); NULL: no instrument rows.
    pub coords: *const f64,
    /// Length of `coords` (3·L; ignored when NULL).
    pub coords_len: usize,
    /// Measured components per row: bit k = coordinate k of `[x, y, z]` (0x7 a full point,
    /// 0x4 z only); 0 on contact rows. NULL: no instrument rows.
    pub coord_mask: *const u8,
    /// Length of `coord_mask` (L; ignored when NULL).
    pub coord_mask_len: usize,
    /// Approach directions / temperature per row, or NULL; `aux_len` = L.
    pub aux: *const kincal_joint_aux,
    /// Length of `aux` (ignored when NULL).
    pub aux_len: usize,
    /// Number of targets T; each needs rows: 2 when unknown, 1 when known.
    pub n_targets: usize,
    /// The targets (T entries), or NULL: all unknown.
    pub targets: *const kincal_target,
    /// Length of `targets` (T; ignored when NULL).
    pub targets_len: usize,
    /// Number of planes; each needs rows: 3 not collinear when unknown, 1 when known.
    pub n_planes: usize,
    /// The planes, or NULL: all unknown.
    pub planes: *const kincal_plane,
    /// Length of `planes` (`n_planes`; ignored when NULL).
    pub planes_len: usize,
    /// Number of known distances.
    pub n_distances: usize,
    /// The distances (NULL when `n_distances` is 0).
    pub distances: *const kincal_distance,
    /// Length of `distances` (`n_distances`).
    pub distances_len: usize,
}

/// What a target's or plane's contacts say at the identified model.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_group_estimate {
    /// Contacts with a positive weight.
    pub contacts: usize,
    /// Mean predicted tool point: the estimated target [m] (for planes a point on it).
    pub point: [f64; 3],
    /// Unit plane normal (zero for targets).
    pub normal: [f64; 3],
    /// Plane offset `normal·p` [m] (0 for targets).
    pub offset_m: f64,
    /// RMS residual distance of the contacts (3-D for targets, to the plane for planes) [m].
    pub rms_m: f64,
    /// Largest residual distance [m].
    pub max_m: f64,
    /// Mean residual distance [m] (MUKCa's "mean absolute consistency error").
    pub mean_m: f64,
    /// Planes: spread across the best-fit line over extent along it (0 for targets).
    pub aspect: f64,
}

/// Everything `kincal_identify_constraints` reports besides the model.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_constraints_report {
    /// The identification report (identifiability, residuals before/after over all rows,
    /// standard errors, correlations). Its residual statistics count contacts as poses:
    /// `rms_pos_m` is over targets' 3-D and planes' 1-D residuals and instrument positions.
    pub identify: kincal_identify_report,
    /// The gauge (mask by flat index): requested parameters no row can see, named rather
    /// than fixed silently: the base frame without an external reference (no instrument
    /// row, known target or plane), one length without a length reference (no distance
    /// either).
    pub gauge: [u8; KINCAL_MAX_PARAMS],
    /// Non-zero: some row refers to the base frame (instrument row, known target or plane).
    pub external_reference: u32,
    /// Non-zero: some row fixes the scale (a distance or an external reference).
    pub length_reference: u32,
    /// Instrument rows.
    pub n_instrument_rows: usize,
    /// Contact rows (target and plane rows).
    pub n_contacts: usize,
}

/// The byte layout of the workspace (offsets from its start).
#[derive(Debug, Clone, Copy)]
struct Layout {
    inst: usize,
    contacts: usize,
    groups: usize,
    distances: usize,
    row_of: usize,
    group_count: usize,
    group_first: usize,
    group_session: usize,
    session_count: usize,
    session_first: usize,
    total: usize,
}

/// Next offset for `n` values of `T` after `off` (aligned), and the offset after them.
const fn array<T>(off: usize, n: usize) -> Option<(usize, usize)> {
    let start = round_up(off, core::mem::align_of::<T>());
    match n.checked_mul(core::mem::size_of::<T>()) {
        Some(b) => match start.checked_add(b) {
            Some(end) => Some((start, end)),
            None => None,
        },
        None => None,
    }
}

fn layout<const N: usize, const P: usize>(
    rows: usize,
    groups: usize,
    distances: usize,
    sessions: usize,
) -> Option<Layout> {
    let ws = round_up(core::mem::size_of::<Workspace<P>>(), KINCAL_WORKSPACE_ALIGN);
    let (inst, e) = array::<Measurement<N>>(ws, rows)?;
    let (contacts, e) = array::<Contact<N>>(e, rows)?;
    let (groups_off, e) = array::<Group>(e, groups)?;
    let (dist, e) = array::<Distance>(e, distances)?;
    let (row_of, e) = array::<usize>(e, rows)?;
    let (group_count, e) = array::<usize>(e, groups)?;
    let (group_first, e) = array::<usize>(e, groups)?;
    let (group_session, e) = array::<usize>(e, groups)?;
    let (session_count, e) = array::<usize>(e, sessions)?;
    let (session_first, e) = array::<usize>(e, sessions)?;
    Some(Layout {
        inst,
        contacts,
        groups: groups_off,
        distances: dist,
        row_of,
        group_count,
        group_first,
        group_session,
        session_count,
        session_first,
        total: round_up(e, KINCAL_WORKSPACE_ALIGN),
    })
}

const _: () = assert!(core::mem::align_of::<Workspace<KINCAL_MAX_PARAMS>>() <= 16);
const _: () = assert!(core::mem::align_of::<Contact<9>>() <= KINCAL_WORKSPACE_ALIGN);

fn size_for<const N: usize>(
    cap: usize,
    rows: usize,
    groups: usize,
    distances: usize,
    sessions: usize,
) -> Option<usize> {
    match cap {
        32 => layout::<N, 32>(rows, groups, distances, sessions).map(|l| l.total),
        KINCAL_MAX_PARAMS => {
            layout::<N, KINCAL_MAX_PARAMS>(rows, groups, distances, sessions).map(|l| l.total)
        }
        _ => None,
    }
}

fn workspace_size(
    n_joints: usize,
    rows: usize,
    groups: usize,
    distances: usize,
    sessions: usize,
    n_requested: usize,
) -> Option<usize> {
    let cap = capacity_for(n_requested)?;
    // Without a session array all rows are one session: one counter either way.
    let (g, d, s) = (groups, distances, sessions.max(1));
    match n_joints {
        1 => size_for::<1>(cap, rows, g, d, s),
        2 => size_for::<2>(cap, rows, g, d, s),
        3 => size_for::<3>(cap, rows, g, d, s),
        4 => size_for::<4>(cap, rows, g, d, s),
        5 => size_for::<5>(cap, rows, g, d, s),
        6 => size_for::<6>(cap, rows, g, d, s),
        7 => size_for::<7>(cap, rows, g, d, s),
        8 => size_for::<8>(cap, rows, g, d, s),
        9 => size_for::<9>(cap, rows, g, d, s),
        _ => None,
    }
}

/// Bytes of caller memory `kincal_identify_constraints` needs: `n_rows` rows of an
/// `n_joints` robot with `n_targets + n_planes` groups, `n_distances` distances,
/// `n_sessions` sessions (0 without a session array) and `n_requested` requested parameters
/// (the identification workspace of capacity 32 or `KINCAL_MAX_PARAMS`, about 92 KB or
/// 1.45 MB, plus about 0.5 KB per row). Returns 0 for an invalid joint count, more than
/// `KINCAL_MAX_PARAMS` parameters, or an overflowing size.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_identify_constraints_workspace_size(
    n_joints: usize,
    n_rows: usize,
    n_targets: usize,
    n_planes: usize,
    n_distances: usize,
    n_sessions: usize,
    n_requested: usize,
) -> usize {
    ffi_boundary!(on_panic = 0; {
        n_targets
            .checked_add(n_planes)
            .and_then(|g| workspace_size(n_joints, n_rows, g, n_distances, n_sessions, n_requested))
            .unwrap_or(0)
    })
}

/// The caller's arrays, checked for NULL, alignment and length (not yet their values).
struct View<'a> {
    rows: usize,
    q: &'a [f64],
    target: Option<&'a [u32]>,
    plane: Option<&'a [u32]>,
    session: Option<&'a [u32]>,
    n_sessions: usize,
    point: Option<&'a [f64]>,
    coords: Option<&'a [f64]>,
    coord_mask: Option<&'a [u8]>,
    aux: Option<&'a [kincal_joint_aux]>,
    targets: Option<&'a [kincal_target]>,
    n_targets: usize,
    planes: Option<&'a [kincal_plane]>,
    n_planes: usize,
    distances: &'a [kincal_distance],
}

/// An error at caller row `row`.
fn at_row(e: kincal_error, row: usize) -> kincal_error {
    let mut e = e;
    e.pose = row;
    e
}

/// # Safety
/// Each non-NULL array is readable for its stated length.
unsafe fn opt_slice<'a, T>(
    p: *const T,
    len: usize,
    expected: usize,
    name: &'static CStr,
) -> FfiResult<Option<&'a [T]>> {
    if p.is_null() {
        return Ok(None);
    }
    // SAFETY: forwarded contract.
    unsafe { crate::args::slice(p, len, expected, name) }.map(Some)
}

/// # Safety
/// `data` is NULL or points to a `kincal_constraint_data` whose non-NULL arrays are readable
/// for their stated lengths.
unsafe fn view<'a>(data: *const kincal_constraint_data, n: usize) -> FfiResult<View<'a>> {
    // SAFETY: forwarded contract.
    let d = unsafe { crate::args::req(data, c"data") }?;
    let l = d.n_rows;
    if l == 0 {
        return Err(kincal_error::new(kincal_status::TooFewData)
            .arg(c"data->n_rows")
            .counts(1, 0));
    }
    let times = |k: usize, name| {
        l.checked_mul(k)
            .ok_or_else(|| crate::args::bad_length(name, KINCAL_NO_INDEX, l))
    };
    // SAFETY (all): forwarded contract; lengths checked before use.
    let q = unsafe { crate::args::slice(d.q, d.q_len, times(n, c"data->q")?, c"data->q") }?;
    crate::args::finite(q, c"data->q").map_err(|e| at_row(e, e.index / n.max(1)))?;
    let target = unsafe { opt_slice(d.target, d.target_len, l, c"data->target") }?;
    let plane = unsafe { opt_slice(d.plane, d.plane_len, l, c"data->plane") }?;
    let session = unsafe { opt_slice(d.session, d.session_len, l, c"data->session") }?;
    let point = unsafe {
        opt_slice(
            d.point,
            d.point_len,
            times(3, c"data->point")?,
            c"data->point",
        )
    }?;
    if let Some(p) = point {
        crate::args::finite(p, c"data->point").map_err(|e| at_row(e, e.index / 3))?;
    }
    let coords = unsafe {
        opt_slice(
            d.coords,
            d.coords_len,
            times(3, c"data->coords")?,
            c"data->coords",
        )
    }?;
    let coord_mask = unsafe { opt_slice(d.coord_mask, d.coord_mask_len, l, c"data->coord_mask") }?;
    if coords.is_some() != coord_mask.is_some() {
        return Err(crate::args::null(if coords.is_none() {
            c"data->coords"
        } else {
            c"data->coord_mask"
        }));
    }
    let aux = unsafe { opt_slice(d.aux, d.aux_len, l, c"data->aux") }?;
    let targets = unsafe { opt_slice(d.targets, d.targets_len, d.n_targets, c"data->targets") }?;
    let planes = unsafe { opt_slice(d.planes, d.planes_len, d.n_planes, c"data->planes") }?;
    let distances = if d.n_distances == 0 {
        &[][..]
    } else {
        unsafe {
            crate::args::slice(
                d.distances,
                d.distances_len,
                d.n_distances,
                c"data->distances",
            )
        }?
    };
    Ok(View {
        rows: l,
        q,
        target,
        plane,
        session,
        n_sessions: if d.session.is_null() { 1 } else { d.n_sessions },
        point,
        coords,
        coord_mask,
        aux,
        targets,
        n_targets: d.n_targets,
        planes,
        n_planes: d.n_planes,
        distances,
    })
}

/// What a row is.
#[derive(Clone, Copy)]
enum RowKind {
    /// A contact of group g (targets first, then planes).
    Contact(usize),
    /// An instrument row with this component mask.
    Instrument(u8),
}

impl View<'_> {
    fn n_groups(&self) -> usize {
        self.n_targets + self.n_planes
    }

    fn session_of(&self, l: usize) -> u32 {
        self.session.and_then(|s| s.get(l).copied()).unwrap_or(0)
    }

    /// The kind of row `l`, or an error naming it.
    fn kind(&self, l: usize) -> FfiResult<RowKind> {
        let get = |a: Option<&[u32]>| {
            a.and_then(|a| a.get(l).copied())
                .filter(|&v| v != KINCAL_NO_GROUP)
        };
        let mask = self.coord_mask.and_then(|m| m.get(l).copied()).unwrap_or(0);
        let bad = |name: &'static CStr, v: f64| {
            at_row(
                kincal_error::new(kincal_status::InvalidArgument)
                    .arg(name)
                    .at(l)
                    .value(v),
                l,
            )
        };
        if mask & !0x7 != 0 {
            return Err(bad(c"data->coord_mask", f64::from(mask)));
        }
        let out_of_range = |name: &'static CStr, v: u32, count: usize| {
            at_row(
                kincal_error::new(kincal_status::IndexOutOfRange)
                    .arg(name)
                    .at(l)
                    .counts(count, v as usize)
                    .value(f64::from(v)),
                l,
            )
        };
        match (get(self.target), get(self.plane)) {
            (Some(t), Some(_)) => Err(bad(c"data->plane", f64::from(t))),
            (Some(_), None) | (None, Some(_)) if mask != 0 => {
                // A pose (coordinates) and a target or plane on one row.
                Err(bad(c"data->coord_mask", f64::from(mask)))
            }
            (Some(t), None) => {
                if t as usize >= self.n_targets {
                    return Err(out_of_range(c"data->target", t, self.n_targets));
                }
                Ok(RowKind::Contact(t as usize))
            }
            (None, Some(p)) => {
                if p as usize >= self.n_planes {
                    return Err(out_of_range(c"data->plane", p, self.n_planes));
                }
                Ok(RowKind::Contact(self.n_targets + p as usize))
            }
            (None, None) if mask == 0 => {
                // The row measures nothing.
                Err(bad(c"data->coord_mask", 0.0))
            }
            (None, None) => Ok(RowKind::Instrument(mask)),
        }
    }

    fn group_kind(&self, g: usize) -> FfiResult<GroupKind> {
        if g < self.n_targets {
            match self.targets.and_then(|t| t.get(g)) {
                Some(t) if t.known != 0 => {
                    crate::args::finite(&t.xyz_m, c"data->targets->xyz_m").map_err(|e| e.at(g))?;
                    Ok(GroupKind::KnownTarget(t.xyz_m))
                }
                _ => Ok(GroupKind::Target),
            }
        } else {
            let p = g - self.n_targets;
            match self.planes.and_then(|t| t.get(p)) {
                Some(pl) if pl.known != 0 => {
                    crate::args::finite(&pl.normal, c"data->planes->normal")
                        .map_err(|e| e.at(p))?;
                    crate::args::finite(&[pl.offset_m], c"data->planes->offset_m")
                        .map_err(|e| e.at(p))?;
                    if pl.normal.iter().all(|&v| v == 0.0) {
                        return Err(kincal_error::new(kincal_status::BadGroup)
                            .arg(c"data->planes->normal")
                            .at(p));
                    }
                    Ok(GroupKind::KnownPlane {
                        normal: pl.normal,
                        offset_m: pl.offset_m,
                    })
                }
                _ => Ok(GroupKind::Plane),
            }
        }
    }

    /// The argument name and id of group `g` for an error.
    fn group_name(&self, g: usize) -> (&'static CStr, usize) {
        if g < self.n_targets {
            (c"data->target", g)
        } else {
            (c"data->plane", g - self.n_targets)
        }
    }
}

/// Typed views of the workspace regions.
struct Arrays<'w, const N: usize, const P: usize> {
    ws: &'w mut Workspace<P>,
    inst: &'w mut [Measurement<N>],
    contacts: &'w mut [Contact<N>],
    groups: &'w mut [Group],
    distances: &'w mut [Distance],
    row_of: &'w mut [usize],
    group_count: &'w mut [usize],
    group_first: &'w mut [usize],
    group_session: &'w mut [usize],
    session_count: &'w mut [usize],
    session_first: &'w mut [usize],
}

/// An array of `n` copies of `v` at `base + off`.
///
/// # Safety
/// `base + off` is aligned for `T` and writable for `n` values, disjoint from every other
/// region handed out, and stays so for `'w`.
unsafe fn fill<'w, T: Copy>(base: *mut u8, off: usize, n: usize, v: T) -> &'w mut [T] {
    // SAFETY: forwarded contract.
    unsafe {
        let p = base.add(off).cast::<T>();
        for k in 0..n {
            p.add(k).write(v);
        }
        core::slice::from_raw_parts_mut(p, n)
    }
}

/// # Safety
/// `ws` is NULL or writable for `ws_len` bytes, and no reference into it is alive.
unsafe fn carve<'w, const N: usize, const P: usize>(
    ws: *mut c_void,
    ws_len: usize,
    v: &View<'_>,
) -> FfiResult<Arrays<'w, N, P>> {
    let (l, g, d, s) = (v.rows, v.n_groups(), v.distances.len(), v.n_sessions.max(1));
    let lay = layout::<N, P>(l, g, d, s)
        .ok_or(kincal_error::new(kincal_status::CapacityExceeded).arg(c"workspace"))?;
    if ws.is_null() {
        return Err(crate::args::null(c"workspace"));
    }
    if !(ws as usize).is_multiple_of(KINCAL_WORKSPACE_ALIGN) {
        return Err(kincal_error::new(kincal_status::MisalignedPointer).arg(c"workspace"));
    }
    if ws_len < lay.total {
        return Err(crate::args::bad_length(c"workspace", lay.total, ws_len));
    }
    let base = ws.cast::<u8>();
    let empty_meas = Measurement::<N>::new([0.0; N], Transform::identity());
    // SAFETY: every region lies inside the checked `lay.total <= ws_len` bytes, is aligned
    // for its type (the base is aligned to 16 >= every alignment here, offsets are aligned
    // by `array`), and the regions are disjoint by construction of the layout. All-zero
    // bytes are a valid Workspace (documented by the core).
    unsafe {
        core::ptr::write_bytes(base, 0, core::mem::size_of::<Workspace<P>>());
        Ok(Arrays {
            ws: &mut *base.cast::<Workspace<P>>(),
            inst: fill(base, lay.inst, l, empty_meas),
            contacts: fill(base, lay.contacts, l, Contact::new([0.0; N])),
            groups: fill(
                base,
                lay.groups,
                g,
                Group {
                    kind: GroupKind::Target,
                    start: 0,
                    len: 0,
                },
            ),
            distances: fill(
                base,
                lay.distances,
                d,
                Distance {
                    a: 0,
                    b: 0,
                    m: 0.0,
                    weight: 0.0,
                },
            ),
            row_of: fill(base, lay.row_of, l, 0usize),
            group_count: fill(base, lay.group_count, g, 0usize),
            group_first: fill(base, lay.group_first, g, KINCAL_NO_INDEX),
            group_session: fill(base, lay.group_session, g, 0usize),
            session_count: fill(base, lay.session_count, s, 0usize),
            session_first: fill(base, lay.session_first, s, KINCAL_NO_INDEX),
        })
    }
}

/// The core data in the workspace, and the counts.
struct Built<'w, const N: usize> {
    data: ConstraintData<'w, N>,
    row_of: &'w [usize],
    group_first: &'w [usize],
    n_inst: usize,
}

/// A broken session or group rule, with the caller's row.
fn session_fault(f: SessionFault, v: &View<'_>) -> kincal_error {
    match f {
        SessionFault::SessionOutOfRange { row, session } => at_row(
            kincal_error::new(kincal_status::IndexOutOfRange)
                .arg(c"data->session")
                .at(row)
                .counts(v.n_sessions, session),
            row,
        ),
        SessionFault::GroupInTwoSessions { row, .. }
        | SessionFault::InstrumentInTwoSessions { row, .. } => at_row(
            kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"data->session")
                .at(row)
                .value(f64::from(v.session_of(row))),
            row,
        ),
        SessionFault::FrameTooSmall {
            session,
            rows,
            first,
        } => at_row(
            kincal_error::new(kincal_status::TooFewData)
                .arg(c"data->session")
                .at(session)
                .counts(kincal::identify::MIN_FRAME_ROWS, rows),
            first,
        ),
        SessionFault::SessionTooSmall {
            session,
            rows,
            first,
        } => at_row(
            kincal_error::new(kincal_status::TooFewData)
                .arg(c"data->session")
                .at(session)
                .counts(KINCAL_MIN_SESSION_ROWS, rows),
            first,
        ),
        SessionFault::GroupTooSmall {
            group,
            rows,
            needed,
            first,
        } => {
            let (name, id) = v.group_name(group);
            at_row(
                kincal_error::new(kincal_status::BadGroup)
                    .arg(name)
                    .at(id)
                    .counts(needed, rows),
                first,
            )
        }
        SessionFault::GroupOutOfRange { .. } | SessionFault::ScratchTooSmall => {
            kincal_error::new(kincal_status::Internal)
        }
    }
}

/// Checks every row, group, session and distance, then groups the rows.
// Long by design: two passes over the caller's arrays (kinds and groups, then rows into place) with no heap; each rule is commented.
fn build<'w, const N: usize, const P: usize>(
    v: &View<'_>,
    a: Arrays<'w, N, P>,
) -> FfiResult<(Built<'w, N>, &'w mut Workspace<P>)> {
    let Arrays {
        ws,
        inst,
        contacts,
        groups,
        distances,
        row_of,
        group_count,
        group_first,
        group_session,
        session_count,
        session_first,
    } = a;
    // Pass 1: every row's kind, every group's kind.
    for l in 0..v.rows {
        v.kind(l)?;
    }
    for (g, grp) in groups.iter_mut().enumerate() {
        grp.kind = v.group_kind(g)?;
    }
    // The session and group rules (core's, shared with the file reader).
    let roles = (0..v.rows).map(|l| {
        let role = match v.kind(l) {
            Ok(RowKind::Contact(g)) => RowRole::Contact(g),
            _ => RowRole::Instrument,
        };
        (role, v.session_of(l) as usize)
    });
    let layout = SessionLayout {
        n_groups: v.n_groups(),
        n_sessions: v.n_sessions,
        sessions_given: v.session.is_some(),
        // One base frame for every instrument row: a frame per session is not in the C ABI.
        instrument_frames: false,
    };
    let scratch = SessionScratch {
        group_rows: group_count,
        group_first,
        group_session,
        session_rows: session_count,
        session_first,
    };
    let kind_of = |g: usize| groups.get(g).map_or(GroupKind::Target, |x| x.kind);
    check_sessions(roles, kind_of, &layout, scratch).map_err(|f| session_fault(f, v))?;
    // Group starts.
    let mut start = 0usize;
    for (grp, &n) in groups.iter_mut().zip(group_count.iter()) {
        grp.start = start;
        grp.len = n;
        start += n;
    }
    // Distances.
    for ((k, d), out) in v.distances.iter().enumerate().zip(distances.iter_mut()) {
        let bad = |found: usize| {
            kincal_error::new(kincal_status::BadDistance)
                .arg(c"data->distances")
                .at(k)
                .counts(v.n_targets, found)
        };
        for end in [d.a, d.b] {
            if end as usize >= v.n_targets {
                return Err(bad(end as usize));
            }
        }
        let ok =
            d.a != d.b && d.m.is_finite() && d.m > 0.0 && d.weight.is_finite() && d.weight >= 0.0;
        if !ok {
            return Err(bad(d.b as usize).value(if d.m.is_finite() && d.m > 0.0 {
                d.weight
            } else {
                d.m
            }));
        }
        *out = Distance {
            a: d.a as usize,
            b: d.b as usize,
            m: d.m,
            weight: d.weight,
        };
    }
    // Pass 2: rows into place (instrument rows in order, contacts sorted by group).
    for c in group_count.iter_mut() {
        *c = 0;
    }
    let mut n_inst = 0usize;
    let n_contacts = start;
    let n_instrument_rows = v.rows - n_contacts;
    for l in 0..v.rows {
        let q =
            v.q.get(l * N..(l + 1) * N)
                .ok_or(kincal_error::new(kincal_status::Internal))?;
        let aux = v.aux.and_then(|a| a.get(l));
        let state = joint_state::<N>(q, aux, DATA_AUX).map_err(|e| at_row(e, l))?;
        let point = match v.point.and_then(|p| p.get(3 * l..3 * l + 3)) {
            Some(&[x, y, z]) => [x, y, z],
            _ => [0.0; 3],
        };
        match v.kind(l)? {
            RowKind::Contact(g) => {
                let grp = groups
                    .get(g)
                    .ok_or(kincal_error::new(kincal_status::Internal))?;
                let fill = group_count
                    .get_mut(g)
                    .ok_or(kincal_error::new(kincal_status::Internal))?;
                let slot = grp.start + *fill;
                *fill += 1;
                if let Some(c) = contacts.get_mut(slot) {
                    *c = Contact {
                        state,
                        point,
                        weight: 1.0,
                    };
                }
                if let Some(r) = row_of.get_mut(n_instrument_rows + slot) {
                    *r = l;
                }
            }
            RowKind::Instrument(mask) => {
                let xyz = match v.coords.and_then(|c| c.get(3 * l..3 * l + 3)) {
                    Some(&[x, y, z]) => [x, y, z],
                    _ => [0.0; 3],
                };
                // Only the measured components must be finite.
                for (k, &x) in xyz.iter().enumerate() {
                    if mask & (1 << k) != 0 && !x.is_finite() {
                        return Err(at_row(
                            kincal_error::new(kincal_status::NonFinite)
                                .arg(c"data->coords")
                                .at(3 * l + k)
                                .value(x),
                            l,
                        ));
                    }
                }
                let mut pose = Transform::identity();
                for (k, (&x, slot)) in xyz
                    .iter()
                    .zip(pose.translation.vector.iter_mut())
                    .enumerate()
                {
                    if mask & (1 << k) != 0 {
                        *slot = x;
                    }
                }
                let mut m = Measurement::new(state.q, pose);
                m.state = state;
                m.mask = ComponentMask(mask);
                m.point = (point != [0.0; 3]).then_some(point);
                if let Some(slot) = inst.get_mut(n_inst) {
                    *slot = m;
                }
                if let Some(r) = row_of.get_mut(n_inst) {
                    *r = l;
                }
                n_inst += 1;
            }
        }
    }
    let data = ConstraintData {
        instrument: inst.get(..n_inst).unwrap_or(&[]),
        contacts: contacts.get(..n_contacts).unwrap_or(&[]),
        groups,
        distances,
        sessions: &[],
    };
    Ok((
        Built {
            data,
            row_of,
            group_first,
            n_inst,
        },
        ws,
    ))
}

/// A core error with the caller's row (`pose`), target or plane (`argument`, `index`).
fn core_error<const N: usize>(e: Error, v: &View<'_>, b: &Built<'_, N>) -> kincal_error {
    let row = |i: usize| b.row_of.get(i).copied().unwrap_or(KINCAL_NO_INDEX);
    let group = |g: usize, status: kincal_status| {
        let (name, id) = v.group_name(g);
        at_row(
            kincal_error::new(status).arg(name).at(id),
            b.group_first.get(g).copied().unwrap_or(KINCAL_NO_INDEX),
        )
    };
    match e {
        Error::NonFinite { index, .. } => {
            let mut k = kincal_error::from(e);
            k.index = row(index);
            k.pose = row(index);
            k
        }
        Error::BadPose { pose } => at_row(kincal_error::from(e), row(pose.0)),
        Error::BadGroup { group: g } => group(g, kincal_status::BadGroup),
        Error::DegenerateGroup { group: g } => group(g, kincal_status::DegenerateGroup),
        Error::BadDistance { .. } => kincal_error::from(e).arg(c"data->distances"),
        other => kincal_error::from(other),
    }
}

/// The outputs of one call, computed before any is written.
struct Results {
    robot: kincal_robot,
    report: kincal_constraints_report,
}

/// Where the estimates go.
struct EstimateOut<'a> {
    targets: Option<&'a mut [kincal_group_estimate]>,
    planes: Option<&'a mut [kincal_group_estimate]>,
    distances: Option<&'a mut [f64]>,
}

fn estimate(e: &kincal::identify::GroupEstimate) -> kincal_group_estimate {
    kincal_group_estimate {
        contacts: e.contacts,
        point: e.point,
        normal: e.normal,
        offset_m: e.offset_m,
        rms_m: e.rms_m,
        max_m: e.max_m,
        mean_m: e.mean_m,
        aspect: e.aspect,
    }
}

/// # Safety
/// As [`carve`].
unsafe fn run_p<const N: usize, const P: usize>(
    r: &Robot<N>,
    v: &View<'_>,
    o: &kincal_identify_options,
    ws: *mut c_void,
    ws_len: usize,
    est: &mut EstimateOut<'_>,
) -> FfiResult<Results> {
    let mut bounds = kincal::identify::Bounds::paper_default(r);
    let prior = crate::identify::prior_of(o, r)?;
    let mut opts = options(o, N, &mut bounds)?;
    opts.prior = prior.as_ref();
    // SAFETY: forwarded contract.
    let arrays = unsafe { carve::<N, P>(ws, ws_len, v) }?;
    let (b, workspace) = build::<N, P>(v, arrays)?;
    // Collinear plane contacts at the starting model.
    for g in v.n_targets..v.n_groups() {
        if matches!(b.data.groups.get(g).map(|g| g.kind), Some(GroupKind::Plane)) {
            let aspect = match group_estimate(r, &b.data, g) {
                Ok(e) => e.aspect,
                Err(Error::DegenerateGroup { .. }) => 0.0,
                Err(e) => return Err(core_error(e, v, &b)),
            };
            if aspect.is_nan() || aspect < KINCAL_PLANE_MIN_ASPECT {
                let (name, id) = v.group_name(g);
                return Err(at_row(
                    kincal_error::new(kincal_status::DegenerateGroup)
                        .arg(name)
                        .at(id)
                        .value(aspect),
                    b.group_first.get(g).copied().unwrap_or(KINCAL_NO_INDEX),
                ));
            }
        }
    }
    let id =
        identify_constrained(r, &b.data, &opts, workspace).map_err(|e| core_error(e, v, &b))?;
    let robot = from_robot(&id.robot)?;
    // Estimates at the identified model (checked finite before anything is written).
    let fitted = &id.robot;
    for g in 0..v.n_groups() {
        let e = group_estimate(fitted, &b.data, g).map_err(|e| core_error(e, v, &b))?;
        let slot = if g < v.n_targets {
            est.targets.as_deref_mut().and_then(|t| t.get_mut(g))
        } else {
            est.planes
                .as_deref_mut()
                .and_then(|p| p.get_mut(g - v.n_targets))
        };
        if let Some(s) = slot {
            *s = estimate(&e);
        }
    }
    if let Some(out) = est.distances.as_deref_mut() {
        for (k, slot) in out.iter_mut().enumerate() {
            *slot = distance_estimate(fitted, &b.data, k)
                .map_err(|e| core_error(e, v, &b))?
                .unwrap_or(f64::NAN);
        }
    }
    let report = kincal_constraints_report {
        identify: report_of(&id, workspace),
        gauge: mask_of(&id.analysis.gauge),
        external_reference: u32::from(b.data.has_external_reference()),
        length_reference: u32::from(b.data.has_length_reference()),
        n_instrument_rows: b.n_inst,
        n_contacts: b.data.contacts.len(),
    };
    Ok(Results { robot, report })
}

/// # Safety
/// As [`carve`].
unsafe fn run<const N: usize>(
    r: &Robot<N>,
    v: &View<'_>,
    o: &kincal_identify_options,
    ws: *mut c_void,
    ws_len: usize,
    est: &mut EstimateOut<'_>,
) -> FfiResult<Results> {
    let n_requested = o
        .requested
        .iter()
        .take(kincal::params::num_params(N))
        .filter(|&&m| m != 0)
        .count();
    if n_requested == 0 {
        return Err(kincal_error::new(kincal_status::TooFewData)
            .arg(c"opts->requested")
            .counts(1, 0));
    }
    // SAFETY (both): forwarded contract.
    match capacity_for(n_requested) {
        Some(32) => unsafe { run_p::<N, 32>(r, v, o, ws, ws_len, est) },
        Some(KINCAL_MAX_PARAMS) => unsafe {
            run_p::<N, KINCAL_MAX_PARAMS>(r, v, o, ws, ws_len, est)
        },
        _ => Err(kincal_error::new(kincal_status::CapacityExceeded)
            .arg(c"opts->requested")
            .counts(KINCAL_MAX_PARAMS, n_requested)),
    }
}

/// Instrument-free calibration: identifies the identifiable subset of `opts->requested` from
/// contacts held at targets or on planes, known distances, known targets and planes, and
/// optional (partial) instrument coordinates, starting from `robot`; the 3 coordinates of
/// every unknown target or plane are eliminated, never fitted (`docs/constraints.md`).
///
/// - `robot`: initial model (read only). `robot_out` may point to the same struct.
/// - `data`: the rows (see `kincal_constraint_data`).
/// - `opts`: from `kincal_identify_options_default` (OLS, OPT1 or OPT2, the parameters to
///   fit; `weight_pos` weighs contact and distance rows too).
/// - `workspace`, `workspace_len`: caller memory of at least
///   `kincal_identify_constraints_workspace_size(...)` bytes, aligned to
///   `KINCAL_WORKSPACE_ALIGN`; scratch.
/// - `report_out` (NULL if not wanted): identification report, gauge, references.
/// - `targets_out` (`n_targets` entries), `planes_out` (`n_planes`), `distances_out`
///   (`n_distances` predicted distances [m]): each NULL if not wanted; the estimates at the
///   identified model (the consistency of the data with it). They are filled last, after
///   the model and the report are known; only a failure while computing them (none is
///   expected once the fit succeeded) can leave them partly written.
///
/// Every refusal of a row sets `kincal_error.pose` to the zero-based row (`KINCAL_NO_INDEX`
/// when no row names the group): INVALID_ARGUMENT (`data->coord_mask`: a row that measures
/// nothing, coordinates and a target or plane on one row, bits beyond 0x7; `data->plane`: a
/// target and a plane on one row; `data->session`: a target, plane or the instrument rows in
/// two sessions), INDEX_OUT_OF_RANGE (a target, plane or session id beyond its count), BAD_GROUP
/// (a target or plane with too few rows: `argument` `data->target` or `data->plane`, `index` =
/// its id, `expected`/`found` = rows needed/given; or a zero known normal), DEGENERATE_GROUP
/// (collinear plane contacts at the starting model, `value` = their aspect, below
/// `KINCAL_PLANE_MIN_ASPECT`), TOO_FEW_DATA (a session with fewer than
/// `KINCAL_MIN_SESSION_ROWS` rows, `index` = session), BAD_DISTANCE (`index` = the distance;
/// an unknown target: `found` = its id, `expected` = `n_targets`; equal ends, a length
/// ≤ 0, a bad weight), NON_FINITE (`pose` = row); plus the argument and numerical statuses of
/// `kincal_identify`. Outputs are written on success only.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
/// `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn kincal_identify_constraints(
    robot: *const kincal_robot,
    data: *const kincal_constraint_data,
    opts: *const kincal_identify_options,
    workspace: *mut c_void,
    workspace_len: usize,
    robot_out: *mut kincal_robot,
    report_out: *mut kincal_constraints_report,
    targets_out: *mut kincal_group_estimate,
    targets_out_len: usize,
    planes_out: *mut kincal_group_estimate,
    planes_out_len: usize,
    distances_out: *mut f64,
    distances_out_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let o = arg_ref!(opts);
        let out = arg_out1!(robot_out);
        let report = arg_out_opt!(report_out, 1, 1);
        let any = to_any(r)?;
        // SAFETY: forwarded contract.
        let v = unsafe { view(data, any.n_joints()) }?;
        let mut t_out = arg_out_opt!(targets_out, targets_out_len, v.n_targets);
        let mut p_out = arg_out_opt!(planes_out, planes_out_len, v.n_planes);
        let mut d_out = arg_out_opt!(distances_out, distances_out_len, v.distances.len());
        let mut est = EstimateOut {
            // SAFETY: checked by `arg_out_opt!`; writable by contract, no other reference.
            targets: t_out.as_mut().map(|o| unsafe { o.as_mut_slice() }),
            planes: p_out.as_mut().map(|o| unsafe { o.as_mut_slice() }),
            distances: d_out.as_mut().map(|o| unsafe { o.as_mut_slice() }),
        };
        // SAFETY: forwarded contract.
        let res = with_any_robot!(&any, r => unsafe {
            run(r, &v, o, workspace, workspace_len, &mut est)
        })?;
        // SAFETY: checked by `arg_out1!`/`arg_out_opt!`; writable by contract.
        unsafe {
            out.put(res.robot);
            if let Some(p) = report {
                p.put(res.report);
            }
        }
        Ok(())
    })
}
