//! Completing a trial recorded by another process: the executor (`mesopush-executor run
//! --record-dir`) wrote the raw frame part of the trial log — frames.csv, the frame store
//! frames.tif (or frames/*.png from older executors), events.csv, recording.json — and the host, which knows the plan, the calibration and what
//! it heard on the host line, adds the rest: trial.json, probe.csv (the setpoint schedule
//! rebuilt from the plan, with the controller's position reports), pose.csv (the host's
//! tracker on every recorded frame) and the verdict. See docs/trial-log.md.

use super::schedule::Schedule;
use super::tracking::{pose_row, wrap_angle};
use crate::Error;
use mesopush_core::fsx::write_atomic;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_protocol::flash::PlanStep;
use mesopush_protocol::host::ProbeTelemetry;
use mesopush_protocol::units::{nm_to_um, um_to_nm_i64};
use mesopush_sim::{Fixture, Model, Plan};
use mesopush_trial::{
    CalibrationRecord, EventRow, FrameRow, Outcome, PoseRow, ProbeRow, Trial, TrialMeta, TrialState,
};
use mesopush_vision::{Calibration, TrackSettings, Tracker, TrialFrames};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What the host knows about the trial.
#[derive(Debug, Clone)]
pub struct Completion {
    /// Trial id for trial.json.
    pub trial_id: String,
    /// The plan run.
    pub plan: Plan,
    /// Its steps as flashed.
    pub steps: Vec<PlanStep>,
    /// The calibration the host tracks with.
    pub calibration: Calibration,
    /// Fixture origin in stage coordinates, µm.
    pub fixture_origin_um: Vec2,
    /// Setpoint period and the lead from `Started` to the first segment, µs (the
    /// executor's configuration).
    pub period_us: u64,
    /// Lead, µs.
    pub lead_us: u64,
    /// Nominal camera period, µs.
    pub frame_period_us: u64,
    /// The trial's start, executor µs (`Started` event).
    pub t0_us: u64,
    /// How it ended, and why.
    pub state: TrialState,
    /// Why (faults, refusals).
    pub reason: Option<String>,
    /// Position reports heard on the host line.
    pub telemetry: Vec<ProbeTelemetry>,
}

/// The verdict and figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Completed {
    /// The trial directory.
    pub trial_dir: PathBuf,
    /// How the run ended.
    pub state: TrialState,
    /// Why.
    pub reason: Option<String>,
    /// Whether the last unflagged tracked pose lies in the goal.
    pub inserted: Option<bool>,
    /// That pose.
    pub final_pose: Option<Pose>,
    /// Frame rows with an image.
    pub frames: u64,
    /// Rows marked dropped.
    pub dropped_frames: u64,
    /// Frames tracked without a flag.
    pub tracked: u64,
}

/// A tracked pose and whether the tracker flagged it.
type TrackedRow = (PoseRow, bool);

/// The tracked poses (with whether each was flagged) and the tracker's learned apparent
/// scale, if any.
fn tracked_poses(
    dir: &Path,
    c: &Completion,
    frames: &[FrameRow],
) -> Result<(Vec<TrackedRow>, Option<f64>), Error> {
    let bg = load_gray(&dir.join("background.png"))?;
    let mut images = TrialFrames::new(dir);
    let settings = TrackSettings {
        calibration: c.calibration,
        theta_hint_rad: c.plan.peg_start_pose().theta_rad,
        ..TrackSettings::default()
    };
    let mut tracker = Tracker::new(&bg, settings)?;
    let mut out = Vec::new();
    let mut last_index: Option<u64> = None;
    for f in frames.iter().filter(|f| !f.dropped && !f.black) {
        let (Some(file), Some(t)) = (&f.file, f.t_capture_us) else { continue };
        // dropped and black frames in between widen the tracker's jump tolerance
        let periods = last_index.map_or(1, |i| f.index.saturating_sub(i));
        last_index = Some(f.index);
        let image = images.load_row(file, Some(f.index))?;
        let m = tracker.track_after(&image, u32::try_from(periods).unwrap_or(u32::MAX))?;
        let Some(row) = pose_row(t, f.index, &m) else { continue };
        out.push((row, m.is_flagged()));
    }
    Ok((out, tracker.apparent_scale()))
}

fn load_gray(path: &Path) -> Result<image::GrayImage, Error> {
    let img = image::open(path)
        .map_err(|e| Error::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    Ok(img.into_luma8())
}

fn csv_bytes<T: Serialize>(path: &Path, rows: &[T]) -> Result<Vec<u8>, Error> {
    let parse = |m: String| Error::Parse { path: path.to_path_buf(), message: m };
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| parse(e.to_string()))?;
    }
    w.into_inner().map_err(|e| parse(e.to_string()))
}

/// probe.csv: one row per setpoint of the schedule, each report on its nearest row.
fn probe_rows(c: &Completion) -> Result<Vec<ProbeRow>, Error> {
    let start = c.plan.probe_start() + c.fixture_origin_um;
    let schedule = Schedule {
        steps: c.steps.clone(),
        start_nm: (
            um_to_nm_i64("probe start x", start.x)?,
            um_to_nm_i64("probe start y", start.y)?,
        ),
        offset_um: c.fixture_origin_um,
        period_us: c.period_us,
        lead_us: c.lead_us,
    };
    let period = schedule.period();
    let mut rows: Vec<ProbeRow> = (0..schedule.rows())
        .map(|k| {
            let cmd = schedule.row_cmd_um(k);
            ProbeRow {
                t_us: (c.lead_us + k * period) as i64,
                cmd_x_um: cmd.x,
                cmd_y_um: cmd.y,
                rep_x_um: None,
                rep_y_um: None,
                cmd_theta_rad: None,
            }
        })
        .collect();
    for t in &c.telemetry {
        let rel = t.exec_time_us as i64 - c.t0_us as i64 - c.lead_us as i64;
        if rel < -(period as i64) / 2 {
            continue;
        }
        let k = ((rel + period as i64 / 2).max(0) as u64 / period) as usize;
        if let Some(r) = rows.get_mut(k) {
            let p = Vec2::new(nm_to_um(t.probe_x_nm), nm_to_um(t.probe_y_nm)) - c.fixture_origin_um;
            (r.rep_x_um, r.rep_y_um) = (Some(p.x), Some(p.y));
        }
    }
    Ok(rows)
}

/// Completes the recorded directory `dir` (which holds frames.csv, frames.tif, events.csv and
/// `background.png`, the empty fixture's frame) into a trial log.
pub fn complete_trial(dir: &Path, c: &Completion) -> Result<Completed, Error> {
    let frames: Vec<FrameRow> = read_rows(&dir.join("frames.csv"))?;
    let (tracked, apparent_scale) = tracked_poses(dir, c, &frames)?;
    let poses: Vec<PoseRow> = tracked.iter().map(|t| t.0).collect();
    write_atomic(&dir.join("pose.csv"), &csv_bytes(&dir.join("pose.csv"), &poses)?)?;
    write_atomic(&dir.join("probe.csv"), &csv_bytes(&dir.join("probe.csv"), &probe_rows(c)?)?)?;
    let fixture = Fixture::paper();
    let last = tracked.iter().rev().find(|t| !t.1).map(|t| t.0);
    let final_pose = last.map(|p| Pose::new(p.x_um, p.y_um, wrap_angle(p.theta_rad)));
    let inserted = final_pose.map(|p| fixture.inserted(&Vec2::new(p.x_um, p.y_um)));
    let verdict = EventRow {
        t_us: frames.iter().filter_map(|f| f.t_capture_us).max().unwrap_or(0),
        kind: "verdict".into(),
        detail: verdict_detail(inserted, final_pose),
    };
    if let Some(r) = apparent_scale {
        let detail = mesopush_vision::scale_lock::describe(r);
        let row = EventRow { t_us: verdict.t_us, kind: "apparent_scale".into(), detail };
        append_event(&dir.join("events.csv"), &row)?;
    }
    append_event(&dir.join("events.csv"), &verdict)?;
    let mut meta = TrialMeta::new(&c.trial_id, "rig", Model::default().part);
    meta.fixture = Some(fixture);
    meta.plan = Some(c.plan.clone());
    meta.calibration = Some(CalibrationRecord::from(&c.calibration));
    meta.frame_period_us = Some(c.frame_period_us as f64);
    meta.outcome = Outcome { state: c.state, reason: c.reason.clone(), inserted };
    let text = serde_json::to_string_pretty(&meta)
        .map_err(|e| Error::invalid("trial.json", e.to_string()))?;
    write_atomic(&dir.join("trial.json"), text.as_bytes())?;
    Trial::load(dir)?; // the directory reads back as a trial log
    Ok(Completed {
        trial_dir: dir.to_path_buf(),
        state: c.state,
        reason: c.reason.clone(),
        inserted,
        final_pose,
        frames: frames.iter().filter(|f| !f.dropped).count() as u64,
        dropped_frames: frames.iter().filter(|f| f.dropped).count() as u64,
        tracked: tracked.iter().filter(|t| !t.1).count() as u64,
    })
}

/// The `verdict` row's detail in events.csv, in words: `inserted; final tracked pose x … µm,
/// y … µm, θ …°`, `NOT inserted; …` or `not judged: no tracked pose of the peg at rest`.
pub fn verdict_detail(inserted: Option<bool>, final_pose: Option<Pose>) -> String {
    match (inserted, final_pose) {
        (Some(i), Some(p)) => {
            format!("{}; final tracked pose {p}", if i { "inserted" } else { "NOT inserted" })
        }
        _ => "not judged: no tracked pose of the peg at rest".into(),
    }
}

/// Reads a CSV file of `T` rows.
pub fn read_rows<T: serde::de::DeserializeOwned>(path: &Path) -> Result<Vec<T>, Error> {
    let parse = |m: String| Error::Parse { path: path.to_path_buf(), message: m };
    let mut r = csv::Reader::from_path(path).map_err(|e| parse(e.to_string()))?;
    r.deserialize().map(|row| row.map_err(|e| parse(e.to_string()))).collect()
}

fn append_event(path: &Path, row: &EventRow) -> Result<(), Error> {
    use std::io::Write;
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
    w.serialize(row).map_err(|e| Error::invalid("events.csv", e.to_string()))?;
    let bytes = w.into_inner().map_err(|e| Error::invalid("events.csv", e.to_string()))?;
    let mut f =
        std::fs::OpenOptions::new().append(true).open(path).map_err(|e| Error::io(path, e))?;
    f.write_all(&bytes).and_then(|()| f.sync_all()).map_err(|e| Error::io(path, e))
}
