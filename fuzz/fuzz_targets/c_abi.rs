//! The C ABI entry points with hostile arguments: NULL pointers, lengths too short, too long
//! or zero, NaN/±inf/extreme values, joint counts out of range, unknown enum values, and
//! output buffers that alias the inputs (allowed by the ABI: inputs are copied before any
//! output is written). Every call must return a status (never crash, never report a panic:
//! `KINCAL_STATUS_PANIC` means a panic reached the boundary and fails the target), and a
//! successful call must leave finite numbers in its outputs.
#![no_main]

use core::ptr::{null, null_mut};

use arbitrary::Arbitrary;
use kincal_ffi::aria::kincal_robot_aria;
use kincal_ffi::identify::{
    kincal_identify, kincal_identify_options, kincal_identify_options_default,
    kincal_identify_report, kincal_identify_workspace_size, kincal_measurements,
};
use kincal_ffi::ik::{
    KINCAL_IK_MAX_EXTRA_SEEDS, KINCAL_IK_MAX_ITERATIONS, KINCAL_IK_MAX_TOTAL_ITERATIONS, kincal_ik,
    kincal_ik_info, kincal_ik_options, kincal_ik_options_default,
};
use kincal_ffi::kinematics::kincal_joint_aux;
use kincal_ffi::kinematics::{kincal_fk, kincal_gravity_torques, kincal_jacobian};
use kincal_ffi::params::{kincal_robot_get_params, kincal_robot_set_params};
use kincal_ffi::pose::kincal_pose_error;
use kincal_ffi::prepared::{
    kincal_prepare, kincal_prepared, kincal_prepared_fk, kincal_prepared_ik,
    kincal_prepared_validate,
};
use kincal_ffi::robot::{kincal_robot, kincal_robot_init};
use kincal_ffi::status::{kincal_error, kincal_status};
use kincal_ffi::validation::{kincal_validate, kincal_validation_summary};
use kincal_ffi::view_point::{kincal_moved_to_point, kincal_view_point, kincal_view_point_result};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    aria_model: u32,
    n_joints: u8,
    /// Pool every numeric buffer is cut from (cycled; zeros when empty).
    numbers: Vec<f64>,
    /// Length deviations per buffer (0: exact).
    deltas: [i8; 12],
    /// Bit k: pass NULL for buffer k.
    nulls: u16,
    /// Bit k: let output k alias an input.
    alias: u8,
    n_poses: u8,
    algorithm: u32,
    effects: u32,
    form: u32,
    max_iterations: u8,
    ops: u16,
    /// (byte offset, xor mask) applied to a prepared handle before use: corrupted or
    /// uninitialised handle storage must give a status.
    corrupt: Vec<(u16, u8)>,
    /// Number of poses for the view point (cut from the pool).
    n_view: u8,
    view_axis: u32,
    /// Raw IK options (every field of `kincal_ik_options`): used as given when any is outside
    /// its documented bounds (the call must refuse them: INVALID_ARGUMENT or NON_FINITE, never
    /// OK, never a hang), else with the iteration budget cut to keep executions fast.
    ik_raw: Option<(u32, u32, usize, f64, f64)>,
}

struct Pool<'a> {
    v: &'a [f64],
    at: usize,
}

impl Pool<'_> {
    fn take(&mut self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|_| {
                let x = self
                    .v
                    .get(self.at % self.v.len().max(1))
                    .copied()
                    .unwrap_or(0.0);
                self.at += 1;
                x
            })
            .collect()
    }
}

fn len(exact: usize, delta: i8) -> usize {
    (exact as isize + isize::from(delta)).max(0) as usize
}

fn ptr(v: &[f64], null_it: bool) -> *const f64 {
    if null_it { null() } else { v.as_ptr() }
}

/// Fails the target on a panic at the boundary; returns whether the call succeeded.
fn ok(what: &str, s: kincal_status) -> bool {
    assert!(
        !matches!(s, kincal_status::Panic),
        "{what}: a panic reached the C ABI"
    );
    matches!(s, kincal_status::Ok)
}

fn finite(what: &str, v: &[f64]) {
    assert!(
        v.iter().all(|x| x.is_finite()),
        "{what}: OK with a non-finite output {v:?}"
    );
}

/// Hostile IK options from the raw fields: `(options, within the documented bounds)`. Out of
/// bounds they are passed as they are; within, the iteration budget is cut to at most
/// 16 x 2 so the target stays fast.
fn ik_options(raw: Option<(u32, u32, usize, f64, f64)>, max_iterations: u8) -> (kincal_ik_options, bool) {
    let mut o = kincal_ik_options {
        max_iterations: 200,
        first_solution: 0,
        extra_seeds: 16,
        tol_pos_m: 1e-11,
        tol_rot_rad: 1e-11,
    };
    let Some((iters, first, seeds, tol_p, tol_r)) = raw else {
        o.max_iterations = u32::from(max_iterations % 16);
        o.extra_seeds = 1;
        return (o, o.max_iterations >= 1);
    };
    o = kincal_ik_options {
        max_iterations: iters,
        first_solution: first,
        extra_seeds: seeds,
        tol_pos_m: tol_p,
        tol_rot_rad: tol_r,
    };
    let within = (1..=KINCAL_IK_MAX_ITERATIONS).contains(&iters)
        && first <= 1
        && seeds <= KINCAL_IK_MAX_EXTRA_SEEDS
        && (seeds as u64 + 1) * u64::from(iters) <= KINCAL_IK_MAX_TOTAL_ITERATIONS
        && tol_p > 0.0
        && tol_p <= 1.0
        && tol_r > 0.0
        && tol_r <= core::f64::consts::PI;
    if within {
        o.max_iterations = 1 + iters % 16;
        o.extra_seeds = seeds % 2;
    }
    (o, within)
}

/// An IK status under hostile options: out of bounds they must be refused (argument errors
/// that are checked first, such as a bad length, may come before the options).
fn ik_status(what: &str, s: kincal_status, within_bounds: bool) -> bool {
    let success = ok(what, s);
    if !within_bounds {
        assert!(!success, "{what}: OK with options outside their bounds");
    }
    success
}

fuzz_target!(|inp: Input| {
    let mut pool = Pool {
        v: &inp.numbers,
        at: 0,
    };
    let d = inp.deltas;
    let null_at = |k: u32| inp.nulls & (1 << k) != 0;
    let alias_at = |k: u32| inp.alias & (1 << k) != 0;
    let mut err: kincal_error = unsafe { core::mem::zeroed() };
    let mut robot: kincal_robot = unsafe { core::mem::zeroed() };

    // A robot: built-in, or from arbitrary links and limits (lengths and N hostile).
    let n_req = usize::from(inp.n_joints);
    let built = if inp.ops & 1 != 0 {
        let links = pool.take(5 * n_req);
        let limits = pool.take(2 * n_req);
        ok("robot_init", unsafe {
            kincal_robot_init(
                &mut robot,
                n_req,
                ptr(&links, null_at(0)),
                len(links.len(), d[0]).min(links.len()),
                ptr(&limits, null_at(1)),
                len(limits.len(), d[1]).min(limits.len()),
                &mut err,
            )
        })
    } else {
        false
    };
    if !built
        && !ok("robot_aria", unsafe {
            kincal_robot_aria(&mut robot, inp.aria_model % 4, &mut err)
        })
        && !ok("robot_aria 0", unsafe {
            kincal_robot_aria(&mut robot, 0, &mut err)
        })
    {
        panic!("the built-in robot must build");
    }
    let n = robot.n_joints as usize;
    if inp.ops & 2 != 0 {
        let p = pool.take(12 * n + 13);
        let _ = ok("set_params", unsafe {
            kincal_robot_set_params(
                &mut robot,
                ptr(&p, null_at(2)),
                len(p.len(), d[2]).min(p.len()),
                &mut err,
            )
        });
    }
    let aux = kincal_joint_aux {
        has_approach: u32::from(inp.ops & 4 != 0),
        has_temp: u32::from(inp.ops & 8 != 0),
        approach: core::array::from_fn(|j| [-1.0, 0.0, 1.0][j % 3]),
        temp_c: pool.take(1)[0],
    };
    let aux_ptr = if inp.ops & 16 != 0 {
        &aux as *const _
    } else {
        null()
    };

    // FK, Jacobian, gravity torques; outputs may alias the joint readings.
    let mut buf = pool.take(16.max(6 * (12 * n + 13)));
    let q_len = len(n, d[3]).min(buf.len());
    let q_ptr = if null_at(3) { null() } else { buf.as_ptr() };
    let mut out = vec![0.0; 16];
    let (o_ptr, o_len) = if alias_at(0) {
        (buf.as_mut_ptr(), 16)
    } else {
        (out.as_mut_ptr(), len(16, d[4]).min(16))
    };
    if ok("fk", unsafe {
        kincal_fk(&robot, q_ptr, q_len, aux_ptr, o_ptr, o_len, &mut err)
    }) {
        finite("fk", if alias_at(0) { &buf[..16] } else { &out });
    }
    let mut buf2 = pool.take(6 * (12 * n + 13));
    let jac_len = len(buf2.len(), d[5]).min(buf2.len());
    let (j_ptr, j_len) = if alias_at(1) {
        (buf.as_mut_ptr(), buf.len())
    } else {
        (buf2.as_mut_ptr(), jac_len)
    };
    if ok("jacobian", unsafe {
        kincal_jacobian(
            &robot,
            buf.as_ptr(),
            n,
            aux_ptr,
            j_ptr,
            j_len,
            out.as_mut_ptr(),
            16,
            &mut err,
        )
    }) {
        finite("jacobian t_base_tool_out", &out);
        // SAFETY: the call succeeded, so it wrote j_len doubles at j_ptr.
        finite("jacobian jac_out", unsafe { core::slice::from_raw_parts(j_ptr, j_len) });
    }
    let mut tau = vec![0.0; n];
    if ok("gravity", unsafe {
        kincal_gravity_torques(
            &robot,
            buf.as_ptr(),
            n,
            tau.as_mut_ptr(),
            tau.len(),
            &mut err,
        )
    }) {
        finite("gravity", &tau);
    }

    // Pose error with measured, model and output overlapping.
    let mut poses = pool.take(32);
    let e_ptr = if alias_at(2) {
        poses.as_mut_ptr()
    } else {
        out.as_mut_ptr()
    };
    if ok("pose_error", unsafe {
        kincal_pose_error(
            poses.as_ptr(),
            len(16, d[6]).min(16),
            poses[16..].as_ptr(),
            16,
            inp.form % 3,
            e_ptr,
            6,
            &mut err,
        )
    }) {
        // SAFETY: the call succeeded, so it wrote 6 doubles at e_ptr.
        finite("pose_error", unsafe { core::slice::from_raw_parts(e_ptr, 6) });
    }

    // IK (few iterations) with a hostile target.
    if inp.ops & 32 != 0 {
        let mut defaults: kincal_ik_options = unsafe { core::mem::zeroed() };
        assert!(ok("ik_options", unsafe {
            kincal_ik_options_default(&mut defaults, &mut err)
        }));
        let (opts, within) = ik_options(inp.ik_raw, inp.max_iterations);
        let target = pool.take(16);
        let seed = pool.take(n);
        let mut q_out = vec![0.0; n];
        let mut info: kincal_ik_info = unsafe { core::mem::zeroed() };
        let q_out_ptr = if alias_at(3) {
            seed.as_ptr() as *mut f64
        } else {
            q_out.as_mut_ptr()
        };
        if ik_status("ik", unsafe {
            kincal_ik(
                &robot,
                target.as_ptr(),
                len(16, d[7]).min(16),
                seed.as_ptr(),
                n,
                aux_ptr,
                &opts,
                q_out_ptr,
                n,
                &mut info,
                &mut err,
            )
        }, within) {
            // SAFETY: the call succeeded, so it wrote n doubles at q_out_ptr.
            finite("ik q_out", unsafe { core::slice::from_raw_parts(q_out_ptr, n) });
            finite("ik info", &[info.residual_pos_m, info.residual_rot_rad]);
        }
    }

    // Identification and validation on hostile measurement sets.
    if inp.ops & 64 != 0 {
        let l = usize::from(inp.n_poses % 24);
        let q = pool.take(l * n);
        let poses = pool.take(16 * l);
        let masks: Vec<u8> = (0..l)
            .map(|k| [0x3f, 0x07, 0x00, 0xff][(k + usize::from(inp.alias)) % 4])
            .collect();
        let weights = pool.take(l);
        let data = kincal_measurements {
            n_poses: l,
            q: ptr(&q, null_at(8)),
            q_len: len(q.len(), d[8]).min(q.len()),
            poses: ptr(&poses, null_at(9)),
            poses_len: len(poses.len(), d[9]).min(poses.len()),
            masks: if inp.ops & 128 != 0 {
                masks.as_ptr()
            } else {
                null()
            },
            masks_len: masks.len(),
            aux: null(),
            aux_len: 0,
            weights: if inp.ops & 256 != 0 {
                weights.as_ptr()
            } else {
                null()
            },
            weights_len: len(weights.len(), d[10]).min(weights.len()),
        };
        let mut opts: kincal_identify_options = unsafe { core::mem::zeroed() };
        let _ = ok("identify_options", unsafe {
            kincal_identify_options_default(
                &robot,
                inp.algorithm % 4,
                inp.effects & 0xff,
                &mut opts,
                &mut err,
            )
        });
        opts.max_iterations = u32::from(inp.max_iterations % 8);
        let n_req = opts.requested.iter().filter(|&&b| b != 0).count();
        let ws_bytes = kincal_identify_workspace_size(n, l, n_req);
        if ws_bytes <= 64 << 20 {
            let mut ws = vec![0u64; ws_bytes.div_ceil(8)];
            let ws_len = len(ws_bytes, d[11]).min(ws.len() * 8);
            let mut fitted: kincal_robot = unsafe { core::mem::zeroed() };
            let mut report: kincal_identify_report = unsafe { core::mem::zeroed() };
            if ok("identify", unsafe {
                kincal_identify(
                    &robot,
                    &data,
                    &opts,
                    ws.as_mut_ptr().cast(),
                    ws_len,
                    &mut fitted,
                    &mut report,
                    &mut err,
                )
            }) {
                let mut p = vec![0.0; 12 * n + 13];
                assert!(ok("identify get_params", unsafe {
                    kincal_robot_get_params(&fitted, p.as_mut_ptr(), p.len(), &mut err)
                }));
                finite("identify fitted params", &p);
            }
        }
        let mut errors = vec![0.0; 2 * l];
        let mut summary: kincal_validation_summary = unsafe { core::mem::zeroed() };
        if ok("validate", unsafe {
            kincal_validate(
                &robot,
                &data,
                1e-3,
                0.01,
                if l > 0 {
                    errors.as_mut_ptr()
                } else {
                    null_mut()
                },
                errors.len(),
                &mut summary,
                &mut err,
            )
        }) {
            finite("validate errors_out", &errors);
            let s = &summary;
            finite(
                "validate summary_out",
                &[s.rms_pos_m, s.max_pos_m, s.rms_rot_rad, s.max_rot_rad],
            );
        }
    }

    // The prepared handle: built from the robot, possibly corrupted; then FK and IK through
    // it. A corrupted handle must be refused (a status) or, if the flipped bytes happen to
    // leave it valid, give finite results.
    if inp.ops & 512 != 0 {
        let mut h: kincal_prepared = unsafe { core::mem::zeroed() };
        let _ = ok("prepare", unsafe {
            kincal_prepare(&robot, &mut h, &mut err)
        });
        {
            // SAFETY: plain u64 storage viewed as bytes.
            let bytes: &mut [u8] = unsafe {
                core::slice::from_raw_parts_mut(
                    h.opaque.as_mut_ptr().cast::<u8>(),
                    core::mem::size_of::<kincal_prepared>(),
                )
            };
            for &(at, mask) in inp.corrupt.iter().take(8) {
                let i = usize::from(at) % bytes.len();
                bytes[i] ^= mask;
            }
        }
        let mut nj = 0usize;
        let _ = ok("prepared_validate", unsafe {
            kincal_prepared_validate(&h, &mut nj, &mut err)
        });
        let q = pool.take(n);
        let mut t = [0.0; 16];
        if ok("prepared_fk", unsafe {
            kincal_prepared_fk(
                &h,
                q.as_ptr(),
                len(n, d[3]).min(q.len()),
                aux_ptr,
                t.as_mut_ptr(),
                16,
                &mut err,
            )
        }) {
            finite("prepared_fk", &t);
        }
        if inp.ops & 32 != 0 {
            let (mut opts, within) = ik_options(inp.ik_raw, inp.max_iterations);
            if within {
                opts.extra_seeds = 0;
            }
            let target = pool.take(16);
            let mut q_out = vec![0.0; n];
            let mut info: kincal_ik_info = unsafe { core::mem::zeroed() };
            if ik_status("prepared_ik", unsafe {
                kincal_prepared_ik(
                    &h,
                    target.as_ptr(),
                    16,
                    q.as_ptr(),
                    n,
                    aux_ptr,
                    &opts,
                    q_out.as_mut_ptr(),
                    n,
                    &mut info,
                    &mut err,
                )
            }, within) {
                finite("prepared_ik q_out", &q_out);
                finite("prepared_ik info", &[info.residual_pos_m, info.residual_rot_rad]);
            }
        }
    }

    // The view point of hostile poses, and a pose moved to a hostile point (in place).
    if inp.ops & 1024 != 0 {
        let m = usize::from(inp.n_view % 16);
        let poses = pool.take(16 * m);
        let mut v: kincal_view_point_result = unsafe { core::mem::zeroed() };
        if ok("view_point", unsafe {
            kincal_view_point(
                ptr(&poses, null_at(12)),
                len(poses.len(), d[0]).min(poses.len()),
                m,
                inp.view_axis % 4,
                &mut v,
                &mut err,
            )
        }) {
            finite("view_point", &v.point_m);
        }
        let mut t = pool.take(16);
        let point = pool.take(3);
        let t_ptr = t.as_mut_ptr();
        if ok("moved_to_point", unsafe {
            kincal_moved_to_point(t_ptr, 16, point.as_ptr(), 3, t_ptr, 16, &mut err)
        }) {
            finite("moved_to_point", &t);
        }
    }
});
