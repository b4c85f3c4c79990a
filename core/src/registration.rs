//! Marker registration: the rigid transform that carries a body's markers from their design
//! positions (body frame) onto their measured positions (motion-capture frame), with
//! per-marker residuals and outlier identification, and the end-effector pose in the robot
//! base frame from base and probe markers (spec/aria.md, Section 5.1):
//! `t_base_ee = t_mocap_base⁻¹ · t_mocap_ee`.
//!
//! # The fit
//! Weighted least squares over the used markers `j` (visible, not excluded as outliers):
//! minimise `Σ w_j |R·d_j + t − m_j|²` over rotations `R` (det = +1) and translations `t`.
//! The translation follows from the weighted centroids; the rotation by **Horn's
//! quaternion method** (J. Opt. Soc. Am. A 4(4), 1987): the unit quaternion of `R` is the
//! eigenvector of the largest eigenvalue of a symmetric 4×4 matrix built from the weighted
//! cross-covariance. A quaternion always gives a proper rotation, so this *is* the weighted
//! Kabsch solution with the reflection guard (`det(U·Vᵀ) = −1` → flip the last singular
//! direction) built in: for coplanar markers, or data closer to a mirror image of the
//! design, the best proper rotation is returned, never a reflection. The eigenvector comes
//! from cyclic Jacobi rotations written here (no panic paths, deterministic; nalgebra's SVD
//! and symmetric eigen keep internal unwraps, TOOLCHAIN.md).
//!
//! # Degenerate marker sets
//! At least 3 used markers are needed ([`Error::TooFewData`]). The design positions must
//! span a plane: when the RMS extent of the used design markers across their best-fit line
//! is not above the stated noise σ, the rotation about that line is not determined and the
//! fit fails with [`Error::RankDeficient`] (`rank` = number of principal directions with an
//! RMS extent above σ, `required` = 2). The same error comes when the measured positions
//! leave the best rotation ambiguous (top two eigenvalues of Horn's matrix equal).
//!
//! # Outliers
//! Each marker has a stated noise `σ_j = σ/√w_j` per axis (σ of
//! [`RegistrationOptions::sigma_m`] at weight 1). A marker is consistent when its 3-D
//! residual distance is at most `k·σ_j` with `k` = [`RegistrationOptions::k_sigma`]
//! (default [`DEFAULT_K_SIGMA`] = 4: for a correctly fitted marker `|r|²/σ_j²` is at most
//! χ²(3)-distributed, so a false alarm has probability below 1.1e-3 per marker). When the
//! fit of all visible markers leaves any marker inconsistent, every subset of 1, then 2, …
//! up to [`RegistrationOptions::max_outliers`] markers is excluded in turn (keeping at least
//! 3) and the smallest exclusion after which all remaining markers are consistent is taken
//! (ties: smallest Σ(|r_j|/σ_j)²). Excluded markers are then named: two for which
//! exchanging their measured positions gives a consistent fit with both of them used are
//! [`MarkerStatus::Swapped`] (a direct test of the swap; comparing each with the other's
//! predicted position would also charge the prediction error of a fit on fewer markers);
//! any other is [`MarkerStatus::Moved`]. Masked markers are
//! [`MarkerStatus::Missing`] (their measured values are ignored, NaN allowed). When no
//! exclusion explains the data, the all-visible fit is returned with
//! [`Registration::consistent`] false and the inconsistent markers marked
//! [`MarkerStatus::Suspect`].
//!
//! # Ambiguous frames
//! Two exclusions of the same (smallest) size can both leave a consistent fit: markers a
//! ghost or a knocked marker has put where a rotated copy of the body would have one. With
//! a symmetric design this happens readily (a rhombus seen with one marker doubled fits
//! rotated 180° about its axis either way), but it needs no symmetry: the fits share too
//! few markers to pin the pose. The tie-break (smallest Σ(|r|/σ)²) would then be a guess;
//! instead [`Registration::ambiguity`] names the competing exclusion whenever its pose puts
//! some visible marker further from the chosen pose's prediction than that marker's
//! threshold (the two poses cannot both be right), and callers must not use the pose.
//! [`design_symmetry`] checks a design up front for congruent marker triangles, the usual
//! cause.
//!
//! A marker design with a symmetry (e.g. a cross with equal arms) cannot reveal a swap that
//! the symmetry maps onto itself: such a swap is explained by another rotation. Use
//! asymmetric designs.

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, Quantity, Result};
use crate::math::{atan2, sqrt};
use crate::pose::{Transform, quaternion_to_matrix, transform};

/// Most markers on one body.
pub const MAX_MARKERS: usize = 32;
/// Most markers [`register`] may exclude as outliers.
pub const MAX_OUTLIERS: usize = 3;
/// Default outlier threshold in units of the stated per-axis noise σ (see module docs).
pub const DEFAULT_K_SIGMA: f64 = 4.0;
/// Jacobi sweeps before [`Error::NotConverged`] (4×4 converges in fewer than 10).
const MAX_SWEEPS: u32 = 50;

/// The markers of one rigid body in one frame of motion-capture data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Markers<'a> {
    /// Design positions in the body frame \[m\].
    pub design: &'a [[f64; 3]],
    /// Measured positions in the motion-capture frame \[m\], same order and length.
    pub measured: &'a [[f64; 3]],
    /// Which markers were seen (`None`: all). Values of unseen markers are ignored.
    pub visible: Option<&'a [bool]>,
    /// Relative weights, finite and > 0 (`None`: all 1); marker `j` has noise `σ/√w_j`.
    pub weights: Option<&'a [f64]>,
}

impl<'a> Markers<'a> {
    /// All markers visible, equal weights.
    #[must_use]
    pub fn new(design: &'a [[f64; 3]], measured: &'a [[f64; 3]]) -> Self {
        Markers {
            design,
            measured,
            visible: None,
            weights: None,
        }
    }
}

/// Options of [`register`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegistrationOptions {
    /// Stated measurement noise, 1σ per axis at weight 1 \[m\].
    pub sigma_m: f64,
    /// Outlier threshold in units of σ_j on the 3-D residual distance.
    pub k_sigma: f64,
    /// Most markers to exclude as outliers (at most [`MAX_OUTLIERS`]; 0 disables the search).
    pub max_outliers: usize,
}

impl RegistrationOptions {
    /// Noise `sigma_m` \[m\], `k` = [`DEFAULT_K_SIGMA`], up to 2 outliers.
    #[must_use]
    pub const fn new(sigma_m: f64) -> Self {
        RegistrationOptions {
            sigma_m,
            k_sigma: DEFAULT_K_SIGMA,
            max_outliers: 2,
        }
    }
}

/// What the registration concluded about one marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerStatus {
    /// Used in the fit and consistent with it.
    Inlier,
    /// Masked as not seen.
    Missing,
    /// Excluded: its measured position is off by more than its threshold and not explained
    /// by a swap (marker moved, knocked, or a ghost).
    Moved,
    /// Excluded: its label is swapped with marker `with` (zero-based).
    Swapped {
        /// The other marker of the pair.
        with: usize,
    },
    /// Used, but above its threshold in a fit that no exclusion could make consistent.
    Suspect,
}

/// The fit of one marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerFit {
    /// Predicted position `t_mocap_body · design` in the motion-capture frame \[m\].
    pub predicted_m: [f64; 3],
    /// Residual measured − predicted in the motion-capture frame \[m\] (zero if missing).
    pub residual_m: [f64; 3],
    /// Length of the residual \[m\] (zero if missing).
    pub distance_m: f64,
    /// Outlier threshold `k·σ/√w` of this marker \[m\].
    pub threshold_m: f64,
    /// The verdict.
    pub status: MarkerStatus,
}

const EMPTY_FIT: MarkerFit = MarkerFit {
    predicted_m: [0.0; 3],
    residual_m: [0.0; 3],
    distance_m: 0.0,
    threshold_m: 0.0,
    status: MarkerStatus::Missing,
};

/// A competing exclusion in an ambiguous registration (module docs, "Ambiguous frames").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ambiguity {
    /// Markers (zero-based, bit `j` for marker `j`) the chosen fit excludes.
    pub excluded: u32,
    /// Markers the competing, equally consistent fit excludes instead.
    pub alternative_excluded: u32,
    /// Rotation between the two poses \[rad\].
    pub rotation_rad: f64,
    /// Largest distance between the two poses' predictions of a visible marker \[m\].
    pub marker_shift_m: f64,
}

/// The result of [`register`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Registration {
    /// The body frame in the motion-capture frame: `measured ≈ t_mocap_body · design`.
    pub t_mocap_body: Transform,
    /// Markers used in the fit.
    pub n_used: usize,
    /// Weighted RMS residual distance of the used markers, `sqrt(Σ w |r|² / Σ w)` \[m\].
    pub rms_m: f64,
    /// Whether every used marker is within its threshold.
    pub consistent: bool,
    /// A second exclusion that fits as well with a different pose (module docs): when set,
    /// the pose is not determined by the data and must not be used.
    pub ambiguity: Option<Ambiguity>,
    fits: [MarkerFit; MAX_MARKERS],
    n: usize,
}

impl Registration {
    /// Per-marker fits, in input order.
    #[must_use]
    pub fn markers(&self) -> &[MarkerFit] {
        self.fits.get(..self.n).unwrap_or(&[])
    }
    /// Whether any marker was excluded or found suspect.
    #[must_use]
    pub fn has_outliers(&self) -> bool {
        self.markers().iter().any(|m| {
            matches!(
                m.status,
                MarkerStatus::Moved | MarkerStatus::Swapped { .. } | MarkerStatus::Suspect
            )
        })
    }
}

/// Eigen-decomposition of a symmetric `D×D` matrix by cyclic Jacobi rotations:
/// `(eigenvalues, eigenvectors as columns v[.][k])`, unsorted. Deterministic, no panics.
pub(crate) fn symmetric_eigen<const D: usize>(
    mut a: [[f64; D]; D],
) -> Result<([f64; D], [[f64; D]; D])> {
    let mut v = [[0.0; D]; D];
    for (i, row) in v.iter_mut().enumerate() {
        if let Some(x) = row.get_mut(i) {
            *x = 1.0;
        }
    }
    // `get` rather than `a[p][q]`, `row[p]`: the bounds checks of indices the optimiser must
    // prove stay panic paths at opt-level z (kincal_view_point on the firmware target).
    let at = |a: &[[f64; D]; D], i: usize, j: usize| {
        a.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
    };
    let diag = |a: &[[f64; D]; D]| {
        let mut e = [0.0; D];
        for (i, x) in e.iter_mut().enumerate() {
            *x = at(a, i, i);
        }
        e
    };
    for sweep in 0..=MAX_SWEEPS {
        let mut off = 0.0;
        let mut total = 0.0;
        for (i, row) in a.iter().enumerate() {
            for (j, &x) in row.iter().enumerate() {
                total += x * x;
                if i != j {
                    off += x * x;
                }
            }
        }
        if off <= 1e-30 * total || off == 0.0 {
            return Ok((diag(&a), v));
        }
        if sweep == MAX_SWEEPS {
            break;
        }
        for p in 0..D {
            for q in (p + 1)..D {
                let apq = at(&a, p, q);
                if apq == 0.0 {
                    continue;
                }
                let theta = (at(&a, q, q) - at(&a, p, p)) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    let s = if theta >= 0.0 { 1.0 } else { -1.0 };
                    s / (theta.abs() + sqrt(theta * theta + 1.0))
                };
                let c = 1.0 / sqrt(t * t + 1.0);
                let s = t * c;
                // A ← Jᵀ·A·J with J the rotation in the (p, q) plane.
                for row in a.iter_mut() {
                    rotate_entries(row, p, q, c, s);
                }
                let (rp, rq) = (a.get(p).copied(), a.get(q).copied());
                if let (Some(rp), Some(rq)) = (rp, rq) {
                    let (mut np, mut nq) = (rp, rq);
                    let new = np.iter_mut().zip(nq.iter_mut());
                    for ((x, y), (&apk, &aqk)) in new.zip(rp.iter().zip(rq.iter())) {
                        *x = c * apk - s * aqk;
                        *y = s * apk + c * aqk;
                    }
                    if let Some(r) = a.get_mut(p) {
                        *r = np;
                    }
                    if let Some(r) = a.get_mut(q) {
                        *r = nq;
                    }
                }
                for row in v.iter_mut() {
                    rotate_entries(row, p, q, c, s);
                }
            }
        }
    }
    Err(Error::NotConverged {
        iterations: MAX_SWEEPS,
    })
}

/// `(row_p, row_q) ← (c·row_p − s·row_q, s·row_p + c·row_q)` (a Jacobi rotation of two
/// entries; nothing for indices out of range).
fn rotate_entries<const D: usize>(row: &mut [f64; D], p: usize, q: usize, c: f64, s: f64) {
    if let (Some(&x), Some(&y)) = (row.get(p), row.get(q)) {
        if let Some(r) = row.get_mut(p) {
            *r = c * x - s * y;
        }
        if let Some(r) = row.get_mut(q) {
            *r = s * x + c * y;
        }
    }
}

fn v3(p: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

/// The weighted rigid transform `T` (proper rotation) minimising `Σ w_j |T·design_j −
/// measured_j|²` over the markers with `w_j > 0` (markers with `w_j = 0` are ignored, and
/// so are their values). Horn's quaternion method with the checks of the module docs;
/// `sigma_m` is the noise used by the collinearity test.
///
/// ```
/// use kincal::registration::weighted_rigid_fit;
/// let design = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.05]];
/// // Shifted by (1, 2, 3), no rotation.
/// let measured = design.map(|p| [p[0] + 1.0, p[1] + 2.0, p[2] + 3.0]);
/// let t = weighted_rigid_fit(&design, &measured, &[1.0; 4], 1e-4).unwrap();
/// assert!((t.translation.vector - nalgebra::Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
/// ```
pub fn weighted_rigid_fit(
    design: &[[f64; 3]],
    measured: &[[f64; 3]],
    weights: &[f64],
    sigma_m: f64,
) -> Result<Transform> {
    if design.len() != measured.len() || design.len() != weights.len() {
        return Err(Error::DimensionMismatch {
            expected: design.len(),
            found: if design.len() != measured.len() {
                measured.len()
            } else {
                weights.len()
            },
        });
    }
    let mut wsum = 0.0;
    let mut used = 0;
    let mut ca = Vector3::zeros();
    let mut cb = Vector3::zeros();
    for (j, ((d, m), &w)) in design.iter().zip(measured).zip(weights).enumerate() {
        if !(w.is_finite() && w >= 0.0) {
            return Err(Error::InvalidParameter { index: j, value: w });
        }
        if w == 0.0 {
            continue;
        }
        crate::error::check_finite(d, Quantity::Position)
            .and(crate::error::check_finite(m, Quantity::Position))
            .map_err(|_| Error::NonFinite {
                what: Quantity::Position,
                index: j,
            })?;
        used += 1;
        wsum += w;
        ca += v3(d) * w;
        cb += v3(m) * w;
    }
    if used < 3 {
        return Err(Error::TooFewData {
            found: used,
            needed: 3,
        });
    }
    ca /= wsum;
    cb /= wsum;
    // Design scatter and cross-covariance S[r][c] = Σ w a_r b_c (centred).
    let mut scatter = [[0.0; 3]; 3];
    let mut s = Matrix3::<f64>::zeros();
    for ((d, m), &w) in design.iter().zip(measured).zip(weights) {
        if w == 0.0 {
            continue;
        }
        let a = v3(d) - ca;
        let b = v3(m) - cb;
        s += a * b.transpose() * w;
        for (r, row) in scatter.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x += w * a[r] * a[c];
            }
        }
    }
    // Collinearity: principal RMS extents of the design markers against the noise.
    let (ev, _) = symmetric_eigen(scatter)?;
    let rank = ev
        .iter()
        .filter(|&&l| sqrt(l.max(0.0) / wsum) > sigma_m)
        .count();
    if rank < 2 {
        return Err(Error::RankDeficient { rank, required: 2 });
    }
    let r = rotation_from_correlation(&s)?;
    Ok(transform(r, cb - r * ca))
}

/// The proper rotation `R` maximising `Σ w·bᵀ·R·a` given the correlation
/// `s = Σ w·a·bᵀ` (Horn's quaternion method, see the module docs). Fails with
/// [`Error::RankDeficient`] when the best rotation is not unique (top two eigenvalues of
/// Horn's matrix equal).
pub(crate) fn rotation_from_correlation(s: &Matrix3<f64>) -> Result<Matrix3<f64>> {
    let (sxx, sxy, sxz) = (s[(0, 0)], s[(0, 1)], s[(0, 2)]);
    let (syx, syy, syz) = (s[(1, 0)], s[(1, 1)], s[(1, 2)]);
    let (szx, szy, szz) = (s[(2, 0)], s[(2, 1)], s[(2, 2)]);
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let (lambda, vecs) = symmetric_eigen(n)?;
    let mut order = [0usize, 1, 2, 3];
    order.sort_unstable_by(|&i, &j| lambda[j].total_cmp(&lambda[i]));
    let (top, second) = (lambda[order[0]], lambda[order[1]]);
    let scale = lambda.iter().fold(0.0_f64, |m, l| m.max(l.abs()));
    if scale <= 0.0 || !scale.is_finite() || top - second <= 1e-12 * scale {
        return Err(Error::RankDeficient {
            rank: 1,
            required: 2,
        });
    }
    let k = order[0];
    let q = [vecs[0][k], vecs[1][k], vecs[2][k], vecs[3][k]];
    quaternion_to_matrix(&q)
}

fn check_inputs(markers: &Markers<'_>, opts: &RegistrationOptions) -> Result<usize> {
    let n = markers.design.len();
    if markers.measured.len() != n {
        return Err(Error::DimensionMismatch {
            expected: n,
            found: markers.measured.len(),
        });
    }
    if n > MAX_MARKERS {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: MAX_MARKERS,
        });
    }
    for s in [
        markers.visible.map(<[bool]>::len),
        markers.weights.map(<[f64]>::len),
    ]
    .into_iter()
    .flatten()
    {
        if s != n {
            return Err(Error::DimensionMismatch {
                expected: n,
                found: s,
            });
        }
    }
    for (i, v) in [opts.sigma_m, opts.k_sigma].into_iter().enumerate() {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::InvalidParameter { index: i, value: v });
        }
    }
    if opts.max_outliers > MAX_OUTLIERS {
        return Err(Error::CapacityExceeded {
            needed: opts.max_outliers,
            capacity: MAX_OUTLIERS,
        });
    }
    if let Some((index, &value)) = markers
        .weights
        .unwrap_or(&[])
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w > 0.0))
    {
        return Err(Error::InvalidParameter { index, value });
    }
    Ok(n)
}

/// Calls `f` with every combination of `size` markers among the first `n_vis` entries of
/// `vis_idx` (marker indices), in lexicographic order.
fn for_each_exclusion(
    vis_idx: &[usize; MAX_MARKERS],
    n_vis: usize,
    size: usize,
    mut f: impl FnMut(&[usize]),
) {
    if size == 0 || size > MAX_OUTLIERS || size > n_vis {
        return;
    }
    let mut comb = [0usize; MAX_OUTLIERS];
    for (i, c) in comb.iter_mut().enumerate().take(size) {
        *c = i;
    }
    loop {
        let mut excluded = [0usize; MAX_OUTLIERS];
        for (e, &c) in excluded.iter_mut().zip(comb.iter()).take(size) {
            *e = vis_idx.get(c).copied().unwrap_or(0);
        }
        f(excluded.get(..size).unwrap_or(&[]));
        // Next combination (lexicographic).
        let mut i = size;
        let mut advanced = false;
        while i > 0 {
            i -= 1;
            let limit = n_vis - size + i;
            if let Some(ci) = comb.get(i).copied()
                && ci < limit
            {
                comb[i] = ci + 1;
                for k in (i + 1)..size {
                    comb[k] = comb[k - 1] + 1;
                }
                advanced = true;
                break;
            }
        }
        if !advanced {
            return;
        }
    }
}

/// `w` with the markers `excluded` set to weight 0.
fn without(w: &[f64; MAX_MARKERS], excluded: &[usize]) -> [f64; MAX_MARKERS] {
    let mut out = *w;
    for &j in excluded {
        if let Some(x) = out.get_mut(j) {
            *x = 0.0;
        }
    }
    out
}

/// Bit mask of the markers visible in `w_all` but at weight 0 in `w`.
fn mask_of(w: &[f64; MAX_MARKERS], w_all: &[f64; MAX_MARKERS]) -> u32 {
    w.iter()
        .zip(w_all.iter())
        .enumerate()
        .filter(|(_, (a, b))| **a == 0.0 && **b > 0.0)
        .fold(0, |m, (j, _)| m | (1u32 << j))
}

/// Angle of the rotation carrying `a`'s orientation onto `b`'s \[rad\].
/// Computed as `atan2(sin θ, cos θ)` from the relative rotation matrix, accurate near 0 and
/// near π (an `acos` of the trace is not, and can leave [-1, 1] by rounding).
fn rotation_between(a: &Transform, b: &Transform) -> f64 {
    let r = a.rotation.matrix().transpose() * b.rotation.matrix();
    let sin_axis = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    atan2(sin_axis.norm() / 2.0, (r.trace() - 1.0) / 2.0)
}

/// Residual distance of marker `j` under `t`, and the residual vector.
fn residual(t: &Transform, d: &[f64; 3], m: &[f64; 3]) -> (Vector3<f64>, Vector3<f64>) {
    let p = t.transform_point(&nalgebra::Point3::from(v3(d))).coords;
    (p, v3(m) - p)
}

/// Weighted rigid registration of one body's markers with outlier identification (module
/// docs).
// Long by design: one exclusion search whose scoring, ambiguity and swap checks share the fit state; each check is commented.
pub fn register(markers: &Markers<'_>, opts: &RegistrationOptions) -> Result<Registration> {
    let n = check_inputs(markers, opts)?;
    let design = markers.design;
    let measured = markers.measured;
    let weight = |j: usize| {
        markers
            .weights
            .and_then(|w| w.get(j).copied())
            .unwrap_or(1.0)
    };
    let visible = |j: usize| {
        markers
            .visible
            .and_then(|v| v.get(j).copied())
            .unwrap_or(true)
    };
    let mut w_all = [0.0; MAX_MARKERS];
    let mut thr = [0.0; MAX_MARKERS];
    let mut vis_idx = [0usize; MAX_MARKERS];
    let mut n_vis = 0;
    for j in 0..n {
        thr[j] = opts.k_sigma * opts.sigma_m / sqrt(weight(j));
        if visible(j) {
            w_all[j] = weight(j);
            vis_idx[n_vis] = j;
            n_vis += 1;
        }
    }
    let d = design.get(..n).unwrap_or(&[]);
    let m = measured.get(..n).unwrap_or(&[]);
    // Score of a fit: (all used consistent, Σ (|r|/σ_j)²).
    let score_of = |t: &Transform, w: &[f64; MAX_MARKERS], measured: &[[f64; 3]]| {
        let mut ok = true;
        let mut chi = 0.0;
        for j in 0..n {
            if w[j] > 0.0 {
                let (_, r) = residual(t, &design[j], &measured[j]);
                let dist = r.norm();
                ok &= dist <= thr[j];
                let z = dist / thr[j] * opts.k_sigma;
                chi += z * z;
            }
        }
        (ok, chi)
    };
    let score = |t: &Transform, w: &[f64; MAX_MARKERS]| score_of(t, w, measured);
    // An all-visible fit that is itself ambiguous (a doubled marker on a symmetric body)
    // still lets the exclusion search find, and report, the competing subsets.
    let fit_all = weighted_rigid_fit(d, m, w_all.get(..n).unwrap_or(&[]), opts.sigma_m);
    let ok_all = fit_all.as_ref().is_ok_and(|t| score(t, &w_all).0);
    if fit_all.is_err() && (opts.max_outliers == 0 || n_vis < 4) {
        fit_all?;
    }
    let mut best: Option<(Transform, [f64; MAX_MARKERS], f64)> = None;
    let mut best_size = 0;
    if !ok_all {
        let mut size = 1;
        while size <= opts.max_outliers && n_vis >= size + 3 && best.is_none() {
            for_each_exclusion(&vis_idx, n_vis, size, |excluded| {
                let w = without(&w_all, excluded);
                if let Ok(t) = weighted_rigid_fit(d, m, w.get(..n).unwrap_or(&[]), opts.sigma_m) {
                    let (ok, chi) = score(&t, &w);
                    if ok && best.as_ref().is_none_or(|b| chi < b.2) {
                        best = Some((t, w, chi));
                    }
                }
            });
            best_size = size;
            size += 1;
        }
    }
    // Ambiguity: another exclusion of the same size, consistent, with a pose that moves some
    // visible marker's prediction by more than its threshold.
    let mut ambiguity = None;
    if let Some((t_best, w_best, _)) = best.as_ref() {
        for_each_exclusion(&vis_idx, n_vis, best_size, |excluded| {
            let w = without(&w_all, excluded);
            if w == *w_best {
                return;
            }
            let Ok(t) = weighted_rigid_fit(d, m, w.get(..n).unwrap_or(&[]), opts.sigma_m) else {
                return;
            };
            if !score(&t, &w).0 {
                return;
            }
            let mut shift: f64 = 0.0;
            let mut beyond = false;
            for j in (0..n).filter(|&j| visible(j)) {
                let a = residual(t_best, &design[j], &measured[j]).0;
                let b = residual(&t, &design[j], &measured[j]).0;
                let dist = (a - b).norm();
                beyond |= dist > thr[j];
                shift = shift.max(dist);
            }
            let found = Ambiguity {
                excluded: mask_of(w_best, &w_all),
                alternative_excluded: mask_of(&w, &w_all),
                rotation_rad: rotation_between(t_best, &t),
                marker_shift_m: shift,
            };
            if beyond
                && ambiguity
                    .as_ref()
                    .is_none_or(|a: &Ambiguity| found.marker_shift_m > a.marker_shift_m)
            {
                ambiguity = Some(found);
            }
        });
    }
    let (t, w_used, consistent) = match best {
        Some((t, w, _)) => (t, w, true),
        None => (fit_all?, w_all, ok_all),
    };
    let mut fits = [EMPTY_FIT; MAX_MARKERS];
    let mut wsum = 0.0;
    let mut ssq = 0.0;
    let mut n_used = 0;
    for j in 0..n {
        let (p, r) = residual(&t, &design[j], &measured[j]);
        let f = &mut fits[j];
        f.predicted_m = [p.x, p.y, p.z];
        f.threshold_m = thr[j];
        if !visible(j) {
            f.status = MarkerStatus::Missing;
            continue;
        }
        f.residual_m = [r.x, r.y, r.z];
        f.distance_m = r.norm();
        f.status = if w_used[j] > 0.0 {
            n_used += 1;
            wsum += w_used[j];
            ssq += w_used[j] * f.distance_m * f.distance_m;
            if f.distance_m <= thr[j] {
                MarkerStatus::Inlier
            } else {
                MarkerStatus::Suspect
            }
        } else {
            MarkerStatus::Moved
        };
    }
    // Name swaps among the excluded markers: a pair is swapped when exchanging their two
    // measured positions gives a fit with both of them back in, all markers consistent.
    for j in 0..n {
        if fits[j].status != MarkerStatus::Moved {
            continue;
        }
        for k in (j + 1)..n {
            if fits[k].status != MarkerStatus::Moved {
                continue;
            }
            let mut m2 = [[0.0; 3]; MAX_MARKERS];
            m2[..n].copy_from_slice(m);
            m2.swap(j, k);
            let mut w2 = w_used;
            w2[j] = weight(j);
            w2[k] = weight(k);
            let m2 = m2.get(..n).unwrap_or(&[]);
            if let Ok(t2) = weighted_rigid_fit(d, m2, w2.get(..n).unwrap_or(&[]), opts.sigma_m)
                && score_of(&t2, &w2, m2).0
            {
                fits[j].status = MarkerStatus::Swapped { with: k };
                fits[k].status = MarkerStatus::Swapped { with: j };
                break;
            }
        }
    }
    Ok(Registration {
        t_mocap_body: t,
        n_used,
        rms_m: if wsum > 0.0 { sqrt(ssq / wsum) } else { 0.0 },
        consistent,
        ambiguity,
        fits,
        n,
    })
}

/// The closest pair of congruent marker triangles of a design (see [`design_symmetry`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignSymmetry {
    /// Largest difference between the two triangles' sorted side lengths \[m\]: how far the
    /// design is from having them congruent. Compare with the outlier threshold `k·σ`.
    pub margin_m: f64,
    /// The two triangles (marker indices, zero-based). Equal when one triangle is congruent
    /// with itself under a relabelling (two equal sides: an isosceles triangle).
    pub triangles: [[usize; 3]; 2],
}

/// Checks a marker design for the symmetry that makes registrations ambiguous: two marker
/// triangles (or one, relabelled) that are congruent, so a rotated copy of the body fits a
/// frame with a ghost, knocked or mislabelled marker as well as the true pose does. Returns
/// the closest such pair, or `None` with fewer than 3 markers. Congruence of triangles is
/// equality of their sorted side lengths (a triangle and its mirror image are related by a
/// proper rotation in space), so the margin is exact, not a fit.
#[must_use]
pub fn design_symmetry(design: &[[f64; 3]]) -> Option<DesignSymmetry> {
    let n = design.len().min(MAX_MARKERS);
    let dist = |a: usize, b: usize| match (design.get(a), design.get(b)) {
        (Some(p), Some(q)) => (v3(p) - v3(q)).norm(),
        _ => 0.0,
    };
    let sides = |t: [usize; 3]| {
        let mut s = [dist(t[0], t[1]), dist(t[1], t[2]), dist(t[0], t[2])];
        s.sort_unstable_by(f64::total_cmp);
        s
    };
    let mut best: Option<DesignSymmetry> = None;
    let mut consider = |margin_m: f64, a: [usize; 3], b: [usize; 3]| {
        if best.as_ref().is_none_or(|x| margin_m < x.margin_m) {
            best = Some(DesignSymmetry {
                margin_m,
                triangles: [a, b],
            });
        }
    };
    let triangles = || {
        (0..n)
            .flat_map(move |i| ((i + 1)..n).flat_map(move |j| ((j + 1)..n).map(move |k| [i, j, k])))
    };
    for a in triangles() {
        let sa = sides(a);
        // Relabelling within one triangle: two equal sides.
        consider((sa[1] - sa[0]).min(sa[2] - sa[1]), a, a);
        for b in triangles().filter(|b| *b > a) {
            let sb = sides(b);
            let margin = sa
                .iter()
                .zip(sb.iter())
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            consider(margin, a, b);
        }
    }
    best
}

/// The end-effector pose in the robot base frame from the two registrations' poses:
/// `t_base_ee = t_mocap_base⁻¹ · t_mocap_ee`.
#[must_use]
pub fn t_base_ee(t_mocap_base: &Transform, t_mocap_ee: &Transform) -> Transform {
    // fixed3: nalgebra's `inverse() *` bit for bit, panic-free at opt-level z.
    crate::fixed3::compose(&crate::fixed3::inverse(t_mocap_base), t_mocap_ee)
}

/// Which body a registration error belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerBody {
    /// The markers fixed to the robot base.
    Base,
    /// The markers on the end-effector probe.
    Probe,
}

/// Both registrations and the end-effector pose of one measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndEffectorRegistration {
    /// End effector (probe frame) in the robot base frame.
    pub t_base_ee: Transform,
    /// The base markers' registration (`t_mocap_body` = base frame in the mocap frame).
    pub base: Registration,
    /// The probe markers' registration (`t_mocap_body` = end-effector frame in mocap).
    pub probe: Registration,
}

/// Registers the base markers (design positions in the robot base frame) and the probe
/// markers (design positions in the end-effector frame) and composes
/// `t_base_ee = t_mocap_base⁻¹ · t_mocap_ee`. An error names the body it came from.
pub fn register_end_effector(
    base: &Markers<'_>,
    probe: &Markers<'_>,
    opts: &RegistrationOptions,
) -> core::result::Result<EndEffectorRegistration, (MarkerBody, Error)> {
    let b = register(base, opts).map_err(|e| (MarkerBody::Base, e))?;
    let p = register(probe, opts).map_err(|e| (MarkerBody::Probe, e))?;
    Ok(EndEffectorRegistration {
        t_base_ee: t_base_ee(&b.t_mocap_body, &p.t_mocap_body),
        base: b,
        probe: p,
    })
}
