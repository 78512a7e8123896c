//! The malformed-input corpus (`tests/malformed/`, issue 19): every case of `cases.toml` runs
//! the real `mesopush` (or `mesopush-fwsim`) binary on a malformed file or option and must
//! end without a panic, with its exit code (2, invalid input, unless the case says otherwise)
//! and with an error naming the offending field or option and its value. All failures are
//! listed together.

mod common;

use rayon::prelude::*;
use serde::Deserialize;
use std::time::Duration;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    name: String,
    #[serde(default = "default_bin")]
    bin: String,
    args: Vec<String>,
    #[serde(default = "default_code")]
    code: i32,
    stderr: Vec<String>,
}

fn default_bin() -> String {
    "mesopush".into()
}

fn default_code() -> i32 {
    2
}

#[derive(Debug, Deserialize)]
struct Cases {
    case: Vec<Case>,
}

/// A run of a valid command stops at its first error in well under this; a case that runs
/// this long has slipped past validation.
const LIMIT: Duration = Duration::from_secs(120);

/// What is wrong with one case's run, if anything.
fn check(case: &Case) -> Option<String> {
    let tmp = tempfile::tempdir().expect("temporary directory");
    let c = common::corpus().display().to_string();
    let out = tmp.path().join("out").display().to_string();
    let args: Vec<String> =
        case.args.iter().map(|a| a.replace("{c}", &c).replace("{out}", &out)).collect();
    let ended = common::run(&common::binary(&case.bin), &args, tmp.path(), LIMIT);
    let mut wrong = Vec::new();
    if ended.panicked() {
        wrong.push("panicked".to_string());
    }
    if ended.timed_out {
        wrong.push(format!("still running after {} s", LIMIT.as_secs()));
    } else if ended.code != Some(case.code) {
        wrong.push(format!("exit code {:?}, expected {}", ended.code, case.code));
    }
    let missing: Vec<&String> = case.stderr.iter().filter(|s| !ended.stderr.contains(*s)).collect();
    if !missing.is_empty() {
        wrong.push(format!("stderr lacks {missing:?}"));
    }
    if wrong.is_empty() {
        return None;
    }
    let tail: String =
        ended.stderr.chars().rev().take(600).collect::<Vec<_>>().into_iter().rev().collect();
    Some(format!("{}: {}\n  args: {args:?}\n  stderr: {tail}", case.name, wrong.join("; ")))
}

#[test]
fn every_malformed_input_is_refused_by_name_without_a_panic() {
    let text = std::fs::read_to_string(common::corpus().join("cases.toml")).expect("cases.toml");
    let cases: Cases = toml::from_str(&text).expect("cases.toml parses");
    assert!(cases.case.len() >= 150, "the corpus shrank to {} cases", cases.case.len());
    let failures: Vec<String> = cases.case.par_iter().filter_map(check).collect();
    assert!(
        failures.is_empty(),
        "{} of {} malformed-input cases failed:\n{}",
        failures.len(),
        cases.case.len(),
        failures.join("\n")
    );
}
