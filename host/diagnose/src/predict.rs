//! The extended model's prediction of what a trial measures: the commanded path goes through
//! the stage backlash to the tip, the simulator (with the model's physical effects) moves
//! the peg from the measured start, and the camera images peg and tip through its scale
//! error, stamped `camera_latency_us` late. With every effect off this is the nominal
//! model's prediction.

use super::data::TrialData;
use super::memo::cached;
use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::contact::closest_on_polygon;
use mesopush_sim::effects::{Backlash, Effects, apply_scale_error, remove_scale_error, scale_pose};
use mesopush_sim::{
    Model, PathReplay, PathSample, ProbePoint, Pusher, SimSettings, Simulator, follow_path,
};
use std::convert::Infallible;

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
    // A one-disc pusher is the model's `probe_radius_um`; only other pushers are spelled out.
    m.pusher = (data.pusher != Pusher::single(data.probe_radius_um)).then(|| data.pusher.clone());
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
    cmd.iter().map(|p| ProbePoint { probe_um: b.update(p.probe_um), ..*p }).collect()
}

/// The probe counts as clear of the peg beyond this gap, µm, for the paper's peg (scaled
/// with the part's size for another part): the peg rests there (pushing is quasi-static; an
/// adhesive contact lets go within a few µm).
const CLEAR_GAP_UM: f64 = 100.0;

pub(super) use mesopush_ident::data::probe_at;
use mesopush_ident::data::sub_path;

/// The frames the replay restarts from (multiple shooting): frame 0, and the last frame of
/// every stretch in which the probe is clear of the measured peg before it comes back. The
/// peg rests there, so a replay from its measured pose loses nothing; an error in a stroke
/// then stays in that stroke instead of carrying the peg elsewhere for the rest of the trial
/// (the fit's landscape stays smooth, e.g. in the support's place, to which a long replay
/// is very sensitive).
pub fn restart_frames(
    data: &TrialData,
    path: &[ProbePoint],
    polygon: &ConvexPolygon,
) -> (Vec<usize>, Vec<bool>) {
    let scale = data.part.char_length_um() / mesopush_sim::Part::default_peg().char_length_um();
    let clear_um = CLEAR_GAP_UM * scale;
    let clear: Vec<bool> = data
        .frames
        .iter()
        .map(|f| {
            let w = mesopush_ident::data::pusher_at(path, f.t_s);
            let at = Pose::new(w.probe_um.x, w.probe_um.y, w.probe_theta_rad);
            let peg = polygon.transformed(&f.pose);
            data.pusher.discs_at(&at).all(|(c, _)| closest_on_polygon(&peg, &c).0 > clear_um)
        })
        .collect();
    let mut out = vec![0];
    out.extend((1..clear.len().saturating_sub(1)).filter(|&k| clear[k] && !clear[k + 1]));
    (out, clear)
}

/// Frames averaged for a restart pose: the tracker's noise in one frame would stay in the
/// whole stroke as an offset; the peg rests while the probe is clear, so the mean of the
/// clear frames next to the restart is the better start (its error falls as 1/√n: 30 frames
/// are one second at 30 Hz).
const RESTART_FRAMES: usize = 30;

/// The clear frames whose mean is the restart pose at frame `k`: up to [`RESTART_FRAMES`]
/// back, or, at frame 0, from it forward (the peg rests until the probe first comes near:
/// a start from frame 0 alone carried one frame's tracker noise through the whole first
/// stroke); empty when frame `k` is not clear.
fn rest_span(clear: &[bool], k: usize) -> Vec<usize> {
    if k == 0 {
        (0..clear.len().min(RESTART_FRAMES)).take_while(|&j| clear[j]).collect()
    } else {
        (k.saturating_sub(RESTART_FRAMES - 1)..=k).rev().take_while(|&j| clear[j]).collect()
    }
}

/// The measured pose to restart from at frame `k`: the mean over [`rest_span`], frame `k`
/// alone when it is not clear.
fn rest_pose(data: &TrialData, clear: &[bool], k: usize) -> Pose {
    let span = rest_span(clear, k);
    if span.is_empty() {
        return data.frames[k].pose;
    }
    // Angles averaged as turns from the first (a peg resting at ±π must not average to 0).
    let th0 = data.frames[span[0]].pose.theta_rad;
    let n = span.len() as f64;
    let (mut x, mut y, mut dth) = (0.0, 0.0, 0.0);
    for &j in &span {
        let p = data.frames[j].pose;
        let d = (p.theta_rad - th0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        (x, y, dth) = (x + p.x_um, y + p.y_um, dth + d);
    }
    Pose::new(x / n, y / n, th0 + dth / n)
}

/// One stretch of a replay with restarts: the frames it predicts and how many measured
/// frames its start pose is the mean of (1 when the start frame is not clear).
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Frames predicted by this stretch's replay.
    pub frames: std::ops::Range<usize>,
    /// Frames averaged for its start pose.
    pub rest_frames: usize,
}

/// The stretches [`predict`] replays `data` in under `model` (restarts where the probe has
/// been clear, and after every gap in the recording), in order.
pub fn segments(data: &TrialData, model: &Model) -> Vec<Segment> {
    let path = tip_path(&model.effects, &data.cmd);
    let (starts, clear) = restarts(data, &path, model.part.polygon(), &model.effects, true);
    starts
        .iter()
        .enumerate()
        .map(|(i, &k)| Segment {
            frames: k..starts.get(i + 1).copied().unwrap_or(data.frames.len()),
            rest_frames: rest_span(&clear, k).len().max(1),
        })
        .collect()
}

/// The frames a replay restarts from, sorted ([`restart_frames`] when `with_restarts`, else
/// frame 0; and the first frame after every log gap), and which frames are clear.
fn restarts(
    data: &TrialData,
    path: &[ProbePoint],
    polygon: &ConvexPolygon,
    fx: &Effects,
    with_restarts: bool,
) -> (Vec<usize>, Vec<bool>) {
    // The same at every evaluation with the same backlash (the tip path) and part: kept.
    let (mut starts, clear) = if with_restarts {
        let key = format!("restart_frames {:?} {polygon:?}", fx.backlash_um);
        let Ok(r) = cached(data, &key, || Ok::<_, Infallible>(restart_frames(data, path, polygon)));
        r.as_ref().clone()
    } else {
        (vec![0], vec![false; data.frames.len()])
    };
    // Where the recording says the pusher's path is unknown, the replay starts again.
    for g in &data.log_gaps_s {
        let k = data.frames.partition_point(|f| f.t_s < *g);
        if k < data.frames.len() {
            starts.push(k);
        }
    }
    starts.sort_unstable();
    starts.dedup();
    (starts, clear)
}

/// Predicts every frame of `data` under `model` (its `effects` included), the replay
/// restarted from the measured pose whenever the probe has been clear of the peg
/// ([`restart_frames`]).
pub fn predict(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
) -> Result<Prediction, Error> {
    predict_with(data, model, settings, true, None)
}

/// As [`predict`], with the start pose of segment `segment` ([`segments`]) moved by
/// `offset` (x µm, y µm, θ rad): how the prediction depends on a restart pose measured
/// with the tracker's noise ([`crate::start_pose`]).
pub fn predict_shifted(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
    segment: usize,
    offset: [f64; 3],
) -> Result<Prediction, Error> {
    predict_with(data, model, settings, true, Some((segment, offset)))
}

/// Predicts every frame of `data` under `model` in one replay from the first frame's pose:
/// what a generator of trials needs (its frames are not measured yet).
pub fn predict_open_loop(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
) -> Result<Prediction, Error> {
    predict_with(data, model, settings, false, None)
}

fn predict_with(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
    with_restarts: bool,
    shift: Option<(usize, [f64; 3])>,
) -> Result<Prediction, Error> {
    let fx = &model.effects;
    let m = model_for_trial(model, data);
    let path = tip_path(fx, &data.cmd);
    let mut sim = Simulator::new(m, data.fixture.clone(), settings.clone())?;
    let compliance_um = sim.settings().probe_compliance_um;
    let polygon = sim.model().part.polygon().clone();
    let mut replay = PathReplay {
        samples: Vec::new(),
        jams: 0,
        steps: 0,
        lcp_solves: 0,
        start_separation_um: 0.0,
    };
    let (starts, clear) = restarts(data, &path, &polygon, fx, with_restarts);
    for (i, &k) in starts.iter().enumerate() {
        let t0 = data.frames[k].t_s;
        let mut t1 = starts.get(i + 1).map_or(f64::INFINITY, |&j| data.frames[j].t_s);
        // A segment ends at the last recorded command before a gap in the recording, not
        // on the invented straight line across it.
        if let Some(g) = data.log_gaps_s.iter().find(|g| **g > t0 && **g <= t1) {
            t1 = path.iter().map(|p| p.t_s).filter(|t| t < g).fold(t0, f64::max);
        }
        let seg = sub_path(&path, t0, t1);
        if seg.len() < 2 {
            continue;
        }
        let mut at = rest_pose(data, &clear, k);
        if let Some((_, [dx, dy, dth])) = shift.filter(|(j, _)| *j == i) {
            at = Pose::new(at.x_um + dx, at.y_um + dy, at.theta_rad + dth);
        }
        let c = remove_scale_error(at.position(), fx.scale_error, fx.scale_origin_um);
        // The angle's aspect distortion is second order (< 1e-4 rad at 3 %); ignored here.
        if i > 0 {
            sim.reset();
        }
        let r = follow_path(&mut sim, Pose::new(c.x, c.y, at.theta_rad), &seg)?;
        replay.jams += r.jams;
        replay.samples.extend(r.samples);
    }
    if replay.samples.is_empty() {
        return Err(Error::invalid("diagnose", format!("trial {} has no probe path", data.id)));
    }
    let latency_s = fx.camera_latency_us * 1e-6;
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
