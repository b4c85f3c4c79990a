//! Where the geometric calibration's residual lies: by axis, by region of the workspace,
//! and how it correlates with the quantities the effects depend on.

use super::{NoiseFloor, PoseDiagnosis};
use crate::any::MAX_JOINTS;
use crate::identify::Measurement;
use crate::math::sqrt;
use crate::model::Robot;

/// Quantities the residual is correlated with: joint angles, gravity torques and approach
/// directions of up to [`MAX_JOINTS`] joints, and the temperature.
pub const MAX_QUANTITIES: usize = 3 * MAX_JOINTS + 1;
/// Regions: the octants of the measured positions' bounding box.
pub const REGIONS: usize = 8;

/// A quantity a residual may depend on (joints zero-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QuantityKind {
    /// Joint reading q_j \[rad\].
    JointAngle(usize),
    /// Gravity torque τ_j of the mass model [N·m].
    GravityTorque(usize),
    /// Approach direction s_j (−1, 0, +1).
    Approach(usize),
    /// Arm temperature [°C].
    Temperature,
}

impl QuantityKind {
    /// Short label: `q2`, `tau2`, `s2`, `temp_c` (1-based joints, as the CSV columns).
    pub fn write_label(&self, f: &mut impl core::fmt::Write) -> core::fmt::Result {
        match *self {
            QuantityKind::JointAngle(j) => write!(f, "q{}", j + 1),
            QuantityKind::GravityTorque(j) => write!(f, "tau{}", j + 1),
            QuantityKind::Approach(j) => write!(f, "s{}", j + 1),
            QuantityKind::Temperature => write!(f, "temp_c"),
        }
    }
}

/// How the residual correlates with one quantity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correlate {
    /// The quantity.
    pub quantity: QuantityKind,
    /// Pearson correlation with each residual component `[x, y, z, φx, φy, φz]` (0 when
    /// either does not vary).
    pub corr: [f64; 6],
    /// Pearson correlation with the position error's norm |Δp|.
    pub corr_norm_pos: f64,
    /// Share of the position residual's variance (summed over x, y, z) that a linear
    /// function of the quantity explains: `Σ_k cov(v, r_k)² / (var v · Σ_k var r_k)`.
    pub explained_pos: f64,
    /// The same for the rotation components.
    pub explained_rot: f64,
    /// The same over all six components whitened by the noise floor (rows count by their
    /// noise, as everywhere in the diagnosis): what [`Location::most_correlated`] ranks by.
    pub explained: f64,
}

/// Residual statistics of one region.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RegionStats {
    /// Lower corner of the region \[m\].
    pub min_m: [f64; 3],
    /// Upper corner of the region \[m\].
    pub max_m: [f64; 3],
    /// Poses in it.
    pub count: usize,
    /// RMS position error \[m\].
    pub rms_pos_m: f64,
    /// RMS rotation angle \[rad\].
    pub rms_rot_rad: f64,
    /// Mean position error (a systematic direction) \[m\].
    pub mean_pos_m: [f64; 3],
}

/// Where the residual of the geometric calibration lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Location {
    /// Poses used (all rows).
    pub poses: usize,
    /// RMS of each residual component `[x, y, z]` \[m\], `[φx, φy, φz]` \[rad\].
    pub rms_axis: [f64; 6],
    /// Mean of each component.
    pub mean_axis: [f64; 6],
    /// RMS position error \[m\].
    pub rms_pos_m: f64,
    /// RMS rotation angle \[rad\].
    pub rms_rot_rad: f64,
    /// Bounding box of the measured positions \[m\].
    pub bbox_min_m: [f64; 3],
    /// Upper corner of the bounding box \[m\].
    pub bbox_max_m: [f64; 3],
    /// Octants of the bounding box: index bit 0 = upper half in x, bit 1 in y, bit 2 in z.
    pub regions: [RegionStats; REGIONS],
    /// Correlations (first `n_correlates`): q_j, τ_j for every joint, then s_j when the
    /// rows carry approach directions, then the temperature when they carry it.
    pub correlates: [Correlate; MAX_QUANTITIES],
    /// Number of correlates.
    pub n_correlates: usize,
    /// Index of the correlate that explains the largest share of the whitened residual
    /// ([`Correlate::explained`]); `None` when nothing varies.
    pub most_correlated: Option<usize>,
}

impl Location {
    /// Nothing located yet.
    #[must_use]
    pub const fn empty() -> Self {
        let c = Correlate {
            quantity: QuantityKind::Temperature,
            corr: [0.0; 6],
            corr_norm_pos: 0.0,
            explained_pos: 0.0,
            explained_rot: 0.0,
            explained: 0.0,
        };
        let r = RegionStats {
            min_m: [0.0; 3],
            max_m: [0.0; 3],
            count: 0,
            rms_pos_m: 0.0,
            rms_rot_rad: 0.0,
            mean_pos_m: [0.0; 3],
        };
        Location {
            poses: 0,
            rms_axis: [0.0; 6],
            mean_axis: [0.0; 6],
            rms_pos_m: 0.0,
            rms_rot_rad: 0.0,
            bbox_min_m: [f64::INFINITY; 3],
            bbox_max_m: [f64::NEG_INFINITY; 3],
            regions: [r; REGIONS],
            correlates: [c; MAX_QUANTITIES],
            n_correlates: 0,
            most_correlated: None,
        }
    }

    /// The correlates.
    #[must_use]
    pub fn correlates(&self) -> &[Correlate] {
        self.correlates
            .get(..self.n_correlates.min(MAX_QUANTITIES))
            .unwrap_or(&[])
    }
}

/// Value of correlate `q` at measurement `m`, with the gravity torques `tau`.
fn value<const N: usize>(q: QuantityKind, m: &Measurement<N>, tau: &[f64; N]) -> f64 {
    match q {
        QuantityKind::JointAngle(j) => m.state.q.get(j).copied().unwrap_or(0.0),
        QuantityKind::GravityTorque(j) => tau.get(j).copied().unwrap_or(0.0),
        QuantityKind::Approach(j) => m
            .state
            .approach
            .and_then(|s| s.get(j).copied())
            .unwrap_or(0.0),
        QuantityKind::Temperature => m.state.temp_c.unwrap_or(0.0),
    }
}

// Long by design: one pass per statistic (quantities, axes, regions, correlations) into the fixed-size `Location` (no heap).
pub(crate) fn locate<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    noise: &NoiseFloor,
) -> Location {
    let w = |k: usize| {
        let s = if k < 3 {
            noise.sigma_pos_m
        } else {
            noise.sigma_rot_rad
        };
        if s > 0.0 { 1.0 / (s * s) } else { 0.0 }
    };
    let mut loc = Location::empty();
    loc.poses = data.len();
    let n = data.len().min(poses.len());
    if n == 0 {
        return loc;
    }
    let nf = n as f64;
    // Quantities.
    let mut nq = 0;
    let mut push = |q: QuantityKind, loc: &mut Location| {
        if nq < MAX_QUANTITIES {
            loc.correlates[nq].quantity = q;
            nq += 1;
        }
    };
    for j in 0..N {
        push(QuantityKind::JointAngle(j), &mut loc);
    }
    if robot.mass().tool_mass_kg > 0.0 || robot.mass().link_masses_kg.iter().any(|&m| m > 0.0) {
        for j in 0..N {
            push(QuantityKind::GravityTorque(j), &mut loc);
        }
    }
    if data.iter().all(|m| m.state.approach.is_some()) {
        for j in 0..N {
            push(QuantityKind::Approach(j), &mut loc);
        }
    }
    if data.iter().all(|m| m.state.temp_c.is_some()) {
        push(QuantityKind::Temperature, &mut loc);
    }
    loc.n_correlates = nq;

    // Axis statistics, bounding box, norms.
    let norm_p = |r: &[f64; 6]| sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    let (mut sp, mut sr) = (0.0, 0.0);
    let mut mean_norm = 0.0;
    for l in 0..n {
        let r = &poses[l].residual;
        for k in 0..6 {
            loc.mean_axis[k] += r[k] / nf;
            loc.rms_axis[k] += r[k] * r[k];
        }
        sp += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        sr += r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
        mean_norm += norm_p(r) / nf;
        let p = data[l].pose.translation.vector;
        for k in 0..3 {
            loc.bbox_min_m[k] = loc.bbox_min_m[k].min(p[k]);
            loc.bbox_max_m[k] = loc.bbox_max_m[k].max(p[k]);
        }
    }
    for v in loc.rms_axis.iter_mut() {
        *v = sqrt(*v / nf);
    }
    loc.rms_pos_m = sqrt(sp / nf);
    loc.rms_rot_rad = sqrt(sr / nf);

    // Regions.
    let mid = |k: usize| 0.5 * (loc.bbox_min_m[k] + loc.bbox_max_m[k]);
    for (idx, reg) in loc.regions.iter_mut().enumerate() {
        for k in 0..3 {
            let upper = idx & (1 << k) != 0;
            reg.min_m[k] = if upper { mid(k) } else { loc.bbox_min_m[k] };
            reg.max_m[k] = if upper { loc.bbox_max_m[k] } else { mid(k) };
        }
    }
    let mut reg_sp = [0.0; REGIONS];
    let mut reg_sr = [0.0; REGIONS];
    for l in 0..n {
        let p = data[l].pose.translation.vector;
        let mut idx = 0;
        for k in 0..3 {
            if p[k] > mid(k) {
                idx |= 1 << k;
            }
        }
        let r = &poses[l].residual;
        let reg = &mut loc.regions[idx];
        reg.count += 1;
        for k in 0..3 {
            reg.mean_pos_m[k] += r[k];
        }
        reg_sp[idx] += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        reg_sr[idx] += r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
    }
    for (idx, reg) in loc.regions.iter_mut().enumerate() {
        if reg.count > 0 {
            let c = reg.count as f64;
            for v in reg.mean_pos_m.iter_mut() {
                *v /= c;
            }
            reg.rms_pos_m = sqrt(reg_sp[idx] / c);
            reg.rms_rot_rad = sqrt(reg_sr[idx] / c);
        }
    }

    // Correlations: means of the quantities, then (co)variances.
    let mut mean_v = [0.0; MAX_QUANTITIES];
    for l in 0..n {
        let tau = robot.gravity_torques(&data[l].state.q);
        for (qi, c) in loc.correlates[..nq].iter().enumerate() {
            mean_v[qi] += value(c.quantity, &data[l], &tau) / nf;
        }
    }
    let mut var_v = [0.0; MAX_QUANTITIES];
    let mut cov = [[0.0; 7]; MAX_QUANTITIES];
    let mut var_r = [0.0; 7];
    for l in 0..n {
        let tau = robot.gravity_torques(&data[l].state.q);
        let r = &poses[l].residual;
        let mut dr = [0.0; 7];
        for k in 0..6 {
            dr[k] = r[k] - loc.mean_axis[k];
        }
        dr[6] = norm_p(r) - mean_norm;
        for k in 0..7 {
            var_r[k] += dr[k] * dr[k];
        }
        for qi in 0..nq {
            let dv = value(loc.correlates[qi].quantity, &data[l], &tau) - mean_v[qi];
            var_v[qi] += dv * dv;
            for k in 0..7 {
                cov[qi][k] += dv * dr[k];
            }
        }
    }
    let tiny = |v: f64, scale: f64| v <= 1e-24 * scale.max(1e-300);
    let mut best: Option<(usize, f64)> = None;
    for qi in 0..nq {
        let c = &mut loc.correlates[qi];
        if tiny(var_v[qi], mean_v[qi] * mean_v[qi] * nf + 1.0) {
            continue;
        }
        for k in 0..6 {
            if var_r[k] > 0.0 {
                c.corr[k] = cov[qi][k] / sqrt(var_v[qi] * var_r[k]);
            }
        }
        if var_r[6] > 0.0 {
            c.corr_norm_pos = cov[qi][6] / sqrt(var_v[qi] * var_r[6]);
        }
        let share = |ks: core::ops::Range<usize>| {
            let tot: f64 = ks.clone().map(|k| var_r[k]).sum();
            if tot > 0.0 {
                ks.map(|k| cov[qi][k] * cov[qi][k]).sum::<f64>() / (var_v[qi] * tot)
            } else {
                0.0
            }
        };
        c.explained_pos = share(0..3);
        c.explained_rot = share(3..6);
        let tot: f64 = (0..6).map(|k| w(k) * var_r[k]).sum();
        if tot > 0.0 {
            c.explained =
                (0..6).map(|k| w(k) * cov[qi][k] * cov[qi][k]).sum::<f64>() / (var_v[qi] * tot);
        }
        if best.is_none_or(|b| c.explained > b.1) {
            best = Some((qi, c.explained));
        }
    }
    loc.most_correlated = best.map(|b| b.0);
    loc
}
