//! The identification sweep split into independent processes by candidate index — one
//! shard per task of an existing scheduler (a Slurm job array, GNU parallel; no cluster
//! code of ours) — and merged back into the sweep one process computes. Every score is a
//! pure function of (trial, candidate) and the candidates (μ grid × random supports) come
//! from the seed alone, so shard `I/N` scores the candidates `k ≡ I (mod N)` exactly as the
//! unsplit sweep does; scores travel as f64 bit patterns (∞ marks a failed simulation).
//!
//! A shard file carries the run's key (trial ids, seed, sweep and scoring settings); the
//! merge refuses files of another run, a shard count that disagrees, a shard given twice or
//! missing, and a candidate missing, duplicated or in the wrong shard — naming the file.

use super::score::Score;
use super::sweep::Sweep;
use crate::Error;
use mesopush_core::fsx::{read_json, write_json_atomic};
use mesopush_core::shard::Shard;
use mesopush_sim::SupportDistribution;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format version of [`SweepShard`].
pub const SWEEP_SHARD_FORMAT: u32 = 1;

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

/// One shard of a sweep, as written by `mesopush identify --shard I/N`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepShard {
    /// [`SWEEP_SHARD_FORMAT`].
    pub format: u32,
    /// The sweep this shard belongs to.
    pub key: SweepKey,
    /// Which shard.
    pub shard: Shard,
    /// Candidates of the whole sweep (μ values × supports).
    pub candidates: u64,
    /// (candidate k, its score on each trial in key order), k ascending.
    pub columns: Vec<(u64, Vec<ExactScore>)>,
}

impl SweepShard {
    /// The shard's candidates out of `candidates`.
    pub fn owned(shard: Shard, candidates: usize) -> Vec<usize> {
        (0..candidates).filter(|&k| shard.owns(k as u64)).collect()
    }

    /// Packs scores from `sweep::score_jobs` over `ks` (trial-major) into columns.
    pub fn new(
        key: SweepKey,
        shard: Shard,
        candidates: usize,
        ks: &[usize],
        flat: &[Score],
    ) -> Self {
        let n_trials = key.trials.len();
        debug_assert_eq!(flat.len(), n_trials * ks.len());
        let columns = ks
            .iter()
            .enumerate()
            .map(|(j, &k)| {
                let col = (0..n_trials).map(|t| flat[t * ks.len() + j].into()).collect();
                (k as u64, col)
            })
            .collect();
        Self { format: SWEEP_SHARD_FORMAT, key, shard, candidates: candidates as u64, columns }
    }

    /// Writes the file (a synced temporary then a rename: a killed run leaves no half file).
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        Ok(write_json_atomic(path, self)?)
    }

    /// Reads a file written by [`SweepShard::save`].
    pub fn load(path: &Path) -> Result<Self, Error> {
        let f: Self = read_json(path)?;
        if f.format != SWEEP_SHARD_FORMAT {
            let msg =
                format!("sweep shard format {} (this build reads {SWEEP_SHARD_FORMAT})", f.format);
            return Err(Error::Parse { path: path.into(), message: msg });
        }
        Ok(f)
    }
}

/// Assembles the sweep of `key` (its grid `mus` × `supports`, re-drawn from the seed) from
/// its shards.
pub fn merge(
    files: &[(PathBuf, SweepShard)],
    key: &SweepKey,
    mus: Vec<f64>,
    supports: Vec<SupportDistribution>,
) -> Result<Sweep, Error> {
    let bad = |p: &Path, m: String| Error::invalid("sweep merge", format!("{}: {m}", p.display()));
    if files.is_empty() {
        return Err(Error::invalid("sweep merge", "no sweep shard files given"));
    }
    let n = mus.len() * supports.len();
    for (p, f) in files {
        if &f.key != key || f.candidates != n as u64 {
            return Err(bad(p, "a different sweep (trials, seed or settings differ)".into()));
        }
    }
    Shard::check_set("sweep merge", files.iter().map(|(p, f)| (p.as_path(), f.shard)))?;
    let n_trials = key.trials.len();
    let mut scores: Vec<Vec<Option<Score>>> = vec![vec![None; n]; n_trials];
    for (p, f) in files {
        for (k, col) in &f.columns {
            let ok = (*k as usize) < n && f.shard.owns(*k) && col.len() == n_trials;
            if !ok || scores[0][*k as usize].is_some() {
                return Err(bad(
                    p,
                    format!("candidate {k} is not this shard's, malformed or given twice"),
                ));
            }
            for (row, s) in scores.iter_mut().zip(col) {
                row[*k as usize] = Some((*s).into());
            }
        }
    }
    let scores: Option<Vec<Vec<Score>>> =
        scores.into_iter().map(|row| row.into_iter().collect()).collect();
    let scores = scores.ok_or_else(|| {
        Error::invalid("sweep merge", "some candidates are missing from their shard's file")
    })?;
    Ok(Sweep { mus, supports, scores })
}
