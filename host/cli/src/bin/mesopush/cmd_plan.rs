//! `mesopush plan`: design a pushing plan and write it as plan TOML. Two modes, one
//! subcommand each: `plan rrt` (the paper's RRT; also what `plan [OPTIONS]` without a mode
//! runs) and `plan robust` (a plan of Table II's shape optimised against the Monte Carlo
//! success rate). Each parses its flags, calls `mesopush_plan` and prints.

use anyhow::Result;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_core::check::Allowed;
use mesopush_core::geom::Pose;
use mesopush_sim::{Fixture, Model, SimSettings, Simulator};
use std::path::{Path, PathBuf};

mod robust;
mod rrt;

/// Design a pushing plan and write it as plan TOML (without a mode: `plan rrt`).
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(crate) struct PlanArgs {
    #[command(subcommand)]
    mode: Option<PlanMode>,
    #[command(flatten)]
    rrt: rrt::RrtArgs,
}

#[derive(Debug, Subcommand)]
enum PlanMode {
    /// The paper's RRT over simulated pushes (the default mode).
    Rrt(rrt::RrtArgs),
    /// Optimise a plan (Table II's shape, a plan file's or the RRT's moves) against the
    /// Monte Carlo success rate under the paper's uncertainty, then check it on fresh draws
    /// (docs/planning.md).
    Robust(robust::RobustArgs),
}

/// The options both modes take.
#[derive(Debug, Args)]
struct CommonArgs {
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
    /// Wall-clock limit of the search, s. Default none: the search's own budget (RRT
    /// iterations, robust replays) alone decides, and the same seed gives the same plan on
    /// any machine and thread count; a limit that stops the search says so.
    #[arg(long, value_parser = crate::ranges::real(Allowed::positive_to(1e6, "s")))]
    time_limit_s: Option<f64>,
    /// Also draw the plan's nominal replay (Fig. 6 style) to this PNG or SVG.
    #[arg(long)]
    figure: Option<PathBuf>,
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

fn load_world(model: Option<&Path>, fixture: Option<&Path>) -> Result<Simulator> {
    let model = model.map_or_else(|| Ok(Model::default()), Model::load)?;
    let fixture = fixture.map_or_else(|| Ok(Fixture::paper()), Fixture::load)?;
    Ok(Simulator::new(model, fixture, SimSettings::default())?)
}

pub(crate) fn run(args: &PlanArgs) -> Result<()> {
    match &args.mode {
        None => rrt::run(&args.rrt),
        Some(PlanMode::Rrt(a)) => rrt::run(a),
        Some(PlanMode::Robust(a)) => robust::run(a),
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
