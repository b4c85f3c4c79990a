//! 4x4 homogeneous matrices (numpy) to and from the core's `Transform`.

use kincal::Transform;
use kincal::pose::checked_transform;
use nalgebra::{Matrix3, Vector3};
use numpy::ndarray::{Array2, ArrayView2};
use pyo3::prelude::*;

use crate::errors;

/// `t` as a row-major 4x4 array.
pub fn homogeneous(t: &Transform) -> Array2<f64> {
    let h = t.to_homogeneous();
    Array2::from_shape_fn((4, 4), |(i, j)| h[(i, j)])
}

/// A transform from a 4x4 homogeneous matrix: finite, last row `0 0 0 1`, rotation
/// orthonormal and right-handed (input checks only; no kinematics).
pub fn transform_from_matrix(
    py: Python<'_>,
    m: &ArrayView2<'_, f64>,
    name: &str,
) -> PyResult<Transform> {
    let bad = |why: &str| errors::usage(py, format!("{name}: {why}"));
    if m.shape() != [4, 4] {
        return Err(bad(&format!("shape {:?}: expected (4, 4)", m.shape())));
    }
    if m.iter().any(|v| !v.is_finite()) {
        return Err(bad("non-finite entry"));
    }
    if m[[3, 0]] != 0.0 || m[[3, 1]] != 0.0 || m[[3, 2]] != 0.0 || m[[3, 3]] != 1.0 {
        return Err(bad("last row must be [0, 0, 0, 1]"));
    }
    let r = Matrix3::from_fn(|i, j| m[[i, j]]);
    checked_transform(r, Vector3::new(m[[0, 3]], m[[1, 3]], m[[2, 3]]))
        .ok_or_else(|| bad("the rotation is not orthonormal and right-handed"))
}
