//! Inputs the fuzz targets (`fuzz/`) found to break a contract, kept as tests of the core.

use kincal::{Error, JointState, ParamIndex, Quantity, Robot, aria};

/// fuzz/c_abi: every parameter set to a finite but absurd 8.7e245 made FK overflow to NaN,
/// and `kincal_fk` returned OK with a NaN pose. FK, FK with frames and the Jacobian now
/// refuse a non-finite result.
#[test]
fn fk_of_absurd_but_finite_parameters_is_an_error_not_a_nan_pose() {
    let mut r = aria::nominal();
    for i in 0..Robot::<6>::NUM_PARAMS {
        r.set_param(ParamIndex(i), 8.739899877464282e245).unwrap();
    }
    let st = JointState {
        q: [0.0; 6],
        approach: Some([1.0; 6]),
        temp_c: Some(20.0),
    };
    let nonfinite = |e: Error| {
        matches!(
            e,
            Error::NonFinite {
                what: Quantity::Position | Quantity::Orientation,
                ..
            }
        )
    };
    assert!(nonfinite(r.fk(&st).unwrap_err()));
    let mut frames = kincal::Frames::default();
    assert!(nonfinite(r.fk_frames(&st, &mut frames).unwrap_err()));
    let mut jac = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
    assert!(nonfinite(r.jacobian(&st, &mut jac).unwrap_err()));
    // Ordinary models are unaffected.
    assert!(aria::nominal().fk(&st).is_ok());
}
