//! What the design commands (`select-poses`, `design-tool`, `evaluate-designs`) share:
//! their arguments and resolved context (`args`), the data-acquisition designs (`designs`),
//! the Monte-Carlo study that compares them (`study`) and the socket-plate comparison
//! (`plate`).

pub mod args;
pub mod designs;
pub mod plate;
pub mod study;
