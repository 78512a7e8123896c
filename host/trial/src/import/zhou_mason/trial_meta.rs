//! The `trial.json` of an imported run: the set-up's part (COM at the origin), the two-finger
//! hand, the 30 Hz camera period, no fixture, and an `import` note that records where every
//! row went and every convention the importer applied, so a reader never has to guess.

use super::convert::{RowCounts, mm_to_um};
use super::setup::{FINGER_RADIUS_MM, FINGER_SPACING_MM, SetUp};
use crate::Error;
use crate::meta::{Outcome, TrialMeta, TrialState};
use mesopush_core::geom::{ConvexPolygon, Vec2};
use mesopush_sim::{Part, Pusher};

/// The `source` of an imported trial.
pub const SOURCE: &str = "zhou-mason-2017";
/// The logs' camera period, µs (30 Hz; the stamps' mean step within a push is 0.03333 s).
pub const FRAME_PERIOD_US: f64 = 33_333.3;

/// Who the run is: where its file lies and what it is called in the output.
#[derive(Debug, Clone, PartialEq)]
pub struct RunId {
    /// The set-up.
    pub set_up: SetUp,
    /// The start condition (the start folder's name after the set-up's).
    pub start: String,
    /// The file, relative to the data root.
    pub file: String,
    /// The trial id and directory name: `<set-up>__<start>__<run stamp>`.
    pub trial_id: String,
}

/// The part of `set_up`, in its body frame (COM at the origin), µm.
pub fn part(set_up: SetUp) -> Result<Part, Error> {
    let com = set_up.com_mm();
    let vertices = set_up
        .outline_mm()
        .iter()
        .map(|[x, y]| Vec2::new(mm_to_um(x - com[0]), mm_to_um(y - com[1])))
        .collect();
    let polygon = ConvexPolygon::new(vertices).map_err(mesopush_sim::Error::from)?;
    Ok(Part::from_polygon(&polygon))
}

/// The hand: two fingers either side of the reference point (the log's pusher_x/y, midway
/// between them), on the line across the push direction (the log's pusher_theta).
pub fn pusher() -> Pusher {
    Pusher::two_finger(mm_to_um(FINGER_RADIUS_MM), mm_to_um(FINGER_SPACING_MM))
}

/// The metadata of run `id`.
pub fn trial_meta(
    id: &RunId,
    counts: &RowCounts,
    vision_latency_s: f64,
) -> Result<TrialMeta, Error> {
    let s = id.set_up;
    let mut m = TrialMeta::new(&id.trial_id, SOURCE, part(s)?);
    m.pusher = pusher();
    m.frame_period_us = Some(FRAME_PERIOD_US);
    m.registration_tol_um = Some(mm_to_um(s.registration_tolerance_mm()));
    m.outcome = Outcome { state: TrialState::Done, reason: None, inserted: None };
    m.import = Some(serde_json::json!({
        "importer": "mesopush import zhou-mason (docs/import-zhou-mason.md)",
        "dataset": "J. Zhou and M. T. Mason, Pushing revisited (ISRR 2017); robinzhoucmu/Pushing \
                    1ff9b01, Apache-2.0",
        "file": id.file,
        "set_up": s.name(),
        "start": id.start,
        "support": s.support(),
        "rows": counts,
        "vision_latency_s": vision_latency_s,
        "outline": s.outline_source(),
        "com_in_logged_object_frame_um": s.com_mm().map(mm_to_um),
        "registration_tolerance_um": mm_to_um(s.registration_tolerance_mm()),
        "pusher": "the log's pusher_x/y = the finger midpoint (probe.csv cmd_x/y), pusher_theta = \
                   the push direction, CCW+ (cmd_theta_rad, unwrapped, otherwise unchanged)",
        "frame": "the log's table frame in um; the goal pose is (0, -317500 um, 0)",
        "events": "push_start (detail action=N: the log's action index) and log_gap (rows stop \
                   for longer than 0.1 s: the hand moves to the next push unlogged)",
    }));
    Ok(m)
}
