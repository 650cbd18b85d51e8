//! Bad input: values that once made the harness loop forever. Each case
//! runs the real `safer` binary with a deadline, so a regression fails
//! here instead of hanging CI; each asserts the verdict and that the
//! message names the file and the place.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bad-input/hangs").join(name)
}

/// Runs `safer ARGS`, killing it after `deadline`; panics on a timeout.
pub(crate) fn safer_within(args: &[&str], deadline: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start safer");
    let started = Instant::now();
    loop {
        if child.try_wait().expect("wait for safer").is_some() {
            return child.wait_with_output().expect("collect safer's output");
        }
        if started.elapsed() > deadline {
            let _ = child.kill();
            let out = child.wait_with_output().expect("collect safer's output");
            panic!(
                "`safer {}` did not end within {deadline:?}\nstdout: {}\nstderr: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

#[test]
fn a_recorded_sample_at_x_1e20_is_refused_naming_the_file_agent_and_step() {
    let file = fixture("womd-json-sample-at-x-1e20.json");
    let out = safer_within(&["simulate", file.to_str().unwrap(), "--planner", "log-replay"], Duration::from_secs(60));
    assert!(!out.status.success());
    let t = text(&out);
    assert!(t.contains("womd-json-sample-at-x-1e20.json"), "{t}");
    assert!(t.contains("agent 0 (track 0), step 20"), "{t}");
    assert!(t.contains("x = 1e20 m"), "{t}");
}

#[test]
fn a_folder_with_one_bad_scene_reports_it_and_runs_the_others() {
    let dir = fixture("folder-with-one-bad-scene");
    let out = safer_within(&["simulate", dir.to_str().unwrap(), "--planner", "log-replay"], Duration::from_secs(60));
    let t = text(&out);
    assert!(!out.status.success(), "a folder with a broken file must not exit 0: {t}");
    assert!(t.contains("b-sample-at-x-1e20.json") && t.contains("x = 1e20 m"), "{t}");
    assert_eq!(t.matches("b-sample-at-x-1e20.json").count(), 1, "the broken file is named once: {t}");
    assert!(t.contains("trimmed-307 ") && t.contains("1 rollouts"), "the good scene did not run: {t}");
}

#[test]
fn a_planner_replying_accel_1e100_fails_its_variant_and_the_run_ends() {
    let suite = fixture("huge-accel.suite.yaml");
    let out = safer_within(&["run", suite.to_str().unwrap()], Duration::from_secs(120));
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("huge-accel") && t.contains("outside the simulation bounds"), "{t}");
}

#[test]
fn a_planner_replying_with_a_point_at_x_1e20_fails_its_variant_and_the_run_ends() {
    let suite = fixture("huge-far.suite.yaml");
    let out = safer_within(&["run", suite.to_str().unwrap()], Duration::from_secs(120));
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("x = 1e20 m is outside the simulation bounds"), "{t}");
}

#[test]
fn a_recorded_road_point_at_x_1e20_is_refused_naming_the_file_and_the_map_feature() {
    // Indexing a 1e20 m road-edge segment once walked ~1e19 grid cells.
    let file = fixture("womd-json-road-point-at-x-1e20.json");
    let out = safer_within(&["simulate", file.to_str().unwrap(), "--planner", "log-replay"], Duration::from_secs(60));
    assert!(!out.status.success());
    let t = text(&out);
    assert!(t.contains("womd-json-road-point-at-x-1e20.json"), "{t}");
    assert!(t.contains("map road edge") && t.contains("point 3"), "{t}");
    assert!(t.contains("implausible map point (1e20, "), "{t}");
}

/// Children of `parent` whose command line contains `needle`, from `/proc`.
#[cfg(target_os = "linux")]
fn children_running(parent: u32, needle: &str) -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    entries
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else { return false };
            let Some((_, rest)) = stat.rsplit_once(')') else { return false };
            let fields: Vec<&str> = rest.split_whitespace().collect();
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            fields.len() > 1
                && !matches!(fields[0], "Z" | "X")
                && fields[1] == parent.to_string()
                && String::from_utf8_lossy(&cmdline).contains(needle)
        })
        .collect()
}

#[cfg(target_os = "linux")]
#[test]
fn ctrl_c_on_the_harness_ends_a_planner_that_never_reads_its_stdin() {
    use std::os::unix::process::ExitStatusExt;
    // The planner runs in its own process group, so the terminal's SIGINT
    // reaches only the harness; before the handler, the deaf planner
    // outlived it for good.
    let suite = fixture("deaf.suite.yaml");
    let mut child = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["run", suite.to_str().unwrap()])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start safer");
    let harness = child.id();
    let started = Instant::now();
    let planner = loop {
        if let Some(&pid) = children_running(harness, "deaf").first() {
            break pid;
        }
        if started.elapsed() > Duration::from_secs(60) || child.try_wait().expect("wait").is_some() {
            let _ = child.kill();
            panic!("the deaf planner never started under safer");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    // Let it answer hello and the harness block on the first step.
    std::thread::sleep(Duration::from_millis(500));
    let sent = Command::new("kill").args(["-INT", &harness.to_string()]).status().expect("run kill");
    assert!(sent.success());
    let status = child.wait().expect("wait for safer");
    assert_eq!(status.signal(), Some(2), "the harness dies of SIGINT as without a handler: {status:?}");
    let deadline = Instant::now() + Duration::from_secs(2);
    while std::path::Path::new(&format!("/proc/{planner}")).exists() && Instant::now() < deadline {
        // A killed orphan is reaped by init; until then it may show as a zombie.
        let state = std::fs::read_to_string(format!("/proc/{planner}/stat")).unwrap_or_default();
        if state.rsplit_once(')').is_some_and(|(_, rest)| rest.trim_start().starts_with('Z')) {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let state = std::fs::read_to_string(format!("/proc/{planner}/stat")).unwrap_or_default();
    let alive = state.rsplit_once(')').is_some_and(|(_, rest)| !rest.trim_start().starts_with('Z'));
    if alive {
        let _ = Command::new("kill").args(["-KILL", &planner.to_string()]).status();
    }
    assert!(!alive, "planner {planner} outlived the interrupted harness");
}
