//! Progress indicators on stderr: drawn as bars when stderr is a terminal, and as plain
//! periodic lines otherwise (CI logs, scripts, pipes), so long runs never look hung.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, WeakProgressBar};

/// Seconds between the plain progress lines when stderr is not a terminal
/// (`KINCAL_PROGRESS_SECS` overrides the default of 5 s; 0 turns the lines off).
fn line_interval() -> Option<Duration> {
    let secs = std::env::var("KINCAL_PROGRESS_SECS")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .unwrap_or(5.0);
    (secs.is_finite() && secs > 0.0).then(|| Duration::from_secs_f64(secs))
}

/// A spinner with a message, ticking until dropped or finished.
pub fn spinner(message: impl Into<String>) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_message(message.into());
    pb.enable_steady_tick(Duration::from_millis(120));
    with_plain_lines(pb)
}

/// A counting bar of `len` steps with a message.
pub fn counter(len: u64, message: impl Into<String>) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:32}] {pos}/{len}, eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(message.into());
    with_plain_lines(pb)
}

/// Starts a new phase of `len` steps on an existing bar (e.g. the exchange after the pool).
pub fn phase(pb: &ProgressBar, len: u64, message: impl Into<String>) {
    pb.set_length(len);
    pb.set_position(0);
    pb.set_message(message.into());
}

/// When stderr is not a terminal (indicatif then draws nothing), a watcher thread writes
/// one plain line per interval while the bar lives, and a last line when it finishes.
fn with_plain_lines(pb: ProgressBar) -> ProgressBar {
    if std::io::stderr().is_terminal() {
        return pb;
    }
    if let Some(every) = line_interval() {
        let weak = pb.downgrade();
        let _ = std::thread::Builder::new()
            .name("kincal-progress".into())
            .spawn(move || watch(weak, every));
    }
    pb
}

fn watch(weak: WeakProgressBar, every: Duration) {
    let start = Instant::now();
    let mut last = start;
    let mut printed = false;
    loop {
        std::thread::sleep(Duration::from_millis(50).min(every));
        let Some(pb) = weak.upgrade() else { return };
        if pb.is_finished() {
            if printed {
                emit(&format!("{}: done after {}", pb.message(), secs(start)));
            }
            return;
        }
        if last.elapsed() >= every {
            last = Instant::now();
            printed = true;
            emit(&plain_line(&pb, start));
        }
    }
}

/// `"{message}: {pos}/{len} ({pct} %), {elapsed}"`, or `"{message}: {elapsed}"` for a spinner.
fn plain_line(pb: &ProgressBar, start: Instant) -> String {
    match pb.length() {
        Some(len) if len > 0 => {
            let pos = pb.position();
            let pct = 100.0 * pos as f64 / len as f64;
            format!(
                "{}: {pos}/{len} ({pct:.0} %), {}",
                pb.message(),
                secs(start)
            )
        }
        _ => format!("{}: {} elapsed", pb.message(), secs(start)),
    }
}

fn secs(start: Instant) -> String {
    format!("{:.0} s", start.elapsed().as_secs_f64())
}

fn emit(line: &str) {
    let mut e = std::io::stderr().lock();
    let _ = writeln!(e, "[progress] {line}");
}

/// A bar as kincal-io's [`Progress`](kincal_io::design::Progress) of a design run.
#[derive(Debug)]
pub struct Bar<'a>(pub &'a ProgressBar);

impl kincal_io::design::Progress for Bar<'_> {
    fn stage(&self, len: u64, message: &str) {
        phase(self.0, len, message);
    }
    fn message(&self, message: &str) {
        self.0.set_message(message.to_string());
    }
    fn inc(&self, n: u64) {
        self.0.inc(n);
    }
}

/// A bar counting the calibrations of a Monte-Carlo study, with their rate.
pub fn calibrations(len: u64, message: impl Into<String>) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:32}] {pos}/{len} calibrations, {per_sec}, eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(message.into());
    pb
}
