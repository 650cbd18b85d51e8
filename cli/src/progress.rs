//! Progress of a long command on standard error when it is not a terminal
//! (CI logs, `2> file`): a plain line at most every [`EVERY`] and one at the
//! end, where a terminal gets a bar redrawn in place. A 4 860-variant
//! evaluation once printed nothing for 34 minutes in CI.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Least time between two progress lines.
const EVERY: Duration = Duration::from_secs(30);

/// Plain progress lines for `total` items of `what` (`variants`).
struct PlainProgress {
    command: &'static str,
    what: &'static str,
    total: usize,
    start: Instant,
    /// Items done and when the last line was printed.
    state: Mutex<(usize, Instant)>,
}

impl PlainProgress {
    /// `Some` when standard error is not a terminal and there is work.
    fn off_terminal(command: &'static str, what: &'static str, total: usize) -> Option<Self> {
        (!std::io::stderr().is_terminal() && total > 0).then(|| {
            let now = Instant::now();
            Self { command, what, total, start: now, state: Mutex::new((0, now)) }
        })
    }

    /// One item done; prints a line when [`EVERY`] has passed or all are done.
    fn tick(&self) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.0 += 1;
        let now = Instant::now();
        if state.0 == self.total || now.duration_since(state.1) >= EVERY {
            state.1 = now;
            let elapsed = now.duration_since(self.start).as_secs();
            eprintln!(
                "{}: {}/{} {} done, {}m{:02}s",
                self.command,
                state.0,
                self.total,
                self.what,
                elapsed / 60,
                elapsed % 60
            );
        }
    }
}

/// Progress of a command over `total` items: a bar redrawn in place on a
/// terminal, [`PlainProgress`] lines off one. Safe to tick from rayon's
/// threads.
pub(super) struct Progress {
    bar: indicatif::ProgressBar,
    plain: Option<PlainProgress>,
}

impl Progress {
    /// Progress of `command` over `total` items of `what` (`scenes`).
    pub(super) fn new(command: &'static str, what: &'static str, total: usize) -> Self {
        let template = format!("{command}: {{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {what} (eta {{eta}})");
        let bar = indicatif::ProgressBar::new(total as u64).with_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Self { bar, plain: PlainProgress::off_terminal(command, what, total) }
    }

    /// One item done.
    pub(super) fn tick(&self) {
        self.bar.inc(1);
        if let Some(p) = &self.plain {
            p.tick();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
