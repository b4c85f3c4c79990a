//! The Wilcoxon signed-rank statistic shared by the paired candidate test
//! ([`super::paired_z`]) and the smooth check's group test (`smooth::group_wilcoxon`), in
//! O(G log G) with no memory: the differences are sorted by magnitude in place, in the
//! `scratch` fields of the caller's pose records, and mid-ranks are assigned to tied
//! magnitudes in one pass. The same in-place sort gives the outlier screening its exact
//! medians.

use super::PoseDiagnosis;
use crate::math::sqrt;

/// Values the rank routines sort in place: the `scratch` fields of pose records (the rest
/// of each record stays where it is) or a plain slice of differences.
pub(crate) trait RankValues {
    /// Number of values.
    fn count(&self) -> usize;
    /// Value `i` (NaN past the end, never reached).
    fn value(&self, i: usize) -> f64;
    /// Swaps values `i` and `j`.
    fn swap_values(&mut self, i: usize, j: usize);
}

impl RankValues for [PoseDiagnosis] {
    fn count(&self) -> usize {
        self.len()
    }
    fn value(&self, i: usize) -> f64 {
        self.get(i).map_or(f64::NAN, |p| p.scratch)
    }
    fn swap_values(&mut self, i: usize, j: usize) {
        let (Some(a), Some(b)) = (
            self.get(i).map(|p| p.scratch),
            self.get(j).map(|p| p.scratch),
        ) else {
            return;
        };
        if let Some(p) = self.get_mut(i) {
            p.scratch = b;
        }
        if let Some(p) = self.get_mut(j) {
            p.scratch = a;
        }
    }
}

impl RankValues for [f64] {
    fn count(&self) -> usize {
        self.len()
    }
    fn value(&self, i: usize) -> f64 {
        self.get(i).copied().unwrap_or(f64::NAN)
    }
    fn swap_values(&mut self, i: usize, j: usize) {
        if i < self.len() && j < self.len() {
            self.swap(i, j);
        }
    }
}

/// `|value|` of entry `i`.
fn magnitude<D: RankValues + ?Sized>(d: &D, i: usize) -> f64 {
    d.value(i).abs()
}

/// Whether entry `i`'s magnitude orders before entry `j`'s (total order: a NaN
/// magnitude, positive after `abs`, sorts last).
fn before<D: RankValues + ?Sized>(d: &D, i: usize, j: usize) -> bool {
    magnitude(d, i).total_cmp(&magnitude(d, j)).is_lt()
}

/// Sorts the `scratch` values of `d` by magnitude, ascending: an in-place heapsort
/// (O(G log G), no recursion, no memory).
pub(crate) fn sort_by_magnitude<D: RankValues + ?Sized>(d: &mut D) {
    heapsort(d, before);
}

/// Sorts the values of `d` ascending (signed, total order): the same heapsort.
pub(crate) fn sort_by_value<D: RankValues + ?Sized>(d: &mut D) {
    heapsort(d, |d, i, j| d.value(i).total_cmp(&d.value(j)).is_lt());
}

/// In-place heapsort of `d` by the strict order `less(d, i, j)`.
fn heapsort<D: RankValues + ?Sized>(d: &mut D, less: impl Fn(&D, usize, usize) -> bool) {
    let n = d.count();
    heapsort_by(d, n, less, |d, i, j| d.swap_values(i, j));
}

/// In-place heapsort of the `n` items of `d` by the strict order `less(d, i, j)`, moved by
/// `swap(d, i, j)`: O(n log n), no recursion, no memory (the one sort of the diagnosis).
pub(crate) fn heapsort_by<T: ?Sized>(
    d: &mut T,
    n: usize,
    less: impl Fn(&T, usize, usize) -> bool,
    swap: impl Fn(&mut T, usize, usize),
) {
    let sift_down = |d: &mut T, mut root: usize, end: usize| loop {
        let mut child = 2 * root + 1;
        if child >= end {
            return;
        }
        if child + 1 < end && less(d, child, child + 1) {
            child += 1;
        }
        if !less(d, root, child) {
            return;
        }
        swap(d, root, child);
        root = child;
    };
    for root in (0..n / 2).rev() {
        sift_down(d, root, n);
    }
    for end in (1..n).rev() {
        swap(d, 0, end);
        sift_down(d, 0, end);
    }
}

/// Wilcoxon signed-rank z (normal approximation) of the non-zero differences in
/// `d[..].scratch`, which it reorders: `W+` is the sum of the mid-ranks of `|D|` over the
/// positive `D`, `z = (W+ − G(G+1)/4) / √(G(G+1)(2G+1)/24 − Σ (t³ − t)/48)` with `t` the
/// size of each group of equal `|D|`. Positive: the differences lean positive. 0 when
/// there is nothing to rank. (A NaN difference, which callers never produce, counts as
/// in the former O(G²) count: ranked with nothing, `−1/48` in the tie correction.)
pub(crate) fn signed_rank_z<D: RankValues + ?Sized>(d: &mut D) -> f64 {
    sort_by_magnitude(d);
    let g = d.count();
    let (mut w_plus, mut ties) = (0.0, 0.0);
    let mut start = 0;
    while start < g {
        let x = magnitude(d, start);
        let run = (start..g)
            .take_while(|&i| magnitude(d, i) == x)
            .count()
            .max(1);
        if x.is_nan() {
            ties -= 1.0 / 48.0;
        } else {
            // Records start.. start+run−1 share the mid-rank start + (run + 1)/2.
            let t = run as f64;
            let mid_rank = start as f64 + 0.5 * (t + 1.0);
            let positive = (start..start + run).filter(|&i| d.value(i) > 0.0).count();
            w_plus += positive as f64 * mid_rank;
            ties += (t * t * t - t) / 48.0;
        }
        start += run;
    }
    if g == 0 {
        return 0.0;
    }
    let nf = g as f64;
    let mean = nf * (nf + 1.0) / 4.0;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - ties;
    if var <= 0.0 {
        return 0.0;
    }
    (w_plus - mean) / sqrt(var)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use std::vec::Vec;

    /// The former O(G²) count, kept as the independent reference: for each difference,
    /// the magnitudes below and equal to its own give its mid-rank directly.
    fn quadratic_z(d: &[f64]) -> f64 {
        let (mut w_plus, mut ties) = (0.0, 0.0);
        for &xi in d {
            let x = xi.abs();
            let (mut below, mut equal) = (0usize, 0usize);
            for &yj in d {
                let y = yj.abs();
                if y < x {
                    below += 1;
                } else if y == x {
                    equal += 1;
                }
            }
            if xi > 0.0 {
                w_plus += below as f64 + 0.5 * (equal as f64 + 1.0);
            }
            let t = equal as f64;
            ties += (t * t - 1.0) / 48.0;
        }
        if d.is_empty() {
            return 0.0;
        }
        let nf = d.len() as f64;
        let mean = nf * (nf + 1.0) / 4.0;
        let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - ties;
        if var <= 0.0 {
            return 0.0;
        }
        (w_plus - mean) / sqrt(var)
    }

    fn records(d: &[f64]) -> Vec<PoseDiagnosis> {
        d.iter()
            .map(|&x| PoseDiagnosis {
                scratch: x,
                ..PoseDiagnosis::EMPTY
            })
            .collect()
    }

    /// Random non-zero differences with many exact ties in magnitude (values drawn from a
    /// few levels with random signs) and untied continuous ones, shifted so that some
    /// sets lean positive: z equal to the O(G²) count to 1e-12 over sizes 0 to 300.
    #[test]
    fn sorted_ranks_match_the_quadratic_count_with_ties() {
        let mut rng = SplitMix64::new(18);
        let mut largest = 0.0f64;
        for case in 0..400 {
            let n = (rng.next_u64() % 301) as usize;
            let levels = 1 + rng.next_u64() % 12;
            let shift = rng.uniform() - 0.3;
            let d: Vec<f64> = (0..n)
                .map(|_| {
                    let tied = case % 3 != 2 && rng.uniform() < 0.7;
                    let m = if tied {
                        ((rng.next_u64() % levels) + 1) as f64 * 0.25
                    } else {
                        rng.uniform() + 1e-3
                    };
                    let sign = if rng.uniform() < 0.5 + shift {
                        1.0
                    } else {
                        -1.0
                    };
                    sign * m
                })
                .collect();
            let want = quadratic_z(&d);
            let got = signed_rank_z(records(&d).as_mut_slice());
            assert!(
                (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                "case {case}: n {n}, {got} vs {want}"
            );
            largest = largest.max(want.abs());
        }
        // The cases reach clearly significant z, so the comparison covers the signed sum.
        assert!(largest > 5.0, "largest |z| {largest}");
    }

    /// Hand-checked small case: D = (1, −2, 2, 3): |D| ranks 1, 2.5, 2.5, 4, W+ = 7.5,
    /// mean 5, variance 30/4 − 6/48, z = 2.5/√7.375.
    #[test]
    fn mid_ranks_and_tie_correction_by_hand() {
        let z = signed_rank_z(records(&[3.0, -2.0, 1.0, 2.0]).as_mut_slice());
        assert!((z - 2.5 / sqrt(7.375)).abs() < 1e-15, "{z}");
        assert_eq!(signed_rank_z(records(&[]).as_mut_slice()), 0.0);
        // One positive difference: W+ = 1, mean 1/2, variance 1/4, z = 1.
        let z1 = signed_rank_z(records(&[1.0]).as_mut_slice());
        assert!((z1 - 1.0).abs() < 1e-15, "{z1}");
    }

    /// The sort is a permutation and ascending in magnitude.
    #[test]
    fn heapsort_orders_magnitudes_and_keeps_the_values() {
        let mut rng = SplitMix64::new(7);
        let d: Vec<f64> = (0..257).map(|_| rng.uniform() - 0.5).collect();
        let mut r = records(&d);
        sort_by_magnitude(r.as_mut_slice());
        let got: Vec<f64> = r.iter().map(|p| p.scratch).collect();
        assert!(got.windows(2).all(|w| w[0].abs() <= w[1].abs()));
        let mut a = got.clone();
        let mut b = d.clone();
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        assert_eq!(a, b);
    }
}
