//! "Do the data determine the effect's form?": the form check that keeps a library effect
//! from being called `explained` when a function of another form fits the data as well.
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
//! `thermal` has the same weakness in time: its column is `(T − 20 °C)·g(q)`, with `g` how
//! the pose moves when every length grows. Where the temperature rises over the session
//! (an arm warming up), `(T − 20)·ḡ`, the part of that column common to every pose, is a
//! translation that grows with time: any slow drift of the instrument or of the arm's
//! mount fits it, and `thermal` then closes most of a gap that has nothing to do with the
//! lengths. What singles out thermal expansion is the dependence on the configuration,
//! `g(q) − ḡ`.
//!
//! # Method: an alternative basis of the same size
//! The verdict's model is cross-validated once more with the effect's columns replaced by
//! a model outside the library with the same number of parameters:
//! - `joint_cyclic`: every term by the next harmonic of the same joint — `sin 3q_j,
//!   cos 3q_j, sin 4q_j, cos 4q_j` times the joint offset's column (the Jacobian of
//!   `Δθ_j = f(q_j)` is `f(q_j)` times that of θ0_j): a transmission error of each joint
//!   as a function of its own angle;
//! - `thermal`: its column by `(T − 20 °C)·ḡ`, ḡ the constant (position only) that fits
//!   `g(q)` best over the clean rows in least squares: a translation that follows the
//!   temperature and not the arm.
//!
//! The library's form is singled out only when the alternative is significantly worse held
//! out than the verdict's model: paired z (Wilcoxon over pose groups, as between
//! candidates) at least [`super::Config::z_equivalence`]. Otherwise the data are as well
//! explained by a function of another form: the verdict becomes `partially_explained`
//! ([`super::Reason::FormNotDetermined`], naming the effect). This is the rule that lists
//! two candidates as confounded, applied to the library's form against one alternative
//! outside it. Over wide joint ranges (or an in-library error large against the noise) the
//! first and second harmonics are distinguishable from the third and fourth, a true length
//! expansion moves each configuration differently, and the verdict stays `explained`.
//!
//! Only run for an `explained` verdict containing `joint_cyclic` or `thermal` under
//! cross-validation, `joint_cyclic` first (and `thermal` only when that one is determined).
//! Cost: one more cross-validation of one model per effect checked.

use super::{DiagWorkspace, MAX_MODELS, ModelAcc, PoseDiagnosis, Rows, SCREEN_MODEL, cv, paired_z};
use crate::effects::Effect;
use crate::error::{ParamIndex, Result};
use crate::identify::Measurement;
use crate::math::{cos, sin, sqrt};
use crate::model::{Robot, THERMAL_REFERENCE_C};
use crate::params::{CyclicTerm, LinkParam, ParamId};

/// The form check of the verdict's `joint_cyclic` or `thermal` (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FormCheck {
    /// Whether the check ran (an `explained` verdict with `joint_cyclic` or `thermal`
    /// under cross-validation).
    pub evaluated: bool,
    /// The effect whose form was checked (the one found not determined, else the last
    /// checked); `None` when the check did not run.
    pub effect: Option<Effect>,
    /// Paired z of the alternative against the verdict's model (positive: the alternative
    /// has the larger held-out errors).
    pub z: f64,
    /// Held-out RMS position error of the alternative \[m\].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle of the alternative \[rad\].
    pub heldout_rms_rot_rad: f64,
    /// Whether the alternative explains the data as well (`z` below `z_equivalence`): the
    /// data do not determine the effect's form.
    pub equivalent: bool,
}

/// The columns the form check's cross-validation replaces (`ws.alternative`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) enum Alternative {
    /// The model's own columns.
    #[default]
    None,
    /// `joint_cyclic`'s terms by the 3rd and 4th harmonics of the same joint.
    Harmonics,
    /// `thermal`'s column `(T − 20 °C)·g(q)` by `(T − 20 °C)·ḡ`, ḡ \[m\] in the base frame.
    TemperatureTranslation([f64; 3]),
}

/// Runs the check of `effect`'s form (`joint_cyclic` or `thermal`; any other effect:
/// not evaluated) in model `mdl` (the verdict's, its held-out errors from the final pass
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
    effect: Effect,
    folds: usize,
    z_equivalence: f64,
    tol: f64,
    ws: &mut DiagWorkspace<P>,
) -> Result<FormCheck> {
    let spare = SCREEN_MODEL;
    if mdl == 0 || mdl >= MAX_MODELS || mdl == spare {
        return Ok(FormCheck::default());
    }
    let replacement = match effect {
        Effect::JointCyclic => Alternative::Harmonics,
        Effect::Thermal => {
            Alternative::TemperatureTranslation(common_translation(geometric, data, poses, ws)?)
        }
        _ => return Ok(FormCheck::default()),
    };
    for p in poses.iter_mut() {
        p.sq[spare] = p.sq[mdl];
        p.sq_rot[spare] = p.sq_rot[mdl];
    }
    let (saved, saved_base) = (ws.acc[mdl], ws.acc[0]);
    ws.alternative = replacement;
    let run = alternative(geometric, data, sw, poses, mdl, folds, tol, ws);
    ws.alternative = Alternative::None;
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
        effect: Some(effect),
        z,
        heldout_rms_pos_m: rms(alt.pos2, alt.n_pos),
        heldout_rms_rot_rad: rms(alt.rot2, alt.n_rot),
        equivalent: z < z_equivalence,
    })
}

/// The alternative model's cross-validation (columns switched by `ws.alternative`).
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

/// ḡ \[m\]: the constant that fits `g(q)`, the position part of the thermal column over
/// `T − 20 °C`, best over the clean rows with a temperature, per measured axis
/// (`Σ ΔT·J_thermal / Σ ΔT²`; 0 on an axis no row measures or where every ΔT is 0).
fn common_translation<const N: usize, const P: usize>(
    geometric: &Robot<N>,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    ws: &mut DiagWorkspace<P>,
) -> Result<[f64; 3]> {
    let thermal = ParamId::Thermal.index(N).0;
    let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
    for (m, p) in data.iter().zip(poses) {
        let Some(t) = m.state.temp_c.filter(|_| !p.suspect) else {
            continue;
        };
        let jac = super::jacobian_slots::<N>(&mut ws.jac)?;
        m.model_jacobian(geometric, jac)?;
        let col = jac.get(thermal).copied().unwrap_or([0.0; 6]);
        let dt = t - THERMAL_REFERENCE_C;
        for k in 0..3 {
            if m.mask.has(k) {
                num[k] += dt * col[k];
                den[k] += dt * dt;
            }
        }
    }
    Ok(core::array::from_fn(|k| {
        if den[k] > 0.0 { num[k] / den[k] } else { 0.0 }
    }))
}

/// Replaces, in the whitened rows `ws.a` of pose `m`, the columns of `U` that
/// `ws.alternative` swaps (module documentation); `ws.jac` holds the pose's whole
/// Jacobian.
pub(crate) fn alternative_columns<const N: usize, const P: usize>(
    m: &Measurement<N>,
    sw: &[f64; 6],
    ws: &mut DiagWorkspace<P>,
) {
    let weight = |k: usize| if m.mask.has(k) { sw[k] } else { 0.0 };
    for c in 0..ws.n_u.min(P) {
        let id = ParamId::from_index(ParamIndex(ws.u[c]), N);
        // The replacement is `column × factor` (the harmonic of q_j times θ0_j's column;
        // ΔT times ḡ), whitened as `w_k·column_k·factor`.
        let (column, factor): ([f64; 6], f64) = match (ws.alternative, id) {
            (Alternative::Harmonics, Ok(ParamId::Cyclic(j, t))) => {
                let theta = ParamId::Link {
                    link: j,
                    kind: LinkParam::Theta0,
                }
                .index(N)
                .0;
                let q = m.state.q.get(j).copied().unwrap_or(0.0);
                let f = match t {
                    CyclicTerm::Sin1 => sin(3.0 * q),
                    CyclicTerm::Cos1 => cos(3.0 * q),
                    CyclicTerm::Sin2 => sin(4.0 * q),
                    CyclicTerm::Cos2 => cos(4.0 * q),
                };
                let Some(&col) = ws.jac.get(theta) else {
                    continue;
                };
                (col, f)
            }
            (Alternative::TemperatureTranslation([gx, gy, gz]), Ok(ParamId::Thermal)) => {
                let dt = m.state.temp_c.map_or(0.0, |t| t - THERMAL_REFERENCE_C);
                ([gx, gy, gz, 0.0, 0.0, 0.0], dt)
            }
            _ => continue,
        };
        for (k, a) in ws.a.iter_mut().enumerate() {
            if let Some(ak) = a.get_mut(c) {
                *ak = weight(k) * column[k] * factor;
            }
        }
    }
}
