//! Criterion benches of what a diagnosis spends its time on: one evaluation of a model, i.e.
//! the replay of a trial from its restart frames (`predict`, not memoised) and the noise-
//! weighted loss over a batch for a model not seen before (every fit evaluation that misses
//! the memo) or seen just before (a hit). The whole diagnosis is timed as a process
//! (`mesopush diagnose run`, see docs/diagnose.md); these show where a change of the replay
//! or of the residual goes.
//!
//! Run: `cargo bench -p mesopush-diagnose --bench diagnose`.

use criterion::{Criterion, criterion_group, criterion_main};
use mesopush_diagnose::data::TrialData;
use mesopush_diagnose::objective::loss;
use mesopush_diagnose::predict::predict;
use mesopush_diagnose::residual::Noise;
use mesopush_diagnose::synth::write_batch;
use mesopush_diagnose::{Effect, Options};
use mesopush_sim::{Model, SimSettings};
use std::hint::black_box;

/// A synthetic clean batch of three trials of three strokes each (seed 1).
fn batch() -> Vec<TrialData> {
    let dir = tempfile::tempdir().expect("temporary directory");
    let dirs = write_batch(dir.path(), Effect::Nominal, 3, 3, 1).expect("synthetic batch");
    dirs.iter().enumerate().map(|(i, d)| TrialData::load(d, i).expect("trial loads")).collect()
}

fn evaluation(c: &mut Criterion) {
    let trials = batch();
    let settings = SimSettings::default();
    let model = Model::default();
    let noise = Noise::estimate(&trials);
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(20);
    g.bench_function("predict_one_trial", |b| {
        b.iter(|| black_box(predict(&trials[0], &model, &settings).expect("replays")))
    });
    // The same replay at diagnosis's Newton tolerance (`Options::default().settings`), side
    // by side with the simulator's default above.
    let loose = Options::default().settings;
    g.bench_function("predict_one_trial_diagnosis_newton_tol", |b| {
        b.iter(|| black_box(predict(&trials[0], &model, &loose).expect("replays")))
    });
    // A new μ_probe at every iteration: the memo never holds the answer.
    let mut k = 0u32;
    g.bench_function("loss_three_trials_new_model", |b| {
        b.iter(|| {
            k += 1;
            let m = Model { mu_probe: 0.5 + 1e-9 * f64::from(k), ..model.clone() };
            black_box(loss(&trials, &m, &settings, &noise))
        })
    });
    g.bench_function("loss_three_trials_same_model", |b| {
        b.iter(|| black_box(loss(&trials, &model, &settings, &noise)))
    });
    g.finish();
}

criterion_group!(benches, evaluation);
criterion_main!(benches);
