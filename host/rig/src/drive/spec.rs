//! What a trial through the whole loop is asked to do ([`TrialSpec`], [`ClockMode`]) and
//! what it reports ([`TrialReport`], [`TrialProgress`]): the vocabulary the in-process trial
//! (`run_trial`), both clock modes and the trial's callers share.

use super::faults::FaultClasses;
use crate::plant::world_file::WorldFile;
use mesopush_core::geom::Pose;
pub use mesopush_executor::shell::controller::ControllerKind;
use mesopush_sim::Plan;
use mesopush_trial::TrialState;
use serde::Serialize;
use std::path::PathBuf;

/// Which clock runs the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClockMode {
    /// Simulated time, one thread, as fast as it computes; deterministic.
    Simulated,
    /// Real time: the executor's std shell on its own thread, the controller serving the pty.
    Realtime,
}

/// What to run.
#[derive(Debug, Clone)]
pub struct TrialSpec {
    /// Trial id (trial.json).
    pub trial_id: String,
    /// The plan.
    pub plan: Plan,
    /// The world.
    pub world: WorldFile,
    /// The one seed.
    pub seed: u64,
    /// Simulated or real time.
    pub clock: ClockMode,
    /// Overrides the world's peg start.
    pub peg_start: Option<Pose>,
    /// The motion controller the executor drives (simulated time: its emulator moves the
    /// stage).
    pub controller: ControllerKind,
}

/// How it went.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialReport {
    /// The trial directory.
    pub dir: PathBuf,
    /// How the run ended.
    pub state: TrialState,
    /// Why (faults, refusals).
    pub reason: Option<String>,
    /// The executor refused the plan or the arm (nothing ran; `reason` says why): invalid
    /// input, not a negative verdict.
    pub refused: bool,
    /// Whether the final pose lies in the goal (absent: no unflagged frame after the end).
    pub inserted: Option<bool>,
    /// The last unflagged tracked pose exposed after the trial's end (the peg at rest).
    pub final_pose: Option<Pose>,
    /// Frames recorded.
    pub frames: u64,
    /// Frames missing (camera drops, recorder overflow).
    pub dropped_frames: u64,
    /// Faults the world injected.
    pub faults_injected: u64,
    /// Faults the executor detected (trial faults).
    pub faults_detected: u64,
    /// Faults injected and detected by class (simulated time; in real time only the
    /// controller's detections are filled in). See [`super::faults`].
    pub faults: FaultClasses,
    /// Recorder messages lost (real time only).
    pub records_lost: u64,
    /// Largest distance between tracked and true peg positions over unflagged frames, µm.
    pub track_error_um_max: f64,
    /// Largest orientation error over the same frames, rad.
    pub track_error_rad_max: f64,
    /// Frames compared with the truth.
    pub frames_compared: usize,
    /// The peg's true final pose (simulation only).
    pub true_final_pose: Option<Pose>,
    /// Simulated (or elapsed) trial time, s.
    pub sim_time_s: f64,
    /// Wall-clock time, s.
    pub wall_time_s: f64,
    /// Jam episodes in the world: the needle deflected beyond `deflection_limit_um` against
    /// a wedged peg (simulation only; logged as `jam` events; the controller faults
    /// `NeedleOverload` beyond the same limit).
    pub jams: u32,
    /// Largest needle deflection seen at an exposure, µm (simulation only).
    pub max_deflection_um: f64,
    /// The needle's deflection limit, µm: the world model's `probe_deflection_limit_um`.
    pub deflection_limit_um: f64,
    /// Segments the controller applied.
    pub segments_applied: u64,
    /// Segments the plan consists of at the setpoint rate.
    pub segments_expected: u64,
    /// Whether the applied segments' ids ran consecutively (no move lost, repeated or
    /// reordered).
    pub segments_in_order: bool,
    /// Tracked (unflagged) poses in time order, for figures.
    #[serde(skip)]
    pub tracked_poses: Vec<Pose>,
}

/// Progress of a running trial.
#[derive(Debug, Clone, Copy)]
pub struct TrialProgress {
    /// Time into the run, s.
    pub t_s: f64,
    /// Expected length, s.
    pub total_s: f64,
}
