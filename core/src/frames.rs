//! Starting base and tool frames from measured poses, for calibrations in which they are
//! unknown: a camera on the wrist observing a board, a tracker or motion-capture system set
//! up anywhere, a marker stuck somewhere on the gripper. The identification linearises
//! about its starting model and needs frames near the truth; this estimate gives them for
//! the nominal link geometry, in closed form where possible.
//!
//! # Model
//! Every measurement is taken as `M_l = B·F_l·X·Trans(r_l)`: `F_l` the robot's current
//! `T_e^b` at the pose's joint state (its base and tool frames included), `r_l` the
//! measured point ([`Measurement::point`], zero when absent), and the unknown rigid
//! corrections `B` (applied before the base frame) and `X` (after the tool frame). The
//! result is the robot with base frame `B·T_0^b` and tool frame `T_e^N·X`, and its gravity
//! vector (a direction in the base frame) turned by `B`'s rotation.
//!
//! # Method
//! - **With orientations** (at least [`MIN_ORIENTED_POSES`] poses with a measured
//!   orientation): `R_X` from the hand-eye equation `R_Fij·R_X = R_X·R_Mij` of pose pairs
//!   (`F_ij = F_i⁻¹·F_j`, `M_ij = M_i⁻¹·M_j`, both rotated by at least
//!   [`MIN_PAIR_ANGLE_RAD`]): with unit quaternions of equal sign,
//!   `(L(q_F) − R(q_M))·q_X = 0`, solved as the eigenvector of the smallest eigenvalue of
//!   `Σ DᵀD` (Chou and Kamel 1991; eigen-decomposition by the Jacobi rotations of
//!   [`crate::registration`]). `R_B` is then the chordal mean of `R_Ml·(R_Fl·R_X)ᵀ`, and
//!   `R_X` and `R_B` are refined alternately by chordal means. The translations `t_X` and
//!   `t_B` follow from the linear least-squares problem of all measured positions.
//! - **Positions only**: alternating fits from `X` = identity: `B` by rigid registration
//!   (Horn's method) of the predicted points onto the measured ones, then `X`: a rigid fit
//!   of the points `r_l` onto their measured positions pulled back through `B·F_l` when the
//!   points span a plane, else its translation alone (the tool rotation cannot be seen
//!   through one point; it keeps its current value), until the RMS residual changes by
//!   less than [`CONVERGED_M`] in a round, or [`MAX_ROUNDS`] rounds.
//!
//! Degenerate data (all relative motions about one axis, positions on a line) fail with
//! [`Error::RankDeficient`]; fewer than 3 poses with [`Error::TooFewData`].
//! Components outside a pose's mask are ignored; poses of weight 0 are not used.

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, Result};
use crate::identify::Measurement;
use crate::math::sqrt;
use crate::model::Robot;
use crate::pose::{Transform, matrix_to_quaternion, pose_to_vector6, rotation_log, transform};
use crate::registration::{rotation_from_correlation, symmetric_eigen};

/// Poses with a measured orientation needed for the hand-eye estimate of the rotations.
pub const MIN_ORIENTED_POSES: usize = 3;
/// Pose pairs whose relative rotation is smaller than this \[rad\] (or within it of a half
/// turn, where the quaternion sign is ambiguous) carry no hand-eye information.
pub const MIN_PAIR_ANGLE_RAD: f64 = 0.05;
/// Alternating rounds of the position-only estimate.
pub const MAX_ROUNDS: u32 = 500;
/// The position-only rounds stop when the RMS residual changes by less than this \[m\].
pub const CONVERGED_M: f64 = 1e-10;
/// Most partners of each pose in the hand-eye sums (pairs `(i, i+1..i+PAIR_SPAN)`):
/// enough pairs for any data set, linear cost.
const PAIR_SPAN: usize = 24;

/// The result of [`estimate_frames`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameEstimate<const N: usize> {
    /// The robot with base frame `B·T_0^b` and tool frame `T_e^N·X` (both also its nominal
    /// frames, see [`Robot::with_base`]) and gravity `R_B·g`.
    pub robot: Robot<N>,
    /// `B`, the correction before the base frame.
    pub base_change: Transform,
    /// `X`, the correction after the tool frame.
    pub tool_change: Transform,
    /// Whether the tool rotation was estimated (not with position-only data of one point).
    pub tool_rotation_estimated: bool,
    /// RMS position residual of the estimate over the poses with positions \[m\].
    pub rms_pos_m: f64,
    /// RMS rotation angle over the poses with orientations \[rad\] (0 without).
    pub rms_rot_rad: f64,
    /// Alternating rounds used.
    pub rounds: u32,
}

/// A used pose: `F_l`, the measurement, the point.
struct Pose {
    f: Transform,
    m: Transform,
    r: Vector3<f64>,
    pos: bool,
    rot: bool,
}

fn pose_at<const N: usize>(robot: &Robot<N>, m: &Measurement<N>) -> Result<Pose> {
    let p = m.point.unwrap_or([0.0; 3]);
    Ok(Pose {
        f: robot.fk(&m.state)?,
        m: m.pose,
        r: Vector3::new(p[0], p[1], p[2]),
        pos: m.mask.has_position(),
        rot: m.mask.has_orientation(),
    })
}

/// Left and right quaternion product matrices: `q ⊗ p = L(q)·p = R(p)·q` ([w, x, y, z]).
fn quat_l(q: &[f64; 4]) -> [[f64; 4]; 4] {
    let [w, x, y, z] = *q;
    [[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]]
}
fn quat_r(q: &[f64; 4]) -> [[f64; 4]; 4] {
    let [w, x, y, z] = *q;
    [[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]]
}

/// Unit quaternion of `r` with `w >= 0`.
fn quat_pos(r: &Matrix3<f64>) -> [f64; 4] {
    let q = matrix_to_quaternion(r);
    if q[0] < 0.0 { q.map(|v| -v) } else { q }
}

/// The hand-eye rotation `R_X` from the oriented poses.
fn hand_eye_rotation<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
) -> Result<Matrix3<f64>> {
    let mut c = [[0.0; 4]; 4];
    let mut pairs = 0usize;
    let oriented = |m: &&Measurement<N>| m.weight > 0.0 && m.mask.has_orientation();
    for (i, mi) in data.iter().filter(oriented).enumerate() {
        let pi = pose_at(robot, mi)?;
        for mj in data.iter().filter(oriented).skip(i + 1).take(PAIR_SPAN) {
            let pj = pose_at(robot, mj)?;
            let rf = pi.f.rotation.matrix().transpose() * pj.f.rotation.matrix();
            let rm = pi.m.rotation.matrix().transpose() * pj.m.rotation.matrix();
            let angle = rotation_log(&rf).norm();
            let informative = MIN_PAIR_ANGLE_RAD..=core::f64::consts::PI - MIN_PAIR_ANGLE_RAD;
            if !informative.contains(&angle) {
                continue;
            }
            let (l, r) = (quat_l(&quat_pos(&rf)), quat_r(&quat_pos(&rm)));
            let mut d = [[0.0; 4]; 4];
            for a in 0..4 {
                for b in 0..4 {
                    d[a][b] = l[a][b] - r[a][b];
                }
            }
            for a in 0..4 {
                for b in 0..4 {
                    c[a][b] += (0..4).map(|k| d[k][a] * d[k][b]).sum::<f64>();
                }
            }
            pairs += 1;
        }
    }
    if pairs < 2 {
        return Err(Error::TooFewData {
            found: pairs,
            needed: 2,
        });
    }
    let (lambda, v) = symmetric_eigen(c)?;
    let mut order = [0usize, 1, 2, 3];
    order.sort_unstable_by(|&i, &j| lambda[i].total_cmp(&lambda[j]));
    let scale = lambda.iter().fold(0.0_f64, |m, l| m.max(l.abs()));
    // A unique solution needs the second-smallest eigenvalue clearly above the smallest.
    if scale.is_nan() || scale <= 0.0 || lambda[order[1]] - lambda[order[0]] <= 1e-9 * scale {
        return Err(Error::RankDeficient {
            rank: 2,
            required: 3,
        });
    }
    let k = order[0];
    crate::pose::quaternion_to_matrix(&[v[0][k], v[1][k], v[2][k], v[3][k]])
}

/// Solves the 6×6 normal equations `a·x = b` (Gaussian elimination with partial pivoting);
/// a pivot below `1e-12·max|a|` is rank deficiency.
fn solve6(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Result<[f64; 6]> {
    let scale = a.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
    for col in 0..6 {
        let piv = (col..6)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        let pivot = a[piv][col].abs();
        if pivot.is_nan() || pivot <= 1e-12 * scale {
            return Err(Error::RankDeficient {
                rank: col,
                required: 6,
            });
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in (col + 1)..6 {
            let f = a[row][col] / a[col][col];
            for k in col..6 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let s: f64 = ((row + 1)..6).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Ok(x)
}

/// Base and tool frames for `robot` from `data` (module docs).
pub fn estimate_frames<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
) -> Result<FrameEstimate<N>> {
    crate::identify::validate_data(data)?;
    let poses = Poses { robot, data };
    let (mut n, mut n_pos, mut n_rot) = (0, 0, 0);
    poses.each(|p| {
        n += 1;
        n_pos += usize::from(p.pos);
        n_rot += usize::from(p.rot);
    })?;
    if n < 3 || n_pos < 3 {
        return Err(Error::TooFewData {
            found: n_pos.min(n),
            needed: 3,
        });
    }
    let (rb, rx, t, rounds, tool_rot) = if n_rot >= MIN_ORIENTED_POSES {
        let mut rx = hand_eye_rotation(robot, data)?;
        let mut rb = Matrix3::identity();
        for _ in 0..20 {
            rb = chordal_mean_of(&poses, |p| {
                p.rot
                    .then(|| p.m.rotation.matrix() * (p.f.rotation.matrix() * rx).transpose())
            })?;
            rx = chordal_mean_of(&poses, |p| {
                p.rot
                    .then(|| (rb * p.f.rotation.matrix()).transpose() * p.m.rotation.matrix())
            })?;
        }
        let t = translations_of(&poses, &rb, &rx)?;
        (rb, rx, t, 0, true)
    } else {
        position_only(&poses)?
    };
    let x = transform(rx, Vector3::new(t[0], t[1], t[2]));
    let bt = transform(rb, Vector3::new(t[3], t[4], t[5]));
    let new_base = bt * robot.t_base_0();
    let new_tool = robot.t_n_tool() * x;
    // Gravity is a direction in the base frame: it turns with it.
    let mut mass = *robot.mass();
    let g = rb * Vector3::new(mass.gravity[0], mass.gravity[1], mass.gravity[2]);
    mass.gravity = [g.x, g.y, g.z];
    let out = robot
        .with_base(pose_to_vector6(&new_base))?
        .with_tool(pose_to_vector6(&new_tool))?
        .with_mass(mass)?;
    // Residuals of the estimate.
    let (mut sp, mut np, mut sr, mut nr) = (0.0, 0usize, 0.0, 0usize);
    poses.each(|p| {
        let pred = bt * p.f * x * nalgebra::Translation3::from(p.r);
        if p.pos {
            sp += (p.m.translation.vector - pred.translation.vector).norm_squared();
            np += 1;
        }
        if p.rot {
            let e = rotation_log(&(p.m.rotation.matrix() * pred.rotation.matrix().transpose()));
            sr += e.norm_squared();
            nr += 1;
        }
    })?;
    Ok(FrameEstimate {
        robot: out,
        base_change: bt,
        tool_change: x,
        tool_rotation_estimated: tool_rot,
        rms_pos_m: if np > 0 { sqrt(sp / np as f64) } else { 0.0 },
        rms_rot_rad: if nr > 0 { sqrt(sr / nr as f64) } else { 0.0 },
        rounds,
    })
}

/// The used poses (positive weight), evaluated on the fly: no buffer, FK per visit.
struct Poses<'a, const N: usize> {
    robot: &'a Robot<N>,
    data: &'a [Measurement<N>],
}

impl<const N: usize> Poses<'_, N> {
    fn each(&self, mut f: impl FnMut(&Pose)) -> Result<()> {
        for m in self.data.iter().filter(|m| m.weight > 0.0) {
            f(&pose_at(self.robot, m)?);
        }
        Ok(())
    }
}

/// Chordal mean of the rotations `each` gives (the `R` maximising `Σ tr(Rᵀ·C_l)`: Horn's
/// fit with correlation `Σ_l Σ_k e_k·(C_l·e_k)ᵀ = Σ_l C_lᵀ`).
fn chordal_mean_of<const N: usize>(
    poses: &Poses<'_, N>,
    mut each: impl FnMut(&Pose) -> Option<Matrix3<f64>>,
) -> Result<Matrix3<f64>> {
    let mut s = Matrix3::zeros();
    poses.each(|p| {
        if let Some(c) = each(p) {
            s += c.transpose();
        }
    })?;
    rotation_from_correlation(&s)
}

/// `t_X` and `t_B` by linear least squares over the positions, rotations fixed.
fn translations_of<const N: usize>(
    poses: &Poses<'_, N>,
    rb: &Matrix3<f64>,
    rx: &Matrix3<f64>,
) -> Result<[f64; 6]> {
    let mut a = [[0.0; 6]; 6];
    let mut b = [0.0; 6];
    poses.each(|p| {
        if !p.pos {
            return;
        }
        let rf = p.f.rotation.matrix();
        let k = rb * rf;
        let rhs = p.m.translation.vector - rb * (rf * (rx * p.r) + p.f.translation.vector);
        for row in 0..3 {
            let mut j = [0.0; 6];
            for c in 0..3 {
                j[c] = k[(row, c)];
            }
            j[3 + row] = 1.0;
            for u in 0..6 {
                b[u] += j[u] * rhs[row];
                for v in 0..6 {
                    a[u][v] += j[u] * j[v];
                }
            }
        }
    })?;
    solve6(a, b)
}

/// Position-only alternation: `(R_B, R_X, [t_X; t_B], rounds, tool rotation estimated)`.
#[allow(clippy::type_complexity)]
fn position_only<const N: usize>(
    poses: &Poses<'_, N>,
) -> Result<(Matrix3<f64>, Matrix3<f64>, [f64; 6], u32, bool)> {
    // Do the points span a plane (so that the tool rotation shows)?
    let (mut cr, mut k) = (Vector3::zeros(), 0.0);
    poses.each(|p| {
        if p.pos {
            cr += p.r;
            k += 1.0;
        }
    })?;
    cr /= k;
    let mut scatter = [[0.0; 3]; 3];
    poses.each(|p| {
        if p.pos {
            let d = p.r - cr;
            for a in 0..3 {
                for b in 0..3 {
                    scatter[a][b] += d[a] * d[b];
                }
            }
        }
    })?;
    let (ev, _) = symmetric_eigen(scatter)?;
    // RMS extent above 1 mm in two directions: the points span a plane.
    let planar = ev.iter().filter(|&&l| sqrt(l.max(0.0) / k) > 1e-3).count() >= 2;

    let mut rb = Matrix3::identity();
    let mut rx = Matrix3::identity();
    let mut tx = Vector3::zeros();
    let mut tb = Vector3::zeros();
    let mut rounds = 0;
    let mut last = f64::INFINITY;
    while rounds < MAX_ROUNDS {
        rounds += 1;
        // B: rigid fit of the points (robot base frame) onto the measured ones.
        let in_base = |p: &Pose, rx: &Matrix3<f64>, tx: &Vector3<f64>| {
            p.f.rotation.matrix() * (rx * p.r + tx) + p.f.translation.vector
        };
        let (mut ca, mut cb) = (Vector3::zeros(), Vector3::zeros());
        poses.each(|p| {
            if p.pos {
                ca += in_base(p, &rx, &tx);
                cb += p.m.translation.vector;
            }
        })?;
        ca /= k;
        cb /= k;
        let mut s = Matrix3::zeros();
        poses.each(|p| {
            if p.pos {
                s += (in_base(p, &rx, &tx) - ca) * (p.m.translation.vector - cb).transpose();
            }
        })?;
        rb = rotation_from_correlation(&s)?;
        tb = cb - rb * ca;
        // X: the measured points pulled back into the tool frame.
        let pull = |p: &Pose| {
            p.f.rotation.matrix().transpose()
                * (rb.transpose() * (p.m.translation.vector - tb) - p.f.translation.vector)
        };
        let mut cs = Vector3::zeros();
        poses.each(|p| {
            if p.pos {
                cs += pull(p);
            }
        })?;
        cs /= k;
        if planar {
            let mut s = Matrix3::zeros();
            poses.each(|p| {
                if p.pos {
                    s += (p.r - cr) * (pull(p) - cs).transpose();
                }
            })?;
            rx = rotation_from_correlation(&s)?;
        }
        tx = cs - rx * cr;
        // Convergence: the RMS residual stops changing.
        let mut ss = 0.0;
        poses.each(|p| {
            if p.pos {
                let pred = rb * in_base(p, &rx, &tx) + tb;
                ss += (p.m.translation.vector - pred).norm_squared();
            }
        })?;
        let rms = sqrt(ss / k);
        if (last - rms).abs() < CONVERGED_M {
            break;
        }
        last = rms;
    }
    Ok((rb, rx, [tx.x, tx.y, tx.z, tb.x, tb.y, tb.z], rounds, planar))
}
