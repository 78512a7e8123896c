//! The batch summary computed from a batch directory's journal: counts per verdict, the
//! success rate with its Wilson 95 % interval, fault and data-loss totals over every
//! attempt, failure reasons, timing. The same code serves a running batch, a resumed one
//! and a merge of shards, so `--json`, the report and the merge agree.

use super::engine::Manifest;
use super::integrity::{Finding, Integrity, verify};
use super::journal::{AttemptRecord, JOURNAL, Problem, Record, read};
use super::runner::TrialVerdict;
use crate::Error;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A batch directory, loaded and its final records verified against their directories.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// `batch.json`.
    pub manifest: Manifest,
    /// The journal.
    pub records: Vec<Record>,
    /// Which final records count, and what is wrong with the others.
    pub integrity: Integrity,
}

impl Loaded {
    /// Reads `dir`'s manifest and journal (a torn last line is ignored, not repaired) and
    /// verifies every final record against its trial directory.
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let manifest = Manifest::load(dir)?;
        let path = dir.join(JOURNAL);
        let records = if path.exists() { read(&path)? } else { Vec::new() };
        let integrity = verify(dir, &manifest.spec, manifest.shard, &records);
        Ok(Self { manifest, records, integrity })
    }

    /// The accepted final record of every trial, by index (lost, damaged, duplicated,
    /// foreign and voided records excluded; [`Loaded::integrity`] lists them).
    pub fn finals(&self) -> BTreeMap<u64, &AttemptRecord> {
        self.integrity
            .accepted
            .iter()
            .filter_map(|(index, i)| match &self.records[*i] {
                Record::Trial(a) => Some((*index, a)),
                _ => None,
            })
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
    /// Trials with an accepted final verdict (verified against their directories).
    pub trials: u64,
    /// Trials this directory is meant to hold (its shard, or the whole batch).
    pub expected: u64,
    /// Expected trials with no final record at all yet.
    pub missing: u64,
    /// Final records of a trial that already has a good one (must be 0).
    pub duplicates: u64,
    /// Final records whose trial directory is gone (must be 0).
    pub lost: u64,
    /// Final records whose trial directory no longer matches its checksum (must be 0).
    pub damaged: u64,
    /// Final records of trials this directory does not hold (must be 0).
    pub foreign: u64,
    /// Accepted final records without a checksum to verify (journals written before
    /// checksums; timed-out attempts, whose runner may have still been writing).
    pub unverified: u64,
    /// Final records set aside by earlier resumes as lost, damaged, duplicated or foreign
    /// (their trials were run again).
    pub voided: u64,
    /// Every final record that does not count, with the evidence.
    pub findings: Vec<Finding>,
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
    /// Records lost (must be 0): records missing from the trial logs over every attempt,
    /// plus final records whose trial directory is lost or damaged.
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

impl Summary {
    /// Whether any record is lost, damaged, duplicated or foreign (the commands exit 1).
    pub fn has_integrity_problems(&self) -> bool {
        self.records_lost > 0 || self.duplicates > 0 || self.foreign > 0
    }

    /// `records lost 2 (1 in trial logs, final directories: 1 lost, 0 damaged), 0 duplicated, 0 foreign`.
    pub fn integrity_line(&self) -> String {
        format!(
            "records lost {} (in trial logs {}; final trial directories: {} lost, {} damaged); \
             final records duplicated {}, foreign {}; unverified {}",
            self.records_lost,
            self.records_lost - self.lost - self.damaged,
            self.lost,
            self.damaged,
            self.duplicates,
            self.foreign,
            self.unverified
        )
    }
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
    let integ = &b.integrity;
    let n = finals.len() as u64;
    let count = |v: TrialVerdict| finals.values().filter(|a| a.result.verdict == v).count() as u64;
    let mut s = Summary {
        name: spec.name.clone(),
        trials: n,
        expected,
        missing: expected.saturating_sub(integ.recorded.len() as u64),
        duplicates: integ.count(Problem::Duplicated),
        lost: integ.count(Problem::Lost),
        damaged: integ.count(Problem::Damaged),
        foreign: integ.count(Problem::Foreign),
        unverified: integ.unverified,
        voided: integ.voided,
        findings: integ.findings.clone(),
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
        records_lost: integ.count(Problem::Lost) + integ.count(Problem::Damaged),
        wall_time_s: 0.0,
        trials_per_s: 0.0,
        sim_time_s: 0.0,
        reasons: count_reasons(finals.values().copied()),
    };
    s.success_rate = if n == 0 { 0.0 } else { s.succeeded as f64 / n as f64 };
    let counted: BTreeSet<usize> = integ.accepted.values().copied().collect();
    for (i, r) in b.records.iter().enumerate() {
        match r {
            Record::Trial(_) if !counted.contains(&i) => {}
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
            Record::Begin { .. } | Record::Voided { .. } => {}
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
