//! Classic LCPs with known answers, degenerate and infeasible ones, planted random problems
//! (P-matrix and PSD classes, seeded), mixed problems and bad input.

mod lcp_common;

use lcp_common::{p_matrix, plant, psd_matrix, residual};
use mesopush_lcp::{Error, LcpSettings, LcpSolver, MlcpProblem, SolveMethod};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn lcp<'a>(m: &'a [f64], q: &'a [f64]) -> MlcpProblem<'a> {
    MlcpProblem { n_free: 0, n: q.len(), m, q }
}

/// Murty's example: `M` upper triangular, 1 on the diagonal and 2 above;
/// `q_i = −(2^{n+1} − 2^i)` (i from 1). Unique solution `z = (0, …, 0, 2ⁿ)`.
fn murty(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        m[i * n + i] = 1.0;
        for j in i + 1..n {
            m[i * n + j] = 2.0;
        }
    }
    let q = (1..=n).map(|i| -((1u64 << (n + 1)) as f64 - (1u64 << i) as f64)).collect();
    (m, q)
}

#[test]
fn murty_takes_exactly_two_to_the_n_pivots() {
    for n in [1usize, 3, 6, 10, 13] {
        let (m, q) = murty(n);
        let mut solver = LcpSolver::new(n, LcpSettings::default());
        let sol = solver.solve(&lcp(&m, &q)).unwrap_or_else(|e| panic!("n = {n}: {e}"));
        assert_eq!(sol.method, SolveMethod::Lemke, "n = {n}");
        // 2ⁿ − 1 pivots along the path plus the one that brings z0 in.
        assert_eq!(sol.pivots, 1 << n, "n = {n}");
        let mut want = vec![0.0; n];
        want[n - 1] = (1u64 << n) as f64;
        assert_eq!(sol.z, &want[..], "n = {n}");
    }
}

#[test]
fn pivot_limit_is_reported_and_each_fallback_rescues_on_its_own() {
    let (m, q) = murty(10);
    let lemke_only = LcpSettings {
        max_pivots: 100,
        retries: 0,
        enumerate_max_n: 0,
        newton_iterations: 0,
        ..Default::default()
    };
    let mut solver = LcpSolver::new(10, lemke_only);
    match solver.solve(&lcp(&m, &q)) {
        Err(Error::PivotLimit { pivots, n }) => assert_eq!((pivots, n), (100, 10)),
        other => panic!("expected PivotLimit, got {other:?}"),
    }
    for (settings, method) in [
        (LcpSettings { enumerate_max_n: 16, ..lemke_only }, SolveMethod::Enumeration),
        (LcpSettings { newton_iterations: 100, ..lemke_only }, SolveMethod::Newton),
    ] {
        solver.set_settings(settings);
        let sol = solver.solve(&lcp(&m, &q)).unwrap_or_else(|e| panic!("{method:?}: {e}"));
        assert_eq!(sol.method, method);
        assert_eq!(sol.z[9], 1024.0, "{method:?}");
    }
}

#[test]
fn degenerate_problem_with_a_continuum_of_solutions() {
    // CPS 2009, Remark 4.1.14: every z ≥ 0 with z₁ + z₂ = 1 solves it.
    let (m, q) = ([1.0, 1.0, 1.0, 1.0], [-1.0, -1.0]);
    let mut solver = LcpSolver::new(2, LcpSettings::default());
    let sol = solver.solve(&lcp(&m, &q)).unwrap();
    assert!((sol.z[0] + sol.z[1] - 1.0).abs() < 1e-12, "{:?}", sol.z);
    assert!(residual(0, &m, &q, sol.z) < 1e-12);
}

#[test]
fn fully_degenerate_q_zero_rows_do_not_cycle() {
    // Many zero entries in q and repeated rows: every ratio test ties. Solution exists
    // (z = (1/3, 1/3, 1/3, 0, 0)-like points); the lexicographic rule must terminate.
    let m = [
        1.0, 1.0, 1.0, -1.0, 0.0, //
        1.0, 1.0, 1.0, 0.0, -1.0, //
        1.0, 1.0, 1.0, -1.0, -1.0, //
        1.0, 0.0, 1.0, 0.0, 0.0, //
        0.0, 1.0, 1.0, 0.0, 0.0,
    ];
    let q = [0.0, 0.0, 0.0, -1.0, -1.0];
    let mut solver = LcpSolver::new(5, LcpSettings { enumerate_max_n: 0, ..Default::default() });
    let sol = solver.solve(&lcp(&m, &q)).unwrap();
    assert!(residual(0, &m, &q, sol.z) < 1e-12, "{:?}", sol.z);
}

#[test]
fn infeasible_problems_fail_honestly() {
    // w = −z − 1 ≥ 0 is impossible for z ≥ 0.
    let mut solver = LcpSolver::new(3, LcpSettings::default());
    match solver.solve(&lcp(&[-1.0], &[-1.0])) {
        Err(Error::NoSolutionFound { bases, .. }) => assert_eq!(bases, 2),
        other => panic!("expected NoSolutionFound, got {other:?}"),
    }
    solver.set_settings(LcpSettings { enumerate_max_n: 0, ..Default::default() });
    let (m, q) = ([0.0, -1.0, -1.0, 0.0], [-1.0, 1.0]);
    assert!(matches!(solver.solve(&lcp(&m, &q)), Err(Error::SecondaryRay { .. })));
}

#[test]
fn p_matrix_planted_solutions_are_found_exactly() {
    let mut solver = LcpSolver::new(4, LcpSettings::default());
    for seed in 0..400u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 2 + (seed as usize % 40);
        let m = p_matrix(&mut rng, n);
        let (z_star, q) = plant(&mut rng, &m, n, seed % 2 == 0);
        let sol = solver.solve(&lcp(&m, &q)).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        // P-matrix: the solution is unique, so it must be the planted one.
        for (i, (a, b)) in sol.z.iter().zip(&z_star).enumerate() {
            assert!((a - b).abs() <= 1e-7 * (1.0 + b.abs()), "seed {seed}: z[{i}] {a} vs {b}");
        }
        assert!(residual(0, &m, &q, sol.z) < 1e-9, "seed {seed}");
    }
}

#[test]
fn psd_planted_problems_are_solved_and_verified() {
    let mut solver = LcpSolver::new(4, LcpSettings { enumerate_max_n: 0, ..Default::default() });
    for seed in 0..400u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
        let n = 2 + (seed as usize % 40);
        let rank = 1 + (seed as usize % n);
        let m = psd_matrix(&mut rng, n, rank);
        let (_, q) = plant(&mut rng, &m, n, seed % 3 == 0);
        // PSD is copositive-plus and the LCP is feasible: Lemke alone must solve it.
        let sol = solver.solve(&lcp(&m, &q)).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert_eq!(sol.method, SolveMethod::Lemke, "seed {seed}");
        let r = residual(0, &m, &q, sol.z);
        assert!(r < 1e-9, "seed {seed}: residual {r:e}");
    }
}

#[test]
fn mixed_problem_with_invertible_free_block() {
    // Free block 2×2 nonsingular, coupled to a 3-variable P-matrix part.
    for seed in 0..200u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(7000 + seed);
        let n = 5;
        let m = p_matrix(&mut rng, n);
        let (mut z_star, _) = plant(&mut rng, &m, n, false);
        // The first two variables are free, one of them negative; w = 0 on their rows, and
        // w = 0.5 where the planted z is zero.
        z_star[0] = -1.5;
        z_star[1] = 0.7;
        let q: Vec<f64> = (0..n)
            .map(|i| {
                let mz: f64 = (0..n).map(|j| m[i * n + j] * z_star[j]).sum();
                let w = if i >= 2 && z_star[i] == 0.0 { 0.5 } else { 0.0 };
                w - mz
            })
            .collect();
        let p = MlcpProblem { n_free: 2, n, m: &m, q: &q };
        let mut solver = LcpSolver::new(n, LcpSettings::default());
        let sol = solver.solve(&p).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        // The P-matrix part makes the answer unique.
        assert!(residual(2, &m, &q, sol.z) < 1e-9, "seed {seed}");
        assert!((sol.z[0] + 1.5).abs() < 1e-8 && (sol.z[1] - 0.7).abs() < 1e-8, "seed {seed}");
    }
}

#[test]
fn singular_equalities_are_a_typed_failure() {
    // One free variable whose equality row and column are zero: no way to pin it.
    let m = [0.0, 0.0, 0.0, 1.0];
    let q = [0.0, -1.0];
    let mut solver = LcpSolver::new(2, LcpSettings::default());
    let err = solver.solve(&MlcpProblem { n_free: 1, n: 2, m: &m, q: &q }).unwrap_err();
    assert_eq!(err, Error::SingularEqualities { n_free: 1 });
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let mut solver = LcpSolver::new(2, LcpSettings::default());
    let cases: [(MlcpProblem<'_>, &str); 4] = [
        (MlcpProblem { n_free: 3, n: 2, m: &[0.0; 4], q: &[0.0; 2] }, "n_free"),
        (MlcpProblem { n_free: 0, n: 2, m: &[0.0; 3], q: &[0.0; 2] }, "M has 3"),
        (MlcpProblem { n_free: 0, n: 2, m: &[0.0; 4], q: &[0.0; 1] }, "q has 1"),
        (MlcpProblem { n_free: 0, n: 2, m: &[0.0, f64::NAN, 0.0, 0.0], q: &[0.0; 2] }, "M[0][1]"),
    ];
    for (p, want) in cases {
        match solver.solve(&p) {
            Err(Error::BadInput(msg)) => assert!(msg.contains(want), "{msg}"),
            other => panic!("expected BadInput({want}), got {other:?}"),
        }
    }
    // Non-finite values anywhere, including the tail the solver's lane-wise check ends on.
    let mut m = vec![1.0; 9];
    m[8] = f64::INFINITY;
    let err = solver.solve(&lcp(&m, &[0.0; 3])).unwrap_err();
    assert!(matches!(&err, Error::BadInput(msg) if msg.contains("M[2][2]")), "{err}");
    let err = solver.solve(&lcp(&[1.0; 9], &[0.0, 0.0, f64::NAN])).unwrap_err();
    assert!(matches!(&err, Error::BadInput(msg) if msg.contains("q[2]")), "{err}");
    solver.set_settings(LcpSettings { tol: f64::NAN, ..Default::default() });
    assert!(matches!(solver.solve(&lcp(&[1.0], &[1.0])), Err(Error::BadInput(_))));
}

#[test]
fn solver_grows_beyond_its_capacity_and_repeats_bit_identically() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let m = p_matrix(&mut rng, 30);
    let (_, q) = plant(&mut rng, &m, 30, true);
    let mut solver = LcpSolver::new(2, LcpSettings::default());
    let first = solver.solve(&lcp(&m, &q)).unwrap().z.to_vec();
    let _ = solver.solve(&lcp(&[1.0], &[-1.0])).unwrap();
    let again = solver.solve(&lcp(&m, &q)).unwrap().z.to_vec();
    assert_eq!(first, again);
    let empty = solver.solve(&lcp(&[], &[])).unwrap();
    assert!(empty.z.is_empty());
}

#[test]
fn only_free_variables_is_a_linear_solve() {
    // 2u₀ + u₁ = 1, u₀ + 3u₁ = 2  →  u = (0.2, 0.6).
    let (m, q) = ([2.0, 1.0, 1.0, 3.0], [-1.0, -2.0]);
    let mut solver = LcpSolver::new(2, LcpSettings::default());
    let sol = solver.solve(&MlcpProblem { n_free: 2, n: 2, m: &m, q: &q }).unwrap();
    assert!((sol.z[0] - 0.2).abs() < 1e-12 && (sol.z[1] - 0.6).abs() < 1e-12, "{:?}", sol.z);
    let singular = [1.0, 2.0, 2.0, 4.0];
    let err = solver.solve(&MlcpProblem { n_free: 2, n: 2, m: &singular, q: &q }).unwrap_err();
    assert_eq!(err, Error::SingularEqualities { n_free: 2 });
}
