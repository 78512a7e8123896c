//! Free space: a batch whose trials left will not fit is refused before it starts (naming
//! the need and the free space) unless told to ignore it; a batch whose disk fills up stops
//! cleanly before a trial, and the same command resumes it to the same results as an
//! uninterrupted run. The free-space figure is injected (a simulated small disk): no test
//! fills a real one. And the batch file's `frames` is parsed with an error naming it.

use mesopush_batch::space::{FreeSpace, SpaceCheck};
use mesopush_batch::spec::{BatchWorld, Policy, StartCameraSpec};
use mesopush_batch::stats::Loaded;
use mesopush_batch::{
    BatchConfig, BatchSpec, Error, RunnerFactory, SimRunner, TrialResult, TrialRunner, run,
};
use mesopush_core::shard::Shard;
use mesopush_sim::{Fixture, Model, Plan};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::Mutex;

/// A disk whose free bytes are scripted call by call (the last value repeats).
#[derive(Debug)]
struct Script(Mutex<Vec<u64>>);

impl FreeSpace for Script {
    fn free_bytes(&self, _dir: &Path) -> Result<u64, Error> {
        let mut v = self.0.lock().unwrap();
        Ok(if v.len() > 1 { v.remove(0) } else { v[0] })
    }
}

const MB: u64 = 1_000_000;

fn spec() -> BatchSpec {
    BatchSpec {
        name: "space".into(),
        seed: 5,
        trials: 6,
        runner: "sim".into(),
        out: None,
        plans: vec![PathBuf::from("table2.toml")],
        world: BatchWorld::default(),
        camera: StartCameraSpec::default(),
        policy: Policy { timeout_s: 30.0, grace_s: 0.5, ..Default::default() },
        frames: Default::default(),
    }
}

fn cfg(out: &Path, free: Vec<u64>, ignore_at_start: bool) -> BatchConfig {
    BatchConfig {
        spec: spec(),
        plans: vec![Plan::table2()],
        out: out.to_path_buf(),
        shard: Shard::ALL,
        max_trials: None,
        space: SpaceCheck {
            trial_bytes: 10 * MB,
            margin_bytes: 100 * MB,
            ignore_at_start,
            free: Arc::new(Script(Mutex::new(free))),
        },
    }
}

fn factory() -> RunnerFactory {
    Box::new(|| {
        let theta = Plan::table2().peg_start_pose().theta_rad;
        let r = SimRunner::new(
            Model::default(),
            Fixture::paper(),
            &StartCameraSpec::default(),
            theta,
            serde_json::json!({}),
        )?;
        Ok(Box::new(r) as Box<dyn TrialRunner>)
    })
}

fn finals(dir: &Path) -> Vec<(u64, TrialResult)> {
    let b = Loaded::load(dir).unwrap();
    b.finals().values().map(|a| (a.index, a.result.clone())).collect()
}

#[test]
fn a_batch_that_will_not_fit_is_refused_before_it_starts() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    // 6 trials × 10 MB + 100 MB margin = 160 MB needed, 159 MB free
    let err = run(&cfg(&out, vec![159 * MB], false), factory(), &mut |_| {}).unwrap_err();
    let text = err.to_string();
    for needle in
        ["free space", "6 trials", "160.0 MB needed", "159.0 MB free", "--ignore-free-space"]
    {
        assert!(text.contains(needle), "{needle:?} in {text}");
    }
    assert!(finals(&out).is_empty(), "no trial ran");
    // exactly enough: runs
    let s = run(&cfg(&out, vec![160 * MB], false), factory(), &mut |_| {}).unwrap();
    assert_eq!((s.ran, s.stopped), (6, None));
}

#[test]
fn the_override_starts_anyway_and_the_margin_still_stops_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    // 120 MB free: short of 160 MB, but each trial sees 10 MB + margin free
    let s = run(&cfg(&out, vec![120 * MB], true), factory(), &mut |_| {}).unwrap();
    assert_eq!((s.ran, s.stopped), (6, None));
    let out2 = tmp.path().join("c");
    let s = run(&cfg(&out2, vec![109 * MB], true), factory(), &mut |_| {}).unwrap();
    assert_eq!(s.ran, 0);
    assert!(s.stopped.as_deref().unwrap().contains("stopped before trial-000000"), "{s:?}");
}

#[test]
fn a_disk_filling_up_stops_the_batch_cleanly_and_the_same_command_resumes_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let plenty = 10_000 * MB;
    // the start check and three trials see plenty; before the fourth the disk is full
    let s =
        run(&cfg(&a, vec![plenty, plenty, plenty, plenty, 50 * MB], false), factory(), &mut |_| {})
            .unwrap();
    assert_eq!(s.ran, 3);
    let why = s.stopped.expect("stopped");
    assert!(why.contains("stopped before trial-000003") && why.contains("50.0 MB free"), "{why}");
    assert!(why.contains("run the same command again to resume"), "{why}");
    assert_eq!(finals(&a).len(), 3, "the journal holds the three finished trials");
    let s = run(&cfg(&a, vec![plenty], false), factory(), &mut |_| {}).unwrap();
    assert_eq!((s.resumed, s.ran, s.stopped), (3, 3, None));
    run(&cfg(&b, vec![plenty], false), factory(), &mut |_| {}).unwrap();
    assert_eq!(finals(&a), finals(&b), "resumed = uninterrupted");
}

#[test]
fn the_batch_files_frames_field_is_parsed_with_an_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("b.toml");
    let head = "seed = 1\ntrials = 2\nplans = [\"p.toml\"]\n";
    std::fs::write(&path, format!("{head}frames = \"every 4\"\n")).unwrap();
    assert_eq!(BatchSpec::load(&path).unwrap().frames.to_string(), "every 4");
    std::fs::write(&path, format!("{head}frames = \"every 0\"\n")).unwrap();
    let err = BatchSpec::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("frames = \"every 0\"") && err.contains("every N (N a whole number ≥ 1)"),
        "{err}"
    );
}
