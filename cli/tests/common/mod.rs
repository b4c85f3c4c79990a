//! What the CLI's integration tests share: running the built `kincal` binary and reading
//! what it printed. Each test file uses part of it, hence the `dead_code` allowance.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The `kincal` binary of this build.
pub const BIN: &str = env!("CARGO_BIN_EXE_kincal");

/// Runs `kincal ARGS` in `dir`.
pub fn kincal(args: &[&str], dir: &Path) -> Output {
    run(BIN, args, dir)
}

/// Runs `kincal ARGS` in `dir` with the optimised binary `KINCAL_RELEASE_BIN` names, else this
/// build's: studies too slow unoptimised run in the debug test binary against the release CLI
/// the project's test command builds anyway (one release build instead of two).
pub fn kincal_optimised(args: &[&str], dir: &Path) -> Output {
    match std::env::var_os("KINCAL_RELEASE_BIN") {
        Some(bin) => run(bin, args, dir),
        None => run(BIN, args, dir),
    }
}

fn run(bin: impl AsRef<std::ffi::OsStr>, args: &[&str], dir: &Path) -> Output {
    Command::new(bin)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run kincal")
}

/// Everything the run printed: stdout, then stderr.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}
