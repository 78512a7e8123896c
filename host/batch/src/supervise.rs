//! Runs one attempt under a wall-clock budget. The runner works on its own thread; the
//! engine waits with a timeout, raises the cancel flag when the budget runs out, waits a
//! grace period, and if the runner still has not returned, abandons that thread and builds
//! a fresh runner (a stuck component is replaced, never waited on forever). Panics are
//! caught and become verdict `error`. Every wait here is bounded.

use super::runner::{Cancel, RunnerFactory, TrialJob, TrialResult, TrialRunner, TrialVerdict};
use crate::Error;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// Owns the current runner and replaces it when it gets stuck or panics.
pub struct Supervisor {
    factory: RunnerFactory,
    runner: Option<Box<dyn TrialRunner>>,
    name: &'static str,
    /// Runners built after the first (abandoned or panicked ones replaced).
    pub restarts: u64,
    /// Whether the last attempt's runner was abandoned (it may still be writing into its
    /// attempt directory).
    pub abandoned_last: bool,
}

impl std::fmt::Debug for Supervisor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Supervisor")
            .field("name", &self.name)
            .field("restarts", &self.restarts)
            .finish()
    }
}

type Reply = (Box<dyn TrialRunner>, std::thread::Result<Result<TrialResult, Error>>);

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-text panic payload".into())
}

/// A verdict the engine makes for the runner (it never got to say).
pub fn engine_verdict(verdict: TrialVerdict, reason: String) -> TrialResult {
    TrialResult {
        verdict,
        reason,
        estimated_start: None,
        plan_name: String::new(),
        final_pose: None,
        frames: 0,
        dropped_frames: 0,
        faults_injected: 0,
        faults_detected: 0,
        faults: mesopush_rig::FaultClasses::default(),
        records_lost: 0,
        track_error_um_max: 0.0,
        sim_time_s: 0.0,
    }
}

/// Starts `runner` on its own thread; the reply comes on the returned channel.
fn spawn(
    mut runner: Box<dyn TrialRunner>,
    job: &TrialJob,
    dir: &Path,
    cancel: &Cancel,
) -> Result<mpsc::Receiver<Reply>, Error> {
    let (tx, rx) = mpsc::sync_channel::<Reply>(1);
    let (job, dir, cancel): (TrialJob, PathBuf, Cancel) =
        (job.clone(), dir.to_path_buf(), cancel.clone());
    std::thread::Builder::new()
        .name(format!("runner-{}", job.trial_id))
        .spawn(move || {
            let r = std::panic::catch_unwind(AssertUnwindSafe(|| runner.run(&job, &dir, &cancel)));
            // The receiver may be gone (abandoned); nothing to do then.
            let _ = tx.send((runner, r));
        })
        .map_err(|e| Error::io("runner thread", e))?;
    Ok(rx)
}

impl Supervisor {
    /// Builds the first runner.
    pub fn new(factory: RunnerFactory) -> Result<Self, Error> {
        let runner = factory()?;
        let name = runner.name();
        Ok(Self { factory, runner: Some(runner), name, restarts: 0, abandoned_last: false })
    }

    /// The runner's name.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// Runs `job` into `dir` within `timeout`, cancelling and then abandoning after `grace`.
    pub fn attempt(
        &mut self,
        job: &TrialJob,
        dir: &Path,
        timeout: Duration,
        grace: Duration,
    ) -> Result<TrialResult, Error> {
        let runner = match self.runner.take() {
            Some(r) => r,
            None => {
                self.restarts += 1;
                (self.factory)()?
            }
        };
        let cancel = Cancel::new();
        self.abandoned_last = false;
        let rx = spawn(runner, job, dir, &cancel)?;
        let reply = match rx.recv_timeout(timeout) {
            Ok(r) => Some(r),
            Err(_) => {
                cancel.cancel();
                match rx.recv_timeout(grace) {
                    Ok((runner, _)) => {
                        self.runner = Some(runner);
                        return Ok(engine_verdict(
                            TrialVerdict::Timeout,
                            format!(
                                "exceeded its {:.1} s budget; cancelled, and it stopped",
                                timeout.as_secs_f64()
                            ),
                        ));
                    }
                    Err(_) => None,
                }
            }
        };
        let Some((runner, result)) = reply else {
            self.abandoned_last = true;
            return Ok(engine_verdict(
                TrialVerdict::Timeout,
                format!(
                    "exceeded its {:.1} s budget and did not stop within {:.1} s of being \
                     cancelled; abandoned, runner restarted",
                    timeout.as_secs_f64(),
                    grace.as_secs_f64()
                ),
            ));
        };
        Ok(match result {
            Ok(Ok(r)) => {
                self.runner = Some(runner);
                r
            }
            Ok(Err(e)) => {
                self.runner = Some(runner);
                engine_verdict(TrialVerdict::Error, format!("runner error: {e}"))
            }
            Err(p) => engine_verdict(
                TrialVerdict::Error,
                format!("runner panicked: {}; runner restarted", panic_text(p.as_ref())),
            ),
        })
    }
}
