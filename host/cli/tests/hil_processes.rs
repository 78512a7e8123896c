//! The hardware-in-the-loop workflow as separate processes, as on a rig: `mesopush-fwsim`
//! serves the controller on a pseudo-terminal and the camera on a Unix socket in real time,
//! `mesopush-executor run` opens both, records, and listens for a host on a Unix socket;
//! `mesopush flash` and `mesopush run` drive it. A 2 s push and Table II (≈ 1 min);
//! generous timeouts, no timing assertions. As on a rig, the simulator's controller loop
//! (standing for the controller's own microcontroller) and the executor run at `SCHED_FIFO`
//! priority (`--rt-priority`; refused without the privilege, then they run without): on the
//! loaded 2-core machine a starved simulator tripped the executor's 100 ms controller-silence
//! watchdog. The clock-sync round-trip limit is raised to 20 ms (docs/hil.md).
//!
//! `mesopush-executor` is another package's binary: it is looked for beside this test's
//! target directory (`cargo test --workspace` builds it; alone, `cargo build -p
//! mesopush-executor --profile test` first).

use mesopush_trial::Trial;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const FWSIM: &str = env!("CARGO_BIN_EXE_mesopush-fwsim");
const MESOPUSH: &str = env!("CARGO_BIN_EXE_mesopush");

/// A 2 s push: the probe starts 70 µm right of the peg (Table II's start pose) and pushes
/// it ≈ 330 µm left.
const PLAN: &str = r#"
name = "short push"
speed_um_s = 200.0
probe_start_um = [2900.0, 1000.0]
moves_um = [[-400.0, 0.0]]

[peg_start]
x_um = 2330.0
y_um = 1210.0
theta_deg = 89.0
"#;

/// Kills the child (by its own handle) when dropped, so a failing test leaves no process.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn executor_bin() -> PathBuf {
    let exe = std::env::current_exe().expect("test path");
    let profile_dir = exe.parent().and_then(Path::parent).expect("target/<profile>/deps");
    let bin = profile_dir.join("mesopush-executor");
    assert!(
        bin.exists(),
        "{} not found: build it first (cargo build -p mesopush-executor --profile test)",
        bin.display()
    );
    bin
}

/// Reads the child's stdout lines until one starts with every prefix; returns them.
fn read_banner(child: &mut Child, prefixes: &[&str], timeout: Duration) -> Vec<String> {
    let out = child.stdout.take().expect("piped");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut found = vec![String::new(); prefixes.len()];
    let t = Instant::now();
    while found.iter().any(String::is_empty) {
        let left = timeout.saturating_sub(t.elapsed());
        let line = rx.recv_timeout(left).unwrap_or_else(|_| panic!("banner: got {found:?}"));
        for (i, p) in prefixes.iter().enumerate() {
            if let Some(v) = line.strip_prefix(p) {
                found[i] = v.trim().to_string();
            }
        }
    }
    found
}

/// Runs a command to its end within `timeout` (killing it after).
fn run_cmd(cmd: &mut Command, timeout: Duration) -> Output {
    let child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawns");
    let id = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(timeout) {
        Ok(out) => out.expect("output"),
        Err(_) => {
            let _ = Command::new("kill").arg(id.to_string()).status();
            panic!("{cmd:?} did not finish within {timeout:?}");
        }
    }
}

fn wait_for(path: &Path, timeout: Duration) {
    let t = Instant::now();
    while !path.exists() {
        assert!(t.elapsed() < timeout, "{} did not appear within {timeout:?}", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The three processes on `plan` (seed 3): fwsim (placed at `plan`'s start), the executor,
/// `mesopush flash` and `mesopush run`; returns `run`'s JSON report and the trial directory.
fn hil_trial(d: &Path, plan: &Path, run_timeout: Duration) -> (serde_json::Value, PathBuf) {
    let fw_dir = d.join("fw");
    let mut fwsim = Killed(
        Command::new(FWSIM)
            .args(["--seed", "3", "--rt-priority", "70", "--plan"])
            .arg(plan)
            .arg("--run-dir")
            .arg(&fw_dir)
            .stdout(Stdio::piped())
            .spawn()
            .expect("mesopush-fwsim starts"),
    );
    let prefixes = ["controller:", "camera:", "background:", "truth:", "fixture origin:", "world:"];
    let b = read_banner(&mut fwsim.0, &prefixes, Duration::from_secs(60));
    assert!(b[0].starts_with("/dev/"), "controller device: {b:?}");
    let host_sock = d.join("host.sock");
    let host = format!("unix:{}", host_sock.display());
    let rec = d.join("rec");
    let _executor = Killed(
        Command::new(executor_bin())
            .args(["run", "--host-port", &host, "--ctrl-port", &b[0], "--camera", &b[1]])
            .args(["--fixture-origin-um", &b[4], "--sync-max-rtt-us", "20000"])
            .args(["--rt-priority", "80", "--record-dir"])
            .arg(&rec)
            .arg("--plan-store")
            .arg(d.join("plan.bin"))
            .stdout(Stdio::null())
            .spawn()
            .expect("mesopush-executor starts"),
    );
    wait_for(&host_sock, Duration::from_secs(30));

    let flash = run_cmd(
        Command::new(MESOPUSH).arg("flash").arg(plan).args(["--port", &host, "--json"]),
        Duration::from_secs(120),
    );
    let text = String::from_utf8_lossy(&flash.stdout);
    assert!(flash.status.success(), "flash: {text} {}", String::from_utf8_lossy(&flash.stderr));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["step_count"].as_u64().unwrap() >= 1, "{v}");

    let out = d.join("trial");
    let run = run_cmd(
        Command::new(MESOPUSH)
            .args(["run", "--port", &host, "--json", "--plan"])
            .arg(plan)
            .arg("--record-dir")
            .arg(&rec)
            .args(["--background", &b[2], "--truth", &b[3], "--sim-world", &b[5], "--out"])
            .arg(&out),
        run_timeout,
    );
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "run: {text} {}", String::from_utf8_lossy(&run.stderr));
    (serde_json::from_str(&text).unwrap(), out)
}

#[test]
fn fwsim_executor_flash_and_run_as_separate_processes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let plan = d.join("push.toml");
    std::fs::write(&plan, PLAN).unwrap();
    let (v, out) = hil_trial(d, &plan, Duration::from_secs(240));
    check_report(&v, &out);
}

/// Table II (≈ 52 s at the rig's speed) through the three processes: the whole plan is
/// streamed, filmed, stamped, recorded and tracked to the end without a fault. The
/// simulator renders off its controller loop, so clock-sync replies and reports are not held
/// up by rendering (they were, and the trial faulted: docs/hil.md). Whether the peg ends in
/// the hole is the world's physics (in real time it can wedge: docs/hil.md), checked only
/// as judged here.
#[test]
fn table2_runs_to_the_end_through_separate_processes() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
    let (v, out) = hil_trial(tmp.path(), &plan, Duration::from_secs(300));
    assert_eq!(v["state"], "done", "{v}");
    assert!(v["inserted"].is_boolean(), "a tracked final pose is judged: {v}");
    assert!(v["frames"].as_u64().unwrap() >= 500, "{v}");
    assert!(v["tracked"].as_u64().unwrap() >= 500, "{v}");
    let truth = &v["truth"];
    assert!(truth["frames_compared"].as_u64().unwrap() >= 500, "{v}");
    assert!(truth["stamp_error_us_max_abs"].as_i64().unwrap() <= 2, "{v}");
    assert!(truth["track_error_um_max"].as_f64().unwrap() < 10.0, "{v}");
    let trial = Trial::load(&out).expect("the trial directory reads back");
    assert!(trial.events.iter().any(|e| e.kind == "done"));
    assert!(trial.meta.world.is_some(), "the simulated world is recorded");
}

fn check_report(v: &serde_json::Value, out: &Path) {
    assert_eq!(v["state"], "done", "{v}");
    assert_eq!(v["inserted"], false, "a 400 µm push does not insert: {v}");
    let x = v["final_pose"]["x_um"].as_f64().expect("a tracked final pose");
    // The probe's 400 µm stroke, 70 µm of it before contact: the peg's centre moves left by
    // up to 330 µm (less as it turns).
    assert!((1950.0..2130.0).contains(&x), "peg pushed from x 2330 to {x}: {v}");
    assert!(v["frames"].as_u64().unwrap() >= 30, "{v}");
    assert!(v["tracked"].as_u64().unwrap() >= 30, "{v}");
    assert!(v["telemetry"].as_u64().unwrap() >= 10, "{v}");
    let truth = &v["truth"];
    assert!(truth["frames_compared"].as_u64().unwrap() >= 30, "{v}");
    // Driver stamps through CLOCK_MONOTONIC: exact up to the µs rounding of two conversions.
    assert!(truth["stamp_error_us_max_abs"].as_i64().unwrap() <= 2, "{v}");
    assert!(truth["track_error_um_max"].as_f64().unwrap() < 10.0, "{v}");
    let trial = Trial::load(out).expect("the trial directory reads back");
    assert_eq!(trial.meta.outcome.inserted, Some(false));
    assert!(trial.probe.len() > 150, "2 s of 100 Hz setpoints: {}", trial.probe.len());
    assert!(trial.probe.iter().any(|r| r.rep_x_um.is_some()), "position reports recorded");
    assert!(trial.poses().unwrap().len() >= 30);
    let pngs = trial.frames.iter().filter_map(|f| f.file.as_ref()).count();
    // The first stored image, not row 0: under load the camera can drop frames around the
    // trial's start, and the recorder keeps a row without an image for each (regression: CI
    // failed here on `frames[0].file` being None, the trial itself was fine).
    let first = trial.frames.iter().find_map(|f| f.file.as_ref()).expect("a stored frame");
    assert!(pngs >= 30 && out.join(first).exists(), "{pngs} images, first {first}");
    assert!(trial.events.iter().any(|e| e.kind == "started"));
    assert!(trial.events.iter().any(|e| e.kind == "done"));
    assert!(trial.events.iter().any(|e| e.kind == "verdict"));
    // The simulated world, as the simulator described it, and its seed.
    let world = trial.meta.world.as_ref().expect("trial.json records the simulated world");
    assert!(world["toml"].as_str().is_some_and(|t| t.contains("[camera]")), "{world}");
    assert_eq!(trial.meta.seeds.get("world"), Some(&3));
}

#[test]
fn bad_input_gives_a_clear_error_not_a_panic() {
    let tmp = tempfile::tempdir().unwrap();
    let nowhere = format!("unix:{}", tmp.path().join("none.sock").display());
    let flash = run_cmd(
        Command::new(MESOPUSH).args(["flash", "plans/none.toml", "--port", &nowhere]),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&flash.stderr);
    assert!(!flash.status.success() && err.starts_with("error:"), "{err}");
    assert!(err.contains("none.toml") && !err.contains("panicked"), "{err}");
    let run =
        run_cmd(Command::new(MESOPUSH).args(["run", "--port", &nowhere]), Duration::from_secs(60));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("none.sock"), "{err}");
    assert!(err.contains("is `mesopush-executor run --host-port` listening"), "{err}");
    let fw =
        run_cmd(Command::new(FWSIM).args(["--world", "worlds/none.toml"]), Duration::from_secs(60));
    let err = String::from_utf8_lossy(&fw.stderr);
    assert!(
        !fw.status.success() && err.contains("none.toml") && !err.contains("panicked"),
        "{err}"
    );
}

/// `mesopush demo --realtime` on the 2 s push: the in-process real-time loop (executor shell
/// on a pseudo-terminal, controller served in real time, frames drawn on a painter thread)
/// runs the plan to its end and records every stamped frame with its image. Regression: the
/// loop rendered on the controller's thread, answered clock-sync requests late and the trial
/// faulted `ClockSyncLost` even on an idle machine.
#[test]
fn demo_realtime_runs_to_the_end_with_every_frame_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = tmp.path().join("push.toml");
    std::fs::write(&plan, PLAN).unwrap();
    let out = tmp.path().join("demo");
    let o = Command::new(MESOPUSH)
        .args(["demo", "--realtime", "--seed", "3", "--json", "--plan"])
        .arg(&plan)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "seed 3: {}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["state"], "done", "seed 3: {v}");
    assert_eq!(v["segments_applied"], v["segments_expected"], "seed 3: {v}");
    let frames = v["frames"].as_u64().unwrap();
    assert!(frames >= 50, "seed 3: 2 s at 30 Hz: {frames} frames");
    let pngs = std::fs::read_dir(out.join("frames")).unwrap().count() as u64;
    let lost = v["records_lost"].as_u64().unwrap();
    assert_eq!(pngs + lost, frames, "seed 3: every frame recorded with its image or counted lost");
}
