//! `kincal`: the command-line tool (commands land with the identification issue).
#![allow(dead_code)]

mod files;
mod measurements;

fn main() {}
