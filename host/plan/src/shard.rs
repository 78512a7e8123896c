//! Monte Carlo robustness runs split into independent processes by trial index — one shard
//! per task of an existing scheduler (a Slurm job array, GNU parallel; no cluster code of
//! ours) — and merged back into the estimate the unsplit run gives. Trial `i` draws its
//! world from its own stream (`montecarlo::trial_seed`), so shard `I/N` runs exactly the
//! unsplit run's trials `i ≡ I (mod N)`, bit for bit, and the merge is their union.
//!
//! The file is the workspace's one shard shape, [`mesopush_core::shard::ShardFile`], keyed by
//! the whole run ([`RunKey`]: plan, model, fixture, supports, uncertainty, seed, sample
//! count), and the merge is [`mesopush_core::shard::merge`]: it refuses files of different
//! runs, a shard count that disagrees, a shard given twice or missing, and any trial index
//! missing, duplicated or in the wrong shard — naming the file and the problem — so a merged
//! estimate is never silently partial.

use crate::Error;
use crate::montecarlo::{MonteCarlo, SampleOutcome, SuccessEstimate};
use crate::sampler::Uncertainty;
use mesopush_core::fsx::read_json;
use mesopush_core::shard::{self, Shard, ShardFile};
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Fixture, Model, Plan};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format version of a [`TrialShard`] file. 2: the core shard shape (`items`; format 1 called
/// them `trials`). 3: a trial that overloaded the needle is not inserted (`overloaded`);
/// format-2 files judged without the needle's limit.
pub const SHARD_FORMAT: u32 = 3;

/// What the merge calls itself in its errors.
const MERGE: &str = "robustness merge";

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
    pub supports: Vec<SupportSample>,
    /// The uncertainty box.
    pub uncertainty: Uncertainty,
    /// Master seed.
    pub seed: u64,
    /// Trials of the whole run.
    pub samples: u64,
}

/// One shard's trials, as `mesopush robustness run --shard I/N` writes them: the run's key and
/// `(trial index, outcome)` pairs in index order.
pub type TrialShard = ShardFile<RunKey, SampleOutcome>;

/// Runs shard `shard` of `mc` (`samples` trials in all, master seed `seed`).
pub fn run(
    mc: &MonteCarlo<'_>,
    samples: u64,
    seed: u64,
    shard: Shard,
    tick: &(dyn Fn() + Sync),
) -> Result<TrialShard, Error> {
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
    let items = indices.into_iter().zip(trials).collect();
    Ok(ShardFile { format: SHARD_FORMAT, key, shard, items })
}

/// Reads a shard file (written with [`ShardFile::write`]), refusing another format version
/// before reading the rest (a format-1 file would otherwise fail on its field names).
pub fn load(path: &Path) -> Result<TrialShard, Error> {
    /// The field every format has.
    #[derive(Deserialize)]
    struct Format {
        format: u32,
    }
    let Format { format } = read_json(path)?;
    if format != SHARD_FORMAT {
        let m = format!(
            "shard file format {format}; this build reads format {SHARD_FORMAT} (run the shard again)"
        );
        return Err(Error::parse(path, m));
    }
    Ok(ShardFile::read(path, SHARD_FORMAT)?)
}

/// Merges the shards of one run into its estimate (trials in index order).
pub fn merge(files: Vec<(PathBuf, TrialShard)>) -> Result<(RunKey, SuccessEstimate), Error> {
    let (key, trials) = shard::merge(MERGE, files, |k: &RunKey| k.samples)?;
    Ok((key, SuccessEstimate::from_trials(trials)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_of_another_format_is_refused_naming_the_file_and_both_formats() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("shard_old.json");
        std::fs::write(&path, r#"{"format": 1, "key": {}, "shard": {}, "trials": []}"#).unwrap();
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains("shard_old.json") && e.contains("format 1"), "{e}");
        assert!(e.contains(&format!("format {SHARD_FORMAT}")), "{e}");
    }
}
