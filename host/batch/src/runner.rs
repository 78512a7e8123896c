//! The seam between the batch engine and whatever runs one trial: the [`TrialRunner`] trait,
//! the job it is handed, the result it returns, and the cancellation token the engine uses to
//! stop a trial that outlives its wall-clock budget. The engine (journal, resume, retries,
//! timeouts, sharding, reports) knows nothing else about how a trial runs.

use crate::Error;
use mesopush_core::geom::Pose;
use mesopush_sim::Plan;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// One attempt at one trial, as the engine hands it to a runner.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialJob {
    /// Index within the batch (0-based); shards take indices ≡ I mod N.
    pub index: u64,
    /// `trial-000007`.
    pub trial_id: String,
    /// Attempt number, 1-based (retries count up).
    pub attempt: u32,
    /// The trial's seed (drawn from the batch seed and the index only, so every shard and
    /// every resumed run draws the same world).
    pub trial_seed: u64,
    /// The attempt's seed (trial seed and attempt): fault streams, sensor noise.
    pub attempt_seed: u64,
    /// Where the world puts the peg (the plan's nominal start, perturbed).
    pub peg_start: Pose,
    /// The candidate plans (the runner adapts or chooses one for the estimated start).
    pub plans: Arc<Vec<Plan>>,
}

/// How a trial ended, from the batch's point of view. Every trial gets exactly one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrialVerdict {
    /// The plan ran and the peg ended inside the narrow channel.
    Inserted,
    /// The plan ran to its end and the peg is not inside the channel.
    Missed,
    /// A fault was detected and the trial stopped (the probe commanded to stop).
    Faulted,
    /// The trial outlived its wall-clock budget and was cancelled (or abandoned).
    Timeout,
    /// The runner failed (bad input, simulator error, unreadable log, panic).
    Error,
}

impl TrialVerdict {
    /// All verdicts, in report order.
    pub const ALL: [TrialVerdict; 5] = [
        TrialVerdict::Inserted,
        TrialVerdict::Missed,
        TrialVerdict::Faulted,
        TrialVerdict::Timeout,
        TrialVerdict::Error,
    ];

    /// Lower-case name as written in the journal.
    pub fn as_str(self) -> &'static str {
        match self {
            TrialVerdict::Inserted => "inserted",
            TrialVerdict::Missed => "missed",
            TrialVerdict::Faulted => "faulted",
            TrialVerdict::Timeout => "timeout",
            TrialVerdict::Error => "error",
        }
    }
}

/// What a runner reports for one attempt. Counts are for this attempt only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// The verdict.
    pub verdict: TrialVerdict,
    /// Why (always present: "inserted at depth …", "stall detected at t = …", …).
    pub reason: String,
    /// The start pose the runner estimated from the camera, when it did.
    pub estimated_start: Option<Pose>,
    /// Name of the plan that ran (chosen or adapted).
    pub plan_name: String,
    /// Last known peg pose (tracked or simulated).
    pub final_pose: Option<Pose>,
    /// Camera frames handled.
    pub frames: u64,
    /// Camera frames dropped or black.
    pub dropped_frames: u64,
    /// Faults the world injected.
    pub faults_injected: u64,
    /// Faults the loop detected (the sum of `faults`' detections; see docs/batch.md).
    pub faults_detected: u64,
    /// Faults injected and detected by class (absent in journals written before it: zero).
    #[serde(default)]
    pub faults: mesopush_rig::FaultClasses,
    /// Records that should be in the trial log and are not (must be 0).
    pub records_lost: u64,
    /// Largest tracking error against the world's truth, µm (0 when not tracked).
    pub track_error_um_max: f64,
    /// Simulated time the trial covered, s.
    pub sim_time_s: f64,
}

/// The flag the engine raises when a trial must stop (its budget ran out, or the batch is
/// being shut down). Runners check it at every bounded step and return promptly.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not raised.
    pub fn new() -> Self {
        Self::default()
    }

    /// Raises it.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether it is raised.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// `Err(Cancelled)` when raised, so runners can write `cancel.check()?`.
    pub fn check(&self) -> Result<(), Error> {
        if self.is_cancelled() {
            Err(Error::invalid("trial", "cancelled by the batch (wall-clock budget exceeded)"))
        } else {
            Ok(())
        }
    }
}

/// Runs one trial attempt into `dir` (which does not exist yet; the runner creates it with a
/// `TrialWriter`). Must return promptly once `cancel` is raised. An `Err` is recorded as
/// verdict `error` with the message as reason; a panic likewise.
pub trait TrialRunner: Send {
    /// Short name recorded in the journal (`sim`, `rig`).
    fn name(&self) -> &'static str;
    /// Runs `job`.
    fn run(&mut self, job: &TrialJob, dir: &Path, cancel: &Cancel) -> Result<TrialResult, Error>;
}

/// Builds runners: once at start, and again whenever a runner is abandoned (stuck past its
/// budget) or panicked, so a stuck component is replaced rather than reused.
pub type RunnerFactory = Box<dyn Fn() -> Result<Box<dyn TrialRunner>, Error> + Send + Sync>;
