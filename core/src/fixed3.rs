//! 3-D algebra on nalgebra's storage arrays, for the firmware path (FK, Jacobians, IK, pose
//! algebra).
//!
//! Why not nalgebra's operators: at opt-level `z` (and 1) the optimiser stops inlining
//! nalgebra's generic accessors (`column(k)`, `Index`, views, `from_columns`, `zeros()`,
//! `identity()`, the matrix product's `gemv`, `dot`, `norm`, `Cholesky`), so their run-time
//! assertions stay reachable and the panic-never link proof fails on the firmware target
//! (`tests/cpp/panic_never.sh thumbv7em-none-eabihf:z`). These functions read the column-major
//! arrays (`data.0`) through destructuring and const-size loops instead, with nothing left to
//! assert.
//!
//! Bit-identical to nalgebra 0.35: every sum runs in the order nalgebra's kernels use
//! (`gemv` accumulates column by column, `dot` of a 3-vector is `a0·b0 + a1·b1 + a2·b2`,
//! longer dots start from `+0` and add term by term), so calibration results do not move.
//! `tests` below compares each function with nalgebra bit for bit.
//!
//! Public but hidden: the C ABI (kincal-ffi) needs the same panic-free operations; it is not
//! part of the documented API.

use nalgebra::{ArrayStorage, Matrix3, Point3, Rotation3, SMatrix, SVector, Translation3, Vector3};

use crate::pose::Transform;

/// The zero vector (nalgebra's `zeros()` goes through an iterator that asserts its length).
pub const ZERO: Vector3<f64> = Vector3::new(0.0, 0.0, 0.0);

/// The 3×3 identity (nalgebra's `identity()` writes the diagonal through `Index`).
pub const IDENTITY: Matrix3<f64> = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);

/// The identity transform.
pub const IDENTITY_TRANSFORM: Transform = Transform::from_parts(
    Translation3::new(0.0, 0.0, 0.0),
    Rotation3::from_matrix_unchecked(IDENTITY),
);

/// Entry `(i, j)` of `m` (row i, column j); zero out of range (callers pass constants or
/// indices below 3).
#[inline(always)]
pub fn at(m: &Matrix3<f64>, i: usize, j: usize) -> f64 {
    m.data
        .0
        .get(j)
        .and_then(|c| c.get(i))
        .copied()
        .unwrap_or(0.0)
}

/// The matrix with columns `x`, `y`, `z`.
#[inline(always)]
pub fn from_columns(x: &Vector3<f64>, y: &Vector3<f64>, z: &Vector3<f64>) -> Matrix3<f64> {
    let [x] = x.data.0;
    let [y] = y.data.0;
    let [z] = z.data.0;
    Matrix3::from_array_storage(ArrayStorage([x, y, z]))
}

/// `m·v`, summed as nalgebra's `gemv`: `(m0·v0 + m1·v1) + m2·v2` per row.
#[inline]
pub fn mat_vec(m: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    let [c0, c1, c2] = &m.data.0;
    let [[x, y, z]] = v.data.0;
    let mut out = [0.0; 3];
    for (((o, a), b), c) in out.iter_mut().zip(c0).zip(c1).zip(c2) {
        *o = a * x + b * y + c * z;
    }
    Vector3::new(out[0], out[1], out[2])
}

/// `a·b`, each column as [`mat_vec`] (nalgebra's `gemm` for fixed sizes).
#[inline]
pub fn mat_mul(a: &Matrix3<f64>, b: &Matrix3<f64>) -> Matrix3<f64> {
    let [b0, b1, b2] = &b.data.0;
    let col = |c: &[f64; 3]| mat_vec(a, &Vector3::new(c[0], c[1], c[2]));
    from_columns(&col(b0), &col(b1), &col(b2))
}

/// `a·b` of 3-vectors, as nalgebra's `dot` (`a0·b0 + a1·b1 + a2·b2`).
#[inline(always)]
pub fn dot(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `|v|²`.
#[inline(always)]
pub fn norm_squared(v: &Vector3<f64>) -> f64 {
    dot(v, v)
}

/// `|v|` (sqrt is correctly rounded: equal to nalgebra's).
#[inline(always)]
pub fn norm(v: &Vector3<f64>) -> f64 {
    crate::math::sqrt(norm_squared(v))
}

/// `a·b` of transforms (nalgebra's `Isometry * Isometry`).
#[inline]
pub fn compose(a: &Transform, b: &Transform) -> Transform {
    let shift = mat_vec(a.rotation.matrix(), &b.translation.vector);
    crate::pose::transform(
        mat_mul(a.rotation.matrix(), b.rotation.matrix()),
        a.translation.vector + shift,
    )
}

/// The inverse transform (nalgebra's `Isometry::inverse`: `Rᵀ`, `−Rᵀ·p`).
#[inline]
pub fn inverse(t: &Transform) -> Transform {
    let rt = t.rotation.matrix().transpose();
    let p = mat_vec(&rt, &(-t.translation.vector));
    crate::pose::transform(rt, p)
}

/// `t·p` of a point (nalgebra's `Isometry::transform_point`).
#[inline]
pub fn transform_point(t: &Transform, p: &Point3<f64>) -> Point3<f64> {
    Point3::from(mat_vec(t.rotation.matrix(), &p.coords) + t.translation.vector)
}

/// Σ `a_k·b_k` from `+0`, term by term: nalgebra's `dot` of vectors that are not 2, 3 or 4
/// long and shorter than 8 (its unrolled accumulators are all zero then).
#[inline]
pub fn dot_seq<'a>(a: impl Iterator<Item = &'a f64>, b: impl Iterator<Item = &'a f64>) -> f64 {
    let mut acc = 0.0;
    for (x, y) in a.zip(b) {
        acc += x * y;
    }
    acc
}

/// `|v|²` of a 6-vector, as nalgebra's `norm_squared` (`+0` plus term by term).
#[inline]
pub fn norm_squared6(v: &SVector<f64, 6>) -> f64 {
    let [c] = &v.data.0;
    0.0 + dot_seq(c.iter(), c.iter())
}

/// `J·Jᵀ` of a 6×N matrix, summed over the columns in order as nalgebra's `gemm`.
#[inline]
pub fn gram_rows<const N: usize>(j: &SMatrix<f64, 6, N>) -> SMatrix<f64, 6, 6> {
    let mut out = [[0.0; 6]; 6];
    for (c, out_c) in out.iter_mut().enumerate() {
        for (k, col) in j.data.0.iter().enumerate() {
            // Jᵀ(k, c) = J(c, k).
            let w = col.get(c).copied().unwrap_or(0.0);
            for (o, &jr) in out_c.iter_mut().zip(col) {
                *o = if k == 0 { jr * w } else { jr * w + *o };
            }
        }
    }
    SMatrix::<f64, 6, 6>::from_array_storage(ArrayStorage(out))
}

/// `Jᵀ·v` of a 6×N matrix, as nalgebra's `gemv` of the transpose (column c of J dotted with v,
/// in row order).
#[inline]
pub fn transpose_mul<const N: usize>(j: &SMatrix<f64, 6, N>, v: &SVector<f64, 6>) -> [f64; N] {
    let [v] = &v.data.0;
    let mut out = [0.0; N];
    for (o, col) in out.iter_mut().zip(j.data.0.iter()) {
        let mut acc = 0.0;
        for (r, (&jr, &vr)) in col.iter().zip(v).enumerate() {
            acc = if r == 0 { jr * vr } else { jr * vr + acc };
        }
        *o = acc;
    }
    out
}

/// Solves `A·x = b` for a symmetric positive definite `D×D` `A` (its lower triangle and
/// diagonal are read; `a[j][i]` is row i of column j, column-major as nalgebra), as nalgebra's
/// `Cholesky::new(A)?.solve(b)` operation for operation; `None` where nalgebra's factorisation
/// fails (a pivot that is zero, negative or NaN). `D < 8`: nalgebra's back substitution sums
/// its dots in another order from 8 terms on.
pub fn cholesky_solve<const D: usize>(a: &[[f64; D]; D], b: &[f64; D]) -> Option<[f64; D]> {
    const { assert!(D < 8) };
    let mut l = *a;
    for j in 0..D {
        for k in 0..j {
            let factor = -l[k][j];
            let lk = l[k];
            for i in j..D {
                l[j][i] += factor * lk[i];
            }
        }
        let diag = l[j][j];
        if diag == 0.0 || diag.is_nan() || diag < 0.0 {
            return None;
        }
        let denom = crate::math::sqrt(diag);
        l[j][j] = denom;
        for i in j + 1..D {
            l[j][i] /= denom;
        }
    }
    let mut x = *b;
    // L·y = b: forward, each solved entry eliminated from the rows below (nalgebra's axpy).
    for i in 0..D {
        let coeff = x[i] / l[i][i];
        x[i] = coeff;
        for r in i + 1..D {
            x[r] += -coeff * l[i][r];
        }
    }
    // Lᵀ·x = y: backward, the dot over the rows below from +0 in order.
    for i in (0..D).rev() {
        let mut dot = 0.0;
        for r in i + 1..D {
            dot += l[i][r] * x[r];
        }
        x[i] = (x[i] - dot) / l[i][i];
    }
    Some(x)
}

/// [`cholesky_solve`] of a 6×6 system in nalgebra types (the IK's damped step).
#[inline]
pub fn cholesky_solve6(a: &SMatrix<f64, 6, 6>, b: &SVector<f64, 6>) -> Option<SVector<f64, 6>> {
    let [b] = &b.data.0;
    cholesky_solve(&a.data.0, b).map(|x| SVector::<f64, 6>::from_array_storage(ArrayStorage([x])))
}

/// The outer product `d·dᵀ` (nalgebra's `d * d.transpose()`: entry `d_i·d_j`).
#[inline]
pub fn outer(d: &Vector3<f64>) -> Matrix3<f64> {
    from_columns(&(d * d.x), &(d * d.y), &(d * d.z))
}

/// The zero 3×3 matrix.
pub const ZERO33: Matrix3<f64> = Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use nalgebra::Cholesky;

    fn rnd(rng: &mut SplitMix64) -> f64 {
        (2.0 * rng.uniform() - 1.0) * 3.0
    }
    fn m3(rng: &mut SplitMix64) -> Matrix3<f64> {
        Matrix3::from_fn(|_, _| rnd(rng))
    }
    fn v3(rng: &mut SplitMix64) -> Vector3<f64> {
        Vector3::new(rnd(rng), rnd(rng), rnd(rng))
    }
    fn same<const R: usize, const C: usize>(
        a: &SMatrix<f64, R, C>,
        b: &SMatrix<f64, R, C>,
    ) -> bool {
        a.iter()
            .zip(b.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// Each function equals nalgebra's operation bit for bit on random inputs.
    #[test]
    fn bit_identical_to_nalgebra() {
        let mut rng = SplitMix64::new(0xf1c3);
        for _ in 0..20_000 {
            let (a, b, v, w) = (m3(&mut rng), m3(&mut rng), v3(&mut rng), v3(&mut rng));
            assert!(same(&mat_vec(&a, &v), &(a * v)));
            assert!(same(&mat_mul(&a, &b), &(a * b)));
            assert_eq!(dot(&v, &w).to_bits(), v.dot(&w).to_bits());
            assert_eq!(norm_squared(&v).to_bits(), v.norm_squared().to_bits());
            assert_eq!(norm(&v).to_bits(), v.norm().to_bits());
            assert!(same(
                &from_columns(&v, &w, &v),
                &Matrix3::from_columns(&[v, w, v])
            ));
            assert_eq!(at(&a, 2, 1).to_bits(), a[(2, 1)].to_bits());
            let ta = crate::pose::transform(a, v);
            let tb = crate::pose::transform(b, w);
            let c = compose(&ta, &tb);
            let c_ref = ta * tb;
            assert!(same(c.rotation.matrix(), c_ref.rotation.matrix()));
            assert!(same(&c.translation.vector, &c_ref.translation.vector));
            let (i, i_ref) = (inverse(&ta), ta.inverse());
            assert!(same(i.rotation.matrix(), i_ref.rotation.matrix()));
            assert!(same(&i.translation.vector, &i_ref.translation.vector));
            let p = Point3::from(w);
            assert!(same(
                &transform_point(&ta, &p).coords,
                &ta.transform_point(&p).coords
            ));

            let j = SMatrix::<f64, 6, 7>::from_fn(|_, _| rnd(&mut rng));
            let e = SVector::<f64, 6>::from_fn(|_, _| rnd(&mut rng));
            let jjt = j * j.transpose();
            assert!(same(&gram_rows(&j), &jjt));
            let jte: SVector<f64, 7> = j.transpose() * e;
            let ours = transpose_mul(&j, &e);
            assert!(
                ours.iter()
                    .zip(jte.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
            assert_eq!(norm_squared6(&e).to_bits(), e.norm_squared().to_bits());
            let damped = jjt + SMatrix::<f64, 6, 6>::identity() * 1e-3;
            let x = cholesky_solve6(&damped, &e).unwrap();
            let x_ref = Cholesky::new(damped).unwrap().solve(&e);
            assert!(same(&x, &x_ref));
            let spd = a * a.transpose() + Matrix3::identity() * 0.1;
            let x3 = cholesky_solve(&spd.data.0, &v.data.0[0]).unwrap();
            let x3_ref = Cholesky::new(spd).unwrap().solve(&v);
            assert!(
                x3.iter()
                    .zip(x3_ref.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
            assert!(same(&outer(&v), &(v * v.transpose())));
        }
        assert_eq!(ZERO33, Matrix3::zeros());
        assert_eq!(IDENTITY, Matrix3::identity());
        assert_eq!(ZERO, Vector3::zeros());
        assert_eq!(IDENTITY_TRANSFORM, Transform::identity());
        // Not positive definite: refused as nalgebra refuses it.
        let bad = -SMatrix::<f64, 6, 6>::identity();
        let e = SVector::<f64, 6>::from_element(1.0);
        assert!(cholesky_solve6(&bad, &e).is_none() && Cholesky::new(bad).is_none());
        let mut nan = SMatrix::<f64, 6, 6>::identity();
        nan[(3, 3)] = f64::NAN;
        assert!(cholesky_solve6(&nan, &e).is_none() && Cholesky::new(nan).is_none());
    }
}
