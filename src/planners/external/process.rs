//! The planner's process: spawning it (in its own process group on Unix,
//! with the configured arguments, environment and working directory), the
//! threads that write its stdin and read its stdout and stderr with bounded
//! line lengths, one request/reply exchange under a timeout, the stderr tail
//! kept for crash reports, and ending it: `bye`, a grace period, then
//! SIGKILL to the whole process group (so children of a wrapper script or
//! of the planner die with it), always reaping the process. Live groups are
//! registered with [`super::interrupt`] so an interrupted harness ends them.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, SyncSender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::ExternalPlannerConfig;
use super::encoding::{parse_reply, quote, truncate_chars};
use super::wire::{HarnessMessage, PlannerMessage};
use crate::planners::PlannerError;

/// Stderr lines kept for error messages.
const STDERR_LINES: usize = 20;
/// Bytes of stderr kept in full for the variant's artefacts; the rest is
/// dropped and `[truncated]` marks the cut (a planner logging without end
/// must not exhaust the harness's memory).
pub(super) const STDERR_LOG_BYTES: usize = 8 << 20;
/// Characters kept of each stderr line.
const STDERR_LINE_CHARS: usize = 500;
/// Bytes read of one stdout line before it is refused: a planner that
/// prints without newlines must not exhaust the harness's memory.
const MAX_REPLY_BYTES: usize = 16 << 20;
/// Stdout lines queued between the reader thread and the harness.
const STDOUT_QUEUE_LINES: usize = 64;
/// Bytes read of one stderr line (the rest is skipped).
const MAX_STDERR_LINE_BYTES: usize = 4096;
/// Time a process gets to exit after `bye` before it is killed.
pub(super) const BYE_GRACE: Duration = Duration::from_millis(1000);
/// Time a process that closed its stdout gets to report an exit status.
const EXIT_STATUS_WAIT: Duration = Duration::from_millis(1000);
/// Time the stderr reader gets to drain the last lines of a dead process.
const STDERR_DRAIN_WAIT: Duration = Duration::from_millis(500);
/// Time the I/O threads get to finish after the process is gone; a
/// grandchild holding the pipes open must not block the harness.
const THREAD_JOIN_WAIT: Duration = Duration::from_millis(200);

/// What the stdout reader thread saw.
enum StdoutEvent {
    /// A complete line, without its line ending.
    Line(Vec<u8>),
    /// A complete line that had already been written when the line before
    /// it was taken: written before the harness could ask the question it
    /// would answer (the harness asks its next question only once it has
    /// the answer to the last). Reported apart so that a line nobody asked
    /// for is caught however the reader thread is scheduled, not only when
    /// it is found waiting before a question.
    Early(Vec<u8>),
    /// A line longer than [`MAX_REPLY_BYTES`]; its beginning.
    TooLong(Vec<u8>),
    /// Reading failed.
    Failed(String),
}

/// A running child process with its stdin writer and stdout/stderr readers.
/// Stdin is written on a thread so that a planner that stops reading can
/// only make the harness time out, never block it.
pub(super) struct Process {
    child: Child,
    /// Process id; on Unix also the id of its process group.
    pub(super) pid: u32,
    /// Lines for the stdin writer; dropping it closes the child's stdin.
    to_stdin: Option<Sender<String>>,
    /// Lines from stdout; disconnected at end of file.
    from_stdout: Receiver<StdoutEvent>,
    /// The last stderr lines.
    stderr_tail: Arc<Mutex<VecDeque<String>>>,
    /// Everything it wrote to stderr, up to [`STDERR_LOG_BYTES`].
    stderr_log: Arc<Mutex<String>>,
    /// Disconnects when the stderr reader has read everything.
    stderr_done: Receiver<()>,
    threads: Vec<JoinHandle<()>>,
    /// Exit status once reaped.
    exited: Option<ExitStatus>,
}

impl Process {
    /// Starts the configured command with piped stdin/stdout/stderr.
    pub(super) fn spawn(config: &ExternalPlannerConfig) -> Result<Self, PlannerError> {
        let spawn_failed = |reason: String| PlannerError::SpawnFailed {
            planner: config.name.clone(),
            command: config.command.clone(),
            reason,
        };
        let mut command = Command::new(&config.command);
        command
            .args(&config.args)
            .envs(&config.env)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        // Its own process group (id = its pid), so that ending it can reach
        // whatever it started: a wrapper script's planner, a planner's helpers.
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut command, 0);
        // A harness killed outright (SIGKILL) runs no handler: the kernel
        // kills the planner's own process when the harness thread that
        // started it dies (helpers it started are not covered). A planner
        // lives within one rollout on the thread that started it.
        // SAFETY: only prctl(2) and getppid(2), async-signal-safe, between
        // fork and exec.
        #[cfg(target_os = "linux")]
        unsafe {
            let harness = libc::getpid();
            std::os::unix::process::CommandExt::pre_exec(&mut command, move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) == -1 {
                    return Err(std::io::Error::last_os_error());
                }
                // The harness may have died between fork and prctl.
                if libc::getppid() != harness {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
        if let Some(dir) = &config.working_dir {
            command.current_dir(dir);
        }
        let mut child = command.spawn().map_err(|e| {
            let place = config.working_dir.as_ref().map(|d| format!(" (working directory {})", d.display()));
            spawn_failed(format!("{e}{}", place.unwrap_or_default()))
        })?;
        let pid = child.id();
        let (Some(stdin), Some(stdout), Some(stderr)) = (child.stdin.take(), child.stdout.take(), child.stderr.take())
        else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(spawn_failed("its standard streams could not be piped".into()));
        };
        let (to_stdin, stdin_rx) = mpsc::channel::<String>();
        // Bounded: a planner flooding stdout is held back by the pipe instead
        // of filling the harness's memory (it fails at its next step anyway).
        let (stdout_tx, from_stdout) = mpsc::sync_channel(STDOUT_QUEUE_LINES);
        let (stderr_done_tx, stderr_done) = mpsc::channel::<()>();
        let stderr_tail = Arc::new(Mutex::new(VecDeque::new()));
        let stderr_log = Arc::new(Mutex::new(String::new()));
        // Killed with the harness on SIGINT/SIGTERM/SIGHUP, which its own
        // process group would not otherwise receive.
        super::interrupt::register(pid);
        let mut process = Process {
            child,
            pid,
            to_stdin: Some(to_stdin),
            from_stdout,
            stderr_tail: stderr_tail.clone(),
            stderr_log: stderr_log.clone(),
            stderr_done,
            threads: Vec::new(),
            exited: None,
        };
        // Thread names may not contain NUL (spawning would panic).
        let name = config.name.replace('\0', "?");
        let spawned = [
            std::thread::Builder::new()
                .name(format!("planner {name} stdin"))
                .spawn(move || write_lines(stdin, stdin_rx)),
            std::thread::Builder::new()
                .name(format!("planner {name} stdout"))
                .spawn(move || read_stdout(stdout, stdout_tx)),
            std::thread::Builder::new()
                .name(format!("planner {name} stderr"))
                .spawn(move || read_stderr(stderr, stderr_tail, stderr_log, stderr_done_tx)),
        ];
        for thread in spawned {
            match thread {
                Ok(handle) => process.threads.push(handle),
                Err(e) => {
                    process.kill();
                    return Err(spawn_failed(format!("could not start an I/O thread: {e}")));
                }
            }
        }
        Ok(process)
    }

    /// Sends `message` and waits up to `timeout_ms` for one reply line.
    pub(super) fn exchange(
        &mut self,
        planner: &str,
        message: &HarnessMessage,
        during: &str,
        timeout_ms: u64,
    ) -> Result<PlannerMessage, PlannerError> {
        let protocol =
            |message: String| PlannerError::Protocol { planner: planner.into(), during: during.into(), message };
        // A line waiting before the question is asked is an answer to no
        // question (often debug output printed to stdout): the protocol
        // would be out of step from here on.
        loop {
            match self.from_stdout.try_recv() {
                Ok(StdoutEvent::Line(l) | StdoutEvent::Early(l)) if is_blank(&l) => continue,
                Ok(StdoutEvent::Line(l) | StdoutEvent::Early(l) | StdoutEvent::TooLong(l)) => {
                    return Err(protocol(unasked(&l)));
                }
                Ok(StdoutEvent::Failed(e)) => return Err(protocol(format!("reading its stdout failed: {e}"))),
                Err(TryRecvError::Disconnected) => return Err(self.crashed(planner, during)),
                Err(TryRecvError::Empty) => break,
            }
        }
        let line = match serde_json::to_string(message) {
            Ok(mut line) => {
                line.push('\n');
                line
            }
            Err(e) => return Err(protocol(format!("the harness could not encode its message: {e}"))),
        };
        // No deadline (wait for ever) when a huge timeout overflows the clock.
        let deadline = Instant::now().checked_add(Duration::from_millis(timeout_ms));
        let sent = self.to_stdin.as_ref().is_some_and(|tx| tx.send(line).is_ok());
        if !sent {
            // The writer stopped: writing failed because stdin is closed.
            return Err(self.crashed(planner, during));
        }
        loop {
            let left = deadline.map_or(Duration::MAX, |d| d.saturating_duration_since(Instant::now()));
            match self.from_stdout.recv_timeout(left) {
                Ok(StdoutEvent::Line(l) | StdoutEvent::Early(l)) if is_blank(&l) => continue,
                Ok(StdoutEvent::Line(l)) => return parse_reply(&l).map_err(protocol),
                // Written before this question was asked: not its answer.
                Ok(StdoutEvent::Early(l)) => return Err(protocol(unasked(&l))),
                Ok(StdoutEvent::TooLong(l)) => {
                    return Err(protocol(format!(
                        "it printed a line longer than {MAX_REPLY_BYTES} bytes: {}",
                        quote(&l)
                    )));
                }
                Ok(StdoutEvent::Failed(e)) => return Err(protocol(format!("reading its stdout failed: {e}"))),
                Err(RecvTimeoutError::Timeout) => {
                    return Err(PlannerError::Timeout { planner: planner.into(), during: during.into(), timeout_ms });
                }
                Err(RecvTimeoutError::Disconnected) => return Err(self.crashed(planner, during)),
            }
        }
    }

    /// The error for a process whose stdout (or stdin) closed: its exit
    /// status and the tail of its stderr.
    fn crashed(&mut self, planner: &str, during: &str) -> PlannerError {
        let what = match self.wait_exit(EXIT_STATUS_WAIT) {
            Some(status) => format!("exited with {status}"),
            None => {
                self.kill();
                "closed its stdout without exiting (killed)".into()
            }
        };
        // Disconnected = the reader saw end of file: the tail is complete.
        let _ = self.stderr_done.recv_timeout(STDERR_DRAIN_WAIT);
        PlannerError::Crashed { planner: planner.into(), what, during: during.into(), stderr_tail: self.stderr_tail() }
    }

    /// Kills the process (so it stops at once) and passes the error through.
    pub(super) fn fail(&mut self, error: PlannerError) -> PlannerError {
        self.kill();
        error
    }

    /// Everything it wrote to stderr so far (lines, each ending in `\n`).
    pub(super) fn stderr_log(&self) -> String {
        self.stderr_log.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    pub(super) fn stderr_tail(&self) -> Vec<String> {
        self.stderr_tail.lock().unwrap_or_else(|e| e.into_inner()).iter().cloned().collect()
    }

    /// Waits up to `timeout` for the process to exit; its status if it did.
    fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        let mut pause = Duration::from_millis(1);
        while self.exited.is_none() {
            match self.child.try_wait() {
                Ok(Some(status)) => self.reaped(status),
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(pause);
                    pause = (pause * 2).min(Duration::from_millis(20));
                }
                Ok(None) | Err(_) => break,
            }
        }
        self.exited
    }

    /// Kills the process and its process group, reaps the process, then
    /// lets the I/O threads finish.
    pub(super) fn kill(&mut self) {
        self.to_stdin = None;
        if self.exited.is_none() {
            // Not reaped yet (running or a zombie), so its pid still names
            // its group: the signal cannot reach an unrelated process.
            kill_group(self.pid);
            // The process itself, also where there are no process groups.
            let _ = self.child.kill();
            if let Ok(status) = self.child.wait() {
                self.reaped(status);
            }
        }
        self.join_threads();
    }

    /// Records the exit status of the reaped process and kills what is left
    /// of its process group (children it did not take with it).
    fn reaped(&mut self, status: ExitStatus) {
        self.exited = Some(status);
        // A group id stays allocated while any member lives, so this reaches
        // only leftovers of this planner; with none left it finds no group
        // (the pid could be reused only after a full cycle of pids, which
        // cannot pass between the reap just now and this call).
        kill_group(self.pid);
        super::interrupt::unregister(self.pid);
    }

    /// `bye`, close stdin, wait [`BYE_GRACE`], then kill.
    pub(super) fn shutdown(&mut self) {
        if self.exited.is_none()
            && let Some(tx) = self.to_stdin.take()
            && let Ok(mut line) = serde_json::to_string(&HarnessMessage::Bye)
        {
            line.push('\n');
            // The writer sends it, then sees the channel closed and closes
            // the child's stdin.
            let _ = tx.send(line);
        }
        self.to_stdin = None;
        self.wait_exit(BYE_GRACE);
        self.kill();
    }

    /// Joins the I/O threads; ones still blocked after [`THREAD_JOIN_WAIT`]
    /// (a grandchild holding a pipe) are left to end with the pipe.
    fn join_threads(&mut self) {
        let deadline = Instant::now() + THREAD_JOIN_WAIT;
        while self.threads.iter().any(|t| !t.is_finished()) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        for t in std::mem::take(&mut self.threads) {
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        if self.exited.is_none() {
            self.shutdown();
        } else {
            self.join_threads();
        }
    }
}

/// Sends SIGKILL to every process in process group `pgid` (the planner and
/// whatever it started that did not leave the group). A process that made
/// itself a new session or group (`setsid`, a daemon) is out of reach.
#[cfg(unix)]
fn kill_group(pgid: u32) {
    // 0 would mean the harness's own group and 1 init's: never those.
    if let Ok(pgid) = libc::pid_t::try_from(pgid)
        && pgid > 1
    {
        // SAFETY: kill(2) takes plain integers and touches no memory of ours;
        // a negative pid addresses the process group. An error (ESRCH: the
        // group is empty) needs no handling.
        unsafe {
            libc::kill(-pgid, libc::SIGKILL);
        }
    }
}

/// Without process groups only the planner's own process is killed.
#[cfg(not(unix))]
fn kill_group(_pgid: u32) {}

/// Stdin writer: one line per message until the channel closes (then stdin
/// is closed by dropping it) or writing fails (the child closed its stdin).
fn write_lines(mut stdin: ChildStdin, lines: Receiver<String>) {
    for line in lines {
        if stdin.write_all(line.as_bytes()).and_then(|()| stdin.flush()).is_err() {
            break;
        }
    }
}

/// Stdout reader: forwards lines until end of file (dropping the sender
/// tells the harness) or until nobody listens.
fn read_stdout(stdout: impl Read, events: SyncSender<StdoutEvent>) {
    let mut reader = BufReader::new(stdout);
    // Whether what is buffered now was read before the last line was taken.
    let mut written_early = false;
    loop {
        let mut line = Vec::new();
        // A line past the limit ends the read at once: waiting for its end
        // would wait on a planner that may never write one.
        let read = read_line_limited(&mut reader, &mut line, MAX_REPLY_BYTES, LongLine::Stop);
        let early = std::mem::replace(&mut written_early, !reader.buffer().is_empty());
        let event = match read {
            Ok(LineRead::Eof) => return,
            Ok(LineRead::Complete) if early => StdoutEvent::Early(line),
            Ok(LineRead::Complete) => StdoutEvent::Line(line),
            Ok(LineRead::Truncated) => StdoutEvent::TooLong(line),
            Err(e) => StdoutEvent::Failed(e.to_string()),
        };
        // After a line too long the stream's framing is lost: stop reading.
        let stop = matches!(event, StdoutEvent::Failed(_) | StdoutEvent::TooLong(_));
        if events.send(event).is_err() || stop {
            return;
        }
    }
}

/// The error for a line the planner wrote before any question it could
/// answer: a protocol message (most likely a second reply to the last
/// observation) or other output.
fn unasked(line: &[u8]) -> String {
    if parse_reply(line).is_ok() {
        format!(
            "it sent a message nobody asked for: {} (one reply per observation: a reply too many puts every later \
             one out of step)",
            quote(line)
        )
    } else {
        format!(
            "it printed a line nobody asked for: {} (stdout is for protocol messages only; log to stderr)",
            quote(line)
        )
    }
}

/// Stderr reader: keeps the last [`STDERR_LINES`] lines and the whole
/// log up to [`STDERR_LOG_BYTES`]; `done` is dropped at end of file.
fn read_stderr(stderr: impl Read, tail: Arc<Mutex<VecDeque<String>>>, log: Arc<Mutex<String>>, done: Sender<()>) {
    let mut reader = BufReader::new(stderr);
    loop {
        let mut line = Vec::new();
        match read_line_limited(&mut reader, &mut line, MAX_STDERR_LINE_BYTES, LongLine::Skip) {
            Ok(LineRead::Eof) | Err(_) => break,
            Ok(LineRead::Complete | LineRead::Truncated) => {
                {
                    let mut log = log.lock().unwrap_or_else(|e| e.into_inner());
                    if log.len() < STDERR_LOG_BYTES {
                        log.push_str(&String::from_utf8_lossy(&line));
                        log.push('\n');
                    } else if !log.ends_with("[truncated]\n") {
                        log.push_str("[truncated]\n");
                    }
                }
                let mut tail = tail.lock().unwrap_or_else(|e| e.into_inner());
                tail.push_back(truncate_chars(&String::from_utf8_lossy(&line), STDERR_LINE_CHARS));
                while tail.len() > STDERR_LINES {
                    tail.pop_front();
                }
            }
        }
    }
    drop(done);
}

/// How a bounded line read ended.
enum LineRead {
    /// End of file before any byte.
    Eof,
    /// A whole line (or the last, unterminated one).
    Complete,
    /// The line was longer than the limit; `buf` holds its beginning and the
    /// rest was skipped.
    Truncated,
}

/// What [`read_line_limited`] does with a line longer than its limit.
#[derive(Clone, Copy, PartialEq, Eq)]
enum LongLine {
    /// Skip the rest, up to its newline (stderr: logging goes on).
    Skip,
    /// Return at once, the rest unread.
    Stop,
}

/// Reads one line into `buf` (without `\n` or `\r\n`), keeping at most
/// `limit` bytes of it.
fn read_line_limited(
    reader: &mut impl BufRead,
    buf: &mut Vec<u8>,
    limit: usize,
    long_line: LongLine,
) -> std::io::Result<LineRead> {
    let mut truncated = false;
    let mut any = false;
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if available.is_empty() {
            break;
        }
        any = true;
        let (chunk, used, end) = match available.iter().position(|&b| b == b'\n') {
            Some(i) => (&available[..i], i + 1, true),
            None => (available, available.len(), false),
        };
        let room = limit.saturating_sub(buf.len());
        truncated |= chunk.len() > room;
        let kept = chunk.len().min(room);
        buf.extend_from_slice(&chunk[..kept]);
        if truncated && long_line == LongLine::Stop {
            reader.consume(kept);
            return Ok(LineRead::Truncated);
        }
        reader.consume(used);
        if end {
            break;
        }
    }
    if !any {
        return Ok(LineRead::Eof);
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    Ok(if truncated { LineRead::Truncated } else { LineRead::Complete })
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
}

/// The stderr part of a crash message (used by [`PlannerError::Crashed`]).
pub(crate) fn format_stderr_tail(lines: &[String]) -> String {
    if lines.is_empty() {
        "; it wrote nothing to stderr".into()
    } else {
        let mut s = format!("; the last {} lines of its stderr:", lines.len());
        for l in lines {
            s.push_str("\n  | ");
            s.push_str(l);
        }
        s
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::planners::external::ExternalPlanner;

    /// A reader handing out its bytes in the chunks given, as a pipe does
    /// what was written by the time of each read.
    struct Chunks(VecDeque<&'static [u8]>);

    impl Read for Chunks {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let Some(chunk) = self.0.pop_front() else { return Ok(0) };
            buf[..chunk.len()].copy_from_slice(chunk);
            Ok(chunk.len())
        }
    }

    /// The stdout reader's events for `chunks`: `L` a line, `E` a line
    /// written before the line before it was taken.
    fn stdout_events(chunks: &[&'static [u8]]) -> Vec<String> {
        let (tx, rx) = mpsc::sync_channel(16);
        read_stdout(Chunks(chunks.iter().copied().collect()), tx);
        rx.try_iter()
            .map(|e| match e {
                StdoutEvent::Line(l) => format!("L {}", String::from_utf8_lossy(&l)),
                StdoutEvent::Early(l) => format!("E {}", String::from_utf8_lossy(&l)),
                StdoutEvent::TooLong(_) | StdoutEvent::Failed(_) => "other".into(),
            })
            .collect()
    }

    #[test]
    fn lines_written_before_the_line_before_them_was_taken_are_early_however_the_reader_runs() {
        // One answer a read, as a planner answering each question writes them.
        assert_eq!(stdout_events(&[b"a\n", b"b\n", b"c\n"]), ["L a", "L b", "L c"]);
        // All at once, as a planner that never reads writes them: every
        // line after the first was there before the one before it was taken.
        assert_eq!(stdout_events(&[b"a\nb\nc\n"]), ["L a", "E b", "E c"]);
        // A line split over two reads is one line; what follows it in the
        // same read is early.
        assert_eq!(stdout_events(&[b"a\nb", b"b\nc\n"]), ["L a", "E bb", "E c"]);
        // A blank line behind an answer is early too (the exchange skips it).
        assert_eq!(stdout_events(&[b"a\n\n", b"b\n"]), ["L a", "E ", "L b"]);
    }

    #[test]
    fn stderr_keeps_a_bounded_tail_and_long_lines_are_cut() {
        let text: String = (0..100).map(|i| format!("line {i}\n")).collect::<String>() + &"y".repeat(10_000);
        let tail = Arc::new(Mutex::new(VecDeque::new()));
        let log = Arc::new(Mutex::new(String::new()));
        let (done, done_rx) = mpsc::channel();
        read_stderr(text.as_bytes(), tail.clone(), log.clone(), done);
        assert!(matches!(done_rx.recv(), Err(mpsc::RecvError)));
        // The whole log is kept (each line cut at 4096 bytes, like the pipe reader's).
        let log = log.lock().unwrap();
        assert!(log.starts_with("line 0\nline 1\n") && log.contains("line 99\n"), "{}", &log[..40]);
        assert_eq!(log.lines().count(), 101);
        let tail = tail.lock().unwrap();
        assert_eq!(tail.len(), STDERR_LINES);
        assert_eq!(tail[0], "line 81");
        assert_eq!(tail[STDERR_LINES - 1].chars().count(), STDERR_LINE_CHARS + 1);

        let mut reader = BufReader::with_capacity(7, "abcdefghij\r\nxy".as_bytes());
        let mut buf = Vec::new();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4, LongLine::Skip).unwrap(), LineRead::Truncated));
        assert_eq!(buf, b"abcd");
        buf.clear();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4, LongLine::Skip).unwrap(), LineRead::Complete));
        assert_eq!(buf, b"xy");
        buf.clear();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4, LongLine::Skip).unwrap(), LineRead::Eof));
        // Stopping at the limit reads no further than it: an endless line
        // is reported as soon as it passes the limit.
        let mut endless = BufReader::with_capacity(7, std::io::repeat(b'x'));
        buf.clear();
        assert!(matches!(read_line_limited(&mut endless, &mut buf, 4, LongLine::Stop).unwrap(), LineRead::Truncated));
        assert_eq!(buf, b"xxxx");
    }

    /// Live (not zombie) processes in process group `pgid`, from `/proc`.
    pub(crate) fn live_group_members(pgid: u32) -> Vec<u32> {
        let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
        entries
            .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
            .filter(|pid| {
                // `pid (comm) state ppid pgrp ...`; comm may hold spaces.
                let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else { return false };
                let Some((_, rest)) = stat.rsplit_once(')') else { return false };
                let fields: Vec<&str> = rest.split_whitespace().collect();
                fields.len() > 2 && fields[0] != "Z" && fields[0] != "X" && fields[2] == pgid.to_string()
            })
            .collect()
    }

    /// The live members of group `pgid` once they are gone, or after 2 s.
    /// A SIGKILLed process still runs until the kernel next schedules it,
    /// and a grandchild (not ours to reap) lingers as long again on a busy
    /// machine: asserting the very moment after the kill raced with that.
    #[cfg(target_os = "linux")]
    fn group_members_after_settling(pgid: u32) -> Vec<u32> {
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            let members = live_group_members(pgid);
            if members.is_empty() || Instant::now() >= deadline {
                return members;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn misbehaving(mode: &str) -> ExternalPlannerConfig {
        let mut c = ExternalPlannerConfig::new(mode, "python3");
        c.args = vec![format!("{}/planners/misbehaving_planner.py", env!("CARGO_MANIFEST_DIR")), mode.into()];
        c
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn drop_kills_the_children_a_planner_left_behind() {
        let planner = ExternalPlanner::start(misbehaving("spawn-child"), 4.5, 2.0).unwrap();
        let pgid = planner.pid().unwrap();
        let child: u32 = planner.announced_name().unwrap().rsplit_once("child=").unwrap().1.parse().unwrap();
        let mut members = live_group_members(pgid);
        members.sort_unstable();
        let mut expected = vec![pgid, child];
        expected.sort_unstable();
        assert_eq!(members, expected, "the planner and its child, in one group");
        drop(planner);
        assert_eq!(group_members_after_settling(pgid), Vec::<u32>::new(), "the planner's child {child} outlived it");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn kill_ends_a_wrapper_script_and_the_planner_under_it() {
        let mut c = ExternalPlannerConfig::new("wrapped", "sh");
        let wrapper = "tests/fixtures/bad-input/planners/wrapper-without-exec.sh";
        c.args = vec![format!("{}/{wrapper}", env!("CARGO_MANIFEST_DIR")), "deaf".into()];
        let mut process = Process::spawn(&c).unwrap();
        let hello = HarnessMessage::Hello {
            protocol: 1,
            protocol_minor: 1,
            dt_s: 0.1,
            ego: super::super::wire::EgoSize { length_m: 4.5, width_m: 2.0 },
            step_timeout_s: 1.0,
            first_step_timeout_s: 1.0,
            startup_timeout_s: 10.0,
            scenario: None,
            origin_world: None,
            horizon: None,
            goal: None,
        };
        let ready = process.exchange("wrapped", &hello, "during startup", 10_000).unwrap();
        assert_eq!(ready.kind(), "ready");
        let pgid = process.pid;
        // The shell and python.
        assert_eq!(live_group_members(pgid).len(), 2, "{:?}", live_group_members(pgid));
        let t0 = Instant::now();
        process.kill();
        assert!(t0.elapsed() < Duration::from_secs(1), "{:?}", t0.elapsed());
        assert_eq!(group_members_after_settling(pgid), Vec::<u32>::new());
    }

    #[test]
    fn a_timeout_beyond_the_clock_waits_without_panicking() {
        let mut c = misbehaving("error");
        c.startup_timeout_ms = u64::MAX;
        let planner = ExternalPlanner::start(c, 4.5, 2.0).unwrap();
        assert_eq!(planner.announced_name(), Some("misbehaving-error"));
    }

    #[test]
    fn env_and_working_dir_reach_the_process() {
        // A planner that answers `ready` with its working directory and an
        // environment variable as its name.
        let mut c = ExternalPlannerConfig::new("env", "python3");
        c.args = vec![
            "-c".into(),
            "import json,os,sys; sys.stdin.readline(); print(json.dumps({'type':'ready','protocol':1,'name':os.getcwd()+'|'+os.environ['SAFER_TEST']}), flush=True); sys.stdin.readline()".into(),
        ];
        c.working_dir = Some(std::env::temp_dir());
        c.env = [("SAFER_TEST".to_string(), "42".to_string())].into();
        let planner = ExternalPlanner::start(c, 4.5, 2.0).unwrap();
        let dir = std::env::temp_dir().canonicalize().unwrap();
        assert_eq!(planner.announced_name(), Some(format!("{}|42", dir.display()).as_str()));
    }
}
