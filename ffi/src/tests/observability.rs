//! Observability and pose selection through the ABI, compared bit for bit with the core.

use core::ffi::c_void;
use core::ptr::{null, null_mut};

use kincal::JointState;
use kincal::aria;
use kincal::identify::Workspace;
use kincal::ik::{IkOptions, solve_ik};
use kincal::observability::{
    Index, ObservabilityOptions, PoseBlock, observability, pose_singular_values,
};
use kincal::selection::{
    Constraints, Objective, Pool, SelectOptions, SelectScratch, fill_pool, sample_joint_space,
    select_poses,
};

use crate::aria::*;
use crate::observability::*;
use crate::robot::*;
use crate::status::*;

fn nominal() -> kincal_robot {
    let mut r = kincal_robot::ZERO;
    assert_eq!(
        unsafe { kincal_robot_aria(&mut r, kincal_aria_model::Nominal as u32, null_mut()) },
        kincal_status::Ok
    );
    r
}

/// The ten Table 2 tool poses solved by IK on the nominal model, row per pose.
pub(super) fn table2_q() -> Vec<[f64; 6]> {
    let r = aria::nominal();
    (0..10)
        .map(|l| {
            solve_ik(
                &r,
                &aria::tool_pose(l).unwrap(),
                &JointState::new(aria::TOOL_SEED_Q),
                &IkOptions::default(),
            )
            .unwrap()
            .q
        })
        .collect()
}

fn ws(bytes: usize) -> Vec<u128> {
    assert!(bytes > 0);
    vec![0u128; bytes.div_ceil(16)]
}

fn boxed<T>() -> Box<T> {
    // SAFETY: all-zero is a valid Workspace / SelectScratch (core documentation).
    unsafe { Box::<T>::new_zeroed().assume_init() }
}

fn c_obs(r: &kincal_robot, q: &[f64]) -> (kincal_status, kincal_observability_indices, Vec<f64>) {
    let p = aria::nominal().geometric_param_set().len();
    let mut w = ws(kincal_observability_workspace_size(p));
    let mut ind = kincal_observability_indices::default();
    let mut sv = vec![0.0; p];
    let s = unsafe {
        kincal_observability(
            r,
            q.as_ptr(),
            q.len() / 6,
            q.len(),
            null(),
            0,
            null(),
            w.as_mut_ptr().cast::<c_void>(),
            w.len() * 16,
            &mut ind,
            sv.as_mut_ptr(),
            sv.len(),
            null_mut(),
        )
    };
    (s, ind, sv)
}

/// The value tests/cpp/consumer.cpp checks too: O (eq. 17) of the ten Table 2 poses.
pub(super) const TABLE2_O: f64 = 1.453933636665828e-2;

#[test]
fn observability_matches_core_bitwise() {
    let r = nominal();
    let qs = table2_q();
    let flat: Vec<f64> = qs.iter().flatten().copied().collect();
    let (s, ind, sv) = c_obs(&r, &flat);
    assert_eq!(s, kincal_status::Ok);
    let core = aria::nominal();
    let opts = ObservabilityOptions::new(core.geometric_param_set());
    let mut w = boxed::<Workspace<32>>();
    let want = observability(&core, &qs, &opts, &mut w).unwrap();
    assert_eq!(ind, indices_of(&want));
    assert_eq!(sv.as_slice(), w.singular_values());
    assert_eq!(ind.poses, 10);
    assert!((ind.o - TABLE2_O).abs() < 1e-9 * TABLE2_O, "{}", ind.o);

    // Per-pose singular values.
    let mut sv6 = [0.0; 6];
    let mut wb = ws(kincal_observability_workspace_size(ind.params));
    let sc = kincal_scaling {
        kind: kincal_scaling_kind::Tolerance as u32,
        length_m: 1e-3,
        angle_rad: 1e-3,
    };
    let s = unsafe {
        kincal_pose_singular_values(
            &r,
            flat.as_ptr(),
            6,
            null(),
            0,
            &sc,
            wb.as_mut_ptr().cast(),
            wb.len() * 16,
            sv6.as_mut_ptr(),
            6,
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);
    let mut o2 = opts;
    o2.scaling = kincal::observability::ColumnScaling::Tolerance {
        length_m: 1e-3,
        angle_rad: 1e-3,
    };
    assert_eq!(
        sv6,
        pose_singular_values(&core, &qs[0], &o2, &mut w).unwrap()
    );
}

#[test]
fn observability_argument_errors() {
    let r = nominal();
    let flat: Vec<f64> = table2_q().iter().flatten().copied().collect();
    let p = aria::nominal().geometric_param_set().len();
    let mut w = ws(kincal_observability_workspace_size(p));
    let mut ind = kincal_observability_indices::default();
    let call = |q: &[f64],
                n: usize,
                w: *mut c_void,
                wl: usize,
                ind: *mut kincal_observability_indices,
                e: &mut kincal_error| unsafe {
        kincal_observability(
            &r,
            q.as_ptr(),
            n,
            q.len(),
            null(),
            0,
            null(),
            w,
            wl,
            ind,
            null_mut(),
            0,
            e,
        )
    };
    let wp = w.as_mut_ptr().cast::<c_void>();
    let wl = w.len() * 16;
    let mut e = kincal_error::new(kincal_status::Ok);
    assert_eq!(
        call(&flat, 10, null_mut(), wl, &mut ind, &mut e),
        kincal_status::NullPointer
    );
    assert_eq!(
        call(&flat, 10, wp, wl, null_mut(), &mut e),
        kincal_status::NullPointer
    );
    assert_eq!(
        call(&flat, 10, wp, 64, &mut ind, &mut e),
        kincal_status::BadLength
    );
    assert_eq!(e.expected, kincal_observability_workspace_size(p));
    assert_eq!(
        call(
            &flat,
            10,
            wp.wrapping_byte_add(8),
            wl - 16,
            &mut ind,
            &mut e
        ),
        kincal_status::MisalignedPointer
    );
    assert_eq!(
        call(&flat, 9, wp, wl, &mut ind, &mut e),
        kincal_status::BadLength
    );
    assert_eq!(
        call(&flat, 0, wp, wl, &mut ind, &mut e),
        kincal_status::TooFewData
    );
    let mut bad = flat.clone();
    bad[7] = f64::NAN;
    assert_eq!(
        call(&bad, 10, wp, wl, &mut ind, &mut e),
        kincal_status::NonFinite
    );
    assert_eq!(e.index, 7);
    // Short singular-value buffer, bad scaling, empty mask.
    let mut sv = [0.0; 3];
    let s = unsafe {
        kincal_observability(
            &r,
            flat.as_ptr(),
            10,
            flat.len(),
            null(),
            0,
            null(),
            wp,
            wl,
            &mut ind,
            sv.as_mut_ptr(),
            3,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::BadLength);
    let sc = kincal_scaling {
        kind: 2,
        length_m: f64::NAN,
        angle_rad: 1.0,
    };
    let s = unsafe {
        kincal_observability(
            &r,
            flat.as_ptr(),
            10,
            flat.len(),
            null(),
            0,
            &sc,
            wp,
            wl,
            &mut ind,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::NonFinite);
    let sc = kincal_scaling {
        kind: 9,
        length_m: 1.0,
        angle_rad: 1.0,
    };
    let s = unsafe {
        kincal_observability(
            &r,
            flat.as_ptr(),
            10,
            flat.len(),
            null(),
            0,
            &sc,
            wp,
            wl,
            &mut ind,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::InvalidArgument);
    let mask = vec![0u8; kincal_num_params(6)];
    let s = unsafe {
        kincal_observability(
            &r,
            flat.as_ptr(),
            10,
            flat.len(),
            mask.as_ptr(),
            mask.len(),
            null(),
            wp,
            wl,
            &mut ind,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::TooFewData);
    let s = unsafe {
        kincal_observability(
            &r,
            flat.as_ptr(),
            10,
            flat.len(),
            mask.as_ptr(),
            3,
            null(),
            wp,
            wl,
            &mut ind,
            null_mut(),
            0,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::BadLength);
}

fn pool(k: usize) -> Vec<[f64; 6]> {
    let r = aria::nominal();
    let mut q = vec![[0.0; 6]; k];
    let mut rng = kincal::rng::SplitMix64::new(5);
    let n = sample_joint_space(&r, &Constraints::none(), &mut rng, &mut q, 100 * k).unwrap();
    q.truncate(n);
    q
}

#[test]
fn select_poses_matches_core_bitwise() {
    let r = nominal();
    let pq = pool(60);
    let flat: Vec<f64> = pq.iter().flatten().copied().collect();
    let core = aria::nominal();
    let obs = ObservabilityOptions::new(core.geometric_param_set());
    let p = obs.params.len();
    let m = 10;
    let mut w = ws(kincal_select_workspace_size(p, pq.len()));
    let mut q_out = vec![0.0; m * 6];
    let mut sel = kincal_selection::default();
    let region = kincal_region {
        min_m: [-2.0; 3],
        max_m: [2.0; 3],
    };
    let s = unsafe {
        kincal_select_poses(
            &r,
            flat.as_ptr(),
            pq.len(),
            flat.len(),
            m,
            null(),
            0,
            null(),
            kincal_obs_index::O as u32,
            7,
            &region,
            0.01,
            w.as_mut_ptr().cast(),
            w.len() * 16,
            q_out.as_mut_ptr(),
            q_out.len(),
            &mut sel,
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);

    let mut cw = boxed::<Workspace<32>>();
    let mut sc = boxed::<SelectScratch<32>>();
    let mut blocks = vec![[[0.0; 32]; 6]; pq.len()];
    let mut pos = vec![[0.0; 3]; pq.len()];
    fill_pool(&core, &pq, &obs, &mut cw, &mut blocks, &mut pos).unwrap();
    let _: &[PoseBlock<32>] = &blocks;
    let pool = Pool {
        q: &pq,
        blocks: &blocks,
        pos: &pos,
    };
    let c = Constraints {
        region: Some(kincal::selection::Region::new([-2.0; 3], [2.0; 3]).unwrap()),
        joint_margin_rad: 0.01,
        ..Constraints::none()
    };
    let opts = SelectOptions::new(Objective::Index(Index::O), 7);
    let mut out = vec![[0.0; 6]; m];
    let want = select_poses(&core, &pool, m, &obs, &c, &opts, &mut cw, &mut sc, &mut out).unwrap();
    let want_flat: Vec<f64> = out.iter().flatten().copied().collect();
    assert_eq!(q_out, want_flat);
    assert_eq!(sel.value, want.value);
    assert_eq!(sel.evaluations, want.evaluations);
    let ind = observability(&core, &out, &obs, &mut cw).unwrap();
    assert_eq!(sel.indices, indices_of(&ind));
    // A selected set is better than the Table 2 tool's.
    let t2 = observability(&core, &table2_q(), &obs, &mut cw).unwrap();
    assert!(sel.indices.o >= t2.o, "{} < {}", sel.indices.o, t2.o);
}

#[test]
fn select_poses_argument_errors() {
    let r = nominal();
    let pq = pool(20);
    let flat: Vec<f64> = pq.iter().flatten().copied().collect();
    let p = aria::nominal().geometric_param_set().len();
    let k = pq.len();
    let mut w = ws(kincal_select_workspace_size(p, k));
    let wl = w.len() * 16;
    let wp = w.as_mut_ptr().cast::<c_void>();
    let mut q_out = vec![0.0; 64 * 6];
    let mut e = kincal_error::new(kincal_status::Ok);
    let call = |pool: &[f64],
                m: usize,
                obj: u32,
                margin: f64,
                wp: *mut c_void,
                wl: usize,
                qo: *mut f64,
                qn: usize,
                e: &mut kincal_error| unsafe {
        kincal_select_poses(
            &r,
            pool.as_ptr(),
            pool.len() / 6,
            pool.len(),
            m,
            null(),
            0,
            null(),
            obj,
            1,
            null(),
            margin,
            wp,
            wl,
            qo,
            qn,
            null_mut(),
            e,
        )
    };
    let qo = q_out.as_mut_ptr();
    assert_eq!(
        call(&flat, k + 1, 0, 0.0, wp, wl, qo, (k + 1) * 6, &mut e),
        kincal_status::TooFewData
    );
    assert_eq!(
        call(&flat, 0, 0, 0.0, wp, wl, qo, 0, &mut e),
        kincal_status::TooFewData
    );
    assert_eq!(
        call(&flat, 5, 0, 0.0, wp, wl, qo, 29, &mut e),
        kincal_status::BadLength
    );
    assert_eq!(
        call(&flat, 5, 0, 0.0, wp, wl, null_mut(), 30, &mut e),
        kincal_status::NullPointer
    );
    assert_eq!(
        call(&flat, 5, 0, 0.0, null_mut(), wl, qo, 30, &mut e),
        kincal_status::NullPointer
    );
    assert_eq!(
        call(&flat, 5, 0, 0.0, wp, wl - 16, qo, 30, &mut e),
        kincal_status::BadLength
    );
    assert_eq!(
        call(&flat, 5, 8, 0.0, wp, wl, qo, 30, &mut e),
        kincal_status::InvalidArgument
    );
    assert_eq!(
        call(&flat, 5, 0, f64::NAN, wp, wl, qo, 30, &mut e),
        kincal_status::NonFinite
    );
    assert_eq!(
        call(&flat, 5, 0, -1.0, wp, wl, qo, 30, &mut e),
        kincal_status::InvalidArgument
    );
    let mut bad = flat.clone();
    bad[3] = f64::INFINITY;
    assert_eq!(
        call(&bad, 5, 0, 0.0, wp, wl, qo, 30, &mut e),
        kincal_status::NonFinite
    );
    let mut big: Vec<f64> = Vec::new();
    for _ in 0..4 {
        big.extend_from_slice(&flat);
    }
    let mut w2 = ws(kincal_select_workspace_size(p, big.len() / 6));
    assert_eq!(
        call(
            &big,
            62,
            0,
            0.0,
            w2.as_mut_ptr().cast(),
            w2.len() * 16,
            qo,
            62 * 6,
            &mut e
        ),
        kincal_status::CapacityExceeded
    );
    assert_eq!(kincal_select_workspace_size(0, 5), 0);
    assert_eq!(kincal_select_workspace_size(KINCAL_MAX_PARAMS + 1, 5), 0);
    assert_eq!(kincal_select_workspace_size(p, usize::MAX), 0);
}

fn c_cluster(
    r: &kincal_robot,
    pq: &[[f64; 6]],
    m: usize,
    region: &kincal_region,
    cube_m: f64,
    tolerance: f64,
) -> (kincal_status, Vec<usize>, kincal_cluster_selection) {
    let flat: Vec<f64> = pq.iter().flatten().copied().collect();
    let p = aria::nominal().geometric_param_set().len();
    let bytes = unsafe { kincal_cluster_workspace_size(p, pq.len(), region, cube_m) };
    let mut w = ws(bytes);
    let mut chosen = vec![usize::MAX; m];
    let mut sel = kincal_cluster_selection::default();
    let s = unsafe {
        kincal_cluster_select(
            r,
            flat.as_ptr(),
            pq.len(),
            flat.len(),
            m,
            null(),
            0,
            null(),
            kincal_obs_index::O as u32,
            region,
            cube_m,
            tolerance,
            w.as_mut_ptr().cast(),
            w.len() * 16,
            chosen.as_mut_ptr(),
            chosen.len(),
            &mut sel,
            null_mut(),
        )
    };
    (s, chosen, sel)
}

#[test]
fn cluster_select_matches_core_and_keeps_its_promises() {
    let r = nominal();
    let pq = pool(120);
    let core = aria::nominal();
    let obs = ObservabilityOptions::new(core.geometric_param_set());
    let (g_min, g_max) = ([-1.5, -1.5, -1.0], [1.5, 1.5, 1.5]);
    let region = kincal_region {
        min_m: g_min,
        max_m: g_max,
    };
    let (cube_m, m, tol) = (0.5, 8, 0.5);
    let (s, chosen, sel) = c_cluster(&r, &pq, m, &region, cube_m, tol);
    assert_eq!(s, kincal_status::Ok);

    // The core, called directly on the same pool.
    let mut cw = boxed::<Workspace<32>>();
    let mut sc = boxed::<SelectScratch<32>>();
    let mut blocks = vec![[[0.0; 32]; 6]; pq.len()];
    let mut pos = vec![[0.0; 3]; pq.len()];
    fill_pool(&core, &pq, &obs, &mut cw, &mut blocks, &mut pos).unwrap();
    let per: Vec<[f64; 6]> = pq
        .iter()
        .map(|q| pose_singular_values(&core, q, &obs, &mut cw).unwrap())
        .collect();
    let g = kincal::selection::Region::new(g_min, g_max).unwrap();
    let c = g.cube_counts(cube_m);
    let mut cubes = vec![(0.0, 0usize); c[0] * c[1] * c[2]];
    let mut out = vec![0usize; m];
    let opts = kincal::selection::ClusterOptions {
        region: g,
        cube_m,
        tolerance: tol,
        objective: Objective::Index(Index::O),
    };
    let pool = Pool {
        q: &pq,
        blocks: &blocks,
        pos: &pos,
    };
    let want = kincal::selection::cluster_select(
        &pool,
        &per,
        m,
        obs.params.len(),
        true,
        &opts,
        &mut sc,
        &mut cubes,
        &mut out,
    )
    .unwrap();
    assert_eq!(chosen, out);
    assert_eq!(
        (sel.spread, sel.value, sel.target, sel.occupied_cubes),
        (want.spread, want.value, want.target, want.occupied_cubes)
    );
    assert_eq!(sel.within_tolerance != 0, want.within_tolerance);

    // Its promises, checked from the outputs: distinct cubes, and the spread recomputed
    // from the per-pose singular values of the chosen poses against the target's.
    let mut seen: Vec<usize> = chosen
        .iter()
        .map(|&i| g.cube_of(&pos[i], cube_m).unwrap())
        .collect();
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), m, "one pose per cube");
    let spread = chosen
        .iter()
        .flat_map(|&i| (0..6).map(move |k| (i, k)))
        .map(|(i, k)| (per[i][k].ln() - per[sel.target][k].ln()).abs())
        .fold(0.0f64, f64::max);
    assert!(
        (spread - sel.spread).abs() < 1e-12,
        "{spread} vs {}",
        sel.spread
    );
    assert_eq!(sel.within_tolerance != 0, sel.spread <= tol);
}

#[test]
fn cluster_select_argument_errors() {
    let r = nominal();
    let pq = pool(30);
    let region = kincal_region {
        min_m: [-1.5, -1.5, -1.0],
        max_m: [1.5, 1.5, 1.5],
    };
    // More poses than occupied cubes.
    let (s, chosen, _) = c_cluster(&r, &pq, 20, &region, 1.5, 0.1);
    assert_eq!((s, chosen[0]), (kincal_status::TooFewData, usize::MAX));
    let (s, _, _) = c_cluster(&r, &pq, 3, &region, 0.5, -1.0);
    assert_eq!(s, kincal_status::InvalidArgument);
    assert_eq!(
        unsafe { kincal_cluster_workspace_size(30, 10, &region, 0.0) },
        0,
        "a cube side of 0"
    );
    assert_eq!(
        unsafe { kincal_cluster_workspace_size(30, 10, null(), 0.5) },
        0
    );
}
