//! Marker registration: Horn's method against nalgebra's SVD Kabsch, noise behaviour,
//! reflection guard, degenerate marker sets, and outlier identification.

use kincal::Error;
use kincal::pose::Transform;
use kincal::registration::{
    MarkerBody, MarkerStatus, Markers, RegistrationOptions, design_symmetry, register,
    register_end_effector, weighted_rigid_fit,
};
use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

/// Agreement of two exact minimisers (Horn vs SVD) [1] / [m].
const EXACT_TOL: f64 = 1e-12;

struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    /// Standard normal (Box–Muller).
    fn normal(&mut self) -> f64 {
        let u1 = self.uniform(1e-300, 1.0);
        let u2 = self.uniform(0.0, 1.0);
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
    fn transform(&mut self) -> Transform {
        let axis = Vector3::new(self.normal(), self.normal(), self.normal()).normalize();
        Transform::from_parts(
            Translation3::new(
                self.uniform(-2.0, 2.0),
                self.uniform(-2.0, 2.0),
                self.uniform(0.0, 3.0),
            ),
            Rotation3::from_scaled_axis(axis * self.uniform(-3.1, 3.1)),
        )
    }
}

/// An asymmetric 6-marker probe [m] (no symmetry maps a marker pair onto each other).
const PROBE: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [0.120, 0.0, 0.0],
    [0.0, 0.085, 0.0],
    [-0.060, -0.030, 0.010],
    [0.030, -0.100, 0.020],
    [0.070, 0.050, 0.045],
];

fn apply(t: &Transform, p: &[f64; 3]) -> [f64; 3] {
    let q = t.transform_point(&nalgebra::Point3::new(p[0], p[1], p[2]));
    [q.x, q.y, q.z]
}

fn noisy(rng: &mut Rng, t: &Transform, design: &[[f64; 3]], sigma: f64) -> Vec<[f64; 3]> {
    design
        .iter()
        .map(|p| {
            let q = apply(t, p);
            [
                q[0] + sigma * rng.normal(),
                q[1] + sigma * rng.normal(),
                q[2] + sigma * rng.normal(),
            ]
        })
        .collect()
}

/// Weighted Kabsch with nalgebra's SVD and the det = −1 guard, as the reference.
fn kabsch_svd(design: &[[f64; 3]], measured: &[[f64; 3]], w: &[f64]) -> (Matrix3<f64>, bool) {
    let v = |p: &[f64; 3]| Vector3::new(p[0], p[1], p[2]);
    let ws: f64 = w.iter().sum();
    let ca = design
        .iter()
        .zip(w)
        .map(|(p, w)| v(p) * *w)
        .sum::<Vector3<f64>>()
        / ws;
    let cb = measured
        .iter()
        .zip(w)
        .map(|(p, w)| v(p) * *w)
        .sum::<Vector3<f64>>()
        / ws;
    let mut h = Matrix3::zeros();
    for ((a, b), w) in design.iter().zip(measured).zip(w) {
        h += (v(a) - ca) * (v(b) - cb).transpose() * *w;
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
    let naive = vt.transpose() * u.transpose();
    let reflected = naive.determinant() < 0.0;
    let mut d = Matrix3::identity();
    if reflected {
        d[(2, 2)] = -1.0;
    }
    (vt.transpose() * d * u.transpose(), reflected)
}

#[test]
fn horn_equals_svd_kabsch() {
    let mut rng = Rng(11);
    for trial in 0..300 {
        let t = rng.transform();
        let n = 3 + trial % 6;
        let design: Vec<[f64; 3]> = (0..n)
            .map(|_| {
                [
                    rng.uniform(-0.2, 0.2),
                    rng.uniform(-0.2, 0.2),
                    rng.uniform(-0.2, 0.2),
                ]
            })
            .collect();
        let w: Vec<f64> = (0..n).map(|_| rng.uniform(0.2, 3.0)).collect();
        // Large noise too, so the two methods are compared away from the exact solution.
        let sigma = [1e-4, 1e-2, 0.1][trial % 3];
        let measured = noisy(&mut rng, &t, &design, sigma);
        let fit = weighted_rigid_fit(&design, &measured, &w, 1e-6).expect("fit");
        let (r_svd, _) = kabsch_svd(&design, &measured, &w);
        let diff = (fit.rotation.matrix() - r_svd).amax();
        assert!(
            diff < EXACT_TOL,
            "trial {trial}: Horn vs SVD differ by {diff:e}"
        );
        assert!((fit.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
    }
}

/// A mirror image of the design is best matched by a reflection; the guard must return the
/// best proper rotation instead (the SVD reference confirms the naive answer reflects).
#[test]
fn reflection_guard() {
    let mut rng = Rng(12);
    let mirror = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0);
    let mut reflected_cases = 0;
    for _ in 0..50 {
        let t = rng.transform();
        let measured: Vec<[f64; 3]> = PROBE
            .iter()
            .map(|p| {
                let m = mirror * Vector3::new(p[0], p[1], p[2]);
                apply(&t, &[m.x, m.y, m.z])
            })
            .collect();
        let w = [1.0; 6];
        let fit = weighted_rigid_fit(&PROBE, &measured, &w, 1e-6).expect("fit");
        let (r_svd, reflected) = kabsch_svd(&PROBE, &measured, &w);
        reflected_cases += usize::from(reflected);
        assert!((fit.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
        assert!((fit.rotation.matrix() - r_svd).amax() < 1e-9);
    }
    assert_eq!(
        reflected_cases, 50,
        "the mirror data must make the naive SVD reflect"
    );
}

/// Coplanar markers (a flat probe) still determine the pose exactly; the naive SVD answer
/// may reflect, the guarded one may not.
#[test]
fn coplanar_markers_recover_pose() {
    let mut rng = Rng(13);
    let flat: Vec<[f64; 3]> = PROBE.iter().map(|p| [p[0], p[1], 0.0]).collect();
    for _ in 0..50 {
        let t = rng.transform();
        let measured: Vec<[f64; 3]> = flat.iter().map(|p| apply(&t, p)).collect();
        let fit = weighted_rigid_fit(&flat, &measured, &[1.0; 6], 1e-6).expect("fit");
        assert!((fit.rotation.matrix() - t.rotation.matrix()).amax() < EXACT_TOL);
        assert!((fit.translation.vector - t.translation.vector).amax() < EXACT_TOL);
    }
}

#[test]
fn degenerate_marker_sets_are_errors() {
    let line = [
        [0.0, 0.0, 0.0],
        [0.1, 0.0, 0.0],
        [0.25, 0.0, 0.0],
        [0.4, 0.0, 0.0],
    ];
    let t = Rng(14).transform();
    let measured: Vec<[f64; 3]> = line.iter().map(|p| apply(&t, p)).collect();
    assert_eq!(
        weighted_rigid_fit(&line, &measured, &[1.0; 4], 1e-4).unwrap_err(),
        Error::RankDeficient {
            rank: 1,
            required: 2
        }
    );
    // Nearly collinear: 20 µm off the line with 0.1 mm noise is still degenerate.
    let mut near = line;
    near[2][1] = 20e-6;
    assert!(matches!(
        weighted_rigid_fit(&near, &measured, &[1.0; 4], 1e-4),
        Err(Error::RankDeficient { rank: 1, .. })
    ));
    // All measured at one point: the rotation is undetermined.
    let same = [[1.0, 2.0, 3.0]; 6];
    assert!(matches!(
        weighted_rigid_fit(&PROBE, &same, &[1.0; 6], 1e-4),
        Err(Error::RankDeficient { .. })
    ));
    // Two markers only (the others masked).
    let m: Vec<[f64; 3]> = PROBE.iter().map(|p| apply(&t, p)).collect();
    let vis = [true, true, false, false, false, false];
    let markers = Markers {
        visible: Some(&vis),
        ..Markers::new(&PROBE, &m)
    };
    assert_eq!(
        register(&markers, &RegistrationOptions::new(1e-4)).unwrap_err(),
        Error::TooFewData {
            found: 2,
            needed: 3
        }
    );
}

/// With noise σ per axis and n equally weighted markers, the centroid (where the fit's
/// position error is smallest and uncorrelated with the rotation) is off by σ/√n per axis.
#[test]
fn noise_gives_sigma_over_sqrt_n() {
    let mut rng = Rng(15);
    let sigma = 1e-4;
    let n = PROBE.len() as f64;
    let centroid: Vector3<f64> = PROBE
        .iter()
        .map(|p| Vector3::new(p[0], p[1], p[2]))
        .sum::<Vector3<f64>>()
        / n;
    let trials = 2000;
    let mut sum_sq = 0.0;
    let mut rot_sq = 0.0;
    let mut false_alarms = 0;
    for _ in 0..trials {
        let t = rng.transform();
        let m = noisy(&mut rng, &t, &PROBE, sigma);
        let reg = register(&Markers::new(&PROBE, &m), &RegistrationOptions::new(sigma))
            .expect("register");
        let c_true = t * nalgebra::Point3::from(centroid);
        let c_fit = reg.t_mocap_body * nalgebra::Point3::from(centroid);
        sum_sq += (c_fit - c_true).norm_squared();
        let dr = reg.t_mocap_body.rotation.matrix() * t.rotation.matrix().transpose();
        rot_sq += kincal::pose::rotation_log(&dr).norm_squared();
        false_alarms += usize::from(reg.has_outliers());
    }
    let rms_per_axis = (sum_sq / (3.0 * trials as f64)).sqrt();
    let expected = sigma / n.sqrt();
    assert!(
        (rms_per_axis / expected - 1.0).abs() < 0.05,
        "centroid error {rms_per_axis:e} per axis, expected {expected:e}"
    );
    // Rotation error: σ over the marker spread (~0.07 m) divided by √n, order of magnitude.
    let rot_rms = (rot_sq / trials as f64).sqrt();
    assert!(
        rot_rms < 3.0 * sigma / 0.05 / n.sqrt(),
        "rotation error {rot_rms:e} rad"
    );
    // k = 4 on a χ²(3) distance: a few per thousand markers at most.
    assert!(
        false_alarms < trials / 50,
        "{false_alarms} false alarms in {trials}"
    );
}

#[test]
fn swapped_marker_is_named() {
    let mut rng = Rng(16);
    let sigma = 1e-4;
    for (a, b) in [(1, 4), (0, 5), (2, 3)] {
        let t = rng.transform();
        let mut m = noisy(&mut rng, &t, &PROBE, sigma);
        m.swap(a, b);
        let reg = register(&Markers::new(&PROBE, &m), &RegistrationOptions::new(sigma))
            .expect("register");
        for (j, f) in reg.markers().iter().enumerate() {
            let want = if j == a {
                MarkerStatus::Swapped { with: b }
            } else if j == b {
                MarkerStatus::Swapped { with: a }
            } else {
                MarkerStatus::Inlier
            };
            assert_eq!(f.status, want, "marker {j} (swap {a}<->{b})");
        }
        assert!(reg.consistent);
        assert_eq!(reg.n_used, 4);
        assert!((reg.t_mocap_body.translation.vector - t.translation.vector).amax() < 1e-3);
    }
}

#[test]
fn moved_and_missing_markers_are_named() {
    let mut rng = Rng(17);
    let sigma = 1e-4;
    let t = rng.transform();
    let mut m = noisy(&mut rng, &t, &PROBE, sigma);
    m[2][0] += 0.004; // knocked by 4 mm
    m[4] = [f64::NAN; 3]; // occluded
    let vis = [true, true, true, true, false, true];
    let w = [1.0, 2.0, 1.0, 1.0, 1.0, 0.5];
    let markers = Markers {
        visible: Some(&vis),
        weights: Some(&w),
        ..Markers::new(&PROBE, &m)
    };
    let reg = register(&markers, &RegistrationOptions::new(sigma)).expect("register");
    let st: Vec<MarkerStatus> = reg.markers().iter().map(|f| f.status).collect();
    use MarkerStatus::*;
    assert_eq!(st, vec![Inlier, Inlier, Moved, Inlier, Missing, Inlier]);
    assert!((reg.markers()[2].distance_m - 0.004).abs() < 1e-3);
    // Five markers left after the exclusion pin the pose: nothing competes with it.
    assert_eq!(reg.ambiguity, None);
    // Thresholds follow the weights: k·σ/√w.
    assert!((reg.markers()[1].threshold_m - 4.0 * sigma / 2f64.sqrt()).abs() < 1e-15);
    // The missing marker's predicted position is where it should have been.
    let p4 = apply(&t, &PROBE[4]);
    for (got, want) in reg.markers()[4].predicted_m.iter().zip(p4) {
        assert!((got - want).abs() < 1e-3);
    }
    // Without the outlier search the fit is flagged inconsistent.
    let opts = RegistrationOptions {
        max_outliers: 0,
        ..RegistrationOptions::new(sigma)
    };
    let reg0 = register(&markers, &opts).expect("register");
    assert!(!reg0.consistent);
    assert!(reg0.markers().iter().any(|f| f.status == Suspect));
}

#[test]
fn end_effector_pose_in_base() {
    let mut rng = Rng(18);
    let sigma = 5e-5;
    let base_design = [
        [0.3, 0.0, 0.0],
        [-0.2, 0.25, 0.0],
        [-0.15, -0.3, 0.0],
        [0.1, 0.1, 0.05],
    ];
    let t_mocap_base = rng.transform();
    let t_base_ee = rng.transform();
    let t_mocap_ee = t_mocap_base * t_base_ee;
    let mb = noisy(&mut rng, &t_mocap_base, &base_design, sigma);
    let me = noisy(&mut rng, &t_mocap_ee, &PROBE, sigma);
    let r = register_end_effector(
        &Markers::new(&base_design, &mb),
        &Markers::new(&PROBE, &me),
        &RegistrationOptions::new(sigma),
    )
    .expect("register");
    let e = kincal::pose::pose_error(&r.t_base_ee, &t_base_ee, kincal::OrientationError::Exact);
    let (dp, dr) = (
        Vector3::new(e[0], e[1], e[2]).norm(),
        Vector3::new(e[3], e[4], e[5]).norm(),
    );
    assert!(dp < 1e-3 && dr < 5e-3, "ee error {dp:e} m, {dr:e} rad");
    // Noise-free: exact.
    let mb0: Vec<[f64; 3]> = base_design
        .iter()
        .map(|p| apply(&t_mocap_base, p))
        .collect();
    let me0: Vec<[f64; 3]> = PROBE.iter().map(|p| apply(&t_mocap_ee, p)).collect();
    let r0 = register_end_effector(
        &Markers::new(&base_design, &mb0),
        &Markers::new(&PROBE, &me0),
        &RegistrationOptions::new(sigma),
    )
    .expect("register");
    assert!((r0.t_base_ee.to_homogeneous() - t_base_ee.to_homogeneous()).amax() < EXACT_TOL);
    // Errors name the body.
    let bad = [[0.0; 3]; 4];
    let err = register_end_effector(
        &Markers::new(&base_design, &mb0),
        &Markers::new(&base_design, &bad),
        &RegistrationOptions::new(sigma),
    )
    .unwrap_err();
    assert_eq!(err.0, MarkerBody::Probe);
}

/// A swap in a five-marker probe leaves three markers for the fit, whose prediction of the
/// swapped markers is itself off by several σ: the swap must still be named (the direct
/// test: exchanging the two measurements makes the fit consistent), and the pose recovered.
#[test]
fn swapped_pair_in_a_five_marker_probe_is_named() {
    let probe5 = [PROBE[0], PROBE[1], PROBE[2], PROBE[3], PROBE[4]];
    let mut rng = Rng(99);
    let sigma = 5e-5;
    for case in 0..40 {
        let t = rng.transform();
        let mut m = noisy(&mut rng, &t, &probe5, sigma);
        m.swap(1, 3);
        let reg = register(&Markers::new(&probe5, &m), &RegistrationOptions::new(sigma))
            .expect("register");
        let st: Vec<MarkerStatus> = reg.markers().iter().map(|f| f.status).collect();
        use MarkerStatus::*;
        assert_eq!(
            st,
            vec![
                Inlier,
                Swapped { with: 3 },
                Inlier,
                Swapped { with: 1 },
                Inlier
            ],
            "case {case}"
        );
        let e = kincal::pose::pose_error(&reg.t_mocap_body, &t, kincal::OrientationError::Exact);
        let (dp, dr) = (
            Vector3::new(e[0], e[1], e[2]).norm(),
            Vector3::new(e[3], e[4], e[5]).norm(),
        );
        assert!(dp < 1e-3 && dr < 1e-2, "case {case}: {dp:e} m, {dr:e} rad");
    }
}

/// A rhombus probe [m]: symmetric about the P1–P2 axis (P3 and P4 mirror images).
const RHOMBUS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.060, 0.0, 0.0],
    [0.030, 0.040, 0.0],
    [0.030, -0.040, 0.0],
];

/// The angle between two rotations [rad], by the trace formula (independent of the code's
/// quaternion path).
fn angle_between(a: &Transform, b: &Transform) -> f64 {
    let r = a.rotation.matrix().transpose() * b.rotation.matrix();
    ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos()
}

#[test]
fn a_doubled_marker_on_a_symmetric_probe_is_ambiguous_not_guessed() {
    // P4 reported where P3 is (a ghost / a marker labelled twice): excluding P4 fits the
    // true pose, excluding P3 fits the pose turned 180° about the P1–P2 axis, equally well.
    let mut rng = Rng(29);
    let sigma = 1e-4;
    for _ in 0..20 {
        let t = rng.transform();
        let mut m = noisy(&mut rng, &t, &RHOMBUS, sigma);
        m[3] = m[2];
        let reg = register(
            &Markers::new(&RHOMBUS, &m),
            &RegistrationOptions::new(sigma),
        )
        .expect("register");
        let a = reg
            .ambiguity
            .expect("two equally good subsets must be reported");
        // One fit excludes P3, the other P4.
        let mut pair = [a.excluded, a.alternative_excluded];
        pair.sort_unstable();
        assert_eq!(pair, [1 << 2, 1 << 3]);
        // Check the reported angle against the independent trace formula on the two fits.
        let flipped =
            t * Transform::from_parts(
                Translation3::new(0.060, 0.0, 0.0),
                Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            ) * Transform::from_parts(Translation3::new(-0.060, 0.0, 0.0), Rotation3::identity());
        let _ = flipped;
        assert!(
            (a.rotation_rad - std::f64::consts::PI).abs() < 0.02,
            "{}",
            a.rotation_rad
        );
        let either = angle_between(&reg.t_mocap_body, &t).min(angle_between(
            &reg.t_mocap_body,
            &(t * Transform::from_parts(
                Translation3::new(0.0, 0.0, 0.0),
                Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            )),
        ));
        assert!(either < 0.02, "the chosen pose is one of the two: {either}");
        // P3/P4 move by 80 mm between the two poses.
        assert!(
            (a.marker_shift_m - 0.080).abs() < 1e-3,
            "{}",
            a.marker_shift_m
        );
    }
}

#[test]
fn a_marker_knocked_round_the_axis_of_two_others_is_ambiguous_on_any_probe() {
    // P4 of the rhombus knocked 120° round the P1–P2 axis: its distances to P1 and P2 are
    // kept, so excluding P3 fits a pose turned 120° as well as excluding P4 fits the truth.
    let mut rng = Rng(37);
    let sigma = 1e-4;
    let turn = Transform::from_parts(
        Translation3::identity(),
        Rotation3::from_axis_angle(&Vector3::x_axis(), 2.0 * std::f64::consts::FRAC_PI_3),
    );
    for _ in 0..20 {
        let t = rng.transform();
        let mut m = noisy(&mut rng, &t, &RHOMBUS, sigma);
        m[3] = apply(&(t * turn), &RHOMBUS[3]);
        let reg = register(
            &Markers::new(&RHOMBUS, &m),
            &RegistrationOptions::new(sigma),
        )
        .expect("register");
        let a = reg.ambiguity.expect("ambiguous");
        assert!(
            (a.rotation_rad - 2.0 * std::f64::consts::FRAC_PI_3).abs() < 0.02,
            "{}",
            a.rotation_rad
        );
        let either =
            angle_between(&reg.t_mocap_body, &t).min(angle_between(&reg.t_mocap_body, &(t * turn)));
        assert!(either < 0.02);
    }
}

#[test]
fn a_moved_marker_on_an_asymmetric_probe_is_not_ambiguous() {
    let mut rng = Rng(31);
    let sigma = 1e-4;
    for _ in 0..20 {
        let t = rng.transform();
        let mut m = noisy(&mut rng, &t, &PROBE, sigma);
        m[1][2] += 0.006;
        let reg = register(&Markers::new(&PROBE, &m), &RegistrationOptions::new(sigma))
            .expect("register");
        assert!(reg.consistent);
        assert_eq!(reg.ambiguity, None);
        assert_eq!(reg.markers()[1].status, MarkerStatus::Moved);
    }
}

#[test]
fn design_symmetry_finds_congruent_triangles_with_their_margin() {
    // The rhombus: triangles P1P2P3 and P1P2P4 are mirror images (margin 0).
    let s = design_symmetry(&RHOMBUS).expect("4 markers");
    assert!(s.margin_m < 1e-15, "{}", s.margin_m);
    // Move P4 by 2 mm along y: the margin is the change of its side lengths, by hand:
    // |P1P4| and |P2P4| go from 50 mm to sqrt(30² + 42²) mm.
    let mut d = RHOMBUS;
    d[3][1] = -0.042;
    let s = design_symmetry(&d).expect("4 markers");
    let by_hand = (0.030f64.hypot(0.042) - 0.050).abs();
    // Other triangle pairs may be closer; the margin is at most the hand figure.
    assert!(s.margin_m <= by_hand + 1e-15, "{} vs {by_hand}", s.margin_m);
    // An isosceles triangle is congruent with itself relabelled.
    let iso = [[0.0, 0.0, 0.0], [0.050, 0.0, 0.0], [0.025, 0.070, 0.0]];
    let s = design_symmetry(&iso).expect("3 markers");
    assert!(s.margin_m < 1e-15);
    assert_eq!(s.triangles[0], s.triangles[1]);
    // The asymmetric probe keeps every triangle pair millimetres apart.
    // (Its closest pair of triangles differs by 0.64 mm: above the 0.4 mm threshold of a
    // 0.1 mm system, which is what matters.)
    let s = design_symmetry(&PROBE).expect("6 markers");
    assert!(s.margin_m > 5e-4, "{}", s.margin_m);
    assert!(design_symmetry(&PROBE[..2]).is_none());
}
