//! Pose selection and the workspace-clustering design: the chosen index improves over
//! random poses, constraints hold, results are deterministic, and the fast (Gram) values
//! agree with independent computations.

use kincal::aria;
use kincal::identify::Workspace;
use kincal::observability::{
    ColumnScaling, Index, ObservabilityOptions, PoseBlock, observability, pose_block,
    pose_singular_values,
};
use kincal::rng::SplitMix64;
use kincal::selection::{
    ClusterOptions, Cone, Constraints, Objective, Pool, Region, SelectOptions, SelectScratch,
    cluster_select, fill_pool, sample_joint_space, sample_region, select_poses, select_start,
};
use nalgebra::DMatrix;

const P: usize = 24;
type Ws = Workspace<P>;

struct OwnedPool {
    q: Vec<[f64; 6]>,
    blocks: Vec<PoseBlock<P>>,
    pos: Vec<[f64; 3]>,
}

impl OwnedPool {
    fn new(q: Vec<[f64; 6]>, obs: &ObservabilityOptions) -> Self {
        let robot = aria::nominal();
        let mut blocks = vec![[[0.0; P]; 6]; q.len()];
        let mut pos = vec![[0.0; 3]; q.len()];
        fill_pool(
            &robot,
            &q,
            obs,
            &mut Box::<Ws>::default(),
            &mut blocks,
            &mut pos,
        )
        .unwrap();
        OwnedPool { q, blocks, pos }
    }
    fn pool(&self) -> Pool<'_, 6, P> {
        Pool {
            q: &self.q,
            blocks: &self.blocks,
            pos: &self.pos,
        }
    }
}

fn joint_pool(n: usize, c: &Constraints, seed: u64) -> Vec<[f64; 6]> {
    let robot = aria::nominal();
    let mut out = vec![[0.0; 6]; n];
    let k = sample_joint_space(&robot, c, &mut SplitMix64::new(seed), &mut out, 1000 * n).unwrap();
    assert_eq!(k, n);
    out
}

fn small_opts(objective: Objective, seed: u64) -> SelectOptions {
    let mut o = SelectOptions::new(objective, seed);
    o.starts = 2;
    o.refine_trials = 120;
    o
}

#[test]
fn selection_beats_random_poses_on_the_chosen_index_and_fast_values_agree() {
    let robot = aria::nominal();
    let obs = ObservabilityOptions::new(robot.geometric_param_set());
    let c = Constraints {
        joint_margin_rad: 0.05,
        ..Constraints::none()
    };
    let owned = OwnedPool::new(joint_pool(200, &c, 1), &obs);
    let mut ws = Box::<Ws>::default();
    let mut s = Box::<SelectScratch<P>>::default();
    let m = 10;
    // The best of 200 random 10-pose sets drawn from the same joint ranges.
    let mut rng = SplitMix64::new(99);
    let mut best_random = [f64::NEG_INFINITY; 3];
    let idx = [Index::O, Index::O4, Index::DOpt];
    for _ in 0..200 {
        let qs: Vec<[f64; 6]> = (0..m).map(|_| owned.q[rng.below(owned.q.len())]).collect();
        let ind = observability(&robot, &qs, &obs, &mut ws).unwrap();
        for (b, i) in best_random.iter_mut().zip(idx) {
            *b = b.max(ind.get(i));
        }
    }
    for (k, index) in idx.into_iter().enumerate() {
        let opts = small_opts(Objective::Index(index), 7);
        let mut out = [[0.0; 6]; 10];
        let sel = select_poses(
            &robot,
            &owned.pool(),
            m,
            &obs,
            &c,
            &opts,
            &mut ws,
            &mut s,
            &mut out,
        )
        .unwrap();
        let ind = observability(&robot, &out, &obs, &mut ws).unwrap();
        let v = ind.get(index);
        println!(
            "{}: selected {v:.4e} (initial {:.4e}, exchange {:.4e}, {} exchanges, {} refinements, {} evaluations), best of 200 random sets {:.4e}",
            index.name(),
            sel.initial_value,
            sel.exchange_value,
            sel.exchanges,
            sel.refinements,
            sel.evaluations,
            best_random[k]
        );
        assert!(
            v > best_random[k],
            "{}: {v} vs {}",
            index.name(),
            best_random[k]
        );
        assert!(sel.value >= sel.exchange_value && sel.exchange_value >= sel.initial_value);
        // The Gram/eigenvalue value used in the search equals the Jacobi-SVD value.
        let rel = (sel.value - v).abs() / v.abs();
        assert!(
            rel < 1e-7,
            "{}: fast {} vs accurate {v}",
            index.name(),
            sel.value
        );
        for q in &out {
            assert!(c.within_limits(&robot, q), "{q:?}");
        }
    }
    // The eq. (17) index of the selection is far better than the paper's Table 2 tool poses.
    let mut out = [[0.0; 6]; 10];
    select_poses(
        &robot,
        &owned.pool(),
        m,
        &obs,
        &c,
        &small_opts(Objective::Index(Index::O), 7),
        &mut ws,
        &mut s,
        &mut out,
    )
    .unwrap();
    let tool: Vec<[f64; 6]> = (0..10)
        .map(|l| {
            kincal::ik::solve_ik(
                &robot,
                &aria::tool_pose(l).unwrap(),
                &kincal::JointState::new(aria::TOOL_SEED_Q),
                &kincal::ik::IkOptions::default(),
            )
            .unwrap()
            .q
        })
        .collect();
    let o_tool = observability(&robot, &tool, &obs, &mut ws).unwrap().o;
    let o_sel = observability(&robot, &out, &obs, &mut ws).unwrap().o;
    println!("O: selected {o_sel:.4e}, Table 2 tool {o_tool:.4e}");
    assert!(o_sel > 5.0 * o_tool);
}

#[test]
fn selection_respects_region_cone_margin_and_separation_and_is_deterministic() {
    let robot = aria::nominal();
    let obs = ObservabilityOptions::new(robot.geometric_param_set());
    let region = Region::new(aria::WORKING_REGION_MIN_M, aria::WORKING_REGION_MAX_M).unwrap();
    let cone = Cone::new([0.0, 0.0, -1.0], 40f64.to_radians()).unwrap();
    let c = Constraints {
        region: Some(region),
        cone: Some(cone),
        joint_margin_rad: 0.1,
        min_dexterity: 0.0,
    };
    let mut q = vec![[0.0; 6]; 120];
    let k = sample_region(
        &robot,
        &c,
        &mut SplitMix64::new(3),
        &aria::TOOL_SEED_Q,
        &mut q,
        2000,
    )
    .unwrap();
    assert_eq!(k, 120);
    let owned = OwnedPool::new(q, &obs);
    let mut ws = Box::<Ws>::default();
    let mut s = Box::<SelectScratch<P>>::default();
    let mut opts = small_opts(Objective::Index(Index::O), 11);
    opts.min_separation_m = 0.05;
    let mut a = [[0.0; 6]; 10];
    let mut b = [[0.0; 6]; 10];
    let sa = select_poses(
        &robot,
        &owned.pool(),
        10,
        &obs,
        &c,
        &opts,
        &mut ws,
        &mut s,
        &mut a,
    )
    .unwrap();
    let sb = select_poses(
        &robot,
        &owned.pool(),
        10,
        &obs,
        &c,
        &opts,
        &mut ws,
        &mut s,
        &mut b,
    )
    .unwrap();
    assert_eq!(a, b, "same seed, same poses");
    assert_eq!(sa, sb);
    // Running the starts one by one (as a parallel caller would) gives the same best.
    let mut best = (f64::NEG_INFINITY, [[0.0; 6]; 10]);
    for start in 0..opts.starts {
        let mut o = [[0.0; 6]; 10];
        let sel = select_start(
            &robot,
            &owned.pool(),
            10,
            &obs,
            &c,
            &opts,
            start,
            &mut ws,
            &mut s,
            &mut o,
        )
        .unwrap();
        if sel.value > best.0 {
            best = (sel.value, o);
        }
    }
    assert_eq!(best.1, a);
    for q in &a {
        assert!(c.within_limits(&robot, q));
        let t = robot.fk_q(q).unwrap();
        let p = t.translation.vector;
        assert!(region.contains(&[p.x, p.y, p.z]), "{p:?} outside");
        let z = t.rotation.matrix().column(2);
        let angle = (-z.z).clamp(-1.0, 1.0).acos();
        assert!(angle <= 40f64.to_radians() + 1e-9, "tilt {angle}");
    }
    for i in 0..10 {
        for j in 0..i {
            let pi = robot.fk_q(&a[i]).unwrap().translation.vector;
            let pj = robot.fk_q(&a[j]).unwrap().translation.vector;
            assert!((pi - pj).norm() >= 0.05 - 1e-12);
        }
    }
    // A different seed explores differently.
    opts.seed = 12;
    let mut d = [[0.0; 6]; 10];
    select_poses(
        &robot,
        &owned.pool(),
        10,
        &obs,
        &c,
        &opts,
        &mut ws,
        &mut s,
        &mut d,
    )
    .unwrap();
    assert_ne!(a, d);
}

#[test]
fn prediction_variance_objective_matches_a_direct_computation() {
    let robot = aria::nominal();
    let mut obs = ObservabilityOptions::new(robot.geometric_param_set());
    obs.scaling = ColumnScaling::None;
    let c = Constraints::none();
    let owned = OwnedPool::new(joint_pool(60, &c, 5), &obs);
    let reference = OwnedPool::new(joint_pool(15, &c, 6), &obs);
    let mut ws = Box::<Ws>::default();
    let mut s = Box::<SelectScratch<P>>::default();
    s.set_reference(&reference.blocks, 24);
    let mut opts = small_opts(Objective::PredictionVariance, 1);
    opts.refine_trials = 0;
    let mut out = [[0.0; 6]; 8];
    let sel = select_poses(
        &robot,
        &owned.pool(),
        8,
        &obs,
        &c,
        &opts,
        &mut ws,
        &mut s,
        &mut out,
    )
    .unwrap();
    let mut stack = |qs: &[[f64; 6]]| {
        let mut j = DMatrix::zeros(6 * qs.len(), 24);
        let mut b = [[0.0; P]; 6];
        for (l, q) in qs.iter().enumerate() {
            pose_block(&robot, q, &obs, &mut ws, &mut b).unwrap();
            for r in 0..6 {
                for k in 0..24 {
                    j[(6 * l + r, k)] = b[r][k];
                }
            }
        }
        j
    };
    let j = stack(&out);
    let jr = stack(&reference.q);
    let cov = (j.transpose() * &j).try_inverse().unwrap();
    let want = -(cov * jr.transpose() * &jr).trace();
    assert!(
        (sel.value - want).abs() <= 1e-6 * want.abs(),
        "{} vs {want}",
        sel.value
    );
    assert!(sel.value >= sel.initial_value);
}

#[test]
fn clustering_picks_distinct_cubes_with_equal_per_pose_index() {
    let robot = aria::nominal();
    let obs = ObservabilityOptions::new(robot.geometric_param_set());
    let region = Region::new(aria::WORKING_REGION_MIN_M, aria::WORKING_REGION_MAX_M).unwrap();
    let c = Constraints {
        region: Some(region),
        cone: Some(Cone::new([0.0, 0.0, -1.0], 35f64.to_radians()).unwrap()),
        joint_margin_rad: 0.1,
        min_dexterity: 0.0,
    };
    let mut q = vec![[0.0; 6]; 150];
    let k = sample_region(
        &robot,
        &c,
        &mut SplitMix64::new(8),
        &aria::TOOL_SEED_Q,
        &mut q,
        3000,
    )
    .unwrap();
    q.truncate(k);
    let owned = OwnedPool::new(q, &obs);
    let mut ws = Box::<Ws>::default();
    let per: Vec<[f64; 6]> = owned
        .q
        .iter()
        .map(|q| pose_singular_values(&robot, q, &obs, &mut ws).unwrap())
        .collect();
    let cube = 0.1;
    let opts = ClusterOptions {
        region,
        cube_m: cube,
        tolerance: 0.25,
        objective: Objective::Index(Index::O),
    };
    let counts = region.cube_counts(cube);
    assert_eq!(counts, [5, 5, 1]);
    let mut scratch = vec![(0.0, 0); 25];
    let mut out = [0usize; 10];
    let cs = cluster_select(
        &owned.pool(),
        &per,
        10,
        24,
        true,
        &opts,
        &mut Box::<SelectScratch<P>>::default(),
        &mut scratch,
        &mut out,
    )
    .unwrap();
    println!("{cs:?}");
    let mut cubes: Vec<usize> = out
        .iter()
        .map(|&i| region.cube_of(&owned.pos[i], cube).unwrap())
        .collect();
    cubes.sort_unstable();
    cubes.dedup();
    assert_eq!(cubes.len(), 10, "mutually different cubes");
    // Independent spread: largest relative difference of the singular values to the target.
    let t = per[cs.target];
    let per_ref = &per;
    let spread = out
        .iter()
        .flat_map(|&i| (0..6).map(move |k| (per_ref[i][k] / t[k]).ln().abs()))
        .fold(0.0, f64::max);
    assert!(
        (spread - cs.spread).abs() < 1e-12,
        "{spread} vs {}",
        cs.spread
    );
    assert!(cs.within_tolerance && spread <= 0.25);
    let qs: Vec<[f64; 6]> = out.iter().map(|&i| owned.q[i]).collect();
    let o = observability(&robot, &qs, &obs, &mut ws).unwrap().o;
    assert!((o - cs.value).abs() < 1e-7 * o);
}

#[test]
fn dexterity_is_the_smallest_singular_value_of_the_joint_jacobian() {
    use kincal::selection::dexterity;
    let robot = aria::nominal();
    for q in joint_pool(5, &Constraints::none(), 21) {
        let mut jac = [[0.0; 6]; 42];
        robot
            .jacobian(&kincal::JointState::new(q), &mut jac)
            .unwrap();
        // The θ0 columns are the joint columns.
        let j = nalgebra::Matrix6::from_fn(|r, c| jac[5 * c][r]);
        let want = j.singular_values().min();
        let got = dexterity(&robot, &q).unwrap();
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    }
    // Near the wrist singularity (q5 = 0: axes 4 and 6 parallel, offset only by d_5) it
    // is small.
    let d = dexterity(&robot, &[0.3, 1.0, -1.0, 0.5, 0.0, 0.2]).unwrap();
    assert!(d < 0.01, "{d}");
    let c = Constraints {
        min_dexterity: 0.05,
        ..Constraints::none()
    };
    assert!(!c.admits(&robot, &[0.3, 1.0, -1.0, 0.5, 0.0, 0.2]).unwrap());
}

/// The bounds that let the selection skip candidates (selection/bound.rs) change nothing:
/// every index and scaling gives the same poses, values and evaluation counts, to the bit,
/// as evaluating every candidate exactly; and they skip most candidates (not vacuous).
#[test]
fn skipping_candidates_by_their_bounds_changes_no_selection() {
    let robot = aria::nominal();
    let c = Constraints {
        joint_margin_rad: 0.05,
        ..Constraints::none()
    };
    let mut ws = Box::<Ws>::default();
    for (scaling, seed) in [
        (ColumnScaling::UnitColumns, 3),
        (
            ColumnScaling::Tolerance {
                length_m: 5e-3,
                angle_rad: 5f64.to_radians(),
            },
            4,
        ),
    ] {
        let mut obs = ObservabilityOptions::new(robot.geometric_param_set());
        obs.scaling = scaling;
        let owned = OwnedPool::new(joint_pool(300, &c, seed), &obs);
        for index in Index::ALL {
            for m in [10, 16] {
                let opts = small_opts(Objective::Index(index), seed + 10);
                let mut run = |exact: bool| {
                    let mut s = Box::<SelectScratch<P>>::default();
                    s.set_exact_only(exact);
                    let mut out = [[0.0; 6]; 16];
                    let sel = select_poses(
                        &robot,
                        &owned.pool(),
                        m,
                        &obs,
                        &c,
                        &opts,
                        &mut ws,
                        &mut s,
                        &mut out,
                    )
                    .unwrap();
                    (out, sel, s.skipped())
                };
                let (q_fast, sel_fast, skipped) = run(false);
                let (q_exact, sel_exact, none) = run(true);
                let what = format!("{scaling:?} {} m {m}", index.name());
                assert_eq!(none, 0, "{what}");
                assert_eq!(sel_fast, sel_exact, "{what}");
                assert_eq!(
                    q_fast.map(|q| q.map(f64::to_bits)),
                    q_exact.map(|q| q.map(f64::to_bits)),
                    "{what}"
                );
                println!(
                    "{what}: {skipped} of {} candidates skipped by their bound",
                    sel_fast.evaluations
                );
                // The greedy start (regularised D bound) skips for every index; the exchange
                // for all but A-optimality.
                let share = skipped as f64 / sel_fast.evaluations as f64;
                let want = if index == Index::AOpt { 0.3 } else { 0.6 };
                assert!(
                    share > want,
                    "{what}: only {skipped} of {} skipped",
                    sel_fast.evaluations
                );
            }
        }
    }
}

/// A pool larger than `RANK_CAPACITY` is swept in index order (bounds against the best so
/// far, no ranking): the same selection as evaluating every candidate exactly.
#[test]
fn a_pool_beyond_the_ranking_capacity_gives_the_same_selection() {
    let robot = aria::nominal();
    let c = Constraints {
        joint_margin_rad: 0.05,
        ..Constraints::none()
    };
    let obs = ObservabilityOptions::new(robot.geometric_param_set());
    let k = kincal::selection::RANK_CAPACITY + 100;
    let owned = OwnedPool::new(joint_pool(k, &c, 5), &obs);
    let mut ws = Box::<Ws>::default();
    for index in [Index::O, Index::DOpt] {
        let mut opts = small_opts(Objective::Index(index), 21);
        opts.starts = 1;
        opts.refine_trials = 0;
        let mut run = |exact: bool| {
            let mut s = Box::<SelectScratch<P>>::default();
            s.set_exact_only(exact);
            let mut out = [[0.0; 6]; 10];
            let sel = select_poses(
                &robot,
                &owned.pool(),
                10,
                &obs,
                &c,
                &opts,
                &mut ws,
                &mut s,
                &mut out,
            )
            .unwrap();
            (out.map(|q| q.map(f64::to_bits)), sel, s.skipped())
        };
        let (q_fast, sel_fast, skipped) = run(false);
        let (q_exact, sel_exact, _) = run(true);
        assert_eq!((q_fast, sel_fast), (q_exact, sel_exact), "{index:?}");
        assert!(
            skipped * 2 > sel_fast.evaluations,
            "{index:?}: {skipped} of {}",
            sel_fast.evaluations
        );
    }
}
