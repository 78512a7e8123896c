//! `trial.json`: what a trial was (part, plan, calibration, seeds, world) and how it ended.

use crate::Error;
use mesopush_sim::{Fixture, Part, Plan};
use mesopush_vision::calib::Calibration;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How a trial ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrialState {
    /// Still being recorded, or the recorder died: rows may be missing at the end.
    Incomplete,
    /// The plan ran to its end.
    Done,
    /// Stopped on request.
    Aborted,
    /// Stopped by a fault (see `reason`).
    Faulted,
}

/// The trial's verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    /// How the run ended.
    pub state: TrialState,
    /// Why, for aborted and faulted trials (and anything else worth saying).
    #[serde(default)]
    pub reason: Option<String>,
    /// Whether the peg ended inside the goal, judged from the last tracked pose (absent
    /// when not judged).
    #[serde(default)]
    pub inserted: Option<bool>,
}

impl Outcome {
    /// A trial still being written.
    pub fn incomplete() -> Self {
        Self { state: TrialState::Incomplete, reason: None, inserted: None }
    }
}

/// Pixel ↔ fixture-frame calibration as recorded (see `vision::calib`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CalibrationRecord {
    /// µm per pixel along image columns.
    pub sx_um_per_px: f64,
    /// µm per pixel along image rows.
    pub sy_um_per_px: f64,
    /// Fixture origin in continuous pixel coordinates.
    pub origin_px: [f64; 2],
}

impl From<&Calibration> for CalibrationRecord {
    fn from(c: &Calibration) -> Self {
        Self {
            sx_um_per_px: c.sx_um_per_px,
            sy_um_per_px: c.sy_um_per_px,
            origin_px: [c.origin_px.x, c.origin_px.y],
        }
    }
}

impl From<CalibrationRecord> for Calibration {
    fn from(c: CalibrationRecord) -> Self {
        Calibration {
            sx_um_per_px: c.sx_um_per_px,
            sy_um_per_px: c.sy_um_per_px,
            origin_px: mesopush_core::geom::Vec2::new(c.origin_px[0], c.origin_px[1]),
        }
    }
}

/// Units of the files, stated so a reader never guesses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Units {
    /// Lengths.
    pub length: String,
    /// Angles.
    pub angle: String,
    /// Time columns.
    pub time: String,
}

impl Default for Units {
    fn default() -> Self {
        Self { length: "um".into(), angle: "rad".into(), time: "us".into() }
    }
}

/// The contents of `trial.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialMeta {
    /// Always [`super::FORMAT`].
    pub format: String,
    /// [`super::FORMAT_VERSION`] when written by this build.
    pub format_version: u32,
    /// Identifier, unique within a batch (e.g. `trial-0007`).
    pub trial_id: String,
    /// Who produced the data: `fwsim`, `rig`, or an outside generator's name.
    pub source: String,
    /// Units of every file.
    #[serde(default)]
    pub units: Units,
    /// The pushed part (body frame, COM at the origin unless `com_um` says otherwise).
    pub part: Part,
    /// Probe tip radius, µm.
    #[serde(default = "default_probe_radius")]
    pub probe_radius_um: f64,
    /// Fixture walls and goal, when the trial ran in a fixture (absent: open plate).
    #[serde(default)]
    pub fixture: Option<Fixture>,
    /// The plan that was run, when it was a plan.
    #[serde(default)]
    pub plan: Option<Plan>,
    /// Camera calibration used to track the frames.
    #[serde(default)]
    pub calibration: Option<CalibrationRecord>,
    /// Camera frame period, µs (absent: no camera, pose.csv came from elsewhere).
    #[serde(default)]
    pub frame_period_us: Option<u64>,
    /// Seeds of every random stream involved, by name.
    #[serde(default)]
    pub seeds: BTreeMap<String, u64>,
    /// The simulated world's description (the firmware simulator's world file, verbatim),
    /// when simulated. Never read by identification or diagnosis.
    #[serde(default)]
    pub world: Option<serde_json::Value>,
    /// How it ended.
    pub outcome: Outcome,
}

fn default_probe_radius() -> f64 {
    12.5
}

impl TrialMeta {
    /// Metadata for a new trial of `part`, outcome incomplete.
    pub fn new(trial_id: impl Into<String>, source: impl Into<String>, part: Part) -> Self {
        Self {
            format: super::FORMAT.into(),
            format_version: super::FORMAT_VERSION,
            trial_id: trial_id.into(),
            source: source.into(),
            units: Units::default(),
            part,
            probe_radius_um: default_probe_radius(),
            fixture: None,
            plan: None,
            calibration: None,
            frame_period_us: None,
            seeds: BTreeMap::new(),
            world: None,
            outcome: Outcome::incomplete(),
        }
    }

    /// Checks the format marker, version and units.
    pub fn check(&self) -> Result<(), Error> {
        if self.format != super::FORMAT {
            return Err(Error::invalid(
                "trial.json",
                format!("format is {:?}, expected {:?}", self.format, super::FORMAT),
            ));
        }
        if self.format_version != super::FORMAT_VERSION {
            return Err(Error::invalid(
                "trial.json",
                format!(
                    "format_version {} is not supported (this build reads {})",
                    self.format_version,
                    super::FORMAT_VERSION
                ),
            ));
        }
        if self.units != Units::default() {
            return Err(Error::invalid(
                "trial.json",
                format!("units {:?}: only um / rad / us are supported", self.units),
            ));
        }
        if !(self.probe_radius_um >= 0.0 && self.probe_radius_um.is_finite()) {
            return Err(Error::invalid("trial.json", "probe_radius_um must be ≥ 0"));
        }
        Ok(())
    }
}
