//! Running the real binaries on untrusted input, shared by the malformed-input corpus test
//! and the mutation test: each run gets its own temporary directory, its output goes to files
//! (no pipe can fill up), and a run that outlives its time limit is killed and reported.

#![allow(dead_code)] // each test file uses its own part

pub(crate) mod mutate;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The corpus directory (`host/cli/tests/malformed`).
pub(crate) fn corpus() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/malformed")
}

/// How a run ended.
#[derive(Debug)]
pub(crate) struct Ended {
    /// The exit code (`None`: killed by a signal, or by us at the time limit).
    pub(crate) code: Option<i32>,
    /// Whether we killed it at the time limit.
    pub(crate) timed_out: bool,
    /// Its standard error.
    pub(crate) stderr: String,
}

impl Ended {
    /// Whether the run panicked (Rust's panic message, or exit code 101).
    pub(crate) fn panicked(&self) -> bool {
        self.stderr.contains("panicked at") || self.code == Some(101)
    }
}

/// Runs `bin` with `args` in `dir` (its working directory, where stdout and stderr go),
/// killing it after `limit`.
pub(crate) fn run(bin: &Path, args: &[String], dir: &Path, limit: Duration) -> Ended {
    let (out, err) = (dir.join("stdout.txt"), dir.join("stderr.txt"));
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).expect("stdout file"))
        .stderr(std::fs::File::create(&err).expect("stderr file"))
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", bin.display()));
    let t0 = Instant::now();
    let (status, timed_out) = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break (Some(s), false);
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break (None, true);
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stderr = String::from_utf8_lossy(&std::fs::read(&err).unwrap_or_default()).into_owned();
    Ended { code: status.and_then(|s| s.code()), timed_out, stderr }
}

/// The binary called `name` of this package.
pub(crate) fn binary(name: &str) -> PathBuf {
    match name {
        "mesopush" => PathBuf::from(env!("CARGO_BIN_EXE_mesopush")),
        "mesopush-fwsim" => PathBuf::from(env!("CARGO_BIN_EXE_mesopush-fwsim")),
        other => panic!("unknown binary {other}"),
    }
}
