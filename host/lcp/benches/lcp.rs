//! Criterion benchmarks of the complementarity solver: the simulator's 31-variable step LCPs
//! (3 free + 31 complementarity, 50 seeded problems, one solve per iteration, cycling), steps
//! with fixture contacts, warm-started next steps, and files of the Siconos suite.
//!
//! Run: `cargo bench -p mesopush-lcp --bench lcp`.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use mesopush_lcp::{LcpSettings, LcpSolver, generate, siconos};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn steps(fixtures: usize, count: u64) -> Vec<generate::StepLcp> {
    (0..count)
        .map(|seed| generate::random_step(&mut ChaCha8Rng::seed_from_u64(seed), fixtures))
        .collect()
}

fn bench_steps(c: &mut Criterion) {
    for (name, fixtures) in [("step_probe_only_n34", 0), ("step_3_fixtures_n46", 3)] {
        let problems = steps(fixtures, 50);
        let mut solver = LcpSolver::new(problems[0].n, LcpSettings::default());
        let mut k = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                let p = &problems[k % problems.len()];
                k += 1;
                black_box(solver.solve(&p.problem()).map(|s| s.pivots).ok())
            })
        });
    }
}

/// Warm start as the simulator would use it: the next step (probe pushed 3 % further) with
/// the previous step's active set as the guess.
fn bench_warm(c: &mut Criterion) {
    let problems = steps(0, 50);
    let mut solver = LcpSolver::new(34, LcpSettings::default());
    let cases: Vec<(generate::StepLcp, Vec<bool>)> = problems
        .iter()
        .filter_map(|p| {
            let active = solver.solve(&p.problem()).ok()?.active.to_vec();
            let mut next = p.clone();
            next.q[3] *= 1.03;
            Some((next, active))
        })
        .collect();
    let mut k = 0;
    c.bench_function("step_probe_only_n34_warm_next_step", |b| {
        b.iter(|| {
            let (p, active) = &cases[k % cases.len()];
            k += 1;
            black_box(solver.solve_warm(&p.problem(), active).map(|s| s.pivots).ok())
        })
    });
}

fn bench_suite(c: &mut Criterion) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/lcp-suite/lcp");
    for file in ["lcp_tobenna.dat", "lcp_mmc.dat", "lcp_CPS_3.dat"] {
        let Ok(lcp) = siconos::read(&dir.join(file)) else {
            eprintln!("skipping {file}: suite not found beside the checkout");
            continue;
        };
        let mut solver = LcpSolver::new(lcp.n, LcpSettings::default());
        c.bench_function(&format!("suite/{file}"), |b| {
            b.iter(|| black_box(solver.solve(&lcp.problem()).map(|s| s.pivots).ok()))
        });
    }
}

criterion_group!(benches, bench_steps, bench_warm, bench_suite);
criterion_main!(benches);
