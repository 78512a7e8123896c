//! `mesopush plan robust`: the robust search's settings and start from the flags (Table II's
//! skeleton, the shipped design, a plan file, or what the RRT finds), the search (with its
//! replay budget and fresh check, `mesopush_plan::search_robust`), the plan written and the
//! report printed — unless its nominal replay bends the needle beyond the model's limit: then no
//! plan is written and the command exits 1 saying so.

use super::{CommonArgs, bar, load_world};
use anyhow::{Context, Result, bail};
use clap::Args;
use mesopush_core::check::Allowed;
use mesopush_plan::figures::draw_replayed_plan;
use mesopush_plan::rrt_starts::{RrtStart, SCREEN_SAMPLES, best_rrt_plan, rrt_screen_seed_for};
use mesopush_plan::staged::{DEFAULT_FIRST_STAGE_SHARE, Refine, Stage2};
use mesopush_plan::wall_press::WallPressSettings;
use mesopush_plan::{
    Init, RobustReport, RobustSearch, RobustSettings, RrtSettings, UncertainWorld, search_robust,
};
use mesopush_sim::start::check_start;
use mesopush_sim::support_set::SupportSet;
use mesopush_sim::{Plan, Simulator};
use serde_json::json;
use std::path::PathBuf;

/// The robust search's options.
#[derive(Debug, Args)]
pub(super) struct RobustArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// CEM generations per round.
    #[arg(long, default_value_t = RobustSettings::default().generations, value_parser = crate::ranges::at_least_one())]
    generations: usize,
    /// Sampled worlds each candidate is scored on.
    #[arg(long, default_value_t = RobustSettings::default().samples, value_parser = crate::ranges::count(2, 1_000_000))]
    train_samples: usize,
    /// Simulator step of the training replays, µm (validation and the check use the
    /// full-fidelity default).
    #[arg(long, default_value_t = RobustSettings::default().train_step_um, value_parser = crate::ranges::step_um())]
    train_step_um: f64,
    /// Score every generation on one common set of training worlds instead of drawing new
    /// ones each generation.
    #[arg(long)]
    common_worlds: bool,
    /// Scale of the uncertainty box the training worlds are drawn from (the validation and
    /// the check use the default box).
    #[arg(long, default_value_t = RobustSettings::default().train_scale, value_parser = crate::ranges::real(Allowed::positive_to(100.0, "")))]
    train_scale: f64,
    /// Most CEM rounds (another runs only while no finalist reaches --accept-rate on the
    /// validation worlds).
    #[arg(long, default_value_t = RobustSettings::default().rounds, value_parser = crate::ranges::at_least_one())]
    rounds: usize,
    /// Validation success rate that ends the search after a round (above 1: never reached,
    /// every round runs).
    #[arg(long, default_value_t = RobustSettings::default().accept_rate,
          value_parser = crate::ranges::real(Allowed::closed(0.0, 2.0, "")))]
    accept_rate: f64,
    /// Start the search at the shipped design (plans/robust.toml's parameters) instead of
    /// Table II's numbers with the press on the rotated peg's right end. It then refines that
    /// design and mostly returns it unchanged: a check of the shipped plan, not a design from
    /// scratch.
    #[arg(long, conflicts_with_all = ["from_table2", "from_plan", "from_rrt"])]
    from_shipped: bool,
    /// Start the search at Table II's numbers alone (the press over the middle of the
    /// rotated peg, at the height that centres a level one); it finds a design of 95 % or
    /// more less often than the default start (docs/planning.md).
    #[arg(long, conflicts_with_all = ["from_plan", "from_rrt"])]
    from_table2: bool,
    /// Start from this plan TOML (any plan for this model and fixture) and search its moves:
    /// every move's end may shift along its axis by up to --move-radius-um. The peg start is
    /// the plan's unless --start is given.
    #[arg(long, conflicts_with = "from_rrt")]
    from_plan: Option<PathBuf>,
    /// Start from the plan the paper's RRT finds (default RRT settings, --seed, --start) and
    /// search its moves as --from-plan does: for parts and fixtures other than Table II's.
    #[arg(long)]
    from_rrt: bool,
    /// With --from-rrt: run the RRT from this many seeds (the first is --seed) and start from
    /// the plan that succeeds most often on 64 screening worlds.
    /// (The RRT runs are bounded by their iterations, not by --time-limit-s.)
    #[arg(long, default_value_t = 8, requires = "from_rrt", value_parser = crate::ranges::count(1, 1000))]
    rrt_starts: usize,
    /// How far each move's end may shift with --from-plan / --from-rrt, µm (default: 0.1 ×
    /// the part's diameter, 189 µm for the paper's peg).
    #[arg(long, value_parser = crate::ranges::real(Allowed::positive_to(1e5, "µm")))]
    move_radius_um: Option<f64>,
    /// Candidate support distributions the sampled worlds draw from (TOML `[[support]]` or
    /// JSON list), e.g. what `identify --consistent-out` wrote: each world draws one member,
    /// with its own probe and surface friction when it has them (a fitted pair); default:
    /// the model's support perturbed by ±100 µm, as `robustness` does.
    #[arg(long)]
    supports: Option<PathBuf>,
    /// Two stages: after the design over the start family, insert the best of the presses
    /// of the part against a wall before the first move (an uncertainty-removing move,
    /// ranked on 64 screening worlds) and search all the plan's moves again; the result replaces stage 1's plan only if it succeeds on more of 1000
    /// common worlds. The stages share --max-replays (stage 1 gets --first-stage-share).
    #[arg(long, conflicts_with = "refine_moves")]
    wall_press: bool,
    /// Two stages as --wall-press, without the press: stage 2 searches stage 1's moves as
    /// they are (the like-for-like comparison for --wall-press).
    #[arg(long)]
    refine_moves: bool,
    /// With --wall-press or --refine-moves: stage 1's share of --max-replays (0.5 reproduces
    /// the two-stage designs measured before 2026-11-28).
    #[arg(long, default_value_t = DEFAULT_FIRST_STAGE_SHARE, value_parser = crate::ranges::real(Allowed::closed(0.05, 0.95, "")))]
    first_stage_share: f64,
    /// Budget of the whole design in plan replays (training, validation, confirmation): the
    /// search stops where the next generation would not fit. Same seed and budget, same
    /// plan, on any machine and thread count.
    #[arg(long, default_value_t = RobustSettings::default().max_replays, value_parser = crate::ranges::count(1, 1_000_000_000))]
    max_replays: usize,
    /// Candidates per CEM generation.
    #[arg(long, default_value_t = RobustSettings::default().population, value_parser = crate::ranges::count(2, 1_000_000))]
    population: usize,
    /// Best candidates that set the next generation's distribution.
    #[arg(long, default_value_t = RobustSettings::default().elite, value_parser = crate::ranges::at_least_one())]
    elite: usize,
    /// Candidates re-scored on the validation worlds.
    #[arg(long, default_value_t = RobustSettings::default().finalists, value_parser = crate::ranges::at_least_one())]
    finalists: usize,
    /// Validation worlds the best candidates are re-scored on.
    #[arg(long, default_value_t = RobustSettings::default().validation_samples, value_parser = crate::ranges::at_least_one())]
    validation_samples: usize,
    /// The most validated finalists re-scored on fresh confirmation worlds.
    #[arg(long, default_value_t = RobustSettings::default().confirm_top, value_parser = crate::ranges::at_least_one())]
    confirm_top: usize,
    /// Confirmation worlds (0: the most validated finalist wins).
    #[arg(long, default_value_t = RobustSettings::default().confirm_samples, value_parser = crate::ranges::count(0, 10_000_000))]
    confirm_samples: usize,
    /// Fresh Monte Carlo trials for the reported success rate.
    #[arg(long, default_value_t = RobustSearch::default().check_samples, value_parser = crate::ranges::at_least_one())]
    check_samples: usize,
    /// Master seed of the fresh check (default: derived from --seed, never the design's own
    /// draws).
    #[arg(long)]
    check_seed: Option<u64>,
}

pub(super) fn run(args: &RobustArgs) -> Result<()> {
    let c = &args.common;
    if args.elite > args.population {
        bail!(
            "invalid --elite = {}: allowed 1..={} (at most --population)",
            args.elite,
            args.population
        );
    }
    let mut sim = load_world(c.model.as_deref(), c.fixture.as_deref())?;
    let from_plan = match &args.from_plan {
        Some(path) => Some(Plan::load(path)?),
        None => None,
    };
    let mut start = from_plan.as_ref().map_or(Plan::table2().peg_start, |p| p.peg_start);
    if let Some(p) = c.start {
        (start.x_um, start.y_um, start.theta_deg) = (p.x_um, p.y_um, p.theta_rad.to_degrees());
    }
    let what = match (c.start, &args.from_plan) {
        (Some(_), _) => "--start",
        (None, Some(_)) => "the --from-plan plan's peg_start",
        (None, None) => "Table II's peg start",
    };
    check_start(&mut sim, what, start.pose(), None)?;
    let (model, fixture) = (sim.model().clone(), sim.fixture().clone());
    let sim_settings = sim.settings().clone();
    let supports = match &args.supports {
        Some(p) => SupportSet::load(p, &model.part)?.support,
        None => Vec::new(),
    };
    let world = UncertainWorld {
        supports: &supports,
        ..UncertainWorld::nominal(&model, &fixture, &sim_settings)
    };
    let (init, rrt_start) = init(args, &mut sim, &world, from_plan, start)?;
    let search = RobustSearch {
        design: robust_settings(args),
        init,
        move_radius_um: args.move_radius_um,
        refine: if args.wall_press {
            Some(Refine::WallPress(WallPressSettings { at_start_only: true, ..Default::default() }))
        } else {
            args.refine_moves.then_some(Refine::Moves)
        },
        first_stage_share: args.first_stage_share,
        seed: c.seed,
        time_limit_s: c.time_limit_s,
        check_samples: args.check_samples,
        check_seed: args.check_seed,
    };
    let stages = if search.refine.is_some() { 2 } else { 1 };
    let bar = bar((search.design.generations * search.design.rounds * stages) as u64, c.json);
    let mut on_progress = |g: usize, best: f64| {
        bar.set_position(g as u64);
        bar.set_message(format!("best {:.1} %", 100.0 * best));
    };
    let report = search_robust(&world, start, &search, &mut on_progress)?;
    bar.finish_and_clear();
    if let Some(o) = &report.nominal_overload {
        print(c, &report, rrt_start.as_ref(), false);
        let why = format!("the designed plan is refused and was not written: {o}");
        return Err(crate::verdict::Negative(why).into());
    }
    let plan = &report.design.plan;
    std::fs::write(&c.out, plan.to_toml())
        .with_context(|| format!("writing {}", c.out.display()))?;
    if let Some(fig) = &c.figure {
        draw_replayed_plan(&mut sim, plan, fig)?;
    }
    print(c, &report, rrt_start.as_ref(), true);
    Ok(())
}

/// Where the search starts: the flags' choice (the RRT run here when asked: with
/// `--rrt-starts N`, from N seeds, the most successful plan on 64 screening worlds).
fn init(
    args: &RobustArgs,
    sim: &mut Simulator,
    world: &UncertainWorld<'_>,
    from_plan: Option<Plan>,
    start: mesopush_sim::plan::PegStart,
) -> Result<(Init, Option<RrtStart>)> {
    if let Some(plan) = from_plan {
        return Ok((Init::Plan { plan }, None));
    }
    if args.from_rrt {
        let seed = args.common.seed;
        let starts = (seed, args.rrt_starts);
        let screen = (SCREEN_SAMPLES, rrt_screen_seed_for(seed));
        let rrt = RrtSettings::default();
        let Some(found) = best_rrt_plan(sim, start.pose(), &rrt, world, starts, screen)? else {
            let why = format!(
                "the RRT found no plan to start from in {} run(s) of {} iterations (seed {seed}); \
                 try another --seed, more --rrt-starts, or --from-plan",
                args.rrt_starts, rrt.max_iterations
            );
            return Err(crate::verdict::Negative(why).into());
        };
        return Ok((Init::Plan { plan: found.plan.clone() }, Some(found)));
    }
    let init = if args.from_shipped {
        Init::Shipped
    } else {
        Init::Table2 { press_on_rotated: !args.from_table2 }
    };
    Ok((init, None))
}

/// The optimiser's settings from the flags.
fn robust_settings(args: &RobustArgs) -> RobustSettings {
    RobustSettings {
        generations: args.generations,
        samples: args.train_samples,
        validation_samples: args.validation_samples,
        train_step_um: args.train_step_um,
        resample: !args.common_worlds,
        train_scale: args.train_scale,
        finalists: args.finalists,
        population: args.population,
        rounds: args.rounds,
        accept_rate: args.accept_rate,
        confirm_top: args.confirm_top,
        confirm_samples: args.confirm_samples,
        elite: args.elite,
        max_replays: args.max_replays,
        ..Default::default()
    }
}

/// The `--json` summary; `written`: the plan was written to `--out` (not refused).
fn summary(
    c: &CommonArgs,
    o: &RobustReport,
    rrt: Option<&RrtStart>,
    written: bool,
) -> serde_json::Value {
    let (r, est) = (&o.design, &o.check);
    json!({
        "found": written, "robust": true, "nominal_feasible": o.nominal_feasible,
        "nominal_overload": o.nominal_overload,
        "success_rate": est.success_rate, "ci_low": est.ci_low, "ci_high": est.ci_high,
        "samples": est.samples, "check_seed": o.check_seed, "training_rate": r.training_rate,
        "validation_rate": r.validation_rate, "confirmation_rate": r.confirmation_rate,
        "replays": r.trials,
        "stopped_by_time": o.stopped_by_time, "out_of_budget": r.out_of_budget,
        "max_replays": o.max_replays,
        "pushes": o.pushes, "moves": r.plan.moves_um.len(), "travel_um": r.plan.travel_um(),
        "iterations": r.evaluations, "generations": r.generations, "rounds": r.rounds,
        "validation_samples": o.validation_samples, "confirmation_samples": o.confirmation_samples,
        "planning_ms": o.planning_ms, "seed": c.seed,
        "plan": if written { Some(&c.out) } else { None },
        "total_replays": o.total_replays,
        "stage2": o.stage2.as_ref().map(stage2_json),
        "first_stage_share": o.first_stage_share,
        "rrt_start": rrt.map(|r| json!({
            "seed": r.seed, "successes": r.successes, "screen_samples": r.samples,
            "runs": r.runs.iter().map(|(s, n)| json!({"seed": s, "successes": n})).collect::<Vec<_>>(),
        })),
        "parameters": o.param_names.iter().zip(&r.params)
            .map(|(n, v)| (n.to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
    })
}

/// The second stage in the `--json` summary.
fn stage2_json(st: &Stage2) -> serde_json::Value {
    let rates = |d: &mesopush_plan::RobustResult| {
        json!({
            "validation_rate": d.validation_rate, "confirmation_rate": d.confirmation_rate,
            "training_rate": d.training_rate, "replays": d.trials, "generations": d.generations,
        })
    };
    json!({
        "first": rates(&st.first),
        "second": st.second.as_ref().map(rates),
        "press": st.press.map(|(after, dir, gap)| json!({
            "after_move": after, "before_first_move": after.is_none(),
            "direction": dir, "gap_um": gap,
        })),
        "screened_variants": st.screened.as_ref().map(|s| s.variants),
        "screen_samples": st.screened.as_ref().map(|s| s.samples),
        "choice": st.choice.map(|c| json!({
            "samples": c.samples, "first_successes": c.first, "second_successes": c.second,
            "second_wins": c.second_wins(),
        })),
        "skipped": st.skipped,
        "without_press": st.without_press,
    })
}

/// Prints the report (the summary with `--json`).
fn print(c: &CommonArgs, o: &RobustReport, rrt: Option<&RrtStart>, written: bool) {
    let (r, est) = (&o.design, &o.check);
    let summary = summary(c, o, rrt, written);
    if c.json {
        println!("{summary}");
        return;
    }
    let inserts = if o.nominal_feasible { "inserts" } else { "does NOT insert" };
    if written {
        println!("robust plan: {} (nominal replay {inserts})", c.out.display());
    } else {
        println!("robust plan: NOT written (its nominal replay overloads the needle)");
    }
    println!(
        "success on {} fresh trials: {:.1} % (95 % interval {:.1}–{:.1} %); on the {} training worlds {:.1} %",
        est.samples,
        100.0 * est.success_rate,
        100.0 * est.ci_low,
        100.0 * est.ci_high,
        o.training_samples,
        100.0 * r.training_rate
    );
    println!(
        "on the {} validation worlds {:.1} %; {} candidates in {} generations of {} \
         rounds ({} replays), {:.0} ms{}",
        o.validation_samples,
        100.0 * r.validation_rate.unwrap_or(f64::NAN),
        r.evaluations,
        r.generations,
        r.rounds,
        r.trials,
        o.planning_ms,
        if o.stopped_by_time {
            " (stopped by --time-limit-s: the plan depends on this machine's speed)"
        } else {
            ""
        }
    );
    if let Some(conf) = r.confirmation_rate {
        println!("on the {} confirmation worlds {:.1} %", o.confirmation_samples, 100.0 * conf);
    }
    print_start_moves(o, rrt);
}

/// Where the search started: the RRT starts and the wall presses, in words.
fn print_start_moves(o: &RobustReport, rrt: Option<&RrtStart>) {
    if let Some(r) = rrt {
        let found = r.runs.iter().filter(|x| x.1.is_some()).count();
        println!(
            "started from the RRT plan of seed {} ({} of {} screening worlds; {found} of {} RRT \
             runs found a plan)",
            r.seed,
            r.successes,
            r.samples,
            r.runs.len()
        );
    }
    let Some(st) = &o.stage2 else { return };
    if let Some((after, dir, gap)) = st.press {
        let at = after.map_or("before the first move".to_string(), |k| format!("after move {k}"));
        println!("stage 2: a press towards {dir} {at} (gap {gap:.0} µm), then every move re-tuned");
    }
    if let Some(why) = &st.without_press {
        println!("stage 2: {why}; every move re-tuned without one");
    }
    match (&st.second, &st.choice, &st.skipped) {
        (Some(_), Some(c), _) => println!(
            "stage 1's plan succeeded on {} of {} common worlds, stage 2's on {}: {}",
            c.first,
            c.samples,
            c.second,
            if c.second_wins() { "stage 2's plan returned" } else { "stage 1's plan returned" }
        ),
        (_, _, Some(why)) => println!("stage 2 did not run ({why}): stage 1's plan returned"),
        _ => {}
    }
}
