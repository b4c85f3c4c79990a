//! Forward kinematics, every intermediate frame, the gravity torques of the mass model, and
//! the analytic identification Jacobian (eq. 13a–e) with base, tool and effect columns.

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, Result};
use crate::fixed3::{IDENTITY, IDENTITY_TRANSFORM, ZERO, compose, dot, from_columns, mat_vec};
use crate::math::column3;
use crate::model::{Geometry, JointState, Robot};
use crate::params::{CyclicTerm, FrameParam, LinkParam, ParamId};
use crate::pose::{Transform, so3_left_jacobian, transform};

/// Row order of every identification Jacobian column: `[Δp (3, m); Δφ (3, rad)]`, both in the
/// base frame — the same order as [`crate::pose::PoseError`].
pub type JacobianColumn = [f64; 6];

/// Every frame of one FK evaluation, in the base frame. Needed by the Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frames<const N: usize> {
    /// `T_0^b`: frame 0 (before joint 1) in the base frame.
    pub t_base_0: Transform,
    /// `t_base_link[i]` = `T_0^b·A_1···A_{i+1}`: frame i+1 in the base frame.
    pub t_base_link: [Transform; N],
    /// x axis of link i+1's intermediate frame (after `Rz·Tz·Tx`, before `Rx(α)·Ry(β)`):
    /// the axis of a_{i+1} and α_{i+1}. Equals frame i+1's x axis when β = 0.
    pub x_mid: [Vector3<f64>; N],
    /// `T_e^b`: end effector (tool) in the base frame.
    pub t_base_ee: Transform,
    /// Factor applied to every d and a (thermal expansion; 1 without it).
    pub length_scale: f64,
}

impl<const N: usize> Default for Frames<N> {
    fn default() -> Self {
        Frames {
            t_base_0: IDENTITY_TRANSFORM,
            t_base_link: [IDENTITY_TRANSFORM; N],
            x_mid: [ZERO; N],
            t_base_ee: IDENTITY_TRANSFORM,
            length_scale: 1.0,
        }
    }
}

/// Refuses a pose that overflowed: finite but absurd parameters or readings (lengths of
/// 1e200 m, say) can make FK non-finite, and a NaN pose must never pass as a result (found by
/// fuzzing the C ABI). [`Error::NonFinite`] names the position or the orientation.
fn check_pose(t: &Transform) -> Result<()> {
    crate::error::check_finite(
        t.translation.vector.as_slice(),
        crate::error::Quantity::Position,
    )?;
    crate::error::check_finite(
        t.rotation.matrix().as_slice(),
        crate::error::Quantity::Orientation,
    )
}

/// FK of a geometry at joint displacements `disp` (q + Δθ, without θ0), fixed lengths times
/// `scale`. `turn[i]` is 1 for a revolute joint (the displacement is an angle added to θ0)
/// and 0 for a prismatic one (a slide added to d, not scaled: the reading is not a length
/// of the structure). `on_link(i, x_mid, R_i, p_i)` sees each link's intermediate x axis
/// (after `Rz·Tz·Tx`, before `Rx(α)·Ry(β)`) and its frame.
///
/// Speed (FK is dominated by this loop): every sine and cosine is taken before the chain,
/// all joints at once ([`crate::math::sin_cos_lanes`]: two per SSE2 register, within 1 ulp
/// of libm), so the trigonometry does not interleave with the chain's dependent arithmetic;
/// each link then turns column pairs of the running rotation (`Rz(θ)`, `Rx(α)`, and `Ry(β)`
/// only where β ≠ 0, which gives the same result as turning by cos 0 = 1, sin 0 = 0) instead
/// of multiplying 3×3 matrices.
#[inline(always)]
fn chain<const N: usize>(
    g: &Geometry<N>,
    turn: &[f64; N],
    disp: &[f64; N],
    scale: f64,
    on_link: impl FnMut(usize, &Vector3<f64>, &Matrix3<f64>, &Vector3<f64>),
) -> Transform {
    let mut theta = [0.0; N];
    let mut slide = [0.0; N];
    for i in 0..N {
        theta[i] = disp[i] * turn[i] + g.links[i].theta0;
        slide[i] = disp[i] * (1.0 - turn[i]);
    }
    chain_sc(
        g,
        &crate::math::sin_cos_lanes(&theta),
        &slide,
        scale,
        on_link,
    )
}

/// [`chain`] from the sines and cosines `(sin θ_i, cos θ_i)` of the full joint angles
/// `θ_i = angle_i + θ0_i` and the slides of the prismatic joints (0 for revolute ones).
#[inline(always)]
fn chain_sc<const N: usize>(
    g: &Geometry<N>,
    sc: &[(f64, f64); N],
    slide: &[f64; N],
    scale: f64,
    mut on_link: impl FnMut(usize, &Vector3<f64>, &Matrix3<f64>, &Vector3<f64>),
) -> Transform {
    let r0 = g.t_base.rotation.matrix();
    let mut x: Vector3<f64> = column3(r0, 0);
    let mut y: Vector3<f64> = column3(r0, 1);
    let mut z: Vector3<f64> = column3(r0, 2);
    let mut p = g.t_base.translation.vector;
    for i in 0..N {
        let l = &g.links[i];
        let (s, c) = sc[i];
        // R_prev·Rz(θ): x and y turn about z.
        let xm = x * c + y * s;
        let ym = y * c - x * s;
        // p_i = p_{i-1} + R_prev·Rz(θ)·(a, 0, d + slide).
        p += xm * (l.a * scale) + z * (l.d * scale + slide[i]);
        let [ca, sa, cb, sb] = g.link_cs[i];
        // ·Rx(α): y and z turn about x.
        y = ym * ca + z * sa;
        let za = z * ca - ym * sa;
        // ·Ry(β): z and x turn about y.
        if sb == 0.0 {
            x = xm;
            z = za;
        } else {
            x = xm * cb - za * sb;
            z = xm * sb + za * cb;
        }
        on_link(i, &xm, &from_columns(&x, &y, &z), &p);
    }
    compose(&transform(from_columns(&x, &y, &z), p), &g.t_tool)
}

impl<const N: usize> Robot<N> {
    /// End-effector pose `T_e^b` for the joint state (effects applied).
    ///
    /// ```
    /// use kincal::{aria, JointState};
    /// let robot = aria::nominal();
    /// let t = robot.fk(&JointState::new([0.0; 6])).unwrap();
    /// // Arm stretched up: 0.205 + 0.41 + 0.336 + 0.202 m above the base, offset by a_3 and d_5.
    /// assert!((t.translation.z - (0.205 + 0.41 + 0.03 + 0.336 + 0.202 - 0.03)).abs() < 1.0);
    /// ```
    pub fn fk(&self, state: &JointState<N>) -> Result<Transform> {
        self.fk_with_torques(state, &mut None)
    }

    /// [`Robot::fk`] with the gravity torques at the readings in `tau` when known (bit for
    /// bit [`Robot::gravity_torques`]'s: the same pose); when unknown and the compliance
    /// needed them, they are computed and left in `tau` for the caller to keep.
    pub(crate) fn fk_with_torques(
        &self,
        state: &JointState<N>,
        tau: &mut Option<[f64; N]>,
    ) -> Result<Transform> {
        let (angles, torques) = self.joint_angles_with_torques(state, tau.as_ref())?;
        if tau.is_none() {
            *tau = torques;
        }
        let scale = self.length_scale(state)?;
        let t = chain(
            &self.geom,
            &self.turn_mask(),
            &angles,
            scale,
            |_, _, _, _| {},
        );
        check_pose(&t)?;
        Ok(t)
    }

    /// End-effector pose of the geometric model from precomputed `[sin q_j, cos q_j]` of the
    /// readings: no trigonometry per call (θ0's sines and cosines are kept with the model),
    /// for evaluating many models at the same configurations (validation in Monte-Carlo
    /// studies). Equals [`Robot::fk_q`] to rounding. A model with joint or thermal effects
    /// is refused with [`Error::InvalidParameter`] naming its first non-zero effect
    /// parameter; one with a prismatic joint (whose reading is a slide, not an angle) with
    /// [`Error::InvalidParameter`] naming that joint's d.
    pub fn fk_sincos(&self, sincos_q: &[[f64; 2]; N]) -> Result<Transform> {
        if let Some(j) = (0..N).find(|&j| self.joint_kind(j) == crate::JointKind::Prismatic) {
            let index = ParamId::Link {
                link: j,
                kind: LinkParam::D,
            }
            .index(N)
            .0;
            return Err(Error::InvalidParameter {
                index,
                value: self.param(crate::error::ParamIndex(index))?,
            });
        }
        if self.active_effects() != crate::EffectSet::NONE {
            let first = crate::params::num_geometric_params(N);
            for i in first..Self::NUM_PARAMS {
                let v = self.param(crate::error::ParamIndex(i))?;
                if v != 0.0 {
                    return Err(Error::InvalidParameter { index: i, value: v });
                }
            }
        }
        let mut sc = [(0.0, 1.0); N];
        for i in 0..N {
            let [sq, cq] = sincos_q[i];
            let [ct, st] = self.geom.theta0_cs[i];
            sc[i] = (sq * ct + cq * st, cq * ct - sq * st);
        }
        Ok(chain_sc(&self.geom, &sc, &[0.0; N], 1.0, |_, _, _, _| {}))
    }

    /// End-effector pose for readings `q` alone (models without backlash/thermal).
    pub fn fk_q(&self, q: &[f64; N]) -> Result<Transform> {
        self.fk(&JointState::new(*q))
    }

    /// The joint (geometric) Jacobian at `state` for a controller: column `j` of `jac` is
    /// `[v; ω]`, the tool origin's velocity \[m/s\] and the tool's angular velocity \[rad/s\],
    /// both in the base frame, per unit rate of reading `j` (rad/s, or m/s for a prismatic
    /// joint); returns the tool pose, equal to [`Robot::fk`]. Joint effects enter through
    /// `dθ_j/dq_j` (scale, cyclic); compliance's dependence on q is neglected (as in the IK,
    /// which uses the same columns), so with compliance the columns are exact only to that
    /// small term. Checked against finite differences of [`Robot::fk`] in
    /// `tests/jacobian_fd.rs`.
    pub fn joint_jacobian(
        &self,
        state: &JointState<N>,
        jac: &mut [JacobianColumn; N],
    ) -> Result<Transform> {
        let angles = self.joint_angles(state)?;
        let scale = self.length_scale(state)?;
        // Each joint's preceding frame (z axis, origin) straight from the chain: the columns
        // need no more of [`Frames`], so none is built (same bits as through `fk_frames`).
        let mut preceding = [(ZERO, ZERO); N];
        let base = &self.geom.t_base;
        let mut prev = (column3(base.rotation.matrix(), 2), base.translation.vector);
        let t = chain(
            &self.geom,
            &self.turn_mask(),
            &angles,
            scale,
            |i, _, r, p| {
                if let Some(slot) = preceding.get_mut(i) {
                    *slot = prev;
                }
                prev = (column3(r, 2), *p);
            },
        );
        check_pose(&t)?;
        crate::ik::joint_jacobian_columns(self, state, &t.translation.vector, &preceding, jac);
        Ok(t)
    }

    /// FK with every intermediate frame written into `frames`.
    pub fn fk_frames(&self, state: &JointState<N>, frames: &mut Frames<N>) -> Result<()> {
        let angles = self.joint_angles(state)?;
        let scale = self.length_scale(state)?;
        self.frames_at(&angles, scale, frames);
        check_pose(&frames.t_base_ee)
    }

    fn frames_at(&self, angles: &[f64; N], scale: f64, frames: &mut Frames<N>) {
        frames.t_base_0 = self.geom.t_base;
        frames.length_scale = scale;
        let (links, x_mid) = (&mut frames.t_base_link, &mut frames.x_mid);
        frames.t_base_ee = chain(
            &self.geom,
            &self.turn_mask(),
            angles,
            scale,
            |i, xm, r, p| {
                links[i] = transform(*r, *p);
                x_mid[i] = *xm;
            },
        );
    }

    /// Gravity torque τ_j about each joint axis [N·m] at readings `q`, from the mass model
    /// and the nominal geometry (spec/effects.md): `τ_j = z_{j−1}·Σ_{k≥j}(c_k − p_{j−1}) ×
    /// (m_k·g)`; for a prismatic joint the gravity force along its axis \[N\],
    /// `F_j = z_{j−1}·Σ_{k≥j} m_k·g`. With this sign a positive compliance moves a joint the
    /// way gravity pulls.
    #[must_use]
    pub fn gravity_torques(&self, q: &[f64; N]) -> [f64; N] {
        let mut p = [ZERO; N];
        let mut z = [ZERO; N];
        let turn = self.turn_mask();
        let ee = chain(&self.nominal, &turn, q, 1.0, |i, _, r, pi| {
            p[i] = *pi;
            z[i] = column3(r, 2);
        });
        let g = self.gravity();
        let base_p = self.nominal.t_base.translation.vector;
        let base_z = column3(self.nominal.t_base.rotation.matrix(), 2);
        // Accumulate from the tip: first moment Σ m_k c_k and mass Σ m_k of links k ≥ j.
        let mut moment = ee.translation.vector * self.mass.tool_mass_kg;
        let mut mass = self.mass.tool_mass_kg;
        let mut tau = [0.0; N];
        for j in (0..N).rev() {
            let (p_prev, z_prev) = if j == 0 {
                (base_p, base_z)
            } else {
                (p[j - 1], z[j - 1])
            };
            let m = self.mass.link_masses_kg[j];
            moment += (p_prev + p[j]) * (0.5 * m);
            mass += m;
            tau[j] = if turn[j] == 0.0 {
                dot(&z_prev, &(g * mass))
            } else {
                dot(&z_prev, &(moment - p_prev * mass).cross(&g))
            };
        }
        tau
    }

    /// The analytic identification Jacobian at `state`: column `i` is `∂[p; φ]/∂param_i`
    /// (rows `[Δp; Δφ]` in the base frame, see [`JacobianColumn`]); returns the pose.
    ///
    /// `jac.len()` must be `5N` (link columns only), [`Robot::NUM_GEOMETRIC_PARAMS`]
    /// (links, base, tool) or [`Robot::NUM_PARAMS`] (also the effect columns). Link columns follow eq. (13a–e):
    /// θ0_i → `[z_{i−1} × (p_e − p_{i−1}); z_{i−1}]`, d_i → `[z_{i−1}; 0]`, a_i → `[x_i; 0]`,
    /// α_i → `[x_i × (p_e − p_i); x_i]`, β_i → `[y_i × (p_e − p_i); y_i]`, with x_i the x
    /// axis before Ry(β_i) (exact for β ≠ 0). Base and tool columns use the SO(3) left
    /// Jacobian of their rotation vectors, so they are exact away from zero too. The link
    /// columns are the same for a prismatic joint (its slide only moves the frames). Effect
    /// columns are the joint's column (θ0's for a revolute joint, `[z_{j−1}; 0]` for a
    /// prismatic one) times ∂Δ_j/∂param (cyclic columns of prismatic and sensor joints and
    /// backlash columns of sensor joints are zero: those terms do not apply); the
    /// thermal column is
    /// `(T − 20)·Σ_i (d_i·col(d_i) + a_i·col(a_i))`. Columns of effects whose input is
    /// missing (approach directions, temperature) are zero.
    pub fn jacobian(&self, state: &JointState<N>, jac: &mut [JacobianColumn]) -> Result<Transform> {
        self.jacobian_with(state, jac, true)
    }

    /// [`Robot::jacobian`]; with `frame_rotations` false the base and tool rotation
    /// columns are not written (left as they were: for a caller that reads none of them,
    /// e.g. a contact fit, where they are gauges; they cost two `J_l(r)`, each a sine and
    /// cosine). Every column written, and the pose, are [`Robot::jacobian`]'s bit for bit.
    pub(crate) fn jacobian_with(
        &self,
        state: &JointState<N>,
        jac: &mut [JacobianColumn],
        frame_rotations: bool,
    ) -> Result<Transform> {
        self.jacobian_with_torques(state, jac, frame_rotations, &mut None)
    }

    /// [`Robot::jacobian_with`] with the gravity torques at the readings in `tau` when
    /// known (as [`Robot::fk_with_torques`]: every column and the pose bit for bit the
    /// same); when unknown and computed (compliance in the model, or the effect columns
    /// written), they are left in `tau`.
    pub(crate) fn jacobian_with_torques(
        &self,
        state: &JointState<N>,
        jac: &mut [JacobianColumn],
        frame_rotations: bool,
        tau: &mut Option<[f64; N]>,
    ) -> Result<Transform> {
        let links_only = jac.len() == 5 * N;
        let full = if jac.len() == Self::NUM_PARAMS {
            true
        } else if jac.len() == Self::NUM_GEOMETRIC_PARAMS || links_only {
            false
        } else {
            return Err(Error::DimensionMismatch {
                expected: Self::NUM_GEOMETRIC_PARAMS,
                found: jac.len(),
            });
        };
        let (angles, torques) = self.joint_angles_with_torques(state, tau.as_ref())?;
        if tau.is_none() {
            *tau = torques;
        }
        let scale = self.length_scale(state)?;
        let mut f = Frames::default();
        self.frames_at(&angles, scale, &mut f);
        let pe = f.t_base_ee.translation.vector;
        let col = |lin: Vector3<f64>, ang: Vector3<f64>| [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z];
        let zero = ZERO;
        // Frame i (before joint i+1) walks along with link i: iterators and `column3` rather
        // than `t_base_link[i - 1]` and `column(k)`, whose bounds checks stay (as panic paths)
        // where the optimiser does not inline (opt-level s/z).
        let mut prev = &f.t_base_0;
        for (i, (ti, xm)) in f.t_base_link.iter().zip(f.x_mid.iter()).enumerate() {
            let p_prev = prev.translation.vector;
            let z_prev = column3(prev.rotation.matrix(), 2);
            let pi = ti.translation.vector;
            let yi = column3(ti.rotation.matrix(), 1);
            let xm = *xm;
            let idx = |k: LinkParam| ParamId::Link { link: i, kind: k }.index(N).0;
            put(
                jac,
                idx(LinkParam::Theta0),
                col(z_prev.cross(&(pe - p_prev)), z_prev),
            );
            put(jac, idx(LinkParam::D), col(z_prev * scale, zero));
            put(jac, idx(LinkParam::A), col(xm * scale, zero));
            put(jac, idx(LinkParam::Alpha), col(xm.cross(&(pe - pi)), xm));
            put(jac, idx(LinkParam::Beta), col(yi.cross(&(pe - pi)), yi));
            prev = ti;
        }
        if links_only {
            return Ok(f.t_base_ee);
        }
        self.frame_columns(&f, jac, frame_rotations);
        if full {
            // The torques the compliance's angles used, bit for bit those computed again.
            let t = match *tau {
                Some(t) => t,
                None => self.gravity_torques(&state.q),
            };
            *tau = Some(t);
            self.effect_columns(state, scale, &f, &t, jac);
        }
        check_pose(&f.t_base_ee)?;
        Ok(f.t_base_ee)
    }

    /// The base and tool columns of [`Robot::jacobian`], from the frames `f`.
    fn frame_columns(&self, f: &Frames<N>, jac: &mut [JacobianColumn], rotations: bool) {
        let pe = f.t_base_ee.translation.vector;
        let col = |lin: Vector3<f64>, ang: Vector3<f64>| [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z];
        let zero = ZERO;
        // Tool: T_e = T_N·Trans(p)·Rot(r); dp moves along R_N's axes.
        let r_n = f
            .t_base_link
            .last()
            .map_or(*f.t_base_0.rotation.matrix(), |t| *t.rotation.matrix());
        for k in FrameParam::ALL.into_iter().take(3) {
            let ax = k as usize % 3;
            put(
                jac,
                ParamId::Base(k).index(N).0,
                col(column3(&IDENTITY, ax), zero),
            );
            put(
                jac,
                ParamId::Tool(k).index(N).0,
                col(column3(&r_n, ax), zero),
            );
        }
        if !rotations {
            return;
        }
        // Base: T_0^b = Trans(p)·Rot(r); a change dr rotates everything after it about the
        // base-frame axis J_l(r)·dr through p.
        let base_p = f.t_base_0.translation.vector;
        let jl_base = so3_left_jacobian(&Vector3::new(
            self.geom.base[3],
            self.geom.base[4],
            self.geom.base[5],
        ));
        // Tool: dr rotates about R_e·J_r(r)·dr with J_r(r) = J_l(r)ᵀ.
        let r_e = *f.t_base_ee.rotation.matrix();
        let jr_tool = so3_left_jacobian(&Vector3::new(
            self.geom.tool[3],
            self.geom.tool[4],
            self.geom.tool[5],
        ))
        .transpose();
        for k in FrameParam::ALL.into_iter().skip(3) {
            let ax = k as usize % 3;
            let w = column3(&jl_base, ax);
            let wt = mat_vec(&r_e, &column3(&jr_tool, ax));
            put(
                jac,
                ParamId::Base(k).index(N).0,
                col(w.cross(&(pe - base_p)), w),
            );
            put(jac, ParamId::Tool(k).index(N).0, col(zero, wt));
        }
    }

    /// Effect columns, from the θ0, d and a columns already in `jac`, the frames `f` (the
    /// axes of prismatic joints) and the gravity torques `tau` at the readings.
    fn effect_columns(
        &self,
        state: &JointState<N>,
        scale: f64,
        f: &Frames<N>,
        tau: &[f64; N],
        jac: &mut [JacobianColumn],
    ) {
        let approach = state.approach.unwrap_or([0.0; N]);
        let scaled = |c: JacobianColumn, f: f64| c.map(|v| v * f);
        let mut thermal = [0.0; 6];
        let turn = self.turn_mask();
        // Iterators rather than `q[j]`, `tau[j]`, …: no bounds check left to the optimiser.
        let per_joint = state.q.iter().zip(tau.iter()).zip(approach.iter());
        let mut prev = &f.t_base_0;
        let frames = f.t_base_link.iter().zip(turn.iter());
        for ((j, ((&q, &tau_j), &approach_j)), (ti, &turn_j)) in per_joint.enumerate().zip(frames) {
            let z_prev = column3(prev.rotation.matrix(), 2);
            prev = ti;
            // ∂pose/∂(joint displacement): θ0's column, or the unscaled slide direction.
            let th = if turn_j == 0.0 {
                [z_prev.x, z_prev.y, z_prev.z, 0.0, 0.0, 0.0]
            } else {
                col_at(
                    jac,
                    ParamId::Link {
                        link: j,
                        kind: LinkParam::Theta0,
                    }
                    .index(N)
                    .0,
                )
            };
            let (s1, c1) = crate::math::sin_cos(q);
            // No cyclic error on a slide (the terms are periodic in an angle) nor on a sensor
            // joint (no gearing); no backlash on a sensor joint (no transmission).
            let kind = self.joint_kind(j);
            let geared = if kind == crate::JointKind::Revolute {
                1.0
            } else {
                0.0
            };
            let transmits = if kind == crate::JointKind::Sensor {
                0.0
            } else {
                1.0
            };
            let terms = [s1, c1, 2.0 * s1 * c1, c1 * c1 - s1 * s1].map(|t| t * geared);
            put(jac, ParamId::Compliance(j).index(N).0, scaled(th, tau_j));
            put(jac, ParamId::Scale(j).index(N).0, scaled(th, q));
            for (t, term) in CyclicTerm::ALL.into_iter().zip(terms) {
                put(jac, ParamId::Cyclic(j, t).index(N).0, scaled(th, term));
            }
            put(
                jac,
                ParamId::Backlash(j).index(N).0,
                scaled(th, approach_j * transmits),
            );
            // The d and a columns carry the factor `scale`; ∂/∂(scaled length) = col/scale.
            let Some(l) = self.geom.links.get(j) else {
                continue;
            };
            let dcol = col_at(
                jac,
                ParamId::Link {
                    link: j,
                    kind: LinkParam::D,
                }
                .index(N)
                .0,
            );
            let acol = col_at(
                jac,
                ParamId::Link {
                    link: j,
                    kind: LinkParam::A,
                }
                .index(N)
                .0,
            );
            for ((th, d), a) in thermal.iter_mut().zip(dcol).zip(acol) {
                *th += (l.d * d + l.a * a) / scale;
            }
        }
        let dt = state
            .temp_c
            .map_or(0.0, |t| t - crate::model::THERMAL_REFERENCE_C);
        put(jac, ParamId::Thermal.index(N).0, scaled(thermal, dt));
    }
}

/// Writes column `i`. The caller checked `jac.len()`; `get_mut` rather than indexing keeps a
/// bounds check the compiler cannot elide (and its panic path) out of the panic-free build.
#[inline(always)]
fn put(jac: &mut [JacobianColumn], i: usize, column: JacobianColumn) {
    if let Some(slot) = jac.get_mut(i) {
        *slot = column;
    }
}

/// Reads column `i` (zero out of range, which the length check excludes), see [`put`].
#[inline(always)]
fn col_at(jac: &[JacobianColumn], i: usize) -> JacobianColumn {
    jac.get(i).copied().unwrap_or([0.0; 6])
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// `Robot::joint_jacobian` takes each joint's preceding frame straight from the chain;
    /// the IK builds the same columns from [`Frames`]: both must agree to the bit, with
    /// effects (scale, cyclic: the dθ/dq factor) and with a prismatic joint.
    #[test]
    fn joint_jacobian_from_the_chain_equals_the_one_from_frames() {
        let mut rng = 0x9E37_79B9_7F4A_7C15_u64;
        let mut uniform = |lo: f64, hi: f64| {
            rng = rng.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            lo + (hi - lo) * ((rng >> 11) as f64 / (1u64 << 53) as f64)
        };
        let plain = crate::aria::nominal();
        let mut effects = plain;
        let n_geom = Robot::<6>::NUM_GEOMETRIC_PARAMS;
        for i in n_geom..Robot::<6>::NUM_PARAMS {
            effects
                .set_param(crate::error::ParamIndex(i), uniform(-1e-3, 1e-3))
                .unwrap();
        }
        let mut slide = plain;
        slide
            .set_joint_kind(2, crate::JointKind::Prismatic)
            .unwrap();
        for robot in [plain, effects, slide] {
            for _ in 0..200 {
                let q = core::array::from_fn(|_| uniform(-3.0, 3.0));
                let mut state = JointState::new(q);
                state.approach = Some([1.0, -1.0, 0.0, 1.0, -1.0, 1.0]);
                state.temp_c = Some(24.0);
                let mut cols = [[0.0; 6]; 6];
                let t = robot.joint_jacobian(&state, &mut cols).unwrap();
                let mut f = Frames::default();
                robot.fk_frames(&state, &mut f).unwrap();
                let want = crate::ik::joint_jacobian(&robot, &state, &f).data.0;
                for (a, b) in cols.iter().flatten().zip(want.iter().flatten()) {
                    assert_eq!(a.to_bits(), b.to_bits(), "q {q:?}");
                }
                assert_eq!(t, f.t_base_ee);
            }
        }
    }

    #[test]
    fn jacobian_without_frame_rotations_writes_the_rest_bit_for_bit() {
        let mut robot = crate::aria::nominal();
        // Base and tool rotations away from zero, so their columns are not trivial.
        for (i, v) in [(33, 0.1), (34, -0.2), (39, 0.3), (41, -0.4)] {
            robot.set_param(crate::error::ParamIndex(i), v).unwrap();
        }
        let state = JointState::new([0.3, -0.7, 1.1, 0.2, -0.5, 0.9]);
        let n = Robot::<6>::NUM_PARAMS;
        let mut all = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
        let t = robot.jacobian(&state, &mut all).unwrap();
        let mut some = [[f64::NAN; 6]; Robot::<6>::NUM_PARAMS];
        let t2 = robot.jacobian_with(&state, &mut some, false).unwrap();
        assert_eq!(t, t2);
        let rotation = |i: usize| {
            FrameParam::ALL
                .into_iter()
                .skip(3)
                .any(|k| i == ParamId::Base(k).index(6).0 || i == ParamId::Tool(k).index(6).0)
        };
        for i in 0..n {
            if rotation(i) {
                assert!(some[i].iter().all(|v| v.is_nan()), "column {i} written");
            } else {
                assert_eq!(some[i].map(f64::to_bits), all[i].map(f64::to_bits), "{i}");
            }
        }
        assert_eq!((0..n).filter(|&i| rotation(i)).count(), 6);
    }
}
