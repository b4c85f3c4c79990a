//! Conversion of joint-axis chains into Hayati/mDH robots: the robot's FK must equal the
//! chain's product-of-exponentials FK, computed here independently (own Rodrigues), to
//! 1e-12 on random configurations, for random chains with parallel, anti-parallel, nearly
//! parallel, intersecting, coincident and perpendicular consecutive axes.

use kincal::axis_chain::{AxisChain, JointAxis};
use kincal::model::{JointLimits, LengthParam, PARALLEL_AXES_TOL_RAD};
use kincal::pose::Transform;
use kincal::{Error, JointIndex, Robot, aria};
use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

/// FK agreement required [m] and [1] (rotation-matrix entries) for an mDH chain whose
/// total length `Σ(|d_i| + |a_i|)` is at most [`FK_TOL_LENGTH_M`].
const FK_TOL: f64 = 1e-12;
/// Beyond this total mDH length the tolerance grows in proportion: evaluating
/// `Rz(q + θ0)·Tz(d)…` rounds the angle (~1e-16 rad), and the lever is the length. Axes just
/// outside the parallel tolerance (1.5°) and 0.5 m apart put their common normal ~20 m
/// away, and consecutive d of ±50 m appear; that is what Hayati's β avoids below 1°.
const FK_TOL_LENGTH_M: f64 = 10.0;
/// Parameter agreement for the ARIA round trip.
const PARAM_TOL: f64 = 1e-12;

/// SplitMix64: a small deterministic generator for the tests.
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
    fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }
    fn point(&mut self) -> Vector3<f64> {
        Vector3::new(
            self.uniform(-0.5, 0.5),
            self.uniform(-0.5, 0.5),
            self.uniform(-0.5, 0.5),
        )
    }
    fn transform(&mut self) -> Transform {
        let axis = self.unit();
        let angle = self.uniform(-3.1, 3.1);
        Transform::from_parts(
            Translation3::from(self.point()),
            Rotation3::from_scaled_axis(axis * angle),
        )
    }
    fn pick(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// A unit vector at `angle` [rad] from `u`.
fn tilted(rng: &mut Rng, u: &Vector3<f64>, angle: f64) -> Vector3<f64> {
    let perp = u.cross(&rng.unit()).normalize();
    Rotation3::from_scaled_axis(perp * angle) * u
}

/// Independent reference: rotation about a line by Rodrigues' formula.
fn rot_about(p: &Vector3<f64>, u: &Vector3<f64>, q: f64) -> Transform {
    let k = Matrix3::new(0.0, -u.z, u.y, u.z, 0.0, -u.x, -u.y, u.x, 0.0);
    let r = Matrix3::identity() + k * q.sin() + k * k * (1.0 - q.cos());
    Transform::from_parts(
        Translation3::from(p - r * p),
        Rotation3::from_matrix_unchecked(r),
    )
}

fn reference_fk<const N: usize>(c: &AxisChain<N>, q: &[f64; N]) -> Transform {
    let mut t = Transform::identity();
    for (ax, &qi) in c.axes.iter().zip(q) {
        t *= rot_about(&ax.point, &ax.direction.normalize(), qi);
    }
    c.t_ref_base.inverse() * t * c.t_ref_tool
}

fn max_diff(a: &Transform, b: &Transform) -> f64 {
    let dp = (a.translation.vector - b.translation.vector).amax();
    let dr = (a.rotation.matrix() - b.rotation.matrix()).amax();
    dp.max(dr)
}

#[derive(Debug, Clone, Copy)]
enum Relation {
    General,
    Parallel,
    AntiParallel,
    NearlyParallel,
    JustNotParallel,
    Intersecting,
    Perpendicular,
    Coincident,
}

const RELATIONS: [Relation; 8] = [
    Relation::General,
    Relation::Parallel,
    Relation::AntiParallel,
    Relation::NearlyParallel,
    Relation::JustNotParallel,
    Relation::Intersecting,
    Relation::Perpendicular,
    Relation::Coincident,
];

/// A random chain whose consecutive axes follow `rel[i]` (axis i+1 relative to axis i).
fn random_chain<const N: usize>(rng: &mut Rng, rel: &[Relation]) -> AxisChain<N> {
    let mut axes = [JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]); N];
    axes[0] = JointAxis {
        point: rng.point(),
        direction: rng.unit() * rng.uniform(0.5, 2.0),
    };
    for i in 1..N {
        let prev = axes[i - 1];
        let u = prev.direction.normalize();
        let along = rng.uniform(-0.3, 0.3);
        let r = rel[(i - 1) % rel.len()];
        let (point, direction) = match r {
            Relation::General => (rng.point(), rng.unit()),
            Relation::Parallel => (rng.point(), u),
            Relation::AntiParallel => (rng.point(), -u),
            Relation::NearlyParallel => (rng.point(), tilted(rng, &u, 0.5 * PARALLEL_AXES_TOL_RAD)),
            Relation::JustNotParallel => {
                (rng.point(), tilted(rng, &u, 1.5 * PARALLEL_AXES_TOL_RAD))
            }
            Relation::Intersecting => (prev.point + u * along, rng.unit()),
            Relation::Perpendicular => {
                let d = u.cross(&rng.unit()).normalize();
                (prev.point + u * along, d)
            }
            Relation::Coincident => (prev.point + u * along, u * rng.uniform(0.5, 2.0)),
        };
        axes[i] = JointAxis { point, direction };
    }
    AxisChain {
        t_ref_base: rng.transform(),
        axes,
        t_ref_tool: rng.transform(),
    }
}

/// Worst FK difference over random configurations, in units of the tolerance.
fn check_chain<const N: usize>(rng: &mut Rng, chain: &AxisChain<N>) -> f64 {
    let robot: Robot<N> = chain
        .to_robot([JointLimits::new(-7.0, 7.0); N])
        .expect("conversion");
    let length: f64 = robot.links().iter().map(|l| l.d.abs() + l.a.abs()).sum();
    let tol = FK_TOL * (length / FK_TOL_LENGTH_M).max(1.0);
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let mut q = [0.0; N];
        for v in q.iter_mut() {
            *v = rng.uniform(-3.2, 3.2);
        }
        let t_robot = robot.fk_q(&q).expect("fk");
        let t_ref = reference_fk(chain, &q);
        let t_core = chain.fk(&q).expect("chain fk");
        worst = worst.max(max_diff(&t_robot, &t_ref) / tol);
        assert!(
            max_diff(&t_core, &t_ref) < FK_TOL,
            "AxisChain::fk disagrees"
        );
    }
    // The d/β choice follows axis parallelism, as Robot::auto_length_params decides it.
    let auto = robot.auto_length_params();
    for (i, pair) in chain.axes.windows(2).enumerate() {
        let ui = pair[0].direction.normalize();
        let uj = pair[1].direction.normalize();
        let angle = ui.dot(&uj).abs().min(1.0).acos();
        let expect = if angle < PARALLEL_AXES_TOL_RAD {
            LengthParam::Beta
        } else {
            LengthParam::D
        };
        assert_eq!(
            robot.length_params()[i],
            expect,
            "link {} d/β choice",
            i + 1
        );
        assert_eq!(auto[i], expect, "auto choice disagrees for link {}", i + 1);
        if expect == LengthParam::Beta {
            assert_eq!(
                robot.links()[i].d,
                0.0,
                "parallel link {} must have d = 0",
                i + 1
            );
        } else {
            assert_eq!(robot.links()[i].beta, 0.0);
        }
    }
    worst
}

#[test]
fn random_chains_reproduce_fk() {
    let mut rng = Rng(0x5EED_0001);
    let mut worst: f64 = 0.0;
    for trial in 0..200 {
        // Mostly one relation everywhere, sometimes random mixes.
        let rel: Vec<Relation> = if trial < 80 {
            vec![RELATIONS[trial % RELATIONS.len()]]
        } else {
            (0..7)
                .map(|_| RELATIONS[rng.pick(RELATIONS.len() as u64) as usize])
                .collect()
        };
        worst = worst.max(match trial % 4 {
            0 => {
                let c = random_chain::<6>(&mut rng, &rel);
                check_chain(&mut rng, &c)
            }
            1 => {
                let c = random_chain::<7>(&mut rng, &rel);
                check_chain(&mut rng, &c)
            }
            2 => {
                let c = random_chain::<3>(&mut rng, &rel);
                check_chain(&mut rng, &c)
            }
            _ => {
                let c = random_chain::<8>(&mut rng, &rel);
                check_chain(&mut rng, &c)
            }
        });
    }
    assert!(worst < 1.0, "worst FK difference {worst:e} x tolerance");
}

#[test]
fn single_joint_and_special_bases() {
    let mut rng = Rng(7);
    // One joint; axis along ±z of the base, through and off the origin.
    for dir in [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ] {
        let chain = AxisChain {
            t_ref_base: Transform::identity(),
            axes: [JointAxis::new([0.1, -0.2, 0.3], dir)],
            t_ref_tool: rng.transform(),
        };
        assert!(check_chain(&mut rng, &chain) < 1.0);
    }
    // Axis 1 along the base z through the base origin gives an identity base.
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes: [
            JointAxis::new([0.0, 0.0, 0.4], [0.0, 0.0, 1.0]),
            JointAxis::new([0.0, 0.0, 0.3], [0.0, 1.0, 0.0]),
        ],
        t_ref_tool: Transform::translation(0.0, 0.0, 0.9),
    };
    let m = chain.to_mdh().expect("mdh");
    assert_eq!(m.base, [0.0; 6]);
    assert!(check_chain(&mut rng, &chain) < 1.0);
}

/// The nominal ARIA, written as axes (z of frame i−1 through its origin) and converted back,
/// gives Table 1 itself: the construction's sign and zero choices match the paper's.
#[test]
fn aria_axes_give_table_1() {
    let robot = aria::nominal();
    let mut frames = kincal::Frames::<6>::default();
    robot
        .fk_frames(&kincal::JointState::new([0.0; 6]), &mut frames)
        .expect("frames");
    let mut axes = [JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]); 6];
    for (i, ax) in axes.iter_mut().enumerate() {
        let f = if i == 0 {
            frames.t_base_0
        } else {
            frames.t_base_link[i - 1]
        };
        *ax = JointAxis {
            point: f.translation.vector,
            direction: f.rotation.matrix().column(2).into_owned(),
        };
    }
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes,
        t_ref_tool: frames.t_base_ee,
    };
    let m = chain.to_mdh().expect("mdh");
    for (i, (got, want)) in m.links.iter().zip(aria::NOMINAL_LINKS.iter()).enumerate() {
        let g = [got.theta0, got.d, got.a, got.alpha, got.beta];
        let w = [want.theta0, want.d, want.a, want.alpha, want.beta];
        for k in 0..5 {
            assert!(
                (g[k] - w[k]).abs() < PARAM_TOL,
                "link {} param {k}: {} vs {}",
                i + 1,
                g[k],
                w[k]
            );
        }
    }
    assert_eq!(&m.length_params, robot.length_params());
    for v in m.base.iter().chain(m.tool.iter()) {
        assert!(v.abs() < PARAM_TOL, "base/tool not identity: {m:?}");
    }
}

#[test]
fn degenerate_inputs_are_named() {
    let mut chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes: [
            JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]),
            JointAxis::new([0.0; 3], [0.0, 0.0, 0.0]),
        ],
        t_ref_tool: Transform::identity(),
    };
    assert_eq!(
        chain.to_mdh().unwrap_err(),
        Error::DegenerateAxis {
            joint: JointIndex(1)
        }
    );
    chain.axes[1] = JointAxis::new([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]);
    assert!(matches!(
        chain.to_mdh().unwrap_err(),
        Error::NonFinite { index: 1, .. }
    ));
}
