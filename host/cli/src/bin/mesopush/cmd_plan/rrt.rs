//! `mesopush plan rrt`: the paper's RRT from the flags, its summary printed.

use super::{CommonArgs, bar, load_world};
use anyhow::{Context, Result};
use clap::Args;
use mesopush_core::check::Allowed;
use mesopush_plan::figures::draw_replayed_plan;
use mesopush_plan::pushes::PushSettings;
use mesopush_plan::{RrtProgress, RrtSettings, plan_rrt_within};
use mesopush_sim::Plan;
use mesopush_sim::start::check_start;
use serde_json::json;

/// The RRT's options.
#[derive(Debug, Args)]
pub(super) struct RrtArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// RRT iterations before giving up.
    #[arg(long, default_value_t = RrtSettings::default().max_iterations, value_parser = crate::ranges::at_least_one())]
    max_iterations: usize,
    /// Random pushes simulated per iteration.
    #[arg(long, default_value_t = RrtSettings::default().inputs_per_iteration, value_parser = crate::ranges::count(1, 100_000))]
    inputs: usize,
    /// Pushing locations on the peg boundary.
    #[arg(long, default_value_t = PushSettings::default().n_locations, value_parser = crate::ranges::count(4, 4096))]
    locations: usize,
    /// Most push drops the shortcut pass tries on the found branch (0: keep it as found).
    #[arg(long, default_value_t = RrtSettings::default().shortcut_attempts, value_parser = crate::ranges::count(0, 1_000_000))]
    shortcut_attempts: usize,
    /// Orientation window of the goal connection while shortcutting, degrees.
    #[arg(long, default_value_t = RrtSettings::default().shortcut_connect_theta_deg, value_parser = crate::ranges::real(Allowed::positive_to(180.0, "°")))]
    shortcut_connect_deg: f64,
}

pub(super) fn run(args: &RrtArgs) -> Result<()> {
    let c = &args.common;
    let mut sim = load_world(c.model.as_deref(), c.fixture.as_deref())?;
    let start = c.start.unwrap_or_else(|| Plan::table2().peg_start_pose());
    check_start(&mut sim, "--start", start, None)?;
    let settings = RrtSettings {
        max_iterations: args.max_iterations,
        inputs_per_iteration: args.inputs,
        shortcut_attempts: args.shortcut_attempts,
        shortcut_connect_theta_deg: args.shortcut_connect_deg,
        pushes: PushSettings { n_locations: args.locations, ..Default::default() },
        ..Default::default()
    };
    let bar = bar(settings.max_iterations as u64, c.json);
    let mut on_progress = |p: RrtProgress| {
        bar.set_position(p.iteration as u64);
        bar.set_message(format!("tree {}", p.tree_size));
    };
    let limit_s = c.time_limit_s.unwrap_or(f64::INFINITY);
    let run = plan_rrt_within(&mut sim, start, &settings, c.seed, limit_s, &mut on_progress)?;
    bar.finish_and_clear();
    let (result, planning_ms) = (&run.result, run.planning_ms);
    let found = result.plan.is_some();
    let (moves, travel) =
        result.plan.as_ref().map_or((0, 0.0), |p| (p.moves_um.len(), p.travel_um()));
    if let Some(plan) = &result.plan {
        std::fs::write(&c.out, plan.to_toml())
            .with_context(|| format!("writing {}", c.out.display()))?;
        if let Some(fig) = &c.figure {
            draw_replayed_plan(&mut sim, plan, fig)?;
        }
    }
    let summary = json!({
        "found": found, "pushes": result.pushes,
        "pushes_before_shortcut": result.pushes_before_shortcut,
        "shortcut_attempts": result.shortcut_attempts, "moves": moves, "travel_um": travel,
        "iterations": result.iterations, "tree_size": result.tree_size,
        "stopped_by_time": result.plan.is_none() && result.iterations < settings.max_iterations
            && planning_ms / 1e3 >= limit_s,
        "simulated_pushes": result.simulated_pushes,
        "rejected_at_verification": result.rejected_at_verification,
        "overloaded_pushes": result.overloaded_pushes,
        "planning_ms": planning_ms, "seed": c.seed,
        "plan": if found { Some(&c.out) } else { None },
    });
    if c.json {
        println!("{summary}");
    } else {
        print_text(&summary);
    }
    if !found && !c.json {
        let why =
            format!("no plan found in {} iterations ({planning_ms:.0} ms)", result.iterations);
        return Err(crate::verdict::Negative(why).into());
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
        "iterations: {}, tree size: {}, pushes simulated: {} ({} rejected: they overload the \
         needle)",
        s["iterations"], s["tree_size"], s["simulated_pushes"], s["overloaded_pushes"]
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
