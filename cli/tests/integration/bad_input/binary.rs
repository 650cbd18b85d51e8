//! Running the real `safer` binary under a deadline, and watching the
//! processes it leaves: what every bad-input case that goes through the
//! command line shares.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `safer ARGS` in `cwd` with extra environment variables, killing it
/// after `deadline`; panics on a timeout.
pub(crate) fn safer_in(cwd: &Path, env: &[(&str, &Path)], args: &[&str], deadline: Duration) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_safer"));
    cmd.args(args).current_dir(cwd).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("start safer");
    let started = Instant::now();
    // Drain both pipes on threads: a JSON report on stdout can outgrow the pipe buffer.
    let mut stdout = child.stdout.take().expect("stdout piped");
    let mut stderr = child.stderr.take().expect("stderr piped");
    let out = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut stdout, &mut b).map(|_| b)
    });
    let err = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut stderr, &mut b).map(|_| b)
    });
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for safer") {
            break status;
        }
        if started.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("`safer {}` did not end within {deadline:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stdout = out.join().expect("stdout reader").expect("read stdout");
    let stderr = err.join().expect("stderr reader").expect("read stderr");
    Output { status, stdout, stderr }
}

/// Runs `safer ARGS` in the package folder, killing it after `deadline`;
/// panics on a timeout.
pub(crate) fn safer_within(args: &[&str], deadline: Duration) -> Output {
    safer_in(Path::new(repo_root!()), &[], args, deadline)
}

/// Standard output and standard error, for assertions and their messages.
pub(crate) fn text(out: &Output) -> String {
    format!("stdout:\n{}\nstderr:\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// Live (not zombie) processes, each with its `/proc/PID/stat` fields
/// after the command name: state, parent, process group, ...
fn live_processes() -> Vec<(u32, Vec<String>)> {
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    entries
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter_map(|pid| {
            // `pid (comm) state ppid pgrp ...`; comm may hold spaces.
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
            let (_, rest) = stat.rsplit_once(')')?;
            let fields: Vec<String> = rest.split_whitespace().map(str::to_owned).collect();
            (fields.len() > 2 && !matches!(fields[0].as_str(), "Z" | "X")).then_some((pid, fields))
        })
        .collect()
}

/// Live processes in process group `pgid`, in pid order.
pub(crate) fn live_group_members(pgid: u32) -> Vec<u32> {
    let mut pids: Vec<u32> =
        live_processes().into_iter().filter(|(_, f)| f[2] == pgid.to_string()).map(|(pid, _)| pid).collect();
    pids.sort_unstable();
    pids
}

/// Live children of `parent` whose command line contains `needle`.
pub(crate) fn live_children(parent: u32, needle: &str) -> Vec<u32> {
    live_processes()
        .into_iter()
        .filter(|(pid, f)| {
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            f[1] == parent.to_string() && String::from_utf8_lossy(&cmdline).contains(needle)
        })
        .map(|(pid, _)| pid)
        .collect()
}

/// Whether `pid` is a live (not zombie) process.
pub(crate) fn is_live(pid: u32) -> bool {
    live_processes().iter().any(|(p, _)| *p == pid)
}
