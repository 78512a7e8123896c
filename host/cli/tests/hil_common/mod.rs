//! Shared by the hardware-in-the-loop process tests: start `mesopush-fwsim` and
//! `mesopush-executor` as a rig, run `mesopush` commands against them with deadlines.
#![allow(dead_code, unreachable_pub)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

pub const FWSIM: &str = env!("CARGO_BIN_EXE_mesopush-fwsim");
pub const MESOPUSH: &str = env!("CARGO_BIN_EXE_mesopush");

/// Kills the child (by its own handle) when dropped, so a failing test leaves no process.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub fn executor_bin() -> PathBuf {
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
pub fn read_banner(child: &mut Child, prefixes: &[&str], timeout: Duration) -> Vec<String> {
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
pub fn run_cmd(cmd: &mut Command, timeout: Duration) -> Output {
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

pub fn wait_for(path: &Path, timeout: Duration) {
    let t = Instant::now();
    while !path.exists() {
        assert!(t.elapsed() < timeout, "{} did not appear within {timeout:?}", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `mesopush-fwsim` (seed 3, probe and peg placed at `plan`'s start) and `mesopush-executor`
/// running, as on a rig between trials.
pub struct RigProcs {
    _fwsim: Killed,
    _executor: Killed,
    /// The executor's host line, `unix:PATH`.
    pub host: String,
    /// The executor's record directory.
    pub rec: PathBuf,
    /// fwsim's banner: controller, camera, background, truth, fixture origin, world.
    pub banner: Vec<String>,
}

pub fn start_rig(d: &Path, plan: &Path) -> RigProcs {
    start_rig_in(d, plan, None)
}

/// [`start_rig`] with the controller `controller` (`native`, `mpc200`, …) on both sides.
pub fn start_rig_with(d: &Path, plan: &Path, controller: &str) -> RigProcs {
    start_rig_on(d, plan, None, controller)
}

/// [`start_rig`] with the simulator's `--world` (default: its embedded default world).
pub fn start_rig_in(d: &Path, plan: &Path, world: Option<&Path>) -> RigProcs {
    start_rig_on(d, plan, world, "native")
}

/// The simulator with `world` and `controller`, the executor with the same controller.
fn start_rig_on(d: &Path, plan: &Path, world: Option<&Path>, controller: &str) -> RigProcs {
    let fw_dir = d.join("fw");
    let mut fw = Command::new(FWSIM);
    fw.args(["--controller", controller]);
    fw.args(["--seed", "3", "--rt-priority", "70", "--plan"]).arg(plan);
    if let Some(w) = world {
        fw.arg("--world").arg(w);
    }
    let mut fwsim = Killed(
        fw.arg("--run-dir")
            .arg(&fw_dir)
            .stdout(Stdio::piped())
            .spawn()
            .expect("mesopush-fwsim starts"),
    );
    let prefixes = ["controller:", "camera:", "background:", "truth:", "fixture origin:", "world:"];
    let b = read_banner(&mut fwsim.0, &prefixes, Duration::from_secs(60));
    let network = controller == "sensapex";
    assert!(b[0].starts_with(if network { "udp:" } else { "/dev/" }), "controller line: {b:?}");
    let host_sock = d.join("host.sock");
    let host = format!("unix:{}", host_sock.display());
    let rec = d.join("rec");
    let executor = Killed(
        Command::new(executor_bin())
            .args(["run", "--host-port", &host, "--ctrl-port", &b[0], "--camera", &b[1]])
            .args(["--controller", controller])
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
    RigProcs { _fwsim: fwsim, _executor: executor, host, rec, banner: b }
}

impl RigProcs {
    pub fn flash(&self, plan: &Path) {
        let flash = run_cmd(
            Command::new(MESOPUSH).arg("flash").arg(plan).args(["--port", &self.host, "--json"]),
            Duration::from_secs(120),
        );
        let text = String::from_utf8_lossy(&flash.stdout);
        assert!(flash.status.success(), "flash: {text} {}", String::from_utf8_lossy(&flash.stderr));
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert!(v["step_count"].as_u64().unwrap() >= 1, "{v}");
    }

    /// `mesopush run` of `plan` into `out`: its exit code and output.
    pub fn run(&self, plan: &Path, out: &Path, timeout: Duration) -> Output {
        let b = &self.banner;
        run_cmd(
            Command::new(MESOPUSH)
                .args(["run", "--port", &self.host, "--json", "--plan"])
                .arg(plan)
                .arg("--record-dir")
                .arg(&self.rec)
                .args(["--background", &b[2], "--truth", &b[3], "--sim-world", &b[5], "--out"])
                .arg(out),
            timeout,
        )
    }

    /// `mesopush rig ARGS --port P`.
    pub fn rig(&self, args: &[&str]) -> Output {
        run_cmd(
            Command::new(MESOPUSH).arg("rig").args(args).args(["--port", &self.host]),
            Duration::from_secs(120),
        )
    }
}
