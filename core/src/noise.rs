//! Noise-floor estimates from measured data, shared by the sim-to-real diagnosis
//! ([`crate::diagnosis`]) and by callers that report a noise floor themselves (the CLI's
//! `crossval`), so that the two cannot disagree:
//!
//! - [`pooled_repeat_scatter`]: the pooled within-repeat scatter of the residuals, per axis,
//!   over subgroups of repeated measurements ([`repeat_leader`] forms them from group ids and
//!   [`same_conditions`]);
//! - [`residual_sigma`]: an upper bound from a fitted model's residuals, per axis, corrected
//!   for the fitted parameters.
//!
//! No memory of their own: the caller supplies the grouping and the residuals as closures or
//! iterators (slices of its own, or values computed on the fly).

use crate::identify::{ComponentMask, Measurement};
use crate::math::sqrt;
use crate::validation::PoseErrors;

/// Whether measurements `a` and `b` of the same group are repeats of the same physical
/// pose: same measured components, same approach directions (backlash makes
/// opposite-direction repeats differ, spec/effects.md), and — our extension of the same
/// reasoning to thermal expansion — temperatures within `temp_tol_c` (or both absent).
#[must_use]
pub fn same_conditions<const N: usize>(
    a: &Measurement<N>,
    b: &Measurement<N>,
    temp_tol_c: f64,
) -> bool {
    let temp_ok = match (a.state.temp_c, b.state.temp_c) {
        (None, None) => true,
        (Some(x), Some(y)) => (x - y).abs() <= temp_tol_c,
        _ => false,
    };
    a.mask == b.mask && a.state.approach == b.state.approach && temp_ok
}

/// The repeat-subgroup leader of measurement `l`: the first earlier measurement of the same
/// group (`group_leader(m) == group_leader(l)`, the index of the group's first measurement)
/// whose conditions match ([`same_conditions`]), else `l` itself. A subgroup is a leader
/// and the measurements whose leader it is. O(l) time.
#[must_use]
pub fn repeat_leader<const N: usize>(
    data: &[Measurement<N>],
    l: usize,
    group_leader: impl Fn(usize) -> usize,
    temp_tol_c: f64,
) -> usize {
    let g = group_leader(l);
    repeat_leader_among(
        data,
        l,
        (0..l).filter(|&m| group_leader(m) == g),
        temp_tol_c,
    )
}

/// [`repeat_leader`] given the rows of `l`'s group in ascending order (`members`, possibly
/// running past `l`): O(group size) time when the caller keeps its groups as lists.
#[must_use]
pub fn repeat_leader_among<const N: usize>(
    data: &[Measurement<N>],
    l: usize,
    members: impl Iterator<Item = usize>,
    temp_tol_c: f64,
) -> usize {
    let Some(row) = data.get(l) else {
        return l;
    };
    members
        .take_while(|&m| m < l)
        .find(|&m| {
            data.get(m)
                .is_some_and(|d| same_conditions(d, row, temp_tol_c))
        })
        .unwrap_or(l)
}

/// Pooled within-subgroup sums of squares of residuals, per axis (see
/// [`pooled_repeat_scatter`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RepeatScatter {
    /// Σ over subgroups and position axes of the squared deviation from the subgroup mean
    /// \[m²\].
    pub ss_pos: f64,
    /// Degrees of freedom of `ss_pos`: Σ (rows measuring the axis − 1) over subgroups and
    /// position axes.
    pub dof_pos: usize,
    /// As `ss_pos` for the rotation axes \[rad²\].
    pub ss_rot: f64,
    /// Degrees of freedom of `ss_rot`.
    pub dof_rot: usize,
    /// Subgroups with at least two rows.
    pub subgroups: usize,
}

impl RepeatScatter {
    /// Pooled position noise, 1σ per axis \[m\]: `√(ss_pos / dof_pos)`; `None` without
    /// degrees of freedom.
    #[must_use]
    pub fn sigma_pos_m(&self) -> Option<f64> {
        (self.dof_pos > 0).then(|| sqrt(self.ss_pos / self.dof_pos as f64))
    }
    /// Pooled rotation noise, 1σ per axis \[rad\]; `None` without degrees of freedom.
    #[must_use]
    pub fn sigma_rot_rad(&self) -> Option<f64> {
        (self.dof_rot > 0).then(|| sqrt(self.ss_rot / self.dof_rot as f64))
    }
}

/// The pooled scatter of residuals within repeat subgroups: for every subgroup of two or
/// more of the `n` rows and every axis k (`[x, y, z, φx, φy, φz]`), the squared deviations
/// of the residuals `e_k` of the rows measuring k (`mask(l).has(k)`) from their mean,
/// summed, with (rows − 1) degrees of freedom per axis; an axis measured by fewer than two
/// rows of a subgroup adds nothing.
///
/// `sub_leader(l)` is row `l`'s subgroup: the index of its first row (`≤ l`; rows whose
/// leader does not lead itself belong to no subgroup). `residual(l)` is row `l`'s residual,
/// measured minus model (any model close to the arm: residual differences between repeats
/// remove the model's prediction exactly when the readings are equal, and to second order
/// otherwise); it is called twice per row of a subgroup and never for the other rows, and
/// its first error is returned. O(n²) time, no memory.
pub fn pooled_repeat_scatter<E>(
    n: usize,
    sub_leader: impl Fn(usize) -> usize,
    mask: impl Fn(usize) -> ComponentMask,
    residual: impl FnMut(usize) -> Result<[f64; 6], E>,
) -> Result<RepeatScatter, E> {
    pooled_repeat_scatter_linked(n, sub_leader, |l| l + 1, mask, residual)
}

/// [`pooled_repeat_scatter`] with the rows that may share a subgroup linked: `next(l)` is
/// the next row after `l` that may (its group's next row; `n` or more after the last), so a
/// subgroup's members are found in O(group size) instead of O(n). Same sums in the same
/// order as the unlinked form.
pub fn pooled_repeat_scatter_linked<E>(
    n: usize,
    sub_leader: impl Fn(usize) -> usize,
    next: impl Fn(usize) -> usize,
    mask: impl Fn(usize) -> ComponentMask,
    mut residual: impl FnMut(usize) -> Result<[f64; 6], E>,
) -> Result<RepeatScatter, E> {
    let mut out = RepeatScatter::default();
    for s in 0..n {
        if sub_leader(s) != s {
            continue;
        }
        let members = || {
            core::iter::successors(Some(s), |&l| Some(next(l)))
                .take_while(|&l| l < n)
                .filter(|&l| sub_leader(l) == s)
        };
        if members().count() < 2 {
            continue;
        }
        out.subgroups += 1;
        let mut count = [0usize; 6];
        for l in members() {
            for (k, c) in count.iter_mut().enumerate() {
                if mask(l).has(k) {
                    *c += 1;
                }
            }
        }
        let mut mean = [0.0; 6];
        for l in members() {
            let e = residual(l)?;
            for k in (0..6).filter(|&k| mask(l).has(k)) {
                mean[k] += e[k] / count[k] as f64;
            }
        }
        for l in members() {
            let e = residual(l)?;
            for k in (0..6).filter(|&k| mask(l).has(k) && count[k] >= 2) {
                let d = e[k] - mean[k];
                if k < 3 {
                    out.ss_pos += d * d;
                } else {
                    out.ss_rot += d * d;
                }
            }
        }
        for (k, &c) in count.iter().enumerate().filter(|&(_, &c)| c >= 2) {
            if k < 3 {
                out.dof_pos += c - 1;
            } else {
                out.dof_rot += c - 1;
            }
        }
    }
    Ok(out)
}

/// Per-axis residual σ of a fitted model: an upper bound of the noise floor (it contains
/// whatever the model does not explain).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ResidualSigma {
    /// Position σ per axis \[m\] (0 without position rows; infinite when the parameters use
    /// up every row).
    pub sigma_pos_m: f64,
    /// Rotation σ per axis \[rad\] (as `sigma_pos_m`).
    pub sigma_rot_rad: f64,
    /// Position rows (measured position components).
    pub rows_pos: usize,
    /// Rotation rows (measured rotation components).
    pub rows_rot: usize,
}

/// Per-axis residual σ of a model with `fitted_params` fitted parameters from its per-pose
/// errors and the components each pose measures: `σ² = Σ|e|² / rows · rows_all /
/// (rows_all − p)` separately for position and rotation, where `rows_all` counts every
/// measured component (the fit's rows) and the factor corrects for the fitted parameters.
/// A pose measuring all three components of a kind adds its squared norm and three rows;
/// one measuring some adds those components and rows. O(n) time, no memory.
#[must_use]
pub fn residual_sigma(
    poses: impl IntoIterator<Item = (PoseErrors, ComponentMask)>,
    fitted_params: usize,
) -> ResidualSigma {
    let (mut sp, mut np, mut sr, mut nr) = (0.0, 0usize, 0.0, 0usize);
    for (e, mask) in poses {
        if mask.has_position() {
            sp += e.pos_norm_m * e.pos_norm_m;
            np += 3;
        } else {
            for k in (0..3).filter(|&k| mask.has(k)) {
                sp += e.pos_m[k] * e.pos_m[k];
                np += 1;
            }
        }
        if mask.has_orientation() {
            sr += e.rot_norm_rad * e.rot_norm_rad;
            nr += 3;
        } else {
            for k in (0..3).filter(|&k| mask.has(3 + k)) {
                sr += e.rot_rad[k] * e.rot_rad[k];
                nr += 1;
            }
        }
    }
    let rows = np + nr;
    let corr = if rows > fitted_params {
        rows as f64 / (rows - fitted_params) as f64
    } else {
        f64::INFINITY
    };
    let s = |ss: f64, n: usize| {
        if n > 0 {
            sqrt(ss / n as f64 * corr)
        } else {
            0.0
        }
    };
    ResidualSigma {
        sigma_pos_m: s(sp, np),
        sigma_rot_rad: s(sr, nr),
        rows_pos: np,
        rows_rot: nr,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: ComponentMask = ComponentMask::POSITION;
    const A: ComponentMask = ComponentMask::ALL;

    /// Hand-computed pooled scatter. Rows (subgroup leader, mask, residual):
    ///
    /// 0: (0, ALL, x=1, y=0, z=0, φx=0.1, φy=φz=0)
    /// 1: (1, POS, x=5)                        — a singleton: ignored
    /// 2: (0, ALL, x=3, y=2, z=0, φx=0.3, φy=φz=0)
    /// 3: (3, POS, x=0, y=1, z=2)
    /// 4: (0, ALL, x=2, y=4, z=0, φx=0.2, φy=φz=0)
    /// 5: (3, POS, x=2, y=1, z=0)
    ///
    /// Subgroup {0, 2, 4}: x: mean 2, deviations −1, 1, 0 → 2; y: mean 2, deviations −2, 0,
    /// 2 → 8; z: 0; φx: mean 0.2, deviations ∓0.1 → 0.02; dof 2 per axis.
    /// Subgroup {3, 5}: x: mean 1 → 1 + 1 = 2; y: 0; z: mean 1 → 2; dof 1 per axis.
    /// ss_pos = 2 + 8 + 0 + 2 + 0 + 2 = 14 over dof 3·2 + 3·1 = 9: σ_pos = √(14/9);
    /// ss_rot = 0.02 over dof 3·2 = 6: σ_rot = √(0.02/6).
    #[test]
    fn pooled_scatter_matches_a_hand_computed_value() {
        let leader = [0, 1, 0, 3, 0, 3];
        let mask = [A, P, A, P, A, P];
        let e = [
            [1.0, 0.0, 0.0, 0.1, 0.0, 0.0],
            [5.0, 0.0, 0.0, 9.0, 9.0, 9.0],
            [3.0, 2.0, 0.0, 0.3, 0.0, 0.0],
            [0.0, 1.0, 2.0, 9.0, 9.0, 9.0],
            [2.0, 4.0, 0.0, 0.2, 0.0, 0.0],
            [2.0, 1.0, 0.0, 9.0, 9.0, 9.0],
        ];
        let mut calls = [0; 6];
        let s = pooled_repeat_scatter::<()>(
            6,
            |l| leader[l],
            |l| mask[l],
            |l| {
                calls[l] += 1;
                Ok(e[l])
            },
        )
        .unwrap();
        assert_eq!(s.subgroups, 2);
        assert_eq!((s.dof_pos, s.dof_rot), (9, 6));
        assert!((s.ss_pos - 14.0).abs() < 1e-12, "{}", s.ss_pos);
        assert!((s.ss_rot - 0.02).abs() < 1e-15, "{}", s.ss_rot);
        assert!((s.sigma_pos_m().unwrap() - (14.0f64 / 9.0).sqrt()).abs() < 1e-12);
        assert!((s.sigma_rot_rad().unwrap() - (0.02f64 / 6.0).sqrt()).abs() < 1e-12);
        // The singleton's residual is never needed.
        assert_eq!(calls, [2, 0, 2, 2, 2, 2]);
        // No repeats: no degrees of freedom, no σ.
        let none = pooled_repeat_scatter::<()>(3, |l| l, |_| A, |_| Ok([1.0; 6])).unwrap();
        assert_eq!(none, RepeatScatter::default());
        assert_eq!(none.sigma_pos_m(), None);
        // The first error is returned.
        assert_eq!(pooled_repeat_scatter(2, |_| 0, |_| A, Err), Err(0usize));
    }

    #[test]
    fn subgroups_split_by_approach_temperature_and_mask() {
        use crate::pose::Transform;
        let m = |approach: f64, temp: Option<f64>, mask: ComponentMask| {
            let mut x = Measurement::<1>::new([0.0], Transform::identity());
            x.state.approach = Some([approach]);
            x.state.temp_c = temp;
            x.mask = mask;
            x
        };
        let data = [
            m(1.0, Some(20.0), A),  // 0: group 0
            m(1.0, Some(20.4), A),  // 1: group 0, same conditions as 0
            m(-1.0, Some(20.0), A), // 2: group 0, other approach
            m(1.0, Some(21.0), A),  // 3: group 0, warmer
            m(1.0, Some(20.0), P),  // 4: group 0, other components
            m(1.0, Some(20.0), A),  // 5: group 5
            m(-1.0, Some(20.2), A), // 6: group 0, as 2
        ];
        let group = [0, 0, 0, 0, 0, 5, 0];
        let lead: [usize; 7] = core::array::from_fn(|l| repeat_leader(&data, l, |m| group[m], 0.5));
        assert_eq!(lead, [0, 0, 2, 3, 4, 5, 2]);
        assert!(!same_conditions(&data[0], &m(1.0, None, A), 0.5));
    }

    /// Two full poses with |e_p| = 3 and 4, |e_φ| = 1 and 2, and one position-only pose
    /// with |e_p| = 12: rows 3 + 3 + 3 position, 6 rotation; with p = 3 fitted parameters
    /// the correction is 15/12. σ_pos² = (9 + 16 + 144)/9 · 15/12, σ_rot² = 5/6 · 15/12.
    #[test]
    fn residual_sigma_matches_a_hand_computed_value() {
        let e = |p: f64, r: f64| PoseErrors {
            pos_m: [p, 0.0, 0.0],
            rot_rad: [0.0, r, 0.0],
            pos_norm_m: p,
            rot_norm_rad: r,
        };
        let poses = [(e(3.0, 1.0), A), (e(4.0, 2.0), A), (e(12.0, 0.0), P)];
        let s = residual_sigma(poses, 3);
        assert_eq!((s.rows_pos, s.rows_rot), (9, 6));
        let want_p = (169.0f64 / 9.0 * 15.0 / 12.0).sqrt();
        let want_r = (5.0f64 / 6.0 * 15.0 / 12.0).sqrt();
        assert!((s.sigma_pos_m - want_p).abs() < 1e-12, "{}", s.sigma_pos_m);
        assert!(
            (s.sigma_rot_rad - want_r).abs() < 1e-12,
            "{}",
            s.sigma_rot_rad
        );
        // Parameters using up every row: unbounded; no rotation rows: zero.
        let s = residual_sigma([(e(1.0, 0.0), P)], 3);
        assert!(s.sigma_pos_m.is_infinite());
        assert_eq!((s.sigma_rot_rad, s.rows_rot), (0.0, 0));
        // A partial mask counts the measured components only.
        let s = residual_sigma([(e(2.0, 5.0), ComponentMask(0b0000_1001))], 0);
        assert_eq!((s.rows_pos, s.rows_rot), (1, 1));
        assert!((s.sigma_pos_m - 2.0).abs() < 1e-15);
        assert_eq!(s.sigma_rot_rad, 0.0);
    }
}
