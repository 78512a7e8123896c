//! Criterion benches of the simulator: one whole Table II replay on the reconstructed fixture
//! with the nominal model (the `mesopush sim --bench` figures, measured by criterion).

use criterion::{Criterion, criterion_group, criterion_main};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use std::hint::black_box;

fn table2(c: &mut Criterion) {
    let plan = Plan::table2();
    let mut sim = Simulator::new(Model::default(), Fixture::paper(), SimSettings::default())
        .expect("nominal model and fixture are valid");
    c.bench_function("table2_replay", |b| {
        b.iter(|| black_box(replay(&mut sim, &plan, None).expect("replay runs")))
    });
}

criterion_group!(benches, table2);
criterion_main!(benches);
