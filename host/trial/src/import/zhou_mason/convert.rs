//! A parsed run converted into trial-log rows. The first row is discarded (a stale vision pose
//! from before the run; the authors discard it too). probe.csv gets the hand pose of every
//! other row; pose.csv the object pose of every row with a fresh vision sample: a vision
//! dropout (object (0, 0, 0)) and a pose bit-identical to the last one kept (a repeated, stale
//! sample) are left out and counted. Time is µs since the first kept row; the object's stamps
//! are moved earlier by the vision latency. Lengths mm → µm, the object's logged point moved to
//! its COM, and both angles unwrapped (the hand's flips between −π and +π at rest).

use super::run_file::RunRow;
use crate::Error;
use crate::records::{EventRow, PoseRow, ProbeRow};
use mesopush_protocol::units::s_to_us_i64;
use serde::Serialize;

/// A gap between rows longer than this, s, is a move between pushes (nothing is logged).
pub const PUSH_GAP_S: f64 = 0.1;

/// mm → µm (host lengths, f64): the importer's one length conversion.
pub fn mm_to_um(mm: f64) -> f64 {
    mm * 1000.0
}

/// Where a run's rows went. `file_rows` = `first_row_dropped` + `vision_dropouts` +
/// `stale_repeats` + `pose_rows`; every row after the first is also a probe row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct RowCounts {
    /// Rows in the file.
    pub file_rows: usize,
    /// The first row, discarded (1).
    pub first_row_dropped: usize,
    /// Rows whose object pose was (0, 0, 0): no vision sample.
    pub vision_dropouts: usize,
    /// Rows whose object pose repeats the last one kept bit for bit.
    pub stale_repeats: usize,
    /// Rows written to pose.csv.
    pub pose_rows: usize,
    /// Rows written to probe.csv.
    pub probe_rows: usize,
}

/// A run as trial-log rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Converted {
    /// probe.csv.
    pub probe: Vec<ProbeRow>,
    /// pose.csv.
    pub pose: Vec<PoseRow>,
    /// events.csv: `push_start` (detail `action=N`) where a push starts, `log_gap` where rows
    /// stop for longer than [`PUSH_GAP_S`] (detail `gap_s=…`).
    pub events: Vec<EventRow>,
    /// Where the rows went.
    pub counts: RowCounts,
}

/// `a` unwrapped next to `prev_raw` (raw) / `prev` (unwrapped): continuous across ±π.
fn unwrap(a: f64, prev_raw: f64, prev: f64) -> f64 {
    let d = (a - prev_raw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    prev + d
}

/// Time of `t_s` since `t0_s`, µs.
fn since(quantity: &'static str, t_s: f64, t0_s: f64) -> Result<i64, Error> {
    Ok(s_to_us_i64(quantity, t_s - t0_s)?)
}

/// The pose.csv row of `r` (object at its COM, `com_mm` in the logged object frame).
fn pose_row(r: &RunRow, t_us: i64, theta: f64, com_mm: [f64; 2]) -> PoseRow {
    let (s, c) = r.obj[2].sin_cos();
    let x_mm = r.obj[0] + c * com_mm[0] - s * com_mm[1];
    let y_mm = r.obj[1] + s * com_mm[0] + c * com_mm[1];
    PoseRow {
        t_us,
        x_um: mm_to_um(x_mm),
        y_um: mm_to_um(y_mm),
        theta_rad: theta,
        frame_index: None,
        residual_px: None,
        probe_tip_x_um: None,
        probe_tip_y_um: None,
    }
}

/// The events of a row that follows `prev`.
fn events(r: &RunRow, prev: Option<&RunRow>, t_us: i64) -> Vec<EventRow> {
    let gap = prev.map(|p| r.t_s - p.t_s).filter(|g| *g > PUSH_GAP_S);
    let mut out = Vec::new();
    if let Some(g) = gap {
        out.push(EventRow { t_us, kind: "log_gap".into(), detail: format!("gap_s={g:.2}") });
    }
    if gap.is_some() || prev.is_none_or(|p| p.action != r.action) {
        out.push(EventRow {
            t_us,
            kind: "push_start".into(),
            detail: format!("action={}", r.action),
        });
    }
    out
}

/// Converts `rows` (a whole run file, first row included); `com_mm` is the object's COM in
/// its logged frame, `vision_latency_s` how much later than the hand pose the object pose of
/// the same instant is logged.
pub fn convert(
    rows: &[RunRow],
    com_mm: [f64; 2],
    vision_latency_s: f64,
) -> Result<Converted, Error> {
    let Some((_, kept)) = rows.split_first().filter(|(_, k)| !k.is_empty()) else {
        return Err(Error::invalid("zhou-mason run", "fewer than two rows"));
    };
    let t0 = kept[0].t_s;
    let latency_us = s_to_us_i64("vision latency", vision_latency_s)?;
    let mut out = Converted {
        probe: Vec::with_capacity(kept.len()),
        pose: Vec::with_capacity(kept.len()),
        events: Vec::new(),
        counts: RowCounts {
            file_rows: rows.len(),
            first_row_dropped: 1,
            vision_dropouts: 0,
            stale_repeats: 0,
            pose_rows: 0,
            probe_rows: 0,
        },
    };
    // The last hand angle (raw, unwrapped) and the last object row kept (with its unwrapped θ).
    let mut hand_prev: Option<(f64, f64)> = None;
    let mut obj_prev: Option<(RunRow, f64)> = None;
    for (i, r) in kept.iter().enumerate() {
        let t_us = since("t_s", r.t_s, t0)?;
        let hand_theta = hand_prev.map_or(r.hand[2], |(raw, un)| unwrap(r.hand[2], raw, un));
        hand_prev = Some((r.hand[2], hand_theta));
        out.probe.push(ProbeRow {
            t_us,
            cmd_x_um: mm_to_um(r.hand[0]),
            cmd_y_um: mm_to_um(r.hand[1]),
            rep_x_um: None,
            rep_y_um: None,
            cmd_theta_rad: Some(hand_theta),
        });
        out.events.extend(events(r, i.checked_sub(1).map(|j| &kept[j]), t_us));
        if r.is_vision_dropout() {
            out.counts.vision_dropouts += 1;
            continue;
        }
        if obj_prev.is_some_and(|(p, _)| p.obj == r.obj) {
            out.counts.stale_repeats += 1;
            continue;
        }
        let theta = obj_prev.map_or(r.obj[2], |(p, un)| unwrap(r.obj[2], p.obj[2], un));
        obj_prev = Some((*r, theta));
        out.pose.push(pose_row(r, t_us.saturating_sub(latency_us), theta, com_mm));
    }
    out.counts.pose_rows = out.pose.len();
    out.counts.probe_rows = out.probe.len();
    Ok(out)
}
