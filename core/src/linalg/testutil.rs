//! Test helpers: deterministic PRNG and conversions to nalgebra.

extern crate std;

use nalgebra::{DMatrix, DVector};

/// SplitMix64, deterministic.
pub(crate) struct Rng(pub u64);

impl Rng {
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    pub(crate) fn sym(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64) * (1.0 / (1u64 << 52) as f64) - 1.0
    }
    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * 0.5 * (self.sym() + 1.0)
    }
    pub(crate) fn mat<const P: usize>(&mut self, n: usize) -> [[f64; P]; P] {
        let mut a = [[0.0; P]; P];
        for row in a.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v = self.sym();
            }
        }
        a
    }
    pub(crate) fn dmat(&mut self, r: usize, c: usize) -> DMatrix<f64> {
        DMatrix::from_fn(r, c, |_, _| self.sym())
    }
    pub(crate) fn dvec(&mut self, n: usize) -> DVector<f64> {
        DVector::from_fn(n, |_, _| self.sym())
    }
}

pub(crate) fn to_d<const P: usize>(a: &[[f64; P]; P], n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |i, j| a[i][j])
}

pub(crate) fn upper_d<const P: usize>(a: &[[f64; P]; P], n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |i, j| if j >= i { a[i][j] } else { 0.0 })
}

pub(crate) fn from_d<const P: usize>(m: &DMatrix<f64>) -> [[f64; P]; P] {
    let mut a = [[0.0; P]; P];
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            a[i][j] = m[(i, j)];
        }
    }
    a
}

/// Random n×n matrix of rank k (product of n×k and k×n random factors).
pub(crate) fn low_rank(rng: &mut Rng, n: usize, k: usize) -> DMatrix<f64> {
    rng.dmat(n, k) * rng.dmat(k, n)
}

/// max |a − b| / max(1, max |b|) style relative difference (normwise).
pub(crate) fn rel_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    let scale = b.amax().max(a.amax()).max(f64::MIN_POSITIVE);
    (a - b).amax() / scale
}

pub(crate) fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, tol: f64, what: &str) {
    let d = rel_diff(a, b);
    assert!(
        d <= tol,
        "{what}: relative difference {d:e} > {tol:e}\n{a}\n{b}"
    );
}
