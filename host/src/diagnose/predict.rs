//! The extended model's prediction of what a trial measures: the commanded path goes through
//! the stage backlash to the tip, the simulator (with the model's physical effects) moves
//! the peg from the measured start, and the camera images peg and tip through its scale
//! error, stamped `camera_latency_us` late. With every effect off this is the nominal
//! model's prediction.

use super::data::TrialData;
use crate::Error;
use crate::effects::{Backlash, Effects, apply_scale_error, remove_scale_error, scale_pose};
use crate::geom::{Pose, Vec2};
use crate::sim::contact::closest_on_polygon;
use crate::sim::{Model, PathSample, ProbePoint, SimSettings, Simulator, follow_path};

/// The predicted measurement of every frame of a trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// Predicted measured peg pose per frame.
    pub poses: Vec<Pose>,
    /// Predicted imaged probe tip per frame, µm.
    pub tips_um: Vec<Vec2>,
    /// Probe contact force at each frame, part weights.
    pub force: Vec<f64>,
    /// Segments on which the simulated peg wedged.
    pub jams: usize,
}

/// The model a trial sees: its own part and probe, and the support drifted to its place in
/// the batch.
pub fn model_for_trial(model: &Model, data: &TrialData) -> Model {
    let mut m = model_for_index(model, data.index);
    m.probe_radius_um = data.probe_radius_um;
    m
}

/// The model of the trial at place `index` in the batch: the support drifted there.
fn model_for_index(model: &Model, index: usize) -> Model {
    let mut m = model.clone();
    if let Some(d) = &model.effects.support_drift {
        let k = index as f64;
        for p in &mut m.support.points_um {
            p[0] += k * d.points_um_per_trial[0];
            p[1] += k * d.points_um_per_trial[1];
        }
        for mu in &mut m.support.mu_surface {
            *mu = (*mu + k * d.mu_surface_per_trial).clamp(0.0, 2.0);
        }
    }
    m
}

/// Whether `model` is physical for every trial of a batch whose last index is `last_index`:
/// with a support drift, the drifted support must stay inside the part and hold its weight
/// at both ends of the batch (and so, the drift being linear and the part convex, between).
/// A fit must not explain the training trials with a drift that no held-out trial could
/// have had.
pub fn valid_over_batch(model: &Model, last_index: usize) -> bool {
    if model.effects.support_drift.is_none() {
        return true;
    }
    [0, last_index].into_iter().all(|k| {
        let m = model_for_index(model, k);
        m.validate().is_ok()
    })
}

/// Linear interpolation of the samples at `t_s` (clamped to the replay's span).
fn sample_at(samples: &[PathSample], t_s: f64) -> (Pose, Vec2, f64) {
    let i = samples.partition_point(|s| s.t_s <= t_s);
    if i == 0 {
        let s = &samples[0];
        return (s.peg, s.probe_um, s.probe_force);
    }
    if i == samples.len() {
        let s = &samples[i - 1];
        return (s.peg, s.probe_um, s.probe_force);
    }
    let (a, b) = (&samples[i - 1], &samples[i]);
    let span = b.t_s - a.t_s;
    let w = if span > 0.0 { (t_s - a.t_s) / span } else { 1.0 };
    let peg = Pose::new(
        a.peg.x_um + w * (b.peg.x_um - a.peg.x_um),
        a.peg.y_um + w * (b.peg.y_um - a.peg.y_um),
        a.peg.theta_rad + w * (b.peg.theta_rad - a.peg.theta_rad),
    );
    (peg, a.probe_um + (b.probe_um - a.probe_um) * w, b.probe_force)
}

/// The tip path after the stage backlash.
pub fn tip_path(fx: &Effects, cmd: &[ProbePoint]) -> Vec<ProbePoint> {
    if fx.backlash_um == [0.0, 0.0] {
        return cmd.to_vec();
    }
    let mut b = Backlash::new(fx.backlash_um);
    cmd.iter().map(|p| ProbePoint { t_s: p.t_s, probe_um: b.update(p.probe_um) }).collect()
}

/// Predicts every frame of `data` under `model` (its `effects` included).
pub fn predict(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
) -> Result<Prediction, Error> {
    let fx = &model.effects;
    let m = model_for_trial(model, data);
    let path = tip_path(fx, &data.cmd);
    let first = data.frames[0].pose;
    let c = remove_scale_error(first.position(), fx.scale_error, fx.scale_origin_um);
    // The angle's aspect distortion is second order (< 1e-4 rad at 3 %); ignored at the start.
    let start = Pose::new(c.x, c.y, first.theta_rad);
    let mut sim = Simulator::new(m, data.fixture.clone(), settings.clone())?;
    let compliance_um = sim.settings().probe_compliance_um;
    let replay = follow_path(&mut sim, start, &path)?;
    let latency_s = fx.camera_latency_us * 1e-6;
    let polygon = sim.model().part.polygon().clone();
    let n = data.frames.len();
    let mut out = Prediction {
        poses: Vec::with_capacity(n),
        tips_um: Vec::with_capacity(n),
        force: Vec::with_capacity(n),
        jams: replay.jams,
    };
    for f in &data.frames {
        let (peg, probe, force) = sample_at(&replay.samples, f.t_s - latency_s);
        // The needle bends back along the contact normal by compliance × force.
        let mut tip = probe;
        if force > 0.0 {
            let (_, _, n_out) = closest_on_polygon(&polygon.transformed(&peg), &probe);
            tip += n_out * (compliance_um * force);
        }
        out.poses.push(scale_pose(&peg, fx.scale_error, fx.scale_origin_um));
        out.tips_um.push(apply_scale_error(tip, fx.scale_error, fx.scale_origin_um));
        out.force.push(force);
    }
    Ok(out)
}
