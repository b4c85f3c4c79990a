//! Instrument-free calibration: rows that say where the tool point is *held*, not where an
//! instrument saw it (issue #13; format in `docs/constraints.md`).
//!
//! A [`Contact`] is a joint state and a point in the tool frame (the ball centre, the probe
//! tip: the tool frame moved to `point`, as [`Measurement::point`]). Contacts come in
//! [`Group`]s, contiguous in the contact slice:
//! - [`GroupKind::Target`]: every contact of the group has its tool point at one fixed,
//!   unknown point `t` (ball in a socket);
//! - [`GroupKind::KnownTarget`]: … at a known point (in the base frame);
//! - [`GroupKind::Plane`]: every tool point lies on one unknown plane `n·p = c`;
//! - [`GroupKind::KnownPlane`]: … on a known plane.
//!
//! A [`Distance`] states the distance between two targets (the only length reference when
//! nothing else is known). Instrument rows ([`Measurement`]s, also partial coordinates via
//! their [`super::ComponentMask`]) may be mixed in; they share the one base frame.
//!
//! **Elimination.** The nuisance parameters (3 per unknown target or plane) never enter the
//! parameter vector. For a target, minimising over `t` gives the weighted mean `p̄` of the
//! predicted tool points, and the reduced problem has residuals `e_i = p̄ − p_i` with the
//! exact Jacobian `J_i − J̄` (`p̄` is linear in the `p_i`). For an unknown plane the normal
//! `n` is the eigenvector of the smallest eigenvalue of the group's scatter about `p̄`, and
//! `e_i = −n·(p_i − p̄)` with the Jacobian `nᵀ(J_i − J̄)` less its fit on the plane's two
//! tilts (`plane_tilt`: the term `∂n/∂θ`, first order, which Kaufman's variable projection
//! would drop; without it the Gauss–Newton matrix, the standard errors and the rank test
//! credited a plane with information its refitted tilt absorbs). A
//! distance adds `e = D − ‖p̄_a − p̄_b‖` with `J = uᵀ(J̄_a − J̄_b)`, `u` the unit vector from
//! `p̄_b` to `p̄_a`: the targets stay the means of their contacts (a distance does not pull
//! them), which makes the objective a proper least-squares problem in the robot
//! parameters alone, consistent, and exact on noise-free data.
//!
//! **Memory.** No heap: each group is streamed (a plane twice: forward kinematics for `p̄`
//! and the scatter, then the Jacobian rows), so memory does not grow with the number of
//! contacts or groups. On the normal-equation path the uncentred rows are folded and the
//! Gram matrix downdated by `W·J̄ᵀJ̄` afterwards (`Σ w (J_i − J̄)ᵀ(J_i − J̄) = Σ w J_iᵀJ_i −
//! W J̄ᵀJ̄`); an unknown target's rows are folded with residuals `ō − p_i` (`ō` its first
//! contact's point) in the same single pass and centred by the same downdate with a
//! right-hand side, so it costs one Jacobian pass and no forward-kinematics pass. A cost
//! alone (a solver's trial point) is one forward-kinematics pass, from each group's
//! moments (`tr S` for a target, `nᵀSn` for a plane). The
//! Givens path (analysis, singular fallback) needs `J̄` first and pays a second Jacobian
//! pass. A distance needs `J̄` of two groups: the means of the last [`MEAN_CACHE`] groups
//! are kept in the workspace and a distance is folded right after the later of its two
//! groups, so distances between neighbouring groups cost nothing extra; others recompute
//! the missing mean (one more pass over that group).
//!
//! **Gauge.** Without an external reference (no instrument row, known target or known
//! plane) rigid motions of the base move every tool point together and leave every
//! coincidence, coplanarity and distance unchanged: the base frame is not observable and
//! its parameters go to [`super::Identifiability::gauge`]. Without a length reference (no
//! known distance, instrument row, known target or known plane) scaling every length
//! scales every tool point: one length, the longest nominal one, is held as the scale
//! gauge — unless a prismatic joint moves in the data: its encoder reads a length, so the
//! scale is observable and nothing is held
//! ([`ConstraintData::prismatic_fixes_scale`]). These are named, never silently fixed; the rest is the usual greedy rank test on
//! the reduced Jacobian.

use super::data::{Measurement, RowSource, add_rows, validate as validate_instrument};
use super::identifiability::{StructuralSel, data_step, structural_step_with};
use super::instrument_sessions::{InstrumentSession, fold_session};
use super::{
    ComponentMask, Identifiability, Identification, IdentifyOptions, ResidualStats, Workspace,
};
use crate::error::{Error, ParamIndex, Quantity, Result, check_finite};
use crate::math::sqrt;
use crate::model::{JointState, Robot};
use crate::params::{FrameParam, ParamId};
use crate::pose::Transform;

/// One contact: the robot's joint state while its tool point (`point`, tool frame, \[m\])
/// was held at a target or on a plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact<const N: usize> {
    /// Joint readings and auxiliary data.
    pub state: JointState<N>,
    /// The tool point in the tool frame \[m\] (zero: the tool-frame origin, e.g. a ball
    /// centre identified as the tool translation).
    pub point: [f64; 3],
    /// Weight (>= 0; 0 holds the contact out, as [`Measurement::weight`]).
    pub weight: f64,
}

impl<const N: usize> Contact<N> {
    /// A contact of the tool-frame origin at readings `q`.
    #[must_use]
    pub const fn new(q: [f64; N]) -> Self {
        Contact {
            state: JointState::new(q),
            point: [0.0; 3],
            weight: 1.0,
        }
    }

    fn as_measurement(&self) -> Measurement<N> {
        Measurement {
            state: self.state,
            pose: Transform::identity(),
            mask: ComponentMask::POSITION,
            weight: self.weight,
            point: Some(self.point),
        }
    }

    /// The predicted tool point in the base frame \[m\].
    pub fn tool_point(&self, robot: &Robot<N>) -> Result<[f64; 3]> {
        let t = self.as_measurement().model_pose(robot)?;
        let v = t.translation.vector;
        Ok([v.x, v.y, v.z])
    }
}

/// What holds a group's tool points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GroupKind {
    /// One unknown point (3 nuisance parameters, eliminated). At least 2 contacts.
    Target,
    /// A known point in the base frame \[m\]. At least 1 contact.
    KnownTarget([f64; 3]),
    /// An unknown plane (3 nuisance parameters, eliminated). At least 3 contacts, not
    /// collinear; only the 4th and later add information.
    Plane,
    /// A known plane `normal·p = offset_m` (normal need not be unit length). At least 1.
    KnownPlane {
        /// Plane normal (base frame).
        normal: [f64; 3],
        /// `normal·p` on the plane, with the normal normalised \[m\].
        offset_m: f64,
    },
}

impl GroupKind {
    /// Whether the group is a point (unknown or known): distances may name it.
    #[must_use]
    pub const fn is_target(self) -> bool {
        matches!(self, GroupKind::Target | GroupKind::KnownTarget(_))
    }
    /// Whether it refers to the base frame (known coordinates).
    #[must_use]
    pub const fn is_known(self) -> bool {
        matches!(
            self,
            GroupKind::KnownTarget(_) | GroupKind::KnownPlane { .. }
        )
    }
    /// What `n` contacts of a group of this kind leave at the noise floor, in units of σ²
    /// per axis, once the group's own unknowns are fitted to them: `3(n − 1)` for an unknown
    /// target (its mean), `n − 3` for an unknown plane (distances to its own plane), `3n`
    /// and `n` when known. The held-out gap test's degrees of freedom.
    #[must_use]
    pub const fn floor_dof(self, n: usize) -> usize {
        match self {
            GroupKind::Target => 3 * n.saturating_sub(1),
            GroupKind::Plane => n.saturating_sub(3),
            GroupKind::KnownTarget(_) => 3 * n,
            GroupKind::KnownPlane { .. } => n,
        }
    }
    /// Contacts a group of this kind needs: 2 for an unknown target, 3 for an unknown
    /// plane, 1 when known (the front ends refuse fewer, see [`super::check_sessions`]).
    #[must_use]
    pub const fn min_contacts(self) -> usize {
        match self {
            GroupKind::Target => 2,
            GroupKind::Plane => 3,
            _ => 1,
        }
    }
}

/// A group: the contacts `start..start + len` of [`ConstraintData::contacts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Group {
    /// Kind.
    pub kind: GroupKind,
    /// First contact.
    pub start: usize,
    /// Number of contacts.
    pub len: usize,
}

/// A known distance between two target groups.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Distance {
    /// First group (a target).
    pub a: usize,
    /// Second group (a target).
    pub b: usize,
    /// The distance \[m\].
    pub m: f64,
    /// Weight relative to a position row (`IdentifyOptions::weight_pos` multiplies it):
    /// 1 weighs the distance like one coordinate of the data; `(σ_data/σ_distance)²`
    /// when the distance's uncertainty is known.
    pub weight: f64,
}

/// Instrument-free (or mixed) calibration data. Groups must tile the contacts in order:
/// the first starts at 0, each starts where the previous ends, the last ends at
/// `contacts.len()` (sort rows by group first; [`Error::BadGroup`] otherwise).
#[derive(Debug, Clone, Copy)]
pub struct ConstraintData<'a, const N: usize> {
    /// Instrument rows (poses, positions, partial coordinates) in the base frame.
    pub instrument: &'a [Measurement<N>],
    /// Contacts, grouped.
    pub contacts: &'a [Contact<N>],
    /// Groups over `contacts`.
    pub groups: &'a [Group],
    /// Known distances between target groups.
    pub distances: &'a [Distance],
    /// Runs of instrument rows measured in a frame of their own, one per set-up
    /// ([`super::instrument_sessions`]); empty: every instrument row is in the base frame.
    pub sessions: &'a [InstrumentSession],
}

/// Number of group means kept for distances (see the module doc).
pub const MEAN_CACHE: usize = 4;

/// Weighted mean of a group's predicted tool points and (column-scaled) position Jacobian
/// rows; `group == usize::MAX`: empty slot.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GroupMean<const P: usize> {
    pub(crate) group: usize,
    /// Σ w of the active contacts.
    pub(crate) w: f64,
    pub(crate) p: [f64; 3],
    pub(crate) jbar: [[f64; P]; 3],
}

impl<const P: usize> GroupMean<P> {
    pub(crate) const EMPTY: Self = GroupMean {
        group: usize::MAX,
        w: 0.0,
        p: [0.0; 3],
        jbar: [[0.0; P]; 3],
    };
}

impl<'a, const N: usize> ConstraintData<'a, N> {
    fn group_contacts(&self, g: &Group) -> &'a [Contact<N>] {
        self.contacts.get(g.start..g.start + g.len).unwrap_or(&[])
    }

    /// Whether an active instrument row is in the base frame (outside every session).
    fn active_instrument(&self) -> bool {
        self.instrument
            .iter()
            .enumerate()
            .any(|(l, m)| m.weight > 0.0 && !self.in_session(l))
    }

    /// Whether some row refers to the base frame: instrument rows outside every session of
    /// its own frame, or known groups.
    #[must_use]
    pub fn has_external_reference(&self) -> bool {
        self.active_instrument()
            || self
                .groups
                .iter()
                .any(|g| g.kind.is_known() && self.group_contacts(g).iter().any(|c| c.weight > 0.0))
    }

    /// Whether some row fixes the scale: a known distance, an external reference, or an
    /// instrument row measuring a position (in any frame).
    #[must_use]
    pub fn has_length_reference(&self) -> bool {
        // Instrument rows in a session's own frame still measure lengths (a rigid frame
        // does not absorb a scaling).
        let measured_lengths = self
            .instrument
            .iter()
            .any(|m| m.weight > 0.0 && (0..3).any(|k| m.mask.has(k)));
        !self.distances.is_empty() || self.has_external_reference() || measured_lengths
    }

    /// Whether the readings of a prismatic joint fix the scale: a slide is a length the
    /// encoder measures, not one of the structure, so scaling every length of the model no
    /// longer moves the tool points exactly once some prismatic joint of `robot` takes two
    /// different readings among the active rows — unless that joint's scale effect is
    /// `requested`, which absorbs the slide's share of the scaling.
    #[must_use]
    pub fn prismatic_fixes_scale(&self, robot: &Robot<N>, requested: &crate::ParamSet) -> bool {
        let states = self
            .instrument
            .iter()
            .filter(|m| m.weight > 0.0)
            .map(|m| &m.state)
            .chain(
                self.contacts
                    .iter()
                    .filter(|c| c.weight > 0.0)
                    .map(|c| &c.state),
            );
        let mut first: Option<[f64; N]> = None;
        for st in states {
            let Some(f) = first else {
                first = Some(st.q);
                continue;
            };
            for (j, (&q, &q0)) in st.q.iter().zip(f.iter()).enumerate() {
                if q != q0
                    && robot.joint_kind(j) == crate::JointKind::Prismatic
                    && !requested.contains(ParamId::Scale(j).index(N).0)
                {
                    return true;
                }
            }
        }
        false
    }
}

/// Position of the predicted tool point and the scaled Jacobian rows of the selected
/// columns (`ws.cols[..n_cols]`, `ws.colscale`) into `rows[..3]`.
fn contact_rows<const N: usize, const P: usize>(
    robot: &Robot<N>,
    c: &Contact<N>,
    n_cols: usize,
    ws: &mut Workspace<P>,
    rows: &mut [[f64; P]; 6],
) -> Result<[f64; 3]> {
    if ws.cost_only {
        // The same point as `model_jacobian`'s: both run the one `chain` of `fk`.
        return c.tool_point(robot);
    }
    let Workspace {
        jac,
        cols,
        colscale,
        frame_rotations,
        ..
    } = ws;
    let cols = cols.get(..n_cols).ok_or(Error::CapacityExceeded {
        needed: n_cols,
        capacity: P,
    })?;
    let n_jac = super::data::jacobian_len::<N>(cols);
    let jac = jac.get_mut(..n_jac).ok_or(Error::CapacityExceeded {
        needed: n_jac,
        capacity: super::MAX_MODEL_PARAMS,
    })?;
    let t = c
        .as_measurement()
        .model_jacobian_with(robot, jac, *frame_rotations)?;
    // The three position rows side by side: no bounds check per entry.
    let [r0, r1, r2, ..] = rows;
    let out = r0.iter_mut().zip(r1.iter_mut().zip(r2.iter_mut()));
    for ((&col, &scale), (x0, (x1, x2))) in cols.iter().zip(colscale.iter()).zip(out) {
        let jc = jac.get(col).copied().unwrap_or([0.0; 6]);
        *x0 = jc[0] * scale;
        *x1 = jc[1] * scale;
        *x2 = jc[2] * scale;
    }
    let v = t.translation.vector;
    Ok([v.x, v.y, v.z])
}

/// Weighted mean `p̄`, total weight and scatter `Σ w (p − p̄)(p − p̄)ᵀ` of the predicted
/// tool points of the active contacts (forward kinematics only).
fn point_moments<const N: usize>(
    robot: &Robot<N>,
    contacts: &[Contact<N>],
) -> Result<(f64, [f64; 3], [[f64; 3]; 3])> {
    let mut w = 0.0;
    let mut origin = None;
    let mut s1 = [0.0; 3];
    let mut s2 = [[0.0; 3]; 3];
    for c in contacts.iter().filter(|c| c.weight > 0.0) {
        let p = c.tool_point(robot)?;
        let o = *origin.get_or_insert(p);
        let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        w += c.weight;
        for a in 0..3 {
            s1[a] += c.weight * d[a];
            for b in 0..3 {
                s2[a][b] += c.weight * d[a] * d[b];
            }
        }
    }
    let o = origin.unwrap_or([0.0; 3]);
    if w <= 0.0 {
        return Ok((0.0, o, [[0.0; 3]; 3]));
    }
    let dbar = [s1[0] / w, s1[1] / w, s1[2] / w];
    for a in 0..3 {
        for b in 0..3 {
            s2[a][b] -= w * dbar[a] * dbar[b];
        }
    }
    Ok((w, [o[0] + dbar[0], o[1] + dbar[1], o[2] + dbar[2]], s2))
}

/// Eigenvalues (ascending) and the unit eigenvector of the smallest, of a symmetric 3×3
/// matrix, by cyclic Jacobi rotations (no panics, no allocation).
pub(crate) fn sym3_smallest(mut a: [[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + sqrt(theta * theta + 1.0));
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / sqrt(t * t + 1.0);
            let s = t * c;
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut idx = [0usize, 1, 2];
    idx.sort_unstable_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let k = idx[0];
    let mut n = [v[0][k], v[1][k], v[2][k]];
    // Sign convention: the largest component positive (reported planes are reproducible).
    let big = (0..3).fold(0, |b, i| if n[i].abs() > n[b].abs() { i } else { b });
    if n[big] < 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    ([a[idx[0]][idx[0]], a[idx[1]][idx[1]], a[idx[2]][idx[2]]], n)
}

/// Relative spread below which plane contacts count as collinear: the RMS distance of the
/// predicted contacts from their best-fit line under this fraction of their RMS extent
/// along it ([`Error::DegenerateGroup`]).
pub const PLANE_MIN_ASPECT: f64 = 1e-3;

/// The stricter test the front ends apply to plane contacts before a fit, at the starting
/// model: a spread across the best-fit line below this fraction of the extent along it
/// counts as collinear (the plane's tilt about that line is then undetermined; a model
/// error of a few mm over a line of a few cm stays below it). The CLI and the C ABI refuse
/// such planes with this one threshold.
pub const USABLE_PLANE_MIN_ASPECT: f64 = 0.1;
/// A session needs at least this many rows: fewer fix nothing a set-up adds (a base frame
/// of its own needs three points; a target needs two contacts).
pub const MIN_SESSION_ROWS: usize = 3;

/// Normal of an unknown plane from the scatter, or [`Error::DegenerateGroup`].
fn plane_normal(scatter: [[f64; 3]; 3], group: usize) -> Result<[f64; 3]> {
    let (ev, n) = sym3_smallest(scatter);
    if ev[2].is_nan() || ev[2] <= 0.0 || ev[1] <= PLANE_MIN_ASPECT * PLANE_MIN_ASPECT * ev[2] {
        return Err(Error::DegenerateGroup { group });
    }
    Ok(n)
}

fn dot3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The tilts of an unknown plane: in-plane unit vectors `u`, `v` (orthonormal to `normal`)
/// and the Cholesky factor `[l00, l10, l11]` of the weighted scatter of the contacts along
/// them, `M = Σ w·t tᵀ` with `t = [u·(p − p̄), v·(p − p̄)]`. A refitted plane tilts with
/// the model, absorbing from each parameter's rows `nᵀJ_i` their fit on `t_i`: the reduced
/// problem's Gauss–Newton matrix is `Σ w r_iᵀr_i − BᵀM⁻¹B` (`B = Σ w t_i r_i`), the
/// Jacobian of the residual with the normal re-estimated (the term `∂n/∂θ` variable
/// projection would otherwise drop; it is first order, not small). `None` for a degenerate
/// scatter (then [`plane_normal`] has refused the group already).
fn plane_tilt(normal: [f64; 3], scatter: &[[f64; 3]; 3]) -> Option<([f64; 3], [f64; 3], [f64; 3])> {
    let axis = if normal[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = unit_normal(cross3(&normal, &axis));
    let v = cross3(&normal, &u);
    let quad = |a: &[f64; 3], b: &[f64; 3]| {
        let mut x = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                x += a[i] * scatter[i][j] * b[j];
            }
        }
        x
    };
    let (muu, muv, mvv) = (quad(&u, &u), quad(&u, &v), quad(&v, &v));
    if muu.is_nan() || muu <= 0.0 {
        return None;
    }
    let l00 = sqrt(muu);
    let l10 = muv / l00;
    let d = mvv - l10 * l10;
    (d > 0.0).then(|| (u, v, [l00, l10, sqrt(d)]))
}

fn cross3(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit_normal(n: [f64; 3]) -> [f64; 3] {
    let l = sqrt(dot3(&n, &n));
    if l > 0.0 {
        [n[0] / l, n[1] / l, n[2] / l]
    } else {
        n
    }
}

fn fold6<const P: usize>(
    ws: &mut Workspace<P>,
    rows: &[[f64; P]; 6],
    e: &[f64; 6],
    w: &[f64; 6],
) -> Result<()> {
    if ws.cost_only {
        Ok(())
    } else if ws.to_gram {
        // Contact rows are position rows: rows 3–5 are never written, their weights are 0.
        ws.gram
            .add_rows3(rows, &[e[0], e[1], e[2]], &[w[0], w[1], w[2]])
    } else {
        // As on the Gram path: rows 3–5 are never written, their weights are 0.
        ws.lsq
            .add_rows3(rows, &[e[0], e[1], e[2]], &[w[0], w[1], w[2]])
    }
}

/// Folds one group; leaves its mean in the cache. Returns the cost.
#[allow(clippy::too_many_lines)]
fn fold_group<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    gi: usize,
    with_rhs: bool,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    let g = data
        .groups
        .get(gi)
        .copied()
        .ok_or(Error::BadGroup { group: gi })?;
    if ws.to_gram && g.kind == GroupKind::Target {
        return fold_target_once(robot, data, gi, with_rhs, opts, n_cols, ws);
    }
    let contacts = data.group_contacts(&g);
    let (w_sum, pbar, scatter) = point_moments(robot, contacts)?;
    let centred = matches!(g.kind, GroupKind::Target | GroupKind::Plane);
    let normal = match g.kind {
        GroupKind::Plane if w_sum > 0.0 => plane_normal(scatter, gi)?,
        GroupKind::KnownPlane { normal, .. } => unit_normal(normal),
        _ => [0.0; 3],
    };
    // Rows 3 and 4 are never folded (contact rows are position rows): an unknown plane
    // keeps there `B = Σ w·t_i·nᵀJ_i` of its tilts (see `plane_tilt`), then on the Givens
    // path `M⁻¹B`.
    let mut rows = [[0.0; P]; 6];
    let mut jbar = [[0.0; P]; 3];
    let tilt = match g.kind {
        GroupKind::Plane if w_sum > 0.0 && !ws.cost_only => plane_tilt(normal, &scatter),
        _ => None,
    };
    let t_of = |p: &[f64; 3], (u, v, _): &([f64; 3], [f64; 3], [f64; 3])| {
        let d = [p[0] - pbar[0], p[1] - pbar[1], p[2] - pbar[2]];
        [dot3(u, &d), dot3(v, &d)]
    };
    // Givens path: the centred rows need J̄ first (one more Jacobian pass), and a plane's
    // rows their tilts' fit.
    let pre_centre = centred && !ws.to_gram;
    if pre_centre && w_sum > 0.0 {
        for c in contacts.iter().filter(|c| c.weight > 0.0) {
            let p = contact_rows(robot, c, n_cols, ws, &mut rows)?;
            for (jb, r) in jbar.iter_mut().zip(rows.iter()) {
                for (x, y) in jb.iter_mut().zip(r.iter()).take(n_cols) {
                    *x += c.weight / w_sum * y;
                }
            }
            if let Some(tl) = &tilt {
                let t = t_of(&p, tl);
                let [r0, r1, r2, b0, b1, _] = &mut rows;
                let js = r0.iter().zip(r1.iter()).zip(r2.iter());
                for (((x, y), z), (b0, b1)) in js.zip(b0.iter_mut().zip(b1.iter_mut())).take(n_cols)
                {
                    let nj = normal[0] * x + normal[1] * y + normal[2] * z;
                    *b0 += c.weight * t[0] * nj;
                    *b1 += c.weight * t[1] * nj;
                }
            }
        }
        if let Some((_, _, l)) = &tilt {
            // M⁻¹B = L⁻ᵀL⁻¹B, column by column.
            let [.., b0, b1, _] = &mut rows;
            for (b0, b1) in b0.iter_mut().zip(b1.iter_mut()).take(n_cols) {
                let y0 = *b0 / l[0];
                *b1 = (*b1 - l[1] * y0) / l[2] / l[2];
                *b0 = (y0 - l[1] * *b1) / l[0];
            }
        }
    }
    let mut jsum = [[0.0; P]; 3];
    let mut cost = 0.0;
    for c in contacts.iter().filter(|c| c.weight > 0.0) {
        let p = contact_rows(robot, c, n_cols, ws, &mut rows)?;
        if !pre_centre {
            for (js, r) in jsum.iter_mut().zip(rows.iter()) {
                for (x, y) in js.iter_mut().zip(r.iter()).take(n_cols) {
                    *x += c.weight * y;
                }
            }
        }
        if pre_centre {
            for (r, jb) in rows.iter_mut().zip(jbar.iter()) {
                for (x, y) in r.iter_mut().zip(jb.iter()).take(n_cols) {
                    *x -= y;
                }
            }
        }
        let wp = c.weight * opts.weight_pos;
        let mut e = [0.0; 6];
        let mut w = [0.0; 6];
        match g.kind {
            GroupKind::Target | GroupKind::KnownTarget(_) => {
                let t = match g.kind {
                    GroupKind::KnownTarget(x) => x,
                    _ => pbar,
                };
                for k in 0..3 {
                    e[k] = t[k] - p[k];
                    w[k] = wp;
                }
            }
            GroupKind::Plane | GroupKind::KnownPlane { .. } => {
                e[0] = match g.kind {
                    GroupKind::KnownPlane { offset_m, .. } => offset_m - dot3(&normal, &p),
                    _ => -dot3(&normal, &[p[0] - pbar[0], p[1] - pbar[1], p[2] - pbar[2]]),
                };
                w[0] = wp;
                let [r0, r1, r2, b0, b1, ..] = &mut rows;
                for ((x, y), z) in r0.iter_mut().zip(r1.iter()).zip(r2.iter()).take(n_cols) {
                    *x = normal[0] * *x + normal[1] * y + normal[2] * z;
                }
                if let Some(tl) = &tilt {
                    let t = t_of(&p, tl);
                    for ((x, b0), b1) in r0
                        .iter_mut()
                        .zip(b0.iter_mut())
                        .zip(b1.iter_mut())
                        .take(n_cols)
                    {
                        if pre_centre {
                            // The row less its fit on the tilts (`M⁻¹B` in rows 3, 4).
                            *x -= t[0] * *b0 + t[1] * *b1;
                        } else {
                            *b0 += c.weight * t[0] * *x;
                            *b1 += c.weight * t[1] * *x;
                        }
                    }
                }
            }
        }
        cost += (0..6).map(|k| w[k] * e[k] * e[k]).sum::<f64>();
        if !with_rhs {
            e = [0.0; 6];
        }
        fold6(ws, &rows, &e, &w)?;
    }
    if !pre_centre && w_sum > 0.0 {
        for (jb, js) in jbar.iter_mut().zip(jsum.iter()) {
            for (x, y) in jb.iter_mut().zip(js.iter()).take(n_cols) {
                *x = y / w_sum;
            }
        }
        if centred && !ws.cost_only {
            let wd = w_sum * opts.weight_pos;
            if g.kind == GroupKind::Target {
                for jb in &jbar {
                    ws.gram.downdate(jb.get(..n_cols).unwrap_or(&[]), wd)?;
                }
            } else {
                let mut nj = [0.0; P];
                for (j, x) in nj.iter_mut().enumerate().take(n_cols) {
                    *x = normal[0] * jbar[0][j] + normal[1] * jbar[1][j] + normal[2] * jbar[2][j];
                }
                ws.gram.downdate(nj.get(..n_cols).unwrap_or(&[]), wd)?;
                if let Some((_, _, l)) = &tilt {
                    // − BᵀM⁻¹B = − (L⁻¹B)ᵀ(L⁻¹B): two rows.
                    let [.., b0, b1, _] = &mut rows;
                    for (y0, y1) in b0.iter_mut().zip(b1.iter_mut()).take(n_cols) {
                        *y0 /= l[0];
                        *y1 = (*y1 - l[1] * *y0) / l[2];
                    }
                    ws.gram
                        .downdate(b0.get(..n_cols).unwrap_or(&[]), opts.weight_pos)?;
                    ws.gram
                        .downdate(b1.get(..n_cols).unwrap_or(&[]), opts.weight_pos)?;
                }
            }
        }
    }
    if g.kind.is_target() {
        cache_mean(data, gi, w_sum, pbar, &jbar, ws);
    }
    Ok(cost)
}

/// Keeps target `gi`'s mean for the distances that name it (see [`MEAN_CACHE`]).
fn cache_mean<const N: usize, const P: usize>(
    data: &ConstraintData<'_, N>,
    gi: usize,
    w: f64,
    p: [f64; 3],
    jbar: &[[f64; P]; 3],
    ws: &mut Workspace<P>,
) {
    let named = data.distances.iter().any(|d| d.a == gi || d.b == gi);
    if let Some(m) = ws.means.get_mut(gi % MEAN_CACHE).filter(|_| named) {
        m.group = gi;
        m.w = w;
        m.p = p;
        m.jbar = *jbar;
    }
}

/// [`fold_group`] of an unknown target on the normal-equation path in one pass (Jacobian
/// and tool point of each contact; no separate forward-kinematics pass for `p̄`): the rows
/// `(J_i, ō − p_i)` are folded with `ō` the first contact's point, and the Gram matrix,
/// right-hand side and cost are then centred by [`GramAccumulator::downdate_with_rhs`]
/// (`Σ w(J_i − J̄)ᵀ(p̄ − p_i) = Σ wJ_iᵀ(ō − p_i) + W·J̄ᵀ(p̄ − ō)`, and likewise for the cost).
///
/// [`GramAccumulator::downdate_with_rhs`]: crate::linalg::gram::GramAccumulator::downdate_with_rhs
fn fold_target_once<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    gi: usize,
    with_rhs: bool,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    if ws.cost_only {
        return target_cost(robot, data, gi, opts, ws);
    }
    let g = data
        .groups
        .get(gi)
        .copied()
        .ok_or(Error::BadGroup { group: gi })?;
    let mut rows = [[0.0; P]; 6];
    let mut jsum = [[0.0; P]; 3];
    let mut origin: Option<[f64; 3]> = None;
    let (mut w_sum, mut s1, mut s2) = (0.0, [0.0; 3], 0.0);
    for c in data.group_contacts(&g).iter().filter(|c| c.weight > 0.0) {
        let p = contact_rows(robot, c, n_cols, ws, &mut rows)?;
        let o = *origin.get_or_insert(p);
        let fold_rows = !ws.cost_only;
        for (js, r) in jsum.iter_mut().zip(rows.iter()).filter(|_| fold_rows) {
            for (x, y) in js.iter_mut().zip(r.iter()).take(n_cols) {
                *x += c.weight * y;
            }
        }
        let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        w_sum += c.weight;
        for k in 0..3 {
            s1[k] += c.weight * d[k];
        }
        s2 += c.weight * dot3(&d, &d);
        let wp = c.weight * opts.weight_pos;
        let e = if with_rhs {
            [-d[0], -d[1], -d[2], 0.0, 0.0, 0.0]
        } else {
            [0.0; 6]
        };
        fold6(ws, &rows, &e, &[wp, wp, wp, 0.0, 0.0, 0.0])?;
    }
    let Some(o) = origin else {
        return Ok(0.0);
    };
    let dbar = [s1[0] / w_sum, s1[1] / w_sum, s1[2] / w_sum];
    let mut jbar = [[0.0; P]; 3];
    for (jb, js) in jbar.iter_mut().zip(jsum.iter()) {
        for (x, y) in jb.iter_mut().zip(js.iter()).take(n_cols) {
            *x = y / w_sum;
        }
    }
    let wd = w_sum * opts.weight_pos;
    for (jb, &db) in jbar.iter().zip(dbar.iter()) {
        if ws.cost_only {
            break;
        }
        let b = if with_rhs { -db } else { 0.0 };
        ws.gram
            .downdate_with_rhs(jb.get(..n_cols).unwrap_or(&[]), b, wd)?;
    }
    let pbar = [o[0] + dbar[0], o[1] + dbar[1], o[2] + dbar[2]];
    cache_mean(data, gi, w_sum, pbar, &jbar, ws);
    Ok(opts.weight_pos * (s2 - w_sum * dot3(&dbar, &dbar)))
}

/// [`fold_target_once`] of a cost-only pass ([`RowSource::fold_cost`]): the same tool
/// points and the same sums in the same order, so the same cost bit for bit, without the
/// Jacobian rows' scratch (zeroing it cost about as much as the sums); caches the mean
/// point (not `J̄`, which a cost-only pass never uses).
fn target_cost<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    gi: usize,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    let g = data
        .groups
        .get(gi)
        .copied()
        .ok_or(Error::BadGroup { group: gi })?;
    let mut origin: Option<[f64; 3]> = None;
    let (mut w_sum, mut s1, mut s2) = (0.0, [0.0; 3], 0.0);
    for c in data.group_contacts(&g).iter().filter(|c| c.weight > 0.0) {
        let p = c.tool_point(robot)?;
        let o = *origin.get_or_insert(p);
        let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        w_sum += c.weight;
        for k in 0..3 {
            s1[k] += c.weight * d[k];
        }
        s2 += c.weight * dot3(&d, &d);
    }
    let Some(o) = origin else {
        return Ok(0.0);
    };
    let dbar = [s1[0] / w_sum, s1[1] / w_sum, s1[2] / w_sum];
    let pbar = [o[0] + dbar[0], o[1] + dbar[1], o[2] + dbar[2]];
    let named = data.distances.iter().any(|d| d.a == gi || d.b == gi);
    if let Some(m) = ws.means.get_mut(gi % MEAN_CACHE).filter(|_| named) {
        m.group = gi;
        m.w = w_sum;
        m.p = pbar;
    }
    Ok(opts.weight_pos * (s2 - w_sum * dot3(&dbar, &dbar)))
}

/// Weight and mean point of group `gi` ([`group_mean`] without copying its `J̄`).
fn mean_point<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    gi: usize,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<(f64, [f64; 3])> {
    if let Some(m) = ws.means.iter().find(|m| m.group == gi) {
        return Ok((m.w, m.p));
    }
    group_mean(robot, data, gi, n_cols, ws).map(|m| (m.w, m.p))
}

/// The mean of group `gi` from the cache, or computed (one Jacobian pass).
fn group_mean<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    gi: usize,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<GroupMean<P>> {
    if let Some(m) = ws.means.iter().find(|m| m.group == gi) {
        return Ok(*m);
    }
    let g = data
        .groups
        .get(gi)
        .copied()
        .ok_or(Error::BadGroup { group: gi })?;
    let contacts = data.group_contacts(&g);
    let mut out = GroupMean::<P>::EMPTY;
    out.group = gi;
    let mut rows = [[0.0; P]; 6];
    let mut s1 = [0.0; 3];
    for c in contacts.iter().filter(|c| c.weight > 0.0) {
        let p = contact_rows(robot, c, n_cols, ws, &mut rows)?;
        out.w += c.weight;
        for k in 0..3 {
            s1[k] += c.weight * p[k];
        }
        for (jb, r) in out.jbar.iter_mut().zip(rows.iter()) {
            for (x, y) in jb.iter_mut().zip(r.iter()).take(n_cols) {
                *x += c.weight * y;
            }
        }
    }
    if out.w > 0.0 {
        let w = out.w;
        out.p = [s1[0] / w, s1[1] / w, s1[2] / w];
        for jb in out.jbar.iter_mut() {
            for x in jb.iter_mut() {
                *x /= w;
            }
        }
    }
    Ok(out)
}

fn fold_distance<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    di: usize,
    with_rhs: bool,
    opts: &IdentifyOptions<'_>,
    n_cols: usize,
    ws: &mut Workspace<P>,
) -> Result<f64> {
    let d = data
        .distances
        .get(di)
        .copied()
        .ok_or(Error::BadDistance { distance: di })?;
    if ws.cost_only {
        // The cached means' points alone (copying `J̄` would cost more than the rest).
        let (wa, pa) = mean_point(robot, data, d.a, n_cols, ws)?;
        let (wb, pb) = mean_point(robot, data, d.b, n_cols, ws)?;
        if wa <= 0.0 || wb <= 0.0 {
            return Ok(0.0);
        }
        let diff = [pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]];
        let len = sqrt(dot3(&diff, &diff));
        if len <= 0.0 {
            return Err(Error::DegenerateGroup { group: d.a });
        }
        let e = d.m - len;
        // A cost-only pass (`RowSource::fold_cost`) folds nothing.
        return Ok(opts.weight_pos * d.weight * e * e);
    }
    let ma = group_mean(robot, data, d.a, n_cols, ws)?;
    let mb = group_mean(robot, data, d.b, n_cols, ws)?;
    if ma.w <= 0.0 || mb.w <= 0.0 {
        return Ok(0.0);
    }
    let diff = [ma.p[0] - mb.p[0], ma.p[1] - mb.p[1], ma.p[2] - mb.p[2]];
    let len = sqrt(dot3(&diff, &diff));
    if len <= 0.0 {
        return Err(Error::DegenerateGroup { group: d.a });
    }
    let u = [diff[0] / len, diff[1] / len, diff[2] / len];
    let mut row = [0.0; P];
    for (j, x) in row.iter_mut().enumerate().take(n_cols) {
        *x = (0..3).map(|k| u[k] * (ma.jbar[k][j] - mb.jbar[k][j])).sum();
    }
    let e = d.m - len;
    let w = opts.weight_pos * d.weight;
    let b = if with_rhs { e } else { 0.0 };
    let a = row.get(..n_cols).unwrap_or(&[]);
    if ws.to_gram {
        ws.gram.add_row_weighted(a, b, w)?;
    } else {
        ws.lsq.add_row_weighted(a, b, w)?;
    }
    Ok(w * e * e)
}

/// Residuals of one active contact given its group's `p̄` and normal: `(|e|, e·w·e)`.
fn contact_residual<const N: usize>(
    robot: &Robot<N>,
    c: &Contact<N>,
    kind: GroupKind,
    pbar: [f64; 3],
    normal: [f64; 3],
) -> Result<f64> {
    let p = c.tool_point(robot)?;
    Ok(match kind {
        GroupKind::Target | GroupKind::KnownTarget(_) => {
            let t = match kind {
                GroupKind::KnownTarget(x) => x,
                _ => pbar,
            };
            let e = [t[0] - p[0], t[1] - p[1], t[2] - p[2]];
            sqrt(dot3(&e, &e))
        }
        GroupKind::KnownPlane { offset_m, .. } => (offset_m - dot3(&normal, &p)).abs(),
        GroupKind::Plane => dot3(&normal, &[p[0] - pbar[0], p[1] - pbar[1], p[2] - pbar[2]]).abs(),
    })
}

/// The residual distance (3-D for targets, to the plane for planes) at `robot` of the
/// contacts `from..from + out.len()` into `out`, each group's target or plane estimated
/// from its contacts with a positive weight as the fit eliminates it; contacts with weight
/// 0 (held out) are measured against that estimate too. Errors: as [`group_estimate`].
pub(crate) fn contact_residuals_range<const N: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    from: usize,
    out: &mut [f64],
) -> Result<()> {
    let to = from + out.len();
    for (g, grp) in data.groups.iter().enumerate() {
        let (lo, hi) = (grp.start.max(from), (grp.start + grp.len).min(to));
        if lo >= hi {
            continue;
        }
        let e = group_estimate(robot, data, g)?;
        let contacts = data.contacts.get(lo..hi).unwrap_or(&[]);
        let slots = out.get_mut(lo - from..hi - from).unwrap_or(&mut []);
        for (c, slot) in contacts.iter().zip(slots.iter_mut()) {
            *slot = contact_residual(robot, c, grp.kind, e.point, e.normal)?;
        }
    }
    Ok(())
}

/// What a group's contacts say at a model: the estimated target or plane and the scatter
/// of the predicted tool points about it (the consistency of the data with the model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupEstimate {
    /// Kind of the group.
    pub kind: GroupKind,
    /// Contacts with a positive weight.
    pub contacts: usize,
    /// Mean predicted tool point: the estimated target \[m\] (for planes, a point on it).
    pub point: [f64; 3],
    /// Plane normal (unit; zero for targets).
    pub normal: [f64; 3],
    /// Plane offset `normal·p` \[m\] (0 for targets).
    pub offset_m: f64,
    /// RMS of the residual distance of the contacts (3-D for targets, to the plane for
    /// planes) \[m\].
    pub rms_m: f64,
    /// Largest residual distance \[m\].
    pub max_m: f64,
    /// Mean residual distance \[m\] (MUKCa's "mean absolute consistency error").
    pub mean_m: f64,
    /// Planes: RMS spread of the contacts across their best-fit line over their RMS
    /// extent along it (`sqrt(λ₂/λ₃)` of the scatter): near 0 for contacts along a line,
    /// whose plane is undetermined. 0 for targets.
    pub aspect: f64,
}

/// The estimate of group `g` at `robot` from its contacts with a positive weight.
/// Errors: an invalid group, a degenerate plane, kinematics errors.
pub fn group_estimate<const N: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    g: usize,
) -> Result<GroupEstimate> {
    let grp = data
        .groups
        .get(g)
        .copied()
        .ok_or(Error::BadGroup { group: g })?;
    let contacts = data.group_contacts(&grp);
    let (w, pbar, scatter) = point_moments(robot, contacts)?;
    let mut aspect = 0.0;
    let (normal, offset_m) = match grp.kind {
        GroupKind::Plane if w > 0.0 => {
            let n = plane_normal(scatter, g)?;
            let (ev, _) = sym3_smallest(scatter);
            aspect = sqrt(ev[1].max(0.0) / ev[2]);
            (n, dot3(&n, &pbar))
        }
        GroupKind::KnownPlane { normal, offset_m } => (unit_normal(normal), offset_m),
        _ => ([0.0; 3], 0.0),
    };
    let mut out = GroupEstimate {
        kind: grp.kind,
        contacts: 0,
        point: pbar,
        normal,
        offset_m,
        rms_m: 0.0,
        max_m: 0.0,
        mean_m: 0.0,
        aspect,
    };
    let mut s = 0.0;
    for c in contacts.iter().filter(|c| c.weight > 0.0) {
        let r = contact_residual(robot, c, grp.kind, pbar, normal)?;
        out.contacts += 1;
        s += r * r;
        out.mean_m += r;
        out.max_m = out.max_m.max(r);
    }
    if out.contacts > 0 {
        out.rms_m = sqrt(s / out.contacts as f64);
        out.mean_m /= out.contacts as f64;
    }
    Ok(out)
}

/// The distance `‖p̄_a − p̄_b‖` \[m\] the model predicts for known distance `k` (compare
/// with `data.distances[k].m`); `None` when a group has no active contact.
pub fn distance_estimate<const N: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    k: usize,
) -> Result<Option<f64>> {
    let d = data
        .distances
        .get(k)
        .copied()
        .ok_or(Error::BadDistance { distance: k })?;
    let ga = data
        .groups
        .get(d.a)
        .ok_or(Error::BadDistance { distance: k })?;
    let gb = data
        .groups
        .get(d.b)
        .ok_or(Error::BadDistance { distance: k })?;
    let (wa, pa, _) = point_moments(robot, data.group_contacts(ga))?;
    let (wb, pb, _) = point_moments(robot, data.group_contacts(gb))?;
    if wa <= 0.0 || wb <= 0.0 {
        return Ok(None);
    }
    let diff = [pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]];
    Ok(Some(sqrt(dot3(&diff, &diff))))
}

impl<const N: usize> RowSource<N> for ConstraintData<'_, N> {
    fn validate(&self) -> Result<()> {
        validate_instrument(self.instrument)?;
        self.validate_sessions()?;
        let base = self.instrument.len();
        for (i, c) in self.contacts.iter().enumerate() {
            let index = base + i;
            c.state.validate().map_err(|e| match e {
                Error::NonFinite { what, .. } => Error::NonFinite { what, index },
                other => other,
            })?;
            if check_finite(&c.point, Quantity::Position).is_err() {
                return Err(Error::NonFinite {
                    what: Quantity::Position,
                    index,
                });
            }
            if !(c.weight.is_finite() && c.weight >= 0.0) {
                return Err(Error::NonFinite {
                    what: Quantity::Setting,
                    index,
                });
            }
        }
        let mut next = 0;
        for (gi, g) in self.groups.iter().enumerate() {
            let bad = Error::BadGroup { group: gi };
            if g.start != next || g.len < g.kind.min_contacts() {
                return Err(bad);
            }
            next = g.start.checked_add(g.len).ok_or(bad)?;
            let finite = match g.kind {
                GroupKind::KnownTarget(x) => check_finite(&x, Quantity::Position).is_ok(),
                GroupKind::KnownPlane { normal, offset_m } => {
                    check_finite(&normal, Quantity::Position).is_ok()
                        && offset_m.is_finite()
                        && dot3(&normal, &normal) > 0.0
                }
                _ => true,
            };
            if !finite {
                return Err(bad);
            }
        }
        if next != self.contacts.len() {
            return Err(Error::BadGroup {
                group: self.groups.len(),
            });
        }
        for (k, d) in self.distances.iter().enumerate() {
            let target = |g: usize| self.groups.get(g).is_some_and(|g| g.kind.is_target());
            let ok = d.a != d.b
                && target(d.a)
                && target(d.b)
                && d.m.is_finite()
                && d.m > 0.0
                && d.weight.is_finite()
                && d.weight >= 0.0;
            if !ok {
                return Err(Error::BadDistance { distance: k });
            }
        }
        Ok(())
    }

    fn check_inputs(&self, opts: &IdentifyOptions<'_>) -> Result<()> {
        let states = self
            .instrument
            .iter()
            .map(|m| &m.state)
            .chain(self.contacts.iter().map(|c| &c.state));
        super::solvers::check_effect_inputs(states, opts)
    }

    /// Residual rows minus the eliminated nuisance parameters (3 per unknown target or
    /// plane with an active contact): the degrees of freedom σ² divides by.
    fn row_count(&self, opts: &IdentifyOptions<'_>) -> usize {
        let mut rows = self.instrument.row_count(opts);
        // 6 per instrument session with an active row (its frame).
        let mut nuisance = 6
            * (0..self.sessions.len())
                .filter(|&s| self.session_rows(s).iter().any(|m| m.weight > 0.0))
                .count();
        for g in self.groups {
            let n = self
                .group_contacts(g)
                .iter()
                .filter(|c| c.weight > 0.0)
                .count();
            rows += n * if g.kind.is_target() { 3 } else { 1 };
            if n > 0 && matches!(g.kind, GroupKind::Target | GroupKind::Plane) {
                nuisance += 3;
            }
        }
        rows += self.distances.len();
        rows.saturating_sub(nuisance)
    }

    fn fold<const P: usize>(
        &self,
        robot: &Robot<N>,
        with_rhs: bool,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        ws: &mut Workspace<P>,
    ) -> Result<f64> {
        self.fold_until(robot, with_rhs, opts, n_cols, f64::INFINITY, ws)
    }

    /// MUKCa: the damped fallback takes `panda_6` from 186 to 10 iterations, every
    /// recording to OPT2's minimum (`core/tests/mukca_convergence.rs`).
    fn damped_fallback(&self) -> bool {
        true
    }
    fn cost(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64> {
        self.cost_from_moments(robot, opts)
    }
    /// The normal-equation fold itself with `ws.cost_only` set: the same code and the same
    /// tool points (forward kinematics is the Jacobian's chain), so the same cost bit for
    /// bit, without Jacobians or folding; it stops after the first group (with its
    /// distances) whose running sum exceeds `stop_above` (see [`STOP_MARGIN`]). Not with
    /// instrument rows (their fold has no such mode).
    fn fold_cost<const P: usize>(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        stop_above: f64,
        ws: &mut Workspace<P>,
    ) -> Result<Option<f64>> {
        if !self.instrument.is_empty() || !self.sessions.is_empty() {
            return Ok(None);
        }
        // `to_gram` selects the normal-equation path (its cost arithmetic) of each group.
        let to_gram = core::mem::replace(&mut ws.to_gram, true);
        ws.cost_only = true;
        let c = self.fold_until(robot, true, opts, n_cols, stop_above, ws);
        ws.cost_only = false;
        ws.to_gram = to_gram;
        c.map(Some)
    }

    fn stats(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<ResidualStats> {
        let mut s = self.instrument_stats(robot, opts)?;
        let n_inst = s.pos_poses;
        let (cost, sum2, max, n) = self.cost_and_sums(robot, opts)?;
        let sp = s.rms_pos_m * s.rms_pos_m * n_inst as f64 + sum2;
        let np = n_inst + n;
        s.poses += n;
        s.pos_poses = np;
        s.rows = self.row_count(opts);
        s.cost = cost;
        s.max_pos_m = s.max_pos_m.max(max);
        s.rms_pos_m = if np > 0 { sqrt(sp / np as f64) } else { 0.0 };
        Ok(s)
    }
}

/// A cost pass ([`RowSource::fold_cost`]) stops once its running sum exceeds the bound by
/// this much (relative): every term it adds is a weighted sum of squares (a target's
/// scatter `Σw|p − p̄|²`, a distance's `w·e²`), never below 0 but for a rounding error of a
/// few ulps of the group's own sum of squares, so a running sum this far above the bound
/// ends above it: the trial is rejected as the whole sum would reject it. (A trial whose
/// later groups would fail, e.g. non-finite tool points, is then rejected instead of
/// reporting that error; those groups are evaluated only if the trial is accepted.)
pub(crate) const STOP_MARGIN: f64 = 1e-9;

impl<const N: usize> ConstraintData<'_, N> {
    /// [`RowSource::fold`], stopping after the first group (with the distances it closes)
    /// at which the running cost exceeds `stop_above` by [`STOP_MARGIN`]: the value
    /// returned is then that running cost (above `stop_above`), not the whole sum.
    fn fold_until<const P: usize>(
        &self,
        robot: &Robot<N>,
        with_rhs: bool,
        opts: &IdentifyOptions<'_>,
        n_cols: usize,
        stop_above: f64,
        ws: &mut Workspace<P>,
    ) -> Result<f64> {
        let stop = stop_above + STOP_MARGIN * stop_above.abs();
        // Base and tool rotation columns only when one is selected (contact fits select
        // the tool translation at most: the rotations are gauges of point contacts).
        let selected = ws.cols.get(..n_cols).unwrap_or(&[]);
        ws.frame_rotations = selected.iter().any(|&c| {
            FrameParam::ALL
                .into_iter()
                .skip(3)
                .any(|k| c == ParamId::Base(k).index(N).0 || c == ParamId::Tool(k).index(N).0)
        });
        let mut c = 0.0;
        ws.torques.bind(robot);
        for (l, m) in self.instrument.iter().enumerate() {
            if m.weight > 0.0 && !self.in_session(l) {
                c += add_rows(robot, l, m, with_rhs, opts, n_cols, ws)?;
            }
        }
        for s in 0..self.sessions.len() {
            let rows = self.session_rows(s);
            c += fold_session(robot, rows, with_rhs, opts, n_cols, ws)?;
        }
        for m in ws.means.iter_mut() {
            m.group = usize::MAX;
        }
        for gi in 0..self.groups.len() {
            c += fold_group(robot, self, gi, with_rhs, opts, n_cols, ws)?;
            for (di, d) in self.distances.iter().enumerate() {
                if d.a.max(d.b) == gi {
                    c += fold_distance(robot, self, di, with_rhs, opts, n_cols, ws)?;
                }
            }
            if c > stop {
                break;
            }
        }
        Ok(c)
    }

    /// The instrument rows' cost: in the base frame, or each session's rows in its own
    /// fitted frame when there are sessions.
    fn instrument_cost(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64> {
        if self.sessions.is_empty() {
            super::data::cost(robot, self.instrument, opts)
        } else {
            Ok(self.instrument_stats(robot, opts)?.cost)
        }
    }

    /// The cost from each group's moments, one forward-kinematics pass over the contacts
    /// (the solvers' trial evaluations): with `S = Σ w(p − p̄)(p − p̄)ᵀ` and `W = Σ w`, a
    /// target costs `tr S`, a known target `tr S + W|x − p̄|²`, a plane `nᵀSn` (`n` its
    /// normal), a known plane `nᵀSn + W(c − n·p̄)²` — the sums of squared residuals of
    /// [`Self::cost_and_sums`], which [`RowSource::stats`] keeps for the RMS and maximum. A
    /// distance takes its targets' means from the last [`MEAN_CACHE`] groups, or
    /// recomputes them.
    fn cost_from_moments(&self, robot: &Robot<N>, opts: &IdentifyOptions<'_>) -> Result<f64> {
        let mut cost = self.instrument_cost(robot, opts)?;
        let mut means = [(usize::MAX, 0.0, [0.0; 3]); MEAN_CACHE];
        for (gi, g) in self.groups.iter().enumerate() {
            let (w, pbar, s) = point_moments(robot, self.group_contacts(g))?;
            if let Some(m) = means.get_mut(gi % MEAN_CACHE) {
                *m = (gi, w, pbar);
            }
            if w > 0.0 {
                let spread = |n: &[f64; 3]| {
                    (0..3)
                        .map(|a| n[a] * (0..3).map(|b| s[a][b] * n[b]).sum::<f64>())
                        .sum::<f64>()
                };
                let sq = match g.kind {
                    GroupKind::Target => s[0][0] + s[1][1] + s[2][2],
                    GroupKind::KnownTarget(x) => {
                        let d = [x[0] - pbar[0], x[1] - pbar[1], x[2] - pbar[2]];
                        s[0][0] + s[1][1] + s[2][2] + w * dot3(&d, &d)
                    }
                    GroupKind::Plane => spread(&plane_normal(s, gi)?),
                    GroupKind::KnownPlane { normal, offset_m } => {
                        let n = unit_normal(normal);
                        let e = offset_m - dot3(&n, &pbar);
                        spread(&n) + w * e * e
                    }
                };
                cost += opts.weight_pos * sq;
            }
            for d in self.distances.iter().filter(|d| d.a.max(d.b) == gi) {
                let mean = |k: usize| -> Result<(f64, [f64; 3])> {
                    if let Some(&(_, w, p)) = means.iter().find(|m| m.0 == k) {
                        return Ok((w, p));
                    }
                    let grp = self.groups.get(k).ok_or(Error::BadGroup { group: k })?;
                    let (w, p, _) = point_moments(robot, self.group_contacts(grp))?;
                    Ok((w, p))
                };
                let ((wa, pa), (wb, pb)) = (mean(d.a)?, mean(d.b)?);
                if wa > 0.0 && wb > 0.0 {
                    let diff = [pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]];
                    let e = d.m - sqrt(dot3(&diff, &diff));
                    cost += opts.weight_pos * d.weight * e * e;
                }
            }
        }
        Ok(cost)
    }

    /// Cost, Σ|e|² and max |e| over the active contacts (3-D for targets, 1-D for planes),
    /// number of active contacts.
    fn cost_and_sums(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
    ) -> Result<(f64, f64, f64, usize)> {
        let mut cost = self.instrument_cost(robot, opts)?;
        let (mut s2, mut max, mut n) = (0.0, 0.0f64, 0);
        for (gi, g) in self.groups.iter().enumerate() {
            let contacts = self.group_contacts(g);
            let (w, pbar, scatter) = point_moments(robot, contacts)?;
            if w <= 0.0 {
                continue;
            }
            let normal = match g.kind {
                GroupKind::Plane => plane_normal(scatter, gi)?,
                GroupKind::KnownPlane { normal, .. } => unit_normal(normal),
                _ => [0.0; 3],
            };
            for c in contacts.iter().filter(|c| c.weight > 0.0) {
                let r = contact_residual(robot, c, g.kind, pbar, normal)?;
                cost += c.weight * opts.weight_pos * r * r;
                s2 += r * r;
                max = max.max(r);
                n += 1;
            }
        }
        for (k, d) in self.distances.iter().enumerate() {
            if let Some(len) = distance_estimate(robot, self, k)? {
                let e = d.m - len;
                cost += opts.weight_pos * d.weight * e * e;
            }
        }
        Ok((cost, s2, max, n))
    }
}

/// The distinct tool points of the active rows (instrument points, contact points), at
/// most [`super::data::MAX_STRUCTURAL_POINTS`].
fn distinct_points<const N: usize>(
    data: &ConstraintData<'_, N>,
) -> (
    [Option<[f64; 3]>; super::data::MAX_STRUCTURAL_POINTS],
    usize,
) {
    let (mut out, mut n) = super::data::distinct_points(data.instrument);
    for c in data.contacts.iter().filter(|c| c.weight > 0.0) {
        let p = if c.point == [0.0; 3] {
            None
        } else {
            Some(c.point)
        };
        if n == out.len() {
            break;
        }
        if !out[..n].contains(&p) {
            out[n] = p;
            n += 1;
        }
    }
    (out, n)
}

/// The identifiability analysis of constraint data (see the module doc on the gauge):
/// structural test as for instrument data (position rows of the tool points), then the
/// gauge (base frame, scale) is set aside and named, then the greedy rank test on the
/// reduced Jacobian at `robot`.
pub fn analyze_constrained<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<Identifiability> {
    let mut out = Identifiability::empty(opts.requested);
    analyze_constrained_into(robot, data, opts, ws, &mut out)?;
    Ok(out)
}

fn analyze_constrained_into<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identifiability,
) -> Result<()> {
    data.validate()?;
    let requested = opts.requested;
    let p = requested.len();
    if p == 0 {
        return Err(Error::TooFewData {
            found: 0,
            needed: 1,
        });
    }
    if p > P {
        return Err(Error::CapacityExceeded {
            needed: p,
            capacity: P,
        });
    }
    if let Some(bad) = requested.iter().find(|&i| i >= Robot::<N>::NUM_PARAMS) {
        return Err(Error::DimensionMismatch {
            expected: Robot::<N>::NUM_PARAMS,
            found: bad + 1,
        });
    }
    let mut union = 0u8;
    let (mut any_approach, mut any_temp) = (false, false);
    for m in data.instrument.iter().filter(|m| m.weight > 0.0) {
        union |= m.mask.0;
        any_approach |= m.state.approach.is_some();
        any_temp |= m.state.temp_c.is_some();
    }
    for c in data.contacts.iter().filter(|c| c.weight > 0.0) {
        union |= ComponentMask::POSITION.0;
        any_approach |= c.state.approach.is_some();
        any_temp |= c.state.temp_c.is_some();
    }
    if union == 0 {
        return Err(Error::TooFewData {
            found: 0,
            needed: p,
        });
    }
    let (points, n_points) = distinct_points(data);
    out.reset(requested);
    let external = data.has_external_reference();
    let sel = StructuralSel {
        mask: ComponentMask(union),
        points: points.get(..n_points).unwrap_or(&[]),
        any_approach,
        any_temp,
        base_first: !external,
    };
    let n_struct =
        structural_step_with(robot, &sel, opts, ws, &mut out.structural, &mut out.partner)?;
    if !external {
        // Link parameters that only duplicate a rigid motion of the base: gauge too.
        let is_base =
            |i: usize| matches!(ParamId::from_index(ParamIndex(i), N), Ok(ParamId::Base(_)));
        for col in 0..super::MAX_MODEL_PARAMS {
            let partner_base = out
                .partner
                .get(col)
                .copied()
                .flatten()
                .is_some_and(|p| is_base(p.param.0));
            if out.structural.contains(col) && partner_base {
                out.structural.remove(col);
                out.gauge.insert(col)?;
            }
        }
    }
    let scale_gauge =
        if data.has_length_reference() || data.prismatic_fixes_scale(robot, &requested) {
            None
        } else {
            scale_gauge_param::<N, P>(robot, ws.free.get(..n_struct).unwrap_or(&[]))
        };
    let mut n = 0;
    for k in 0..n_struct {
        let col = ws.free[k];
        let base = matches!(
            ParamId::from_index(ParamIndex(col), N),
            Ok(ParamId::Base(_))
        );
        if base && !external {
            if requested.contains(col) {
                out.gauge.insert(col)?;
            }
        } else if scale_gauge == Some(col) {
            out.gauge.insert(col)?;
        } else {
            ws.cols[n] = col;
            n += 1;
        }
    }
    data_step(robot, data, opts, ws, out, n)
}

/// The scale gauge: the non-base length parameter among `cols` with the largest nominal
/// magnitude (fixing it fixes the scale; one of value 0 would not).
fn scale_gauge_param<const N: usize, const P: usize>(
    robot: &Robot<N>,
    cols: &[usize],
) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for &col in cols {
        let Ok(id) = ParamId::from_index(ParamIndex(col), N) else {
            continue;
        };
        if !id.is_length() || matches!(id, ParamId::Base(_)) {
            continue;
        }
        let v = robot.param(ParamIndex(col)).unwrap_or(0.0).abs();
        if v > 0.0 && best.is_none_or(|(_, b)| v > b) {
            best = Some((col, v));
        }
    }
    best.map(|(c, _)| c)
}

/// Identifies the identifiable subset of `opts.requested` from constraint data (see the
/// module doc), starting at `robot`. Same solvers, options and result as
/// [`super::identify`]; `analysis.gauge` names what the data cannot see at all.
///
/// Errors: as [`super::identify`], plus [`Error::BadGroup`], [`Error::DegenerateGroup`],
/// [`Error::BadDistance`].
pub fn identify_constrained<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<Identification<N>> {
    let mut out = Identification::start(robot, opts.algorithm, None);
    data.validate()?;
    super::solvers::check_identify_options(opts)?;
    super::solvers::check_inputs(data, opts)?;
    analyze_constrained_into(robot, data, opts, ws, &mut out.analysis)?;
    super::solvers::identify_into(data, opts, ws, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    //! The reduced rows against finite differences: `Jᵀe` (the normal-equation right-hand
    //! side) is `−½∇cost` for every kind of row (exact for targets and distances, and for
    //! planes by the eigenvalue derivative), and for targets the Gram matrix equals `JᵀJ`
    //! of the finite-difference Jacobian of the centred residuals; the Givens path gives
    //! the same normal equations as the Gram path.
    use super::*;
    use crate::aria;
    use crate::identify::Algorithm;
    use crate::params::ParamSet;
    extern crate std;
    use std::boxed::Box;

    type Ws = Workspace<48>;

    fn ws() -> Box<Ws> {
        // SAFETY: all-zero is a valid Workspace (documented).
        unsafe { Box::<Ws>::new_zeroed().assume_init() }
    }

    /// Deterministic joint readings around ARIA's tool seed.
    fn q(k: usize) -> [f64; 6] {
        let mut q = aria::TOOL_SEED_Q;
        for (j, v) in q.iter_mut().enumerate() {
            *v += 0.4 * libm::sin(1.7 * k as f64 + 2.3 * j as f64);
        }
        q
    }

    fn contact(k: usize, point: [f64; 3]) -> Contact<6> {
        Contact {
            point,
            ..Contact::new(q(k))
        }
    }

    struct Case {
        instrument: [Measurement<6>; 2],
        contacts: [Contact<6>; 20],
        groups: [Group; 5],
        distances: [Distance; 1],
    }

    /// Two targets with a distance, an unknown plane, a known plane, a known target, and
    /// two partial-coordinate instrument rows; the predicted points are inconsistent (the
    /// readings do not hold anything), so every residual is non-zero.
    fn case() -> Case {
        let p = [0.01, -0.02, 0.05];
        let contacts = core::array::from_fn(|k| contact(k, if k % 2 == 0 { p } else { [0.0; 3] }));
        let mut m0 = Measurement::new(q(40), Transform::identity());
        m0.pose.translation.vector.x = 0.4;
        m0.mask = ComponentMask(0b001);
        let mut m1 = Measurement::new(q(41), Transform::identity());
        m1.pose.translation.vector.y = 0.1;
        m1.pose.translation.vector.z = 0.3;
        m1.mask = ComponentMask(0b110);
        Case {
            instrument: [m0, m1],
            contacts,
            groups: [
                Group {
                    kind: GroupKind::Target,
                    start: 0,
                    len: 4,
                },
                Group {
                    kind: GroupKind::Target,
                    start: 4,
                    len: 5,
                },
                Group {
                    kind: GroupKind::Plane,
                    start: 9,
                    len: 5,
                },
                Group {
                    kind: GroupKind::KnownPlane {
                        normal: [0.1, 0.2, 1.0],
                        offset_m: 0.3,
                    },
                    start: 14,
                    len: 3,
                },
                Group {
                    kind: GroupKind::KnownTarget([0.5, 0.1, 0.4]),
                    start: 17,
                    len: 3,
                },
            ],
            distances: [Distance {
                a: 0,
                b: 1,
                m: 0.05,
                weight: 2.0,
            }],
        }
    }

    fn data(c: &Case) -> ConstraintData<'_, 6> {
        ConstraintData {
            instrument: &c.instrument,
            contacts: &c.contacts,
            groups: &c.groups,
            distances: &c.distances,
            sessions: &[],
        }
    }

    fn params() -> ParamSet {
        let mut s = ParamSet::new();
        for i in 0..Robot::<6>::NUM_GEOMETRIC_PARAMS {
            s.insert(i).unwrap();
        }
        s
    }

    fn fold_all(robot: &Robot<6>, d: &ConstraintData<'_, 6>, gram: bool, ws: &mut Ws) -> f64 {
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let n = params().len();
        for (k, i) in params().iter().enumerate() {
            ws.cols[k] = i;
            ws.colscale[k] = 1.0;
        }
        if gram {
            ws.gram.reset(n).unwrap();
            ws.to_gram = true;
        } else {
            ws.lsq.reset(n).unwrap();
            ws.to_gram = false;
        }
        let c = d.fold(robot, true, &opts, n, ws).unwrap();
        ws.to_gram = false;
        c
    }

    #[test]
    fn gradient_matches_finite_differences_for_every_kind_of_row() {
        let robot = aria::nominal();
        let c = case();
        let d = data(&c);
        d.validate().unwrap();
        let mut ws = ws();
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let cost = fold_all(&robot, &d, true, &mut ws);
        assert!((cost - d.cost(&robot, &opts).unwrap()).abs() <= 1e-12 * cost);
        // The cost from the groups' moments against the sum of every residual's square,
        // and the one-pass target fold's centred bᵀWb against both.
        let summed = d.cost_and_sums(&robot, &opts).unwrap().0;
        assert!((cost - summed).abs() <= 1e-12 * cost, "{cost} vs {summed}");
        assert!((ws.gram.btb() - summed).abs() <= 1e-12 * cost);
        assert!(cost > 1e-4, "residuals must not vanish: {cost}");
        for (k, i) in params().iter().enumerate() {
            let h = 1e-6;
            let at = |x: f64| {
                let mut r = robot;
                r.set_param(ParamIndex(i), x).unwrap();
                d.cost(&r, &opts).unwrap()
            };
            let v = robot.param(ParamIndex(i)).unwrap();
            let fd = -(at(v + h) - at(v - h)) / (4.0 * h);
            let an = ws.gram.atb()[k];
            let scale = an.abs().max(fd.abs()).max(1e-6);
            assert!(
                (an - fd).abs() <= 1e-6 * scale,
                "param {i}: Jᵀe {an} vs FD {fd}"
            );
        }
    }

    #[test]
    fn target_gram_matches_the_finite_difference_jacobian_and_the_givens_path() {
        let robot = aria::nominal();
        let c = case();
        // Targets and the known target only (their rows are linear in the tool points).
        let groups = [c.groups[0], c.groups[1]];
        let d = only_contacts(&c.contacts[..9], &groups);
        // FD Jacobian of the centred residuals p_i − p̄ of each group.
        let residuals = |r: &Robot<6>| -> std::vec::Vec<f64> {
            let mut out = std::vec![0.0; 27];
            for g in &groups {
                let pts: [[f64; 3]; 5] = core::array::from_fn(|k| {
                    c.contacts
                        .get(g.start + k)
                        .filter(|_| k < g.len)
                        .map_or([0.0; 3], |x| x.tool_point(r).unwrap())
                });
                let mut mean = [0.0; 3];
                for p in pts.iter().take(g.len) {
                    for a in 0..3 {
                        mean[a] += p[a] / g.len as f64;
                    }
                }
                for (k, p) in pts.iter().take(g.len).enumerate() {
                    for a in 0..3 {
                        out[3 * (g.start + k) + a] = p[a] - mean[a];
                    }
                }
            }
            out
        };
        assert_gram_is_the_fd_gram(&robot, &d, residuals);
    }

    /// An unknown plane's Gram matrix is `JᵀJ` of the finite-difference Jacobian of its
    /// residuals with the plane refitted at every model (offset and tilt), on both paths:
    /// the contacts hold the tool point on one plane (IK), where that Jacobian is the
    /// Gauss–Newton one.
    #[test]
    fn plane_gram_matches_the_finite_difference_jacobian_with_the_plane_refitted() {
        use crate::ik::{IkOptions, solve_ik};
        let robot = aria::nominal();
        let seed = crate::JointState::new(aria::TOOL_SEED_Q);
        let t0 = robot.fk(&seed).unwrap();
        let (u, v) = (
            nalgebra::Vector3::new(0.8, 0.6, 0.0),
            nalgebra::Vector3::new(-0.36, 0.48, 0.8),
        );
        let contacts: [Contact<6>; 7] = core::array::from_fn(|k| {
            let a = 0.9 * k as f64;
            let p = t0.translation.vector + u * (0.06 * libm::cos(a)) + v * (0.04 * libm::sin(a));
            let pose = Transform::from_parts(nalgebra::Translation3::from(p), t0.rotation);
            let sol = solve_ik(&robot, &pose, &seed, &IkOptions::default()).unwrap();
            assert!(sol.residual_pos_m < 1e-9, "{}", sol.residual_pos_m);
            Contact::new(sol.q)
        });
        let groups = [Group {
            kind: GroupKind::Plane,
            start: 0,
            len: 7,
        }];
        let d = only_contacts(&contacts, &groups);
        let n0 = plane_normal(point_moments(&robot, &contacts).unwrap().2, 0).unwrap();
        // Signed distances to the plane refitted at `r` (normal's sign kept).
        let residuals = |r: &Robot<6>| -> std::vec::Vec<f64> {
            let (_, pbar, scatter) = point_moments(r, &contacts).unwrap();
            let mut nr = plane_normal(scatter, 0).unwrap();
            if dot3(&nr, &n0) < 0.0 {
                nr = [-nr[0], -nr[1], -nr[2]];
            }
            contacts
                .iter()
                .map(|c| {
                    let p = c.tool_point(r).unwrap();
                    dot3(&nr, &[p[0] - pbar[0], p[1] - pbar[1], p[2] - pbar[2]])
                })
                .collect()
        };
        let largest = assert_gram_is_the_fd_gram(&robot, &d, residuals);
        assert!(
            largest > 1e-6,
            "every diagonal entry vanished: the test says nothing"
        );
    }

    /// Asserts that the normal equations of `d` at `robot`, on the Gram path and on the
    /// Givens path, are `JᵀJ` of the central-difference Jacobian of `residuals` (every
    /// geometric parameter, step 1e-6); returns the largest diagonal entry.
    fn assert_gram_is_the_fd_gram(
        robot: &Robot<6>,
        d: &ConstraintData<'_, 6>,
        residuals: impl Fn(&Robot<6>) -> std::vec::Vec<f64>,
    ) -> f64 {
        let mut ws = ws();
        fold_all(robot, d, true, &mut ws);
        let gram = *ws.gram.gram();
        fold_all(robot, d, false, &mut ws);
        let h = 1e-6;
        let jac: std::vec::Vec<std::vec::Vec<f64>> = params()
            .iter()
            .map(|i| {
                let v = robot.param(ParamIndex(i)).unwrap();
                let at = |x: f64| {
                    let mut r = *robot;
                    r.set_param(ParamIndex(i), x).unwrap();
                    residuals(&r)
                };
                let (a, b) = (at(v + h), at(v - h));
                a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect()
            })
            .collect();
        let r = ws.lsq.r();
        let n = params().len();
        let mut largest = 0.0f64;
        for a in 0..n {
            largest = largest.max(gram[a][a]);
            for b in a..n {
                let fd: f64 = jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum();
                let givens: f64 = (0..=a).map(|i| r[i][a] * r[i][b]).sum();
                let scale = gram[a][a].abs().max(gram[b][b].abs()).max(1e-6);
                assert!(
                    (gram[a][b] - fd).abs() <= 1e-6 * scale,
                    "G[{a}][{b}] {} vs FD {fd}",
                    gram[a][b]
                );
                assert!(
                    (gram[a][b] - givens).abs() <= 1e-9 * scale,
                    "G[{a}][{b}] {} vs Givens {givens}",
                    gram[a][b]
                );
            }
        }
        largest
    }

    #[test]
    fn layout_errors_name_the_group_and_distance() {
        let c = case();
        let mut groups = c.groups;
        groups[2].start += 1;
        let d = ConstraintData {
            groups: &groups,
            ..data(&c)
        };
        assert_eq!(d.validate(), Err(Error::BadGroup { group: 2 }));
        let mut groups = c.groups;
        groups[0].len = 1;
        groups[1].start = 1;
        groups[1].len = 8;
        let d = ConstraintData {
            groups: &groups,
            ..data(&c)
        };
        assert_eq!(d.validate(), Err(Error::BadGroup { group: 0 }));
        let distances = [Distance {
            a: 0,
            b: 2,
            m: 0.05,
            weight: 1.0,
        }];
        let d = ConstraintData {
            distances: &distances,
            ..data(&c)
        };
        assert_eq!(d.validate(), Err(Error::BadDistance { distance: 0 }));
        // Collinear plane contacts.
        let line: [Contact<6>; 4] = core::array::from_fn(|_| contact(0, [0.0; 3]));
        let groups = [Group {
            kind: GroupKind::Plane,
            start: 0,
            len: 4,
        }];
        let d = only_contacts(&line, &groups);
        assert_eq!(
            group_estimate(&aria::nominal(), &d, 0),
            Err(Error::DegenerateGroup { group: 0 })
        );
    }

    #[test]
    fn smallest_eigenvector_of_a_known_scatter() {
        // Points spread in x (10) and y (1), thin in z (0.01), then rotated.
        let s = [[100.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1e-4]];
        let (ev, n) = sym3_smallest(s);
        assert!(
            (ev[0] - 1e-4).abs() < 1e-15
                && (ev[1] - 1.0).abs() < 1e-12
                && (ev[2] - 100.0).abs() < 1e-12
        );
        assert_eq!(n, [0.0, 0.0, 1.0]);
        let (c, si) = (libm::cos(0.3), libm::sin(0.3));
        let r = [
            [c, -si, 0.0],
            [si * 0.6, c * 0.6, -0.8],
            [si * 0.8, c * 0.8, 0.6],
        ];
        let mut rs = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                rs[a][b] = (0..3).map(|k| r[a][k] * s[k][k] * r[b][k]).sum();
            }
        }
        let (ev, n) = sym3_smallest(rs);
        assert!((ev[0] - 1e-4).abs() < 1e-12);
        let want = [r[0][2], r[1][2], r[2][2]];
        let dot = (n[0] * want[0] + n[1] * want[1] + n[2] * want[2]).abs();
        assert!((dot - 1.0).abs() < 1e-12, "{n:?} vs {want:?}");
    }

    /// Contacts in `groups` alone: no instrument rows, distances or sessions.
    fn only_contacts<'a>(contacts: &'a [Contact<6>], groups: &'a [Group]) -> ConstraintData<'a, 6> {
        ConstraintData {
            instrument: &[],
            contacts,
            groups,
            distances: &[],
            sessions: &[],
        }
    }

    /// Every contact group kind and a distance, without instrument rows (whose fold has no
    /// cost-only mode).
    fn contact_data(c: &Case) -> ConstraintData<'_, 6> {
        ConstraintData {
            instrument: &[],
            ..data(c)
        }
    }

    /// Models around the nominal one: each geometric parameter moved by a different amount.
    fn moved(k: usize) -> Robot<6> {
        let mut r = aria::nominal();
        for i in params().iter() {
            let v = r.param(ParamIndex(i)).unwrap();
            let dv = 1e-3 * libm::sin(0.7 * i as f64 + 1.9 * k as f64);
            r.set_param(ParamIndex(i), v + dv).unwrap();
        }
        r
    }

    #[test]
    fn fold_cost_is_the_normal_equation_folds_cost_bit_for_bit() {
        let c = case();
        let d = contact_data(&c);
        d.validate().unwrap();
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let n = params().len();
        let mut ws = ws();
        for k in 0..5 {
            let robot = moved(k);
            let folded = fold_all(&robot, &d, true, &mut ws);
            let gram = ws.gram.clone();
            // At another model: the cost-only pass leaves the normal equations alone.
            let other = d
                .fold_cost(&moved(k + 7), &opts, n, f64::INFINITY, &mut ws)
                .unwrap();
            assert!(other.is_some_and(|o| o.to_bits() != folded.to_bits()));
            let cost = d
                .fold_cost(&robot, &opts, n, f64::INFINITY, &mut ws)
                .unwrap()
                .unwrap();
            assert_eq!(
                cost.to_bits(),
                folded.to_bits(),
                "model {k}: {cost} vs {folded}"
            );
            assert!(!ws.to_gram && !ws.cost_only);
            assert_eq!(ws.gram.gram(), gram.gram());
            assert_eq!(ws.gram.atb(), gram.atb());
            assert_eq!(ws.gram.btb().to_bits(), gram.btb().to_bits());
            // The moment-based cost is the same sum, to rounding only.
            let moments = d.cost(&robot, &opts).unwrap();
            assert!(
                (moments - cost).abs() <= 1e-12 * cost,
                "{moments} vs {cost}"
            );
        }
        // With instrument rows there is no cost-only pass.
        assert!(
            data(&c)
                .fold_cost(&moved(0), &opts, n, f64::INFINITY, &mut ws)
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn a_cost_pass_stops_only_above_its_bound() {
        let c = case();
        let d = contact_data(&c);
        let opts = IdentifyOptions::new(Algorithm::Ols, params());
        let n = params().len();
        let mut ws = ws();
        for k in 0..5 {
            let robot = moved(k);
            let full = d.fold_cost(&robot, &opts, n, f64::INFINITY, &mut ws);
            let full = full.unwrap().unwrap();
            // The first group's cost alone: the running sum after it.
            (ws.cost_only, ws.to_gram) = (true, true);
            let first = fold_group(&robot, &d, 0, true, &opts, n, &mut ws).unwrap();
            (ws.cost_only, ws.to_gram) = (false, false);
            assert!(first > 0.0 && first < full, "model {k}: {first} vs {full}");
            // A bound below the first group's cost: the pass stops there, above the bound.
            let low = 0.5 * first;
            let partial = d
                .fold_cost(&robot, &opts, n, low, &mut ws)
                .unwrap()
                .unwrap();
            assert!(
                partial > low && partial < full,
                "model {k}: {partial} vs {full}"
            );
            // A bound at the whole cost, or just below it (within the margin): the whole
            // sum, bit for bit.
            for bound in [full, full * (1.0 - 0.5 * STOP_MARGIN)] {
                let c = d
                    .fold_cost(&robot, &opts, n, bound, &mut ws)
                    .unwrap()
                    .unwrap();
                assert_eq!(c.to_bits(), full.to_bits(), "model {k}");
            }
        }
    }

    /// `d`'s rows, counting the Jacobian passes; with `cost_pass` false it hides
    /// [`RowSource::fold_cost`] (every trial then pays a Jacobian pass, as before it existed).
    struct Counted<'a, 'b> {
        d: &'a ConstraintData<'b, 6>,
        cost_pass: bool,
        folds: core::cell::Cell<usize>,
    }

    impl RowSource<6> for Counted<'_, '_> {
        fn validate(&self) -> Result<()> {
            self.d.validate()
        }
        fn check_inputs(&self, opts: &IdentifyOptions<'_>) -> Result<()> {
            RowSource::check_inputs(self.d, opts)
        }
        fn row_count(&self, opts: &IdentifyOptions<'_>) -> usize {
            self.d.row_count(opts)
        }
        fn fold<const P: usize>(
            &self,
            robot: &Robot<6>,
            with_rhs: bool,
            opts: &IdentifyOptions<'_>,
            n_cols: usize,
            ws: &mut Workspace<P>,
        ) -> Result<f64> {
            if !ws.cost_only {
                self.folds.set(self.folds.get() + 1);
            }
            self.d.fold(robot, with_rhs, opts, n_cols, ws)
        }
        fn cost(&self, robot: &Robot<6>, opts: &IdentifyOptions<'_>) -> Result<f64> {
            self.d.cost(robot, opts)
        }
        fn fold_cost<const P: usize>(
            &self,
            robot: &Robot<6>,
            opts: &IdentifyOptions<'_>,
            n_cols: usize,
            stop_above: f64,
            ws: &mut Workspace<P>,
        ) -> Result<Option<f64>> {
            if self.cost_pass {
                self.d.fold_cost(robot, opts, n_cols, stop_above, ws)
            } else {
                Ok(None)
            }
        }
        fn stats(&self, robot: &Robot<6>, opts: &IdentifyOptions<'_>) -> Result<ResidualStats> {
            self.d.stats(robot, opts)
        }
        fn damped_fallback(&self) -> bool {
            self.d.damped_fallback()
        }
    }

    #[test]
    fn costing_trials_first_leaves_the_fit_bit_for_bit() {
        let c = case();
        let d = contact_data(&c);
        // These readings hold nothing (no minimum at zero cost): stop at a relative gain
        // of 1e-4, after a few iterations with rejected trials.
        let opts = IdentifyOptions {
            ftol: 1e-4,
            ..IdentifyOptions::new(Algorithm::Ols, params())
        };
        let mut ws = ws();
        let start = moved(3);
        let mut analysis = Identifiability::empty(ParamSet::new());
        analyze_constrained_into(&start, &d, &opts, &mut ws, &mut analysis).unwrap();
        let fit = |cost_pass: bool, ws: &mut Ws| {
            let src = Counted {
                d: &d,
                cost_pass,
                folds: core::cell::Cell::new(0),
            };
            let mut out = Identification::start(&start, opts.algorithm, Some(&analysis));
            super::super::solvers::identify_into(&src, &opts, ws, &mut out).unwrap();
            (out, src.folds.get())
        };
        let (new, new_folds) = fit(true, &mut ws);
        let (old, old_folds) = fit(false, &mut ws);
        assert!(new.iterations >= 2, "{} iterations", new.iterations);
        assert_eq!(new.iterations, old.iterations);
        for i in 0..Robot::<6>::NUM_PARAMS {
            let (a, b) = (
                new.robot.param(ParamIndex(i)),
                old.robot.param(ParamIndex(i)),
            );
            assert_eq!(a.unwrap().to_bits(), b.unwrap().to_bits(), "parameter {i}");
        }
        assert_eq!(new.fitted, old.fitted);
        assert_eq!(
            new.std_errors.map(f64::to_bits),
            old.std_errors.map(f64::to_bits)
        );
        // The saving is real: rejected trials cost no Jacobian pass.
        assert!(
            new_folds < old_folds,
            "{new_folds} vs {old_folds} Jacobian passes"
        );
    }
}
