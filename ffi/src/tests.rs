//! Unit tests of the C ABI, called as C would call it (raw pointers, lengths, status codes),
//! and the header staleness check.
#![allow(clippy::indexing_slicing, clippy::unwrap_used, clippy::expect_used)]

mod abi;
mod calibration;
mod constraints;
mod diagnosis;
mod fuzz_regressions;
mod header;
mod hostile;
mod measurement_read;
mod model_read;
mod observability;
mod prepared;
mod view_point;
