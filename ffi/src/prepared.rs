//! The prepared-model handle: a core model built and validated once (`kincal_prepare`) into
//! caller-owned storage, and FK / compensated joint angles / IK exports that use it without
//! rebuilding it.
//!
//! Why: every `kincal_robot` export converts and validates the parameter table on each call
//! (see [`crate::robot`]), which costs several times the FK itself. Controllers evaluate FK
//! and IK at kHz rates, so they prepare the model once and pass the handle.
//!
//! Storage: `kincal_prepared` is `KINCAL_PREPARED_SIZE` bytes aligned to
//! `KINCAL_PREPARED_ALIGN`, declared by the caller anywhere (stack, static); nothing is
//! allocated and the library keeps no pointer to it. Its content is private to this module:
//!
//! | word | content                                                                  |
//! |------|--------------------------------------------------------------------------|
//! | 0    | [`MAGIC`] (tag and layout version)                                       |
//! | 1    | joint count N (low 32 bits), `size_of::<Robot<N>>()` (high 32 bits)      |
//! | 2    | guard: the checksum's complement                                         |
//! | 3    | checksum of words 0–1 and of the stored model                            |
//! | 4..  | the core `Robot<N>`, byte for byte                                       |
//!
//! Misuse is a status, never undefined behaviour. On every call, before a stored model is
//! read, the pointer is checked (NULL, alignment), then the magic word, the joint count and
//! size, the guard word against the checksum word, and the bytes of the model's only field
//! with invalid bit patterns (`[LengthParam; N]`, each 0 or 1 at
//! [`Robot::LENGTH_PARAM_OFFSET`]); any failure is `KINCAL_STATUS_BAD_HANDLE`. Every other
//! byte of a `Robot<N>` belongs to an `f64` (the layout contract documented on [`Robot`],
//! guarded by [`payload_fits`]), so a model that passed these checks is a valid Rust value
//! whatever the storage held. Uninitialised, zeroed, foreign or overwritten-from-the-start
//! storage fails these cheap checks (a few words: about 2 ns). The checksum over the whole
//! model (about 90 ns for six joints, most of an FK) is verified by `kincal_prepare`'s
//! counterpart `kincal_prepared_validate` only, which a caller runs when it wants to know the
//! stored numbers are intact (after start-up, a memory self-test, a copy between memories):
//! validate once, then call the fast exports in the loop. The checksum never reads the
//! padding bytes after `[LengthParam; N]` (they are uninitialised in Rust's sense).
//!
//! A handle is tied to the library build that prepared it (the layout of `Robot<N>` is not an
//! ABI): never persist one across builds; prepare again at start-up.

use core::mem::{align_of, size_of};

use kincal::ik::IkOptions;
use kincal::{JointState, LengthParam, Robot, Transform, with_any_robot};

use crate::ik::{ik_of, kincal_ik_info, kincal_ik_options, options};
use crate::kinematics::{CALL_AUX, angles_of, jacobian_of, joint_state, kincal_joint_aux};
use kincal::params::{num_geometric_params, num_params};

use crate::robot::{KINCAL_MAX_JOINTS, kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// Size in bytes of `kincal_prepared` (`sizeof(kincal_prepared)`; also `kincal_prepared_size()`).
pub const KINCAL_PREPARED_SIZE: usize = 4096;
/// Alignment in bytes of `kincal_prepared` (`alignof(kincal_prepared)`, that of `uint64_t`).
pub const KINCAL_PREPARED_ALIGN: usize = 8;
/// Number of `uint64_t` words of `kincal_prepared.opaque`: `KINCAL_PREPARED_SIZE / 8`.
pub const KINCAL_PREPARED_WORDS: usize = 512;

/// A prepared robot model: the core model built and validated once by `kincal_prepare`, for
/// fast repeated FK and IK (`kincal_prepared_*`). Caller-owned storage of
/// `KINCAL_PREPARED_SIZE` bytes aligned to `KINCAL_PREPARED_ALIGN`, wherever the caller puts it
/// (static, stack): the library allocates nothing and keeps no pointer to it.
///
/// The content is opaque and private to the library build that wrote it: do not edit it, do
/// not persist it across library builds or versions (prepare again at start-up). A handle may
/// be copied with `memcpy`. Storage that `kincal_prepare` did not fill (uninitialised,
/// zeroed, overwritten, or from another build) makes every `kincal_prepared_*` call return
/// `KINCAL_STATUS_BAD_HANDLE` (cheap header and guard words, checked on every call); a
/// checksum over the whole stored model, checked by `kincal_prepared_validate` only, detects
/// corruption of the stored numbers themselves.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct kincal_prepared {
    /// Opaque; written only by `kincal_prepare`.
    pub opaque: [u64; KINCAL_PREPARED_WORDS],
}

const _: () = assert!(size_of::<kincal_prepared>() == KINCAL_PREPARED_SIZE);
const _: () = assert!(align_of::<kincal_prepared>() == KINCAL_PREPARED_ALIGN);
const _: () = assert!(KINCAL_PREPARED_WORDS * 8 == KINCAL_PREPARED_SIZE);

/// Header words before the stored model.
const HEADER_WORDS: usize = 4;
/// Word 0 of a prepared handle: tag `kcPREP`, then the layout version (1) in the last byte.
const MAGIC: u64 = u64::from_le_bytes(*b"kcPREP\x00\x01");
/// Seeds of the four checksum lanes (digits of π) and the multiplier (2^64 / golden ratio,
/// odd, so each step is a bijection of the lane: a single changed word always changes the sum).
const LANE_SEEDS: [u64; 4] = [
    0x243F_6A88_85A3_08D3,
    0x1319_8A2E_0370_7344,
    0xA409_3822_299F_31D0,
    0x082E_FA98_EC4E_6C89,
];
const MUL: u64 = 0x9E37_79B9_7F4A_7C15;

/// Words of a `Robot<N>` taken by the N bytes of `[LengthParam; N]` and their padding.
const fn lp_words<const N: usize>() -> usize {
    N.div_ceil(8)
}

/// Whether a `Robot<N>` fits the storage with the layout this module relies on: 8-byte words
/// (all `f64` and the one `u64` of the joint-kind bits: `32N + 78` of them) plus the N bytes of `[LengthParam; N]` at an 8-aligned
/// offset padded to whole words ([`lp_words`]). A core change of `Robot`'s fields fails this
/// at compile time.
const fn payload_fits<const N: usize>() -> bool {
    let size = size_of::<Robot<N>>();
    let lp = Robot::<N>::LENGTH_PARAM_OFFSET;
    N <= 64
        && size == 8 * (32 * N + 78) + 8 * lp_words::<N>()
        && (HEADER_WORDS * 8 + size) <= KINCAL_PREPARED_SIZE
        && align_of::<Robot<N>>() <= KINCAL_PREPARED_ALIGN
        && (HEADER_WORDS * 8).is_multiple_of(align_of::<Robot<N>>())
        && lp.is_multiple_of(8)
        && lp + 8 * lp_words::<N>() <= size
        && size_of::<LengthParam>() == 1
}
const _: () = assert!(
    payload_fits::<1>()
        && payload_fits::<2>()
        && payload_fits::<3>()
        && payload_fits::<4>()
        && payload_fits::<5>()
        && payload_fits::<6>()
        && payload_fits::<7>()
        && payload_fits::<8>()
        && payload_fits::<9>()
        && payload_fits::<10>()
        && payload_fits::<11>()
        && payload_fits::<12>()
);
const _: () = assert!(KINCAL_MAX_JOINTS == 12);
const _: () = assert!(LengthParam::D as u8 == 0 && LengthParam::Beta as u8 == 1);

/// Word 1 of a handle holding a `Robot<N>`.
const fn shape<const N: usize>() -> u64 {
    N as u64 | ((size_of::<Robot<N>>() as u64) << 32)
}

fn bad_handle() -> kincal_error {
    kincal_error::new(kincal_status::BadHandle).arg(c"prepared")
}

/// The N bytes of `[LengthParam; N]` of the stored model as one word (bit k = link k), if
/// each is a valid `LengthParam` (0 or 1). Reads only those N bytes, never the padding after.
///
/// # Safety
/// `base` points to `KINCAL_PREPARED_WORDS` readable words.
unsafe fn length_param_word<const N: usize>(base: *const u64) -> Option<u64> {
    // SAFETY: `HEADER_WORDS + LENGTH_PARAM_OFFSET / 8 + lp_words::<N>()` words lie within the
    // storage (`payload_fits`), and N bytes from an 8-aligned offset stay within those words.
    let p = unsafe {
        base.add(HEADER_WORDS)
            .cast::<u8>()
            .add(Robot::<N>::LENGTH_PARAM_OFFSET)
    };
    let mut word = 0u64;
    for k in 0..N {
        // SAFETY: see above (k < N).
        let b = unsafe { p.add(k).read() };
        if b > 1 {
            return None;
        }
        // N <= 64 (`payload_fits`): one bit per link.
        word |= u64::from(b) << k;
    }
    Some(word)
}

/// Checksum of header words 0–1 and of the stored `Robot<N>` (its length params given packed
/// as `lp_word`, so the padding bytes after them are never read). Four independent
/// lanes of xor-multiply steps keep the multiply chain short.
///
/// # Safety
/// `base` points to `KINCAL_PREPARED_WORDS` readable words, unmodified during the call.
unsafe fn checksum<const N: usize>(base: *const u64, lp_word: u64) -> u64 {
    let words = size_of::<Robot<N>>() / 8;
    let lp_index = Robot::<N>::LENGTH_PARAM_OFFSET / 8;
    let lp_end = lp_index + lp_words::<N>();
    // SAFETY: lp_end <= words and HEADER_WORDS + words <= KINCAL_PREPARED_WORDS
    // (`payload_fits`), so both runs lie within the storage; every stored-model word outside
    // `lp_index..lp_end` belongs to f64 fields only (layout contract of `Robot`), so it is
    // initialised when `store` wrote it (and any bits are a valid u64).
    let (header, head, tail) = unsafe {
        let payload = base.add(HEADER_WORDS);
        (
            [base.read(), base.add(1).read(), 0, lp_word],
            core::slice::from_raw_parts(payload, lp_index),
            core::slice::from_raw_parts(payload.add(lp_end), words - lp_end),
        )
    };
    let mut lanes = LANE_SEEDS;
    let mut mix = |chunk: &[u64]| {
        for (lane, &w) in lanes.iter_mut().zip(chunk) {
            *lane = (*lane ^ w).wrapping_mul(MUL);
        }
    };
    mix(&header);
    for run in [head, tail] {
        let (chunks, rest) = run.as_chunks::<4>();
        for c in chunks {
            mix(c);
        }
        mix(rest);
    }
    let mut h = words as u64;
    for lane in lanes {
        h = (h ^ lane).wrapping_mul(MUL);
        h ^= h >> 29;
    }
    h
}

/// Writes a prepared handle of `r` into the storage at `out`.
///
/// # Safety
/// `out` is non-NULL, aligned and writable for `KINCAL_PREPARED_WORDS` words; no reference
/// into it is alive.
unsafe fn store<const N: usize>(r: &Robot<N>, out: *mut u64) -> FfiResult {
    // SAFETY: forwarded contract; the model fits after the header with its alignment
    // (`payload_fits`).
    unsafe {
        core::ptr::write_bytes(out, 0, KINCAL_PREPARED_WORDS);
        out.add(HEADER_WORDS).cast::<Robot<N>>().write(*r);
        out.write(MAGIC);
        out.add(1).write(shape::<N>());
    }
    // SAFETY: the storage now holds a valid `Robot<N>`.
    let lp = unsafe { length_param_word::<N>(out.cast_const()) }
        .ok_or(kincal_error::new(kincal_status::Internal))?;
    // SAFETY: as above.
    let sum = unsafe { checksum::<N>(out.cast_const(), lp) };
    // SAFETY: words 2 and 3 are within the storage.
    unsafe {
        out.add(2).write(!sum);
        out.add(3).write(sum);
    }
    Ok(())
}

/// A checked view of a prepared handle's model.
#[derive(Debug, Clone, Copy)]
pub(crate) enum PreparedRobot<'a> {
    J1(&'a Robot<1>),
    J2(&'a Robot<2>),
    J3(&'a Robot<3>),
    J4(&'a Robot<4>),
    J5(&'a Robot<5>),
    J6(&'a Robot<6>),
    J7(&'a Robot<7>),
    J8(&'a Robot<8>),
    J9(&'a Robot<9>),
    J10(&'a Robot<10>),
    J11(&'a Robot<11>),
    J12(&'a Robot<12>),
}

/// Runs `$body` with `$r` bound to the `&Robot<N>` of a [`PreparedRobot`].
macro_rules! with_prepared_robot {
    ($p:expr, $r:ident => $body:expr) => {
        match $p {
            PreparedRobot::J1($r) => $body,
            PreparedRobot::J2($r) => $body,
            PreparedRobot::J3($r) => $body,
            PreparedRobot::J4($r) => $body,
            PreparedRobot::J5($r) => $body,
            PreparedRobot::J6($r) => $body,
            PreparedRobot::J7($r) => $body,
            PreparedRobot::J8($r) => $body,
            PreparedRobot::J9($r) => $body,
            PreparedRobot::J10($r) => $body,
            PreparedRobot::J11($r) => $body,
            PreparedRobot::J12($r) => $body,
        }
    };
}

impl PreparedRobot<'_> {
    fn n_joints(self) -> usize {
        with_prepared_robot!(self, r => r.links().len())
    }
}

/// Whether a handle's model is checked against its checksum ([`Check::Full`], in
/// `kincal_prepared_validate`) or only its header, guard and length params ([`Check::Guard`],
/// on every other call).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Check {
    Guard,
    Full,
}

/// The stored model of a handle of N joints, after the checks of `check`.
///
/// # Safety
/// `base` points to `KINCAL_PREPARED_WORDS` readable words, unmodified for `'a`.
unsafe fn view<'a, const N: usize>(base: *const u64, check: Check) -> FfiResult<&'a Robot<N>> {
    // SAFETY: forwarded contract (words 1 to 3 are within the storage).
    let (w1, w2, w3) = unsafe { (base.add(1).read(), base.add(2).read(), base.add(3).read()) };
    if w1 != shape::<N>() || w2 != !w3 {
        return Err(bad_handle());
    }
    // SAFETY: forwarded contract.
    let lp = unsafe { length_param_word::<N>(base) }.ok_or_else(bad_handle)?;
    // SAFETY: forwarded contract.
    if check == Check::Full && unsafe { checksum::<N>(base, lp) } != w3 {
        return Err(bad_handle());
    }
    // SAFETY: in bounds and aligned (`payload_fits`); every byte of the `Robot<N>` but the
    // length params belongs to an f64 (any bit pattern is valid) and the length params were
    // checked to be valid `LengthParam`s, so the bytes are a valid `Robot<N>`; padding has no
    // validity requirement. Unmodified for `'a` by contract.
    Ok(unsafe { &*base.add(HEADER_WORDS).cast::<Robot<N>>() })
}

/// The model of the handle argument `prepared`, after the checks of `check`.
///
/// # Safety
/// `p` is NULL or points to a readable `kincal_prepared`, unmodified for `'a`.
#[inline]
pub(crate) unsafe fn prepared_robot<'a>(
    p: *const kincal_prepared,
    check: Check,
) -> FfiResult<PreparedRobot<'a>> {
    if p.is_null() {
        return Err(crate::args::null(c"prepared"));
    }
    if !p.is_aligned() {
        return Err(kincal_error::new(kincal_status::MisalignedPointer).arg(c"prepared"));
    }
    let base = p.cast::<u64>();
    // SAFETY: non-NULL, aligned, readable for the whole struct (contract).
    let (magic, w1) = unsafe { (base.read(), base.add(1).read()) };
    if magic != MAGIC {
        return Err(bad_handle());
    }
    // SAFETY (all arms): forwarded contract.
    Ok(match w1 & 0xFFFF_FFFF {
        1 => PreparedRobot::J1(unsafe { view::<1>(base, check) }?),
        2 => PreparedRobot::J2(unsafe { view::<2>(base, check) }?),
        3 => PreparedRobot::J3(unsafe { view::<3>(base, check) }?),
        4 => PreparedRobot::J4(unsafe { view::<4>(base, check) }?),
        5 => PreparedRobot::J5(unsafe { view::<5>(base, check) }?),
        6 => PreparedRobot::J6(unsafe { view::<6>(base, check) }?),
        7 => PreparedRobot::J7(unsafe { view::<7>(base, check) }?),
        8 => PreparedRobot::J8(unsafe { view::<8>(base, check) }?),
        9 => PreparedRobot::J9(unsafe { view::<9>(base, check) }?),
        10 => PreparedRobot::J10(unsafe { view::<10>(base, check) }?),
        11 => PreparedRobot::J11(unsafe { view::<11>(base, check) }?),
        12 => PreparedRobot::J12(unsafe { view::<12>(base, check) }?),
        _ => return Err(bad_handle()),
    })
}

/// The prologue of the joint-space handle exports: handle checked, `q` checked (length N,
/// finite), `aux` copied.
///
/// # Safety
/// `prepared`, `q`, `aux` NULL or valid as the exports document.
unsafe fn prepared_and_q<'a>(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    q_name: &'static core::ffi::CStr,
    aux: *const kincal_joint_aux,
) -> FfiResult<(
    PreparedRobot<'a>,
    [f64; KINCAL_MAX_JOINTS],
    Option<kincal_joint_aux>,
)> {
    // SAFETY: forwarded contract.
    let model = unsafe { prepared_robot(prepared, Check::Guard) }?;
    // SAFETY: forwarded contract.
    let (q, aux) =
        unsafe { crate::kinematics::joint_args(model.n_joints(), q, q_len, q_name, aux) }?;
    Ok((model, q, aux))
}

/// The checked joint state of a call on a prepared model of N joints: `q` (length N,
/// finite) and `aux`, with the same checks in the same order as [`prepared_and_q`] but read
/// straight from the caller's arrays. The FK and joint-Jacobian exports are a controller's
/// inner loop: staging `q` and `aux` in fixed-size copies returned through memory cost FK
/// about 15 of its 120 ns (`tests/cpp/bench_pinocchio.sh`).
///
/// # Safety
/// `q` and `aux` NULL or valid as the exports document.
#[inline(always)]
unsafe fn state_of<const N: usize>(
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
) -> FfiResult<JointState<N>> {
    // SAFETY: forwarded contract.
    let q = unsafe { crate::args::slice(q, q_len, N, c"q") }?;
    crate::args::finite(q, c"q")?;
    let aux = arg_opt!(aux);
    joint_state::<N>(q, aux, CALL_AUX)
}

/// The tool pose of a prepared model at the caller's `q`/`aux` ([`state_of`]), once `out`
/// (checked after the readings, as the other exports order their checks) accepts it.
///
/// # Safety
/// As [`state_of`].
#[inline(always)]
unsafe fn prepared_fk_at<const N: usize>(
    r: &Robot<N>,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    out: impl FnOnce() -> FfiResult<crate::args::Out<f64>>,
) -> FfiResult<(Transform, crate::args::Out<f64>)> {
    // SAFETY: forwarded contract.
    let state = unsafe { state_of::<N>(q, q_len, aux) }?;
    let out = out()?;
    Ok((r.fk(&state)?, out))
}

/// `sizeof(kincal_prepared)` as the library was built (`KINCAL_PREPARED_SIZE`): compare with
/// the header's to detect a header/library mismatch.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_prepared_size() -> usize {
    ffi_boundary!(on_panic = 0; { size_of::<kincal_prepared>() })
}

/// Validates `robot` once and writes the built model into the caller's handle storage
/// `prepared_out` (`KINCAL_PREPARED_SIZE` bytes, aligned to `KINCAL_PREPARED_ALIGN`; need not
/// be initialised). The handle then serves `kincal_prepared_fk`, `kincal_prepared_fk_pq`,
/// `kincal_prepared_joint_angles` and `kincal_prepared_ik`, which give bit-identical results
/// to `kincal_fk`, `kincal_fk_pq`, `kincal_joint_angles` and `kincal_ik` on `robot` without
/// converting the parameter table on every call.
///
/// The handle is a snapshot: later edits of `*robot` do not reach it (prepare again). It keeps
/// no pointer to `robot` and may be copied with `memcpy`. `*prepared_out` is written on success
/// only (a failed call leaves an earlier handle in it intact).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `prepared_out` NULL or writable
/// for `KINCAL_PREPARED_SIZE` bytes; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepare(
    robot: *const kincal_robot,
    prepared_out: *mut kincal_prepared,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let _checked = arg_out1!(prepared_out);
        let any = to_any(r)?;
        let out = prepared_out.cast::<u64>();
        // SAFETY: non-NULL and aligned (`arg_out1!`), writable for the whole struct by
        // contract; `any` is a copy, so no reference into the storage is alive.
        with_any_robot!(&any, m => unsafe { store(m, out) })
    })
}

/// Checks a prepared handle in full: OK when `kincal_prepare` filled it (with this library
/// build) and every stored number is intact (a checksum over the whole model, about as costly
/// as one FK), else BAD_HANDLE; NULL_POINTER or MISALIGNED_POINTER for a bad pointer. The
/// other `kincal_prepared_*` calls check only the handle's header and guard words (a few
/// nanoseconds), which catch storage `kincal_prepare` never filled but not a corrupted number
/// inside a filled one: validate once after preparing or copying a handle, and again
/// whenever its memory may have been damaged (e.g. after a memory self-test); then call the
/// fast exports in the loop. `n_joints_out`: the joint count, or NULL.
///
/// # Safety
/// `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; `n_joints_out`
/// NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_validate(
    prepared: *const kincal_prepared,
    n_joints_out: *mut usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let model = unsafe { prepared_robot(prepared, Check::Full) }?;
        if !n_joints_out.is_null() {
            let out = arg_out1!(n_joints_out);
            // SAFETY: checked by `arg_out1!`; writable by contract.
            unsafe { out.put(model.n_joints()) };
        }
        Ok(())
    })
}

/// `kincal_fk` on a prepared model: the tool pose `T_e^b` (effects compensated) as a 4×4
/// column-major matrix in `t_base_tool_out` (16 doubles), bit-identical to `kincal_fk` on the
/// prepared robot.
///
/// - `prepared`: a handle filled by `kincal_prepare` (read only).
/// - `q`, `q_len`: joint readings [rad], `q_len` = the prepared robot's joint count.
/// - `aux`: approach directions / temperature, or NULL (as `kincal_fk`).
///
/// Joint limits are not checked. Returns OK, BAD_HANDLE, NULL_POINTER, MISALIGNED_POINTER,
/// BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT (an approach direction not −1/0/+1) or
/// MISSING_INPUT.
///
/// # Safety
/// `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; other non-NULL
/// pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_fk(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    t_base_tool_out: *mut f64,
    t_base_tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let model = unsafe { prepared_robot(prepared, Check::Guard) }?;
        let out = || Ok(arg_out!(t_base_tool_out, t_base_tool_len, 16));
        // SAFETY: forwarded contract.
        let (t, out) = with_prepared_robot!(model, r => unsafe { prepared_fk_at(r, q, q_len, aux, out) })?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_matrix(&t)) }
    })
}

/// As `kincal_prepared_fk`, with the pose as position + quaternion `[px, py, pz, qw, qx, qy,
/// qz]` in `pq_out` (7 doubles), bit-identical to `kincal_fk_pq`.
///
/// # Safety
/// As `kincal_prepared_fk`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_fk_pq(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    pq_out: *mut f64,
    pq_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let model = unsafe { prepared_robot(prepared, Check::Guard) }?;
        let out = || Ok(arg_out!(pq_out, pq_len, 7));
        // SAFETY: forwarded contract.
        let (t, out) = with_prepared_robot!(model, r => unsafe { prepared_fk_at(r, q, q_len, aux, out) })?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_pq(&t)) }
    })
}

/// `kincal_joint_angles` on a prepared model: the joint angles after the joint effects
/// (compliance, scale, cyclic, backlash), `q_j + Δθ_j` without θ0, in `angles_out` (N doubles)
/// [rad]. Arguments and statuses as `kincal_prepared_fk`.
///
/// # Safety
/// As `kincal_prepared_fk`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_joint_angles(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    angles_out: *mut f64,
    angles_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (model, q, aux) = unsafe { prepared_and_q(prepared, q, q_len, c"q", aux) }?;
        let out = arg_out!(angles_out, angles_len, model.n_joints());
        let angles = with_prepared_robot!(model, r => angles_of(r, &q, aux.as_ref()))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&angles) }?;
        Ok(())
    })
}

/// `kincal_ik` on a prepared model: readings `q_out` (N doubles, within the joint limits)
/// whose effect-compensated FK reaches `target` (16 doubles, column-major rigid transform),
/// bit-identical to `kincal_ik` on the prepared robot. Arguments as `kincal_ik` with
/// `prepared` in place of `robot`: `q_seed` (N doubles), `aux` or NULL, `opts` or NULL for the
/// defaults, `q_out` (N doubles; may overlap `q_seed`), `info_out` or NULL.
///
/// Returns OK, UNREACHABLE, BAD_HANDLE, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
/// NON_FINITE, INVALID_TRANSFORM, INVALID_ARGUMENT or MISSING_INPUT.
///
/// # Safety
/// `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; other non-NULL
/// pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_ik(
    prepared: *const kincal_prepared,
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
        let (model, seed, aux) =
            unsafe { prepared_and_q(prepared, q_seed, q_seed_len, c"q_seed", aux) }?;
        let n = model.n_joints();
        let target = crate::pose::from_matrix(arg_slice!(target, target_len, 16), c"target")?;
        let opts = match arg_opt!(opts) {
            Some(o) => options(o)?,
            None => IkOptions::default(),
        };
        let out = arg_out!(q_out, q_out_len, n);
        let info = if info_out.is_null() { None } else { Some(arg_out1!(info_out)) };
        let (q, info_v) =
            with_prepared_robot!(model, r => ik_of(r, &target, &seed, aux.as_ref(), &opts))?;
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

/// The joint (geometric) Jacobian of a prepared model at `q`, for a controller's resolved-rate
/// or operational-space loop: a 6 × N column-major matrix in `jac_out` (6N doubles), column
/// `j` = `[v; ω]`, the tool origin's velocity \[m/s\] and the tool's angular velocity
/// \[rad/s\], both in the base frame, per unit rate of reading `j` (rad/s; m/s for a prismatic
/// joint). Joint effects enter through dθ_j/dq_j (scale, cyclic); compliance's dependence on
/// q is neglected (as in the IK). `t_base_tool_out`: the pose at `q` (16 doubles,
/// column-major, bit-identical to `kincal_prepared_fk`), or NULL. Other arguments and
/// statuses as `kincal_prepared_fk`; NON_FINITE_RESULT when a column overflowed.
///
/// # Safety
/// As `kincal_prepared_fk`; `jac_out` must not overlap the other arguments.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_joint_jacobian(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    jac_out: *mut f64,
    jac_len: usize,
    t_base_tool_out: *mut f64,
    t_base_tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let model = unsafe { prepared_robot(prepared, Check::Guard) }?;
        let outs = || {
            let jac = arg_out!(jac_out, jac_len, 6 * model.n_joints());
            Ok((jac, arg_out_opt!(t_base_tool_out, t_base_tool_len, 16)))
        };
        // SAFETY: forwarded contract.
        let (t, t_out) = with_prepared_robot!(model, r => unsafe {
            prepared_joint_jacobian_at(r, q, q_len, aux, outs)
        })?;
        if let Some(o) = t_out {
            // SAFETY: checked by `arg_out_opt!`; writable by contract.
            unsafe { o.write_finite(&crate::pose::to_matrix(&t)) }?;
        }
        Ok(())
    })
}

/// The joint Jacobian of a prepared model at the caller's `q`/`aux` ([`state_of`]), written
/// straight into the caller's `jac_out` once `outs` accepts it (6N doubles, checked after the
/// readings) and checked finite; returns the pose and the optional pose output.
///
/// # Safety
/// As [`state_of`]; the buffer `outs` checks must be writable by the export's contract and not
/// overlap the other arguments.
#[inline(always)]
unsafe fn prepared_joint_jacobian_at<const N: usize>(
    r: &Robot<N>,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    outs: impl FnOnce() -> FfiResult<(crate::args::Out<f64>, Option<crate::args::Out<f64>>)>,
) -> FfiResult<(Transform, Option<crate::args::Out<f64>>)> {
    // SAFETY: forwarded contract.
    let state = unsafe { state_of::<N>(q, q_len, aux) }?;
    let (mut jac, t_out) = outs()?;
    // SAFETY: checked by `arg_out!` (6N doubles); writable by contract, no other reference
    // into it.
    let flat = unsafe { jac.as_mut_slice() };
    let columns: &mut [[f64; 6]; N] = flat
        .as_chunks_mut::<6>()
        .0
        .try_into()
        .map_err(|_| kincal_error::new(kincal_status::Internal))?;
    let t = r.joint_jacobian(&state, columns)?;
    crate::args::finite_result(flat, c"jac_out")?;
    Ok((t, t_out))
}

/// `kincal_jacobian` on a prepared model: the identification Jacobian (6 × P column-major in
/// `jac_out`, P = `kincal_num_geometric_params(N)` or `kincal_num_params(N)` chosen by
/// `jac_len`) and optionally the pose, bit-identical to `kincal_jacobian` on the prepared
/// robot. Arguments and statuses as `kincal_jacobian` with `prepared` in place of `robot`.
///
/// # Safety
/// As `kincal_prepared_fk`; `jac_out` must not overlap the other arguments.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_prepared_jacobian(
    prepared: *const kincal_prepared,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    jac_out: *mut f64,
    jac_len: usize,
    t_base_tool_out: *mut f64,
    t_base_tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (model, q, aux) = unsafe { prepared_and_q(prepared, q, q_len, c"q", aux) }?;
        let n = model.n_joints();
        let cols = if jac_len == 6 * num_geometric_params(n) {
            num_geometric_params(n)
        } else {
            num_params(n)
        };
        let mut jac = arg_out!(jac_out, jac_len, 6 * cols);
        let t_out = arg_out_opt!(t_base_tool_out, t_base_tool_len, 16);
        // SAFETY: checked by `arg_out!`; writable by contract, no other reference into it.
        let flat = unsafe { jac.as_mut_slice() };
        let (columns, _) = flat.as_chunks_mut::<6>();
        let t = with_prepared_robot!(model, r => jacobian_of(r, &q, aux.as_ref(), columns))?;
        crate::args::finite_result(flat, c"jac_out")?;
        if let Some(o) = t_out {
            // SAFETY: checked by `arg_out_opt!`; writable by contract.
            unsafe { o.write_finite(&crate::pose::to_matrix(&t)) }?;
        }
        Ok(())
    })
}
