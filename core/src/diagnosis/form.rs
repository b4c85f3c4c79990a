//! "Do the data determine the effect's form?": the form check that keeps the library's
//! flexible effect from being called `explained` when another smooth function of the same
//! joints fits the data as well.
//!
//! # Why this check
//! `joint_cyclic` has four terms per joint, `Δθ_j = a·sin q_j + b·cos q_j + c·sin 2q_j +
//! d·cos 2q_j`. Over the narrow joint ranges of a working region (60–100° per joint) these
//! terms and the joint offset θ0_j span nearly every smooth function of q_j (about the
//! polynomials up to degree four), so joint_cyclic — alone or with another effect — also
//! fits effects of other forms: a third harmonic, a hardening compliance, a wobbling axis.
//! It then closes 90–99 % of the held-out gap, its remaining gap is not significant, no
//! smooth function of q finds structure in what it leaves, and its fits on one half of a
//! joint's range predict the other half within their (large) uncertainty: on such data an
//! absorbed surrogate and a true cyclic error are statistically the same. What differs is
//! the claim: `explained` says the library's *form* is the cause, and the data do not
//! single that form out.
//!
//! # Method: an alternative basis of the same size
//! The verdict's model is cross-validated once more with every `joint_cyclic` column
//! replaced by the next harmonics of the same joint — `sin 3q_j, cos 3q_j, sin 4q_j,
//! cos 4q_j` times the joint offset's column (the Jacobian of `Δθ_j = f(q_j)` is `f(q_j)`
//! times that of θ0_j) — a model outside the library with the same number of parameters
//! and the same structure (a transmission error of each joint as a function of its own
//! angle). The library's harmonics are singled out only when the alternative is
//! significantly worse held out than the verdict's model: paired z (Wilcoxon over pose
//! groups, as between candidates) at least [`super::Config::z_equivalence`]. Otherwise
//! the data are as well explained by a function of another form: the verdict becomes
//! `partially_explained` ([`super::Reason::FormNotDetermined`]). This is the rule that
//! lists two candidates as confounded, applied to the library's form against one
//! alternative outside it. Over wide joint ranges (or an in-library error large against
//! the noise) the first and second harmonics are distinguishable from the third and
//! fourth and a true cyclic error stays `explained`.
//!
//! Only run for an `explained` verdict containing `joint_cyclic` under cross-validation
//! (the one effect of the library with a basis of several functions per joint). Cost: one
//! more cross-validation of one model.

use super::{DiagWorkspace, MAX_MODELS, ModelAcc, PoseDiagnosis, Rows, SCREEN_MODEL, cv, paired_z};
use crate::error::Result;
use crate::identify::Measurement;
use crate::math::sqrt;
use crate::model::Robot;

/// The form check of the verdict's `joint_cyclic` (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FormCheck {
    /// Whether the check ran (an `explained` verdict with `joint_cyclic` under
    /// cross-validation).
    pub evaluated: bool,
    /// Paired z of the alternative (3rd and 4th harmonics) against the verdict's model
    /// (positive: the alternative has the larger held-out errors).
    pub z: f64,
    /// Held-out RMS position error of the alternative \[m\].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle of the alternative \[rad\].
    pub heldout_rms_rot_rad: f64,
    /// Whether the alternative explains the data as well (`z` below `z_equivalence`): the
    /// data do not determine the effect's form.
    pub equivalent: bool,
}

/// Runs the check of model `mdl` (the verdict's, its held-out errors from the final pass
/// in `poses[..].sq[mdl]`), linearised at the geometric calibration `geometric` as the
/// candidates were. Leaves `poses` and `ws.acc` as it found them for `mdl` and the
/// baseline (the union-model slot is used as scratch); `ws.g_all` is rebuilt at
/// `geometric` with the alternative columns.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check<const N: usize, const P: usize>(
    geometric: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    mdl: usize,
    folds: usize,
    z_equivalence: f64,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<FormCheck> {
    let spare = SCREEN_MODEL;
    if mdl == 0 || mdl >= MAX_MODELS || mdl == spare {
        return Ok(FormCheck::default());
    }
    for p in poses.iter_mut() {
        p.sq[spare] = p.sq[mdl];
        p.sq_rot[spare] = p.sq_rot[mdl];
    }
    let (saved, saved_base) = (ws.acc[mdl], ws.acc[0]);
    ws.alt_harmonics = true;
    let run = alternative(geometric, data, sw, poses, mdl, folds, tol, ws);
    ws.alt_harmonics = false;
    run?;
    let alt: ModelAcc = ws.acc[mdl];
    (ws.acc[mdl], ws.acc[0]) = (saved, saved_base);
    for slot in [mdl, spare] {
        for p in poses.iter_mut() {
            p.gsq[slot] = 0.0;
            p.gsq_rot[slot] = 0.0;
        }
        for l in 0..poses.len() {
            let lead = poses[l].leader as usize;
            let (s, r) = (poses[l].sq[slot], poses[l].sq_rot[slot]);
            if let Some(g) = poses.get_mut(lead) {
                g.gsq[slot] += s;
                g.gsq_rot[slot] += r;
            }
        }
    }
    let z = paired_z(poses, mdl, spare, Rows::All);
    for p in poses.iter_mut() {
        p.sq[mdl] = p.sq[spare];
        p.sq_rot[mdl] = p.sq_rot[spare];
        p.gsq[mdl] = p.gsq[spare];
        p.gsq_rot[mdl] = p.gsq_rot[spare];
    }
    let rms = |s: f64, n: usize| if n == 0 { 0.0 } else { sqrt(s / n as f64) };
    Ok(FormCheck {
        evaluated: true,
        z,
        heldout_rms_pos_m: rms(alt.pos2, alt.n_pos),
        heldout_rms_rot_rad: rms(alt.rot2, alt.n_rot),
        equivalent: z < z_equivalence,
    })
}

/// The alternative model's cross-validation (columns switched by `ws.alt_harmonics`).
#[allow(clippy::too_many_arguments)]
fn alternative<const N: usize, const P: usize>(
    geometric: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    mdl: usize,
    folds: usize,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<()> {
    ws.g_all.reset(ws.n_u)?;
    let at = cv::Lin::bind(geometric, ws);
    for (l, (m, p)) in data.iter().zip(poses.iter()).enumerate() {
        if !p.suspect {
            cv::pose_rows(&at, l, m, sw, ws)?;
            cv::fold_rows(ws, false)?;
        }
    }
    cv::cross_validate(
        geometric,
        data,
        sw,
        poses,
        folds,
        &[mdl],
        cv::Pass::Candidates,
        tol,
        ws,
    )
}
