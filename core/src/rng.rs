//! A small deterministic random generator (SplitMix64) for simulation, Monte-Carlo studies
//! and multi-start searches: the same seed gives the same numbers on every target, with no
//! dependency and no global state.

/// SplitMix64 (Steele, Lea & Flood 2014): 64-bit state, passes BigCrush, trivially
/// seedable and splittable (derive independent streams with [`SplitMix64::fork`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator from a seed.
    #[must_use]
    pub const fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Standard normal (Box–Muller, one value per call).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        crate::math::sqrt(-2.0 * crate::math::ln(u1))
            * crate::math::cos(2.0 * core::f64::consts::PI * u2)
    }
    /// Uniform integer in 0..n (n > 0; 0 for n = 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            return 0;
        }
        ((self.next_u64() >> 11) % n as u64) as usize
    }
    /// Shuffles `items` in place (Fisher–Yates from the last element down, one
    /// [`SplitMix64::below`] per position), so a seed gives the same order on every target.
    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        for i in (1..items.len()).rev() {
            let j = self.below(i + 1);
            items.swap(i, j);
        }
    }
    /// An independent generator for stream `k` (e.g. one per Monte-Carlo run), so parallel
    /// runs give the same numbers whatever the thread count.
    #[must_use]
    pub fn fork(&self, k: u64) -> Self {
        let mut s = SplitMix64::new(self.state ^ k.wrapping_mul(0xD1B5_4A32_D192_ED03));
        let _ = s.next_u64();
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shuffle_permutes_and_repeats_with_the_seed() {
        let mut a: [usize; 10] = core::array::from_fn(|i| i);
        let mut b = a;
        SplitMix64::new(7).shuffle(&mut a);
        SplitMix64::new(7).shuffle(&mut b);
        assert_eq!(a, b);
        assert_ne!(a, core::array::from_fn(|i| i));
        let mut sorted = a;
        sorted.sort_unstable();
        assert_eq!(sorted, core::array::from_fn(|i| i));
        // The same draws as the loop it replaces.
        let mut c: [usize; 10] = core::array::from_fn(|i| i);
        let mut r = SplitMix64::new(7);
        for i in (1..10).rev() {
            let j = r.below(i + 1);
            c.swap(i, j);
        }
        assert_eq!(a, c);
    }
}
