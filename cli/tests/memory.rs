//! Memory per data row (issue #16 item 6: "the spec promises streaming, so a 10^6-row file
//! should not take 640 MB"): the peak resident set of `predict`, `validate` and `calibrate`
//! on a small and a large generated ARIA file, and the growth per row between them. Linux
//! only (the peak is the kernel's `ru_maxrss` of the child); skipped with a message elsewhere.

mod common;

#[cfg(target_os = "linux")]
mod linux {
    use std::fmt::Write as _;
    use std::fs;
    use std::io::ErrorKind;
    use std::path::Path;
    use std::process::{Command, Stdio};

    use super::common::BIN;

    /// Joint readings of `rows` poses within ARIA's limits [deg] (a fixed LCG), with pose ids.
    fn joints_csv(rows: usize) -> String {
        let lim = [
            (-170.0, 170.0),
            (-50.0, 200.0),
            (-170.0, 90.0),
            (-170.0, 170.0),
            (-170.0, 170.0),
            (-170.0, 170.0),
        ];
        let mut s = String::from("pose_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n");
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        for i in 0..rows {
            let _ = write!(s, "p{i}");
            for (lo, hi) in lim {
                x = x
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                let _ = write!(s, ",{:.6}", lo + (hi - lo) * u);
            }
            s.push('\n');
        }
        s
    }

    /// Runs `kincal ARGS` in `dir` (stdout discarded, stderr to a file) and returns its peak
    /// resident set [bytes]: the kernel's own account, `ru_maxrss` from `wait4`. Polling
    /// VmHWM in /proc until the process ended missed its last milliseconds: on a loaded CI
    /// machine a 1,000-row calibration measured 30.6 MB where it peaks at 34, which alone
    /// turned 326 B/row into 454.
    fn peak_rss(args: &[&str], dir: &Path) -> u64 {
        let err = fs::File::create(dir.join("stderr.txt")).unwrap();
        let child = Command::new(BIN)
            .args(args)
            .current_dir(dir)
            .stdout(Stdio::null())
            .stderr(err)
            .spawn()
            .unwrap();
        let pid = libc::pid_t::try_from(child.id()).unwrap();
        let mut status: libc::c_int = 0;
        // SAFETY: `rusage` is plain integers and structs of integers; all zeros is valid.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        let waited = loop {
            // SAFETY: `pid` is this process's own child, not waited for yet (`child` is
            // dropped below without waiting); both out-pointers are valid for the call.
            let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
            if r != -1 || std::io::Error::last_os_error().kind() != ErrorKind::Interrupted {
                break r;
            }
        };
        assert_eq!(waited, pid, "wait4: {}", std::io::Error::last_os_error());
        drop(child);
        assert!(
            libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
            "{args:?}: {}",
            fs::read_to_string(dir.join("stderr.txt")).unwrap_or_default()
        );
        u64::try_from(usage.ru_maxrss).unwrap() * 1024
    }

    /// Peak-RSS growth per row [bytes] of `command` between `small` and `large` rows of
    /// full poses (made by `predict`).
    fn bytes_per_row(command: &[&str], small: usize, large: usize) -> f64 {
        let dir = tempfile::tempdir().unwrap();
        let mut peaks = Vec::new();
        for rows in [small, large] {
            fs::write(dir.path().join("q.csv"), joints_csv(rows)).unwrap();
            peak_rss(&["predict", "aria", "q.csv", "--out", "d.csv"], dir.path());
            peaks.push(peak_rss(command, dir.path()) as f64);
        }
        let per_row = (peaks[1] - peaks[0]) / (large - small) as f64;
        eprintln!(
            "{command:?}: peak {:.1} MB at {small} rows, {:.1} MB at {large} rows: {per_row:.0} B/row",
            peaks[0] / 1e6,
            peaks[1] / 1e6
        );
        per_row
    }

    /// `predict` streams: no memory per row (was ~850 B/row).
    #[test]
    fn predict_streams_rows() {
        let per_row = bytes_per_row(
            &["predict", "aria", "d.csv", "--out", "p.csv"],
            2_000,
            60_000,
        );
        assert!(per_row < 64.0, "{per_row:.0} B/row");
    }

    /// `validate` keeps the core measurements and a compact label per row, not the rows as
    /// read, its errors or its per-pose table (was ~1950 B/row with the table, ~940 B/row with
    /// the rows and errors; now ~295).
    #[test]
    fn validate_holds_no_table() {
        let per_row = bytes_per_row(&["validate", "aria", "d.csv"], 2_000, 60_000);
        assert!(per_row < VALIDATE_MAX_B_PER_ROW, "{per_row:.0} B/row");
    }

    /// `calibrate` keeps the core measurements and a compact label per row, not the rows as
    /// read (was ~780 B/row; now ~330).
    #[test]
    fn calibrate_memory_per_row_is_bounded() {
        let per_row = bytes_per_row(
            &["calibrate", "d.csv", "--robot", "aria", "--out", "m.json"],
            1_000,
            15_000,
        );
        assert!(per_row < CALIBRATE_MAX_B_PER_ROW, "{per_row:.0} B/row");
    }

    /// A core `Measurement<6>` is 264 bytes; the label (line, pose_id) ~30.
    const VALIDATE_MAX_B_PER_ROW: f64 = 400.0;
    const CALIBRATE_MAX_B_PER_ROW: f64 = 400.0;
}

#[cfg(not(target_os = "linux"))]
#[test]
fn memory_per_row_needs_linux() {
    eprintln!("skipped: the peak resident set is read from /proc (Linux only)");
}
