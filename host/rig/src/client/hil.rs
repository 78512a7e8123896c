//! The hardware-in-the-loop workflow's host side, as separate processes (docs/hil.md):
//! [`flash`] uploads a plan to a running `mesopush-executor`; [`run`] arms and starts it,
//! listens until the trial ends, waits for the executor's recording of it, and completes
//! that into a trial log ([`super::complete`]) with a verdict — and, when the firmware
//! simulator's truth file is given, the frame-timestamp and tracking errors against it.

use super::complete::{Completed, Completion, complete_trial, read_rows};
use super::hostlink::{HostPort, drive, fresh_session_id};
use super::session::{HostSession, SessionEnd, SessionGoal, plan_start, plan_steps};
use crate::Error;
use mesopush_core::geom::Vec2;
use mesopush_core::stats::percentile_i64;
use mesopush_framestore::STORE_FILE;
use mesopush_protocol::host::{
    CommandRejectReason, ExecToHost, ProbeTelemetry, StagePoint, TrialEvent, TrialEventKind,
};
use mesopush_sim::Plan;
use mesopush_trial::{FrameRow, PoseRow, TrialState};
use mesopush_vision::Calibration;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Longest wait for the executor to accept an upload.
pub const FLASH_TIMEOUT: Duration = Duration::from_secs(30);
/// Longest wait for the executor's recording after the trial's end.
pub const RECORDING_TIMEOUT: Duration = Duration::from_secs(20);

/// Uploads `plan` to the executor at `addr`; returns the steps accepted.
pub fn flash(addr: &str, plan: &Plan) -> Result<u32, Error> {
    let mut port = HostPort::open(addr)?;
    // The start is stated when arming (`run`); flashing does not use it.
    let unused = StagePoint { x_nm: 0, y_nm: 0 };
    let mut s = HostSession::new(plan, SessionGoal::Flash, unused, fresh_session_id())?;
    match drive(&mut s, &mut port, addr, FLASH_TIMEOUT, &mut |_, _| {})? {
        SessionEnd::Accepted { step_count } => Ok(step_count),
        SessionEnd::Refused(why) => Err(Error::invalid("flash", why)),
        SessionEnd::Rejected(r) => Err(Error::invalid("flash", r.to_string())),
        other => Err(Error::invalid("flash", format!("unexpected answer: {other}"))),
    }
}

/// What `run` needs.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The executor's host line.
    pub addr: String,
    /// The plan flashed (its id arms it; its steps rebuild the schedule).
    pub plan: Plan,
    /// The executor's `--record-dir`.
    pub record_dir: PathBuf,
    /// Where the trial log goes (default: the recording's own directory).
    pub out: Option<PathBuf>,
    /// The empty fixture's frame (tracking reference).
    pub background: PathBuf,
    /// The calibration, the stage's fixture origin (µm) and the camera period (µs).
    pub calibration: Calibration,
    /// Fixture origin in stage coordinates, µm.
    pub fixture_origin_um: Vec2,
    /// Nominal camera period, µs.
    pub frame_period_us: u64,
    /// The executor's setpoint period and start lead, µs.
    pub period_us: u64,
    /// Start lead, µs.
    pub lead_us: u64,
    /// The firmware simulator's `fwsim-truth.csv`, for the error figures.
    pub truth: Option<PathBuf>,
    /// The firmware simulator's `fwsim-world.json` (its world description and seed), recorded
    /// as trial.json's `world` when the rig was simulated.
    pub sim_world: Option<PathBuf>,
}

/// Errors against the simulator's truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruthFigures {
    /// Frames matched with the truth by their counter.
    pub frames_compared: usize,
    /// Executor stamp − true exposure, µs: median (0 with no frame compared), and largest
    /// magnitude.
    pub stamp_error_us_p50: i64,
    /// Largest |stamp − exposure|, µs.
    pub stamp_error_us_max_abs: i64,
    /// Arrival at the executor − true exposure, µs (what an arrival stamp would be off by):
    /// median and maximum.
    pub arrival_latency_us_p50: i64,
    /// Maximum.
    pub arrival_latency_us_max: i64,
    /// Largest tracked-vs-true peg position error over tracked frames, µm.
    pub track_error_um_max: f64,
}

/// `run`'s report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// The completed trial.
    #[serde(flatten)]
    pub trial: Completed,
    /// Position reports heard.
    pub telemetry: usize,
    /// Against the simulator's truth, when given.
    pub truth: Option<TruthFigures>,
    /// Wall time, s.
    pub wall_time_s: f64,
}

#[derive(Debug, Deserialize)]
struct Recording {
    exec_epoch_mono_us: u64,
    t0_exec_us: u64,
}

#[derive(Debug, Deserialize)]
struct TruthRow {
    frame_seq: u32,
    exposure_mono_us: u64,
    x_um: f64,
    y_um: f64,
}

/// Where [`run_with`] is, for a progress display (a run is silent for up to a minute and
/// more otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum RunPhase {
    /// Connecting to the executor.
    Connecting,
    /// Arming and starting the flashed plan (the executor checks the probe is at its start).
    Arming,
    /// The trial runs: executor time since its start and the plan's nominal duration, s.
    Running {
        /// Executor time since the trial's start, s.
        elapsed_s: f64,
        /// The plan's travel over its speed, s.
        expected_s: f64,
    },
    /// The trial ended; waiting for the executor's recording (at most [`RECORDING_TIMEOUT`]).
    WaitingForRecording,
    /// Tracking the recorded frames and writing the trial log.
    Completing,
}

/// Arms, starts and follows the trial, then completes its recording.
pub fn run(o: &RunOptions) -> Result<RunReport, Error> {
    run_with(o, &mut |_| {})
}

/// [`run`], telling `progress` each phase (and, while the trial runs, each position report).
pub fn run_with(o: &RunOptions, progress: &mut dyn FnMut(RunPhase)) -> Result<RunReport, Error> {
    let wall = Instant::now();
    progress(RunPhase::Connecting);
    let mut port = HostPort::open(&o.addr)?;
    let start = plan_start(&o.plan, o.fixture_origin_um)?;
    let mut s = HostSession::new(&o.plan, SessionGoal::Run, start, fresh_session_id())?;
    progress(RunPhase::Arming);
    let (end, telemetry, started) = follow(&mut s, &mut port, o, progress)?;
    drop(port); // hang up: the executor's line waits for the next host
    let (state, reason) = end_state(end, o)?;
    let Some(t0) = started else {
        return Err(Error::invalid("run", "the trial ended but its start was never heard"));
    };
    let name = format!("trial-{:08x}-{}", t0.plan_id, t0.exec_time_us);
    progress(RunPhase::WaitingForRecording);
    let recorded = wait_for_recording(&o.record_dir.join(&name))?;
    progress(RunPhase::Completing);
    let dir = match &o.out {
        Some(out) => copy_dir(&recorded, out)?,
        None => recorded,
    };
    let bg = std::fs::read(&o.background).map_err(|e| Error::io(&o.background, e))?;
    std::fs::write(dir.join("background.png"), bg).map_err(|e| Error::io(&dir, e))?;
    let c = Completion {
        trial_id: name,
        plan: o.plan.clone(),
        steps: plan_steps(&o.plan)?,
        calibration: o.calibration,
        fixture_origin_um: o.fixture_origin_um,
        period_us: o.period_us,
        lead_us: o.lead_us,
        frame_period_us: o.frame_period_us,
        t0_us: t0.exec_time_us,
        state,
        reason,
        telemetry: telemetry.clone(),
    };
    let sim_world = o.sim_world.as_deref().map(read_sim_world).transpose()?;
    let trial = complete_trial(&dir, &c)?;
    if let Some(world) = sim_world {
        record_sim_world(&dir, world)?;
    }
    let truth = o.truth.as_deref().map(|t| truth_figures(&dir, t)).transpose()?;
    Ok(RunReport {
        trial,
        telemetry: telemetry.len(),
        truth,
        wall_time_s: wall.elapsed().as_secs_f64(),
    })
}

/// Arms, starts and follows the trial to its end: how it ended, the position reports and the
/// start event.
fn follow(
    s: &mut HostSession,
    port: &mut HostPort,
    o: &RunOptions,
    progress: &mut dyn FnMut(RunPhase),
) -> Result<(SessionEnd, Vec<ProbeTelemetry>, Option<TrialEvent>), Error> {
    let (mut telemetry, mut started): (Vec<ProbeTelemetry>, Option<TrialEvent>) = (vec![], None);
    let expected_s = o.plan.travel_um() / o.plan.speed_um_s;
    let timeout = Duration::from_secs_f64(expected_s + 60.0);
    let end = drive(s, port, &o.addr, timeout, &mut |_, m| match m {
        ExecToHost::Telemetry(t) => {
            telemetry.push(*t);
            if let Some(t0) = started {
                let elapsed_s = t.exec_time_us.saturating_sub(t0.exec_time_us) as f64 * 1e-6;
                progress(RunPhase::Running { elapsed_s, expected_s });
            }
        }
        ExecToHost::Trial(t) if t.kind == TrialEventKind::Started => {
            started = Some(*t);
            progress(RunPhase::Running { elapsed_s: 0.0, expected_s });
        }
        _ => {}
    })?;
    Ok((end, telemetry, started))
}

/// The trial's end state and reason (in words) from how the session ended; a refusal is an
/// error naming what to do.
fn end_state(end: SessionEnd, o: &RunOptions) -> Result<(TrialState, Option<String>), Error> {
    Ok(match end {
        SessionEnd::Trial(TrialEventKind::Done) => (TrialState::Done, None),
        SessionEnd::Trial(TrialEventKind::Aborted) => (TrialState::Aborted, None),
        SessionEnd::Trial(TrialEventKind::Faulted(f)) => (TrialState::Faulted, Some(f.to_string())),
        SessionEnd::Refused(r) => return Err(Error::invalid("run", r)),
        SessionEnd::Rejected(r @ CommandRejectReason::StartMismatch { .. }) => {
            let p = o.plan.probe_start();
            let hint = format!(
                "{r}: the plan starts at fixture ({:.1}, {:.1}) µm; `mesopush rig goto --plan \
                 PLAN --port {}` moves the probe there",
                p.x, p.y, o.addr
            );
            return Err(Error::invalid("run", hint));
        }
        SessionEnd::Rejected(r @ CommandRejectReason::OutsideWorkspace { .. }) => {
            let p = o.plan.probe_start();
            let hint = format!(
                "the plan's start, fixture ({:.1}, {:.1}) µm, is outside the rig's workspace: \
                 {r}; fix the plan's probe_start_um or the rig's fixture offset",
                p.x, p.y
            );
            return Err(Error::invalid("run", hint));
        }
        SessionEnd::Rejected(r) => return Err(Error::invalid("run", r.to_string())),
        other => return Err(Error::invalid("run", format!("unexpected end: {other}"))),
    })
}

/// Reads the simulator's `fwsim-world.json`: `{"seed": …, "world": <description>}`.
fn read_sim_world(path: &Path) -> Result<SimWorld, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| Error::invalid("--sim-world", format!("{}: {e}", path.display())))
}

/// Adds the simulated world to the completed trial.json (`world`, seed `world`).
fn record_sim_world(dir: &Path, w: SimWorld) -> Result<(), Error> {
    let path = dir.join("trial.json");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    let bad = |e: serde_json::Error| Error::invalid("trial.json", e.to_string());
    let mut meta: mesopush_trial::TrialMeta = serde_json::from_str(&text).map_err(bad)?;
    meta.world = Some(w.world);
    meta.seeds.insert("world".into(), w.seed);
    let text = serde_json::to_string_pretty(&meta).map_err(bad)?;
    Ok(mesopush_core::fsx::write_atomic(&path, text.as_bytes())?)
}

/// The simulator's world file: the one seed and the world's description.
#[derive(Debug, Deserialize)]
struct SimWorld {
    seed: u64,
    world: serde_json::Value,
}

/// Waits (at most [`RECORDING_TIMEOUT`]) for the executor to close the recording `dir`
/// (`recording.json` appears); the error says which flags the executor needs.
pub fn wait_for_recording(dir: &Path) -> Result<PathBuf, Error> {
    let marker = dir.join("recording.json");
    let t = Instant::now();
    while !marker.exists() {
        if t.elapsed() > RECORDING_TIMEOUT {
            return Err(Error::invalid(
                "recording",
                format!(
                    "{} did not appear within {RECORDING_TIMEOUT:?}: is the executor running \
                     with --record-dir {} and --camera?",
                    marker.display(),
                    dir.parent().unwrap_or(dir).display()
                ),
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(dir.to_path_buf())
}

/// Copies a recording (flat files, among them the frame store, and the `frames/` PNGs of
/// older recordings) into `out`, which must not hold a trial. The frame images — hundreds of
/// MB, never written again once recorded (thinning them writes a new store and renames it,
/// or unlinks) — are hard-linked where the file system allows, so `out` costs no second copy;
/// every other file is copied (completing the trial appends to some of them).
fn copy_dir(from: &Path, out: &Path) -> Result<PathBuf, Error> {
    if out.join("trial.json").exists() || out.join("frames.csv").exists() {
        let msg = format!("{} already holds a trial; refusing to overwrite it", out.display());
        return Err(Error::invalid("--out", msg));
    }
    for sub in ["", "frames"] {
        let (src, dst) = (from.join(sub), out.join(sub));
        if !src.is_dir() {
            continue;
        }
        std::fs::create_dir_all(&dst).map_err(|e| Error::io(&dst, e))?;
        for entry in std::fs::read_dir(&src).map_err(|e| Error::io(&src, e))? {
            let p = entry.map_err(|e| Error::io(&src, e))?.path();
            if p.is_file() {
                let to = dst.join(p.file_name().unwrap_or_default());
                let image = sub == "frames" || p.file_name().is_some_and(|n| n == STORE_FILE);
                if !(image && std::fs::hard_link(&p, &to).is_ok()) {
                    std::fs::copy(&p, &to).map_err(|e| Error::io(&to, e))?;
                }
            }
        }
    }
    Ok(out.to_path_buf())
}

/// Frame stamps and tracked poses of the trial in `dir` against `fwsim-truth.csv`.
pub fn truth_figures(dir: &Path, truth_path: &Path) -> Result<TruthFigures, Error> {
    let rec_path = dir.join("recording.json");
    let text = std::fs::read_to_string(&rec_path).map_err(|e| Error::io(&rec_path, e))?;
    let rec: Recording = serde_json::from_str(&text)
        .map_err(|e| Error::Parse { path: rec_path.clone(), message: e.to_string() })?;
    let base = (rec.exec_epoch_mono_us + rec.t0_exec_us) as i64;
    let truth: Vec<TruthRow> = read_rows(truth_path)?;
    let by_seq: std::collections::HashMap<u32, &TruthRow> =
        truth.iter().map(|t| (t.frame_seq, t)).collect();
    let frames: Vec<FrameRow> = read_rows(&dir.join("frames.csv"))?;
    let poses: Vec<PoseRow> = read_rows(&dir.join("pose.csv"))?;
    let (mut stamp, mut arrival, mut track) = (vec![], vec![], 0.0f64);
    for f in &frames {
        let (Some(tc), Some(t)) = (f.t_capture_us, by_seq.get(&f.frame_seq)) else { continue };
        stamp.push(base + tc - t.exposure_mono_us as i64);
        if let Some(ta) = f.t_arrival_us {
            arrival.push(base + ta - t.exposure_mono_us as i64);
        }
        if let Some(p) = poses.iter().find(|p| p.frame_index == Some(f.index)) {
            track = track.max(Vec2::new(p.x_um - t.x_um, p.y_um - t.y_um).norm());
        }
    }
    let n = stamp.len();
    let max_abs = stamp.iter().map(|e| e.abs()).max().unwrap_or(0);
    Ok(TruthFigures {
        frames_compared: n,
        stamp_error_us_p50: percentile_i64(&mut stamp, 0.5).unwrap_or(0),
        stamp_error_us_max_abs: max_abs,
        arrival_latency_us_p50: percentile_i64(&mut arrival, 0.5).unwrap_or(0),
        arrival_latency_us_max: arrival.iter().copied().max().unwrap_or(0),
        track_error_um_max: track,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::MetadataExt;

    /// `run --out` copied the whole recording, frame store included (≈ 400 MB per trial a
    /// second time): the images are linked, the files completing the trial appends to are not.
    #[test]
    fn the_copy_links_the_frame_images_and_copies_the_files_that_change() {
        let dir = tempfile::tempdir().unwrap();
        let (from, out) = (dir.path().join("rec"), dir.path().join("out"));
        std::fs::create_dir_all(from.join("frames")).unwrap();
        std::fs::write(from.join(STORE_FILE), b"pages").unwrap();
        std::fs::write(from.join("frames").join("000001.png"), b"png").unwrap();
        std::fs::write(from.join("events.csv"), b"t_us,kind,detail\n").unwrap();
        copy_dir(&from, &out).unwrap();
        let nlink = |p: &Path| std::fs::metadata(p).unwrap().nlink();
        assert_eq!(nlink(&out.join(STORE_FILE)), 2, "the store is linked, not copied");
        assert_eq!(nlink(&out.join("frames").join("000001.png")), 2);
        assert_eq!(nlink(&out.join("events.csv")), 1, "events.csv is copied");
        let mut f = std::fs::OpenOptions::new().append(true).open(out.join("events.csv")).unwrap();
        std::io::Write::write_all(&mut f, b"1,verdict,inserted\n").unwrap();
        let original = std::fs::read_to_string(from.join("events.csv")).unwrap();
        assert_eq!(original, "t_us,kind,detail\n", "appending to the copy left the recording");
        // A second copy into a directory that holds a trial is refused.
        std::fs::write(out.join("trial.json"), b"{}").unwrap();
        assert!(copy_dir(&from, &out).is_err());
    }
}
