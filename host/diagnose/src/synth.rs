//! A trial generator for testing diagnosis: trial logs in the documented format (trial.json,
//! probe.csv, pose.csv with the imaged tip; no frames — as a trial tracked elsewhere) made
//! from a true model that may carry one library effect at a realistic size, undeclared:
//! the effect is written only into `world` in trial.json, which diagnosis never reads.
//!
//! Probe paths (100 Hz setpoints) are strokes around an open-plate peg: approach a random
//! edge, push, pull back a little (a reversal), push again, retract (a release), dwell —
//! at a speed drawn per stroke, so backlash, adhesion, latency and speed have signatures.
//! Frames at 30 Hz: the peg pose and tip at the exposure, through the scale error, stamped
//! late by the latency, with tracker-like noise (0.3 µm, 0.04°; tip 0.5 µm).

use super::candidates::Effect;
use super::data::{Measured, TrialData, open_plate};
use super::predict::{Prediction, predict_open_loop};
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_protocol::units;
use mesopush_sim::effects::{Adhesion, Effects, FrictionPatch, SpeedFriction, SupportDrift};
use mesopush_sim::{Model, ProbePoint, SimSettings, Simulator, follow_path};
use mesopush_trial::{Outcome, TrialMeta, TrialState, TrialWriter};
use rand::{Rng, RngExt};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Setpoint period, s (100 Hz).
const CMD_DT_S: f64 = 0.01;
/// Frame period, µs (30 Hz).
const FRAME_US: i64 = 33_333;

/// Tracker-like measurement noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthNoise {
    /// Peg position per axis, µm.
    pub xy_um: f64,
    /// Peg angle, rad.
    pub theta_rad: f64,
    /// Imaged tip per axis, µm.
    pub tip_um: f64,
}

impl Default for SynthNoise {
    fn default() -> Self {
        Self { xy_um: 0.3, theta_rad: 0.04f64.to_radians(), tip_um: 0.5 }
    }
}

/// A standard normal deviate (Box–Muller).
fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// One library effect at a realistic size (the ranges), drawn from `rng`.
pub fn realistic_effect(c: Effect, rng: &mut impl Rng) -> Effects {
    let sign = |rng: &mut dyn FnMut() -> bool| if rng() { 1.0 } else { -1.0 };
    let mut coin = || rng.random_bool(0.5);
    let s = [sign(&mut coin), sign(&mut coin)];
    let mut e = Effects::default();
    match c {
        Effect::Nominal => {}
        Effect::Backlash => {
            e.backlash_um = [rng.random_range(5.0..20.0), rng.random_range(5.0..20.0)]
        }
        Effect::Latency => e.camera_latency_us = rng.random_range(30e3..100e3),
        Effect::Scale => {
            e.scale_error =
                [s[0] * rng.random_range(0.01..0.03), s[1] * rng.random_range(0.01..0.03)]
        }
        Effect::Compliance => e.probe_compliance_um_per_weight = Some(rng.random_range(20.0..60.0)),
        Effect::Adhesion => {
            e.adhesion = Some(Adhesion {
                pull_off_weight: rng.random_range(0.3..0.6),
                range_um: 2.0,
                mu_bond: None,
            })
        }
        Effect::FrictionPatch => {
            // A patch over the right or the lower part of the workspace.
            let (min_um, max_um) = if rng.random_bool(0.5) {
                ([rng.random_range(1600.0..1900.0), -1e4], [1e4, 1e4])
            } else {
                ([-1e4, rng.random_range(1200.0..1500.0)], [1e4, 1e4])
            };
            e.friction_patch =
                Some(FrictionPatch { min_um, max_um, mu_surface: rng.random_range(0.6..0.9) })
        }
        Effect::SpeedFriction => {
            e.speed_friction = Some(SpeedFriction { gain_per_mm_s: rng.random_range(1.5..3.0) })
        }
        Effect::SupportDrift => {
            e.support_drift = Some(SupportDrift {
                // Along the peg's long axis, so a 6-trial batch keeps every support inside
                // the part (the nominal points sit within ~50 µm of its long edges).
                points_um_per_trial: [s[0] * rng.random_range(10.0..25.0), 0.0],
                mu_surface_per_trial: 0.0,
            })
        }
    }
    e
}

/// Appends a straight move to `to` at `speed_um_s` (setpoints every 10 ms).
fn line(path: &mut Vec<ProbePoint>, to: Vec2, speed_um_s: f64) {
    let last = *path.last().expect("path starts with a point");
    let n = ((to - last.probe_um).norm() / (speed_um_s * CMD_DT_S)).ceil().max(1.0) as usize;
    for k in 1..=n {
        let w = k as f64 / n as f64;
        path.push(ProbePoint {
            t_s: last.t_s + k as f64 * CMD_DT_S,
            probe_um: last.probe_um + (to - last.probe_um) * w,
            probe_theta_rad: 0.0,
        });
    }
}

fn dwell(path: &mut Vec<ProbePoint>, s: f64) {
    let last = *path.last().expect("path starts with a point");
    for k in 1..=(s / CMD_DT_S).round() as usize {
        path.push(ProbePoint::new(last.t_s + k as f64 * CMD_DT_S, last.probe_um));
    }
}

/// A stroke path from the probe's place to the next push on `peg`: around the peg at a safe
/// radius, in along an edge normal, push, back off, push again, retract.
fn stroke(path: &mut Vec<ProbePoint>, model: &Model, peg: Pose, rng: &mut impl Rng) {
    let poly = model.part.polygon().transformed(&peg);
    let e = rng.random_range(0..poly.len());
    let (a, b) = poly.edge(e);
    let normal = poly.edge_normal(e);
    let at = a + (b - a) * rng.random_range(0.25..0.75);
    let speed: f64 = rng.random_range(120.0..450.0);
    let radius = model.part.char_length_um() + 150.0;
    let c = peg.position();
    let from = path.last().expect("start").probe_um - c;
    let (a0, a1) = (from.y.atan2(from.x), normal.y.atan2(normal.x));
    let mut da = (a1 - a0).rem_euclid(std::f64::consts::TAU);
    if da > std::f64::consts::PI {
        da -= std::f64::consts::TAU;
    }
    line(path, c + from.normalize() * radius.max(from.norm()), speed.max(300.0));
    for k in 1..=12 {
        let ang = a0 + da * k as f64 / 12.0;
        line(path, c + Vec2::new(ang.cos(), ang.sin()) * radius.max(from.norm()), speed.max(300.0));
    }
    let approach = at + normal * 120.0;
    line(path, approach, speed);
    let rot = rng.random_range(-0.25f64..0.25);
    let push = -Vec2::new(
        normal.x * rot.cos() - normal.y * rot.sin(),
        normal.x * rot.sin() + normal.y * rot.cos(),
    );
    let depth = rng.random_range(250.0..450.0);
    let p1 = at + push * depth;
    line(path, p1, speed);
    dwell(path, 0.2);
    let p2 = p1 - push * rng.random_range(20.0..60.0);
    line(path, p2, speed);
    dwell(path, 0.2);
    let p3 = p2 + push * rng.random_range(80.0..160.0);
    line(path, p3, speed);
    dwell(path, 0.2);
    line(path, p3 - push * 250.0, speed);
    dwell(path, 0.3);
}

/// The commanded path of one open-plate trial with `strokes` strokes, and the peg start.
pub fn open_plate_path(
    model: &Model,
    strokes: usize,
    rng: &mut impl Rng,
) -> Result<(Pose, Vec<ProbePoint>), Error> {
    let start = Pose::new(
        rng.random_range(1500.0..1900.0),
        rng.random_range(1100.0..1400.0),
        rng.random_range(-0.3..0.3),
    );
    let r = model.part.char_length_um() + 200.0;
    let mut path = vec![ProbePoint::new(0.0, start.position() + Vec2::new(r, 0.0))];
    let mut peg = start;
    for _ in 0..strokes {
        let from = path.len() - 1;
        stroke(&mut path, model, peg, rng);
        let mut sim = Simulator::new(model.clone(), open_plate(), SimSettings::default())?;
        let rep = follow_path(&mut sim, peg, &path[from..])?;
        peg = rep.samples.last().map_or(peg, |s| s.peg);
    }
    Ok((start, path))
}

#[derive(Debug, Serialize)]
struct PoseCsvRow {
    t_us: i64,
    x_um: f64,
    y_um: f64,
    theta_rad: f64,
    frame_index: u64,
    residual_px: Option<f64>,
    probe_tip_x_um: f64,
    probe_tip_y_um: f64,
}

/// The last setpoint's time `t_s` in whole µs, truncated toward zero (the frames are those
/// stamped at or before it). [`units::s_to_us_i64`] rounds half away from zero; for t ≥ 0
/// truncation is one less exactly when that rounded up.
fn end_us(t_s: f64) -> Result<i64, Error> {
    let rounded = units::s_to_us_i64("last setpoint t_s", t_s)?;
    Ok(if rounded as f64 > t_s * 1e6 { rounded - 1 } else { rounded })
}

/// Generates one trial into `dir` from the true model `truth` (effects included).
pub fn write_trial(
    dir: &Path,
    id: &str,
    index: usize,
    truth: &Model,
    strokes: usize,
    noise: &SynthNoise,
    seed: u64,
) -> Result<(), Error> {
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut nominal = truth.clone();
    nominal.effects = Effects::default();
    let (start, cmd) = open_plate_path(&nominal, strokes, &mut rng)?;
    let fx = &truth.effects;
    let end_us = end_us(cmd.last().map_or(0.0, |p| p.t_s))?;
    let first = mesopush_sim::effects::scale_pose(&start, fx.scale_error, fx.scale_origin_um);
    let stamps: Vec<i64> = (0..).map(|k| k * FRAME_US).take_while(|t| *t <= end_us).collect();
    // × 1e-6, not `units::us_i64_to_s` (÷ 1e6): the two differ in the last bit for about a
    // third of the stamps, and the predicted poses written below were made with this one.
    let frames = stamps
        .iter()
        .map(|t| Measured { t_s: *t as f64 * 1e-6, pose: first, tip_um: None })
        .collect();
    let data = TrialData {
        id: id.into(),
        index,
        part: truth.part.clone(),
        probe_radius_um: truth.probe_radius_um,
        pusher: truth.pusher(),
        registration_tol_um: None,
        pose_rows_dropped: 0,
        log_gaps_s: Vec::new(),
        fixture: open_plate(),
        cmd: cmd.clone(),
        frames,
        start_sensitivity: None,
    };
    let pred = predict_open_loop(&data, truth, &SimSettings::default())?;
    let mut meta = TrialMeta::new(id, "mesopush-synth", truth.part.clone());
    meta.pusher = mesopush_sim::Pusher::single(truth.probe_radius_um);
    meta.frame_period_us = Some(FRAME_US.unsigned_abs() as f64);
    meta.seeds.insert("synth".into(), seed);
    meta.world =
        Some(serde_json::to_value(truth).map_err(|e| Error::invalid("synth", e.to_string()))?);
    let mut w = TrialWriter::create(dir, meta)?;
    for p in &cmd {
        w.probe(&mesopush_trial::ProbeRow {
            t_us: units::s_to_us_i64("probe t_s", p.t_s)?,
            cmd_x_um: p.probe_um.x,
            cmd_y_um: p.probe_um.y,
            rep_x_um: None,
            rep_y_um: None,
            cmd_theta_rad: None,
        })?;
    }
    let dir = w.finish(Outcome { state: TrialState::Done, reason: None, inserted: None })?;
    write_poses(&dir.join(mesopush_trial::files::POSE), &stamps, &pred, noise, &mut rng)
}

/// Writes pose.csv: the predicted pose and imaged tip at each stamp (µs) with tracker-like
/// noise drawn from `rng`.
fn write_poses(
    path: &Path,
    stamps: &[i64],
    pred: &Prediction,
    noise: &SynthNoise,
    rng: &mut impl Rng,
) -> Result<(), Error> {
    let mut csv = csv::Writer::from_path(path).map_err(|e| Error::parse(path, e))?;
    for (k, t) in stamps.iter().enumerate() {
        let (p, tip) = (pred.poses[k], pred.tips_um[k]);
        csv.serialize(PoseCsvRow {
            t_us: *t,
            x_um: p.x_um + noise.xy_um * normal(rng),
            y_um: p.y_um + noise.xy_um * normal(rng),
            theta_rad: p.theta_rad + noise.theta_rad * normal(rng),
            frame_index: k as u64,
            residual_px: None,
            probe_tip_x_um: tip.x + noise.tip_um * normal(rng),
            probe_tip_y_um: tip.y + noise.tip_um * normal(rng),
        })
        .map_err(|e| Error::parse(path, e))?;
    }
    csv.flush().map_err(|e| Error::io(path, e))
}

/// Writes a synthetic batch of `n_trials` trials with one undeclared `effect` (or none) into
/// `out/trial-NNN`: the true model drawn from `seed` ([`batch_truth`]), trial `i`'s strokes
/// and noise from `seed · 1000 + i`, [`SynthNoise::default`]. Returns the trial directories.
pub fn write_batch(
    out: &Path,
    effect: Effect,
    n_trials: usize,
    strokes: usize,
    seed: u64,
) -> Result<Vec<PathBuf>, Error> {
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = batch_truth(effect, n_trials, &mut rng);
    (0..n_trials)
        .map(|i| {
            let id = format!("trial-{i:03}");
            let dir = out.join(&id);
            let noise = SynthNoise::default();
            write_trial(&dir, &id, i, &truth, strokes, &noise, seed * 1000 + i as u64)?;
            Ok(dir)
        })
        .collect()
}

/// The true model of an `n_trials` batch with one library effect at a realistic size: a
/// drawn support drift is halved until the support stays physical (inside the part, holding
/// its weight) over the whole batch, as a real one must.
pub fn batch_truth(effect: Effect, n_trials: usize, rng: &mut impl Rng) -> Model {
    let mut truth = true_nominal(rng);
    truth.effects = realistic_effect(effect, rng);
    let last = n_trials.saturating_sub(1);
    for _ in 0..20 {
        if super::predict::valid_over_batch(&truth, last) {
            break;
        }
        if let Some(d) = &mut truth.effects.support_drift {
            d.points_um_per_trial = d.points_um_per_trial.map(|v| v / 2.0);
        }
    }
    truth
}

/// The true nominal model of a synthetic batch: the default model a little off (μ_probe and
/// the support), so identification has something to find.
pub fn true_nominal(rng: &mut impl Rng) -> Model {
    let mut m = Model { mu_probe: rng.random_range(0.65..0.95), ..Model::default() };
    let (dx, dy) = (rng.random_range(-40.0..40.0), rng.random_range(-40.0..40.0));
    for p in &mut m.support.points_um {
        p[0] += dx;
        p[1] += dy;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Caught by the 3-seed confusion run: seed 12's drawn drift moved the centre of mass out
    /// of the support triangle by the batch's last trial, and the batch could not be made.
    #[test]
    fn a_drawn_support_drift_stays_physical_over_the_batch() {
        for seed in 0..200 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let truth = batch_truth(Effect::SupportDrift, 6, &mut rng);
            assert!(truth.effects.support_drift.is_some(), "seed {seed}");
            assert!(super::super::predict::valid_over_batch(&truth, 5), "seed {seed}: {truth:?}");
        }
    }
}
