//! Bad input: values that once made the harness loop forever. Each case
//! runs the real `safer` binary with a deadline, so a regression fails
//! here instead of hanging CI; each asserts the verdict and that the
//! message names the file and the place.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::binary::{is_live, live_children, safer_within, text};

fn fixture(name: &str) -> PathBuf {
    Path::new(repo_root!()).join("tests/fixtures/bad-input/hangs").join(name)
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

#[cfg(target_os = "linux")]
#[test]
fn ctrl_c_on_the_harness_ends_a_planner_that_never_reads_its_stdin() {
    // The planner runs in its own process group, so the terminal's SIGINT
    // reaches only the harness; before the handler, the deaf planner
    // outlived it for good.
    the_planner_dies_with_the_harness("INT", 2);
}

#[cfg(target_os = "linux")]
#[test]
fn sigquit_on_the_harness_ends_a_planner_that_never_reads_its_stdin() {
    the_planner_dies_with_the_harness("QUIT", 3);
}

#[cfg(target_os = "linux")]
#[test]
fn sigkill_of_the_harness_ends_a_planner_that_never_reads_its_stdin() {
    // No handler runs: the kernel's parent-death signal ends the planner.
    the_planner_dies_with_the_harness("KILL", 9);
}

/// Runs the deaf-planner suite under `safer`, sends the harness `signal`
/// once the planner is blocking it, and checks that the harness dies of
/// that signal (number `expected`) and takes the planner with it.
#[cfg(target_os = "linux")]
fn the_planner_dies_with_the_harness(signal: &str, expected: i32) {
    use std::os::unix::process::ExitStatusExt;
    let suite = fixture("deaf.suite.yaml");
    let mut command = Command::new(env!("CARGO_BIN_EXE_safer"));
    command.args(["run", suite.to_str().unwrap()]).stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::null());
    // As at a terminal: a test run started in the background of a shell
    // without job control inherits SIGINT and SIGQUIT ignored, which safer
    // keeps.
    // SAFETY: only signal(2), async-signal-safe, between fork and exec.
    unsafe {
        std::os::unix::process::CommandExt::pre_exec(&mut command, || {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            libc::signal(libc::SIGQUIT, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut child = command.spawn().expect("start safer");
    let harness = child.id();
    let started = Instant::now();
    let planner = loop {
        if let Some(&pid) = live_children(harness, "deaf").first() {
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
    let sent = Command::new("kill").args([&format!("-{signal}"), &harness.to_string()]).status().expect("run kill");
    assert!(sent.success());
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for safer") {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = Command::new("kill").args(["-KILL", &planner.to_string()]).status();
            panic!("safer did not end within 30 s of SIG{signal}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    assert_eq!(status.signal(), Some(expected), "the harness dies of SIG{signal} as without a handler: {status:?}");
    let deadline = Instant::now() + Duration::from_secs(2);
    while is_live(planner) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    let alive = is_live(planner);
    if alive {
        let _ = Command::new("kill").args(["-KILL", &planner.to_string()]).status();
    }
    assert!(!alive, "planner {planner} outlived the harness killed by SIG{signal}");
}

/// A fresh folder for one case.
fn temp(tag: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("bad-hangs-{tag}"))
}

#[cfg(unix)]
#[test]
fn a_recorded_folder_with_a_link_back_up_the_tree_is_walked_once() {
    let dir = temp("link-loop");
    std::fs::create_dir(dir.join("scenes")).unwrap();
    let scene = Path::new(repo_root!()).join("scenes/ngsim/USA_US101-4_3_T-1.xml");
    std::fs::copy(scene, dir.join("scenes/one.xml")).unwrap();
    std::os::unix::fs::symlink("..", dir.join("scenes/up")).unwrap();
    let out = safer_within(&["simulate", dir.to_str().unwrap(), "--planner", "log-replay"], Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("1 rollouts"), "the scene once, however many links lead to it: {}", text(&out));
}

#[cfg(unix)]
#[test]
fn a_fifo_given_as_a_scene_is_refused_without_blocking() {
    let dir = temp("fifo");
    let fifo = dir.join("scene.xml");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    let out = safer_within(&["inspect", fifo.to_str().unwrap()], Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("not a regular file"), "{}", text(&out));
    // In a folder it is skipped; the folder holds no scene.
    let out = safer_within(&["simulate", dir.to_str().unwrap()], Duration::from_secs(30));
    assert!(!text(&out).contains("rollouts: 1"), "{}", text(&out));
}

/// A spec in `dir` named `name` holding `text`; `safer run` on it within
/// 10 s: the exit code and everything it printed.
fn run_spec(name: &str, spec: &str) -> (Option<i32>, String) {
    let dir = crate::scratch::Scratch::new(&format!("bad-spec-size-{name}"));
    let path = dir.join(name);
    std::fs::write(&path, spec).unwrap();
    let out = safer_within(&["run", path.to_str().unwrap()], Duration::from_secs(10));
    (out.status.code(), text(&out))
}

#[test]
fn a_spec_of_20_mb_on_one_line_is_refused_at_once_in_a_short_message() {
    // It took 22 s and echoed all 20 MB to stderr.
    let (code, said) = run_spec("huge-line.suite.yaml", &format!("name: {}\n", "a".repeat(20 << 20)));
    assert_eq!(code, Some(2), "{said}");
    assert!(said.contains("the file is larger than 1 MiB, the most a spec may be"), "{said}");
    assert!(said.len() < 1_000, "{} bytes printed", said.len());
}

#[test]
fn a_spec_of_comments_only_is_refused_by_its_size() {
    // 200 MB of comments took 6.4 GB of memory; the size bound refuses it unread.
    let (code, said) = run_spec("comments.suite.yaml", &"# a comment line\n".repeat(200_000));
    assert_eq!(code, Some(2), "{said}");
    assert!(said.contains("larger than 1 MiB"), "{said}");
}

#[test]
fn a_long_line_under_the_size_bound_is_cut_in_the_message() {
    let (code, said) = run_spec("long-line.suite.yaml", &format!("name: x\nscenarios: [{}]\n", "b".repeat(900 << 10)));
    assert_eq!(code, Some(2), "{said}");
    assert!(said.contains("missing field `planner`"), "{said}");
    assert!(said.lines().all(|l| l.chars().count() < 400), "{said}");
    let (code, said) =
        run_spec("deep.suite.yaml", &format!("name: x\nscenarios: {}{}\n", "[".repeat(5000), "]".repeat(5000)));
    assert_eq!(code, Some(2), "{said}");
    assert!(said.contains("lists or mappings nest deeper than the parser allows"), "{said}");
    assert!(said.contains("here (line 2, column "), "the label gives the file's column: {said}");
    assert!(said.lines().all(|l| l.chars().count() < 400), "{said}");
}

#[test]
fn a_womd_json_scene_with_a_byte_order_mark_is_read() {
    // It failed with "expected value at line 1, column 1".
    let dir = crate::scratch::Scratch::new("bad-bom");
    let scene = fixture("folder-with-one-bad-scene/a-good-scene.json");
    let mut bytes = b"\xEF\xBB\xBF".to_vec();
    bytes.extend(std::fs::read(scene).unwrap());
    let file = dir.join("bom.json");
    std::fs::write(&file, bytes).unwrap();
    let out = safer_within(&["inspect", file.to_str().unwrap()], Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}
