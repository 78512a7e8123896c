//! The batch engine against runners with known behaviour (the sim runner, and small runners
//! that hang, ignore cancellation, panic, misreport or write no log): verdicts, retries,
//! timeouts, restarts, resume after an interrupted attempt, sharding + merge, the report.

use mesopush_batch::journal::{JOURNAL, Record, read};
use mesopush_batch::space::SpaceCheck;
use mesopush_batch::spec::{BatchWorld, Policy, StartCameraSpec};
use mesopush_batch::stats::{Loaded, summarize};
use mesopush_batch::{
    BatchConfig, BatchSpec, Cancel, RunnerFactory, SimRunner, TrialJob, TrialResult, TrialRunner,
    TrialVerdict, merge, report, run,
};
use mesopush_core::shard::Shard;
use mesopush_sim::{Fixture, Model, Plan};
use mesopush_trial::{Outcome, TrialMeta, TrialState, TrialWriter};
use std::path::{Path, PathBuf};

fn spec(trials: u64, seed: u64, camera: bool) -> BatchSpec {
    BatchSpec {
        name: "test".into(),
        seed,
        trials,
        runner: "sim".into(),
        out: None,
        plans: vec![PathBuf::from("table2.toml")],
        world: BatchWorld::default(),
        camera: StartCameraSpec {
            estimate_start: camera,
            frame_drop: 0.3,
            frame_black: 0.3,
            max_frames: 2,
            film_period_us: None,
        },
        policy: Policy { timeout_s: 30.0, grace_s: 0.5, max_attempts: 2, ..Default::default() },
        frames: Default::default(),
    }
}

fn cfg(spec: BatchSpec, out: &Path, shard: Shard, max_trials: Option<u64>) -> BatchConfig {
    let space = SpaceCheck::default();
    BatchConfig {
        spec,
        plans: vec![Plan::table2()],
        out: out.to_path_buf(),
        shard,
        max_trials,
        space,
    }
}

fn sim_factory(camera: StartCameraSpec) -> RunnerFactory {
    Box::new(move || {
        let theta = Plan::table2().peg_start_pose().theta_rad;
        let r = SimRunner::new(
            Model::default(),
            Fixture::paper(),
            &camera,
            theta,
            serde_json::json!({}),
        )?;
        Ok(Box::new(r) as Box<dyn TrialRunner>)
    })
}

/// Final records without wall times (which differ run to run).
fn finals(dir: &Path) -> Vec<(u64, String, TrialResult)> {
    let b = Loaded::load(dir).unwrap();
    b.finals()
        .values()
        .map(|a| (a.index, a.dir.rsplit('/').next().unwrap().to_string(), a.result.clone()))
        .collect()
}

#[test]
fn resumed_sim_batch_equals_an_uninterrupted_one() {
    let tmp = tempfile::tempdir().unwrap();
    let s = spec(6, 11, true);
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    run(&cfg(s.clone(), &a, Shard::ALL, None), sim_factory(s.camera.clone()), &mut |_| {}).unwrap();
    for _ in 0..3 {
        run(&cfg(s.clone(), &b, Shard::ALL, Some(2)), sim_factory(s.camera.clone()), &mut |_| {})
            .unwrap();
    }
    assert_eq!(finals(&a), finals(&b));
    let sum = summarize(&Loaded::load(&a).unwrap());
    assert_eq!((sum.trials, sum.missing, sum.duplicates, sum.records_lost), (6, 0, 0, 0));
    assert!(sum.faults_injected > 0, "camera faults at p = 0.3 over 6 trials");
    assert_eq!(sum.faults_injected, sum.faults_detected);
}

#[test]
fn interrupted_attempt_is_set_aside_and_rerun() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    let s = spec(3, 5, false);
    run(&cfg(s.clone(), &out, Shard::ALL, Some(1)), sim_factory(s.camera.clone()), &mut |_| {})
        .unwrap();
    // What a kill mid-trial leaves: a Begin record and a half-written trial directory.
    let dir = out.join("trials/trial-000001-a1");
    let meta = TrialMeta::new("trial-000001", "sim", Model::default().part);
    drop(TrialWriter::create(&dir, meta).unwrap());
    let line = serde_json::to_string(&Record::Begin {
        index: 1,
        attempt: 1,
        dir: "trials/trial-000001-a1".into(),
    })
    .unwrap();
    let mut j = std::fs::read_to_string(out.join(JOURNAL)).unwrap();
    j.push_str(&line);
    j.push('\n');
    std::fs::write(out.join(JOURNAL), j).unwrap();
    let session =
        run(&cfg(s.clone(), &out, Shard::ALL, None), sim_factory(s.camera.clone()), &mut |_| {})
            .unwrap();
    assert_eq!((session.resumed, session.ran, session.discarded), (1, 2, 1));
    let kept = out.join("trials/trial-000001-a1.discarded-1");
    assert!(kept.join("trial.json").exists(), "the half-written trial is kept, renamed");
    let recs = read(&out.join(JOURNAL)).unwrap();
    assert!(
        recs.iter().any(
            |r| matches!(r, Record::Discarded { index: 1, found, .. } if found == "incomplete")
        )
    );
    assert_eq!(finals(&out).len(), 3);
}

/// Writes a finished trial log with `state` / `inserted`.
fn write_log(job: &TrialJob, dir: &Path, state: TrialState, inserted: Option<bool>) {
    let meta = TrialMeta::new(job.trial_id.clone(), "test", Model::default().part);
    let w = TrialWriter::create(dir, meta).unwrap();
    w.finish(Outcome { state, reason: None, inserted }).unwrap();
}

fn result(verdict: TrialVerdict) -> TrialResult {
    let mut r = mesopush_batch::supervise::engine_verdict(verdict, "test runner".into());
    r.faults_injected = 1;
    r
}

/// What a scripted runner does in a trial.
#[derive(Debug, Clone, Copy)]
enum Act {
    /// Hang until cancelled on the first attempt, then succeed.
    HangOnce,
    /// Never return, ignoring cancellation (a component stuck for good).
    Stuck,
    Panic,
    /// Claim a success its log denies.
    Lie,
    /// Claim a miss and write no log.
    NoLog,
    Succeed,
}

/// Acts by trial index.
#[derive(Debug)]
struct Scripted(Vec<Act>);

impl TrialRunner for Scripted {
    fn name(&self) -> &'static str {
        "scripted"
    }
    fn run(
        &mut self,
        job: &TrialJob,
        dir: &Path,
        cancel: &Cancel,
    ) -> Result<TrialResult, mesopush_batch::Error> {
        match self.0[job.index as usize] {
            Act::HangOnce if job.attempt == 1 => {
                while !cancel.is_cancelled() {
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
                cancel.check()?;
                unreachable!("check fails once cancelled")
            }
            Act::Stuck => loop {
                std::thread::park();
            },
            Act::Panic => panic!("boom in {}", job.trial_id),
            Act::Lie => {
                write_log(job, dir, TrialState::Done, Some(false));
                Ok(result(TrialVerdict::Inserted))
            }
            Act::NoLog => Ok(result(TrialVerdict::Missed)),
            Act::HangOnce | Act::Succeed => {
                write_log(job, dir, TrialState::Done, Some(true));
                Ok(result(TrialVerdict::Inserted))
            }
        }
    }
}

fn scripted(acts: &[Act], policy: Policy) -> (tempfile::TempDir, PathBuf, mesopush_batch::Session) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    let mut s = spec(acts.len() as u64, 1, false);
    s.policy = policy;
    let acts = acts.to_vec();
    let factory: RunnerFactory =
        Box::new(move || Ok(Box::new(Scripted(acts.clone())) as Box<dyn TrialRunner>));
    let session = run(&cfg(s, &out, Shard::ALL, None), factory, &mut |_| {}).unwrap();
    (tmp, out, session)
}

fn verdicts(out: &Path) -> Vec<(u64, TrialVerdict, u32)> {
    let b = Loaded::load(out).unwrap();
    b.finals().values().map(|a| (a.index, a.result.verdict, a.attempt)).collect()
}

#[test]
fn hung_and_stuck_runners_time_out_are_replaced_and_the_batch_goes_on() {
    let policy = Policy {
        timeout_s: 1.5,
        grace_s: 0.5,
        max_attempts: 2,
        retry_on: vec![TrialVerdict::Timeout],
    };
    let (_tmp, out, session) = scripted(&[Act::HangOnce, Act::Stuck, Act::Succeed], policy);
    assert_eq!(
        verdicts(&out),
        vec![
            (0, TrialVerdict::Inserted, 2), // timed out, cancelled, stopped; retried
            (1, TrialVerdict::Timeout, 2),  // stuck twice: abandoned twice
            (2, TrialVerdict::Inserted, 1),
        ]
    );
    assert_eq!(session.restarts, 2, "each abandoned runner is replaced");
    let b = Loaded::load(&out).unwrap();
    let r = &b.finals()[&1].result.reason;
    assert!(r.contains("abandoned"), "{r}");
    assert_eq!(summarize(&b).attempts, 5);
}

#[test]
fn panics_and_lies_end_with_true_verdicts_and_the_batch_goes_on() {
    let policy = Policy { timeout_s: 60.0, grace_s: 1.0, max_attempts: 1, retry_on: vec![] };
    let acts = [Act::Panic, Act::Lie, Act::NoLog, Act::Succeed];
    let (_tmp, out, session) = scripted(&acts, policy);
    assert_eq!(
        verdicts(&out),
        vec![
            (0, TrialVerdict::Error, 1),
            (1, TrialVerdict::Error, 1), // its log says not inserted
            (2, TrialVerdict::Error, 1), // no log
            (3, TrialVerdict::Inserted, 1),
        ]
    );
    assert_eq!(session.restarts, 1, "the panicked runner is replaced");
    let b = Loaded::load(&out).unwrap();
    assert!(b.finals()[&0].result.reason.contains("boom in trial-000000"));
    assert!(b.finals()[&1].result.reason.contains("does not support `inserted`"));
    assert_eq!(summarize(&b).records_lost, 1, "trial 2's missing log is counted as lost");
}

#[test]
fn shards_merge_into_the_unsharded_batch_and_the_report_has_every_figure() {
    let tmp = tempfile::tempdir().unwrap();
    let s = spec(5, 3, false);
    let whole = tmp.path().join("whole");
    run(&cfg(s.clone(), &whole, Shard::ALL, None), sim_factory(s.camera.clone()), &mut |_| {})
        .unwrap();
    let shards: Vec<PathBuf> = (0..2).map(|i| tmp.path().join(format!("s{i}"))).collect();
    for (i, d) in shards.iter().enumerate() {
        let sh = Shard { index: i as u64, count: 2 };
        run(&cfg(s.clone(), d, sh, None), sim_factory(s.camera.clone()), &mut |_| {}).unwrap();
    }
    let merged = tmp.path().join("merged");
    assert!(merge::merge(&shards[..1], &merged).is_ok());
    assert_eq!(
        summarize(&Loaded::load(&merged).unwrap()).missing,
        2,
        "a lone shard leaves trials missing"
    );
    let merged = tmp.path().join("merged2");
    merge::merge(&shards, &merged).unwrap();
    assert_eq!(finals(&merged), finals(&whole));
    let again = merge::merge(&[shards[0].clone(), shards[0].clone()], &tmp.path().join("dup"));
    assert!(again.unwrap_err().to_string().contains("both"));
    let w = report::write(&merged, &merged.join("report")).unwrap();
    let md = std::fs::read_to_string(&w.markdown).unwrap();
    for needle in [
        "Wilson 95 %",
        "success.png",
        "final_poses.png",
        "timing.png",
        "Failure reasons",
        "trials per second",
    ] {
        assert!(md.contains(needle), "{needle} missing from\n{md}");
    }
    for f in &w.figures {
        assert!(std::fs::metadata(f).unwrap().len() > 1000, "{}", f.display());
    }
    assert_eq!(w.summary.trials, 5);
}

#[test]
fn another_batch_in_the_same_directory_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    let s = spec(2, 1, false);
    run(&cfg(s.clone(), &out, Shard::ALL, Some(1)), sim_factory(s.camera.clone()), &mut |_| {})
        .unwrap();
    let e = run(
        &cfg(spec(2, 2, false), &out, Shard::ALL, None),
        sim_factory(s.camera.clone()),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("different batch"), "{e}");
}

/// A trial's result must not depend on which trials the runner ran before it (shards and
/// resumed runs see other predecessors). Found in release builds: the sim runner reused one
/// simulator, whose LCP warm start carried over, and trial 858 of `batches/table2.toml`
/// differed in the last bit of θ between a 2-shard run (856 before it) and the whole batch
/// (857 before it). This profile's floating point did not reproduce that pair; the release
/// check is the shard-vs-whole comparison in docs/batch.md.
#[test]
fn a_sim_trial_does_not_depend_on_the_trial_before_it() {
    use mesopush_batch::engine::peg_start;
    use mesopush_batch::spec::{attempt_seed, trial_id, trial_seed};
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let spec = BatchSpec::load(&root.join("batches/table2.toml")).unwrap();
    let plans = std::sync::Arc::new(spec.load_plans(&root.join("batches")).unwrap());
    let job = |index: u64| {
        let seed = trial_seed(spec.seed, index);
        TrialJob {
            index,
            trial_id: trial_id(index),
            attempt: 1,
            trial_seed: seed,
            attempt_seed: attempt_seed(seed, 1),
            peg_start: peg_start(&spec, &plans, seed),
            plans: plans.clone(),
        }
    };
    let tmp = tempfile::tempdir().unwrap();
    let mut results = Vec::new();
    for before in [856, 857] {
        let mut r = sim_factory(spec.camera.clone())().unwrap();
        let d = tmp.path().join(format!("after-{before}"));
        r.run(&job(before), &d.join("first"), &Cancel::new()).unwrap();
        results.push(r.run(&job(858), &d.join("858"), &Cancel::new()).unwrap());
    }
    assert_eq!(results[0], results[1]);
    let pose = |d: &str| std::fs::read(tmp.path().join(d).join("858/pose.csv")).unwrap();
    assert_eq!(pose("after-856"), pose("after-857"));
}
