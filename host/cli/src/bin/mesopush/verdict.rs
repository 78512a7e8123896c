//! Verdicts: the head of a trial's printed summary (state, verdict, reason, final pose),
//! shared by `mesopush demo` (in-process loop) and `mesopush run` (a rig or
//! `mesopush-fwsim`), so both say the same thing the same way; and [`Negative`], the error a
//! command returns for a negative verdict (exit status 1; any other error is invalid input
//! or a refusal, exit status 2).

use mesopush_core::geom::Pose;
use mesopush_trial::TrialState;

/// Prints `trial <state>[ (seed S)]: <verdict>`, the reason and the final tracked pose.
pub(crate) fn print_head(
    state: TrialState,
    seed: Option<u64>,
    inserted: Option<bool>,
    reason: Option<&str>,
    final_pose: Option<Pose>,
) {
    let verdict = match inserted {
        Some(true) => "INSERTED",
        Some(false) => "NOT inserted",
        None => "not judged (no tracked pose)",
    };
    let seed = seed.map(|s| format!(" (seed {s})")).unwrap_or_default();
    println!("trial {state}{seed}: {verdict}");
    if let Some(reason) = reason {
        println!("  reason: {reason}");
    }
    if let Some(p) = final_pose {
        println!("  final tracked pose: {p}");
    }
}

/// A negative verdict (no plan found, no verified LCP solution, records lost): the command
/// ran and the answer is no. `main` exits with status 1 for it, 2 for any other error.
#[derive(Debug)]
pub(crate) struct Negative(pub(crate) String);

impl std::fmt::Display for Negative {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Negative {}

/// The exit verdict of a trial: `Ok` only for a trial that ran to its end and was judged
/// inserted; a fault, an abort, an unfinished trial, a peg not inserted or not judged is a
/// negative verdict (exit status 1).
pub(crate) fn trial_verdict(state: TrialState, inserted: Option<bool>) -> Result<(), Negative> {
    match (state, inserted) {
        (TrialState::Done, Some(true)) => Ok(()),
        (TrialState::Done, Some(false)) => Err(Negative("the peg was NOT inserted".into())),
        (TrialState::Done, None) => {
            Err(Negative("not judged: no tracked pose of the peg at rest".into()))
        }
        (state, _) => Err(Negative(format!("the trial did not run to its end: {state}"))),
    }
}
