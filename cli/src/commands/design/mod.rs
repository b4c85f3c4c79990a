//! What the design commands (`select-poses`, `design-tool`, `evaluate-designs`) share: their
//! arguments (`args`), the tables of a Monte-Carlo comparison (`study`) and the wording of the
//! socket-plate comparison (`plate`: table, verdicts, figure). The designs, studies and
//! plates themselves are kincal-io's [`kincal_io::design`].

pub mod args;
pub mod plate;
pub mod study;
