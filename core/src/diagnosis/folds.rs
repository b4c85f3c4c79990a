//! Groups of repeated measurements and the cross-validation folds built from them.

use super::PoseDiagnosis;
use crate::error::{Error, Result};
use crate::rng::SplitMix64;

/// Writes each measurement's group leader (index of the first measurement with the same
/// group id) and fold into `poses`; returns the number of groups.
///
/// Folds: every group is given a key from a hash of its id and `seed`; groups ranked by
/// key are dealt to the folds in turn, so the folds hold equally many groups (±1), the
/// repeats of a pose always share a fold, and the assignment depends only on the set of
/// group ids and the seed, not on the order of the rows. O(n²) time, no memory.
pub(crate) fn assign(
    groups: &[u32],
    folds: usize,
    seed: u64,
    poses: &mut [PoseDiagnosis],
) -> Result<usize> {
    let n = groups.len();
    let key = |g: u32| {
        let mut r = SplitMix64::new(seed ^ u64::from(g).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        r.next_u64()
    };
    let mut n_groups = 0;
    for l in 0..n {
        let g = groups[l];
        let leader = groups.iter().position(|&h| h == g).unwrap_or(l);
        poses[l].group = g;
        poses[l].leader = leader as u32;
        if leader == l {
            n_groups += 1;
        }
    }
    if n_groups < folds {
        return Err(Error::TooFewData {
            found: n_groups,
            needed: folds,
        });
    }
    for l in 0..n {
        let leader = poses[l].leader as usize;
        if leader != l {
            continue;
        }
        let (kl, gl) = (key(groups[l]), groups[l]);
        let rank = (0..n)
            .filter(|&m| poses[m].leader as usize == m)
            .filter(|&m| {
                let (km, gm) = (key(groups[m]), groups[m]);
                (km, gm) < (kl, gl)
            })
            .count();
        poses[l].fold = (rank % folds) as u16;
    }
    for l in 0..n {
        let leader = poses[l].leader as usize;
        poses[l].fold = poses[leader].fold;
    }
    Ok(n_groups)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

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
