//! The Monte Carlo estimator: Wilson interval coverage on a known Bernoulli, determinism for a
//! seed and any thread count, a plan that works without uncertainty scores 1, a plan that
//! cannot insert scores 0, candidate supports are drawn from the given set.

use mesopush_core::stats::{Z95, wilson_interval};
use mesopush_plan::montecarlo::draws;
use mesopush_plan::{MonteCarlo, Uncertainty};
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, SupportDistribution};
use rand::{RngExt, SeedableRng};

#[test]
fn wilson_interval_covers_a_known_bernoulli_95_percent_of_the_time() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for (p, n) in [(0.3, 50), (0.9, 200), (0.98, 400)] {
        let reps = 2000;
        let covered = (0..reps)
            .filter(|_| {
                let k = (0..n).filter(|_| rng.random_bool(p)).count();
                let (lo, hi) = wilson_interval(k, n, Z95);
                lo <= p && p <= hi
            })
            .count();
        let coverage = covered as f64 / reps as f64;
        assert!((0.925..=0.975).contains(&coverage), "p {p}, n {n}: coverage {coverage}");
    }
}

fn estimate(plan: &Plan, unc: Uncertainty, n: usize, seed: u64) -> mesopush_plan::SuccessEstimate {
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let mc = MonteCarlo {
        plan,
        model: &model,
        fixture: &fixture,
        settings: &settings,
        uncertainty: unc,
        supports: &[],
    };
    mc.estimate(n, seed, &|| ()).unwrap()
}

fn zero() -> Uncertainty {
    Uncertainty { dx_um: 0.0, dy_um: 0.0, dtheta_deg: 0.0, dmu: 0.0, support_um: 0.0 }
}

#[test]
fn same_seed_same_estimate_for_any_thread_count() {
    let plan = Plan::table2();
    let pool = |t| rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
    let a = pool(1).install(|| estimate(&plan, Uncertainty::default(), 12, 3));
    let b = pool(2).install(|| estimate(&plan, Uncertainty::default(), 12, 3));
    assert_eq!(a, b, "seed 3");
    let c = estimate(&plan, Uncertainty::default(), 12, 4);
    assert_ne!(a.trials, c.trials, "different seeds draw different worlds");
}

#[test]
fn a_plan_that_works_without_uncertainty_scores_one() {
    let e = estimate(&Plan::table2(), zero(), 4, 1);
    assert_eq!((e.successes, e.samples), (4, 4));
    assert_eq!(e.ci_high, 1.0);
}

#[test]
fn a_plan_that_cannot_insert_scores_zero() {
    let mut plan = Plan::table2();
    plan.moves_um.truncate(5); // rotates the peg but never pushes it in
    let e = estimate(&plan, Uncertainty::default(), 10, 1);
    assert_eq!(e.successes, 0);
    assert_eq!((e.success_rate, e.ci_low), (0.0, 0.0));
    assert!(e.ci_high > 0.0 && e.ci_high < 0.35, "{}", e.ci_high);
}

#[test]
fn draws_respect_the_box_and_the_candidate_supports() {
    let model = Model::default();
    let candidates: Vec<SupportSample> =
        [model.support.clone(), SupportDistribution::symmetric(200.0, 250.0, 0.4)]
            .iter()
            .map(|s| SupportSample::new(None, s))
            .collect();
    let unc = Uncertainty::default();
    let d = draws(&model, &unc, &candidates, 64, 9);
    assert_eq!(d, draws(&model, &unc, &candidates, 64, 9));
    let mut used = [false; 2];
    for w in &d {
        assert!(w.offset[0].abs() <= 26.0 && w.offset[1].abs() <= 74.0 && w.offset[2].abs() <= 3.0);
        let i = w.support_index.expect("drawn from the set");
        used[i] = true;
        assert_eq!(w.model.support.points_um, candidates[i].points_um);
        assert!((w.model.mu_probe - model.mu_probe).abs() <= 0.1 + 1e-12);
    }
    assert_eq!(used, [true, true]);
    // Pairs from identification are drawn whole: their μ_probe and surface μ as fitted.
    let pairs: Vec<SupportSample> = candidates
        .iter()
        .zip([0.41, 0.93])
        .map(|(c, mu)| SupportSample { mu_probe: Some(mu), ..c.clone() })
        .collect();
    for w in draws(&model, &unc, &pairs, 64, 9) {
        let i = w.support_index.expect("drawn from the set");
        assert_eq!(w.model.mu_probe, pairs[i].mu_probe.unwrap());
        assert_eq!(w.model.support, pairs[i].support());
    }
    // Without candidates the supports are perturbed and stay valid (COM inside).
    for w in draws(&model, &unc, &[], 64, 9) {
        assert!(w.support_index.is_none());
        w.model.validate().unwrap();
    }
}

#[test]
fn robustness_cli_prints_the_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let plan = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["robustness", "run", "--samples", "6", "--seed", "2", "--json", "--out"])
        .arg(dir.path())
        .arg(&plan)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in ["success_rate", "ci_low", "ci_high"] {
        assert!(v[k].is_number(), "{k} missing: {v}");
    }
    assert_eq!(v["samples"], 6);
    assert!(dir.path().join("failures_table2.png").exists());
}

/// A one-round, one-generation search small enough for a test: 4 candidates on 8 worlds,
/// one common set, no validation, from Table II's numbers.
fn small_search() -> mesopush_plan::RobustSettings {
    mesopush_plan::RobustSettings {
        generations: 1,
        population: 4,
        elite: 2,
        samples: 8,
        validation_samples: 0,
        finalists: 1,
        train_step_um: 5.0,
        resample: false,
        train_scale: 1.0,
        rounds: 1,
        accept_rate: 0.97,
        confirm_top: 3,
        confirm_samples: 0,
        target_rate: 1.0,
        max_replays: usize::MAX,
    }
}

#[test]
fn robust_design_is_deterministic_and_never_worse_than_its_start_on_its_worlds() {
    use mesopush_plan::{RobustSettings, Skeleton, Table2Family, UncertainWorld, design_robust};
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let world = UncertainWorld::nominal(&model, &fixture, &settings);
    let rs = small_search();
    let start = Plan::table2().peg_start;
    let t2 = Skeleton::table2_like().params;
    let run = |rs: &RobustSettings, seed| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        design_robust(&world, start, &Table2Family, &t2, rs, &mut rng, &mut |_, _| true).unwrap()
    };
    let a = run(&rs, 5);
    assert_eq!(a, run(&rs, 5), "seed 5");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    assert_eq!(a, pool.install(|| run(&rs, 5)), "seed 5, one thread");
    a.plan.validate().unwrap();
    assert_eq!(a.evaluations, 5);
    // Start skeleton on all 8 worlds + 4 candidates on the first half + 2 survivors on the
    // second half + the final sampling mean on all 8; no validation.
    assert_eq!(a.trials, 8 + 4 * 4 + 2 * 4 + 8, "seed 5");
    assert_eq!(a.validation_rate, None);
    // Score the starting skeleton on the same worlds (the optimiser draws them first): the
    // start is scored too, and without validation the best trained wins, so the result
    // cannot be worse on these worlds.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let worlds = draws(&model, &world.uncertainty, &[], rs.samples, rng.random());
    let s0 = Skeleton::table2_like().to_plan("start", start);
    let e0 =
        mesopush_plan::montecarlo::evaluate(&s0, &worlds, &fixture, &settings, &|| ()).unwrap();
    let ea =
        mesopush_plan::montecarlo::evaluate(&a.plan, &worlds, &fixture, &settings, &|| ()).unwrap();
    assert_eq!(ea.success_rate, a.training_rate, "seed 5: the reported training rate");
    eprintln!("seed 5: start {} → designed {}", e0.success_rate, a.training_rate);
    assert!(a.training_rate >= e0.success_rate, "{} < {}", a.training_rate, e0.success_rate);
    // With validation the winner is one of the finalists and its validation rate is reported.
    let v = run(&RobustSettings { validation_samples: 6, finalists: 3, ..rs }, 5);
    let rate = v.validation_rate.expect("validated");
    assert!((0.0..=1.0).contains(&rate), "{rate}");
    assert_eq!(v.trials, a.trials + 3 * 6);
    assert_eq!(v.confirmation_rate, None, "no confirmation worlds");
    // Confirmation: the two most validated finalists within reach of the first (Table II's
    // numbers are not) run on 5 more worlds, drawn after the validation ones (the search
    // itself is unchanged), and the winner's rate there is reported.
    // (Seed 4, two generations: at seed 5 only the start is eligible, and no confirmation runs.)
    let val = RobustSettings { generations: 2, validation_samples: 20, finalists: 3, ..rs };
    let v = run(&val, 4);
    let c = run(&RobustSettings { confirm_top: 2, confirm_samples: 5, ..val }, 4);
    assert_eq!(c.trials, v.trials + 2 * 5, "seed 4, confirmation");
    assert_eq!((c.evaluations, c.generations), (v.evaluations, v.generations));
    let conf = c.confirmation_rate.expect("confirmed");
    assert!((0.0..=1.0).contains(&conf) && (conf * 5.0).fract() == 0.0, "{conf}");
    let alone = run(&RobustSettings { generations: 1, confirm_samples: 5, ..val }, 5);
    assert_eq!(alone.confirmation_rate, None, "seed 5: the start alone is eligible");
    // With room for three, still two: Table II's numbers are out of reach.
    let all = run(&RobustSettings { confirm_top: 3, confirm_samples: 5, ..val }, 4);
    assert_eq!(all.trials, c.trials, "seed 4: Table II's numbers confirmed");
}

#[test]
fn robust_design_on_fresh_worlds_each_generation_is_deterministic_and_reraces_the_incumbent() {
    use mesopush_plan::{RobustSettings, Skeleton, Table2Family, UncertainWorld, design_robust};
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let world = UncertainWorld::nominal(&model, &fixture, &settings);
    let t2 = Skeleton::table2_like().params;
    let rs = RobustSettings {
        generations: 2,
        validation_samples: 6,
        finalists: 3,
        train_step_um: 10.0,
        resample: true,
        train_scale: 1.3,
        ..small_search()
    };
    let start = Plan::table2().peg_start;
    let run = |seed| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        design_robust(&world, start, &Table2Family, &t2, &rs, &mut rng, &mut |_, _| true).unwrap()
    };
    let a = run(3);
    assert_eq!(a, run(3), "seed 3");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    assert_eq!(a, pool.install(|| run(3)), "seed 3, one thread");
    a.plan.validate().unwrap();
    // Generation 1: 4 candidates; generation 2 on new worlds: 4 new + the incumbent.
    assert_eq!(a.evaluations, 1 + 4 + 5, "seed 3");
    // Start on 8; per generation all candidates on the first half, 2 survivors on the second;
    // the final mean on 8; 3 finalists on 6 validation worlds.
    assert_eq!(a.trials, 8 + (4 * 4 + 2 * 4) + (5 * 4 + 2 * 4) + 8 + 3 * 6, "seed 3");
    let rate = a.validation_rate.expect("validated");
    assert!((0.0..=1.0).contains(&rate), "{rate}");
    assert_ne!(a, run(4), "seeds 3 and 4 gave the same design");
    // Rounds: an unreachable acceptance rate runs all of them, each a whole search from the
    // start, all validated on the same worlds; the winner is validated no worse than round 1's.
    let rounds = RobustSettings { rounds: 2, accept_rate: 1.01, ..rs };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let b = design_robust(&world, start, &Table2Family, &t2, &rounds, &mut rng, &mut |_, _| true)
        .unwrap();
    assert_eq!(b.evaluations, 2 * a.evaluations, "seed 3, two rounds");
    // The start is a finalist of both rounds; its validation is not run again.
    assert_eq!(b.trials, 2 * a.trials - 6, "seed 3, two rounds");
    assert_eq!(b.generations, 4, "seed 3, two rounds");
    assert_eq!((a.rounds, b.rounds), (1, 2), "seed 3");
    assert!(
        b.validation_rate >= a.validation_rate,
        "{:?} < {:?}",
        b.validation_rate,
        a.validation_rate
    );
}

#[test]
fn support_set_files_load_as_toml_or_json_and_name_a_bad_candidate() {
    use mesopush_sim::support_set::SupportSet;
    let dir = tempfile::tempdir().unwrap();
    let model = Model::default();
    let toml_path = dir.path().join("supports.toml");
    std::fs::write(
        &toml_path,
        "[[support]]\npoints_um = [[-250.0, 440.0], [50.0, -330.0], [250.0, 60.0]]\n\
         mu_surface = [0.3, 0.3, 0.3]\n[[support]]\n\
         points_um = [[-200.0, -250.0], [-200.0, 250.0], [400.0, 0.0]]\n\
         mu_surface = [0.25, 0.3, 0.35]\n",
    )
    .unwrap();
    let set = SupportSet::load(&toml_path, &model.part).unwrap();
    assert_eq!(set.support.len(), 2);
    let json_path = dir.path().join("supports.json");
    std::fs::write(&json_path, serde_json::to_string(&set.support).unwrap()).unwrap();
    assert_eq!(SupportSet::load(&json_path, &model.part).unwrap(), set);
    let bad = toml_path.with_file_name("bad.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap().replace("400.0, 0.0", "4000.0, 0.0");
    std::fs::write(&bad, text).unwrap();
    let e = SupportSet::load(&bad, &model.part).unwrap_err().to_string();
    assert!(e.contains("support 2") && e.contains("bad.toml"), "{e}");
}

#[test]
fn the_shipped_start_is_the_shipped_robust_plan_and_the_default_is_table2_with_its_press_on_the_rotated_peg()
 {
    use mesopush_plan::{Init, RobustSearch, Skeleton};
    let shipped = Plan::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../plans/robust.toml"
    )))
    .unwrap();
    let start = Plan::table2().peg_start;
    let best = Skeleton::best_known().to_plan("", start);
    assert_eq!(RobustSearch::default().init, Init::Table2 { press_on_rotated: true });
    assert_eq!(best.probe_start_um, shipped.probe_start_um);
    assert_eq!(best.moves_um.len(), shipped.moves_um.len());
    for (a, b) in best.moves_um.iter().zip(&shipped.moves_um) {
        assert!((a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6, "{a:?} vs {b:?}");
    }
}
