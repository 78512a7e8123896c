//! The engine's own check of every attempt against the trial log the runner wrote: a runner
//! that reports a success its log does not show, leaves its log unfinished, or writes none,
//! gets verdict `error` (and the missing data is counted as lost) — a failure is never
//! reported as a success on the runner's word alone.

use super::runner::{TrialResult, TrialVerdict};
use mesopush_trial::{Trial, TrialState};
use std::path::Path;

/// The `outcome.state` of the trial in `dir` as text (`unreadable` when it cannot be read).
pub fn state_of(dir: &Path) -> String {
    match Trial::load(dir) {
        Ok(t) => serde_json::to_value(t.meta.outcome.state)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        Err(_) => "unreadable".into(),
    }
}

fn downgrade(mut r: TrialResult, why: String, lost: u64) -> TrialResult {
    r.reason = format!("{why} (runner said: {} — {})", r.verdict.as_str(), r.reason);
    r.verdict = TrialVerdict::Error;
    r.records_lost += lost;
    r
}

/// Checks `result` against the log in `dir`; returns it, or a downgraded copy.
pub fn against_log(dir: &Path, result: TrialResult) -> TrialResult {
    let v = result.verdict;
    if v == TrialVerdict::Timeout {
        return result;
    }
    if !dir.exists() {
        if v == TrialVerdict::Error {
            return result;
        }
        return downgrade(result, "no trial log was written".into(), 1);
    }
    let trial = match Trial::load(dir) {
        Ok(t) => t,
        Err(e) => return downgrade(result, format!("trial log unreadable: {e}"), 1),
    };
    let o = &trial.meta.outcome;
    if v == TrialVerdict::Error {
        return result;
    }
    if o.state == TrialState::Incomplete {
        return downgrade(result, "trial log left incomplete".into(), 1);
    }
    let agrees = match v {
        TrialVerdict::Inserted => o.state == TrialState::Done && o.inserted == Some(true),
        TrialVerdict::Missed => o.state == TrialState::Done && o.inserted != Some(true),
        TrialVerdict::Faulted => matches!(o.state, TrialState::Faulted | TrialState::Aborted),
        TrialVerdict::Timeout | TrialVerdict::Error => true,
    };
    if !agrees {
        let inserted = match o.inserted {
            Some(true) => "yes",
            Some(false) => "no",
            None => "not judged",
        };
        let why = format!(
            "trial.json says state {}, inserted {inserted}, which does not support `{}`",
            o.state,
            v.as_str()
        );
        return downgrade(result, why, 0);
    }
    result
}
