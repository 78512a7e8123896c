//! The simulator's step problems (paper Eq. 7–8) from the seeded generator: every probe-only
//! step has a physical answer, so the solver must solve all of them; with fixture contacts a
//! step can jam (no answer exists), so there every answer must verify and every failure must
//! be an honest one.

mod lcp_common;

use lcp_common::residual;
use mesopush_lcp::{Error, LcpSettings, LcpSolver, generate};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn every_probe_only_step_is_solved_and_verified() {
    let mut solver = LcpSolver::new(34, LcpSettings::default());
    let mut max_pivots = 0;
    for seed in 0..2000u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let step = generate::random_step(&mut rng, 0);
        assert_eq!((step.n, step.n_free), (34, 3));
        let sol = solver.solve(&step.problem()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let r = residual(3, &step.m, &step.q, sol.z);
        assert!(r < 1e-9, "seed {seed}: independent residual {r:e}");
        // The probe pushes inward (its gap row starts negative), so it must carry load.
        assert!(sol.z[3] > 0.0, "seed {seed}: probe force {}", sol.z[3]);
        max_pivots = max_pivots.max(sol.pivots);
    }
    println!("2000 probe-only steps solved, at most {max_pivots} pivots");
}

/// Whether some peg motion `Δq` keeps every planar contact's gap row `≥ 0` (rows 3..3+nc
/// of `M`, columns `Δq`): a 3-variable LP, decided by enumerating the vertices of the
/// feasible set cut by a large box. If not, the step is geometrically jammed: no LCP
/// solution can exist, whatever the forces.
fn kinematically_feasible(step: &generate::StepLcp, contacts: usize) -> bool {
    let n = step.n;
    let mut rows: Vec<([f64; 3], f64)> = (3..3 + contacts)
        .map(|i| ([step.m[i * n], step.m[i * n + 1], step.m[i * n + 2]], -step.q[i]))
        .collect();
    for k in 0..3 {
        for sign in [1.0, -1.0] {
            let mut a = [0.0; 3];
            a[k] = sign;
            rows.push((a, -1e4));
        }
    }
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let m = rows.len();
    for i in 0..m {
        for j in i + 1..m {
            for k in j + 1..m {
                let a = [rows[i].0, rows[j].0, rows[k].0];
                let d = det(a);
                if d.abs() < 1e-12 {
                    continue;
                }
                let b = [rows[i].1, rows[j].1, rows[k].1];
                let x: [f64; 3] = std::array::from_fn(|c| {
                    let mut ac = a;
                    (0..3).for_each(|r| ac[r][c] = b[r]);
                    det(ac) / d
                });
                if rows.iter().all(|(r, rb)| r[0] * x[0] + r[1] * x[1] + r[2] * x[2] >= rb - 1e-9) {
                    return true;
                }
            }
        }
    }
    false
}

#[test]
fn steps_with_fixtures_verify_or_fail_only_when_jammed() {
    // With fixture contacts a step can jam. Every answer must verify; every failure must be a
    // geometric jam (no motion keeps all gaps open: proven by the LP above) or a friction jam
    // (the same step with frictionless planar contacts is solved); and no step that the LP
    // proves jammed may be reported solved.
    let mut solver = LcpSolver::new(8, LcpSettings::default());
    for fixtures in 1..=5 {
        let (mut solved, mut geometric, mut friction) = (0, 0, 0);
        for seed in 0..400u64 {
            let at = format!("fixtures {fixtures} seed {seed}");
            let mut rng = ChaCha8Rng::seed_from_u64(10_000 * fixtures as u64 + seed);
            let step = generate::random_step(&mut rng, fixtures);
            let feasible = kinematically_feasible(&step, 1 + fixtures);
            match solver.solve(&step.problem()) {
                Ok(sol) => {
                    let r = residual(3, &step.m, &step.q, sol.z);
                    assert!(r < 1e-9 && feasible, "{at}: residual {r:e}, feasible {feasible}");
                    solved += 1;
                }
                Err(Error::SecondaryRay { .. } | Error::PivotLimit { .. }) if !feasible => {
                    geometric += 1
                }
                Err(Error::SecondaryRay { .. } | Error::PivotLimit { .. }) => {
                    // Planar contacts' μ sit in their σ rows at the λ_n columns.
                    let (nc, n) = (1 + fixtures, step.n);
                    let mut frictionless = step.clone();
                    let o_s = 3 + 3 * nc + 24;
                    (0..nc).for_each(|c| frictionless.m[(o_s + c) * n + 3 + c] = 0.0);
                    let sol = solver.solve(&frictionless.problem());
                    assert!(sol.is_ok(), "{at}: not jammed geometrically, not by friction");
                    friction += 1;
                }
                Err(e) => panic!("{at}: unexpected failure {e}"),
            }
        }
        println!(
            "{fixtures} fixtures: {solved} solved, {geometric} geometric jams, {friction} friction jams"
        );
        assert!(solved > 0, "fixtures {fixtures}: nothing solved");
    }
}

#[test]
fn warm_start_reuses_an_active_set_and_falls_back_when_it_is_wrong() {
    use mesopush_lcp::SolveMethod;
    let mut solver = LcpSolver::new(34, LcpSettings::default());
    let mut warm_hits = 0;
    for seed in 0..300u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(50_000 + seed);
        let step = generate::random_step(&mut rng, 0);
        let cold = solver.solve(&step.problem()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let (z_cold, active) = (cold.z.to_vec(), cold.active.to_vec());
        // Same problem, its own active set: one linear solve reproduces the answer.
        let warm = solver.solve_warm(&step.problem(), &active).unwrap();
        assert_eq!(warm.method, SolveMethod::WarmStart, "seed {seed}");
        assert_eq!(warm.pivots, 0);
        for (a, b) in warm.z.iter().zip(&z_cold) {
            assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "seed {seed}: {a} vs {b}");
        }
        // The next step: the probe pushes 3 % further. Warm or not, the answer verifies.
        let mut next = step.clone();
        next.q[3] *= 1.03;
        let sol = solver.solve_warm(&next.problem(), &active).unwrap();
        assert!(residual(3, &next.m, &next.q, sol.z) < 1e-9, "seed {seed}");
        warm_hits += usize::from(sol.method == SolveMethod::WarmStart);
        // A useless guess (nothing active) falls back to Lemke.
        let none = vec![false; step.n];
        let sol = solver.solve_warm(&step.problem(), &none).unwrap();
        assert_ne!(sol.method, SolveMethod::WarmStart, "seed {seed}");
        assert!(residual(3, &step.m, &step.q, sol.z) < 1e-9, "seed {seed}");
    }
    println!("warm start kept the active set on {warm_hits} of 300 perturbed steps");
    let err = solver.solve_warm(
        &generate::random_step(&mut ChaCha8Rng::seed_from_u64(1), 0).problem(),
        &[true],
    );
    assert!(matches!(err, Err(Error::BadInput(_))));
}

#[test]
fn answers_do_not_depend_on_the_units_of_the_problem() {
    // Other units for forces (λ → λ/s: comp columns of M times s) and for the whole system
    // (w → t·w: M and q times t) give an equivalent problem; relative tolerances must keep
    // every step solvable and verified, with the same peg motion Δq (the friction forces
    // need not be unique: several direction combinations can give the same wrench).
    let mut solver = LcpSolver::new(34, LcpSettings::default());
    for seed in 0..200u64 {
        let step = generate::random_step(&mut ChaCha8Rng::seed_from_u64(70_000 + seed), 0);
        let base = solver.solve(&step.problem()).unwrap().z.to_vec();
        for (s_force, t_all) in [(1e-6, 1.0), (1e6, 1.0), (1.0, 1e-6), (1.0, 1e6), (1e6, 1e-6)] {
            let mut p = step.clone();
            let n = p.n;
            for i in 0..n {
                for j in 0..n {
                    p.m[i * n + j] *= t_all * if j >= 3 { s_force } else { 1.0 };
                }
                p.q[i] *= t_all;
            }
            let at = format!("seed {seed} s {s_force:e} t {t_all:e}");
            let sol = solver.solve(&p.problem()).unwrap_or_else(|e| panic!("{at}: {e}"));
            let r = residual(3, &p.m, &p.q, sol.z);
            assert!(r < 1e-9, "{at}: residual {r:e}");
            for (j, (a, b)) in sol.z.iter().zip(&base).enumerate().take(3) {
                assert!((a - b).abs() <= 1e-6 * (1.0 + b.abs()), "{at}: Δq[{j}] {a} vs {b}");
            }
        }
    }
}

#[test]
fn symmetric_push_through_the_com_has_the_translation_answer() {
    use generate::{PlanarContact, Support, assemble};
    // Supports symmetric about the x axis, COM at the origin (forces from statics: 1/4, 1/4,
    // 1/2), surface friction 0.3; a frictionless probe pushes 1 µm along +x through the COM.
    // Known answer: the peg follows the probe, Δq = (1, 0, 0); the probe carries the total
    // support friction 0.3 (weights); friction points along −x at every support; every
    // support slides at 1 µm. The 8-direction friction polygon makes the answer non-unique
    // (the solver may return another verified one, e.g. a slight pivot where a support's
    // velocity sits on a polygon vertex); every answer must still move the contact point
    // with the probe (dx = 1: the peg has to move, so the probe pushes, so its gap closes).
    let sup = |x: f64, y: f64, f: f64| Support { point_um: [x, y], normal_force: f, mu: 0.3 };
    let supports = [sup(-400.0, -200.0, 0.25), sup(-400.0, 200.0, 0.25), sup(400.0, 0.0, 0.5)];
    let probe = PlanarContact {
        point_um: [-807.5, 0.0],
        normal: [1.0, 0.0],
        mu: 0.0,
        gap_um: -1.0,
        drive_um: 0.0,
    };
    let step = assemble(&[probe], &supports, 8);
    assert_eq!(step.n, 3 + 1 + 2 + 24 + 1 + 3);
    // Layout: Δq 0..3 | λ_n 3 | probe λ_f 4..6 | support λ_f 6..30 (8 per support, direction
    // 4 is −x) | σ probe 30 | σ supports 31..34.
    let mut z_known = vec![0.0; step.n];
    z_known[0] = 1.0;
    z_known[3] = 0.3;
    for (k, s) in supports.iter().enumerate() {
        z_known[6 + 8 * k + 4] = 0.3 * s.normal_force;
        z_known[31 + k] = 1.0;
    }
    let r = residual(3, &step.m, &step.q, &z_known);
    assert!(r < 1e-12, "the translation answer violates the assembled LCP: {r:e}");

    let mut solver = LcpSolver::new(step.n, LcpSettings::default());
    let sol = solver.solve(&step.problem()).unwrap();
    assert!(residual(3, &step.m, &step.q, sol.z) < 1e-9);
    assert!((sol.z[0] - 1.0).abs() < 1e-9 && sol.z[3] > 0.0, "{:?}", &sol.z[..4]);
}
