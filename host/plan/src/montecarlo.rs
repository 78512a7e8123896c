//! Monte Carlo estimate of a plan's success probability under [`Uncertainty`]: independent
//! trials, each a whole-plan replay in a world drawn by [`draw`], run in parallel.
//!
//! Deterministic: trial `i` draws from its own ChaCha stream seeded by (master seed, i), so
//! the result is bit-identical for any thread count. The candidate supports are a plain
//! slice, so identification can hand its identified set straight in.

use crate::Error;
use crate::sampler::{Draw, Uncertainty, draw};
use mesopush_core::geom::Pose;
use mesopush_core::stats::{Z95, wilson_interval};
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use rand::SeedableRng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// What one Monte Carlo sample did: the world it drew and the plan's outcome there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleOutcome {
    /// The world it ran in.
    pub draw: Draw,
    /// Whether the peg ended inserted (in the goal, the needle within its limit).
    pub inserted: bool,
    /// Whether the probe jammed on the way.
    pub jammed: bool,
    /// Whether the needle was bent beyond the model's limit (a failure, even with the peg
    /// in the goal).
    #[serde(default)]
    pub overloaded: bool,
    /// Largest needle deflection of the replay, µm (when the replay ran).
    #[serde(default)]
    pub max_deflection_um: Option<f64>,
    /// The simulator's error, when the replay failed (counts as a failure).
    pub error: Option<String>,
    /// Final peg pose (when the replay ran).
    pub final_pose: Option<Pose>,
}

/// A plan's estimated success probability, with every sample's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuccessEstimate {
    /// Trials run.
    pub samples: usize,
    /// Trials that inserted the peg.
    pub successes: usize,
    /// successes / samples.
    pub success_rate: f64,
    /// Wilson 95 % interval, lower end.
    pub ci_low: f64,
    /// Wilson 95 % interval, upper end.
    pub ci_high: f64,
    /// Every trial, in index order.
    pub trials: Vec<SampleOutcome>,
}

impl SuccessEstimate {
    /// Summarises trials.
    pub fn from_trials(trials: Vec<SampleOutcome>) -> Self {
        let successes = trials.iter().filter(|t| t.inserted).count();
        let n = trials.len();
        let (ci_low, ci_high) = wilson_interval(successes, n, Z95);
        let success_rate = if n == 0 { 0.0 } else { successes as f64 / n as f64 };
        Self { samples: n, successes, success_rate, ci_low, ci_high, trials }
    }
}

/// The seed of trial `i` under master seed `seed` (SplitMix64 of both).
pub fn trial_seed(seed: u64, i: u64) -> u64 {
    let mut z = seed ^ i.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// `n` worlds drawn from `seed` (trial `i` from its own stream).
pub fn draws(
    model: &Model,
    unc: &Uncertainty,
    supports: &[SupportSample],
    n: usize,
    seed: u64,
) -> Vec<Draw> {
    let all: Vec<u64> = (0..n as u64).collect();
    draws_at(model, unc, supports, &all, seed)
}

/// The worlds of trials `indices` under `seed`: the same draws as [`draws`] gives those
/// indices, so a shard of a run is that run's trials.
pub fn draws_at(
    model: &Model,
    unc: &Uncertainty,
    supports: &[SupportSample],
    indices: &[u64],
    seed: u64,
) -> Vec<Draw> {
    indices
        .par_iter()
        .map(|&i| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(trial_seed(seed, i));
            draw(model, unc, supports, &mut rng)
        })
        .collect()
}

/// Runs `plan` once in the world of `d`.
pub fn run_trial(
    plan: &Plan,
    d: &Draw,
    fixture: &Fixture,
    settings: &SimSettings,
) -> SampleOutcome {
    let result = Simulator::new(d.model.clone(), fixture.clone(), settings.clone())
        .and_then(|mut sim| replay(&mut sim, plan, Some(d.start(plan))));
    match result {
        Ok(r) => SampleOutcome {
            draw: d.clone(),
            inserted: r.inserted,
            jammed: !r.events.is_empty(),
            overloaded: r.overload.is_some(),
            max_deflection_um: Some(r.max_probe_deflection_um),
            error: None,
            final_pose: Some(r.final_pose),
        },
        Err(e) => SampleOutcome {
            draw: d.clone(),
            inserted: false,
            jammed: false,
            overloaded: false,
            max_deflection_um: None,
            error: Some(e.to_string()),
            final_pose: None,
        },
    }
}

/// Runs `plan` in every world of `worlds` (in parallel; `tick` is called after each trial).
pub fn evaluate(
    plan: &Plan,
    worlds: &[Draw],
    fixture: &Fixture,
    settings: &SimSettings,
    tick: &(dyn Fn() + Sync),
) -> Result<SuccessEstimate, Error> {
    plan.validate()?;
    let trials = worlds
        .par_iter()
        .map(|d| {
            let t = run_trial(plan, d, fixture, settings);
            tick();
            t
        })
        .collect();
    Ok(SuccessEstimate::from_trials(trials))
}

/// A Monte Carlo problem: a plan, the nominal world and the uncertainty around it.
#[derive(Debug, Clone, Copy)]
pub struct MonteCarlo<'a> {
    /// The plan under test.
    pub plan: &'a Plan,
    /// The nominal model (its support is perturbed when `supports` is empty).
    pub model: &'a Model,
    /// The fixture.
    pub fixture: &'a Fixture,
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// The uncertainty box.
    pub uncertainty: Uncertainty,
    /// Candidate support distributions (e.g. identification's set); empty: perturb.
    pub supports: &'a [SupportSample],
}

impl MonteCarlo<'_> {
    /// `samples` trials from master seed `seed`.
    pub fn estimate(
        &self,
        samples: usize,
        seed: u64,
        tick: &(dyn Fn() + Sync),
    ) -> Result<SuccessEstimate, Error> {
        self.model.validate()?;
        let worlds = draws(self.model, &self.uncertainty, self.supports, samples, seed);
        evaluate(self.plan, &worlds, self.fixture, self.settings, tick)
    }

    /// The success rate at every scale of [`SWEEP_SCALES`] of the uncertainty box, each from
    /// `samples` trials of master seed `seed` (`tick` after each trial).
    pub fn sweep(
        &self,
        samples: usize,
        seed: u64,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Vec<SweepPoint>, Error> {
        let mut pts = Vec::new();
        for scale in SWEEP_SCALES {
            let scaled = MonteCarlo { uncertainty: self.uncertainty.scaled(scale), ..*self };
            let e = scaled.estimate(samples, seed, tick)?;
            let (success_rate, ci_low, ci_high) = (e.success_rate, e.ci_low, e.ci_high);
            pts.push(SweepPoint { scale, success_rate, ci_low, ci_high });
        }
        Ok(pts)
    }

    /// Trials `indices` of the run seeded `seed` (each identical to that trial of
    /// [`MonteCarlo::estimate`]), in the order given.
    pub fn trials_at(
        &self,
        indices: &[u64],
        seed: u64,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Vec<SampleOutcome>, Error> {
        self.model.validate()?;
        let worlds = draws_at(self.model, &self.uncertainty, self.supports, indices, seed);
        Ok(evaluate(self.plan, &worlds, self.fixture, self.settings, tick)?.trials)
    }
}

/// Uncertainty scales of [`MonteCarlo::sweep`]: half to twice the box.
pub const SWEEP_SCALES: [f64; 5] = [0.5, 0.75, 1.0, 1.5, 2.0];

/// One point of a success-rate sweep over the uncertainty box's scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SweepPoint {
    /// Scale of the box (1 = the paper's).
    pub scale: f64,
    /// Success rate at that scale.
    pub success_rate: f64,
    /// Wilson 95 % interval, lower end.
    pub ci_low: f64,
    /// Wilson 95 % interval, upper end.
    pub ci_high: f64,
}

/// CSV header of [`write_trials_csv`].
pub const TRIALS_HEADER: &str = "trial,dx_um,dy_um,dtheta_deg,mu_probe,mu_wall,mu_s1,mu_s2,mu_s3,\
r1x_um,r1y_um,r2x_um,r2y_um,r3x_um,r3y_um,support_index,inserted,jammed,overloaded,\
max_deflection_um,final_x_um,final_y_um,final_theta_deg,error";

/// Writes every trial as one CSV row (a pandas user can load it).
pub fn write_trials_csv(
    trials: &[SampleOutcome],
    mut w: impl std::io::Write,
) -> std::io::Result<()> {
    writeln!(w, "{TRIALS_HEADER}")?;
    for (i, t) in trials.iter().enumerate() {
        let m = &t.draw.model;
        let [r1, r2, r3] = m.support.points_um;
        let [s1, s2, s3] = m.support.mu_surface;
        let fp = t.final_pose.map_or([f64::NAN; 3], |p| [p.x_um, p.y_um, p.theta_rad.to_degrees()]);
        let [dx, dy, dt] = t.draw.offset;
        let si = t.draw.support_index.map_or(String::new(), |i| i.to_string());
        let err = t.error.as_deref().unwrap_or("").replace([',', '\n'], ";");
        let defl = t.max_deflection_um.unwrap_or(f64::NAN);
        writeln!(
            w,
            "{i},{dx:.3},{dy:.3},{dt:.4},{:.4},{:.4},{s1:.4},{s2:.4},{s3:.4},{:.2},{:.2},{:.2},{:.2},\
             {:.2},{:.2},{si},{},{},{},{defl:.3},{:.3},{:.3},{:.4},{err}",
            m.mu_probe,
            m.mu_wall,
            r1[0],
            r1[1],
            r2[0],
            r2[1],
            r3[0],
            r3[1],
            t.inserted,
            t.jammed,
            t.overloaded,
            fp[0],
            fp[1],
            fp[2]
        )?;
    }
    Ok(())
}
