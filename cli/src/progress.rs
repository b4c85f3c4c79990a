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
