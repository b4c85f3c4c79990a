//! The built-in ARIA arm (spec/aria.md): Table 1 nominal model, joint limits, the Table 2
//! calibration-tool poses, the Table 3 virtual "true" robot, and the assumed mass model.

use core::f64::consts::{FRAC_PI_2, PI};

use crate::model::{JointLimits, Link, MassModel, Robot};
use crate::pose::{Transform, pose_from_xyz_rpy};

/// Number of joints of ARIA.
pub const N: usize = 6;

/// Lower limit of joint 3 \[rad\]. **Assumed**: the paper's eq. (2) prints a garbled "2π";
/// −π is our choice, kept in one place so it can be corrected.
pub const Q3_LOWER_ASSUMED_RAD: f64 = -PI;

/// Joint limits, eq. (2) \[rad\], with [`Q3_LOWER_ASSUMED_RAD`].
pub const JOINT_LIMITS: [JointLimits; N] = [
    JointLimits::new(-2.0 * PI, 2.0 * PI),
    JointLimits::new(-0.97, 3.615),
    JointLimits::new(Q3_LOWER_ASSUMED_RAD, 1.69),
    JointLimits::new(-2.0 * PI, 2.0 * PI),
    JointLimits::new(-PI, PI),
    JointLimits::new(-2.0 * PI, 2.0 * PI),
];

/// Table 1: nominal links (θ0 \[rad\], d \[m\], a \[m\], α \[rad\]; β = 0).
pub const NOMINAL_LINKS: [Link; N] = [
    Link::dh(0.0, 0.205, 0.0, FRAC_PI_2),
    Link::dh(0.0, 0.0, 0.41, 0.0),
    Link::dh(FRAC_PI_2, -0.0048, 0.03, FRAC_PI_2),
    Link::dh(0.0, 0.336, 0.0, -FRAC_PI_2),
    Link::dh(0.0, -0.049, 0.0, FRAC_PI_2),
    Link::dh(0.0, 0.202, 0.0, 0.0),
];

/// Table 3: the virtual "true" robot of the simulation study (d_2 is not identified, so it
/// keeps its nominal 0).
pub const TRUE_LINKS: [Link; N] = [
    Link {
        theta0: 1.67e-7,
        d: 0.205,
        a: 1.28e-6,
        alpha: 1.57,
        beta: 0.0,
    },
    Link {
        theta0: 1.17e-6,
        d: 0.0,
        a: 0.41,
        alpha: 0.1,
        beta: -1.41e-7,
    },
    Link {
        theta0: 1.57,
        d: -0.0048,
        a: 0.03,
        alpha: 1.57,
        beta: 0.0,
    },
    Link {
        theta0: -0.8,
        d: 0.34,
        a: -3.25e-7,
        alpha: -1.57,
        beta: 0.0,
    },
    Link {
        theta0: 3.16e-7,
        d: -0.049,
        a: -2.00e-8,
        alpha: 1.57,
        beta: 0.0,
    },
    Link {
        theta0: -3.97e-7,
        d: 0.205,
        a: -7.38e-8,
        alpha: 5.39e-8,
        beta: 0.0,
    },
];

/// Table 4: the real ARIA identified from motion-capture data (OLS).
pub const REAL_LINKS: [Link; N] = [
    Link::dh(0.0068, 0.21, -0.0016, 1.58),
    Link {
        theta0: -0.0024,
        d: 0.0,
        a: 0.41,
        alpha: -0.011,
        beta: 0.0063,
    },
    Link::dh(1.54, -0.0066, 0.036, 1.59),
    Link::dh(-0.015, 0.34, -0.00081, -1.59),
    Link::dh(0.026, -0.049, 0.0018, 1.56),
    Link::dh(0.0093, 0.216, -0.0011, -0.0087),
];

/// **Assumed** mass model: link masses \[kg\] (links 1..6) and tool mass \[kg\].
pub const LINK_MASSES_KG: [f64; N] = [1.6, 2.2, 1.4, 1.2, 0.7, 0.4];
/// **Assumed** tool mass \[kg\], at the end-effector origin.
pub const TOOL_MASS_KG: f64 = 0.3;

/// The assumed mass model with g = (0, 0, −9.81) m/s² in the base frame.
pub const MASS_MODEL: MassModel<N> = MassModel {
    link_masses_kg: LINK_MASSES_KG,
    tool_mass_kg: TOOL_MASS_KG,
    gravity: [0.0, 0.0, -9.81],
};

/// Table 2: the calibration tool's ten reference poses, `[x, y, z]` \[m\] and
/// `[roll, pitch, yaw]` \[deg\] (R = Rz(yaw)·Ry(pitch)·Rx(roll)).
pub const TOOL_POSES: [([f64; 3], [f64; 3]); 10] = [
    ([0.566, 0.354, 0.235], [-150.0, 0.0, 0.0]),
    ([0.518, 0.501, 0.235], [-160.0, 0.0, 0.0]),
    ([0.393, 0.592, 0.235], [-150.0, 0.0, 0.0]),
    ([0.238, 0.592, 0.235], [-160.0, 0.0, 0.0]),
    ([0.113, 0.501, 0.235], [-150.0, 0.0, 0.0]),
    ([0.066, 0.354, 0.235], [-160.0, 0.0, 0.0]),
    ([0.113, 0.207, 0.235], [-150.0, 0.0, 0.0]),
    ([0.238, 0.116, 0.235], [-160.0, 0.0, 0.0]),
    ([0.393, 0.116, 0.235], [-150.0, 0.0, 0.0]),
    ([0.518, 0.207, 0.235], [-160.0, 0.0, 0.0]),
];

/// A configuration near the Table 2 tool poses (the measurement-format example's joint values
/// for pose 1), used as the default inverse-kinematics seed so every tool pose is solved on
/// the same branch.
pub const TOOL_SEED_Q: [f64; N] = [0.4813, 0.7750, -1.0383, 3.6605, 1.1053, -2.8499];

/// Table 2 pose `l` (zero-based) as a transform.
#[must_use]
pub fn tool_pose(l: usize) -> Option<Transform> {
    TOOL_POSES
        .get(l)
        .map(|(xyz, rpy_deg)| pose_from_xyz_rpy(*xyz, rpy_deg.map(|d| d.to_radians())))
}

/// The nominal ARIA (Table 1) with limits and mass model.
#[must_use]
pub fn nominal() -> Robot<N> {
    Robot::new_unchecked(NOMINAL_LINKS, JOINT_LIMITS, MASS_MODEL)
}

/// The Table 3 virtual "true" robot. Its nominal geometry (for gravity torques and the d/β
/// choice) is Table 1's.
#[must_use]
pub fn virtual_truth() -> Robot<N> {
    with_links(TRUE_LINKS)
}

/// The Table 4 robot identified from real data (nominal geometry Table 1).
#[must_use]
pub fn real_identified() -> Robot<N> {
    with_links(REAL_LINKS)
}

/// The nominal ARIA with its links replaced by `links` (d/β choice kept from Table 1).
#[must_use]
pub fn with_links(links: [Link; N]) -> Robot<N> {
    let mut r = nominal();
    for (i, l) in links.iter().enumerate() {
        for (k, v) in [l.theta0, l.d, l.a, l.alpha, l.beta]
            .into_iter()
            .enumerate()
        {
            let _ = r.set_param(crate::error::ParamIndex(5 * i + k), v);
        }
    }
    r
}

/// **Assumed** biopsy working region (the paper gives no numbers): the box above the
/// calibration tool's plate that the Table 2 circle spans, x ∈ [0.066, 0.566] m,
/// y ∈ [0.116, 0.592] m, z ∈ [0.235, 0.335] m, with the tool tilted 150°–160° about x
/// (needle pointing down and outwards) as on the calibration tool.
pub const WORKING_REGION_MIN_M: [f64; 3] = [0.066, 0.116, 0.235];
/// Upper corner of the working region \[m\] (see [`WORKING_REGION_MIN_M`]).
pub const WORKING_REGION_MAX_M: [f64; 3] = [0.566, 0.592, 0.335];

/// The validation grid over the working region: `nx × ny × nz` positions (corners
/// included) times two orientations (roll −150° and −160°, as Table 2), returned in
/// `out` in x-major order; returns how many were written (`out` may be shorter).
pub fn working_region_grid(nx: usize, ny: usize, nz: usize, out: &mut [Transform]) -> usize {
    let lin = |k: usize, n: usize, lo: f64, hi: f64| {
        if n <= 1 {
            0.5 * (lo + hi)
        } else {
            lo + (hi - lo) * k as f64 / (n - 1) as f64
        }
    };
    let mut w = 0;
    for ix in 0..nx {
        for iy in 0..ny {
            for iz in 0..nz {
                for roll_deg in [-150.0f64, -160.0] {
                    let xyz = [
                        lin(ix, nx, WORKING_REGION_MIN_M[0], WORKING_REGION_MAX_M[0]),
                        lin(iy, ny, WORKING_REGION_MIN_M[1], WORKING_REGION_MAX_M[1]),
                        lin(iz, nz, WORKING_REGION_MIN_M[2], WORKING_REGION_MAX_M[2]),
                    ];
                    if let Some(slot) = out.get_mut(w) {
                        *slot = pose_from_xyz_rpy(xyz, [roll_deg.to_radians(), 0.0, 0.0]);
                        w += 1;
                    }
                }
            }
        }
    }
    w
}
