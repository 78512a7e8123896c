//! `mesopush calibrate` on a rig: measures the camera's pixel size, its rotation relative to
//! the stage axes and where the fixture origin lies in the image, by moving the probe known
//! distances and tracking its tip (docs/vision.md, "Calibrating pixel size on a rig").
//!
//! Through the ordinary host ↔ executor flow: the probe's position from the executor's
//! status; the moves of [`super::calib_plan`] flashed, armed at that position and run while
//! the executor records (`--camera`, `--record-dir`); the recording's frames at rest tracked
//! with the host's tracker against the empty fixture's frame, with a nominal calibration
//! (only the needle's size in pixels depends on it; the tip is read back in pixels); the tip's
//! median at each rest and the commanded positions fitted
//! ([`mesopush_vision::calib_fit::fit_calibration`]). A rest at which the tip is not located
//! in enough frames is refused with what was seen there and what to do.

use super::calib_plan::{CalibrationMoves, RestWindow};
use super::complete::read_rows;
use super::hil::{RunPhase, wait_for_recording};
use super::hostlink::{HostPort, drive, fresh_session_id};
use super::rig::{Registration, stage_um, status};
use super::schedule::Schedule;
use super::session::{HostSession, SessionEnd, SessionGoal};
use crate::Error;
use mesopush_core::geom::Vec2;
use mesopush_protocol::host::{ExecToHost, TrialEvent, TrialEventKind};
use mesopush_protocol::units::um_to_nm_i64;
use mesopush_trial::FrameRow;
use mesopush_trial::calib_file::{CalibrationFile, CalibrationPosition};
use mesopush_trial::meta::CalibrationRecord;
use mesopush_vision::calib_fit::{TipSample, fit_calibration};
use mesopush_vision::{Calibration, TrackSettings, Tracker, TrialFrames};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A rest needs the tip located in at least this many frames.
pub const MIN_TIP_FRAMES: usize = 5;

/// What `calibrate` needs.
#[derive(Debug, Clone)]
pub struct CalibrateOptions {
    /// The executor's host line.
    pub addr: String,
    /// The executor's `--record-dir`.
    pub record_dir: PathBuf,
    /// The empty fixture's frame (tracking reference; the probe out of view).
    pub background: PathBuf,
    /// The calibration the tip is tracked with (a nominal one: the objective's).
    pub nominal: Calibration,
    /// The stage registration (the executor's `--fixture-origin-um`).
    pub registration: Registration,
    /// The moves.
    pub moves: CalibrationMoves,
    /// The executor's setpoint period and start lead, µs.
    pub period_us: u64,
    /// Start lead, µs.
    pub lead_us: u64,
}

/// What `calibrate` found.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateReport {
    /// The calibration file's contents (the calibration, the fit, the positions).
    pub file: CalibrationFile,
    /// The recording of the calibration moves.
    pub trial_dir: PathBuf,
}

/// Runs the calibration moves on the executor at `o.addr` and fits the calibration,
/// telling `progress` each phase.
pub fn calibrate(
    o: &CalibrateOptions,
    progress: &mut dyn FnMut(RunPhase),
) -> Result<CalibrateReport, Error> {
    let plan = o.moves.plan()?;
    progress(RunPhase::Connecting);
    let start = status(&o.addr)?.probe.ok_or_else(|| {
        Error::invalid(
            "calibrate",
            "the executor has no position report from the motion controller yet: is the \
             controller connected and on (`mesopush rig status`)?",
        )
    })?;
    progress(RunPhase::Arming);
    let mut session =
        HostSession::with_steps(&plan.steps, SessionGoal::FlashAndRun, start, fresh_session_id())?;
    let t0 = run_moves(&mut session, o, &plan.steps, progress)?;
    let name = format!("trial-{:08x}-{}", session.plan_id(), t0.exec_time_us);
    progress(RunPhase::WaitingForRecording);
    let dir = wait_for_recording(&o.record_dir.join(name))?;
    progress(RunPhase::Completing);
    let start_um = stage_um(start);
    let schedule = Schedule {
        steps: plan.steps.clone(),
        start_nm: (um_to_nm_i64("start x", start_um.x)?, um_to_nm_i64("start y", start_um.y)?),
        offset_um: o.registration.fixture_origin_um,
        period_us: o.period_us,
        lead_us: o.lead_us,
    };
    let positions = rest_tips(&dir, o, &schedule, &plan.rests)?;
    let samples: Vec<TipSample> = positions
        .iter()
        .map(|p| TipSample { fixture_um: p.fixture_um.into(), tip_px: p.tip_px.into() })
        .collect();
    let fit = fit_calibration(&samples)?;
    let file = CalibrationFile {
        calibration: CalibrationRecord::from(&fit.calibration()?),
        fit: Some(fit),
        positions,
    };
    Ok(CalibrateReport { file, trial_dir: dir })
}

/// Flashes, arms and runs the moves to their end; the trial's start event.
fn run_moves(
    s: &mut HostSession,
    o: &CalibrateOptions,
    steps: &[mesopush_protocol::flash::PlanStep],
    progress: &mut dyn FnMut(RunPhase),
) -> Result<TrialEvent, Error> {
    let expected_us: u64 =
        steps.iter().map(|s| mesopush_executor::plan::StepGeometry::of(s).duration_us).sum();
    let expected_s = expected_us as f64 * 1e-6;
    let timeout = Duration::from_secs_f64(expected_s + 90.0);
    let mut port = HostPort::open(&o.addr)?;
    let mut started: Option<TrialEvent> = None;
    let end = drive(s, &mut port, &o.addr, timeout, &mut |_, m| match m {
        ExecToHost::Trial(t) if t.kind == TrialEventKind::Started => started = Some(*t),
        ExecToHost::Telemetry(t) => {
            if let Some(t0) = started {
                let elapsed_s = t.exec_time_us.saturating_sub(t0.exec_time_us) as f64 * 1e-6;
                progress(RunPhase::Running { elapsed_s, expected_s });
            }
        }
        _ => {}
    })?;
    let why = match end {
        SessionEnd::Trial(TrialEventKind::Done) => None,
        SessionEnd::Trial(TrialEventKind::Faulted(f)) => Some(format!("the moves faulted: {f}")),
        SessionEnd::Trial(TrialEventKind::Aborted) => Some("the moves were aborted".into()),
        SessionEnd::Rejected(r) => Some(format!("the executor refused the moves: {r}")),
        SessionEnd::Refused(r) => Some(format!("the executor refused the moves: {r}")),
        other => Some(format!("unexpected end: {other}")),
    };
    if let Some(why) = why {
        return Err(Error::invalid("calibrate", why));
    }
    started.ok_or_else(|| {
        Error::invalid("calibrate", "the moves ended but their start was never heard")
    })
}

/// What the tracker made of the frames at one rest.
#[derive(Debug, Default)]
struct RestSeen {
    frames: usize,
    tips_px: Vec<Vec2>,
    at_um: Vec<Vec2>,
    no_needle: usize,
    withheld: BTreeMap<&'static str, usize>,
}

/// The tip's median location and the commanded position at each rest; refuses a rest
/// where the tip was located in fewer than [`MIN_TIP_FRAMES`] frames.
fn rest_tips(
    dir: &Path,
    o: &CalibrateOptions,
    schedule: &Schedule,
    rests: &[RestWindow; 3],
) -> Result<Vec<CalibrationPosition>, Error> {
    let bg = image::open(&o.background)
        .map_err(|e| Error::parse(&o.background, e.to_string()))?
        .into_luma8();
    let settings = TrackSettings { calibration: o.nominal, ..TrackSettings::default() };
    let mut tracker = Tracker::new(&bg, settings)?;
    let frames: Vec<FrameRow> = read_rows(&dir.join("frames.csv"))?;
    let mut images = TrialFrames::new(dir);
    let mut seen: [RestSeen; 3] = Default::default();
    for f in frames.iter().filter(|f| !f.dropped && !f.black) {
        let (Some(file), Some(t)) = (&f.file, f.t_capture_us) else { continue };
        let rel = t - o.lead_us as i64;
        let Some(k) = rests.iter().position(|r| r.contains(rel)) else { continue };
        let s = &mut seen[k];
        s.frames += 1;
        let m = tracker.measure(&images.load_row(file, Some(f.index))?)?;
        match (m.probe_tip_um, m.tip_flag) {
            (Some(tip), _) => {
                s.tips_px.push(o.nominal.um_to_px(&tip));
                s.at_um.push(schedule.cmd_um(u64::try_from(rel).unwrap_or(0)));
            }
            (None, Some(flag)) => *s.withheld.entry(flag.as_str()).or_default() += 1,
            (None, None) => s.no_needle += 1,
        }
    }
    seen.iter().enumerate().map(|(k, s)| position(k, s, schedule, rests, dir)).collect()
}

/// One rest's position, or the refusal saying what was seen there.
fn position(
    k: usize,
    s: &RestSeen,
    schedule: &Schedule,
    rests: &[RestWindow; 3],
    dir: &Path,
) -> Result<CalibrationPosition, Error> {
    if s.tips_px.len() < MIN_TIP_FRAMES {
        let at = schedule.cmd_um(rests[k].from_us);
        let names = ["the start", "after the x move", "after the y move"];
        let withheld: Vec<String> = s.withheld.iter().map(|(f, n)| format!("{n} {f}")).collect();
        return Err(Error::invalid(
            "calibrate",
            format!(
                "probe tip not found at rest position {} ({}, fixture ({:.1}, {:.1}) µm): \
                 located in {} of {} frames at rest (no needle seen in {}; withheld: {}); at \
                 least {MIN_TIP_FRAMES} are needed. Keep the tip in view and clear of the peg \
                 and the walls at all three positions (choose --move-um, or move the probe \
                 with `mesopush rig goto`), check that --background is the empty fixture \
                 under the same light, and look at the frames in {}",
                k + 1,
                names[k],
                at.x,
                at.y,
                s.tips_px.len(),
                s.frames,
                s.no_needle,
                if withheld.is_empty() { "none".into() } else { withheld.join(", ") },
                dir.display()
            ),
        ));
    }
    let tip = median2(&s.tips_px);
    let at = median2(&s.at_um);
    let n = s.tips_px.len();
    let spread =
        (s.tips_px.iter().map(|t| (t - tip).norm_squared()).sum::<f64>() / n as f64).sqrt();
    Ok(CalibrationPosition {
        fixture_um: [at.x, at.y],
        tip_px: [tip.x, tip.y],
        frames: n,
        spread_px: spread,
    })
}

/// Component-wise median.
fn median2(v: &[Vec2]) -> Vec2 {
    let med = |mut a: Vec<f64>| mesopush_core::stats::median(&mut a).unwrap_or(f64::NAN);
    Vec2::new(med(v.iter().map(|p| p.x).collect()), med(v.iter().map(|p| p.y).collect()))
}
