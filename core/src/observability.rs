//! Observability indices of a set of poses (Section 3.3, eq. 17, and the literature's
//! O1–O5): how well the poses determine the identified parameters, from the singular values
//! of the stacked, scaled identification Jacobian at the nominal model.
//!
//! For poses `q^1..q^m` the stacked Jacobian `J` (6m × p) has one 6-row block per pose
//! (rows `[Δp (m); w·Δφ (rad)]`, `w` = [`ObservabilityOptions::rot_weight`]) and one column
//! per identified parameter, scaled as [`ColumnScaling`] says. With its singular values
//! `σ_1 ≥ … ≥ σ_p` ([`Indices`]):
//!
//! | index | value | source |
//! |---|---|---|
//! | O (eq. 17) | σ_p/σ_1 | the paper |
//! | O1 | (σ_1···σ_p)^(1/p)/√m | Borm & Menq |
//! | O2 | σ_p/σ_1 (inverse condition number, equal to O) | Driels & Pathre |
//! | O3 | σ_p | Nahvi et al. |
//! | O4 | σ_p²/σ_1 (noise amplification) | Nahvi & Hollerbach |
//! | O5 | 1/σ_1 | spec/aria.md |
//! | A | 1/(1/σ_1 + … + 1/σ_p) | Sun & Hollerbach's O5 |
//! | D | ln det(JᵀJ) = 2 Σ ln σ_k | D-optimality |
//!
//! The per-pose index ([`pose_singular_values`]) is the six singular values of one pose's
//! 6 × p block, what the workspace-clustering design compares between poses.
//!
//! Two routes to the singular values: [`observability`] folds the rows into a Givens
//! factor and runs a one-sided Jacobi SVD on it (backward stable, the reported numbers);
//! [`indices_from_gram`] takes the eigenvalues of the Gram matrix `JᵀJ` (cheap, used to rank
//! thousands of candidate sets in [`crate::selection`]; relative accuracy of σ_p about
//! ε·(σ_1/σ_p)², ample for ranking).

use crate::error::ParamIndex;
use crate::error::{Error, Result};
use crate::identify::{ComponentMask, Workspace};
use crate::linalg::svd::jacobi_svd;
use crate::linalg::symeig::sym_eigenvalues;
use crate::math::sqrt;
use crate::model::{JointState, Robot};
use crate::params::{ParamId, ParamSet};
use crate::pose::Transform;

/// One pose's rows of the scaled identification Jacobian: `block[r][k]` is row `r`
/// (`x, y, z, φx, φy, φz`) and column `k` (the k-th parameter of the set, in index order).
pub type PoseBlock<const P: usize> = [[f64; P]; 6];

/// How the Jacobian columns are scaled before the singular values are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColumnScaling {
    /// Raw columns (metres per metre, metres per radian): the index then depends on units.
    None,
    /// Every column of the stacked Jacobian divided by its norm over the pose set
    /// (equilibration; the convention of [`crate::identify::Identifiability`]'s condition
    /// number). For one pose ([`pose_singular_values`]) the pose's own column norms.
    UnitColumns,
    /// Columns times the expected size of their parameter's error: `length_m` for lengths,
    /// `angle_rad` for angles (effect parameters unscaled), so the singular values are pose
    /// errors caused by parameter errors of one tolerance.
    Tolerance {
        /// Tolerance of lengths \[m\].
        length_m: f64,
        /// Tolerance of angles \[rad\].
        angle_rad: f64,
    },
}

/// Options of the observability computations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservabilityOptions {
    /// Parameters (flat indices), one column each in index order.
    pub params: ParamSet,
    /// Column scaling.
    pub scaling: ColumnScaling,
    /// Measured components (rows outside the mask are left out).
    pub mask: ComponentMask,
    /// Factor on the orientation rows [m/rad]; 1 weighs metres and radians alike, as the
    /// paper's identification does.
    pub rot_weight: f64,
}

impl ObservabilityOptions {
    /// Unit-column scaling, full poses, orientation weight 1.
    #[must_use]
    pub fn new(params: ParamSet) -> Self {
        ObservabilityOptions {
            params,
            scaling: ColumnScaling::UnitColumns,
            mask: ComponentMask::ALL,
            rot_weight: 1.0,
        }
    }
    fn check(&self) -> Result<()> {
        let bad = |v: f64| !(v.is_finite() && v > 0.0);
        if bad(self.rot_weight) {
            return Err(Error::InvalidParameter {
                index: 0,
                value: self.rot_weight,
            });
        }
        if let ColumnScaling::Tolerance {
            length_m,
            angle_rad,
        } = self.scaling
            && (bad(length_m) || bad(angle_rad))
        {
            return Err(Error::InvalidParameter {
                index: 1,
                value: if bad(length_m) { length_m } else { angle_rad },
            });
        }
        if self.params.is_empty() || self.mask.0 == 0 || self.mask.0 & !0x3f != 0 {
            return Err(Error::TooFewData {
                found: 0,
                needed: 1,
            });
        }
        Ok(())
    }
}

/// The observability indices of one pose set (see the module table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Indices {
    /// Number of poses m.
    pub poses: usize,
    /// Number of parameters p (columns).
    pub params: usize,
    /// Largest singular value σ_1.
    pub sigma_max: f64,
    /// Smallest singular value σ_p.
    pub sigma_min: f64,
    /// Eq. (17): σ_p/σ_1.
    pub o: f64,
    /// Borm–Menq: (Π σ)^(1/p)/√m.
    pub o1: f64,
    /// Inverse condition number σ_p/σ_1 (equal to `o`).
    pub o2: f64,
    /// σ_p.
    pub o3: f64,
    /// Noise amplification σ_p²/σ_1.
    pub o4: f64,
    /// 1/σ_1 (spec/aria.md's O5; infinite for a zero Jacobian).
    pub o5: f64,
    /// 1/Σ σ_k⁻¹ (Sun & Hollerbach's O5, related to A-optimality; 0 if rank-deficient).
    pub a_opt: f64,
    /// ln det(JᵀJ) = 2 Σ ln σ_k (−∞ if rank-deficient).
    pub log_det: f64,
}

impl Indices {
    /// The indices of singular values `sv` (any order, non-negative) of a stack of `poses`
    /// poses. Empty `sv` gives all zeros (and `log_det = 0`).
    #[must_use]
    pub fn from_singular_values(sv: &[f64], poses: usize) -> Self {
        let p = sv.len();
        let smax = sv.iter().fold(0.0f64, |a, &b| a.max(b));
        let smin = sv.iter().fold(f64::INFINITY, |a, &b| a.min(b.max(0.0)));
        let smin = if p == 0 { 0.0 } else { smin };
        let sum_ln: f64 = sv.iter().map(|&s| crate::math::ln(s.max(0.0))).sum();
        let sum_inv: f64 = sv.iter().map(|&s| 1.0 / s.max(0.0)).sum();
        let ratio = if smax > 0.0 { smin / smax } else { 0.0 };
        let full = p > 0 && smin > 0.0;
        Indices {
            poses,
            params: p,
            sigma_max: smax,
            sigma_min: smin,
            o: ratio,
            o1: if full {
                crate::math::exp(sum_ln / p as f64) / sqrt(poses.max(1) as f64)
            } else {
                0.0
            },
            o2: ratio,
            o3: smin,
            o4: if smax > 0.0 { smin * smin / smax } else { 0.0 },
            o5: if smax > 0.0 {
                1.0 / smax
            } else {
                f64::INFINITY
            },
            a_opt: if full { 1.0 / sum_inv } else { 0.0 },
            log_det: if p == 0 {
                0.0
            } else if full {
                2.0 * sum_ln
            } else {
                f64::NEG_INFINITY
            },
        }
    }

    /// The value of one index.
    #[must_use]
    pub fn get(&self, index: Index) -> f64 {
        match index {
            Index::O => self.o,
            Index::O1 => self.o1,
            Index::O2 => self.o2,
            Index::O3 => self.o3,
            Index::O4 => self.o4,
            Index::O5 => self.o5,
            Index::AOpt => self.a_opt,
            Index::DOpt => self.log_det,
        }
    }
}

/// A named observability index; every one is "larger is better".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Index {
    /// Eq. (17), σ_min/σ_max.
    O,
    /// Borm–Menq.
    O1,
    /// Inverse condition number.
    O2,
    /// Minimum singular value.
    O3,
    /// Noise amplification index.
    O4,
    /// 1/σ_max.
    O5,
    /// 1/Σ σ⁻¹.
    AOpt,
    /// ln det(JᵀJ).
    DOpt,
}

impl Index {
    /// Every index.
    pub const ALL: [Index; 8] = [
        Index::O,
        Index::O1,
        Index::O2,
        Index::O3,
        Index::O4,
        Index::O5,
        Index::AOpt,
        Index::DOpt,
    ];
    /// Lower-case name: `o`, `o1` … `o5`, `aopt`, `dopt`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Index::O => "o",
            Index::O1 => "o1",
            Index::O2 => "o2",
            Index::O3 => "o3",
            Index::O4 => "o4",
            Index::O5 => "o5",
            Index::AOpt => "aopt",
            Index::DOpt => "dopt",
        }
    }
    /// Parses a name of [`Index::name`].
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        Index::ALL.into_iter().find(|i| i.name() == s)
    }
}

/// Column factor of parameter `i` under `scaling` (1 for `None` and `UnitColumns`).
fn column_factor(scaling: ColumnScaling, i: usize, n_joints: usize) -> f64 {
    match scaling {
        ColumnScaling::Tolerance {
            length_m,
            angle_rad,
        } => match ParamId::from_index(ParamIndex(i), n_joints) {
            Ok(id) if id.is_length() => length_m,
            Ok(ParamId::Link { .. } | ParamId::Base(_) | ParamId::Tool(_)) => angle_rad,
            _ => 1.0,
        },
        _ => 1.0,
    }
}

/// The 6 × p block of configuration `q` at `robot`'s parameters: rows outside the mask are
/// zero, orientation rows weighted, columns scaled by [`ColumnScaling::Tolerance`] if asked
/// (unit-column scaling is a property of a set and is not applied here). Returns the
/// end-effector pose.
pub fn pose_block<const N: usize, const P: usize>(
    robot: &Robot<N>,
    q: &[f64; N],
    opts: &ObservabilityOptions,
    ws: &mut Workspace<P>,
    out: &mut PoseBlock<P>,
) -> Result<Transform> {
    opts.check()?;
    let n = opts.params.len();
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    if let Some(bad) = opts.params.iter().find(|&i| i >= Robot::<N>::NUM_PARAMS) {
        return Err(Error::DimensionMismatch {
            expected: Robot::<N>::NUM_PARAMS,
            found: bad + 1,
        });
    }
    let full = opts
        .params
        .iter()
        .any(|i| i >= Robot::<N>::NUM_GEOMETRIC_PARAMS);
    let n_jac = if full {
        Robot::<N>::NUM_PARAMS
    } else {
        Robot::<N>::NUM_GEOMETRIC_PARAMS
    };
    let jac = ws.jac.get_mut(..n_jac).ok_or(Error::CapacityExceeded {
        needed: n_jac,
        capacity: crate::identify::MAX_MODEL_PARAMS,
    })?;
    let t = robot.jacobian(&JointState::new(*q), jac)?;
    for (r, row) in out.iter_mut().enumerate() {
        let w = if !opts.mask.has(r) {
            0.0
        } else if r < 3 {
            1.0
        } else {
            opts.rot_weight
        };
        for (k, i) in opts.params.iter().enumerate() {
            row[k] = w * jac[i][r] * column_factor(opts.scaling, i, N);
        }
        for v in row.iter_mut().skip(n) {
            *v = 0.0;
        }
    }
    Ok(t)
}

/// The indices of the poses `qs` (stacked Jacobian at `robot`'s parameters, normally the
/// nominal model): rows folded into a Givens factor `R` (same singular values as `J`),
/// unit-column scaling applied to `R`'s columns, one-sided Jacobi SVD. The singular values
/// (descending) stay in `ws` ([`Workspace::singular_values`]).
///
/// Errors: as [`pose_block`]; `TooFewData` for no poses; `NotConverged` from the SVD.
pub fn observability<const N: usize, const P: usize>(
    robot: &Robot<N>,
    qs: &[[f64; N]],
    opts: &ObservabilityOptions,
    ws: &mut Workspace<P>,
) -> Result<Indices> {
    opts.check()?;
    if qs.is_empty() {
        return Err(Error::TooFewData {
            found: 0,
            needed: 1,
        });
    }
    let n = opts.params.len();
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    ws.lsq.reset(n)?;
    let mut block = [[0.0; P]; 6];
    for q in qs {
        pose_block(robot, q, opts, ws, &mut block)?;
        for (r, row) in block.iter().enumerate() {
            if opts.mask.has(r) {
                ws.lsq.add_row(&row[..n], 0.0)?;
            }
        }
    }
    let r = ws.lsq.r();
    for i in 0..n {
        for j in 0..n {
            ws.mat[i][j] = if j >= i { r[i][j] } else { 0.0 };
        }
    }
    if opts.scaling == ColumnScaling::UnitColumns {
        for j in 0..n {
            let norm = sqrt((0..=j).map(|i| ws.mat[i][j] * ws.mat[i][j]).sum::<f64>());
            if norm > 0.0 {
                for i in 0..=j {
                    ws.mat[i][j] /= norm;
                }
            }
        }
    }
    let Workspace { mat, sv, v, .. } = ws;
    jacobi_svd(mat, n, sv, v)?;
    ws.n_sv = n;
    Ok(Indices::from_singular_values(&ws.sv[..n], qs.len()))
}

/// Adds (`sign = 1`) or removes (`sign = -1`) one pose block's contribution `BᵀB` to the
/// upper triangle of the `n`×`n` Gram matrix `g`.
pub fn gram_update<const P: usize>(
    g: &mut [[f64; P]; P],
    block: &PoseBlock<P>,
    n: usize,
    sign: f64,
) {
    let n = n.min(P);
    for row in block.iter() {
        for i in 0..n {
            let a = sign * row[i];
            if a == 0.0 {
                continue;
            }
            for (gij, &rj) in g[i][i..n].iter_mut().zip(row[i..n].iter()) {
                *gij += a * rj;
            }
        }
    }
}

/// Scratch memory of [`indices_from_gram`].
#[derive(Debug, Clone)]
pub struct GramScratch<const P: usize> {
    pub(crate) a: [[f64; P]; P],
    pub(crate) eig: [f64; P],
    pub(crate) off: [f64; P],
}

impl<const P: usize> GramScratch<P> {
    /// Zeroed scratch.
    #[must_use]
    pub const fn new() -> Self {
        GramScratch {
            a: [[0.0; P]; P],
            eig: [0.0; P],
            off: [0.0; P],
        }
    }
}

impl<const P: usize> Default for GramScratch<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// The indices of a pose set given the upper triangle of its (unscaled) Gram matrix
/// `g = JᵀJ` (e.g. a sum of [`gram_update`]s), from the eigenvalues of `D·g·D`, where
/// `D = diag(g)^(-1/2)` when `unit_columns`, else the identity.
pub fn indices_from_gram<const P: usize>(
    g: &[[f64; P]; P],
    n: usize,
    poses: usize,
    unit_columns: bool,
    s: &mut GramScratch<P>,
) -> Result<Indices> {
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    for i in 0..n {
        s.off[i] = if unit_columns && g[i][i] > 0.0 {
            1.0 / sqrt(g[i][i])
        } else {
            1.0
        };
    }
    for i in 0..n {
        for j in i..n {
            s.a[i][j] = g[i][j] * s.off[i] * s.off[j];
        }
    }
    let GramScratch { a, eig, off } = s;
    sym_eigenvalues(a, n, eig, off)?;
    for v in eig.iter_mut().take(n) {
        *v = sqrt(v.max(0.0));
    }
    Ok(Indices::from_singular_values(&s.eig[..n], poses))
}

/// The per-pose index: the six singular values (descending) of configuration `q`'s 6 × p
/// block, with the columns scaled as `opts.scaling` says (unit-column scaling uses this
/// pose's own column norms). Rows outside the mask give zero singular values.
pub fn pose_singular_values<const N: usize, const P: usize>(
    robot: &Robot<N>,
    q: &[f64; N],
    opts: &ObservabilityOptions,
    ws: &mut Workspace<P>,
) -> Result<[f64; 6]> {
    let n = opts.params.len();
    let mut b = [[0.0; P]; 6];
    pose_block(robot, q, opts, ws, &mut b)?;
    if opts.scaling == ColumnScaling::UnitColumns {
        for k in 0..n {
            let norm = sqrt(b.iter().map(|row| row[k] * row[k]).sum::<f64>());
            if norm > 0.0 {
                for row in b.iter_mut() {
                    row[k] /= norm;
                }
            }
        }
    }
    // 6×6 Gram B·Bᵀ and its eigenvalues.
    let mut g = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in r..6 {
            g[r][c] = (0..n).map(|k| b[r][k] * b[c][k]).sum();
        }
    }
    let (mut eig, mut off) = ([0.0; 6], [0.0; 6]);
    sym_eigenvalues(&mut g, 6, &mut eig, &mut off)?;
    Ok(eig.map(|v| sqrt(v.max(0.0))))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::aria;
    use crate::rng::SplitMix64;
    use nalgebra::DMatrix;
    use std::vec::Vec;

    fn random_configs(n: usize, seed: u64) -> Vec<[f64; 6]> {
        let robot = aria::nominal();
        let mut rng = SplitMix64::new(seed);
        (0..n)
            .map(|_| {
                let mut q = [0.0; 6];
                for (j, v) in q.iter_mut().enumerate() {
                    let l = robot.limits()[j];
                    *v = rng.range(l.lower.max(-3.0), l.upper.min(3.0));
                }
                q
            })
            .collect()
    }

    /// The stacked Jacobian built directly from `Robot::jacobian`, independent of the
    /// blocks and the Givens route.
    fn direct_stack(qs: &[[f64; 6]], opts: &ObservabilityOptions) -> DMatrix<f64> {
        let robot = aria::nominal();
        let cols: Vec<usize> = opts.params.iter().collect();
        let mut j = DMatrix::zeros(6 * qs.len(), cols.len());
        let mut jac = [[0.0; 6]; 42];
        for (l, q) in qs.iter().enumerate() {
            robot.jacobian(&JointState::new(*q), &mut jac).unwrap();
            for r in 0..6 {
                let w = if r < 3 { 1.0 } else { opts.rot_weight };
                for (k, &c) in cols.iter().enumerate() {
                    let f = match opts.scaling {
                        ColumnScaling::Tolerance {
                            length_m,
                            angle_rad,
                        } => {
                            if matches!(c % 5, 1 | 2) {
                                length_m
                            } else {
                                angle_rad
                            }
                        }
                        _ => 1.0,
                    };
                    j[(6 * l + r, k)] = w * jac[c][r] * f;
                }
            }
        }
        if opts.scaling == ColumnScaling::UnitColumns {
            for k in 0..cols.len() {
                let n = j.column(k).norm();
                j.column_mut(k).scale_mut(1.0 / n);
            }
        }
        j
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    #[test]
    fn indices_agree_with_a_direct_svd_of_the_stacked_jacobian() {
        let robot = aria::nominal();
        let params = robot.geometric_param_set();
        let mut ws = std::boxed::Box::<Workspace<24>>::default();
        for (seed, scaling, w) in [
            (1, ColumnScaling::UnitColumns, 1.0),
            (2, ColumnScaling::None, 1.0),
            (
                3,
                ColumnScaling::Tolerance {
                    length_m: 5e-3,
                    angle_rad: 5f64.to_radians(),
                },
                0.2,
            ),
        ] {
            let qs = random_configs(10, seed);
            let mut opts = ObservabilityOptions::new(params);
            opts.scaling = scaling;
            opts.rot_weight = w;
            let ind = observability(&robot, &qs, &opts, &mut ws).unwrap();
            let j = direct_stack(&qs, &opts);
            let sv = j.clone().svd(false, false).singular_values;
            let mut sv: Vec<f64> = sv.iter().copied().collect();
            sv.sort_by(|a, b| b.partial_cmp(a).unwrap());
            let p = sv.len();
            assert_eq!(p, 24);
            for (k, (&a, &b)) in ws.singular_values().iter().zip(sv.iter()).enumerate() {
                assert!(close(a, b, 1e-10), "{scaling:?} σ{k}: {a} vs {b}");
            }
            let (smax, smin) = (sv[0], sv[p - 1]);
            let prod_root = (sv.iter().map(|s| s.ln()).sum::<f64>() / p as f64).exp();
            // Independent check of every index from the direct SVD.
            assert!(close(ind.o, smin / smax, 1e-9));
            assert!(close(ind.o2, smin / smax, 1e-9));
            assert!(close(ind.o1, prod_root / (10f64).sqrt(), 1e-10));
            assert!(close(ind.o3, smin, 1e-9));
            assert!(close(ind.o4, smin * smin / smax, 1e-9));
            assert!(close(ind.o5, 1.0 / smax, 1e-10));
            assert!(close(
                ind.a_opt,
                1.0 / sv.iter().map(|s| 1.0 / s).sum::<f64>(),
                1e-9
            ));
            let det = (j.transpose() * &j).determinant();
            assert!(
                close(ind.log_det, det.ln(), 1e-6),
                "{} vs {}",
                ind.log_det,
                det.ln()
            );
            // The Gram route gives the same indices.
            let mut g = [[0.0; 24]; 24];
            let mut b = [[0.0; 24]; 6];
            for q in &qs {
                pose_block(&robot, q, &opts, &mut ws, &mut b).unwrap();
                gram_update(&mut g, &b, 24, 1.0);
            }
            let gi = indices_from_gram(
                &g,
                24,
                10,
                scaling == ColumnScaling::UnitColumns,
                &mut GramScratch::new(),
            )
            .unwrap();
            for idx in Index::ALL {
                assert!(
                    close(gi.get(idx), ind.get(idx), 1e-7),
                    "{scaling:?} {}: {} vs {}",
                    idx.name(),
                    gi.get(idx),
                    ind.get(idx)
                );
            }
            // Removing a pose again restores the smaller set.
            pose_block(&robot, &qs[9], &opts, &mut ws, &mut b).unwrap();
            gram_update(&mut g, &b, 24, -1.0);
            let nine = observability(&robot, &qs[..9], &opts, &mut ws).unwrap();
            let g9 = indices_from_gram(
                &g,
                24,
                9,
                scaling == ColumnScaling::UnitColumns,
                &mut GramScratch::new(),
            )
            .unwrap();
            assert!(close(g9.o, nine.o, 1e-6));
        }
    }

    #[test]
    fn unit_column_inverse_condition_equals_the_identifiability_analysis() {
        use crate::identify::{Algorithm, IdentifyOptions, Measurement, analyze};
        let robot = aria::nominal();
        let qs = random_configs(8, 11);
        let data: Vec<Measurement<6>> = qs
            .iter()
            .map(|q| Measurement::new(*q, robot.fk_q(q).unwrap()))
            .collect();
        let mut ws = std::boxed::Box::<Workspace<24>>::default();
        let a = analyze(
            &robot,
            &data,
            &IdentifyOptions::new(Algorithm::Ols, robot.geometric_param_set()),
            &mut ws,
        )
        .unwrap();
        assert_eq!(a.rank, 24);
        let ind = observability(
            &robot,
            &qs,
            &ObservabilityOptions::new(robot.geometric_param_set()),
            &mut ws,
        )
        .unwrap();
        assert!(close(ind.o, 1.0 / a.condition_number, 1e-9));
    }

    #[test]
    fn per_pose_singular_values_agree_with_a_direct_svd() {
        let robot = aria::nominal();
        let mut ws = std::boxed::Box::<Workspace<24>>::default();
        for (l, q) in random_configs(5, 5).iter().enumerate() {
            for scaling in [ColumnScaling::None, ColumnScaling::UnitColumns] {
                let mut opts = ObservabilityOptions::new(robot.geometric_param_set());
                opts.scaling = scaling;
                let s = pose_singular_values(&robot, q, &opts, &mut ws).unwrap();
                // direct_stack normalises by the one pose's own column norms.
                let j = direct_stack(&[*q], &opts);
                let sv = j.svd(false, false).singular_values;
                let mut sv: Vec<f64> = sv.iter().copied().collect();
                sv.sort_by(|a, b| b.partial_cmp(a).unwrap());
                for k in 0..6 {
                    assert!(
                        (s[k] - sv[k]).abs() <= 1e-10 * sv[0],
                        "pose {l} {scaling:?} σ{k}: {} vs {}",
                        s[k],
                        sv[k]
                    );
                }
                assert!(s.windows(2).all(|w| w[0] >= w[1]));
            }
        }
    }

    #[test]
    fn rank_deficiency_bad_options_and_names() {
        let robot = aria::nominal();
        let mut ws = std::boxed::Box::<Workspace<24>>::default();
        // Three poses give 18 rows for 24 parameters: σ_min = 0 to rounding.
        let qs = random_configs(3, 9);
        let opts = ObservabilityOptions::new(robot.geometric_param_set());
        let ind = observability(&robot, &qs, &opts, &mut ws).unwrap();
        assert!(ind.o < 1e-12 && ind.o3 < 1e-12, "{ind:?}");
        assert!(observability(&robot, &[], &opts, &mut ws).is_err());
        let mut bad = opts;
        bad.rot_weight = -1.0;
        assert!(observability(&robot, &qs, &bad, &mut ws).is_err());
        let mut small = std::boxed::Box::<Workspace<8>>::default();
        assert!(matches!(
            observability(&robot, &qs, &opts, &mut small),
            Err(Error::CapacityExceeded { .. })
        ));
        for i in Index::ALL {
            assert_eq!(Index::parse(i.name()), Some(i));
        }
        let z = Indices::from_singular_values(&[2.0, 0.0], 1);
        assert_eq!(
            (z.o, z.o1, z.a_opt, z.log_det),
            (0.0, 0.0, 0.0, f64::NEG_INFINITY)
        );
    }
}
