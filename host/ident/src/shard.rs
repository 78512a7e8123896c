//! The identification sweep split into independent processes by candidate index — one
//! shard per task of an existing scheduler (a Slurm job array, GNU parallel; no cluster
//! code of ours) — and merged back into the sweep one process computes. Every score is a
//! pure function of (trial, candidate) and the candidates (μ grid × random supports) come
//! from the seed alone, so shard `I/N` scores the candidates `k ≡ I (mod N)` exactly as the
//! unsplit sweep does; scores travel as f64 bit patterns (∞ marks a failed simulation).
//!
//! The file is the workspace's one shard shape, [`ShardFile`], keyed by the run (trial ids,
//! seed, sweep and scoring settings, candidate count) with one item per candidate: its score
//! on each trial. [`mesopush_core::shard::merge`] refuses a shard count that disagrees, a shard
//! given twice or missing, and a candidate missing, duplicated or in the wrong shard; the
//! files of another run and malformed items are refused here — each naming the file.

use super::IdentifySettings;
use super::data::IdentTrial;
use super::score::Score;
use super::sweep::{Sweep, grid, score_jobs};
use crate::Error;
use mesopush_core::shard::{Shard, ShardFile, merge};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format version of [`SweepShard`] (2: the workspace's [`ShardFile`] layout).
pub const SWEEP_SHARD_FORMAT: u32 = 2;

/// What makes two shards parts of the same sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepKey {
    /// Trial ids, in the order scored.
    pub trials: Vec<String>,
    /// Master seed (draws the supports).
    pub seed: u64,
    /// μ grid step.
    pub mu_step: f64,
    /// Largest μ.
    pub mu_max: f64,
    /// Random supports per μ.
    pub n_supports: usize,
    /// Surface friction of the sampled supports.
    pub mu_surface: f64,
    /// Simulator step, µm.
    pub step_um: f64,
    /// Part–wall friction.
    pub mu_wall: f64,
    /// Candidates of the whole sweep (μ values × supports).
    pub candidates: u64,
}

impl SweepKey {
    /// The key of the sweep of `trials` with `settings`, its supports drawn from `seed`.
    pub fn new(
        trials: &[IdentTrial],
        seed: u64,
        settings: &IdentifySettings,
    ) -> Result<Self, Error> {
        let s = &settings.sweep;
        let candidates = (s.mus()?.len() * s.n_supports) as u64;
        Ok(Self {
            trials: trials.iter().map(|t| t.id.clone()).collect(),
            seed,
            mu_step: s.mu_step,
            mu_max: s.mu_max,
            n_supports: s.n_supports,
            mu_surface: s.mu_surface,
            step_um: settings.score.sim.step_um,
            mu_wall: settings.score.mu_wall,
            candidates,
        })
    }
}

/// A [`Score`] with its floats as bit patterns (exact, and ∞ survives JSON).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExactScore {
    xy_bits: u64,
    theta_bits: u64,
    cost_bits: u64,
    n_poses: usize,
    jams: usize,
}

impl From<Score> for ExactScore {
    fn from(s: Score) -> Self {
        Self {
            xy_bits: s.xy_mse_um2.to_bits(),
            theta_bits: s.theta_mse_rad2.to_bits(),
            cost_bits: s.cost_um2.to_bits(),
            n_poses: s.n_poses,
            jams: s.jams,
        }
    }
}

impl From<ExactScore> for Score {
    fn from(e: ExactScore) -> Self {
        Self {
            xy_mse_um2: f64::from_bits(e.xy_bits),
            theta_mse_rad2: f64::from_bits(e.theta_bits),
            cost_um2: f64::from_bits(e.cost_bits),
            n_poses: e.n_poses,
            jams: e.jams,
        }
    }
}

/// One shard of a sweep, as `mesopush identify shard` writes it: items are (candidate k,
/// its score on each trial in key order), k ascending.
pub type SweepShard = ShardFile<SweepKey, Vec<ExactScore>>;

/// The candidates of `shard` out of `candidates`.
pub fn owned(shard: Shard, candidates: usize) -> Vec<usize> {
    (0..candidates).filter(|&k| shard.owns(k as u64)).collect()
}

/// Scores `shard`'s candidates of the sweep of `trials` (`rng` seeded from `seed`, as for
/// [`crate::identify`]); `tick` is called once per simulation.
pub fn score_shard(
    trials: &[IdentTrial],
    settings: &IdentifySettings,
    seed: u64,
    shard: Shard,
    rng: &mut impl Rng,
    tick: &(dyn Fn() + Sync),
) -> Result<SweepShard, Error> {
    let (mus, supports) = grid(trials, &settings.sweep, rng)?;
    let n = mus.len() * supports.len();
    let ks = owned(shard, n);
    let flat = score_jobs(trials, &mus, &supports, &settings.score, &ks, tick);
    let n_trials = trials.len();
    let items = ks
        .iter()
        .enumerate()
        .map(|(j, &k)| {
            let col = (0..n_trials).map(|t| flat[t * ks.len() + j].into()).collect();
            (k as u64, col)
        })
        .collect();
    let key = SweepKey::new(trials, seed, settings)?;
    Ok(ShardFile { format: SWEEP_SHARD_FORMAT, key, shard, items })
}

/// Writes a shard file (a synced temporary then a rename: a killed run leaves no half file).
pub fn save(file: &SweepShard, path: &Path) -> Result<(), Error> {
    Ok(file.write(path)?)
}

/// Reads a shard file written by [`save`], refusing another format version.
pub fn load(path: &Path) -> Result<SweepShard, Error> {
    Ok(SweepShard::read(path, SWEEP_SHARD_FORMAT)?)
}

/// The sweep of `trials` with `settings` assembled from the shard files at `paths` instead of
/// run; `rng` (seeded from `seed`) re-draws the grid and is left where the unsplit sweep
/// leaves it, so [`crate::identify_from`] continues exactly as [`crate::identify`] would.
pub fn merged_sweep(
    trials: &[IdentTrial],
    settings: &IdentifySettings,
    seed: u64,
    rng: &mut impl Rng,
    paths: &[PathBuf],
) -> Result<Sweep, Error> {
    let (mus, supports) = grid(trials, &settings.sweep, rng)?;
    let key = SweepKey::new(trials, seed, settings)?;
    if paths.is_empty() {
        return Err(Error::invalid("sweep merge", "no sweep shard files given"));
    }
    let mut files = Vec::with_capacity(paths.len());
    for p in paths {
        let f = load(p)?;
        check(p, &f, &key)?;
        files.push((p.clone(), f));
    }
    let (_, columns) = merge("sweep merge", files, |k| k.candidates)?;
    let scores =
        (0..trials.len()).map(|t| columns.iter().map(|col| col[t].into()).collect()).collect();
    Ok(Sweep { mus, supports, scores })
}

/// Refuses a shard of another sweep or with a malformed item, naming the file.
fn check(path: &Path, f: &SweepShard, key: &SweepKey) -> Result<(), Error> {
    let bad = |m: String| Error::invalid("sweep merge", format!("{}: {m}", path.display()));
    if &f.key != key {
        return Err(bad("a different sweep (trials, seed or settings differ)".into()));
    }
    match f.items.iter().find(|(_, col)| col.len() != key.trials.len()) {
        Some((k, col)) => Err(bad(format!(
            "candidate {k} has {} scores for {} trials",
            col.len(),
            key.trials.len()
        ))),
        None => Ok(()),
    }
}
