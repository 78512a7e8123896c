//! The world file (`worlds/*.toml`): everything the firmware simulator's physical world is
//! made of — its own physical model (which may differ from the host's nominal one), the peg's
//! start and a seeded start perturbation, the stage's registration to the fixture frame, the
//! camera (period, readout, the true optics and the calibration the host is told), the
//! faults to inject, and the undeclared effects (`[effects]`, [`Effects`]) the host's model
//! does not know about. Documented in `docs/hil.md`. The file's text is kept verbatim: the trial
//! log stores it in `trial.json` (`world`), where identification never reads it.

use super::world_check::{check_camera, check_optics, check_peg, check_stage_offset};
use crate::Error;
use mesopush_core::geom::Vec2;
use mesopush_firmware_sim::FaultConfig;
use mesopush_sim::Model;
use mesopush_sim::effects::Effects;
use mesopush_sim::plan::PegStart;
use mesopush_vision::Calibration;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The default world, embedded (`worlds/default.toml`).
pub const DEFAULT_WORLD_TOML: &str = include_str!("../../../../worlds/default.toml");

/// The world's physics: a model inline, or a path to a model TOML (relative to the world
/// file), or (neither) the host's default model.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// Path of a model TOML, relative to the world file's directory.
    #[serde(default)]
    pub path: Option<PathBuf>,
    /// The model inline.
    #[serde(default)]
    pub inline: Option<Model>,
}

/// Where the peg starts in the world.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PegSpec {
    /// Start pose; absent: the plan's nominal start.
    #[serde(default)]
    pub start: Option<PegStart>,
    /// Uniform start perturbation ±(x µm, y µm, θ degrees) drawn from the seed; default none.
    #[serde(default)]
    pub perturb: Option<[f64; 3]>,
}

/// The stage's registration: stage position (controller nm) = (fixture µm + `offset_um`) ×
/// 1000. The host is told the same (as a rig's stage-to-fixture registration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Fixture origin in stage coordinates, µm. Default (1000, 1000).
    #[serde(default = "default_offset")]
    pub offset_um: [f64; 2],
}

fn default_offset() -> [f64; 2] {
    [1000.0, 1000.0]
}

impl Default for StageSpec {
    fn default() -> Self {
        Self { offset_um: default_offset() }
    }
}

/// The microscope camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Frame period, µs. Default 33 333 (30 Hz).
    #[serde(default = "default_period")]
    pub period_us: u64,
    /// Readout and transfer: a frame arrives this long after its exposure, µs. Default 15 000.
    #[serde(default = "default_readout")]
    pub readout_us: u64,
    /// Image size, px. Default 928 × 480 (the paper's scale, widened to the left so the
    /// inserted peg stays in view).
    #[serde(default = "default_size")]
    pub size_px: [u32; 2],
    /// µm per pixel (x, y) the host tracks with. Default the paper's 5.265625, 5.25.
    #[serde(default = "default_scale")]
    pub um_per_px: [f64; 2],
    /// Fixture origin in the image, continuous px. Default (285, 0).
    #[serde(default = "default_origin")]
    pub origin_px: [f64; 2],
    /// Seed offset of the renderer's sensor noise stream (kept for reproducible variants).
    #[serde(default)]
    pub noise_stream: u64,
}

fn default_period() -> u64 {
    33_333
}
fn default_readout() -> u64 {
    15_000
}
fn default_size() -> [u32; 2] {
    [928, 480]
}
fn default_scale() -> [f64; 2] {
    [5.265625, 5.25]
}
fn default_origin() -> [f64; 2] {
    [285.0, 0.0]
}

impl Default for CameraSpec {
    fn default() -> Self {
        Self {
            period_us: default_period(),
            readout_us: default_readout(),
            size_px: default_size(),
            um_per_px: default_scale(),
            origin_px: default_origin(),
            noise_stream: 0,
        }
    }
}

impl CameraSpec {
    /// The calibration the host tracks with.
    pub fn calibration(&self) -> Result<Calibration, Error> {
        let [sx, sy] = self.um_per_px;
        let [ox, oy] = self.origin_px;
        Ok(Calibration::new(sx, sy, Vec2::new(ox, oy))?)
    }
}

/// The world's faults, validated (probabilities in `[0, 1]`, rates non-negative).
pub fn validated_faults(f: &FaultConfig) -> Result<FaultConfig, Error> {
    f.validate().map_err(|e| Error::invalid("world faults", e.to_string()))?;
    Ok(*f)
}

/// The faults a real-time run injects: the stage's and the camera's, validated; not the
/// line faults (in real time the lines are real).
pub fn realtime_faults(f: &FaultConfig) -> Result<FaultConfig, Error> {
    Ok(FaultConfig {
        link_drop: 0.0,
        link_corrupt: 0.0,
        link_duplicate: 0.0,
        link_delay: 0.0,
        ..validated_faults(f)?
    })
}

/// A parsed world file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    /// Free-text name.
    #[serde(default)]
    pub name: String,
    /// The world's physics.
    #[serde(default)]
    pub model: ModelSpec,
    /// The peg's start.
    #[serde(default)]
    pub peg: PegSpec,
    /// Stage registration.
    #[serde(default)]
    pub stage: StageSpec,
    /// The camera.
    #[serde(default)]
    pub camera: CameraSpec,
    /// Faults to inject.
    #[serde(default)]
    pub faults: FaultConfig,
    /// Undeclared effects (default: none). The one place a world declares them: the
    /// physical ones (compliance, adhesion, friction patch, speed friction) are copied into
    /// the world's model; backlash, camera latency and scale error act in the world
    /// ([`super::world::RigWorld`]) and the renderer. Never passed to the host.
    #[serde(default)]
    pub effects: Effects,
}

/// A world file: its parsed contents, its text verbatim and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldFile {
    /// Parsed contents.
    pub spec: WorldSpec,
    /// The model the world runs (resolved from `spec.model`).
    pub model: Model,
    /// The file's text, verbatim.
    pub text: String,
    /// The file (absent: embedded or built in code).
    pub path: Option<PathBuf>,
}

impl WorldFile {
    /// Parses `text` (`path` names it in errors and anchors a relative model path).
    pub fn from_toml(text: &str, path: Option<&Path>) -> Result<Self, Error> {
        let name = path.map_or_else(|| PathBuf::from("<world>"), Path::to_path_buf);
        let spec: WorldSpec = toml::from_str(text)
            .map_err(|e| Error::Parse { path: name.clone(), message: e.to_string() })?;
        let in_file = |e: Error| Error::Parse { path: name.clone(), message: e.to_string() };
        let model = match (&spec.model.inline, &spec.model.path) {
            (Some(_), Some(_)) => {
                return Err(in_file(Error::invalid(
                    "world model",
                    "give either `inline` or `path`",
                )));
            }
            (Some(m), None) => m.clone(),
            (None, Some(p)) => {
                let base = path.and_then(Path::parent).unwrap_or(Path::new("."));
                Model::load(&base.join(p))?
            }
            (None, None) => Model::default(),
        };
        let model = with_physical_effects(model, &spec.effects).map_err(in_file)?;
        model.validate().map_err(|e| in_file(e.into()))?;
        check_values(&spec).map_err(in_file)?;
        Ok(Self { spec, model, text: text.to_string(), path: path.map(Path::to_path_buf) })
    }

    /// The calibration the renderer really images with: the host's one when the world has
    /// no scale error; else the one that makes the host's measurement of a fixture point
    /// `p` equal `o + (p − o)(1 + err)` (`o` = `effects.scale_origin_um`, the convention of
    /// [`mesopush_sim::effects::apply_scale_error`]): true µm/px = told / (1 + err), origin moved
    /// by `−o·err / told`.
    pub fn render_calibration(&self) -> Result<Calibration, Error> {
        let cal = self.spec.camera.calibration()?;
        let [ex, ey] = self.spec.effects.scale_error;
        let [ox, oy] = self.spec.effects.scale_origin_um;
        let (sx, sy) = (cal.sx_um_per_px, cal.sy_um_per_px);
        Ok(Calibration::new(
            sx / (1.0 + ex),
            sy / (1.0 + ey),
            Vec2::new(cal.origin_px.x - ox * ex / sx, cal.origin_px.y - oy * ey / sy),
        )?)
    }

    /// Loads a world file.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::from_toml(&text, Some(path))
    }

    /// The embedded default world.
    pub fn default_world() -> Self {
        Self::from_toml(DEFAULT_WORLD_TOML, None).expect("the embedded default world is valid")
    }

    /// The description stored in `trial.json`: the text verbatim plus the parsed form (and
    /// the camera period in force, which a batch may set apart from the text).
    pub fn description(&self) -> serde_json::Value {
        serde_json::json!({
            "file": self.path.as_ref().map(|p| p.display().to_string()),
            "toml": self.text,
            "resolved_model": self.model,
            "camera_period_us": self.spec.camera.period_us,
        })
    }
}

/// Every value of the world's own tables within its range ([`super::world_check`]).
fn check_values(spec: &WorldSpec) -> Result<(), Error> {
    validated_faults(&spec.faults)?;
    let (c, fx) = (&spec.camera, &spec.effects);
    check_camera(c.period_us, c.readout_us, c.size_px, fx.camera_latency_us)?;
    check_optics(c.um_per_px, c.origin_px)?;
    spec.camera.calibration()?;
    check_stage_offset(spec.stage.offset_um)?;
    check_peg(spec.peg.start.as_ref(), spec.peg.perturb)
}

/// The world's model with the physical part of `effects` (compliance, adhesion, friction
/// patch, speed friction) as its `effects`: the world file's `[effects]` table is the one
/// source, so a model that brings effects of its own is refused, as is support drift (a
/// single trial has no place in a batch).
fn with_physical_effects(mut model: Model, effects: &Effects) -> Result<Model, Error> {
    effects.validate()?;
    if !model.effects.is_none() {
        return Err(Error::invalid(
            "world model",
            "the model has an [effects] table; declare a world's effects in the world file's \
             [effects] table",
        ));
    }
    if effects.support_drift.is_some() {
        return Err(Error::invalid(
            "world effects",
            "support_drift acts over a batch; a world runs one trial (not supported here)",
        ));
    }
    model.effects = Effects {
        probe_compliance_um_per_weight: effects.probe_compliance_um_per_weight,
        adhesion: effects.adhesion,
        friction_patch: effects.friction_patch,
        speed_friction: effects.speed_friction,
        ..Effects::default()
    };
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_world_parses() {
        let w = WorldFile::default_world();
        assert_eq!(w.spec.camera.period_us, 33_333);
        assert_eq!(w.model, Model::default());
    }

    #[test]
    fn unknown_fields_and_bad_rates_are_named() {
        let e = WorldFile::from_toml("[camera]\nperiod = 3\n", None).unwrap_err().to_string();
        assert!(e.contains("period"), "{e}");
        let e = WorldFile::from_toml("[faults]\nlink_drop = 2.0\n", None).unwrap_err();
        assert!(e.to_string().contains("link_drop"), "{e}");
    }

    #[test]
    fn physical_effects_reach_the_model_and_scale_error_the_renderer() {
        let text = "[effects]\nbacklash_um = [10.0, 10.0]\nscale_error = [0.02, -0.01]\n\
                    scale_origin_um = [100.0, 50.0]\n\
                    [effects.adhesion]\npull_off_weight = 0.3\n";
        let w = WorldFile::from_toml(text, None).unwrap();
        assert_eq!(w.model.effects.adhesion.map(|a| a.pull_off_weight), Some(0.3));
        assert_eq!(w.model.effects.backlash_um, [0.0, 0.0], "kinematic effects stay in the world");
        let (told, real) = (w.spec.camera.calibration().unwrap(), w.render_calibration().unwrap());
        let p = Vec2::new(1100.0, 2050.0);
        let measured = told.px_to_um(&real.um_to_px(&p));
        let want = mesopush_sim::effects::apply_scale_error(p, [0.02, -0.01], [100.0, 50.0]);
        assert!((measured - want).norm() < 1e-9, "{measured:?} vs {want:?}");
        let clean = WorldFile::default_world();
        assert_eq!(clean.render_calibration().unwrap(), clean.spec.camera.calibration().unwrap());
    }

    #[test]
    fn effects_outside_the_world_table_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = Model::default();
        m.effects.backlash_um = [1.0, 1.0];
        m.save(&dir.path().join("m.toml")).unwrap();
        let world = dir.path().join("w.toml");
        let e = WorldFile::from_toml("[model]\npath = \"m.toml\"\n", Some(&world)).unwrap_err();
        assert!(e.to_string().contains("[effects]"), "{e}");
        m.effects = Effects::default();
        m.save(&dir.path().join("m.toml")).unwrap();
        WorldFile::from_toml("[model]\npath = \"m.toml\"\n", Some(&world)).unwrap();
        let e = WorldFile::from_toml("[effects.support_drift]\nmu_surface_per_trial = 0.1\n", None)
            .unwrap_err();
        assert!(e.to_string().contains("support_drift"), "{e}");
        let e = WorldFile::from_toml("[effects]\nbacklash_um = [-1.0, 0.0]\n", None).unwrap_err();
        assert!(e.to_string().contains("backlash_um"), "{e}");
    }

    #[test]
    fn the_example_worlds_parse_and_carry_their_effect() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds");
        for name in ["latency", "backlash", "scale", "adhesion", "patch"] {
            let w = WorldFile::load(&dir.join(format!("{name}.toml"))).unwrap();
            assert!(!w.spec.effects.is_none(), "{name}.toml declares no effect");
        }
    }
}
