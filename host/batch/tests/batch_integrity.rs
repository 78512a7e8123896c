//! Data honesty of a batch directory: final trial directories deleted, truncated or
//! changed, final records duplicated or foreign are counted (never "records lost 0"), and a
//! resume sets them aside and runs the trials again so the batch ends equal to a clean run;
//! the window between renaming an interrupted attempt and journalling it is closed; the lock
//! refuses a second engine on one directory; a merge run again completes or finds itself
//! complete.

use mesopush_batch::journal::{JOURNAL, Problem, Record, read};
use mesopush_batch::lock::BatchLock;
use mesopush_batch::merge::{self, MARKER, Outcome};
use mesopush_batch::spec::{BatchWorld, Policy, StartCameraSpec};
use mesopush_batch::stats::{Loaded, Summary, summarize};
use mesopush_batch::{
    BatchConfig, BatchSpec, Error, RunnerFactory, Session, SimRunner, TrialResult, TrialRunner, run,
};
use mesopush_core::shard::Shard;
use mesopush_sim::{Fixture, Model, Plan};
use mesopush_trial::{TrialMeta, TrialWriter};
use std::path::{Path, PathBuf};

const TRIALS: u64 = 6;

fn spec() -> BatchSpec {
    BatchSpec {
        name: "integrity".into(),
        seed: 41,
        trials: TRIALS,
        runner: "sim".into(),
        out: None,
        plans: vec![PathBuf::from("table2.toml")],
        world: BatchWorld::default(),
        camera: StartCameraSpec {
            estimate_start: true,
            frame_drop: 0.3,
            frame_black: 0.3,
            max_frames: 2,
            film_period_us: None,
        },
        policy: Policy { timeout_s: 60.0, grace_s: 1.0, max_attempts: 2, ..Default::default() },
        frames: Default::default(),
    }
}

fn factory() -> RunnerFactory {
    Box::new(move || {
        let theta = Plan::table2().peg_start_pose().theta_rad;
        let r = SimRunner::new(
            Model::default(),
            Fixture::paper(),
            &spec().camera,
            theta,
            serde_json::json!({}),
        )?;
        Ok(Box::new(r) as Box<dyn TrialRunner>)
    })
}

fn run_batch(out: &Path, shard: Shard, max_trials: Option<u64>) -> Result<Session, Error> {
    let cfg = BatchConfig {
        spec: spec(),
        plans: vec![Plan::table2()],
        out: out.to_path_buf(),
        shard,
        max_trials,
        space: mesopush_batch::space::SpaceCheck::default(),
    };
    run(&cfg, factory(), &mut |_| {})
}

/// Final records without wall times: (index, dir name, result).
fn finals(dir: &Path) -> Vec<(u64, String, TrialResult)> {
    let b = Loaded::load(dir).unwrap();
    b.finals().values().map(|a| (a.index, a.dir.clone(), a.result.clone())).collect()
}

fn summary(dir: &Path) -> Summary {
    summarize(&Loaded::load(dir).unwrap())
}

fn append_line(out: &Path, line: &str) {
    let mut j = std::fs::read_to_string(out.join(JOURNAL)).unwrap();
    j.push_str(line);
    j.push('\n');
    std::fs::write(out.join(JOURNAL), j).unwrap();
}

/// The final record line of trial `index`.
fn final_line(out: &Path, index: u64) -> String {
    std::fs::read_to_string(out.join(JOURNAL))
        .unwrap()
        .lines()
        .find(|l| l.contains("\"type\":\"trial\"") && l.contains(&format!("\"index\":{index},")))
        .unwrap()
        .to_string()
}

/// The reference: one clean run.
fn reference(tmp: &Path) -> PathBuf {
    let a = tmp.join("reference");
    run_batch(&a, Shard::ALL, None).unwrap();
    let s = summary(&a);
    assert_eq!((s.trials, s.lost, s.damaged, s.duplicates, s.foreign), (TRIALS, 0, 0, 0, 0));
    assert_eq!(s.unverified, 0, "every final record of a fresh run carries a checksum");
    a
}

/// Damages a fresh copy of the batch with `harm`, checks the summary counts `problem`
/// exactly once, resumes, checks the resume found it, and that the batch then equals the
/// clean run with nothing left to count.
fn harm_count_and_repair(tmp: &Path, name: &str, problem: Problem, harm: &dyn Fn(&Path)) {
    let reference = reference(&tmp.join(format!("{name}-ref")));
    let out = tmp.join(name);
    run_batch(&out, Shard::ALL, None).unwrap();
    harm(&out);
    let s = summary(&out);
    let counts = (s.lost, s.damaged, s.duplicates, s.foreign);
    let expected = match problem {
        Problem::Lost => (1, 0, 0, 0),
        Problem::Damaged => (0, 1, 0, 0),
        Problem::Duplicated => (0, 0, 1, 0),
        Problem::Foreign => (0, 0, 0, 1),
    };
    assert_eq!(counts, expected, "{name}: (lost, damaged, duplicated, foreign)");
    assert!(s.has_integrity_problems(), "{name}");
    assert_eq!(s.findings.len(), 1, "{name}: {:?}", s.findings);
    assert_eq!(s.findings[0].problem, problem);
    let verified = if matches!(problem, Problem::Lost | Problem::Damaged) { 5 } else { 6 };
    assert_eq!(s.trials, verified, "{name}: trials counts verified verdicts only (never 7 of 6)");
    assert_eq!(s.expected, TRIALS);
    let session = run_batch(&out, Shard::ALL, None).unwrap();
    assert_eq!(session.found.len(), 1, "{name}: the resume reports what it found");
    assert_eq!(session.found[0].problem, problem);
    let rerun = u64::from(matches!(problem, Problem::Lost | Problem::Damaged));
    assert_eq!(session.ran, rerun, "{name}: lost and damaged trials run again, others do not");
    let s = summary(&out);
    assert!(!s.has_integrity_problems(), "{name}: {:?}", s.findings);
    assert_eq!((s.trials, s.missing, s.voided), (TRIALS, 0, 1), "{name}");
    assert_eq!(finals(&out), finals(&reference), "{name}: equal to a clean run after resume");
    assert!(run_batch(&out, Shard::ALL, None).unwrap().found.is_empty(), "{name}: and stays so");
}

#[test]
fn a_deleted_final_trial_directory_is_counted_lost_and_run_again() {
    let tmp = tempfile::tempdir().unwrap();
    harm_count_and_repair(tmp.path(), "deleted", Problem::Lost, &|out| {
        let dir = out.join(&Loaded::load(out).unwrap().finals()[&2].dir);
        std::fs::remove_dir_all(dir).unwrap();
    });
}

#[test]
fn a_truncated_final_trial_log_is_counted_damaged_kept_aside_and_run_again() {
    let tmp = tempfile::tempdir().unwrap();
    harm_count_and_repair(tmp.path(), "truncated", Problem::Damaged, &|out| {
        let dir = out.join(&Loaded::load(out).unwrap().finals()[&3].dir);
        let pose = dir.join("pose.csv");
        let len = std::fs::metadata(&pose).unwrap().len();
        let f = std::fs::OpenOptions::new().write(true).open(&pose).unwrap();
        f.set_len(len / 2).unwrap();
    });
    let out = tmp.path().join("truncated");
    let recs = read(&out.join(JOURNAL)).unwrap();
    let aside = recs.iter().find_map(|r| match r {
        Record::Discarded { index: 3, renamed_to, .. } => Some(renamed_to.clone()),
        _ => None,
    });
    let aside = out.join(aside.expect("the damaged directory is set aside, journalled"));
    assert!(aside.join("pose.csv").exists(), "the damaged log is kept, renamed, never deleted");
}

#[test]
fn a_duplicated_final_record_is_counted_and_voided() {
    let tmp = tempfile::tempdir().unwrap();
    harm_count_and_repair(tmp.path(), "duplicated", Problem::Duplicated, &|out| {
        let line = final_line(out, 4);
        append_line(out, &line);
    });
}

#[test]
fn a_record_of_a_trial_outside_the_batch_is_counted_foreign() {
    let tmp = tempfile::tempdir().unwrap();
    harm_count_and_repair(tmp.path(), "foreign", Problem::Foreign, &|out| {
        let line = final_line(out, 1)
            .replace("\"index\":1,", "\"index\":999,")
            .replace("trial-000001", "trial-000999");
        append_line(out, &line);
    });
}

/// What a kill mid-trial leaves: a Begin record and a half-written trial directory at
/// `dir` (relative to the batch directory).
fn interrupted_attempt(out: &Path, index: u64, dir: &str) {
    let meta = TrialMeta::new(format!("trial-{index:06}"), "sim", Model::default().part);
    drop(TrialWriter::create(&out.join(dir), meta).unwrap());
    let begin = Record::Begin { index, attempt: 1, dir: format!("trials/trial-{index:06}-a1") };
    append_line(out, &serde_json::to_string(&begin).unwrap());
}

fn discarded(out: &Path, index: u64) -> Vec<(String, String)> {
    read(&out.join(JOURNAL))
        .unwrap()
        .into_iter()
        .filter_map(|r| match r {
            Record::Discarded { index: i, renamed_to, found, .. } if i == index => {
                Some((renamed_to, found))
            }
            _ => None,
        })
        .collect()
}

/// The window between setting an interrupted attempt aside and journalling it, from both
/// sides: (a) the `discarded` record written, the rename not done (the order the engine
/// uses now: the resume completes the rename, no second record); (b) the rename done, no
/// record (a batch directory written before that order, or renamed by hand: the resume
/// journals it). Either way every set-aside directory is journalled exactly once and the
/// batch ends equal to a clean run.
#[test]
fn the_rename_journal_window_is_closed_from_both_sides() {
    let tmp = tempfile::tempdir().unwrap();
    let reference = reference(tmp.path());
    // (a) journalled, then killed before the rename
    let a = tmp.path().join("intent");
    run_batch(&a, Shard::ALL, Some(1)).unwrap();
    interrupted_attempt(&a, 1, "trials/trial-000001-a1");
    let intent = Record::Discarded {
        index: 1,
        attempt: 1,
        renamed_to: "trials/trial-000001-a1.discarded-1".into(),
        found: "incomplete".into(),
    };
    append_line(&a, &serde_json::to_string(&intent).unwrap());
    let session = run_batch(&a, Shard::ALL, None).unwrap();
    assert_eq!(session.discarded, 1);
    assert!(a.join("trials/trial-000001-a1.discarded-1/trial.json").exists(), "rename completed");
    assert_eq!(discarded(&a, 1).len(), 1, "no second record for the completed rename");
    assert_eq!(finals(&a), finals(&reference));
    // (b) renamed, then killed before the record
    let b = tmp.path().join("renamed");
    run_batch(&b, Shard::ALL, Some(1)).unwrap();
    interrupted_attempt(&b, 1, "trials/trial-000001-a1.discarded-1");
    let session = run_batch(&b, Shard::ALL, None).unwrap();
    assert_eq!(session.discarded, 1);
    let d = discarded(&b, 1);
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].0, "trials/trial-000001-a1.discarded-1");
    assert!(d[0].1.contains("unjournalled"), "{d:?}");
    assert_eq!(summary(&b).discarded, 1);
    assert_eq!(finals(&b), finals(&reference));
}

#[test]
fn a_second_engine_on_a_locked_directory_is_refused_naming_the_holder() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    let held = BatchLock::exclusive(&out).unwrap();
    let e = run_batch(&out, Shard::ALL, None).unwrap_err();
    assert!(matches!(e, Error::Locked { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains(&format!("pid {}", std::process::id())) && text.contains("since"),
        "{text}"
    );
    assert!(!out.join(JOURNAL).exists(), "refused before touching the journal");
    drop(held);
    run_batch(&out, Shard::ALL, None).unwrap();
    assert_eq!(summary(&out).trials, TRIALS);
    let e = run_batch(&out, Shard::ALL, Some(0)).unwrap_err().to_string();
    assert!(e.contains("--max-trials") && e.contains('0'), "{e}");
}

/// `batch merge` killed after writing its journal (the journal is its last write, so that
/// is a merge that ended) and run again: complete, identical, nothing written. Killed
/// before the journal: run again, it writes the same bytes. An input that progressed: the
/// merge is brought up to date. A run's directory as --out is still refused.
#[test]
fn merge_run_again_completes_or_finds_itself_complete() {
    let tmp = tempfile::tempdir().unwrap();
    let shards: Vec<PathBuf> = (0..2).map(|i| tmp.path().join(format!("s{i}"))).collect();
    run_batch(&shards[0], Shard { index: 0, count: 2 }, None).unwrap();
    run_batch(&shards[1], Shard { index: 1, count: 2 }, Some(1)).unwrap();
    let out = tmp.path().join("merged");
    assert_eq!(merge::merge(&shards, &out).unwrap().outcome, Outcome::Written);
    let journal = std::fs::read(out.join(JOURNAL)).unwrap();
    let again = merge::merge(&shards, &out).unwrap();
    assert_eq!((again.outcome, again.trials), (Outcome::AlreadyComplete, 4));
    assert_eq!(std::fs::read(out.join(JOURNAL)).unwrap(), journal);
    std::fs::remove_file(out.join(JOURNAL)).unwrap(); // killed after the marker and manifest
    assert!(out.join(MARKER).exists());
    assert_eq!(merge::merge(&shards, &out).unwrap().outcome, Outcome::Written);
    assert_eq!(std::fs::read(out.join(JOURNAL)).unwrap(), journal, "the same bytes");
    run_batch(&shards[1], Shard { index: 1, count: 2 }, None).unwrap();
    let updated = merge::merge(&shards, &out).unwrap();
    assert_eq!((updated.outcome, updated.trials), (Outcome::Updated, 6));
    assert_eq!(summary(&out).trials, TRIALS);
    let e = merge::merge(&shards, &shards[0]).unwrap_err().to_string();
    assert!(e.contains("is an input"), "{e}");
    let whole = reference(tmp.path());
    let e = merge::merge(&shards, &whole).unwrap_err().to_string();
    assert!(e.contains("did not write"), "{e}");
    let _running = BatchLock::exclusive(&shards[0]).unwrap();
    let e = merge::merge(&shards, &tmp.path().join("m2")).unwrap_err().to_string();
    assert!(e.contains("in use"), "a shard still being run is not merged: {e}");
}

/// A shard input holding a damaged record is refused by name rather than merged.
#[test]
fn merge_refuses_an_input_with_records_that_do_not_count() {
    let tmp = tempfile::tempdir().unwrap();
    let s0 = tmp.path().join("s0");
    run_batch(&s0, Shard { index: 0, count: 2 }, None).unwrap();
    let dir = s0.join(&Loaded::load(&s0).unwrap().finals()[&2].dir);
    std::fs::remove_dir_all(dir).unwrap();
    let e = merge::merge(&[s0], &tmp.path().join("m")).unwrap_err().to_string();
    assert!(e.contains("trial-000002") && e.contains("lost"), "{e}");
}
