//! Blind diagnosis of full-loop trial logs: batches run through the whole loop
//! (`diagnose::rig_batch`: executor, pty, firmware simulator, rendered camera, tracker, in
//! simulated time) in a world carrying one undeclared effect, and a clean control. The
//! frames are rendered and tracked, the time base is the executor's: none of it comes from
//! the synthetic generator diagnosis was tuned on. Every library candidate is tried.

use mesopush_diagnose::rig_batch::write_rig_batch;
use mesopush_diagnose::{Diagnosis, Effect, Options, TrialData, Verdict, diagnose};
use mesopush_rig::WorldFile;

/// The default world filming every `period_us` (the tracker runs on every frame), with
/// `effects`.
fn world_at(period_us: u64, effects: &str) -> WorldFile {
    let text = format!(
        "name = \"diagnose rig test\"\n[camera]\nperiod_us = {period_us}\n[effects]\n{effects}\n"
    );
    WorldFile::from_toml(&text, None).expect("test world")
}

fn run(effects: &str, seed: u64) -> Diagnosis {
    run_in(&world_at(100_000, effects), effects, seed)
}

fn run_in(world: &WorldFile, effects: &str, seed: u64) -> Diagnosis {
    let dir = tempfile::tempdir().unwrap();
    let dirs =
        write_rig_batch(dir.path(), world, 4, seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
    let trials: Vec<TrialData> =
        dirs.iter().enumerate().map(|(i, d)| TrialData::load(d, i).unwrap()).collect();
    let (train, test): (Vec<_>, Vec<_>) = trials.into_iter().partition(|t| t.index % 2 == 0);
    let opts = Options { nominal_evals: 150, effect_evals: 60, ..Options::default() };
    let d = diagnose(&train, &test, &opts, &|_| {}).unwrap();
    eprintln!("seed {seed} [{effects}]: {:?} {:?}, floor {:?}", d.verdict, d.effect, d.noise);
    for s in &d.scores {
        eprintln!(
            "  {:?} bic {:.0} held-out {:.1} {:?}",
            s.candidate, s.bic, s.heldout_norm, s.params
        );
    }
    d
}

#[test]
fn latency_in_a_full_loop_batch_is_named_blind_and_the_clean_batch_gives_none() {
    let seed = 5;
    let d = run("camera_latency_us = 60000.0", seed);
    assert_eq!(d.effect, Some(Effect::Latency), "seed {seed}");
    let (before, after) = (&d.scores[0].heldout, &d.best);
    let after = d.scores.iter().find(|s| s.candidate == after.candidate).unwrap().heldout;
    assert!(after.xy_um2 < 0.5 * before.xy_um2, "seed {seed}: {before:?} → {after:?}");
    let lat = d.best.values[4];
    assert!((lat - 60e3).abs() < 15e3, "seed {seed}: fitted latency {lat} µs");
    let clean = run("", seed);
    assert_eq!(clean.verdict, Verdict::None, "seed {seed}");
}

/// Caught by the first full-loop backlash batch (12 µm, seed 6): it was attributed to
/// adhesion. No candidate comes near the floor on its held-out trials (two x-only training
/// pushes identify the nominal parameters poorly), so the honest verdicts are backlash or
/// `unexplained` — never another effect.
#[test]
fn a_full_loop_backlash_batch_is_not_misattributed() {
    let seed = 6;
    let d = run("backlash_um = [12.0, 12.0]", seed);
    assert_ne!(d.verdict, Verdict::None, "seed {seed}: a 12 µm backlash is not at the floor");
    assert!(
        d.verdict == Verdict::Unexplained || d.effect == Some(Effect::Backlash),
        "seed {seed}: {:?} {:?}",
        d.verdict,
        d.effect
    );
}

/// Caught by the 30 Hz clean controls of the shipped-world sweep: seed 6 named a friction
/// patch (a false alarm) and seeds 5 and 7 read `unexplained`. The world lost up to 5 µm of
/// each push at a reversal (fixed in `rig::world`), the tracker's touching and nearly
/// touching tips were read as a bending needle (`diagnose::tip`), and two training pushes
/// left the support's place 40 µm loose, which the all-trial refit now tells from a missing
/// effect (`diagnose::adequacy`).
#[test]
fn a_clean_30_hz_batch_is_not_read_as_a_friction_patch() {
    let seed = 6;
    let d = run_in(&world_at(33_333, ""), "clean, 30 Hz", seed);
    assert_eq!(d.verdict, Verdict::None, "seed {seed}: {:?}", d.effect);
}
