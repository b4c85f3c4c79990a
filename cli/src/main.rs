//! `kincal`: the command-line tool (commands land with the identification issue).
#![allow(dead_code)]

mod files;
mod measurements;
mod robot_file;
mod urdf;

fn main() {}
