//! Progress of a long command on standard error: a bar redrawn in place on
//! a terminal, plain lines off one (CI logs, `2> file`). Both say at once
//! that the command has started and keep saying it while nothing finishes:
//! a 4 860-variant evaluation against an external planner once printed
//! nothing for 34 minutes, each variant taking minutes. Plain lines come at
//! most every [`EVERY`] while items finish, at least every [`EVERY`] while
//! none does, and once at the end.

use std::io::IsTerminal;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Least time between two progress lines, and the most while nothing
/// finishes.
const EVERY: Duration = Duration::from_secs(30);

/// How often the bar redraws its clock while nothing finishes.
const STEADY_TICK: Duration = Duration::from_secs(1);

/// What plain progress lines count.
struct Counter {
    /// Items done.
    done: usize,
    /// When the last line was printed.
    last: Instant,
    /// The command has ended: the heartbeat stops.
    finished: bool,
}

/// Plain progress lines for `total` items of `what` (`variants`).
struct PlainProgress {
    command: &'static str,
    what: &'static str,
    total: usize,
    start: Instant,
    state: Mutex<Counter>,
    /// Wakes the heartbeat when the command ends.
    ended: Condvar,
}

impl PlainProgress {
    /// `Some` when standard error is not a terminal and there is work.
    fn off_terminal(command: &'static str, what: &'static str, total: usize) -> Option<Arc<Self>> {
        (!std::io::stderr().is_terminal() && total > 0).then(|| {
            let now = Instant::now();
            Arc::new(Self {
                command,
                what,
                total,
                start: now,
                state: Mutex::new(Counter { done: 0, last: now, finished: false }),
                ended: Condvar::new(),
            })
        })
    }

    /// `evaluate: 3/4860 variants done, 12m30s`, with an estimate of the
    /// time left once something is done.
    fn line(&self, done: usize, now: Instant) -> String {
        let elapsed = now.duration_since(self.start).as_secs_f64();
        let left = if done > 0 && done < self.total {
            let s = (elapsed / done as f64 * (self.total - done) as f64).round() as u64;
            format!(", about {} left", minutes(s))
        } else {
            String::new()
        };
        format!("{}: {}/{} {} done, {}{left}", self.command, done, self.total, self.what, minutes(elapsed as u64))
    }

    /// One item done; prints a line when [`EVERY`] has passed or all are done.
    fn tick(&self) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.done += 1;
        let now = Instant::now();
        if state.done == self.total || now.duration_since(state.last) >= EVERY {
            state.last = now;
            eprintln!("{}", self.line(state.done, now));
        }
    }

    /// Prints a line whenever [`EVERY`] passes without one, until the
    /// command ends.
    fn heartbeat(&self) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        while !state.finished {
            let wait = EVERY.saturating_sub(state.last.elapsed());
            state = self.ended.wait_timeout(state, wait).unwrap_or_else(|e| e.into_inner()).0;
            let now = Instant::now();
            if !state.finished && now.duration_since(state.last) >= EVERY {
                state.last = now;
                eprintln!("{} (still running)", self.line(state.done, now));
            }
        }
    }

    /// Stops the heartbeat.
    fn finish(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).finished = true;
        self.ended.notify_all();
    }
}

/// `0m07s`, `34m02s`.
fn minutes(s: u64) -> String {
    format!("{}m{:02}s", s / 60, s % 60)
}

/// Progress of a command over `total` items: a bar redrawn in place on a
/// terminal, [`PlainProgress`] lines off one. Safe to tick from rayon's
/// threads.
pub(super) struct Progress {
    bar: indicatif::ProgressBar,
    plain: Option<Arc<PlainProgress>>,
    heartbeat: Option<std::thread::JoinHandle<()>>,
}

impl Progress {
    /// Progress of `command` over `total` items of `what` (`scenes`),
    /// announced at once.
    pub(super) fn new(command: &'static str, what: &'static str, total: usize) -> Self {
        let template = format!("{command}: {{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {what} (eta {{eta}})");
        let bar = indicatif::ProgressBar::new(total as u64).with_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        // The clock moves while a slow item runs.
        bar.enable_steady_tick(STEADY_TICK);
        let plain = PlainProgress::off_terminal(command, what, total);
        let heartbeat = plain.as_ref().map(|p| {
            eprintln!("{command}: {total} {what} to run");
            let p = p.clone();
            std::thread::spawn(move || p.heartbeat())
        });
        Self { bar, plain, heartbeat }
    }

    /// One item done.
    pub(super) fn tick(&self) {
        self.bar.inc(1);
        if let Some(p) = &self.plain {
            p.tick();
        }
    }
}

/// A stage of a command that is not counted in items (loading scenes,
/// writing reports): said when it starts, on a terminal or off one, so a
/// slow one is not silence.
pub(super) fn stage(command: &str, what: &str) {
    eprintln!("{command}: {what}");
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
        if let Some(p) = &self.plain {
            p.finish();
        }
        if let Some(h) = self.heartbeat.take() {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_says_what_is_done_how_long_it_took_and_what_is_left() {
        let start = Instant::now();
        let p = PlainProgress {
            command: "evaluate",
            what: "variants",
            total: 4,
            start,
            state: Mutex::new(Counter { done: 0, last: start, finished: false }),
            ended: Condvar::new(),
        };
        let at = |s| start + Duration::from_secs(s);
        assert_eq!(p.line(0, at(95)), "evaluate: 0/4 variants done, 1m35s");
        assert_eq!(p.line(1, at(60)), "evaluate: 1/4 variants done, 1m00s, about 3m00s left");
        assert_eq!(p.line(4, at(240)), "evaluate: 4/4 variants done, 4m00s");
    }

    #[test]
    fn the_heartbeat_ends_with_the_command() {
        let p = PlainProgress::off_terminal("test", "items", 3);
        // Under `cargo test` standard error may be a terminal; build one anyway.
        let p = p.unwrap_or_else(|| {
            let now = Instant::now();
            Arc::new(PlainProgress {
                command: "test",
                what: "items",
                total: 3,
                start: now,
                state: Mutex::new(Counter { done: 0, last: now, finished: false }),
                ended: Condvar::new(),
            })
        });
        let beating = p.clone();
        let h = std::thread::spawn(move || beating.heartbeat());
        p.tick();
        p.finish();
        let begun = Instant::now();
        h.join().unwrap();
        assert!(begun.elapsed() < EVERY, "the heartbeat waited out its period after the end");
        assert_eq!(p.state.lock().unwrap().done, 1);
    }
}
