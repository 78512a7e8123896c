//! Verification of a batch directory's final records against what is on disk: the one
//! place that decides which final record of a trial counts. `batch report`, the summary of
//! `batch run` and `batch merge`, and a resume all go through it, so they agree.
//!
//! Every final (`trial`) record not set aside by a `voided` record is exactly one of:
//! - **foreign**: its index is outside the batch or this directory's shard, or its trial id
//!   or trial seed is not the one the index gives (a record from another batch);
//! - **lost**: its trial directory is gone;
//! - **damaged**: the directory no longer matches the checksum recorded with it
//!   ([`crate::digest`]), or cannot be read;
//! - **duplicated**: a good final record of the same trial came earlier in the journal;
//! - **accepted**: the trial's final record (counted in trials, verdicts and rates).
//!
//! Records written before checksums, and those of attempts a runner may still be writing
//! (timeouts), are accepted when their directory exists and counted `unverified`.

use super::digest::{self, DirChecksum};
use super::journal::{AttemptRecord, Problem, Record};
use super::runner::TrialVerdict;
use super::spec::{BatchSpec, trial_id, trial_seed};
use mesopush_core::shard::Shard;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One final record that does not count, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// Its position in the journal (0-based).
    pub record: u64,
    /// Its trial index.
    pub index: u64,
    /// Its trial id.
    pub trial_id: String,
    /// Its directory (relative to the batch directory).
    pub dir: String,
    /// What is wrong.
    pub problem: Problem,
    /// The evidence (checksums recorded and found, the missing path, …).
    pub detail: String,
}

/// The verification of a journal's final records.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Integrity {
    /// The accepted final record of each trial: index → record position.
    pub accepted: BTreeMap<u64, usize>,
    /// Final records that do not count.
    pub findings: Vec<Finding>,
    /// Accepted records that could not be checked against a checksum.
    pub unverified: u64,
    /// Final records set aside by earlier resumes (`voided` records).
    pub voided: u64,
    /// Trials of this directory that have a final record which is not voided and not
    /// foreign (good or not).
    pub recorded: BTreeSet<u64>,
}

impl Integrity {
    /// How many findings have `problem`.
    pub fn count(&self, problem: Problem) -> u64 {
        self.findings.iter().filter(|f| f.problem == problem).count() as u64
    }

    /// Whether any final record does not count.
    pub fn has_problems(&self) -> bool {
        !self.findings.is_empty()
    }
}

fn foreign(spec: &BatchSpec, shard: Shard, a: &AttemptRecord) -> Option<String> {
    if a.index >= spec.trials {
        return Some(format!("index {} is outside the batch's 0..{}", a.index, spec.trials));
    }
    if !shard.owns(a.index) {
        return Some(format!("index {} is not in shard {}", a.index, shard.dir_name()));
    }
    if a.trial_id != trial_id(a.index) || a.trial_seed != trial_seed(spec.seed, a.index) {
        return Some(format!(
            "trial id {} / seed {} do not belong to index {} of this batch",
            a.trial_id, a.trial_seed, a.index
        ));
    }
    None
}

/// Checks one record's directory; `Ok(true)` when verified by checksum.
fn check_dir(base: &Path, a: &AttemptRecord) -> Result<bool, (Problem, String)> {
    let path = base.join(&a.dir);
    let gone = || (Problem::Lost, format!("{} is gone", path.display()));
    match &a.checksum {
        Some(DirChecksum::Absent) => Ok(true),
        Some(DirChecksum::Unsettled { present }) => {
            if *present && !path.exists() {
                Err(gone())
            } else {
                Ok(false)
            }
        }
        None => {
            let no_log_expected = matches!(a.result.verdict, TrialVerdict::Error)
                || matches!(a.result.verdict, TrialVerdict::Timeout);
            if !no_log_expected && !path.exists() { Err(gone()) } else { Ok(false) }
        }
        Some(recorded @ DirChecksum::Tree { .. }) => {
            if !path.exists() {
                return Err(gone());
            }
            let found = digest::of_dir(&path)
                .map_err(|e| (Problem::Damaged, format!("unreadable: {e}")))?;
            if &found == recorded {
                Ok(true)
            } else {
                Err((
                    Problem::Damaged,
                    format!("recorded {}; found {}", recorded.describe(), found.describe()),
                ))
            }
        }
    }
}

/// Verifies every final record of `records` (a batch directory `base` of batch `spec`,
/// shard `shard`) against the directories on disk.
pub fn verify(base: &Path, spec: &BatchSpec, shard: Shard, records: &[Record]) -> Integrity {
    let voided: BTreeSet<u64> = records
        .iter()
        .filter_map(|r| if let Record::Voided { record, .. } = r { Some(*record) } else { None })
        .collect();
    let mut out = Integrity { voided: voided.len() as u64, ..Integrity::default() };
    for (i, r) in records.iter().enumerate() {
        let Record::Trial(a) = r else { continue };
        if voided.contains(&(i as u64)) {
            continue;
        }
        let mut finding = |problem, detail| {
            out.findings.push(Finding {
                record: i as u64,
                index: a.index,
                trial_id: a.trial_id.clone(),
                dir: a.dir.clone(),
                problem,
                detail,
            });
        };
        if let Some(why) = foreign(spec, shard, a) {
            finding(Problem::Foreign, why);
            continue;
        }
        out.recorded.insert(a.index);
        match check_dir(base, a) {
            Err((problem, detail)) => finding(problem, detail),
            Ok(verified) => {
                if let Some(first) = out.accepted.get(&a.index) {
                    let why = format!("record {first} is already this trial's good final record");
                    finding(Problem::Duplicated, why);
                } else {
                    out.accepted.insert(a.index, i);
                    out.unverified += u64::from(!verified);
                }
            }
        }
    }
    out
}
