//! `mesopush plan`: design a pushing plan with the paper's RRT (or, with `--robust`, a plan
//! optimised against the Monte Carlo success rate) and write it as plan TOML.

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_core::geom::Pose;
use mesopush_plan::{Progress, RobustSettings, RrtSettings, plan_rrt};
use mesopush_plot::{PlanFigure, draw_plan};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
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
    /// parameters) instead of Table II's numbers with the press on the rotated peg's right
    /// end. It then refines that design and mostly returns it unchanged: a check of the
    /// shipped plan, not a design from scratch.
    #[arg(long, conflicts_with = "from_table2")]
    from_shipped: bool,
    /// With --robust: start the search at Table II's numbers alone (the press over the
    /// middle of the rotated peg, at the height that centres a level one), the default before
    /// issue 6's fifth round; it finds a design of 95 % or more less often (docs/planning.md).
    #[arg(long)]
    from_table2: bool,
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
    /// With --robust: the most validated finalists re-scored on fresh confirmation worlds.
    #[arg(long, default_value_t = RobustSettings::default().confirm_top)]
    confirm_top: usize,
    /// With --robust: confirmation worlds (0: the most validated finalist wins).
    #[arg(long, default_value_t = RobustSettings::default().confirm_samples)]
    confirm_samples: usize,
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

mod robust;

pub(crate) fn run(args: &PlanArgs) -> Result<()> {
    let mut sim = load_world(args.model.as_deref(), args.fixture.as_deref())?;
    if args.robust {
        return robust::run_robust(args, &mut sim);
    }
    let start = args.start.unwrap_or_else(|| Plan::table2().peg_start_pose());
    let settings = RrtSettings {
        max_iterations: args.max_iterations,
        inputs_per_iteration: args.inputs.max(1),
        shortcut_attempts: args.shortcut_attempts,
        shortcut_connect_theta_deg: args.shortcut_connect_deg,
        pushes: mesopush_plan::pushes::PushSettings {
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
