//! Stack probes shared by `tests/stack.rs` and `tests/diagnosis_stack.rs`: a workload runs
//! on a thread with a fixed stack, each probe in a child process (a stack overflow aborts
//! the process), and a bisection finds the smallest stack that works.
//!
//! The probe is a test of the calling binary that does nothing unless the environment
//! variable it names holds a stack size in bytes; [`fits`] re-executes the binary with
//! `--exact <probe test>` and that variable set.

use std::process::Command;

/// Body of a probe test: without `env` set, returns at once (a normal test run); with it,
/// runs `setup` on the calling thread (memory the caller owns, e.g. the workspace on the
/// heap as a `static` on firmware) and then the workload it returns on a thread with
/// `env`'s value as its stack size [bytes]. Panics if the workload panics.
pub fn run_probe<W: FnOnce() + Send + 'static>(env: &str, setup: impl FnOnce() -> W) {
    let Ok(bytes) = std::env::var(env) else {
        return;
    };
    let bytes: usize = bytes.parse().unwrap();
    let work = setup();
    std::thread::Builder::new()
        .stack_size(bytes)
        .spawn(work)
        .unwrap()
        .join()
        .unwrap();
}

/// Whether the probe test `probe` of this binary completes with `bytes` of stack (`env`
/// set to `bytes`); a failure other than a stack overflow fails the calling test.
pub fn fits(probe: &str, env: &str, bytes: usize) -> bool {
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", probe, "--nocapture", "--test-threads=1"])
        .env(env, bytes.to_string())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.success() {
        return true;
    }
    assert!(
        stderr.contains("has overflowed its stack"),
        "probe with {bytes} bytes failed for another reason: {}\n{stderr}",
        out.status
    );
    false
}

/// The smallest stack in `[floor, bound]` that works, to `resolution` [bytes], given that
/// `bound` works: `floor` itself if it works, else a bisection on multiples of 256 bytes
/// keeping "lo fails, hi works" until `hi − lo ≤ resolution`; returns `hi`.
pub fn smallest_stack(
    fits: impl Fn(usize) -> bool,
    floor: usize,
    bound: usize,
    resolution: usize,
) -> usize {
    let (mut lo, mut hi) = (floor, bound);
    if fits(lo) {
        hi = lo;
    }
    while hi - lo > resolution {
        let mid = (lo + hi) / 2 / 256 * 256;
        if fits(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The build profile of the figures printed.
pub fn profile() -> &'static str {
    if cfg!(debug_assertions) {
        "dev (core at opt-level 2)"
    } else {
        "release"
    }
}
