//! Eigenvalues (only) of a symmetric matrix: Householder tridiagonalisation followed by the
//! implicit QL algorithm with Wilkinson-type shifts.
//!
//! Why: pose selection scores thousands of candidate sets, each by the spectrum of a p×p
//! Gram matrix `JᵀJ`. Without eigenvectors this costs about `4p³/3` flops, several times
//! less than a Jacobi SVD of the triangular factor; the accuracy (absolute error about
//! `ε·‖A‖` per eigenvalue) is ample for ranking designs. The reported observability indices
//! use the backward-stable route (Givens factor, then [`super::svd::jacobi_svd`]).

use super::util::{check_capacity, check_finite_block};
use crate::error::{Error, Result};

/// Maximum QL sweeps per eigenvalue before `NotConverged`.
pub const MAX_QL_ITERATIONS: u32 = 60;

/// Eigenvalues of the symmetric matrix whose **upper** triangle is the leading `n`×`n` block
/// of `a`, written to `eig[0..n]` in descending order. `a` is used as scratch (its contents
/// afterwards are unspecified); `off` is scratch for the off-diagonal.
///
/// Errors: `CapacityExceeded` if `n > P`; `NonFinite { Parameter, i * n + j }` for a
/// non-finite upper-triangle entry (nothing modified); `NotConverged` if QL needs more than
/// [`MAX_QL_ITERATIONS`] sweeps for one eigenvalue (not seen for finite input).
pub fn sym_eigenvalues<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    eig: &mut [f64; P],
    off: &mut [f64; P],
) -> Result<()> {
    check_capacity::<P>(n)?;
    check_finite_block(a, n, true)?;
    if n == 0 {
        return Ok(());
    }
    // The tridiagonalisation reads the lower triangle: mirror the upper one.
    for i in 0..n {
        for j in 0..i {
            a[i][j] = a[j][i];
        }
    }
    tridiagonalise(a, n, eig, off);
    tql(n, eig, off)?;
    // Insertion sort, descending (n is small).
    for i in 1..n {
        let v = eig[i];
        let mut j = i;
        while j > 0 && eig[j - 1] < v {
            eig[j] = eig[j - 1];
            j -= 1;
        }
        eig[j] = v;
    }
    Ok(())
}

/// Householder reduction of the lower triangle of `a` to tridiagonal form: diagonal in `d`,
/// sub-diagonal in `e[1..n]` (`e[0] = 0`).
fn tridiagonalise<const P: usize>(
    a: &mut [[f64; P]; P],
    n: usize,
    d: &mut [f64; P],
    e: &mut [f64; P],
) {
    for i in (1..n).rev() {
        let l = i - 1;
        let mut h = 0.0;
        if l > 0 {
            let scale: f64 = (0..l + 1).map(|k| libm::fabs(a[i][k])).sum();
            if scale == 0.0 {
                e[i] = a[i][l];
            } else {
                for k in 0..l + 1 {
                    a[i][k] /= scale;
                    h += a[i][k] * a[i][k];
                }
                let f = a[i][l];
                let g = if f >= 0.0 {
                    -libm::sqrt(h)
                } else {
                    libm::sqrt(h)
                };
                e[i] = scale * g;
                h -= f * g;
                a[i][l] = f - g;
                let mut f = 0.0;
                for j in 0..l + 1 {
                    let mut g = 0.0;
                    for k in 0..j + 1 {
                        g += a[j][k] * a[i][k];
                    }
                    for k in (j + 1)..(l + 1) {
                        g += a[k][j] * a[i][k];
                    }
                    e[j] = g / h;
                    f += e[j] * a[i][j];
                }
                let hh = f / (h + h);
                for j in 0..l + 1 {
                    let f = a[i][j];
                    let g = e[j] - hh * f;
                    e[j] = g;
                    for k in 0..j + 1 {
                        a[j][k] -= f * e[k] + g * a[i][k];
                    }
                }
            }
        } else {
            e[i] = a[i][l];
        }
        d[i] = h;
    }
    e[0] = 0.0;
    for i in 0..n {
        d[i] = a[i][i];
    }
}

/// Implicit QL on the tridiagonal matrix (`d`, `e[1..n]`); eigenvalues end up in `d`.
fn tql<const P: usize>(n: usize, d: &mut [f64; P], e: &mut [f64; P]) -> Result<()> {
    for i in 1..n {
        e[i - 1] = e[i];
    }
    e[n - 1] = 0.0;
    for l in 0..n {
        let mut iter = 0;
        loop {
            let mut m = l;
            while m + 1 < n {
                let dd = libm::fabs(d[m]) + libm::fabs(d[m + 1]);
                if libm::fabs(e[m]) <= f64::EPSILON * dd {
                    break;
                }
                m += 1;
            }
            if m == l {
                break;
            }
            iter += 1;
            if iter > MAX_QL_ITERATIONS {
                return Err(Error::NotConverged {
                    iterations: MAX_QL_ITERATIONS,
                });
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = libm::hypot(g, 1.0);
            g = d[m] - d[l] + e[l] / (g + libm::copysign(r, g));
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut i = m;
            let mut underflow = false;
            while i > l {
                i -= 1;
                let f = s * e[i];
                let b = c * e[i];
                // |f|, |g| are bounded by the matrix norm here: no overflow, plain sqrt.
                r = libm::sqrt(f * f + g * g);
                e[i + 1] = r;
                if r == 0.0 {
                    d[i + 1] -= p;
                    e[m] = 0.0;
                    underflow = true;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
            }
            if underflow {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[m] = 0.0;
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::testutil::Rng;
    use nalgebra::{DMatrix, SymmetricEigen};

    fn check<const P: usize>(a: &[[f64; P]; P], n: usize, tol: f64) {
        let m = DMatrix::from_fn(n, n, |i, j| a[i.min(j)][i.max(j)]);
        let mut want: std::vec::Vec<f64> = SymmetricEigen::new(m.clone())
            .eigenvalues
            .iter()
            .copied()
            .collect();
        want.sort_by(|x, y| y.partial_cmp(x).unwrap());
        let mut w = *a;
        let (mut eig, mut off) = ([0.0; P], [0.0; P]);
        sym_eigenvalues(&mut w, n, &mut eig, &mut off).unwrap();
        let norm = m.norm();
        for k in 0..n {
            assert!(
                (eig[k] - want[k]).abs() <= tol * (1.0 + norm),
                "n={n} k={k}: {} vs {}",
                eig[k],
                want[k]
            );
        }
    }

    #[test]
    fn eigenvalues_match_nalgebra_on_random_symmetric_and_gram_matrices() {
        let mut rng = Rng(7);
        for n in [1, 2, 3, 5, 8, 13, 24] {
            for _ in 0..5 {
                let a: [[f64; 24]; 24] = rng.mat(n);
                check(&a, n, 1e-12);
                // A Gram matrix with a wide spectrum (graded columns).
                let j = rng.dmat(3 * n + 6, n);
                let mut j = j.clone();
                for c in 0..n {
                    let s = 10f64.powi(-(c as i32) / 4);
                    j.column_mut(c).scale_mut(s);
                }
                let g = j.transpose() * &j;
                let mut ga = [[0.0; 24]; 24];
                for r in 0..n {
                    for c in 0..n {
                        ga[r][c] = g[(r, c)];
                    }
                }
                check(&ga, n, 1e-13);
            }
        }
    }

    #[test]
    fn diagonal_zero_and_repeated_spectra() {
        let mut a = [[0.0; 6]; 6];
        let (mut eig, mut off) = ([0.0; 6], [0.0; 6]);
        sym_eigenvalues(&mut a, 6, &mut eig, &mut off).unwrap();
        assert!(eig.iter().all(|&v| v == 0.0));
        let mut b = [[0.0; 6]; 6];
        for (i, v) in [3.0, 1.0, 3.0, 2.0, 1.0].iter().enumerate() {
            b[i][i] = *v;
        }
        sym_eigenvalues(&mut b, 5, &mut eig, &mut off).unwrap();
        assert_eq!(&eig[..5], &[3.0, 3.0, 2.0, 1.0, 1.0]);
        let mut c = [[0.0; 6]; 6];
        c[0][1] = f64::NAN;
        assert!(matches!(
            sym_eigenvalues(&mut c, 3, &mut eig, &mut off),
            Err(Error::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            sym_eigenvalues(&mut c, 7, &mut eig, &mut off),
            Err(Error::CapacityExceeded { .. })
        ));
    }
}
