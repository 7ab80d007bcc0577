//! Progress display: a spinner with elapsed time on stderr for anything
//! that can take over a second, drawn only when stdout is a terminal (so
//! scripts and CI logs stay clean).

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A running stage; cleared when dropped. `None` when nothing is drawn:
/// a hidden bar would draw nothing, so none is made (a library caller's
/// frames build no bar and parse no style each).
pub struct Stage(Option<ProgressBar>);

impl Stage {
    /// Starts showing `msg` with a spinner and elapsed time.
    pub fn start(msg: impl Into<String>) -> Stage {
        if !std::io::stdout().is_terminal() {
            return Stage(None);
        }
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.set_message(msg.into());
        bar.enable_steady_tick(Duration::from_millis(120));
        Stage(Some(bar))
    }
}

impl Stage {
    /// Starts showing `msg` with a count of `total` steps done so far
    /// ([`Stage::inc`]) and the elapsed time.
    pub fn counted(msg: impl Into<String>, total: u64) -> Stage {
        let s = Stage::start(msg);
        if let Some(bar) = &s.0 {
            bar.set_length(total);
            bar.set_style(
                ProgressStyle::with_template("{spinner} {msg} {pos}/{len} [{elapsed}]")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
        }
        s
    }

    /// One more step of a [`Stage::counted`] stage done.
    pub fn inc(&self) {
        if let Some(bar) = &self.0 {
            bar.inc(1);
        }
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}
