//! The batch summary computed from a batch directory's journal: counts per verdict, the
//! success rate with its Wilson 95 % interval, fault and data-loss totals over every
//! attempt, failure reasons, timing. The same code serves a running batch, a resumed one
//! and a merge of shards, so `--json`, the report and the merge agree.

use super::engine::Manifest;
use super::journal::{AttemptRecord, JOURNAL, Record, read};
use super::runner::TrialVerdict;
use crate::Error;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// A batch directory, loaded.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// `batch.json`.
    pub manifest: Manifest,
    /// The journal.
    pub records: Vec<Record>,
}

impl Loaded {
    /// Reads `dir`'s manifest and journal (a torn last line is ignored, not repaired).
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let manifest = Manifest::load(dir)?;
        let path = dir.join(JOURNAL);
        let records = if path.exists() { read(&path)? } else { Vec::new() };
        Ok(Self { manifest, records })
    }

    /// The final record of every trial, by index (the last one wins if a journal somehow
    /// holds two; [`Summary::duplicates`] counts that).
    pub fn finals(&self) -> BTreeMap<u64, &AttemptRecord> {
        self.records
            .iter()
            .filter_map(|r| if let Record::Trial(a) = r { Some((a.index, a)) } else { None })
            .collect()
    }
}

/// One row of the failure-reasons table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReasonCount {
    /// The verdict.
    pub verdict: TrialVerdict,
    /// The reason with its numbers cut off (text before the first `:`).
    pub reason: String,
    /// How many trials.
    pub trials: u64,
}

/// The summary (`--json` prints it; the report shows it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Batch name.
    pub name: String,
    /// Trials with a final verdict.
    pub trials: u64,
    /// Trials this directory is meant to hold (its shard, or the whole batch).
    pub expected: u64,
    /// Expected trials with no final verdict yet.
    pub missing: u64,
    /// Trials with more than one final record (must be 0).
    pub duplicates: u64,
    /// TrialVerdict `inserted`.
    pub succeeded: u64,
    /// TrialVerdict `missed`.
    pub missed: u64,
    /// TrialVerdict `faulted`.
    pub faulted: u64,
    /// TrialVerdict `timeout`.
    pub timeouts: u64,
    /// TrialVerdict `error`.
    pub errors: u64,
    /// succeeded / trials.
    pub success_rate: f64,
    /// Wilson score 95 % interval of the success rate.
    pub success_ci95: [f64; 2],
    /// Attempts run (finals plus retried ones).
    pub attempts: u64,
    /// Attempt directories set aside after interruptions.
    pub discarded: u64,
    /// Faults the world injected, over every attempt.
    pub faults_injected: u64,
    /// Faults the loop detected, over every attempt.
    pub faults_detected: u64,
    /// The same by class (see docs/batch.md, "Faults injected and detected").
    pub faults_by_class: mesopush_rig::FaultClasses,
    /// Records lost, over every attempt (must be 0).
    pub records_lost: u64,
    /// Wall-clock time of all attempts, s.
    pub wall_time_s: f64,
    /// Trials per wall-clock second over the whole loop (trials / wall_time_s).
    pub trials_per_s: f64,
    /// Simulated time covered, s.
    pub sim_time_s: f64,
    /// Failure reasons, most frequent first.
    pub reasons: Vec<ReasonCount>,
}

/// Wilson score interval for `k` successes in `n` trials at z = 1.96.
pub fn wilson95(k: u64, n: u64) -> [f64; 2] {
    let (lo, hi) =
        mesopush_core::stats::wilson_interval(k as usize, n as usize, mesopush_core::stats::Z95);
    [lo, hi]
}

/// The reason's class: the text before its first `:` (numbers come after it).
pub fn reason_class(reason: &str) -> String {
    let head = reason.split(':').next().unwrap_or(reason).trim();
    head.chars().take(80).collect()
}

fn count_reasons<'a>(finals: impl Iterator<Item = &'a AttemptRecord>) -> Vec<ReasonCount> {
    let mut m: BTreeMap<(TrialVerdict, String), u64> = BTreeMap::new();
    for a in finals {
        *m.entry((a.result.verdict, reason_class(&a.result.reason))).or_default() += 1;
    }
    let mut v: Vec<ReasonCount> = m
        .into_iter()
        .map(|((verdict, reason), trials)| ReasonCount { verdict, reason, trials })
        .collect();
    v.sort_by(|a, b| b.trials.cmp(&a.trials).then(a.verdict.cmp(&b.verdict)));
    v
}

/// Summarises a loaded batch directory.
pub fn summarize(b: &Loaded) -> Summary {
    let spec = &b.manifest.spec;
    let shard = b.manifest.shard;
    let expected = (0..spec.trials).filter(|i| shard.owns(*i)).count() as u64;
    let finals = b.finals();
    let all_finals = b.records.iter().filter(|r| matches!(r, Record::Trial(_))).count() as u64;
    let n = finals.len() as u64;
    let count = |v: TrialVerdict| finals.values().filter(|a| a.result.verdict == v).count() as u64;
    let mut s = Summary {
        name: spec.name.clone(),
        trials: n,
        expected,
        missing: expected.saturating_sub(n),
        duplicates: all_finals - n,
        succeeded: count(TrialVerdict::Inserted),
        missed: count(TrialVerdict::Missed),
        faulted: count(TrialVerdict::Faulted),
        timeouts: count(TrialVerdict::Timeout),
        errors: count(TrialVerdict::Error),
        success_rate: 0.0,
        success_ci95: wilson95(count(TrialVerdict::Inserted), n),
        attempts: 0,
        discarded: 0,
        faults_injected: 0,
        faults_detected: 0,
        faults_by_class: mesopush_rig::FaultClasses::default(),
        records_lost: 0,
        wall_time_s: 0.0,
        trials_per_s: 0.0,
        sim_time_s: 0.0,
        reasons: count_reasons(finals.values().copied()),
    };
    s.success_rate = if n == 0 { 0.0 } else { s.succeeded as f64 / n as f64 };
    for r in &b.records {
        match r {
            Record::Attempt(a) | Record::Trial(a) => {
                s.attempts += 1;
                s.faults_injected += a.result.faults_injected;
                s.faults_detected += a.result.faults_detected;
                s.faults_by_class.add(&a.result.faults);
                s.records_lost += a.result.records_lost;
                s.wall_time_s += a.wall_time_s;
                s.sim_time_s += a.result.sim_time_s;
            }
            Record::Discarded { .. } => s.discarded += 1,
            Record::Begin { .. } => {}
        }
    }
    s.trials_per_s = if s.wall_time_s > 0.0 { n as f64 / s.wall_time_s } else { 0.0 };
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_a_worked_example() {
        // 81 of 263 (Wilson's textbook example region): [0.2553, 0.3662] at 95 %.
        let [lo, hi] = wilson95(81, 263);
        assert!((lo - 0.2553).abs() < 5e-4 && (hi - 0.3662).abs() < 5e-4, "{lo} {hi}");
        let [lo, hi] = wilson95(10, 10);
        assert!(hi == 1.0 && (lo - 0.7225).abs() < 5e-4, "{lo}");
        assert_eq!(wilson95(0, 0), [0.0, 1.0]);
    }

    #[test]
    fn reason_class_drops_the_numbers() {
        assert_eq!(reason_class("missed: COM 120 µm outside"), "missed");
        assert_eq!(reason_class("no start pose"), "no start pose");
    }
}
