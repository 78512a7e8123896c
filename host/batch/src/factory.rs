//! The runner a batch file asks for, built from the file alone: `rig` (the whole loop over
//! the world file) or `sim` (the host simulator with the batch's model and fixture). One
//! place, so the CLI and the tests run a batch file the same way.

use super::runner::{RunnerFactory, TrialRunner};
use super::{BatchSpec, RigRunner, SimRunner};
use crate::Error;
use mesopush_rig::WorldFile;
use mesopush_sim::{Fixture, Model};
use serde_json::json;
use std::path::Path;

/// The runner factory for `spec`; relative paths in it are resolved against `base` (the
/// batch file's folder); `theta_hint_rad` orients the pre-trial tracker.
pub fn runner_factory(
    spec: &BatchSpec,
    base: &Path,
    theta_hint_rad: f64,
) -> Result<RunnerFactory, Error> {
    if spec.runner == "rig" {
        let world = match &spec.world.file {
            Some(p) => WorldFile::load(&base.join(p))?,
            None => WorldFile::default_world(),
        };
        let (camera, frames) = (spec.camera.clone(), spec.frames);
        return Ok(Box::new(move || {
            let r = RigRunner::new(world.clone(), &camera, theta_hint_rad)?.keeping(frames);
            Ok(Box::new(r) as Box<dyn TrialRunner>)
        }));
    }
    let model = match &spec.world.model {
        Some(p) => Model::load(&base.join(p))?,
        None => Model::default(),
    };
    let fixture = match &spec.world.fixture {
        Some(p) => Fixture::load(&base.join(p))?,
        None => Fixture::paper(),
    };
    let world = json!({"runner": "sim", "world": spec.world, "camera": spec.camera});
    let camera = spec.camera.clone();
    Ok(Box::new(move || {
        let r =
            SimRunner::new(model.clone(), fixture.clone(), &camera, theta_hint_rad, world.clone())?;
        Ok(Box::new(r) as Box<dyn TrialRunner>)
    }))
}
