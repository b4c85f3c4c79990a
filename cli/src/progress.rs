//! Progress indicators on stderr (drawn only when stderr is a terminal).

use std::time::Duration;

use indicatif::ProgressBar;

/// A spinner with a message, ticking until dropped or finished.
pub fn spinner(message: impl Into<String>) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_message(message.into());
    pb.enable_steady_tick(Duration::from_millis(120));
    pb
}

/// A counting bar of `len` steps with a message (hidden when stderr is not a terminal).
pub fn counter(len: u64, message: impl Into<String>) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:32}] {pos}/{len}, eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(message.into());
    pb
}
