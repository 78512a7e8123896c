//! `mesopush plan`: design a pushing plan with the paper's RRT (or, with `--robust`, a plan
//! optimised against the Monte Carlo success rate) and write it as plan TOML.

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_host::geom::Pose;
use mesopush_host::plan::pushes::pushing_moves;
use mesopush_host::plan::{
    MonteCarlo, Progress, RobustSettings, RrtSettings, Skeleton, Uncertainty, World, design_robust,
    plan_is_feasible, plan_rrt,
};
use mesopush_host::plot::{PlanFigure, draw_plan};
use mesopush_host::sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use rand::SeedableRng;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Design a pushing plan (RRT over simulated pushes) and write it as plan TOML.
#[derive(Debug, Args)]
pub(crate) struct PlanArgs {
    /// Seed of every random choice (same seed, same plan).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the plan TOML.
    #[arg(long, default_value = "plan.toml")]
    out: PathBuf,
    /// Model TOML (part, supports, friction); default: the nominal model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fixture TOML (walls, goal); default: the reconstructed paper fixture.
    #[arg(long)]
    fixture: Option<PathBuf>,
    /// Peg start pose "x_um,y_um,theta_deg"; default: Table II's (2330, 1210, 89°).
    #[arg(long, value_parser = parse_pose)]
    start: Option<Pose>,
    /// RRT iterations before giving up.
    #[arg(long, default_value_t = RrtSettings::default().max_iterations)]
    max_iterations: usize,
    /// Random pushes simulated per iteration.
    #[arg(long, default_value_t = RrtSettings::default().inputs_per_iteration)]
    inputs: usize,
    /// Pushing locations on the peg boundary.
    #[arg(long, default_value_t = 100)]
    locations: usize,
    /// Most push drops the shortcut pass tries on the found branch (0: keep it as found).
    #[arg(long, default_value_t = RrtSettings::default().shortcut_attempts)]
    shortcut_attempts: usize,
    /// Orientation window of the goal connection while shortcutting, degrees.
    #[arg(long, default_value_t = RrtSettings::default().shortcut_connect_theta_deg)]
    shortcut_connect_deg: f64,
    /// Wall-clock limit, s (the search stops and reports `found: false`).
    #[arg(long, default_value_t = 60.0)]
    time_limit_s: f64,
    /// Also draw the plan (Fig. 6 style) to this PNG or SVG.
    #[arg(long)]
    figure: Option<PathBuf>,
    /// Design a robust plan instead: optimise the Table II skeleton against the Monte Carlo
    /// success rate under the paper's uncertainty (docs/planning.md).
    #[arg(long)]
    robust: bool,
    /// With --robust: CEM generations.
    #[arg(long, default_value_t = RobustSettings::default().generations)]
    generations: usize,
    /// With --robust: sampled worlds each candidate is scored on.
    #[arg(long, default_value_t = RobustSettings::default().samples)]
    train_samples: usize,
    /// With --robust: simulator step of the training replays, µm (validation and the check
    /// use the full-fidelity default).
    #[arg(long, default_value_t = RobustSettings::default().train_step_um)]
    train_step_um: f64,
    /// With --robust: score every generation on one common set of training worlds instead of
    /// drawing new ones each generation.
    #[arg(long)]
    common_worlds: bool,
    /// With --robust: scale of the uncertainty box the training worlds are drawn from (the
    /// validation and the check use the default box).
    #[arg(long, default_value_t = RobustSettings::default().train_scale)]
    train_scale: f64,
    /// With --robust: most CEM rounds (another runs only while no finalist reaches
    /// --accept-rate on the validation worlds).
    #[arg(long, default_value_t = RobustSettings::default().rounds)]
    rounds: usize,
    /// With --robust: validation success rate that ends the search after a round.
    #[arg(long, default_value_t = RobustSettings::default().accept_rate)]
    accept_rate: f64,
    /// With --robust: start the search at the shipped design (plans/robust.toml's
    /// parameters) instead of Table II's numbers. It then refines that design and mostly
    /// returns it unchanged: a check of the shipped plan, not a design from scratch.
    #[arg(long)]
    from_shipped: bool,
    /// With --robust: candidates per CEM generation.
    #[arg(long, default_value_t = RobustSettings::default().population)]
    population: usize,
    /// With --robust: best candidates that set the next generation's distribution.
    #[arg(long, default_value_t = RobustSettings::default().elite)]
    elite: usize,
    /// With --robust: candidates re-scored on the validation worlds.
    #[arg(long, default_value_t = RobustSettings::default().finalists)]
    finalists: usize,
    /// With --robust: validation worlds the best candidates are re-scored on.
    #[arg(long, default_value_t = RobustSettings::default().validation_samples)]
    validation_samples: usize,
    /// With --robust: fresh Monte Carlo trials for the reported success rate.
    #[arg(long, default_value_t = 400)]
    check_samples: usize,
    /// With --robust: master seed of the fresh check (default: derived from --seed, never
    /// the design's own draws).
    #[arg(long)]
    check_seed: Option<u64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_pose(s: &str) -> Result<Pose, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, t] if v.iter().all(|a| a.is_finite()) => Ok(Pose::new(x, y, t.to_radians())),
        _ => Err("expected three finite numbers x_um,y_um,theta_deg".into()),
    }
}

pub(crate) fn load_world(model: Option<&Path>, fixture: Option<&Path>) -> Result<Simulator> {
    let model = model.map_or_else(|| Ok(Model::default()), Model::load)?;
    let fixture = fixture.map_or_else(|| Ok(Fixture::paper()), Fixture::load)?;
    Ok(Simulator::new(model, fixture, SimSettings::default())?)
}

pub(crate) fn run(args: &PlanArgs) -> Result<()> {
    let mut sim = load_world(args.model.as_deref(), args.fixture.as_deref())?;
    if args.robust {
        return run_robust(args, &mut sim);
    }
    let start = args.start.unwrap_or_else(|| Plan::table2().peg_start_pose());
    let settings = RrtSettings {
        max_iterations: args.max_iterations,
        inputs_per_iteration: args.inputs.max(1),
        shortcut_attempts: args.shortcut_attempts,
        shortcut_connect_theta_deg: args.shortcut_connect_deg,
        pushes: mesopush_host::plan::pushes::PushSettings {
            n_locations: args.locations.max(4),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let bar = bar(settings.max_iterations as u64, args.json);
    let t0 = Instant::now();
    let limit = args.time_limit_s;
    let mut on_progress = |p: Progress| {
        bar.set_position(p.iteration as u64);
        bar.set_message(format!("tree {}", p.tree_size));
        t0.elapsed().as_secs_f64() < limit
    };
    let result = plan_rrt(&mut sim, start, &settings, &mut rng, &mut on_progress)?;
    let planning_ms = t0.elapsed().as_secs_f64() * 1e3;
    bar.finish_and_clear();
    let found = result.plan.is_some();
    let (moves, travel) =
        result.plan.as_ref().map_or((0, 0.0), |p| (p.moves_um.len(), p.travel_um()));
    if let Some(plan) = &result.plan {
        std::fs::write(&args.out, plan.to_toml())
            .with_context(|| format!("writing {}", args.out.display()))?;
        if let Some(fig) = &args.figure {
            figure(&mut sim, plan, fig)?;
        }
    }
    let summary = json!({
        "found": found, "pushes": result.pushes,
        "pushes_before_shortcut": result.pushes_before_shortcut,
        "shortcut_attempts": result.shortcut_attempts, "moves": moves, "travel_um": travel,
        "iterations": result.iterations, "tree_size": result.tree_size,
        "simulated_pushes": result.simulated_pushes,
        "rejected_at_verification": result.rejected_at_verification,
        "planning_ms": planning_ms, "seed": args.seed,
        "plan": if found { Some(&args.out) } else { None },
    });
    if args.json {
        println!("{summary}");
    } else {
        print_text(&summary);
    }
    if !found && !args.json {
        bail!("no plan found in {} iterations ({planning_ms:.0} ms)", result.iterations);
    }
    Ok(())
}

fn print_text(s: &serde_json::Value) {
    println!("found: {}", s["found"]);
    println!(
        "pushes: {} ({} probe moves, {:.0} µm of probe travel)",
        s["pushes"],
        s["moves"],
        s["travel_um"].as_f64().unwrap_or(0.0)
    );
    println!(
        "iterations: {}, tree size: {}, pushes simulated: {}",
        s["iterations"], s["tree_size"], s["simulated_pushes"]
    );
    println!(
        "pushes before shortcutting: {} ({} drops tried)",
        s["pushes_before_shortcut"], s["shortcut_attempts"]
    );
    println!("planning time: {:.0} ms", s["planning_ms"].as_f64().unwrap_or(0.0));
    if let Some(p) = s["plan"].as_str() {
        println!("plan: {p}");
    }
}

pub(crate) fn bar(len: u64, hidden: bool) -> ProgressBar {
    if hidden {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    let style = ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
        .expect("constant template");
    bar.set_style(style);
    bar
}

pub(crate) fn figure(sim: &mut Simulator, plan: &Plan, path: &Path) -> Result<()> {
    let r = replay(sim, plan, None)?;
    let poses: Vec<_> = r.samples.iter().map(|s| s.peg).collect();
    let probe: Vec<_> = r.samples.iter().map(|s| s.probe_um).collect();
    let title = format!("{} — {}", plan.name, if r.inserted { "inserted" } else { "NOT inserted" });
    let fig = PlanFigure {
        title: &title,
        walls: &sim.fixture().walls,
        goal: Some(&sim.fixture().goal),
        part: sim.model().part.polygon(),
        poses: &poses,
        probe_um: &probe,
        max_outlines: 25,
    };
    Ok(draw_plan(&fig, path)?)
}

fn run_robust(args: &PlanArgs, sim: &mut Simulator) -> Result<()> {
    let mut start = Plan::table2().peg_start;
    if let Some(p) = args.start {
        (start.x_um, start.y_um, start.theta_deg) = (p.x_um, p.y_um, p.theta_rad.to_degrees());
    }
    let settings = robust_settings(args);
    let (model, fixture) = (sim.model().clone(), sim.fixture().clone());
    let sim_settings = sim.settings().clone();
    let world = World {
        model: &model,
        fixture: &fixture,
        settings: &sim_settings,
        uncertainty: Uncertainty::default(),
        supports: &[],
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let bar = bar((settings.generations * settings.rounds) as u64, args.json);
    let t0 = Instant::now();
    let limit = args.time_limit_s;
    let mut time_limited = false;
    let mut on_progress = |g: usize, best: f64| {
        bar.set_position(g as u64);
        bar.set_message(format!("best {:.1} %", 100.0 * best));
        let go_on = fits_another_generation(&settings, g, t0.elapsed().as_secs_f64(), limit);
        time_limited |= !go_on && g < settings.generations * settings.rounds;
        go_on
    };
    let r = design_robust(&world, start, &settings, &mut rng, &mut on_progress)?;
    let planning_ms = t0.elapsed().as_secs_f64() * 1e3;
    bar.finish_and_clear();
    let feasible = plan_is_feasible(sim, &r.plan)?;
    let mc = MonteCarlo {
        plan: &r.plan,
        model: &model,
        fixture: &fixture,
        settings: &sim_settings,
        uncertainty: Uncertainty::default(),
        supports: &[],
    };
    // Fresh draws (a different master seed from the training worlds') for an honest figure.
    let check_seed = args.check_seed.unwrap_or(args.seed.wrapping_add(0x005E_ED0F_C4EC));
    let est = mc.estimate(args.check_samples.max(1), check_seed, &|| ())?;
    std::fs::write(&args.out, r.plan.to_toml())
        .with_context(|| format!("writing {}", args.out.display()))?;
    if let Some(fig) = &args.figure {
        figure(sim, &r.plan, fig)?;
    }
    let pushes = pushing_moves(&replay(sim, &r.plan, None)?);
    let train = settings.samples;
    let out = RobustOutput {
        result: &r,
        est: &est,
        feasible,
        planning_ms,
        train,
        pushes,
        time_limited,
        check_seed,
        validation_samples: settings.validation_samples,
    };
    print_robust(args, &out);
    Ok(())
}

/// The optimiser's settings from the flags.
fn robust_settings(args: &PlanArgs) -> RobustSettings {
    RobustSettings {
        generations: args.generations.max(1),
        samples: args.train_samples.max(2),
        validation_samples: args.validation_samples,
        train_step_um: args.train_step_um,
        resample: !args.common_worlds,
        train_scale: args.train_scale,
        finalists: args.finalists.max(1),
        population: args.population.max(2),
        rounds: args.rounds.max(1),
        accept_rate: args.accept_rate,
        elite: args.elite.clamp(1, args.population.max(2)),
        initial: if args.from_shipped { Skeleton::best_known() } else { Skeleton::table2_like() },
        ..Default::default()
    }
}

/// Whether generation `g + 1` and the validation still fit in `limit_s` after `elapsed_s`.
fn fits_another_generation(
    settings: &RobustSettings,
    g: usize,
    elapsed_s: f64,
    limit_s: f64,
) -> bool {
    // A generation is about 16 candidates on 96 worlds × 3/4 each (racing).
    let per_gen = (settings.population * settings.samples * 3 / 4).max(1) as f64;
    let val = (settings.finalists * settings.validation_samples) as f64;
    let gen_s = elapsed_s / g.max(1) as f64;
    // Validation runs at the fine step: two to three times the cost per replay (a 2.0 × 1.2
    // reserve let a search at load 6 finish in 64 s). At the end of a round its own
    // validation runs before the next round's first generation: reserve both.
    let val_s = gen_s * 3.0 * val / per_gen;
    let round_end = g % settings.generations.max(1) == 0;
    let next = gen_s + val_s * if round_end { 2.0 } else { 1.0 };
    elapsed_s + 1.2 * next < limit_s
}

struct RobustOutput<'a> {
    result: &'a mesopush_host::plan::RobustResult,
    est: &'a mesopush_host::plan::Estimate,
    feasible: bool,
    planning_ms: f64,
    train: usize,
    pushes: usize,
    time_limited: bool,
    check_seed: u64,
    validation_samples: usize,
}

fn print_robust(args: &PlanArgs, o: &RobustOutput<'_>) {
    let (r, est, feasible, planning_ms) = (o.result, o.est, o.feasible, o.planning_ms);
    let summary = json!({
        "found": true, "robust": true, "nominal_feasible": feasible,
        "success_rate": est.success_rate, "ci_low": est.ci_low, "ci_high": est.ci_high,
        "samples": est.samples, "check_seed": o.check_seed, "training_rate": r.training_rate,
        "validation_rate": r.validation_rate, "replays": r.trials,
        "time_limited": o.time_limited,
        "pushes": o.pushes, "moves": r.plan.moves_um.len(), "travel_um": r.plan.travel_um(),
        "iterations": r.evaluations, "generations": r.generations, "rounds": r.rounds,
        "validation_samples": o.validation_samples,
        "planning_ms": planning_ms, "seed": args.seed, "plan": &args.out,
        "parameters": mesopush_host::plan::skeleton::NAMES.iter().zip(r.skeleton.params)
            .map(|(n, v)| (n.to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
    });
    if args.json {
        println!("{summary}");
    } else {
        println!(
            "robust plan: {} (nominal replay {})",
            args.out.display(),
            if feasible { "inserts" } else { "does NOT insert" }
        );
        println!(
            "success on {} fresh trials: {:.1} % (95 % interval {:.1}–{:.1} %); on the {} training worlds {:.1} %",
            est.samples,
            100.0 * est.success_rate,
            100.0 * est.ci_low,
            100.0 * est.ci_high,
            o.train,
            100.0 * r.training_rate
        );
        println!(
            "on the {} validation worlds {:.1} %; {} candidates in {} generations of {} \
             rounds ({} replays), {planning_ms:.0} ms{}",
            o.validation_samples,
            100.0 * r.validation_rate.unwrap_or(f64::NAN),
            r.evaluations,
            r.generations,
            r.rounds,
            r.trials,
            if o.time_limited { " (cut by --time-limit-s)" } else { "" }
        );
    }
}
