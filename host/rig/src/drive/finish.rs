//! The end both clock modes share: [`finish`] writes truth.csv, the jam events and the
//! verdict, closes the trial directory and builds the [`TrialReport`]; the verdict is judged
//! on the peg at rest (the last unflagged frame after the trial's end), and the tracking
//! error against the world's truth ([`track_error`]).

use super::faults::{FaultClasses, FaultCount};
use super::recorder::{RecorderResult, Tracked};
use super::spec::TrialReport;
use crate::Error;
use crate::client::complete::verdict_detail;
use crate::client::session::SessionEnd;
use crate::client::tracking::wrap_angle;
use crate::plant::truth::TruthSample;
use crate::plant::truth_log::{write_jams, write_truth};
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_protocol::host::TrialEventKind;
use mesopush_sim::Fixture;
use mesopush_trial::{EventRow, Outcome, TrialState};
use std::path::Path;

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
    /// The world's needle deflection limit, µm (its model's `probe_deflection_limit_um`).
    pub deflection_limit_um: f64,
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
        (_, Some((_, TrialEventKind::Faulted(f)))) => (TrialState::Faulted, Some(f.to_string())),
        (Some(SessionEnd::Refused(r)), _) => (TrialState::Aborted, Some(r.clone())),
        (Some(SessionEnd::Rejected(r)), _) => {
            (TrialState::Aborted, Some(format!("command refused: {r}")))
        }
        _ => (TrialState::Incomplete, Some("the trial did not end in time".to_string())),
    }
}

/// Writes truth.csv, the verdict and the final trial.json; builds the report.
pub(crate) fn finish(
    out_dir: &Path,
    rec: RecorderResult,
    truth: &[TruthSample],
    (fixture, part): (&Fixture, &ConvexPolygon),
    done: Finished,
) -> Result<TrialReport, Error> {
    write_truth(out_dir, truth, rec.t0_us.unwrap_or(0))?;
    let final_pose = final_pose(&rec);
    // The fixture's own goal rule (with `goal_whole_part`, the whole outline inside).
    let inserted = final_pose
        .map(|p| fixture.part_inserted(&part.transformed(&p), &Vec2::new(p.x_um, p.y_um)));
    let (state, reason) = end_state(done.end.as_ref(), rec.end);
    let refused = matches!(done.end, Some(SessionEnd::Refused(_) | SessionEnd::Rejected(_)))
        && rec.end.is_none();
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
    let jams = write_jams(&mut writer, truth, t0, done.deflection_limit_um)?;
    let max_deflection_um = truth.iter().map(|s| s.deflection_um).fold(0.0, f64::max);
    let verdict = format!(
        "{}; tracking error against the truth ≤ {err_um:.2} µm over {compared} frames",
        verdict_detail(inserted, final_pose)
    );
    let t_end = rec.end.map_or(0, |(t, _)| t as i64 - rec.t0_us.unwrap_or(0) as i64);
    writer.event(&EventRow { t_us: t_end, kind: "verdict".into(), detail: verdict })?;
    let dir = writer.finish(Outcome { state, reason: reason.clone(), inserted })?;
    Ok(TrialReport {
        dir,
        state,
        reason,
        refused,
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
        deflection_limit_um: done.deflection_limit_um,
        segments_applied: done.applied.0,
        segments_expected: done.segments_expected,
        segments_in_order: done.applied.1,
        tracked_poses,
    })
}

/// Largest distance between tracked (unflagged) poses and the truth at the same exposure,
/// µm and rad; `None` without a comparable frame. A frame stamped `t` was exposed at
/// `t − camera_latency_us` (the world's undeclared latency; 0 in a clean world).
pub(crate) fn track_error(
    tracked: &[Tracked],
    truth: &[TruthSample],
    camera_latency_us: i64,
) -> Option<(f64, f64, usize)> {
    let mut worst: Option<(f64, f64, usize)> = None;
    for t in tracked.iter().filter(|t| !t.flagged) {
        let exposed = t.t_exposure_us as i64 - camera_latency_us;
        let Ok(i) = truth.binary_search_by_key(&exposed, |s| s.t_us as i64) else { continue };
        let s = truth[i].peg;
        let d = Vec2::new(t.row.x_um - s.x_um, t.row.y_um - s.y_um).norm();
        let a = wrap_angle(t.row.theta_rad - s.theta_rad).abs();
        let w = worst.get_or_insert((0.0, 0.0, 0));
        *w = (w.0.max(d), w.1.max(a), w.2 + 1);
    }
    worst
}
