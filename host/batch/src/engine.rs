//! The batch engine: runs the trials a shard owns, one attempt at a time, under the policy's
//! budget and retries, journalling every step (fsynced) so that killing the process at any
//! moment and running the same command again continues where it stopped — no trial lost,
//! none duplicated, a half-written attempt set aside (renamed) and run again.
//!
//! Batch directory: `batch.lock` (held for the whole run: a second process is refused,
//! [`crate::lock`]), `batch.json` (the manifest: spec, plans, shard; a re-run with a
//! different batch is refused), `journal.jsonl`, `trials/trial-000007-a1/` (trial logs in
//! the `host::trial` format, one per attempt). A resume first verifies every final record
//! against its directory's checksum ([`crate::integrity`]), voids the ones that do not
//! count and runs their trials again, then sets aside what the interrupted run left
//! ([`crate::leftovers`]).

use super::check;
use super::digest::{self, DirChecksum};
use super::integrity::{Finding, Integrity, verify};
use super::journal::{AttemptRecord, JOURNAL, Journal, Record};
use super::leftovers;
use super::lock::BatchLock;
use super::runner::{RunnerFactory, TrialJob, TrialResult, TrialVerdict};
use super::space::{SpaceCheck, estimate_trial_bytes};
use super::spec::{BatchSpec, attempt_seed, trial_id, trial_seed};
pub use super::spec::{TRIALS_DIR, attempt_dir};
use super::supervise::Supervisor;
use crate::Error;
use mesopush_core::geom::Pose;
use mesopush_core::shard::Shard;
use mesopush_sim::Plan;
use mesopush_trial::FrameRetention;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The manifest's file name.
pub const MANIFEST: &str = "batch.json";
/// The manifest's format marker.
pub const FORMAT: &str = "mesopush-batch";

/// `batch.json`: what this directory holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// 1.
    pub format_version: u32,
    /// The batch file as parsed (`out` cleared: where it lives does not change the batch).
    pub spec: BatchSpec,
    /// The plans' contents.
    pub plans: Vec<Plan>,
    /// Which trials this directory runs.
    pub shard: Shard,
}

impl Manifest {
    /// Reads `dir/batch.json`.
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let path = dir.join(MANIFEST);
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        let m: Manifest = serde_json::from_str(&text)
            .map_err(|e| Error::Parse { path: path.clone(), message: e.to_string() })?;
        if m.format != FORMAT || m.format_version != 1 {
            return Err(Error::Parse { path, message: "not a mesopush-batch v1 manifest".into() });
        }
        Ok(m)
    }
}

/// What to run.
#[derive(Debug, Clone)]
pub struct BatchConfig {
    /// The batch.
    pub spec: BatchSpec,
    /// Its plans, loaded.
    pub plans: Vec<Plan>,
    /// The batch (or shard) directory.
    pub out: PathBuf,
    /// Which trials.
    pub shard: Shard,
    /// Stop this session after this many trials (the rest on the next run).
    pub max_trials: Option<u64>,
    /// The free-space policy (refusal at the start, stop before a trial).
    pub space: SpaceCheck,
}

impl BatchConfig {
    /// The run of batch file `batch` the CLI asks for: its plans (resolved against the
    /// file's directory), the output directory (`out`, else the file's `out`, else
    /// `runs/batch-<file stem>`; a shard runs in `<out>/shard-I-of-N`), the frame retention
    /// (`frames`, else the file's), the free-space check (its per-trial estimate from the
    /// file; `ignore_free_space` skips the refusal at the start), and the factory of its
    /// trial runners.
    pub fn from_file(
        batch: &Path,
        out: Option<PathBuf>,
        shard: Shard,
        max_trials: Option<u64>,
        frames: Option<FrameRetention>,
        ignore_free_space: bool,
    ) -> Result<(Self, RunnerFactory), Error> {
        let mut spec = BatchSpec::load(batch)?;
        spec.frames = frames.unwrap_or(spec.frames);
        let base = batch.parent().unwrap_or(Path::new("."));
        let plans = spec.load_plans(base)?;
        let stem = batch.file_stem().map_or("batch".into(), |s| s.to_string_lossy().into_owned());
        let mut out =
            out.or(spec.out.clone()).unwrap_or(PathBuf::from(format!("runs/batch-{stem}")));
        if shard != Shard::ALL {
            out = out.join(shard.dir_name());
        }
        let theta_hint_rad = plans.first().map_or(0.0, |p| p.peg_start_pose().theta_rad);
        let factory = super::factory::runner_factory(&spec, base, theta_hint_rad)?;
        let space = SpaceCheck {
            trial_bytes: estimate_trial_bytes(&spec, base, &plans)?,
            ignore_at_start: ignore_free_space,
            ..SpaceCheck::default()
        };
        Ok((Self { spec, plans, out, shard, max_trials, space }, factory))
    }
}

/// Progress after each trial.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchProgress {
    /// Trials with a final record (including earlier sessions').
    pub done: u64,
    /// Trials in the shard.
    pub total: u64,
    /// Of those done, inserted.
    pub succeeded: u64,
    /// Done in earlier sessions.
    pub resumed: u64,
}

/// What one session did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Session {
    /// Trials already done when it started.
    pub resumed: u64,
    /// Trials it finished.
    pub ran: u64,
    /// Attempt directories set aside (renamed) because an earlier run was interrupted.
    pub discarded: u64,
    /// Runners rebuilt after a stuck or panicked one.
    pub restarts: u64,
    /// A torn journal line saved here, when one was found.
    pub torn_saved_to: Option<PathBuf>,
    /// Final records this session found lost, damaged, duplicated or foreign when it
    /// started, and set aside (voided) before running their trials again.
    pub found: Vec<Finding>,
    /// Wall-clock time of the session, s.
    pub elapsed_s: f64,
    /// Why the session stopped before its last trial (the disk nearly full), if it did.
    pub stopped: Option<String>,
}

/// The start pose the world gives trial `seed`: the first plan's nominal start, perturbed.
pub fn peg_start(spec: &BatchSpec, plans: &[Plan], seed: u64) -> Pose {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let [x, y, t] = spec.world.perturbation;
    plans[0].perturbed_starts(&mut rng, 1, (x, y, t))[0]
}

fn open_manifest(cfg: &BatchConfig) -> Result<(), Error> {
    let mut spec = cfg.spec.clone();
    spec.out = None;
    // which frames trials keep may change between sessions: it changes no result
    spec.frames = FrameRetention::All;
    let m = Manifest {
        format: FORMAT.into(),
        format_version: 1,
        spec,
        plans: cfg.plans.clone(),
        shard: cfg.shard,
    };
    std::fs::create_dir_all(cfg.out.join(TRIALS_DIR)).map_err(|e| Error::io(&cfg.out, e))?;
    if cfg.out.join(MANIFEST).exists() {
        let old = Manifest::load(&cfg.out)?;
        if old != m {
            return Err(Error::invalid(
                "batch directory",
                format!(
                    "{} holds a different batch (batch file, plans or shard changed); \
                     resume with the same command or choose another --out",
                    cfg.out.display()
                ),
            ));
        }
        return Ok(());
    }
    let text = serde_json::to_string_pretty(&m).expect("manifest serialises");
    Ok(mesopush_core::fsx::write_atomic(&cfg.out.join(MANIFEST), text.as_bytes())?)
}

/// What the journal says so far.
#[derive(Debug, Default)]
struct State {
    done: BTreeMap<u64, TrialVerdict>,
    next_attempt: BTreeMap<u64, u32>,
}

/// The trials with an accepted final record, and the next attempt of each retried one.
fn replay_journal(records: &[Record], integrity: &Integrity) -> State {
    let mut s = State::default();
    for (index, i) in &integrity.accepted {
        if let Record::Trial(a) = &records[*i] {
            s.done.insert(*index, a.result.verdict);
        }
    }
    for r in records {
        if let Record::Attempt(a) = r {
            s.next_attempt.insert(a.index, a.attempt + 1);
        }
    }
    s
}

/// Sets aside (journals a `voided` record for) every final record that does not count:
/// lost, damaged, duplicated or foreign. Their trials, when this batch's and left without
/// a good final record, then run again like unfinished ones.
fn void_findings(integrity: &Integrity, journal: &mut Journal) -> Result<(), Error> {
    for f in &integrity.findings {
        journal.append(&Record::Voided {
            record: f.record,
            index: f.index,
            dir: f.dir.clone(),
            problem: f.problem,
            detail: f.detail.clone(),
        })?;
    }
    Ok(())
}

/// Runs (or resumes) the batch; calls `on_progress` after every trial. Holds the batch
/// directory's lock ([`BatchLock`]) throughout: a second process fails at once.
pub fn run(
    cfg: &BatchConfig,
    factory: RunnerFactory,
    on_progress: &mut dyn FnMut(&BatchProgress),
) -> Result<Session, Error> {
    let t0 = Instant::now();
    cfg.spec.validate()?;
    if cfg.max_trials == Some(0) {
        return Err(Error::invalid("--max-trials", "0: must be at least 1 (omit it to run all)"));
    }
    let _lock = BatchLock::exclusive(&cfg.out)?;
    open_manifest(cfg)?;
    let (mut journal, opened) = Journal::open(&cfg.out.join(JOURNAL))?;
    let integrity = verify(&cfg.out, &cfg.spec, cfg.shard, &opened.records);
    void_findings(&integrity, &mut journal)?;
    let mut state = replay_journal(&opened.records, &integrity);
    let mut session = Session {
        resumed: state.done.len() as u64,
        torn_saved_to: opened.torn_saved_to,
        found: integrity.findings,
        ..Default::default()
    };
    let owned = |i: &u64| cfg.shard.owns(*i);
    let unfinished: BTreeMap<u64, u32> = (0..cfg.spec.trials)
        .filter(|i| owned(i) && !state.done.contains_key(i))
        .map(|i| (i, state.next_attempt.get(&i).copied().unwrap_or(1)))
        .collect();
    session.discarded = leftovers::set_aside(
        &cfg.out,
        &unfinished,
        cfg.spec.policy.max_attempts,
        &opened.records,
        &mut journal,
    )?;
    let mut sup = Supervisor::new(factory)?;
    let plans = Arc::new(cfg.plans.clone());
    let total = (0..cfg.spec.trials).filter(owned).count() as u64;
    let count_ok = |s: &State| s.done.values().filter(|v| **v == TrialVerdict::Inserted).count();
    let mut progress = BatchProgress {
        done: session.resumed,
        total,
        succeeded: count_ok(&state) as u64,
        resumed: session.resumed,
    };
    on_progress(&progress);
    let take = cfg.max_trials.map_or(usize::MAX, |m| usize::try_from(m).unwrap_or(usize::MAX));
    cfg.space.before_start(&cfg.out, unfinished.len().min(take) as u64)?;
    for (&index, &first) in unfinished.iter().take(take) {
        if let Some(why) = cfg.space.before_trial(&cfg.out)? {
            session.stopped = Some(format!("stopped before {}: {why}", trial_id(index)));
            break;
        }
        let verdict = run_trial(cfg, &mut sup, &mut journal, &plans, index, first)?;
        state.done.insert(index, verdict);
        session.ran += 1;
        progress.done += 1;
        progress.succeeded += u64::from(verdict == TrialVerdict::Inserted);
        on_progress(&progress);
    }
    session.restarts = sup.restarts;
    session.elapsed_s = t0.elapsed().as_secs_f64();
    Ok(session)
}

/// The checksum recorded with a final record: the directory's, unless a runner abandoned
/// or cancelled after its budget may still be writing into it.
fn final_checksum(
    abs: &Path,
    verdict: TrialVerdict,
    abandoned: bool,
) -> Result<DirChecksum, Error> {
    if abandoned || verdict == TrialVerdict::Timeout {
        return Ok(DirChecksum::Unsettled { present: abs.exists() });
    }
    digest::of_dir(abs)
}

/// Runs the attempts of one trial from attempt `first`; returns its final verdict.
fn run_trial(
    cfg: &BatchConfig,
    sup: &mut Supervisor,
    journal: &mut Journal,
    plans: &Arc<Vec<Plan>>,
    index: u64,
    first: u32,
) -> Result<TrialVerdict, Error> {
    let policy = &cfg.spec.policy;
    let seed = trial_seed(cfg.spec.seed, index);
    let start = peg_start(&cfg.spec, plans, seed);
    let timeout = Duration::from_secs_f64(policy.timeout_s);
    let grace = Duration::from_secs_f64(policy.grace_s);
    let mut attempt = first;
    loop {
        let dir = attempt_dir(index, attempt);
        journal.append(&Record::Begin { index, attempt, dir: dir.clone() })?;
        let t0 = Instant::now();
        let job = TrialJob {
            index,
            trial_id: trial_id(index),
            attempt,
            trial_seed: seed,
            attempt_seed: attempt_seed(seed, attempt),
            peg_start: start,
            plans: Arc::clone(plans),
        };
        let abs = cfg.out.join(&dir);
        let result: TrialResult = sup.attempt(&job, &abs, timeout, grace)?;
        let result = check::against_log(&abs, result);
        let verdict = result.verdict;
        let rec = AttemptRecord {
            index,
            trial_id: job.trial_id,
            attempt,
            trial_seed: seed,
            attempt_seed: job.attempt_seed,
            runner: sup.name().into(),
            peg_start: start,
            dir,
            result,
            wall_time_s: t0.elapsed().as_secs_f64(),
            checksum: None,
        };
        if policy.retry_on.contains(&verdict) && attempt < policy.max_attempts {
            journal.append(&Record::Attempt(rec))?;
            attempt += 1;
            continue;
        }
        let checksum = final_checksum(&abs, verdict, sup.abandoned_last)?;
        journal.append(&Record::Trial(AttemptRecord { checksum: Some(checksum), ..rec }))?;
        return Ok(verdict);
    }
}
