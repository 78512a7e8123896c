//! Criterion benches of the planner: one RRT search (seed 2, the planning tests' seed) on the
//! reconstructed fixture, one Monte Carlo estimate of Table II on 64 worlds (both cores), and
//! one raced CEM generation of the robust design. Speed figures live here and in
//! docs/planning.md, never in timed test assertions.

use criterion::{Criterion, criterion_group, criterion_main};
use mesopush_plan::{
    MonteCarlo, RobustSettings, RrtSettings, Skeleton, Table2Family, UncertainWorld, Uncertainty,
    design_robust, plan_rrt,
};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator};
use rand::SeedableRng;
use std::hint::black_box;

fn rrt(c: &mut Criterion) {
    let mut sim = Simulator::new(Model::default(), Fixture::paper(), SimSettings::default())
        .expect("nominal model and fixture are valid");
    let start = Plan::table2().peg_start_pose();
    let settings = RrtSettings { max_iterations: 300, ..Default::default() };
    let mut g = c.benchmark_group("plan");
    g.sample_size(10);
    g.bench_function("rrt_seed2", |b| {
        b.iter(|| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
            black_box(plan_rrt(&mut sim, start, &settings, &mut rng, &mut |_| true).expect("rrt"))
        })
    });
    let (model, fixture, sim_settings) =
        (Model::default(), Fixture::paper(), SimSettings::default());
    let plan = Plan::table2();
    let mc = MonteCarlo {
        plan: &plan,
        model: &model,
        fixture: &fixture,
        settings: &sim_settings,
        uncertainty: Uncertainty::default(),
        supports: &[],
    };
    g.bench_function("montecarlo_table2_64", |b| {
        b.iter(|| black_box(mc.estimate(64, 11, &|| ()).expect("estimate")))
    });
    let world = UncertainWorld::nominal(&model, &fixture, &sim_settings);
    let rs = RobustSettings { generations: 1, validation_samples: 0, ..Default::default() };
    g.bench_function("robust_one_generation", |b| {
        b.iter(|| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
            let start = Plan::table2().peg_start;
            let t2 = Skeleton::table2_like().params;
            let f = &Table2Family;
            black_box(
                design_robust(&world, start, f, &t2, &rs, &mut rng, &mut |_, _| true).expect("cem"),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, rrt);
criterion_main!(benches);
