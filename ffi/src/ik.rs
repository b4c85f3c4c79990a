//! Inverse kinematics with effects compensated.

use kincal::ik::{IkOptions, IkSolution, solve_ik};
use kincal::pose::Transform;
use kincal::{Robot, with_any_robot};

use crate::kinematics::{CALL_AUX, joint_state, kincal_joint_aux, robot_and_q};
use crate::robot::{KINCAL_MAX_JOINTS, kincal_robot};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// Options of `kincal_ik` and `kincal_prepared_ik`; start from one of three presets:
/// `kincal_ik_options_control_loop` (seed near the answer: microseconds),
/// `kincal_ik_options_global_search` (any seed, first solution: tens of microseconds) or
/// `kincal_ik_options_default` (every seed, the solution nearest the seed: milliseconds).
/// Every field is checked against its bounds before any work (INVALID_ARGUMENT naming the
/// field, e.g. `opts->extra_seeds`, and its value), and so is
/// the budget (1 + extra_seeds)·max_iterations <= `KINCAL_IK_MAX_TOTAL_ITERATIONS` (20000,
/// about 6x the defaults' 3400), so every call ends in bounded time.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_ik_options {
    /// Iterations per seed, 1..=`KINCAL_IK_MAX_ITERATIONS` (1000; default 200).
    pub max_iterations: u32,
    /// 1: stop at the first seed that converges (faster; the answer is then the solution
    /// reached from the earliest converging seed rather than the nearest to the caller's
    /// seed); 0: try every seed (default). Other values are INVALID_ARGUMENT.
    pub first_solution: u32,
    /// Seeds tried after the caller's: a deterministic Halton sequence over the limits clipped
    /// to ±π, 0..=`KINCAL_IK_MAX_EXTRA_SEEDS` (256; default 16), within the budget above
    /// (INVALID_ARGUMENT names `opts->extra_seeds` when the budget is exceeded).
    pub extra_seeds: usize,
    /// Convergence: position residual below this [m], in (0, 1] (default 1e-11).
    pub tol_pos_m: f64,
    /// Convergence: orientation residual below this [rad], in (0, π] (default 1e-11).
    pub tol_rot_rad: f64,
}

/// Largest `kincal_ik_options.max_iterations`.
pub const KINCAL_IK_MAX_ITERATIONS: u32 = 1000;
/// Largest `kincal_ik_options.extra_seeds`.
pub const KINCAL_IK_MAX_EXTRA_SEEDS: usize = 256;
/// Largest `(1 + extra_seeds) * max_iterations` of `kincal_ik_options`.
pub const KINCAL_IK_MAX_TOTAL_ITERATIONS: u64 = 20_000;
const _: () = assert!(KINCAL_IK_MAX_ITERATIONS == IkOptions::MAX_ITERATIONS);
const _: () = assert!(KINCAL_IK_MAX_TOTAL_ITERATIONS == IkOptions::MAX_TOTAL_ITERATIONS);
const _: () = assert!(KINCAL_IK_MAX_EXTRA_SEEDS == IkOptions::MAX_EXTRA_SEEDS);

impl From<IkOptions> for kincal_ik_options {
    fn from(o: IkOptions) -> Self {
        kincal_ik_options {
            max_iterations: o.max_iterations,
            first_solution: u32::from(o.first_solution),
            extra_seeds: o.extra_seeds,
            tol_pos_m: o.tol_pos_m,
            tol_rot_rad: o.tol_rot_rad,
        }
    }
}

/// The core's options from the C struct, every field checked against its bounds (the core's
/// [`IkOptions::validate`]; `first_solution` must be 0 or 1).
pub(crate) fn options(o: &kincal_ik_options) -> FfiResult<IkOptions> {
    let first_solution = match o.first_solution {
        0 => false,
        1 => true,
        v => {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"opts->first_solution")
                .value(f64::from(v)));
        }
    };
    // A NaN or infinite tolerance stays NON_FINITE (as every other double argument).
    crate::args::finite(&[o.tol_pos_m], c"opts->tol_pos_m")?;
    crate::args::finite(&[o.tol_rot_rad], c"opts->tol_rot_rad")?;
    let opts = IkOptions {
        max_iterations: o.max_iterations,
        tol_pos_m: o.tol_pos_m,
        tol_rot_rad: o.tol_rot_rad,
        extra_seeds: o.extra_seeds,
        first_solution,
    };
    opts.validate()?;
    Ok(opts)
}

/// What `kincal_ik` found besides the readings.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_ik_info {
    /// Position residual of the solution [m].
    pub residual_pos_m: f64,
    /// Orientation residual of the solution [rad].
    pub residual_rot_rad: f64,
    /// Iterations used from the chosen seed.
    pub iterations: u32,
    /// Which seed converged to the solution (0 = the caller's).
    pub seed_index: usize,
}

/// Writes the default IK options into `opts_out`. Returns OK, NULL_POINTER or
/// MISALIGNED_POINTER.
///
/// # Safety
/// `opts_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_ik_options_default(
    opts_out: *mut kincal_ik_options,
    err: *mut kincal_error,
) -> kincal_status {
    // SAFETY: forwarded from this function's contract.
    unsafe { put_ik_options(opts_out, err, IkOptions::default()) }
}

/// Writes the control-loop IK options into `opts_out`: one descent of at most 50 iterations
/// from the caller's seed (the last cycle's answer), no further seeds; a few microseconds
/// from a seed within a few degrees of the answer, never a jump to another branch. On
/// UNREACHABLE (rare: an answer against a joint limit or at a singularity) fall back to
/// `kincal_ik_options_global_search`. Returns OK, NULL_POINTER or MISALIGNED_POINTER.
///
/// # Safety
/// `opts_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_ik_options_control_loop(
    opts_out: *mut kincal_ik_options,
    err: *mut kincal_error,
) -> kincal_status {
    // SAFETY: forwarded from this function's contract.
    unsafe { put_ik_options(opts_out, err, IkOptions::control_loop()) }
}

/// Writes the global-search IK options into `opts_out`, for a target whose branch is unknown:
/// the caller's seed, then up to 128 Halton seeds over the joint ranges, each descent cut
/// off after 20 iterations, stopping at the first solution (not the one nearest the seed).
/// Tens of microseconds where the default (every seed to the end) takes milliseconds.
/// Returns OK, NULL_POINTER or MISALIGNED_POINTER.
///
/// # Safety
/// `opts_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_ik_options_global_search(
    opts_out: *mut kincal_ik_options,
    err: *mut kincal_error,
) -> kincal_status {
    // SAFETY: forwarded from this function's contract.
    unsafe { put_ik_options(opts_out, err, IkOptions::global_search()) }
}

/// Writes `opts` into `opts_out` (the three option presets' one body).
///
/// # Safety
/// `opts_out` must be NULL or writable; `err` NULL or writable.
unsafe fn put_ik_options(
    opts_out: *mut kincal_ik_options,
    err: *mut kincal_error,
    opts: IkOptions,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(opts_out);
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(opts.into()) };
        Ok(())
    })
}

/// The solution of one IK call on a built model: readings (first N used) and the info.
pub(crate) fn ik_of<const N: usize>(
    r: &Robot<N>,
    target: &Transform,
    seed: &[f64; KINCAL_MAX_JOINTS],
    aux: Option<&kincal_joint_aux>,
    opts: &IkOptions,
) -> FfiResult<([f64; KINCAL_MAX_JOINTS], kincal_ik_info)> {
    let s = seed
        .get(..N)
        .ok_or(kincal_error::new(kincal_status::Internal))?;
    let state = joint_state::<N>(s, aux, CALL_AUX)?;
    let sol: IkSolution<N> = solve_ik(r, target, &state, opts)?;
    let mut q = [0.0; KINCAL_MAX_JOINTS];
    for (d, s) in q.iter_mut().zip(sol.q.iter()) {
        *d = *s;
    }
    let info = kincal_ik_info {
        residual_pos_m: sol.residual_pos_m,
        residual_rot_rad: sol.residual_rot_rad,
        iterations: sol.iterations,
        seed_index: sol.seed_index,
    };
    Ok((q, info))
}

/// Inverse kinematics: readings `q_out` (N doubles [rad], within the joint limits) whose
/// effect-compensated FK reaches `target` (4×4 column-major rigid transform, 16 doubles: the
/// tool pose in the base frame). Damped least squares from `q_seed` and `opts->extra_seeds`
/// further seeds; the converged solution nearest to `q_seed` is returned (joints whose range
/// spans more than 2π are shifted by ±2π towards the seed where the limits allow).
///
/// - `q_seed`, `q_seed_len`: start configuration [rad], N doubles (clamped into the limits).
/// - `aux`: approach directions / temperature the model needs, or NULL.
/// - `opts`: NULL for the defaults (`kincal_ik_options_default`); a control loop passes
///   `kincal_ik_options_control_loop`'s options, a search without a good seed
///   `kincal_ik_options_global_search`'s.
/// - `q_out`, `q_out_len`: N doubles, written on success only; may overlap `q_seed`.
/// - `info_out`: residuals, iterations and seed of the solution, or NULL.
///
/// Returns OK, UNREACHABLE (no seed converged; `residual_pos_m`/`residual_rot_rad` give the
/// best residual found), NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE,
/// INVALID_TRANSFORM, INVALID_ARGUMENT (an approach direction, or an option outside the
/// bounds documented in `kincal_ik_options`), MISSING_INPUT or any status of
/// `kincal_robot_validate`. With `std` the call runs in a catch_unwind
/// boundary; the no_std build is proved panic-free at link time.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_ik(
    robot: *const kincal_robot,
    target: *const f64,
    target_len: usize,
    q_seed: *const f64,
    q_seed_len: usize,
    aux: *const kincal_joint_aux,
    opts: *const kincal_ik_options,
    q_out: *mut f64,
    q_out_len: usize,
    info_out: *mut kincal_ik_info,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, seed, aux) = unsafe { robot_and_q(robot, q_seed, q_seed_len, c"q_seed", aux) }?;
        let n = any.n_joints();
        let target = crate::pose::from_matrix(arg_slice!(target, target_len, 16), c"target")?;
        let opts = match arg_opt!(opts) {
            Some(o) => options(o)?,
            None => IkOptions::default(),
        };
        let out = arg_out!(q_out, q_out_len, n);
        let info = if info_out.is_null() { None } else { Some(arg_out1!(info_out)) };
        let (q, info_v) = with_any_robot!(&any, r => ik_of(r, &target, &seed, aux.as_ref(), &opts))?;
        // SAFETY: checked by `arg_out!`/`arg_out1!`; writable by contract.
        unsafe {
            out.write_finite(&q)?;
            if let Some(i) = info {
                i.put(info_v);
            }
        }
        Ok(())
    })
}
