//! Scoring one parameter set on one trial: simulate the trial's recorded probe path from its
//! first tracked pose and compare the simulated peg with every later tracked pose.
//!
//! Errors: `xy_mse_um2` is the mean squared position error (Δx² + Δy²) of the centre of mass,
//! µm²; `theta_mse_rad2` the mean squared orientation error, rad² (tables also print deg²).
//! One scalar ranks candidates: `cost_um2 = xy_mse_um2 + L²·theta_mse_rad2`, with L the
//! part's characteristic length (largest vertex radius), i.e. the orientation error as the
//! displacement of the part's far corner — a scale-free weighting that works for any part.

use super::data::{IdentTrial, sub_path};
use mesopush_core::geom::Pose;
use mesopush_sim::{Model, PathSample, SimSettings, Simulator, SupportDistribution, follow_path};
use serde::{Deserialize, Serialize};

/// The identified quantities: probe friction and support distribution (with its surface
/// friction).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Probe–part friction coefficient.
    pub mu_probe: f64,
    /// Three support points relative to the COM and their surface friction.
    pub support: SupportDistribution,
}

/// What stays fixed while identifying.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreSettings {
    /// The simulator's settings for the paper's peg; each trial's part gets them scaled to its
    /// size (`SimSettings::scaled_to`).
    pub sim: SimSettings,
    /// Part–wall friction (only matters for trials with walls). Default 0.25.
    pub mu_wall: f64,
}

impl Default for ScoreSettings {
    fn default() -> Self {
        Self { sim: SimSettings::default(), mu_wall: 0.25 }
    }
}

/// How well one candidate reproduces one trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Mean of Δx² + Δy² over the scored poses, µm² (∞ when the simulation failed).
    pub xy_mse_um2: f64,
    /// Mean of Δθ² over the scored poses, rad².
    pub theta_mse_rad2: f64,
    /// `xy_mse_um2 + L²·theta_mse_rad2`, µm² (the ranking scalar).
    pub cost_um2: f64,
    /// Poses scored.
    pub n_poses: usize,
    /// Path segments on which the simulated peg wedged.
    pub jams: usize,
}

impl Score {
    /// The score of a candidate the simulator refused or could not run.
    pub fn failed() -> Self {
        let inf = f64::INFINITY;
        Self { xy_mse_um2: inf, theta_mse_rad2: inf, cost_um2: inf, n_poses: 0, jams: 0 }
    }

    /// Whether the simulation ran.
    pub fn ok(&self) -> bool {
        self.cost_um2.is_finite()
    }

    /// θ MSE in deg².
    pub fn theta_mse_deg2(&self) -> f64 {
        self.theta_mse_rad2 * (180.0 / std::f64::consts::PI).powi(2)
    }

    /// Sum of squared residual components (Δx, Δy, L·Δθ) over the poses, µm².
    pub fn sse_um2(&self) -> f64 {
        self.cost_um2 * self.n_poses as f64
    }
}

/// The model a candidate stands for on `trial`.
pub fn model_for(trial: &IdentTrial, c: &Candidate, settings: &ScoreSettings) -> Model {
    Model {
        part: trial.part.clone(),
        support: c.support.clone(),
        mu_probe: c.mu_probe,
        mu_wall: settings.mu_wall,
        probe_radius_um: trial.pusher.max_radius_um(),
        pusher: Some(trial.pusher.clone()),
        probe_deflection_limit_um: mesopush_sim::model::DEFAULT_PROBE_DEFLECTION_LIMIT_UM,
        effects: Default::default(),
    }
}

/// The simulated peg at `t_s`, interpolated linearly between the replay's samples.
pub fn pose_at(samples: &[PathSample], t_s: f64) -> Pose {
    let i = samples.partition_point(|s| s.t_s <= t_s);
    if i == 0 {
        return samples[0].peg;
    }
    if i == samples.len() {
        return samples[i - 1].peg;
    }
    let (a, b) = (&samples[i - 1].peg, &samples[i].peg);
    let dt = samples[i].t_s - samples[i - 1].t_s;
    let f = if dt > 0.0 { (t_s - samples[i - 1].t_s) / dt } else { 1.0 };
    Pose::new(
        a.x_um + (b.x_um - a.x_um) * f,
        a.y_um + (b.y_um - a.y_um) * f,
        a.theta_rad + (b.theta_rad - a.theta_rad) * f,
    )
}

/// Simulates `c` on `trial`; `None` when the model is invalid or the simulator fails.
pub fn simulate(
    trial: &IdentTrial,
    c: &Candidate,
    settings: &ScoreSettings,
) -> Option<(Vec<PathSample>, usize)> {
    simulate_or_why(trial, c, settings).ok()
}

/// As [`simulate`], with the simulator's reason when it fails (for error messages).
pub fn simulate_or_why(
    trial: &IdentTrial,
    c: &Candidate,
    settings: &ScoreSettings,
) -> Result<(Vec<PathSample>, usize), mesopush_sim::Error> {
    let model = model_for(trial, c, settings);
    // The settings' lengths are the peg's; another part gets them scaled to its size.
    let mut sim_settings = settings.sim.clone().scaled_to(&trial.part);
    if let Some(r) = trial.registration_tol_um {
        sim_settings.registration_tol = r / trial.part.char_length_um();
    }
    let mut sim = Simulator::new(model, trial.fixture.clone(), sim_settings)?;
    if trial.restarts.is_empty() {
        let r = follow_path(&mut sim, trial.start, &trial.path)?;
        return Ok((r.samples, r.jams));
    }
    // Segment by segment: each from its start pose along the commands up to the last one
    // before the next gap in the recording.
    let (mut samples, mut jams) = (Vec::new(), 0);
    let mut from = (trial.path[0].t_s, trial.start);
    let ends = trial.restarts.iter().map(|r| (r.before_s, Some(*r)));
    for (end_s, next) in ends.chain(std::iter::once((f64::INFINITY, None))) {
        let seg = sub_path(&trial.path, from.0, end_s);
        if seg.len() >= 2 {
            let r = follow_path(&mut sim, from.1, &seg)?;
            samples.extend(r.samples);
            jams += r.jams;
        }
        if let Some(r) = next {
            from = (r.t_s, r.pose);
        }
    }
    Ok((samples, jams))
}

/// Scores `c` on `trial` (a failed simulation scores [`Score::failed`]).
pub fn score(trial: &IdentTrial, c: &Candidate, settings: &ScoreSettings) -> Score {
    let Some((samples, jams)) = simulate(trial, c, settings) else {
        return Score::failed();
    };
    let l = trial.part.char_length_um();
    let (mut xy, mut th) = (0.0, 0.0);
    for (t, m) in &trial.measured {
        let p = pose_at(&samples, *t);
        xy += (p.x_um - m.x_um).powi(2) + (p.y_um - m.y_um).powi(2);
        th += (p.theta_rad - m.theta_rad).powi(2);
    }
    let n = trial.measured.len();
    let (xy, th) = (xy / n as f64, th / n as f64);
    Score { xy_mse_um2: xy, theta_mse_rad2: th, cost_um2: xy + l * l * th, n_poses: n, jams }
}

/// The residual components (Δx, Δy, L·Δθ per scored pose, µm) of `c` on `trial`, in pose
/// order; `None` when the simulation fails. Their sum of squares is [`Score::sse_um2`].
pub fn residuals(trial: &IdentTrial, c: &Candidate, settings: &ScoreSettings) -> Option<Vec<f64>> {
    let (samples, _) = simulate(trial, c, settings)?;
    let l = trial.part.char_length_um();
    let mut r = Vec::with_capacity(3 * trial.measured.len());
    for (t, m) in &trial.measured {
        let p = pose_at(&samples, *t);
        r.extend([p.x_um - m.x_um, p.y_um - m.y_um, l * (p.theta_rad - m.theta_rad)]);
    }
    Some(r)
}
