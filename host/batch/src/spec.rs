//! The batch file (`batches/*.toml`): which plans, how many trials, the world (start-pose
//! perturbation, camera faults, model and fixture), the runner, the retry and timeout policy
//! and the output directory. Paths inside it are relative to the batch file; `out` is
//! relative to the working directory (like every `--out`). Parsed strictly: an unknown field
//! is an error naming it.

use super::runner::TrialVerdict;
use crate::Error;
use mesopush_sim::Plan;
use mesopush_trial::FrameRetention;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Most trials one batch may hold (bounded loops; shard anything larger).
pub const MAX_TRIALS: u64 = 10_000_000;

/// The whole batch file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatchSpec {
    /// Free-text name.
    #[serde(default)]
    pub name: String,
    /// The one seed every random choice of the batch derives from.
    pub seed: u64,
    /// Number of trials.
    pub trials: u64,
    /// Which runner: `rig` (the whole loop: executor, firmware simulator, camera, tracking;
    /// the default) or `sim` (the host simulator alone; fast Monte Carlo).
    #[serde(default = "default_runner")]
    pub runner: String,
    /// Output directory (relative to the working directory); `--out` overrides it.
    #[serde(default)]
    pub out: Option<PathBuf>,
    /// Plan files (relative to the batch file). Several: the runner chooses the one whose
    /// nominal start is nearest the estimated start.
    pub plans: Vec<PathBuf>,
    /// The simulated world.
    #[serde(default)]
    pub world: BatchWorld,
    /// Start-pose estimation from the camera.
    #[serde(default)]
    pub camera: StartCameraSpec,
    /// Timeouts and retries.
    #[serde(default)]
    pub policy: Policy,
    /// Which frame images each trial keeps: `"all"` (default), `"failed"` (only trials whose
    /// verdict is not inserted), `"every N"`, `"none"`; `batch run --frames` overrides it.
    /// Poses are tracked while the trial runs, so results never depend on it.
    #[serde(default)]
    pub frames: FrameRetention,
}

fn default_runner() -> String {
    "rig".into()
}

/// The world a trial runs in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatchWorld {
    /// Uniform start perturbation half-widths: x µm, y µm, θ degrees (default the paper's
    /// trials: 26 µm, 74 µm, 3°), around the first plan's nominal start.
    #[serde(default = "default_perturbation")]
    pub perturbation: [f64; 3],
    /// Model TOML (relative to the batch file); default the nominal model.
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// Fixture TOML (relative to the batch file); default the paper's fixture. `sim` only
    /// (the `rig` world is the paper's fixture).
    #[serde(default)]
    pub fixture: Option<PathBuf>,
    /// `rig` only: the world file (`worlds/*.toml` format: the world's model, camera,
    /// faults), relative to the batch file; default the embedded default world. Its
    /// `peg.perturb` is ignored (`perturbation` above applies).
    #[serde(default)]
    pub file: Option<PathBuf>,
}

fn default_perturbation() -> [f64; 3] {
    [26.0, 74.0, 3.0]
}

impl Default for BatchWorld {
    fn default() -> Self {
        Self { perturbation: default_perturbation(), model: None, fixture: None, file: None }
    }
}

/// How the start pose is estimated from the camera before the plan is adapted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartCameraSpec {
    /// Render and track the first frame to estimate the start (default true). False: the
    /// plan runs unadapted from its nominal start (open loop, as the paper's trials).
    #[serde(default = "yes")]
    pub estimate_start: bool,
    /// Frames tried before the trial is faulted for want of a start pose (default 5).
    #[serde(default = "default_frames")]
    pub max_frames: u32,
    /// Probability a frame is dropped (default 0).
    #[serde(default)]
    pub frame_drop: f64,
    /// Probability a frame is black (default 0).
    #[serde(default)]
    pub frame_black: f64,
    /// `rig` runner only: film each trial at this frame period, µs, instead of the world
    /// file's (absent: the world's, 33 333 µs = 30 Hz). Rendering and tracking every frame is
    /// most of a full-loop trial's cost, so a batch at scale films slower (e.g. 500 000 µs,
    /// 2 Hz); the verdict still comes from the last tracked frame after the peg came to rest.
    #[serde(default)]
    pub film_period_us: Option<u64>,
}

fn yes() -> bool {
    true
}

fn default_frames() -> u32 {
    5
}

impl StartCameraSpec {
    /// The faults the start camera injects and how long it tries.
    pub fn frame_faults(&self) -> mesopush_rig::plant::start_camera::FrameFaults {
        mesopush_rig::plant::start_camera::FrameFaults {
            max_frames: self.max_frames,
            frame_drop: self.frame_drop,
            frame_black: self.frame_black,
        }
    }
}

impl Default for StartCameraSpec {
    fn default() -> Self {
        Self {
            estimate_start: true,
            max_frames: default_frames(),
            frame_drop: 0.0,
            frame_black: 0.0,
            film_period_us: None,
        }
    }
}

/// Timeouts and retries.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Policy {
    /// Wall-clock budget of one attempt, s (default 120).
    #[serde(default = "default_timeout")]
    pub timeout_s: f64,
    /// After cancelling, how long to wait for the runner to stop before abandoning it and
    /// building a fresh one, s (default 5).
    #[serde(default = "default_grace")]
    pub grace_s: f64,
    /// Attempts per trial (default 2: one retry).
    #[serde(default = "default_attempts")]
    pub max_attempts: u32,
    /// Verdicts that earn another attempt (default `timeout`, `error`).
    #[serde(default = "default_retry_on")]
    pub retry_on: Vec<TrialVerdict>,
}

fn default_timeout() -> f64 {
    120.0
}
fn default_grace() -> f64 {
    5.0
}
fn default_attempts() -> u32 {
    2
}
fn default_retry_on() -> Vec<TrialVerdict> {
    vec![TrialVerdict::Timeout, TrialVerdict::Error]
}

impl Default for Policy {
    fn default() -> Self {
        Self {
            timeout_s: default_timeout(),
            grace_s: default_grace(),
            max_attempts: default_attempts(),
            retry_on: default_retry_on(),
        }
    }
}

fn bad(message: impl Into<String>) -> Error {
    Error::invalid("batch", message)
}

impl BatchSpec {
    /// Parses and checks a batch file.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let spec: BatchSpec = toml::from_str(&text)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        spec.validate().map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        Ok(spec)
    }

    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), Error> {
        if self.trials == 0 || self.trials > MAX_TRIALS {
            return Err(bad(format!("trials = {}: must be in 1..={MAX_TRIALS}", self.trials)));
        }
        if self.runner != "sim" && self.runner != "rig" {
            return Err(bad(format!("runner = {:?}: expected \"rig\" or \"sim\"", self.runner)));
        }
        if self.plans.is_empty() {
            return Err(bad("plans must name at least one plan file"));
        }
        let [px, py, pt] = self.world.perturbation;
        if !self.world.perturbation.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(bad(format!(
                "world.perturbation = [{px}, {py}, {pt}]: each must be finite and ≥ 0 (µm, µm, °)"
            )));
        }
        let c = &self.camera;
        for (name, p) in [("frame_drop", c.frame_drop), ("frame_black", c.frame_black)] {
            if !(0.0..=1.0).contains(&p) {
                return Err(bad(format!("camera.{name} = {p}: must be a probability in [0, 1]")));
            }
        }
        if c.max_frames == 0 || c.max_frames > 1000 {
            return Err(bad(format!("camera.max_frames = {}: must be in 1..=1000", c.max_frames)));
        }
        if let Some(p) = c.film_period_us.filter(|p| !(1_000..=10_000_000).contains(p)) {
            return Err(bad(format!(
                "camera.film_period_us = {p}: must be in 1000..=10000000 µs (1 kHz to 0.1 Hz)"
            )));
        }
        let p = &self.policy;
        for (name, v) in [("timeout_s", p.timeout_s), ("grace_s", p.grace_s)] {
            if !(v.is_finite() && v > 0.0 && v <= 86_400.0) {
                return Err(bad(format!("policy.{name} = {v}: must be in (0, 86400] s")));
            }
        }
        if p.max_attempts == 0 || p.max_attempts > 100 {
            return Err(bad(format!(
                "policy.max_attempts = {}: must be in 1..=100",
                p.max_attempts
            )));
        }
        if p.retry_on.iter().any(|v| matches!(v, TrialVerdict::Inserted)) {
            return Err(bad(
                "policy.retry_on = [.., \"inserted\", ..]: a success is never retried",
            ));
        }
        Ok(())
    }

    /// Loads the plans, resolved against the batch file's directory `base`.
    pub fn load_plans(&self, base: &Path) -> Result<Vec<Plan>, Error> {
        Ok(self.plans.iter().map(|p| Plan::load(&base.join(p))).collect::<Result<_, _>>()?)
    }
}

/// SplitMix64: the seed mixer (trial seeds from the batch seed and index).
pub fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of trial `index` of a batch seeded `seed` (independent of sharding).
pub fn trial_seed(seed: u64, index: u64) -> u64 {
    mix(seed ^ mix(index))
}

/// The seed of attempt `attempt` of a trial.
pub fn attempt_seed(trial_seed: u64, attempt: u32) -> u64 {
    mix(trial_seed.wrapping_add(u64::from(attempt)))
}

/// `trial-000007`.
pub fn trial_id(index: u64) -> String {
    format!("trial-{index:06}")
}

/// Trial directories live here, inside the batch directory.
pub const TRIALS_DIR: &str = "trials";

/// Directory of an attempt, relative to the batch directory.
pub fn attempt_dir(index: u64, attempt: u32) -> String {
    format!("{TRIALS_DIR}/{}-a{attempt}", trial_id(index))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_field_is_named() {
        let text = "seed = 1\ntrials = 3\nplans = [\"a.toml\"]\nbogus = 2\n";
        let e = toml::from_str::<BatchSpec>(text).unwrap_err().to_string();
        assert!(e.contains("bogus"), "{e}");
    }

    /// Every numeric field out of range is refused naming the field, the value and the range.
    #[test]
    fn out_of_range_fields_are_named_with_value_and_range() {
        let base = "seed = 1\ntrials = 3\nplans = [\"a.toml\"]\n";
        for (extra, needles) in [
            ("", &["trials = 0", "1..=10000000"][..]),
            ("[world]\nperturbation = [1.0, -2.0, 0.0]\n", &["world.perturbation", "-2", "≥ 0"]),
            ("[camera]\nframe_drop = 1.5\n", &["camera.frame_drop = 1.5", "[0, 1]"]),
            ("[camera]\nframe_black = -0.1\n", &["camera.frame_black = -0.1", "[0, 1]"]),
            ("[camera]\nmax_frames = 0\n", &["camera.max_frames = 0", "1..=1000"]),
            ("[camera]\nfilm_period_us = 5\n", &["camera.film_period_us = 5", "1000..="]),
            ("[policy]\ntimeout_s = 0.0\n", &["policy.timeout_s = 0", "(0, 86400]"]),
            ("[policy]\ngrace_s = inf\n", &["policy.grace_s = inf", "(0, 86400]"]),
            ("[policy]\nmax_attempts = 0\n", &["policy.max_attempts = 0", "1..=100"]),
        ] {
            let text = if extra.is_empty() {
                base.replace("trials = 3", "trials = 0")
            } else {
                format!("{base}{extra}")
            };
            let spec: BatchSpec = toml::from_str(&text).unwrap();
            let e = spec.validate().unwrap_err().to_string();
            for n in needles {
                assert!(e.contains(n), "{extra:?}: {n:?} not in {e}");
            }
        }
    }

    #[test]
    fn retrying_a_success_is_refused() {
        let text =
            "seed = 1\ntrials = 3\nplans = [\"a.toml\"]\n[policy]\nretry_on = [\"inserted\"]\n";
        let spec: BatchSpec = toml::from_str(text).unwrap();
        assert!(spec.validate().unwrap_err().to_string().contains("retry_on"));
    }
}
