//! `trial.json`: what a trial was (part, pusher, plan, calibration, seeds, world) and how it
//! ended. In memory a [`TrialMeta`] is always the current version (2); a version-1 file reads
//! as its version-2 equivalent (its `probe_radius_um` becomes a one-disc [`Pusher`]), so every
//! reader sees one shape.

use super::retention::FramesKept;
use crate::Error;
use mesopush_sim::{Fixture, Part, Plan, Pusher};
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

impl std::fmt::Display for TrialState {
    /// The same word trial.json uses (`done`, `aborted`, `faulted`, `incomplete`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Incomplete => "incomplete",
            Self::Done => "done",
            Self::Aborted => "aborted",
            Self::Faulted => "faulted",
        })
    }
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

/// The contents of `trial.json` (version 2; see the module header for version 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MetaFile")]
pub struct TrialMeta {
    /// Always [`super::FORMAT`].
    pub format: String,
    /// Always [`super::FORMAT_VERSION`] in memory (a version-1 file is upgraded on reading).
    pub format_version: u32,
    /// Identifier, unique within a batch (e.g. `trial-0007`).
    pub trial_id: String,
    /// Who produced the data: `fwsim`, `rig`, or an outside generator's name.
    pub source: String,
    /// Units of every file.
    pub units: Units,
    /// The pushed part (body frame, COM at the origin unless `com_um` says otherwise).
    pub part: Part,
    /// The pusher: its discs in its own frame, whose origin is the point probe.csv's
    /// `cmd_x_um, cmd_y_um` move (see [`TrialMeta::pusher`]).
    pub pusher: Pusher,
    /// Fixture walls and goal, when the trial ran in a fixture (absent or null: open plate).
    pub fixture: Option<Fixture>,
    /// The plan that was run, when it was a plan.
    pub plan: Option<Plan>,
    /// Camera calibration used to track the frames.
    pub calibration: Option<CalibrationRecord>,
    /// Nominal camera frame period, µs; may be fractional (30 Hz is 33 333.3 µs). Absent: no
    /// camera, pose.csv came from elsewhere.
    pub frame_period_us: Option<f64>,
    /// Seeds of every random stream involved, by name.
    pub seeds: BTreeMap<String, u64>,
    /// The simulated world's description (the firmware simulator's world file, verbatim),
    /// when simulated. Never read by identification or diagnosis.
    pub world: Option<serde_json::Value>,
    /// How the trial was converted from a foreign recording (importer, source file, rows
    /// kept and dropped, conventions), when it was imported. Never read by the physics.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub import: Option<serde_json::Value>,
    /// How deep the recorded pusher may appear inside the part through registration error
    /// alone, µm (pusher and part measured by different instruments); a replay moves the
    /// part clear of a first pusher position at most this deep. Absent: the simulator's
    /// default (`registration_tol` × the part's size).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub registration_tol_um: Option<f64>,
    /// Which frame images were kept after the trial (the retention setting, frames stored,
    /// frames kept); absent: every stored frame is kept (trials before the setting).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frames_kept: Option<FramesKept>,
    /// How it ended.
    pub outcome: Outcome,
}

/// The version-1 probe radius when `probe_radius_um` is absent, µm.
pub const V1_DEFAULT_PROBE_RADIUS_UM: f64 = 12.5;

impl TrialMeta {
    /// Metadata for a new trial of `part` pushed by the paper's probe (one 12.5 µm disc),
    /// outcome incomplete.
    pub fn new(trial_id: impl Into<String>, source: impl Into<String>, part: Part) -> Self {
        Self {
            format: super::FORMAT.into(),
            format_version: super::FORMAT_VERSION,
            trial_id: trial_id.into(),
            source: source.into(),
            units: Units::default(),
            part,
            pusher: Pusher::single(V1_DEFAULT_PROBE_RADIUS_UM),
            fixture: None,
            plan: None,
            calibration: None,
            frame_period_us: None,
            seeds: BTreeMap::new(),
            world: None,
            import: None,
            registration_tol_um: None,
            frames_kept: None,
            outcome: Outcome::incomplete(),
        }
    }

    /// The effective pusher for either file version: version 2's `pusher`, or version 1's
    /// one disc of `probe_radius_um` (default 12.5 µm) at the reference point.
    pub fn pusher(&self) -> Pusher {
        self.pusher.clone()
    }

    /// Checks the format marker, version, units, pusher and frame period (the rules every
    /// loaded file meets; writers may call it before writing).
    pub fn check(&self) -> Result<(), Error> {
        if self.format != super::FORMAT {
            return Err(Error::invalid(
                "trial.json format",
                format!("format = {:?}; expected {:?}", self.format, super::FORMAT),
            ));
        }
        if self.format_version != super::FORMAT_VERSION {
            return Err(Error::invalid(
                "trial.json format_version",
                format!(
                    "format_version {} is not supported (this build reads {} to {})",
                    self.format_version,
                    super::OLDEST_FORMAT_VERSION,
                    super::FORMAT_VERSION
                ),
            ));
        }
        if self.units != Units::default() {
            return Err(Error::invalid(
                "trial.json units",
                format!("units = {:?}: only um / rad / us are supported", self.units),
            ));
        }
        self.pusher.validate().map_err(|e| Error::invalid("trial.json pusher", e.to_string()))?;
        if let Some(r) = self.registration_tol_um
            && !(r.is_finite() && r >= 0.0)
        {
            return Err(Error::invalid(
                "trial.json registration_tol_um",
                format!("registration_tol_um = {r}; must be a finite number ≥ 0 (µm)"),
            ));
        }
        if let Some(p) = self.frame_period_us
            && !(p.is_finite() && p > 0.0)
        {
            return Err(Error::invalid(
                "trial.json frame_period_us",
                format!("frame_period_us = {p}; must be a finite number > 0 (µs)"),
            ));
        }
        Ok(())
    }
}

/// `trial.json` as written by any supported version: what a reader accepts before the
/// version-1 fields are converted.
#[derive(Debug, Deserialize)]
struct MetaFile {
    format: String,
    format_version: u32,
    trial_id: String,
    source: String,
    #[serde(default)]
    units: Units,
    part: Part,
    #[serde(default)]
    pusher: Option<Pusher>,
    #[serde(default)]
    probe_radius_um: Option<f64>,
    #[serde(default)]
    fixture: Option<Fixture>,
    #[serde(default)]
    plan: Option<Plan>,
    #[serde(default)]
    calibration: Option<CalibrationRecord>,
    #[serde(default)]
    frame_period_us: Option<f64>,
    #[serde(default)]
    seeds: BTreeMap<String, u64>,
    #[serde(default)]
    world: Option<serde_json::Value>,
    #[serde(default)]
    import: Option<serde_json::Value>,
    #[serde(default)]
    registration_tol_um: Option<f64>,
    #[serde(default)]
    frames_kept: Option<FramesKept>,
    outcome: Outcome,
}

/// The pusher a file of `version` describes, refusing a field the version does not have.
fn file_pusher(
    version: u32,
    pusher: Option<Pusher>,
    probe_radius_um: Option<f64>,
) -> Result<Pusher, Error> {
    match (version, pusher, probe_radius_um) {
        (1, None, r) => {
            let r = r.unwrap_or(V1_DEFAULT_PROBE_RADIUS_UM);
            if !(r.is_finite() && r >= 0.0) {
                return Err(Error::invalid(
                    "trial.json probe_radius_um",
                    format!("probe_radius_um = {r}; must be a finite number ≥ 0 (µm)"),
                ));
            }
            Ok(Pusher::single(r))
        }
        (1, Some(_), _) => Err(Error::invalid(
            "trial.json pusher",
            "`pusher` is a version-2 field; a file that gives it says \"format_version\": 2",
        )),
        (_, Some(_), Some(r)) => Err(Error::invalid(
            "trial.json probe_radius_um",
            format!(
                "probe_radius_um = {r} is the version-1 field; version 2 gives the pusher's \
                 discs in `pusher` only"
            ),
        )),
        (_, Some(p), None) => Ok(p),
        (v, None, _) => Err(Error::invalid(
            "trial.json pusher",
            format!(
                "format_version {v} requires `pusher`, e.g. {{\"discs\": [{{\"center_um\": \
                 [0, 0], \"radius_um\": 12.5}}]}}"
            ),
        )),
    }
}

impl TryFrom<MetaFile> for TrialMeta {
    type Error = Error;
    fn try_from(f: MetaFile) -> Result<Self, Error> {
        if f.format != super::FORMAT {
            return Err(Error::invalid(
                "trial.json format",
                format!("format = {:?}; expected {:?}", f.format, super::FORMAT),
            ));
        }
        let v = f.format_version;
        if !(super::OLDEST_FORMAT_VERSION..=super::FORMAT_VERSION).contains(&v) {
            return Err(Error::invalid(
                "trial.json format_version",
                format!(
                    "format_version {v} is not supported (this build reads {} to {})",
                    super::OLDEST_FORMAT_VERSION,
                    super::FORMAT_VERSION
                ),
            ));
        }
        let meta = TrialMeta {
            format: f.format,
            format_version: super::FORMAT_VERSION,
            trial_id: f.trial_id,
            source: f.source,
            units: f.units,
            part: f.part,
            pusher: file_pusher(v, f.pusher, f.probe_radius_um)?,
            fixture: f.fixture,
            plan: f.plan,
            calibration: f.calibration,
            frame_period_us: f.frame_period_us,
            seeds: f.seeds,
            world: f.world,
            import: f.import,
            registration_tol_um: f.registration_tol_um,
            frames_kept: f.frames_kept,
            outcome: f.outcome,
        };
        meta.check()?;
        Ok(meta)
    }
}
