//! Progress bars on stderr for the long commands.

use geared_servo_host::Progress;

/// An indicatif bar that the host library's computations advance.
pub struct Bar(pub indicatif::ProgressBar);

impl Progress for Bar {
    fn advance(&self, n: u64) {
        self.0.inc(n);
    }
    fn stage(&self, name: &str) {
        self.0.set_message(name.to_string());
    }
}

impl Bar {
    /// Clears the bar from the terminal.
    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn progress(len: u64, what: &str) -> Bar {
    let pb = indicatif::ProgressBar::with_draw_target(
        Some(len),
        indicatif::ProgressDrawTarget::stderr(),
    );
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg:>8} [{bar:40}] {pos}/{len} {elapsed}")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(what.to_string());
    Bar(pb)
}

/// A spinner on stderr for a computation of unknown length, showing the elapsed time and the
/// last stage it reported: hidden when stderr is not a terminal, and while the host's debug
/// trace is on (its lines go to stderr too, and a redrawn spinner would tear them).
pub fn spinner(what: &str) -> Bar {
    let pb = if log::log_enabled!(target: "geared_servo_host", log::Level::Debug) {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr())
    };
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} {elapsed:>4} {prefix}, done so far: {msg}",
    ) {
        pb.set_style(style);
    }
    pb.set_prefix(what.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    Bar(pb)
}
