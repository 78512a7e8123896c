//! Monte Carlo robustness runs split into independent processes by trial index — one shard
//! per task of an existing scheduler (a Slurm job array, GNU parallel; no cluster code of
//! ours) — and merged back into the estimate the unsplit run gives. Trial `i` draws its
//! world from its own stream (`montecarlo::trial_seed`), so shard `I/N` runs exactly the
//! unsplit run's trials `i ≡ I (mod N)`, bit for bit, and the merge is their union.
//!
//! A shard file carries the whole run's key (plan, model, fixture, supports, uncertainty, seed,
//! sample count); the merge refuses files of different runs, a shard count that disagrees,
//! a shard given twice or missing, and any trial index missing or duplicated — naming the
//! file and the problem — so a merged estimate is never silently partial.

use super::montecarlo::{Estimate, MonteCarlo, Trial};
use super::sampler::Uncertainty;
use crate::Error;
use mesopush_core::fsx::{read_json, write_json_atomic};
use mesopush_core::shard::Shard;
use mesopush_sim::{Fixture, Model, Plan, SupportDistribution};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format version of [`ShardFile`].
pub const SHARD_FORMAT: u32 = 1;

/// What makes two shards parts of the same run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunKey {
    /// The plan under test.
    pub plan: Plan,
    /// The nominal model.
    pub model: Model,
    /// The fixture.
    pub fixture: Fixture,
    /// Candidate supports (empty: the model's, perturbed).
    pub supports: Vec<SupportDistribution>,
    /// The uncertainty box.
    pub uncertainty: Uncertainty,
    /// Master seed.
    pub seed: u64,
    /// Trials of the whole run.
    pub samples: u64,
}

/// One shard's trials, as written by `mesopush robustness --shard I/N`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardFile {
    /// [`SHARD_FORMAT`].
    pub format: u32,
    /// The run this shard belongs to.
    pub key: RunKey,
    /// Which shard.
    pub shard: Shard,
    /// (trial index, result), index order.
    pub trials: Vec<(u64, Trial)>,
}

impl ShardFile {
    /// Runs shard `shard` of `mc` (`samples` trials in all, master seed `seed`).
    pub fn run(
        mc: &MonteCarlo<'_>,
        samples: u64,
        seed: u64,
        shard: Shard,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Self, Error> {
        let indices: Vec<u64> = (0..samples).filter(|&i| shard.owns(i)).collect();
        let trials = mc.trials_at(&indices, seed, tick)?;
        let key = RunKey {
            plan: mc.plan.clone(),
            model: mc.model.clone(),
            fixture: mc.fixture.clone(),
            supports: mc.supports.to_vec(),
            uncertainty: mc.uncertainty,
            seed,
            samples,
        };
        let trials = indices.into_iter().zip(trials).collect();
        Ok(Self { format: SHARD_FORMAT, key, shard, trials })
    }

    /// Writes the file (a synced temporary then a rename: a killed run leaves no half file).
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        Ok(write_json_atomic(path, self)?)
    }

    /// Reads a file written by [`ShardFile::save`].
    pub fn load(path: &Path) -> Result<Self, Error> {
        let f: Self = read_json(path)?;
        if f.format != SHARD_FORMAT {
            let msg = format!("shard format {} (this build reads {SHARD_FORMAT})", f.format);
            return Err(Error::Parse { path: path.into(), message: msg });
        }
        Ok(f)
    }
}

/// Merges the shards of one run into its estimate (trials in index order).
pub fn merge(files: &[(PathBuf, ShardFile)]) -> Result<(RunKey, Estimate), Error> {
    let bad =
        |p: &Path, m: String| Error::invalid("robustness merge", format!("{}: {m}", p.display()));
    let Some((p0, first)) = files.first() else {
        return Err(Error::invalid("robustness merge", "no shard files given"));
    };
    for (p, f) in files {
        if f.key != first.key {
            return Err(bad(
                p,
                format!(
                    "a different run than {} (plan, model, fixture, supports, uncertainty, seed or samples differ)",
                    p0.display()
                ),
            ));
        }
    }
    Shard::check_set("robustness merge", files.iter().map(|(p, f)| (p.as_path(), f.shard)))?;
    let n = first.key.samples;
    let mut slots: Vec<Option<Trial>> = vec![None; n as usize];
    for (p, f) in files {
        for (i, t) in &f.trials {
            let ok = *i < n && f.shard.owns(*i);
            let slot = slots.get_mut(*i as usize).filter(|_| ok);
            match slot {
                Some(s @ None) => *s = Some(t.clone()),
                _ => return Err(bad(p, format!("trial {i} is not this shard's or appears twice"))),
            }
        }
    }
    let trials: Option<Vec<Trial>> = slots.into_iter().collect();
    let trials = trials.ok_or_else(|| {
        Error::invalid("robustness merge", "some trials are missing from their shard's file")
    })?;
    Ok((first.key.clone(), Estimate::from_trials(trials)))
}
