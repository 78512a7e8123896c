//! The RRT planner: it finds plans that replay to an insertion, keeps the probe out of the
//! walls and inside the executor's workspace, and is deterministic for a seed.

use mesopush_plan::clearance::{first_wall_violation, in_workspace, max_speed_um_s};
use mesopush_plan::{RrtSettings, plan_is_feasible, plan_rrt};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use rand::SeedableRng;
use std::path::Path;

fn sim() -> Simulator {
    Simulator::new(Model::default(), Fixture::paper(), SimSettings::default()).unwrap()
}

/// Seed 2 finds a plan in a few dozen iterations with the default settings.
const SEED: u64 = 2;

fn plan(seed: u64, max_iterations: usize) -> (mesopush_plan::RrtResult, Simulator) {
    plan_with(seed, RrtSettings { max_iterations, ..Default::default() })
}

fn plan_with(seed: u64, settings: RrtSettings) -> (mesopush_plan::RrtResult, Simulator) {
    let mut s = sim();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let start = Plan::table2().peg_start_pose();
    let r = plan_rrt(&mut s, start, &settings, &mut rng, &mut |_| true).unwrap();
    (r, s)
}

#[test]
fn rrt_plan_inserts_the_peg_and_keeps_the_probe_out_of_the_walls() {
    let (r, mut s) = plan(SEED, 300);
    let plan =
        r.plan.unwrap_or_else(|| panic!("seed {SEED}: no plan in {} iterations", r.iterations));
    assert!(r.pushes >= 2 && r.pushes <= plan.moves_um.len(), "{} pushes", r.pushes);
    let rep = replay(&mut s, &plan, None).unwrap();
    assert!(rep.inserted, "seed {SEED}: final pose {:?}", rep.final_pose);
    assert!(rep.events.is_empty(), "seed {SEED}: {:?}", rep.events);
    let walls = &s.fixture().walls;
    assert_eq!(first_wall_violation(plan.probe_start(), &plan.moves_um, walls, 12.5), None);
    assert!(plan.speed_um_s <= max_speed_um_s());
    let mut p = plan.probe_start();
    for m in &plan.moves_um {
        p += mesopush_core::geom::Vec2::new(m[0], m[1]);
        assert!(in_workspace(&p), "probe leaves the workspace at {p:?}");
    }
    assert!(plan_is_feasible(&mut s, &plan).unwrap());
    // What `plan --out` writes is what `sim` and the executor load.
    let back = Plan::from_toml(&plan.to_toml(), Path::new("rrt.toml")).unwrap();
    assert_eq!(back, plan);
}

#[test]
fn same_seed_same_plan() {
    let (a, _) = plan(SEED, 300);
    let (b, _) = plan(SEED, 300);
    assert_eq!(a, b, "seed {SEED}");
}

#[test]
fn shortcutting_never_adds_pushes_and_the_shortcut_plan_still_inserts() {
    let (mut before, mut after) = (0, 0);
    for seed in [SEED, 4, 6] {
        let settings = RrtSettings { max_iterations: 2000, ..Default::default() };
        let raw = RrtSettings { shortcut_attempts: 0, ..settings.clone() };
        let (r0, _) = plan_with(seed, raw);
        let (r, mut s) = plan_with(seed, settings);
        let plan = r.plan.unwrap_or_else(|| panic!("seed {seed}: no plan"));
        // The search is the same; only the found branch is shortened.
        assert_eq!(r0.pushes, r0.pushes_before_shortcut, "seed {seed}");
        assert_eq!(r.pushes_before_shortcut, r0.pushes, "seed {seed}");
        assert!(r.pushes <= r.pushes_before_shortcut, "seed {seed}: {} pushes", r.pushes);
        assert!(r.shortcut_attempts > 0, "seed {seed}");
        let rep = replay(&mut s, &plan, None).unwrap();
        assert!(rep.inserted && rep.events.is_empty(), "seed {seed}: {:?}", rep.final_pose);
        assert!(plan_is_feasible(&mut s, &plan).unwrap(), "seed {seed}");
        (before, after) = (before + r.pushes_before_shortcut, after + r.pushes);
    }
    // A pass that never shortens anything would be dead weight.
    assert!(after < before, "{after} pushes after shortcutting, {before} before");
}

#[test]
fn no_iterations_no_plan_and_a_table2_cut_short_is_not_feasible() {
    let (r, mut s) = plan(SEED, 0);
    assert!(r.plan.is_none() && r.iterations == 0 && r.pushes == 0);
    let mut short = Plan::table2();
    short.moves_um.truncate(2);
    assert!(!plan_is_feasible(&mut s, &short).unwrap());
    assert!(plan_is_feasible(&mut s, &Plan::table2()).unwrap());
}

#[test]
fn plan_cli_prints_the_json_summary_and_writes_a_loadable_plan() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args([
            "plan",
            "rrt",
            "--seed",
            &SEED.to_string(),
            "--json",
            "--max-iterations",
            "300",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["found"], true, "{v}");
    for k in ["pushes", "pushes_before_shortcut", "iterations", "planning_ms", "tree_size"] {
        assert!(v[k].is_number(), "{k} missing: {v}");
    }
    Plan::load(&out).unwrap();
}

#[test]
fn robust_plan_cli_reports_the_fresh_check_and_the_design_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("robust.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["plan", "robust", "--seed", "3", "--json", "--generations", "1"])
        .args(["--train-samples", "4", "--validation-samples", "4", "--check-samples", "6"])
        .args(["--check-seed", "99", "--rounds", "2", "--accept-rate", "1.01", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["samples"].as_u64(), v["check_seed"].as_u64()), (Some(6), Some(99)), "{v}");
    for k in
        ["success_rate", "ci_low", "ci_high", "training_rate", "validation_rate", "planning_ms"]
    {
        assert!(v[k].is_number(), "{k} missing: {v}");
    }
    assert_eq!((v["generations"].as_u64(), v["rounds"].as_u64()), (Some(2), Some(2)), "{v}");
    assert_eq!(v["validation_samples"], 4, "{v}");
    assert_eq!((&v["stopped_by_time"], &v["out_of_budget"]), (&false.into(), &false.into()));
    Plan::load(&out).unwrap().validate().unwrap();
}

/// `plan robust` with a small search: 2 generations of 6 candidates on 8 worlds, 3
/// finalists on 16 validation worlds, 2 confirmed on 16; `extra` appended.
fn small_robust(out: &Path, threads: usize, extra: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .env("RAYON_NUM_THREADS", threads.to_string())
        .args(["plan", "robust", "--seed", "5", "--json", "--generations", "2"])
        .args(["--population", "6", "--elite", "2", "--train-samples", "8"])
        .args(["--validation-samples", "16", "--confirm-top", "2", "--confirm-samples", "16"])
        .args(["--rounds", "1", "--check-samples", "4", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn a_robust_plan_is_the_same_file_from_the_same_seed_on_one_thread_and_on_two() {
    // The search's budget counts replays, never seconds, and every parallel batch is
    // collected in order: the thread count cannot change the plan (it did when a 60-s
    // wall-clock budget decided how many generations ran, issue 21).
    let dir = tempfile::tempdir().unwrap();
    let table2 = concat!(env!("CARGO_MANIFEST_DIR"), "/../../plans/table2.toml");
    for (label, extra) in [
        ("table2 skeleton", vec!["--from-shipped"]),
        ("from a plan", vec!["--from-plan", table2]),
        ("two stages with a wall press", vec!["--from-shipped", "--wall-press"]),
    ] {
        let files: Vec<Vec<u8>> = [1, 2, 2]
            .iter()
            .enumerate()
            .map(|(i, &threads)| {
                let out = dir.path().join(format!("{i}.toml"));
                let o = small_robust(&out, threads, &extra);
                assert!(o.status.success(), "{label}: {}", String::from_utf8_lossy(&o.stderr));
                std::fs::read(&out).unwrap()
            })
            .collect();
        assert!(files[0] == files[1], "{label}: one thread and two gave different plans");
        assert!(files[1] == files[2], "{label}: the same run twice gave different plans");
        let plan: Plan = toml::from_str(std::str::from_utf8(&files[0]).unwrap()).unwrap();
        plan.validate().unwrap();
    }
}

#[test]
fn the_replay_budget_ends_a_robust_search_and_a_wall_clock_limit_says_it_stopped_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.toml");
    let json = |o: std::process::Output| -> serde_json::Value {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let full = json(small_robust(&out, 2, &["--from-shipped"]));
    assert_eq!(
        (full["generations"].as_u64(), full["out_of_budget"].as_bool()),
        (Some(2), Some(false))
    );
    let replays = full["replays"].as_u64().unwrap();
    // A budget one replay short of the full search's cuts its second generation and stays
    // within the budget.
    let budget = (replays - 1).to_string();
    let cut = json(small_robust(&out, 2, &["--from-shipped", "--max-replays", &budget]));
    assert_eq!(
        (cut["generations"].as_u64(), cut["out_of_budget"].as_bool()),
        (Some(1), Some(true)),
        "{cut}"
    );
    assert!(cut["replays"].as_u64().unwrap() <= budget.parse::<u64>().unwrap(), "{cut}");
    assert_eq!(cut["stopped_by_time"], false, "{cut}");
    // A budget that cannot hold one generation with its validation and confirmation is
    // refused before any work, naming the field and the smallest allowed.
    let tiny = small_robust(&out, 2, &["--from-shipped", "--max-replays", "10"]);
    let err = String::from_utf8_lossy(&tiny.stderr);
    assert_eq!(tiny.status.code(), Some(2), "{err}");
    assert!(err.contains("max_replays") && err.contains("at least"), "{err}");
    // With two stages the first gets its share (0.35 by default): a budget that holds one
    // stage but not that share of it for the first of two is refused the same way, before
    // any work.
    let one = json(small_robust(&out, 2, &["--from-shipped"]))["replays"].as_u64().unwrap();
    let half = small_robust(
        &out,
        2,
        &["--from-shipped", "--wall-press", "--max-replays", &one.to_string()],
    );
    let err = String::from_utf8_lossy(&half.stderr);
    assert_eq!(half.status.code(), Some(2), "{err}");
    assert!(err.contains("max_replays") && err.contains("two stages"), "{err}");
    // The share decides stage 1's budget: of 420 replays, 0.35 (147) holds one generation
    // of this search's stage 1, 0.5 (210) both.
    for (share, generations) in [("0.35", 1), ("0.5", 2)] {
        let args = ["--from-shipped", "--wall-press", "--max-replays", "420"];
        let v = json(small_robust(&out, 2, &[&args[..], &["--first-stage-share", share]].concat()));
        assert_eq!(v["stage2"]["first"]["generations"].as_u64(), Some(generations), "{v}");
        assert_eq!(v["first_stage_share"].as_f64(), share.parse().ok(), "{v}");
    }
    // A share outside [0.05, 0.95] is refused by name.
    for bad in ["0", "1", "NaN"] {
        let args = ["--from-shipped", "--wall-press", "--first-stage-share", bad];
        let o = small_robust(&out, 2, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains("--first-stage-share") && err.contains("0.95"), "{bad}: {err}");
    }
    // A wall-clock limit shorter than one generation stops the search after its first and
    // says so.
    let timed = json(small_robust(&out, 2, &["--from-shipped", "--time-limit-s", "0.000001"]));
    assert_eq!(
        (timed["generations"].as_u64(), timed["stopped_by_time"].as_bool()),
        (Some(1), Some(true)),
        "{timed}"
    );
}

#[test]
fn a_wall_press_stage_presses_before_the_first_move_and_its_plan_wins_only_on_more_worlds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.toml");
    let o = small_robust(&out, 2, &["--from-shipped", "--wall-press", "--max-replays", "4000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let st = &v["stage2"];
    // Table II's peg starts 94 µm below the upper wall: the press before the first move goes
    // there (the lower wall is 3 times as far, and the plan after it then fails nominally).
    assert_eq!(st["press"]["before_first_move"], true, "{v}");
    assert_eq!(st["press"]["direction"], "-y", "{v}");
    let gap = st["press"]["gap_um"].as_f64().unwrap();
    assert!((gap - 94.0).abs() < 5.0, "{v}");
    let c = &st["choice"];
    let (first, second) = (c["first_successes"].as_u64(), c["second_successes"].as_u64());
    assert_eq!(c["second_wins"].as_bool(), Some(second > first), "{v}");
    // The plan written is stage 2's (it starts with the press: the probe goes down past the
    // peg's lower end first) only if it won.
    let plan: Plan = toml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let starts_with_press = plan.moves_um[0][1] > 700.0;
    assert_eq!(starts_with_press, second > first, "{v}\n{:?}", plan.moves_um);
    assert!(v["total_replays"].as_u64().unwrap() <= 4000, "{v}");
    assert_eq!(v["first_stage_share"].as_f64(), Some(0.35), "{v}");
    // Without the press the same two stages run, none is inserted.
    let o = small_robust(&out, 2, &["--from-shipped", "--refine-moves", "--max-replays", "4000"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["stage2"]["press"].is_null() && !v["stage2"]["choice"].is_null(), "{v}");
}

#[test]
fn plan_robust_from_the_rrt_starts_from_the_most_successful_of_its_rrt_plans() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.toml");
    let o = small_robust(&out, 2, &["--from-rrt", "--rrt-starts", "3"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let r = &v["rrt_start"];
    let runs = r["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 3, "{r}");
    assert_eq!(runs[0]["seed"], 5, "the first start is --seed itself: {r}");
    let best = runs.iter().filter_map(|x| x["successes"].as_u64()).max().unwrap();
    assert_eq!(r["successes"].as_u64(), Some(best), "{r}");
    let first_best = runs.iter().find(|x| x["successes"].as_u64() == Some(best)).unwrap();
    assert_eq!(r["seed"], first_best["seed"], "ties go to the earlier seed: {r}");
    assert_eq!(r["screen_samples"], 64, "{r}");
    Plan::load(&out).unwrap().validate().unwrap();
}

#[test]
fn the_shipped_two_stage_plan_inserts_in_its_nominal_replay_within_the_needle_limit() {
    // plans/robust_wall_press.toml is a design written by `plan robust --wall-press`: the
    // docs' figures and sweep use it, and `flash` may be given it, so it must stay feasible as
    // the simulator changes (the probe clear of the walls, no overload, the peg inserted).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../plans/robust_wall_press.toml");
    let plan = Plan::load(std::path::Path::new(path)).unwrap();
    let mut s = sim();
    assert!(mesopush_plan::plan_is_feasible(&mut s, &plan).unwrap());
    let r = mesopush_sim::replay(&mut s, &plan, None).unwrap();
    assert!(r.inserted && r.overload.is_none(), "{:?}", r.final_pose);
    // It starts with the press before the first push: down past the peg, then up.
    assert!(plan.moves_um[0][1] > 700.0 && plan.moves_um[2][1] < -100.0, "{:?}", plan.moves_um);
}

#[test]
fn a_wall_press_stage_with_no_press_that_suits_re_tunes_the_moves_and_uses_its_budget() {
    // The triangle task's plans have no press before the first move that keeps them
    // inserting: stage 2 used to be skipped then, leaving half the budget unused (issue 21).
    let dir = tempfile::tempdir().unwrap();
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../plans/triangle");
    let (model, fixture) = (format!("{root}/model.toml"), format!("{root}/fixture.toml"));
    let out = small_robust(
        &dir.path().join("tri.toml"),
        2,
        &[
            "--model",
            &model,
            "--fixture",
            &fixture,
            "--start",
            "2330,1210,90",
            "--from-rrt",
            "--rrt-starts",
            "2",
            "--wall-press",
            "--max-replays",
            "4000",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let st = &o["stage2"];
    assert!(st["without_press"].as_str().is_some_and(|w| w.contains("no press")), "{o}");
    assert!(st["press"].is_null() && st["skipped"].is_null(), "{o}");
    assert!(st["second"].is_object() && st["choice"].is_object(), "stage 2 ran: {o}");
    assert!(o["total_replays"].as_u64().unwrap() <= 4000, "{o}");
}
