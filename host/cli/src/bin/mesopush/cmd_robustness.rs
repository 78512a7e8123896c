//! `mesopush robustness`: Monte Carlo success probability of one or more plans under the
//! paper's uncertainty (start pose, supports, friction), with a 95 % Wilson interval, a plot
//! of where failures come from and, with `--sweep`, success against the uncertainty's size.
//! `robustness run` (also what `robustness PLAN...` without a subcommand runs) estimates,
//! or runs one shard; `robustness merge` merges shards. The work is
//! `mesopush_plan::robustness`; this module parses and prints.

use crate::cmd_plan::bar;
use anyhow::Result;
use clap::{Args, Subcommand};
use mesopush_core::check::Allowed;
use mesopush_core::shard::Shard;
use mesopush_plan::Uncertainty;
use mesopush_plan::robustness::{PlanRow, RobustnessRun, ShardRow, merge_shards};
use mesopush_sim::support_set::SupportSet;
use mesopush_sim::{Fixture, Model};
use serde_json::json;
use std::path::PathBuf;

/// Monte Carlo success probability of plans (without a subcommand: `robustness run`).
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(crate) struct RobustnessArgs {
    #[command(subcommand)]
    command: Option<RobustnessCommand>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Debug, Subcommand)]
enum RobustnessCommand {
    /// Estimate plans' success under start-pose, support and friction error (the default).
    Run(RunArgs),
    /// Merge `robustness run --shard` outputs into the unsplit run's estimate, figure and CSV.
    Merge(MergeArgs),
}

/// Estimate plans' success probability.
#[derive(Debug, Args)]
struct RunArgs {
    /// Plan TOML files (several: one row each, `--markdown` prints them as a table).
    #[arg(required = true)]
    plans: Vec<PathBuf>,
    /// Trials per plan.
    #[arg(long, default_value_t = 200, value_parser = crate::ranges::at_least_one())]
    samples: usize,
    /// Master seed (trial i draws from its own stream: same seed, same result).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Model TOML; default: the nominal model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Candidate support distributions (TOML `[[support]]` or JSON list; docs/planning.md),
    /// e.g. what `identify --consistent-out` wrote: a member with `mu_probe` is drawn with
    /// its own probe and surface friction (a fitted pair); default: the model's support
    /// perturbed by ±`--support-um`.
    #[arg(long, conflicts_with = "support_um")]
    supports: Option<PathBuf>,
    /// Fixture TOML; default: the reconstructed paper fixture.
    #[arg(long)]
    fixture: Option<PathBuf>,
    /// Start x error, ± µm.
    #[arg(long, default_value_t = Uncertainty::default().dx_um, value_parser = crate::ranges::length_um(10_000.0))]
    dx_um: f64,
    /// Start y error, ± µm.
    #[arg(long, default_value_t = Uncertainty::default().dy_um, value_parser = crate::ranges::length_um(10_000.0))]
    dy_um: f64,
    /// Start orientation error, ± degrees.
    #[arg(long, default_value_t = Uncertainty::default().dtheta_deg, value_parser = crate::ranges::real(Allowed::closed(0.0, 180.0, "°")))]
    dtheta_deg: f64,
    /// Friction error, ± (on μ_probe, μ_wall and each support's μ).
    #[arg(long, default_value_t = Uncertainty::default().dmu, value_parser = crate::ranges::real(Allowed::closed(0.0, 2.0, "")))]
    dmu: f64,
    /// Support point error when no --supports set is given, ± µm per coordinate.
    #[arg(long, default_value_t = Uncertainty::default().support_um, value_parser = crate::ranges::length_um(10_000.0))]
    support_um: f64,
    /// Also sweep the uncertainty box's scale over 0.5, 0.75, 1, 1.5, 2 and plot it.
    #[arg(long)]
    sweep: bool,
    /// Output directory for the figures and the per-trial CSV (`trials_PLAN.csv`).
    #[arg(long, default_value = "runs/robustness")]
    out: PathBuf,
    /// Print a Markdown table row per plan (name, success, interval, pushes, travel).
    #[arg(long, conflicts_with = "json")]
    markdown: bool,
    /// Print JSON (one object; with several plans, `{"plans": [...]}`).
    #[arg(long)]
    json: bool,
    /// Run only trials i ≡ I (mod N) of the `--samples` (`I/N`), writing
    /// `shard_PLAN.json` into `--out` for `robustness merge` (docs/batch.md, Scale).
    #[arg(long, value_name = "I/N", conflicts_with_all = ["sweep", "markdown"])]
    shard: Option<String>,
}

/// Merge `robustness run --shard` outputs of one run.
#[derive(Debug, Args)]
struct MergeArgs {
    /// Shard files (`shard_PLAN.json`) or directories holding them; files of the same name
    /// are one plan's shards.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Output directory for the merged figures and per-trial CSV.
    #[arg(long, default_value = "runs/robustness-merged")]
    out: PathBuf,
    /// Print a Markdown table row per plan.
    #[arg(long, conflicts_with = "json")]
    markdown: bool,
    /// Print JSON (one object; with several plans, `{"plans": [...]}`).
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &RobustnessArgs) -> Result<()> {
    match &args.command {
        None => estimate(&args.run),
        Some(RobustnessCommand::Run(a)) => estimate(a),
        Some(RobustnessCommand::Merge(a)) => merge(a),
    }
}

fn estimate(args: &RunArgs) -> Result<()> {
    let model = args.model.as_deref().map_or_else(|| Ok(Model::default()), Model::load)?;
    let fixture = args.fixture.as_deref().map_or_else(|| Ok(Fixture::paper()), Fixture::load)?;
    let supports = match &args.supports {
        Some(p) => SupportSet::load(p, &model.part)?.support,
        None => Vec::new(),
    };
    let run = RobustnessRun {
        model: &model,
        fixture: &fixture,
        supports: &supports,
        uncertainty: Uncertainty {
            dx_um: args.dx_um,
            dy_um: args.dy_um,
            dtheta_deg: args.dtheta_deg,
            dmu: args.dmu,
            support_um: args.support_um,
        },
        samples: args.samples,
        seed: args.seed,
        sweep: args.sweep,
        out: &args.out,
    };
    if let Some(s) = args.shard.as_deref().map(Shard::parse).transpose()? {
        let bar = bar(run.shard_trial_count(args.plans.len(), s), args.json);
        let rows = run.run_shard(&args.plans, s, &|| bar.inc(1))?;
        bar.finish_and_clear();
        print_shards(&rows, args.json);
        return Ok(());
    }
    let bar = bar(run.trial_count(args.plans.len()), args.json);
    let report = run.run(&args.plans, &|| bar.inc(1))?;
    bar.finish_and_clear();
    if let (Some(fig), false) = (&report.sweep_figure, args.json) {
        println!("sweep figure: {}", fig.display());
    }
    print(&report.rows, args.json, args.markdown);
    Ok(())
}

fn merge(args: &MergeArgs) -> Result<()> {
    let rows = merge_shards(&args.shards, &args.out)?;
    print(&rows, args.json, args.markdown);
    Ok(())
}

/// One JSON value: the only row, or `{"plans": [...]}`.
fn one_value<T: serde::Serialize>(rows: &[T]) -> serde_json::Value {
    if rows.len() == 1 { json!(rows[0]) } else { json!({ "plans": rows }) }
}

fn print_shards(rows: &[ShardRow], json: bool) {
    if json {
        println!("{}", one_value(rows));
        return;
    }
    for r in rows {
        println!(
            "{}: shard {}, {} of {} trials inserted: {}",
            r.plan,
            r.shard,
            r.successes,
            r.trials,
            r.shard_file.display()
        );
    }
}

fn print(rows: &[PlanRow], json: bool, markdown: bool) {
    if json {
        println!("{}", one_value(rows));
        return;
    }
    if markdown {
        println!("| plan | success | 95 % interval | pushes | moves | probe travel [µm] |");
        println!("|---|---|---|---|---|---|");
    }
    for r in rows {
        if markdown {
            println!(
                "| {} | {:.1} % | {:.1}–{:.1} % | {} | {} | {:.0} |",
                r.name,
                100.0 * r.success_rate,
                100.0 * r.ci_low,
                100.0 * r.ci_high,
                r.pushes_nominal,
                r.moves,
                r.travel_um
            );
            continue;
        }
        println!("{} ({}):", r.name, r.plan.display());
        println!(
            "  success {}/{} = {:.1} % (95 % Wilson interval {:.1}–{:.1} %), jammed {}, \
             needle overloaded {}, simulator errors {}",
            r.successes,
            r.samples,
            100.0 * r.success_rate,
            100.0 * r.ci_low,
            100.0 * r.ci_high,
            r.jammed,
            r.overloaded,
            r.sim_errors
        );
        println!("  failures figure: {}", r.failures_figure.display());
    }
}
