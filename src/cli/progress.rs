//! Progress display: a spinner with elapsed time on stderr for anything
//! that can take over a second, drawn only when stdout is a terminal (so
//! scripts and CI logs stay clean).

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A running stage; cleared when dropped.
pub struct Stage(ProgressBar);

impl Stage {
    /// Starts showing `msg` with a spinner and elapsed time.
    pub fn start(msg: impl Into<String>) -> Stage {
        let shown = std::io::stdout().is_terminal();
        let bar = if shown {
            ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
        } else {
            ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden())
        };
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.set_message(msg.into());
        // The ticker is a thread; a hidden bar draws nothing, so it starts
        // none (a library caller's frames start and join no thread each).
        if shown {
            bar.enable_steady_tick(Duration::from_millis(120));
        }
        Stage(bar)
    }
}

impl Stage {
    /// Starts showing `msg` with a count of `total` steps done so far
    /// ([`Stage::inc`]) and the elapsed time.
    pub fn counted(msg: impl Into<String>, total: u64) -> Stage {
        let s = Stage::start(msg);
        s.0.set_length(total);
        s.0.set_style(
            ProgressStyle::with_template("{spinner} {msg} {pos}/{len} [{elapsed}]")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        s
    }

    /// One more step of a [`Stage::counted`] stage done.
    pub fn inc(&self) {
        self.0.inc(1);
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}
