//! `mesopush diagnose confusion`: parses the experiment's settings, runs
//! [`mesopush_diagnose::confusion::run`] with a log line per batch and a progress bar on
//! stderr, and prints the confusion matrix and the per-batch errors.

use super::cmd_diagnose::{Budgets, effect};
use anyhow::Result;
use clap::Args;
use indicatif::ProgressBar;
use mesopush_diagnose::confusion::{self, ConfusionSettings};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub(crate) struct ConfusionArgs {
    /// Batches per true effect (seeds --seed, --seed + 1, ...).
    #[arg(long, default_value_t = 3)]
    seeds: usize,
    /// Only these true effects (comma-separated library names, `none` for the clean
    /// control); default every effect and the clean control.
    #[arg(long, value_delimiter = ',', value_name = "EFFECTS")]
    only: Vec<String>,
    /// Seed of each effect's first batch.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory the batches are written to (`<effect>-<seed>` each).
    #[arg(long, default_value = "runs/diagnose")]
    out: PathBuf,
    /// Trials per batch.
    #[arg(long, default_value_t = 6)]
    n_trials: usize,
    /// Strokes per synthetic trial.
    #[arg(long, default_value_t = 3)]
    strokes: usize,
    #[command(flatten)]
    budgets: Budgets,
}

pub(crate) fn run(args: &ConfusionArgs) -> Result<()> {
    let mut settings = ConfusionSettings::new(&args.out);
    if !args.only.is_empty() {
        settings.truths = args.only.iter().map(|n| effect(n)).collect::<Result<_>>()?;
    }
    settings.seeds = args.seeds;
    settings.first_seed = args.seed;
    settings.n_trials = args.n_trials;
    settings.strokes = args.strokes;
    settings.options = args.budgets.options();
    let started = std::time::Instant::now();
    let pb = ProgressBar::new((settings.truths.len() * settings.seeds) as u64);
    let report = confusion::run(&settings, &mut |truth, seed, outcome| {
        eprintln!("{}", confusion::batch_line(truth, seed, outcome));
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    eprintln!("{} batches in {:.0} s", report.rows.len(), started.elapsed().as_secs_f64());
    print!("{}", report.text());
    Ok(())
}
