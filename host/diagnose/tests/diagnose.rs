//! Blind diagnosis of synthetic batches: each batch carries one undeclared library effect at a
//! realistic size (or none); `diagnose` must name it and lower the held-out error, and find
//! nothing on clean data. CI-sized: few short trials, small fit budgets.

use mesopush_diagnose::synth::{SynthNoise, realistic_effect, true_nominal, write_trial};
use mesopush_diagnose::{Effect, Options, TrialData, Verdict, diagnose};
use rand::SeedableRng;

fn batch(
    effect: Effect,
    seed: u64,
    n: usize,
    strokes: usize,
) -> (tempfile::TempDir, Vec<TrialData>) {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut truth = true_nominal(&mut rng);
    truth.effects = realistic_effect(effect, &mut rng);
    let trials = write_batch(dir.path(), &truth, n, strokes, |i| seed * 100 + i as u64);
    (dir, trials)
}

/// Writes `n` synthetic trials of `truth` under `dir` (trial `i` seeded `noise_seed(i)`) and
/// loads them back.
fn write_batch(
    dir: &std::path::Path,
    truth: &mesopush_sim::Model,
    n: usize,
    strokes: usize,
    noise_seed: impl Fn(usize) -> u64,
) -> Vec<TrialData> {
    (0..n)
        .map(|i| {
            let id = format!("trial-{i:03}");
            let d = dir.join(&id);
            write_trial(&d, &id, i, truth, strokes, &SynthNoise::default(), noise_seed(i))
                .unwrap_or_else(|e| panic!("trial {i}: {e}"));
            TrialData::load(&d, i).unwrap()
        })
        .collect()
}

/// Blind diagnosis with even trials training and odd ones held out.
fn diagnose_split(trials: Vec<TrialData>, opts: &Options) -> mesopush_diagnose::Diagnosis {
    let (train, test): (Vec<_>, Vec<_>) = trials.into_iter().partition(|t| t.index % 2 == 0);
    diagnose(&train, &test, opts, &|_| {}).unwrap()
}

fn run(effect: Effect, seed: u64) -> mesopush_diagnose::Diagnosis {
    let (_d, trials) = batch(effect, seed, 6, 3);
    let opts = Options {
        nominal_evals: 300,
        effect_evals: 150,
        candidates: vec![Effect::Backlash, Effect::Latency, Effect::Scale],
        ..Options::default()
    };
    let d = diagnose_split(trials, &opts);
    eprintln!("seed {seed} {effect:?}: {:?} {:?}", d.verdict, d.effect);
    for s in &d.scores {
        eprintln!(
            "  {:?} bic {:.0} held-out {:.1} {:?}",
            s.candidate, s.bic, s.heldout_norm, s.params
        );
    }
    d
}

#[test]
fn latency_is_named_and_clean_data_gives_none() {
    let d = run(Effect::Latency, 7);
    assert_eq!(d.effect, Some(Effect::Latency));
    per_trial_norms_make_up_the_heldout_norm(&d);
    let d = run(Effect::Nominal, 8);
    assert_eq!(d.verdict, Verdict::None);
}

/// Every candidate reports each held-out trial's error alone, the pooled held-out error lies
/// between them, and the nominal's are its held-out residuals' own, trial by trial.
fn per_trial_norms_make_up_the_heldout_norm(d: &mesopush_diagnose::Diagnosis) {
    use mesopush_diagnose::residual::Mse;
    for s in &d.scores {
        let e = &s.heldout_per_trial_norm;
        assert_eq!(e.len(), d.heldout.len(), "{:?}", s.candidate);
        let (lo, hi) = e.iter().fold((f64::INFINITY, 0.0f64), |(l, h), x| (l.min(*x), h.max(*x)));
        assert!(lo <= s.heldout_norm && s.heldout_norm <= hi, "{:?}: {e:?}", s.candidate);
    }
    let nominal = &d.scores[0].heldout_per_trial_norm;
    for (r, e) in d.residuals.0.iter().zip(nominal) {
        let own = Mse::of(std::slice::from_ref(r)).normalised(&d.noise, true);
        assert!((own - e).abs() <= 1e-12 * own, "{own} against {e}");
    }
}

/// Multiple shooting loses nothing when the model is right: a noise-free trial of 3 strokes,
/// replayed with restarts from its measured poses, matches the open-loop replay that made
/// it; and the replay restarts between strokes (not only at frame 0).
#[test]
fn restarts_from_the_resting_peg_reproduce_a_noise_free_trial() {
    use mesopush_diagnose::predict::{predict, restart_frames, tip_path};
    let seed = 21;
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = true_nominal(&mut rng);
    let quiet = SynthNoise { xy_um: 0.0, theta_rad: 0.0, tip_um: 0.0 };
    let d = dir.path().join("trial-00");
    write_trial(&d, "trial-00", 0, &truth, 3, &quiet, seed).unwrap();
    let t = TrialData::load(&d, 0).unwrap();
    let path = tip_path(&truth.effects, &t.cmd);
    let (starts, _) = restart_frames(&t, &path, truth.part.polygon());
    assert!(starts.len() >= 3, "seed {seed}: restarts at {starts:?}");
    let p = predict(&t, &truth, &mesopush_sim::SimSettings::default()).unwrap();
    for (k, (m, q)) in t.frames.iter().zip(&p.poses).enumerate() {
        let e = (m.pose.position() - q.position()).norm();
        assert!(e < 0.2, "seed {seed}: frame {k} off by {e} µm");
    }
}

/// The patch search must not depend on where the generator of `--confusion` puts its patch
/// (the right or lower part of the workspace, 2–3× grippier): a *slipperier* patch over the
/// *left* part of the plate (x < 1650 µm, μ 0.12 against the plate's 0.3) is named too and
/// explains most of the held-out error.
#[test]
fn a_slippery_patch_on_the_other_side_is_named() {
    use mesopush_diagnose::residual::Mse;
    use mesopush_sim::effects::FrictionPatch;
    let seed = 31;
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut truth = true_nominal(&mut rng);
    truth.effects.friction_patch =
        Some(FrictionPatch { min_um: [-1e4, -1e4], max_um: [1650.0, 1e4], mu_surface: 0.12 });
    let trials = write_batch(dir.path(), &truth, 6, 3, |i| seed * 100 + i as u64);
    let opts = Options {
        nominal_evals: 150,
        effect_evals: 80,
        candidates: vec![Effect::FrictionPatch, Effect::SupportDrift],
        ..Options::default()
    };
    let d = diagnose_split(trials, &opts);
    let (before, after) = (Mse::of(&d.residuals.0), Mse::of(&d.residuals.1));
    for s in &d.scores {
        eprintln!("seed {seed}: {:?} held-out {:.1} {:?}", s.candidate, s.heldout_norm, s.params);
    }
    assert_eq!(d.effect, Some(Effect::FrictionPatch), "seed {seed}: {:?}", d.verdict);
    assert!(after.xy_um2 < 0.3 * before.xy_um2, "seed {seed}: {before:?} -> {after:?}");
}

/// A small support drift whose nominal model, refitted on all six trials, reaches the floor
/// band: the adequacy rule alone would call it `none`, a missed effect; the drift refitted on
/// all six trials lowers that error, so it is named. Found as seed 12 of the confusion run
/// with the paper's polygonal cone (10.8 noise units against 15); with the exact cone seed 12
/// is no longer small (20.3 units, named anyway) and seed 15 is the first of 13–16 in this
/// regime (11.6 units; seeds 13 and 14: 53 and 134 units).
#[test]
fn a_small_support_drift_survives_the_all_trial_refit() {
    let seed = 15;
    let n = 6;
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = mesopush_diagnose::synth::batch_truth(Effect::SupportDrift, n, &mut rng);
    let trials = write_batch(dir.path(), &truth, n, 3, |i| seed * 1000 + i as u64);
    let opts = Options {
        nominal_evals: 150,
        effect_evals: 80,
        candidates: vec![Effect::SupportDrift, Effect::Scale],
        ..Options::default()
    };
    let d = diagnose_split(trials, &opts);
    eprintln!(
        "seed {seed}: {:?} {:?}, nominal on all {:?}, winner on all {:?}",
        d.verdict, d.effect, d.nominal_all_norm, d.effect_all_norm
    );
    let all = d.nominal_all_norm.expect("held-out error above the floor band");
    assert!(all <= d.floor_band, "seed {seed}: the nominal refit on all trials is in the band");
    assert_eq!(d.effect, Some(Effect::SupportDrift), "seed {seed}: {:?}", d.verdict);
}
