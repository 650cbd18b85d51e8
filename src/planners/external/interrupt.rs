//! Planners outlive an interrupted harness unless someone ends them: each
//! runs in its own process group, so the terminal's Ctrl-C (SIGINT to the
//! foreground group) does not reach it, and a planner that does not read
//! its stdin never sees the harness go. This module keeps the process
//! groups of live planners in a fixed table and, on SIGINT, SIGTERM,
//! SIGHUP or SIGQUIT, sends SIGKILL to each before the harness dies of the
//! signal as it would have without the handler (same signal, same exit
//! status). SIGKILL runs no handler: there the kernel ends each planner's
//! own process (Linux's parent-death signal, set when it starts), not the
//! helpers it started.
//!
//! The handler is installed at the first planner start, and only for a
//! signal whose disposition is still the default: a program that ignores
//! SIGHUP (under `nohup`) or handles SIGINT itself keeps its choice. It
//! uses only async-signal-safe calls (atomic loads, `kill`, `sigaction`,
//! `raise`). A planner started while the table is full (more than
//! [`SLOTS`] at once) is not covered; its stdin still closes when the
//! harness dies.

use std::sync::Once;
use std::sync::atomic::{AtomicI32, Ordering};

/// Planners tracked at once; far more than a machine's worker threads.
pub(super) const SLOTS: usize = 1024;

/// Process group ids of live planners; 0 marks a free slot.
static GROUPS: [AtomicI32; SLOTS] = [const { AtomicI32::new(0) }; SLOTS];

static INSTALL: Once = Once::new();

/// The signals that end the harness and should end its planners.
#[cfg(unix)]
const SIGNALS: [libc::c_int; 4] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT];

/// Records `pgid` as a live planner's group (installing the handler on
/// first use). Whether a slot was free.
pub(super) fn register(pgid: u32) -> bool {
    INSTALL.call_once(install);
    let Ok(pgid) = i32::try_from(pgid) else { return false };
    if pgid <= 1 {
        return false;
    }
    GROUPS.iter().any(|slot| slot.compare_exchange(0, pgid, Ordering::SeqCst, Ordering::SeqCst).is_ok())
}

/// Forgets `pgid` once its planner is reaped and its group killed.
pub(super) fn unregister(pgid: u32) {
    let Ok(pgid) = i32::try_from(pgid) else { return };
    for slot in &GROUPS {
        if slot.compare_exchange(pgid, 0, Ordering::SeqCst, Ordering::SeqCst).is_ok() {
            return;
        }
    }
}

#[cfg(unix)]
fn install() {
    for signal in SIGNALS {
        // SAFETY: sigaction with a zeroed, then filled, struct; the old
        // action is read first so a non-default disposition is kept. The
        // handler below is async-signal-safe.
        unsafe {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(signal, std::ptr::null(), &mut old) != 0 || old.sa_sigaction != libc::SIG_DFL {
                continue;
            }
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            libc::sigemptyset(&mut action.sa_mask);
            action.sa_flags = libc::SA_RESTART;
            libc::sigaction(signal, &action, std::ptr::null_mut());
        }
    }
}

#[cfg(not(unix))]
fn install() {}

/// Kills every tracked planner group, then dies of `signal` with its
/// default action.
#[cfg(unix)]
extern "C" fn on_signal(signal: libc::c_int) {
    for slot in &GROUPS {
        let pgid = slot.load(Ordering::SeqCst);
        if pgid > 1 {
            // SAFETY: kill(2) is async-signal-safe; a negative pid names the group.
            unsafe {
                libc::kill(-pgid, libc::SIGKILL);
            }
        }
    }
    // SAFETY: restoring the default action and re-raising are
    // async-signal-safe; the signal is delivered when the handler returns.
    unsafe {
        let mut action: libc::sigaction = std::mem::zeroed();
        action.sa_sigaction = libc::SIG_DFL;
        libc::sigemptyset(&mut action.sa_mask);
        libc::sigaction(signal, &action, std::ptr::null_mut());
        libc::raise(signal);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_group_is_tracked_until_unregistered_and_bad_ids_are_refused() {
        // Ids far above any real pid, so no other test's planner clashes.
        assert!(register(2_000_000_001));
        assert!(register(2_000_000_002));
        assert!(!register(0), "group 0 is the harness's own");
        assert!(!register(1), "group 1 is init's");
        assert!(!register(u32::MAX), "not a pid");
        assert!(GROUPS.iter().any(|s| s.load(Ordering::SeqCst) == 2_000_000_001));
        unregister(2_000_000_001);
        unregister(2_000_000_002);
        assert!(!GROUPS.iter().any(|s| matches!(s.load(Ordering::SeqCst), 2_000_000_001 | 2_000_000_002)));
    }
}
