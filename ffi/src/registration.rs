//! Marker registration (Section 5.1): the rigid transform carrying a body's design marker
//! positions onto their motion-capture measurements, with per-marker residuals and outlier
//! identification, and the end-effector pose from base and probe registrations.

use kincal::registration::{
    MAX_MARKERS, MAX_OUTLIERS, MarkerStatus, Markers, RegistrationOptions, register, t_base_ee,
};

use crate::status::{kincal_error, kincal_status};

/// Most markers on one body.
pub const KINCAL_MAX_MARKERS: usize = 32;
/// Most markers `kincal_register` may exclude as outliers.
pub const KINCAL_MAX_OUTLIERS: usize = 3;
const _: () = assert!(KINCAL_MAX_MARKERS == MAX_MARKERS && KINCAL_MAX_OUTLIERS == MAX_OUTLIERS);

/// Options of `kincal_register`; `kincal_registration_options_default` fills them.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_registration_options {
    /// Stated measurement noise, 1σ per axis at weight 1 [m] (finite, > 0).
    pub sigma_m: f64,
    /// Outlier threshold in units of σ_j on the 3-D residual distance (default 4).
    pub k_sigma: f64,
    /// Most markers to exclude as outliers (≤ `KINCAL_MAX_OUTLIERS`; 0 disables the search;
    /// default 2).
    pub max_outliers: usize,
}

/// What the registration concluded about one marker (`kincal_marker_fit.status`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_marker_status {
    /// Used in the fit and consistent with it.
    Inlier = 0,
    /// Masked as not seen.
    Missing = 1,
    /// Excluded: off by more than its threshold and not explained by a swap.
    Moved = 2,
    /// Excluded: its label is swapped with marker `swapped_with`.
    Swapped = 3,
    /// Used, but above its threshold in a fit no exclusion could make consistent.
    Suspect = 4,
}

/// The fit of one marker.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_marker_fit {
    /// Predicted position `t_mocap_body · design` in the motion-capture frame [m].
    pub predicted_m: [f64; 3],
    /// Residual measured − predicted [m] (zero if missing).
    pub residual_m: [f64; 3],
    /// Length of the residual [m] (zero if missing).
    pub distance_m: f64,
    /// Outlier threshold k·σ/√w of this marker [m].
    pub threshold_m: f64,
    /// A `kincal_marker_status`.
    pub status: u32,
    /// For `KINCAL_MARKER_STATUS_SWAPPED`: the other marker (zero-based); else
    /// `KINCAL_NO_INDEX`.
    pub swapped_with: usize,
}

/// The result of `kincal_register`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_registration {
    /// The body frame in the motion-capture frame, 4×4 column-major:
    /// measured ≈ t_mocap_body · design.
    pub t_mocap_body: [f64; 16],
    /// Markers used in the fit.
    pub n_used: usize,
    /// Weighted RMS residual distance of the used markers [m].
    pub rms_m: f64,
    /// 1 when every used marker is within its threshold.
    pub consistent: u32,
    /// Number of markers (entries of `markers` that are valid).
    pub n_markers: usize,
    /// Per-marker fits, in input order.
    pub markers: [kincal_marker_fit; KINCAL_MAX_MARKERS],
    /// 1 when another exclusion fits as well with a different pose (a ghost or knocked
    /// marker on a body with too few markers to pin it, typical of symmetric designs): the
    /// pose is not determined and must not be used. 0 otherwise.
    pub ambiguous: u32,
    /// When `ambiguous`: the markers (bit j for marker j) the competing fit excludes.
    pub alternative_excluded: u32,
    /// When `ambiguous`: the rotation between the two poses [rad]; else 0.
    pub ambiguity_rotation_rad: f64,
}

/// Default registration options for noise `sigma_m` [m]: k = 4, up to 2 outliers. Returns OK,
/// NULL_POINTER or MISALIGNED_POINTER (`sigma_m` is checked by `kincal_register`).
///
/// # Safety
/// `opts_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_registration_options_default(
    sigma_m: f64,
    opts_out: *mut kincal_registration_options,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(opts_out);
        let o = RegistrationOptions::new(sigma_m);
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe {
            out.put(kincal_registration_options {
                sigma_m: o.sigma_m,
                k_sigma: o.k_sigma,
                max_outliers: o.max_outliers,
            })
        };
        Ok(())
    })
}

/// Weighted rigid registration of one body's M markers (3 ≤ M ≤ `KINCAL_MAX_MARKERS`) with
/// outlier identification (Horn's method; see the core's `registration` docs).
///
/// - `design`, `design_len`: design positions in the body frame, M × 3 doubles [m].
/// - `measured`, `measured_len`: measured positions in the motion-capture frame, M × 3 [m];
///   entries of markers not visible are ignored (NaN allowed).
/// - `visible`, `visible_len`: M bytes (non-zero = seen), or NULL for all seen.
/// - `weights`, `weights_len`: M relative weights (finite, > 0), or NULL for all 1.
/// - `opts`: from `kincal_registration_options_default`.
/// - `registration_out`: written on success only.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH (lengths not M × 3 / M),
/// CAPACITY_EXCEEDED (M or `max_outliers` too large), NON_FINITE, INVALID_PARAMETER (σ, k or a
/// weight not positive: `index`), TOO_FEW_DATA (fewer than 3 markers used) or RANK_DEFICIENT
/// (collinear design or ambiguous rotation).
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_register(
    design: *const f64,
    design_len: usize,
    measured: *const f64,
    measured_len: usize,
    visible: *const u8,
    visible_len: usize,
    weights: *const f64,
    weights_len: usize,
    opts: *const kincal_registration_options,
    registration_out: *mut kincal_registration,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let o = arg_ref!(opts);
        let out = arg_out1!(registration_out);
        if design.is_null() {
            return Err(crate::args::null(c"design"));
        }
        let m = design_len / 3;
        if !design_len.is_multiple_of(3) || m > KINCAL_MAX_MARKERS {
            return Err(if !design_len.is_multiple_of(3) {
                crate::args::bad_length(c"design", 3 * m, design_len)
            } else {
                kincal_error::new(kincal_status::CapacityExceeded)
                    .arg(c"design")
                    .counts(KINCAL_MAX_MARKERS, m)
            });
        }
        let design = arg_f64s!(design, design_len, 3 * m);
        let measured = arg_slice!(measured, measured_len, 3 * m);
        let mut seen = [true; KINCAL_MAX_MARKERS];
        if !visible.is_null() {
            let v = arg_slice!(visible, visible_len, m);
            for (s, &b) in seen.iter_mut().zip(v) {
                *s = b != 0;
            }
        }
        let seen = seen.get(..m).ok_or(kincal_error::new(kincal_status::Internal))?;
        for (j, (p, &s)) in measured.chunks_exact(3).zip(seen).enumerate() {
            if s {
                crate::args::finite(p, c"measured").map_err(|e| e.at(3 * j + e.index))?;
            }
        }
        let w = if weights.is_null() {
            None
        } else {
            Some(arg_f64s!(weights, weights_len, m))
        };
        let (design3, _) = design.as_chunks::<3>();
        let (measured3, _) = measured.as_chunks::<3>();
        let markers = Markers {
            design: design3,
            measured: measured3,
            visible: if visible.is_null() { None } else { Some(seen) },
            weights: w,
        };
        let opts = RegistrationOptions {
            sigma_m: o.sigma_m,
            k_sigma: o.k_sigma,
            max_outliers: o.max_outliers,
        };
        let reg = register(&markers, &opts)?;
        let mut r = kincal_registration {
            t_mocap_body: crate::pose::to_matrix(&reg.t_mocap_body),
            n_used: reg.n_used,
            rms_m: reg.rms_m,
            consistent: u32::from(reg.consistent),
            n_markers: reg.markers().len(),
            markers: [kincal_marker_fit::default(); KINCAL_MAX_MARKERS],
            ambiguous: u32::from(reg.ambiguity.is_some()),
            alternative_excluded: reg.ambiguity.map_or(0, |a| a.alternative_excluded),
            ambiguity_rotation_rad: reg.ambiguity.map_or(0.0, |a| a.rotation_rad),
        };
        for (d, f) in r.markers.iter_mut().zip(reg.markers()) {
            let (status, with) = match f.status {
                MarkerStatus::Inlier => (kincal_marker_status::Inlier, crate::status::KINCAL_NO_INDEX),
                MarkerStatus::Missing => (kincal_marker_status::Missing, crate::status::KINCAL_NO_INDEX),
                MarkerStatus::Moved => (kincal_marker_status::Moved, crate::status::KINCAL_NO_INDEX),
                MarkerStatus::Swapped { with } => (kincal_marker_status::Swapped, with),
                MarkerStatus::Suspect => (kincal_marker_status::Suspect, crate::status::KINCAL_NO_INDEX),
            };
            *d = kincal_marker_fit {
                predicted_m: f.predicted_m,
                residual_m: f.residual_m,
                distance_m: f.distance_m,
                threshold_m: f.threshold_m,
                status: status as u32,
                swapped_with: with,
            };
        }
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(r) };
        Ok(())
    })
}

/// The end-effector pose in the robot base frame from the two registrations' poses,
/// `t_base_ee = t_mocap_base⁻¹ · t_mocap_ee` (all 4×4 column-major rigid transforms, 16
/// doubles each). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or
/// INVALID_TRANSFORM.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_t_base_ee(
    t_mocap_base: *const f64,
    t_mocap_base_len: usize,
    t_mocap_ee: *const f64,
    t_mocap_ee_len: usize,
    t_base_ee_out: *mut f64,
    t_base_ee_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let b = crate::pose::from_matrix(arg_slice!(t_mocap_base, t_mocap_base_len, 16), c"t_mocap_base")?;
        let e = crate::pose::from_matrix(arg_slice!(t_mocap_ee, t_mocap_ee_len, 16), c"t_mocap_ee")?;
        let out = arg_out!(t_base_ee_out, t_base_ee_len, 16);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_matrix(&t_base_ee(&b, &e))) }?;
        Ok(())
    })
}
