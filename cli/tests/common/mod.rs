//! What the CLI's integration tests share: running the built `kincal` binary and reading
//! what it printed. Each test file uses part of it, hence the `dead_code` allowance.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The `kincal` binary of this build.
pub const BIN: &str = env!("CARGO_BIN_EXE_kincal");

/// Runs `kincal ARGS` in `dir`.
pub fn kincal(args: &[&str], dir: &Path) -> Output {
    Command::new(BIN)
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
