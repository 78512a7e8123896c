//! One trial through the whole loop: [`run_trial`] builds the world from the world file and
//! the seed, runs the loop (simulated or real time), lets the recorder write and track, and
//! judges the verdict from the tracked poses. Simulated time is deterministic: the same seed
//! gives a byte-identical trial directory.

use super::build::{Built, build};
use super::faults::{FaultClasses, FaultCount};
use super::recorder::{Recorder, RecorderResult, Schedule, Tracked, track_error};
use super::session::{HostSession, SessionEnd, SessionGoal, plan_steps};
use super::simloop::{CameraTiming, STEP_US, SimLoop};
use super::world::{RigWorld, TruthSample};
use super::world_file::WorldFile;
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_executor::ExecutorConfig;
use mesopush_firmware_sim::SimRng;
use mesopush_protocol::host::TrialEventKind;
use mesopush_sim::{Fixture, Plan};
use mesopush_trial::{CalibrationRecord, EventRow, Outcome, TrialMeta, TrialState};
use mesopush_vision::TrackSettings;
use serde::Serialize;
use std::path::{Path, PathBuf};

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
    /// Jam episodes in the world: the needle deflected beyond
    /// [`super::world::NEEDLE_DEFLECTION_LIMIT_UM`] against a wedged peg (simulation only; logged as `jam`
    /// events).
    pub jams: u32,
    /// Largest needle deflection seen at an exposure, µm (simulation only).
    pub max_deflection_um: f64,
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
pub struct Progress {
    /// Time into the run, s.
    pub t_s: f64,
    /// Expected length, s.
    pub total_s: f64,
}

/// Parts shared by both clock modes.
pub(crate) struct Prepared {
    pub rng: SimRng,
    pub world: RigWorld,
    pub recorder: Recorder,
    pub probe_start_nm: (f64, f64),
    pub camera: CameraTiming,
    pub config: ExecutorConfig,
    pub plan_duration_s: f64,
    pub segments_expected: u64,
}

fn meta(spec: &TrialSpec, cal: &mesopush_vision::Calibration) -> TrialMeta {
    let mut m = TrialMeta::new(&spec.trial_id, "fwsim", spec.world.model.part.clone());
    m.probe_radius_um = spec.world.model.probe_radius_um;
    m.fixture = Some(Fixture::paper());
    m.plan = Some(spec.plan.clone());
    m.calibration = Some(CalibrationRecord::from(cal));
    m.frame_period_us = Some(spec.world.spec.camera.period_us);
    m.seeds.insert("seed".into(), spec.seed);
    m.world = Some(spec.world.description());
    m
}

pub(crate) fn prepare(spec: &TrialSpec, out_dir: &Path) -> Result<Prepared, Error> {
    spec.plan.validate()?;
    let rng = SimRng::new(spec.seed);
    let ws = &spec.world.spec;
    let cal = ws.camera.calibration()?;
    let Built { mut world, camera, offset_um: offset, .. } =
        build(&spec.world, &spec.plan, spec.peg_start, &rng)?;
    let background = world.background();
    let writer = mesopush_trial::TrialWriter::create(out_dir, meta(spec, &cal))?;
    let config = ExecutorConfig::DEFAULT;
    let p = spec.plan.probe_start() + offset;
    let probe_start_nm = ((p.x * 1000.0).round(), (p.y * 1000.0).round());
    let schedule = Schedule {
        steps: plan_steps(&spec.plan)?,
        start_nm: (probe_start_nm.0 as i64, probe_start_nm.1 as i64),
        offset_um: offset,
        period_us: config.setpoint_period_us(),
        lead_us: config.start_lead_us,
    };
    let track = TrackSettings {
        calibration: cal,
        theta_hint_rad: spec.plan.peg_start_pose().theta_rad,
        ..TrackSettings::default()
    };
    let total_us: u64 = schedule
        .steps
        .iter()
        .map(|s| mesopush_executor::plan::StepGeometry::of(s).duration_us)
        .sum();
    let segments_expected = total_us.div_ceil(schedule.period_us.max(1));
    let recorder = Recorder::new(writer, &background, track, schedule)?;
    let plan_duration_s = spec.plan.travel_um() / spec.plan.speed_um_s;
    Ok(Prepared {
        rng,
        world,
        recorder,
        probe_start_nm,
        camera,
        config,
        plan_duration_s,
        segments_expected,
    })
}

/// Runs one trial into `out_dir` (created; must not hold a trial). `progress` is called
/// now and then.
pub fn run_trial(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrialReport, Error> {
    let wall = std::time::Instant::now();
    let mut report = match spec.clock {
        ClockMode::Simulated => run_simulated(spec, out_dir, progress)?,
        ClockMode::Realtime => super::realtime::run_realtime(spec, out_dir, progress)?,
    };
    report.wall_time_s = wall.elapsed().as_secs_f64();
    Ok(report)
}

/// Time the loop keeps running after the trial's end (frames of the peg at rest), µs.
pub(crate) const TAIL_US: u64 = 300_000;

/// The tail for a camera: [`TAIL_US`], or long enough for two more frames to be exposed and
/// delivered after the end (a slow camera's last frame must show the peg at rest: the
/// verdict is judged on it).
pub(crate) fn tail_us(camera: &CameraTiming) -> u64 {
    TAIL_US.max(2 * camera.period_us + camera.readout_us)
}

fn run_simulated(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrialReport, Error> {
    let prep = prepare(spec, out_dir)?;
    let faults = super::world_file::validated_faults(&spec.world.spec.faults)?;
    let session_id = 7_000 + prep.rng.fork(11).below(1000) as u16;
    let host = HostSession::new(&spec.plan, SessionGoal::FlashAndRun, session_id)?;
    let (tx, rx) = crossbeam_channel::bounded(256);
    let recorder = prep.recorder;
    let rec = std::thread::spawn(move || recorder.run(rx));
    let total_s = prep.plan_duration_s + 2.0;
    let max_us = ((prep.plan_duration_s + 30.0) * 1e6) as u64;
    let tail = tail_us(&prep.camera);
    let mut lp = SimLoop::new(
        &prep.rng,
        prep.config,
        faults,
        prep.probe_start_nm,
        host,
        prep.world,
        prep.camera,
        tx,
    )?;
    let mut ended_at = None;
    let mut result = Ok(());
    while lp.now_us < max_us {
        if let Err(e) = lp.step() {
            result = Err(e);
            break;
        }
        if lp.now_us % 100_000 < STEP_US {
            progress(Progress { t_s: lp.now_us as f64 * 1e-6, total_s });
        }
        if lp.host.end().is_some() && ended_at.is_none() {
            ended_at = Some(lp.now_us);
        }
        if ended_at.is_some_and(|t| lp.now_us >= t + tail) {
            break;
        }
    }
    let end = lp.host.end().cloned();
    let faults_injected = lp.faults_injected();
    let mut classes = lp.fault_classes();
    let applied = lp.applied();
    let sim_time_s = lp.now_us as f64 * 1e-6;
    let world = lp.into_world(); // flushes, then closes the recorder's channel
    let recorded =
        rec.join().map_err(|_| Error::invalid("recorder", "the recorder panicked"))??;
    result?;
    let world = world?;
    let segments_expected = prep.segments_expected;
    let done = Finished {
        end,
        applied,
        segments_expected,
        faults_injected,
        records_lost: 0,
        sim_time_s,
        camera_latency_us: world.camera_latency_us(),
    };
    let mut report = finish(out_dir, recorded, world.truth(), world.fixture(), done)?;
    classes.controller.detected = report.faults_detected;
    report.faults = classes;
    Ok(report)
}

/// The loop's outcome, for [`finish`].
pub(crate) struct Finished {
    pub end: Option<SessionEnd>,
    pub applied: (u64, bool),
    pub segments_expected: u64,
    pub faults_injected: u64,
    pub records_lost: u64,
    pub sim_time_s: f64,
    /// The world's camera latency, µs: a frame stamped `t` shows the truth at `t − latency`.
    pub camera_latency_us: i64,
}

/// The peg at rest: the last unflagged frame exposed after the trial ended. Earlier frames
/// show it still moving; when every frame after the end is flagged (the needle over the
/// peg, say) there is nothing to judge on, and the report says so (`inserted` absent)
/// rather than guessing from an older frame.
fn final_pose(rec: &RecorderResult) -> Option<Pose> {
    let end_us = rec.end.map(|(t, _)| t);
    let last: Option<&Tracked> = rec
        .tracked
        .iter()
        .rev()
        .find(|t| !t.flagged && end_us.is_none_or(|e| t.t_exposure_us >= e));
    last.map(|t| Pose::new(t.row.x_um, t.row.y_um, t.row.theta_rad))
}

/// How the trial ended, and why: from the executor's end event, else the session's refusal.
fn end_state(
    session: Option<&SessionEnd>,
    end: Option<(u64, TrialEventKind)>,
) -> (TrialState, Option<String>) {
    match (session, end) {
        (_, Some((_, TrialEventKind::Done))) => (TrialState::Done, None),
        (_, Some((_, TrialEventKind::Aborted))) => (TrialState::Aborted, None),
        (_, Some((_, TrialEventKind::Faulted(f)))) => (TrialState::Faulted, Some(format!("{f:?}"))),
        (Some(SessionEnd::Refused(r)), _) => (TrialState::Aborted, Some(r.clone())),
        _ => (TrialState::Incomplete, Some("the trial did not end in time".to_string())),
    }
}

/// Writes truth.csv, the verdict and the final trial.json; builds the report.
pub(crate) fn finish(
    out_dir: &Path,
    rec: RecorderResult,
    truth: &[TruthSample],
    fixture: &Fixture,
    done: Finished,
) -> Result<TrialReport, Error> {
    super::truth_log::write_truth(out_dir, truth, rec.t0_us.unwrap_or(0))?;
    let final_pose = final_pose(&rec);
    let inserted = final_pose.map(|p| fixture.inserted(&Vec2::new(p.x_um, p.y_um)));
    let (state, reason) = end_state(done.end.as_ref(), rec.end);
    let (err_um, err_rad, compared) =
        track_error(&rec.tracked, truth, done.camera_latency_us).unwrap_or((0.0, 0.0, 0));
    let tracked_poses: Vec<Pose> = rec
        .tracked
        .iter()
        .filter(|t| !t.flagged)
        .map(|t| Pose::new(t.row.x_um, t.row.y_um, t.row.theta_rad))
        .collect();
    let mut writer = rec.writer;
    let t0 = rec.t0_us.unwrap_or(0) as i64;
    let jams = super::truth_log::write_jams(&mut writer, truth, t0)?;
    let max_deflection_um = truth.iter().map(|s| s.deflection_um).fold(0.0, f64::max);
    let verdict = format!(
        "inserted={}; final_pose={final_pose:?}; track_error_um_max={err_um:.2} over {compared} frames",
        inserted.map_or("unknown".into(), |b| b.to_string())
    );
    let t_end = rec.end.map_or(0, |(t, _)| t as i64 - rec.t0_us.unwrap_or(0) as i64);
    writer.event(&EventRow { t_us: t_end, kind: "verdict".into(), detail: verdict })?;
    let dir = writer.finish(Outcome { state, reason: reason.clone(), inserted })?;
    Ok(TrialReport {
        dir,
        state,
        reason,
        inserted,
        final_pose,
        frames: rec.frames,
        dropped_frames: rec.dropped_frames,
        faults_injected: done.faults_injected,
        faults_detected: rec.faults_detected,
        faults: FaultClasses {
            controller: FaultCount { injected: 0, detected: rec.faults_detected },
            ..FaultClasses::default()
        },
        records_lost: done.records_lost,
        track_error_um_max: err_um,
        track_error_rad_max: err_rad,
        frames_compared: compared,
        true_final_pose: truth.last().map(|s| s.peg),
        sim_time_s: done.sim_time_s,
        wall_time_s: 0.0,
        jams,
        max_deflection_um,
        segments_applied: done.applied.0,
        segments_expected: done.segments_expected,
        segments_in_order: done.applied.1,
        tracked_poses,
    })
}
