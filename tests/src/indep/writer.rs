//! Writes one trial directory in the trial-log format, version 2 (docs/trial-log.md):
//! trial.json, probe.csv (one row per setpoint) and pose.csv (one row per frame, with the
//! imaged needle). JSON through serde_json, CSV by hand, numbers at fixed precision, so
//! the same inputs give the same bytes.

use super::Error;
use super::camera::{FRAME_PERIOD_US, Frame};
use super::effects::Effect;
use super::path::{Path as ProbePath, SETPOINT_PERIOD_S};
use super::physics::Truth;
use super::world::World;
use crate::coulomb::Pose;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::Path;

/// The `source` written into trial.json.
pub const SOURCE: &str = "indep-coulomb";

/// Everything one trial directory holds.
#[derive(Debug, Clone, Copy)]
pub struct TrialRecord<'a> {
    /// `trial_id`.
    pub id: &'a str,
    /// Place in the batch.
    pub index: usize,
    /// The world this trial ran in (drift applied).
    pub world: &'a World,
    /// The batch's effect.
    pub effect: &'a Effect,
    /// The part's true start pose.
    pub start: Pose,
    /// Commanded path.
    pub path: &'a ProbePath,
    /// True motion (only its end is recorded, under `world`).
    pub truth: &'a Truth,
    /// Tracked frames.
    pub frames: &'a [Frame],
    /// Seeds of the plan and the camera noise.
    pub seeds: [u64; 2],
}

fn pose_json(p: &Pose) -> Value {
    json!({ "x_um": p.x, "y_um": p.y, "theta_rad": p.theta })
}

/// trial.json's content.
pub fn meta_json(r: &TrialRecord<'_>) -> Value {
    let end = r.truth.last();
    json!({
        "format": "mesopush-trial",
        "format_version": 2,
        "trial_id": r.id,
        "source": SOURCE,
        "units": { "length": "um", "angle": "rad", "time": "us" },
        "part": { "vertices_um": r.world.outline_um },
        "pusher": { "discs": [{ "center_um": [0.0, 0.0], "radius_um": r.world.pusher_radius_um }] },
        "fixture": null,
        "frame_period_us": FRAME_PERIOD_US,
        "seeds": { "plan": r.seeds[0], "camera": r.seeds[1] },
        "world": {
            "generator": SOURCE,
            "world": r.world.to_json(),
            "effect": r.effect.to_json(),
            "trial_index": r.index,
            "true_start": pose_json(&r.start),
            "true_end": pose_json(&end.pose),
            "unresolved_increments": r.truth.unresolved,
            "adhesion_drag_increments": r.truth.dragged,
        },
        "outcome": { "state": "done" },
    })
}

fn write(path: &Path, text: &str) -> Result<(), Error> {
    std::fs::write(path, text).map_err(|e| Error::io(path, e))
}

/// probe.csv: the commanded needle centre at every setpoint.
pub fn probe_csv(path: &ProbePath) -> String {
    let mut s = String::from("t_us,cmd_x_um,cmd_y_um\n");
    let period_us = (SETPOINT_PERIOD_S * 1e6).round() as u64;
    for tick in 0..=path.end_tick() {
        let p = path.at_tick(tick as f64);
        let _ = writeln!(s, "{},{:.4},{:.4}", tick * period_us, p.x, p.y);
    }
    s
}

/// pose.csv: the tracked pose and imaged needle per frame (no edge residual).
pub fn pose_csv(frames: &[Frame]) -> String {
    let mut s = String::from(
        "t_us,x_um,y_um,theta_rad,frame_index,residual_px,probe_tip_x_um,probe_tip_y_um\n",
    );
    for f in frames {
        let _ = writeln!(
            s,
            "{},{:.4},{:.4},{:.7},{},,{:.4},{:.4}",
            f.t_us, f.pose.x, f.pose.y, f.pose.theta, f.index, f.tip.x, f.tip.y
        );
    }
    s
}

/// Writes the trial into `dir` (created).
pub fn write_trial(dir: &Path, r: &TrialRecord<'_>) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let meta = serde_json::to_string_pretty(&meta_json(r))
        .map_err(|e| Error::invalid("trial.json", e.to_string()))?;
    write(&dir.join("trial.json"), &(meta + "\n"))?;
    write(&dir.join("probe.csv"), &probe_csv(r.path))?;
    write(&dir.join("pose.csv"), &pose_csv(r.frames))
}
