//! Statistics of the contact-data diagnosis (instrument-free data: targets, planes,
//! sessions). The CLI cross-validates the geometric model and every candidate by whole
//! sessions and scores each held-out target about its own held-out mean; these functions
//! turn those per-target scores into the paired test and the gap test.

use libm::sqrt;

use crate::identify::EstimationError;

/// Wilcoxon signed-rank z of paired differences `d` (positive: the second model is
/// better), in its normal approximation: zero and non-finite differences dropped, mid-ranks
/// and the tie correction for equal |d| — the instrument diagnosis' paired statistic (one
/// routine, `rank.rs`). Reorders `d` in place (no memory); O(n log n). 0 when no difference
/// is non-zero.
#[must_use]
pub fn signed_rank_z(d: &mut [f64]) -> f64 {
    // Move the usable differences to the front, in order.
    let mut n = 0;
    for i in 0..d.len() {
        let x = d.get(i).copied().unwrap_or(0.0);
        if x != 0.0 && x.is_finite() {
            d.swap(n, i);
            n += 1;
        }
    }
    d.get_mut(..n).map_or(0.0, super::rank::signed_rank_z)
}

/// Gap test of held-out contacts against a stated noise floor σ (1σ per axis, metres).
///
/// At the floor, a held-out target with `n` contacts scored about the mean of those same
/// contacts has `E[Σ‖e‖²] = 3σ²(n − 1)` (3 components, one mean estimated) and a plane
/// `σ²(n − 3)` (distances to its own plane): `dof` sums these over the scored groups, and
/// `sum_sq_m2` is their `Σ‖e‖²`. The fits the groups were scored at carry their own
/// estimation error, which the held-out rows see as an excess `est`
/// ([`crate::identify::held_out_estimation_error`], summed over folds): whitened, the sum
/// has mean `μ = dof + tr` and variance `V = 2·dof + 2·tr² + 4·tr`, matched by a scaled
/// χ² (`c·χ²(ν)`, `c = V/2μ`, `ν = 2μ²/V`) and turned into a z by Wilson–Hilferty.
/// Returns (z, the floor's RMS per contact `sqrt(σ²·μ/Σn_t)` \[m\], estimation error
/// included). (0, 0) without dof or with σ ≤ 0.
#[must_use]
pub fn contact_gap_z(
    sum_sq_m2: f64,
    contacts: usize,
    dof: usize,
    est: EstimationError,
    sigma_m: f64,
) -> (f64, f64) {
    if dof == 0 || contacts == 0 || sigma_m.is_nan() || sigma_m <= 0.0 {
        return (0.0, 0.0);
    }
    let (k, t, t2) = (dof as f64, est.trace.max(0.0), est.trace_sq.max(0.0));
    let mean = k + t;
    let var = 2.0 * k + 2.0 * t2 + 4.0 * t;
    let (scale, nu) = (var / (2.0 * mean), 2.0 * mean * mean / var);
    let v = 2.0 / (9.0 * nu);
    let q = sum_sq_m2 / (sigma_m * sigma_m) / scale;
    let z = (libm::cbrt(q.max(0.0) / nu) - (1.0 - v)) / sqrt(v);
    (z, sqrt(sigma_m * sigma_m * mean / contacts as f64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_rank_z_matches_hand_computation() {
        // n = 5, all positive: W+ = 15, mean 7.5, var 13.75.
        let z = signed_rank_z(&mut [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert!((z - 7.5 / sqrt(13.75)).abs() < 1e-12);
        // Zero dropped; |d| = 1, 1, 2 (mid-ranks 1.5, 1.5, 3); W+ = 4.5, mean 3,
        // var 3.5 − (2³ − 2)/48 = 3.375.
        let z = signed_rank_z(&mut [1.0, -1.0, 2.0, 0.0]);
        assert!((z - 1.5 / sqrt(3.375)).abs() < 1e-12);
        // Antisymmetric.
        assert!((signed_rank_z(&mut [-1.0, 1.0, -2.0]) + z).abs() < 1e-12);
        assert_eq!(signed_rank_z(&mut [0.0, 0.0]), 0.0);
    }

    #[test]
    fn estimation_error_moves_the_floor_and_widens_the_test() {
        // The same sum is at the floor once the fits' estimation error (trace 60) is
        // expected, and far above it without.
        let sigma = 1e-4;
        let sum_sq = sigma * sigma * (270.0 + 60.0);
        let est = EstimationError {
            trace: 60.0,
            trace_sq: 900.0,
        };
        let (z0, _) = contact_gap_z(sum_sq, 100, 270, EstimationError::default(), sigma);
        let (z, floor) = contact_gap_z(sum_sq, 100, 270, est, sigma);
        assert!(z0 > 2.0 && z.abs() < 0.1, "{z0} {z}");
        assert!((floor - sqrt(sigma * sigma * 330.0 / 100.0)).abs() < 1e-15);
        // The law is right-skewed: its 0.99865 quantile (z = 3) lies beyond the mean plus
        // 3 sd, so a sum there gives z a little below 3.
        let (mean, sd) = (330.0, (2.0f64 * 270.0 + 2.0 * 900.0 + 4.0 * 60.0).sqrt());
        let (z3, _) = contact_gap_z(sigma * sigma * (mean + 3.0 * sd), 100, 270, est, sigma);
        assert!((2.6..3.0).contains(&z3), "{z3}");
    }

    #[test]
    fn gap_z_is_near_zero_at_the_floor_and_large_above_it() {
        // At the floor Σ‖e‖² = 3σ²·Σ(n−1): z ≈ Wilson–Hilferty's small offset.
        let sigma = 1e-4;
        let none = EstimationError::default();
        let (z, floor) = contact_gap_z(3.0 * sigma * sigma * 90.0, 100, 270, none, sigma);
        assert!(z.abs() < 0.1, "{z}");
        assert!((floor - sqrt(sigma * sigma * 270.0 / 100.0)).abs() < 1e-15);
        // Twice the floor in RMS (4× in sum of squares) on 270 dof: far beyond 3.
        let (z, _) = contact_gap_z(4.0 * 3.0 * sigma * sigma * 90.0, 100, 270, none, sigma);
        assert!(z > 10.0, "{z}");
        assert_eq!(contact_gap_z(1.0, 10, 0, none, sigma), (0.0, 0.0));
    }
}
