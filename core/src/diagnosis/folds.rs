//! Groups of repeated measurements and the cross-validation folds built from them.

use super::PoseDiagnosis;
use crate::error::{Error, Result};
use crate::rng::SplitMix64;

/// End of a group's member list ([`PoseDiagnosis::next`]).
pub(crate) const NO_NEXT: u32 = u32::MAX;

/// Writes each measurement's group leader (index of the first measurement with the same
/// group id), the next measurement of its group ([`NO_NEXT`] after the last) and its fold
/// into `poses`; returns the number of groups.
///
/// Folds: every group is given a key from a hash of its id and `seed`; groups ranked by
/// key are dealt to the folds in turn, so the folds hold equally many groups (±1), the
/// repeats of a pose always share a fold, and the assignment depends only on the set of
/// group ids and the seed, not on the order of the rows. O(n log n) time, no memory: two
/// in-place heapsorts of row indices kept in the records' `sub_leader` fields (which the
/// noise floor overwrites afterwards).
pub(crate) fn assign(
    groups: &[u32],
    folds: usize,
    seed: u64,
    poses: &mut [PoseDiagnosis],
) -> Result<usize> {
    let n = groups.len().min(poses.len());
    let group = |l: u32| groups.get(l as usize).copied().unwrap_or(u32::MAX);
    // Rows ordered by (group id, row): each run of one id is a group, its first row the
    // leader, and the run in order is the member list.
    for (l, p) in poses.iter_mut().enumerate().take(n) {
        p.sub_leader = l as u32;
    }
    sort_rows(&mut poses[..n], |l| (group(l), l));
    let mut n_groups = 0;
    let mut run_start = 0;
    while run_start < n {
        let id = group(poses[run_start].sub_leader);
        let run = (run_start..n)
            .take_while(|&i| group(poses[i].sub_leader) == id)
            .count()
            .max(1);
        let leader = poses[run_start].sub_leader;
        for i in run_start..run_start + run {
            let row = poses[i].sub_leader as usize;
            let next = if i + 1 < run_start + run {
                poses[i + 1].sub_leader
            } else {
                NO_NEXT
            };
            if let Some(p) = poses.get_mut(row) {
                p.group = id;
                p.leader = leader;
                p.next = next;
            }
        }
        // The leaders' rows, compacted to the front (slot n_groups ≤ run_start: read).
        poses[n_groups].sub_leader = leader;
        n_groups += 1;
        run_start += run;
    }
    if n_groups < folds {
        return Err(Error::TooFewData {
            found: n_groups,
            needed: folds,
        });
    }
    // Leaders ranked by (key, id), dealt to the folds in turn.
    let key = |l: u32| {
        let g = group(l);
        let mut r = SplitMix64::new(seed ^ u64::from(g).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        (r.next_u64(), g)
    };
    sort_rows(&mut poses[..n_groups], key);
    for rank in 0..n_groups {
        let row = poses[rank].sub_leader as usize;
        if let Some(p) = poses.get_mut(row) {
            p.fold = (rank % folds.max(1)) as u16;
        }
    }
    for l in 0..n {
        let leader = poses[l].leader as usize;
        poses[l].fold = poses.get(leader).map_or(0, |p| p.fold);
    }
    Ok(n_groups)
}

/// Sorts the row indices held in `rows[..].sub_leader` ascending by `key` (in-place
/// heapsort: O(n log n), no recursion, no memory).
fn sort_rows<K: Ord>(rows: &mut [PoseDiagnosis], key: impl Fn(u32) -> K) {
    let n = rows.len();
    super::rank::heapsort_by(
        rows,
        n,
        |rows, i, j| key(rows[i].sub_leader) < key(rows[j].sub_leader),
        |rows, i, j| {
            let (a, b) = (rows[i].sub_leader, rows[j].sub_leader);
            rows[i].sub_leader = b;
            rows[j].sub_leader = a;
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// The former O(n²) assignment, kept as the independent reference: leader by a scan,
    /// rank by counting the leaders with a smaller (key, id).
    fn quadratic(groups: &[u32], folds: usize, seed: u64) -> Vec<(u32, u32, u16)> {
        let key = |g: u32| {
            let mut r = SplitMix64::new(seed ^ u64::from(g).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            r.next_u64()
        };
        let leader: Vec<usize> = (0..groups.len())
            .map(|l| groups.iter().position(|&h| h == groups[l]).unwrap())
            .collect();
        let fold = |l: usize| {
            let (kl, gl) = (key(groups[l]), groups[l]);
            let rank = (0..groups.len())
                .filter(|&m| leader[m] == m && (key(groups[m]), groups[m]) < (kl, gl))
                .count();
            (rank % folds) as u16
        };
        (0..groups.len())
            .map(|l| (groups[l], leader[l] as u32, fold(leader[l])))
            .collect()
    }

    /// The sorted assignment equals the quadratic one exactly (groups, leaders, folds) on
    /// random group ids with repeats in any order, and each group's member list runs
    /// through its rows in ascending order from the leader.
    #[test]
    fn sorted_assignment_matches_the_quadratic_one() {
        let mut rng = SplitMix64::new(14);
        for case in 0..200 {
            let n = 5 + rng.below(300);
            let ids = 1 + rng.below(n as u64 as usize) as u64;
            let groups: Vec<u32> = (0..n)
                .map(|_| (rng.next_u64() % ids) as u32 * 7919 + 3)
                .collect();
            let folds = 2 + case % 6;
            let mut poses = vec![PoseDiagnosis::default(); n];
            let Ok(g) = assign(&groups, folds, case as u64, &mut poses) else {
                continue;
            };
            let want = quadratic(&groups, folds, case as u64);
            for (l, p) in poses.iter().enumerate() {
                assert_eq!((p.group, p.leader, p.fold), want[l], "case {case} row {l}");
            }
            let mut seen = 0;
            for l in 0..n {
                if poses[l].leader as usize != l {
                    continue;
                }
                let members: Vec<usize> = (l..n).filter(|&m| groups[m] == groups[l]).collect();
                let mut walk = vec![l];
                while poses[*walk.last().unwrap()].next != NO_NEXT {
                    walk.push(poses[*walk.last().unwrap()].next as usize);
                }
                assert_eq!(walk, members, "case {case} group of row {l}");
                seen += 1;
            }
            assert_eq!(seen, g);
        }
    }

    #[test]
    fn repeats_share_a_fold_and_folds_are_balanced_and_order_free() {
        let groups: Vec<u32> = (1..=50).chain(1..=20).chain([7, 7]).collect();
        let mut poses = vec![PoseDiagnosis::default(); groups.len()];
        let n = assign(&groups, 5, 42, &mut poses).unwrap();
        assert_eq!(n, 50);
        for (l, p) in poses.iter().enumerate() {
            let first = groups.iter().position(|&g| g == groups[l]).unwrap();
            assert_eq!(p.fold, poses[first].fold);
        }
        let mut count = [0usize; 5];
        for l in 0..50 {
            count[poses[l].fold as usize] += 1;
        }
        assert!(count.iter().all(|&c| c == 10), "{count:?}");
        // Reversed rows: same fold per group.
        let rev: Vec<u32> = groups.iter().rev().copied().collect();
        let mut poses2 = vec![PoseDiagnosis::default(); rev.len()];
        assign(&rev, 5, 42, &mut poses2).unwrap();
        for (l, &g) in rev.iter().enumerate() {
            let m = groups.iter().position(|&h| h == g).unwrap();
            assert_eq!(poses2[l].fold, poses[m].fold);
        }
        assert!(assign(&groups[..3], 5, 42, &mut poses).is_err());
    }
}
