//! Helpers shared by the integration tests: a deterministic PRNG, an independent
//! plain-matrix forward kinematics (std `sin`/`cos`, 4×4 arrays, no kincal pose helpers),
//! an independent rotation logarithm for small rotations, and test robots.
//!
//! Every test file uses a different subset, hence the `dead_code` allowance.
#![allow(dead_code)]

use std::f64::consts::PI;

use kincal::{JointLimits, JointState, Link, MassModel, Robot, Transform, aria};

/// SplitMix64 (Steele, Lea, Flood 2014): tiny, deterministic, good enough for test inputs.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// Uniform in [−a, a), never closer to zero than a/10 (so "non-zero" really is).
    pub fn nonzero(&mut self, a: f64) -> f64 {
        let m = self.uniform(0.1 * a, a);
        if self.unit() < 0.5 { -m } else { m }
    }
    /// A random unit vector.
    pub fn unit_vector(&mut self) -> [f64; 3] {
        loop {
            let v = [
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
            ];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if n > 0.1 && n <= 1.0 {
                return [v[0] / n, v[1] / n, v[2] / n];
            }
        }
    }
    /// Joint readings uniform within `limits`, each range clipped to [−π, π] so that
    /// configurations are spread over distinct geometry rather than 2π repeats.
    pub fn q_within<const N: usize>(&mut self, limits: &[JointLimits; N]) -> [f64; N] {
        let mut q = [0.0; N];
        for (v, l) in q.iter_mut().zip(limits.iter()) {
            *v = self.uniform(l.lower.max(-PI), l.upper.min(PI));
        }
        q
    }
    /// Approach directions, each −1, 0 or +1.
    pub fn approach<const N: usize>(&mut self) -> [f64; N] {
        let mut s = [0.0; N];
        for v in &mut s {
            *v = (self.next_u64() % 3) as f64 - 1.0;
        }
        s
    }
}

/// A plain 4×4 homogeneous matrix, row-major.
pub type Mat4 = [[f64; 4]; 4];

pub fn mat_identity() -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    m
}

pub fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

pub fn mat_rot_x(t: f64) -> Mat4 {
    let (s, c) = t.sin_cos();
    [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, c, -s, 0.0],
        [0.0, s, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

pub fn mat_rot_y(t: f64) -> Mat4 {
    let (s, c) = t.sin_cos();
    [
        [c, 0.0, s, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [-s, 0.0, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

pub fn mat_rot_z(t: f64) -> Mat4 {
    let (s, c) = t.sin_cos();
    [
        [c, -s, 0.0, 0.0],
        [s, c, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

pub fn mat_trans(x: f64, y: f64, z: f64) -> Mat4 {
    let mut m = mat_identity();
    m[0][3] = x;
    m[1][3] = y;
    m[2][3] = z;
    m
}

/// Rodrigues' formula written out: `Trans(p)·Rot(r)` for `[px, py, pz, rx, ry, rz]`.
pub fn mat_from_vector6(v: &[f64; 6]) -> Mat4 {
    let (rx, ry, rz) = (v[3], v[4], v[5]);
    let t = (rx * rx + ry * ry + rz * rz).sqrt();
    let mut m = mat_trans(v[0], v[1], v[2]);
    if t == 0.0 {
        return m;
    }
    let (kx, ky, kz) = (rx / t, ry / t, rz / t);
    let (s, c) = t.sin_cos();
    let v1 = 1.0 - c;
    let r = [
        [
            c + kx * kx * v1,
            kx * ky * v1 - kz * s,
            kx * kz * v1 + ky * s,
        ],
        [
            ky * kx * v1 + kz * s,
            c + ky * ky * v1,
            ky * kz * v1 - kx * s,
        ],
        [
            kz * kx * v1 - ky * s,
            kz * ky * v1 + kx * s,
            c + kz * kz * v1,
        ],
    ];
    for i in 0..3 {
        m[i][..3].copy_from_slice(&r[i]);
    }
    m
}

/// Hayati/mDH link: `Rz(q + θ0)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`, lengths times `scale`.
pub fn mat_link(l: &Link, q: f64, scale: f64) -> Mat4 {
    let m = mat_mul(&mat_rot_z(q + l.theta0), &mat_trans(0.0, 0.0, l.d * scale));
    let m = mat_mul(&m, &mat_trans(l.a * scale, 0.0, 0.0));
    let m = mat_mul(&m, &mat_rot_x(l.alpha));
    mat_mul(&m, &mat_rot_y(l.beta))
}

/// Independent FK: `T_0^b · A_1 ··· A_N · T_e^N` at joint angles `angles` (already including
/// every effect's Δθ, without θ0); also returns frames 0..=N (frame 0 = base).
pub fn plain_fk_frames(
    links: &[Link],
    base: &[f64; 6],
    tool: &[f64; 6],
    angles: &[f64],
    scale: f64,
) -> (Mat4, Vec<Mat4>) {
    let mut t = mat_from_vector6(base);
    let mut frames = vec![t];
    for (l, &q) in links.iter().zip(angles) {
        t = mat_mul(&t, &mat_link(l, q, scale));
        frames.push(t);
    }
    (mat_mul(&t, &mat_from_vector6(tool)), frames)
}

/// Independent FK of the end effector.
pub fn plain_fk(links: &[Link], base: &[f64; 6], tool: &[f64; 6], angles: &[f64]) -> Mat4 {
    plain_fk_frames(links, base, tool, angles, 1.0).0
}

/// Largest absolute element difference between a kincal transform and a plain matrix
/// (rotation and translation parts).
pub fn max_abs_diff(t: &Transform, m: &Mat4) -> (f64, f64) {
    let r = t.rotation.matrix();
    let p = t.translation.vector;
    let mut dr: f64 = 0.0;
    let mut dp: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            dr = dr.max((r[(i, j)] - m[i][j]).abs());
        }
        dp = dp.max((p[i] - m[i][3]).abs());
    }
    (dr, dp)
}

/// Rotation matrix of a kincal transform as plain rows.
pub fn rot_rows(t: &Transform) -> [[f64; 3]; 3] {
    let r = t.rotation.matrix();
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = r[(i, j)];
        }
    }
    m
}

/// `a·bᵀ` for 3×3 rows.
pub fn mul_abt(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[j][k]).sum();
        }
    }
    c
}

/// Independent rotation vector of a rotation matrix with angle below ~170° (written out
/// here, not kincal's `rotation_log`): `θ/sinθ · vee(skew part)`, with θ from `atan2`.
pub fn small_rotation_log(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let s = [
        0.5 * (r[2][1] - r[1][2]),
        0.5 * (r[0][2] - r[2][0]),
        0.5 * (r[1][0] - r[0][1]),
    ];
    let sin_t = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    let cos_t = 0.5 * (r[0][0] + r[1][1] + r[2][2] - 1.0);
    assert!(
        cos_t > -0.98,
        "small_rotation_log used on a rotation near π"
    );
    let t = sin_t.atan2(cos_t);
    let f = if sin_t < 1e-300 { 1.0 } else { t / sin_t };
    [s[0] * f, s[1] * f, s[2] * f]
}

/// Position error [m] and rotation angle [rad] between two poses, computed independently
/// of kincal's pose helpers (angle from the skew part of `R_a·R_bᵀ`, accurate for tiny
/// angles, and from its trace to rule out a flip).
pub fn pose_distance(a: &Transform, b: &Transform) -> (f64, f64) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    let r = mul_abt(&rot_rows(a), &rot_rows(b));
    let v = small_rotation_log(&r);
    (dp, (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
}

/// Table 2 pose `l` as a transform built here (RPY zyx from degrees, plain matrices), so
/// the IK and FK tests do not depend on kincal's own conversion.
pub fn table2_pose(l: usize) -> Transform {
    let (xyz, rpy_deg) = aria::TOOL_POSES[l];
    let r = mat_mul(
        &mat_mul(
            &mat_rot_z(rpy_deg[2].to_radians()),
            &mat_rot_y(rpy_deg[1].to_radians()),
        ),
        &mat_rot_x(rpy_deg[0].to_radians()),
    );
    let m = nalgebra::Matrix3::from_fn(|i, j| r[i][j]);
    Transform::from_parts(
        nalgebra::Translation3::new(xyz[0], xyz[1], xyz[2]),
        nalgebra::Rotation3::from_matrix_unchecked(m),
    )
}

/// A made-up 7-joint arm with Panda-like dimensions, written in this crate's
/// `Rz·Tz·Tx·Rx·Ry` convention (not Craig's): alternating ±90° twists, offsets of 8 cm.
pub const ARM7_LINKS: [Link; 7] = [
    Link::dh(0.0, 0.333, 0.0, -PI / 2.0),
    Link::dh(0.0, 0.0, 0.0, PI / 2.0),
    Link::dh(0.0, 0.316, 0.0825, PI / 2.0),
    Link::dh(0.0, 0.0, -0.0825, -PI / 2.0),
    Link::dh(0.0, 0.384, 0.0, PI / 2.0),
    Link::dh(0.0, 0.0, 0.088, PI / 2.0),
    Link::dh(0.0, 0.107, 0.0, 0.0),
];

/// Joint limits of the 7-joint arm [rad].
pub const ARM7_LIMITS: [JointLimits; 7] = [
    JointLimits::new(-2.8973, 2.8973),
    JointLimits::new(-1.7628, 1.7628),
    JointLimits::new(-2.8973, 2.8973),
    JointLimits::new(-3.0718, 3.0718),
    JointLimits::new(-2.8973, 2.8973),
    JointLimits::new(-3.7525, 3.7525),
    JointLimits::new(-2.8973, 2.8973),
];

/// The 7-joint arm with a mass model (so the compliance columns are not trivially zero).
pub fn arm7() -> Robot<7> {
    Robot::new(ARM7_LINKS, ARM7_LIMITS)
        .and_then(|r| {
            r.with_mass(MassModel {
                link_masses_kg: [4.0, 4.0, 3.0, 2.7, 1.3, 1.5, 0.5],
                tool_mass_kg: 0.7,
                gravity: [0.0, 0.0, -9.81],
            })
        })
        .expect("7-joint test arm")
}

/// `robot` with every link parameter perturbed (β non-zero on every link), non-zero base
/// and tool frames with rotation vectors well away from zero, and non-zero parameters of
/// every non-geometric effect. Deterministic in `seed`.
pub fn perturbed<const N: usize>(robot: &Robot<N>, seed: u64) -> Robot<N> {
    use kincal::ParamIndex;
    let mut rng = SplitMix64::new(seed);
    let mut r = *robot;
    for i in 0..N {
        let l = r.links()[i];
        let new = [
            l.theta0 + rng.nonzero(0.05),
            l.d + rng.nonzero(0.005),
            l.a + rng.nonzero(0.005),
            l.alpha + rng.nonzero(0.087),
            rng.nonzero(0.087),
        ];
        for (k, v) in new.into_iter().enumerate() {
            r.set_param(ParamIndex(5 * i + k), v).expect("link param");
        }
    }
    let base = [0.01, -0.02, 0.03, 0.3, -0.2, 0.5];
    let tool = [0.02, 0.01, 0.1, -0.4, 0.6, 0.2];
    for k in 0..6 {
        r.set_param(ParamIndex(5 * N + k), base[k]).expect("base");
        r.set_param(ParamIndex(5 * N + 6 + k), tool[k])
            .expect("tool");
    }
    // Effects: compliance [rad/(N·m)], scale, cyclic [rad], backlash [rad], κ [1/K].
    for i in 5 * N + 12..Robot::<N>::NUM_PARAMS - 1 {
        r.set_param(ParamIndex(i), rng.nonzero(2e-3))
            .expect("effect");
    }
    r.set_param(ParamIndex(Robot::<N>::NUM_PARAMS - 1), 2.3e-5)
        .expect("thermal");
    r
}

/// A joint state with approach directions and a temperature (so every effect is active).
pub fn full_state<const N: usize>(
    rng: &mut SplitMix64,
    limits: &[JointLimits; N],
) -> JointState<N> {
    JointState {
        q: rng.q_within(limits),
        approach: Some(rng.approach()),
        temp_c: Some(rng.uniform(5.0, 45.0)),
    }
}

/// The ARIA calibration-tool data: the Table 2 poses reached by the virtual truth (its IK
/// from the tool's seed), measured exactly (as the MATLAB tests build them).
pub fn aria_tool_data() -> Vec<kincal::identify::Measurement<6>> {
    let truth = aria::virtual_truth();
    (0..10)
        .map(|l| {
            let target = aria::tool_pose(l).expect("pose");
            let s = kincal::ik::solve_ik(
                &truth,
                &target,
                &JointState::new(aria::TOOL_SEED_Q),
                &kincal::ik::IkOptions::default(),
            )
            .expect("reachable");
            kincal::identify::Measurement::new(s.q, truth.fk_q(&s.q).expect("fk"))
        })
        .collect()
}

/// `m` poses of `truth` at random configurations, each component disturbed by up to
/// `noise` (m and rad; 0: exact).
pub fn random_data<const N: usize>(
    truth: &Robot<N>,
    m: usize,
    noise: f64,
    seed: u64,
) -> Vec<kincal::identify::Measurement<N>> {
    let mut rng = SplitMix64::new(seed);
    (0..m)
        .map(|_| {
            let q = rng.q_within(truth.limits());
            let t = truth.fk_q(&q).expect("fk");
            let dp = nalgebra::Vector3::new(
                rng.uniform(-noise, noise),
                rng.uniform(-noise, noise),
                rng.uniform(-noise, noise),
            );
            let dr = nalgebra::Rotation3::new(nalgebra::Vector3::new(
                rng.uniform(-noise, noise),
                rng.uniform(-noise, noise),
                rng.uniform(-noise, noise),
            ));
            let pose = kincal::pose::Transform::from_parts(
                nalgebra::Translation3::from(t.translation.vector + dp),
                dr * t.rotation,
            );
            kincal::identify::Measurement::new(q, pose)
        })
        .collect()
}
