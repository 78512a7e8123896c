//! `mesopush diagnose run|synth|rig|confusion`: find what the model lacks in measured trials
//! (held-out residuals, their structure, attribution to a library effect), report
//! before/after errors and write the extended model TOML; make synthetic or whole-loop
//! batches with one undeclared effect; run the confusion-matrix experiment.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_diagnose::confusion::{self, ConfusionSettings};
use mesopush_diagnose::data::load_split;
use mesopush_diagnose::heldout::heldout_by_group;
use mesopush_diagnose::report;
use mesopush_diagnose::rig_batch::write_rig_batch;
use mesopush_diagnose::synth::write_batch;
use mesopush_diagnose::{Diagnosis, Effect, Options, diagnose};
use std::path::{Path, PathBuf};

/// Diagnose trials: residuals, their structure, the missing effect, before/after errors.
#[derive(Debug, Args)]
pub(crate) struct DiagnoseArgs {
    #[command(subcommand)]
    mode: Mode,
}

#[derive(Debug, Subcommand)]
enum Mode {
    /// Diagnose trial directories: held-out residuals, their structure, the missing effect,
    /// before/after errors; writes report.md, summary.json, residuals.png and the models.
    Run(RunArgs),
    /// Make a synthetic batch with one undeclared library effect (or none).
    Synth(SynthArgs),
    /// Make a batch through the whole loop (executor, firmware simulator, camera, tracker;
    /// simulated time) in a world file whose `[effects]` the host is never told.
    Rig(RigArgs),
    /// Blind diagnoses of synthetic batches of every effect and clean controls: the
    /// confusion matrix and before/after errors.
    Confusion(ConfusionArgs),
    /// Held-out prediction across start conditions: each group of runs (one start) replayed
    /// open-loop by the nominal model identified on the other groups, its final-pose error
    /// next to the group's repeat spread.
    Heldout(HeldoutArgs),
}

/// The fit budgets of a diagnosis.
#[derive(Debug, Args)]
pub(crate) struct Budgets {
    /// Evaluations of the nominal fit.
    #[arg(long, default_value_t = 300, value_parser = crate::ranges::at_least_one())]
    nominal_evals: usize,
    /// Evaluations per effect fit.
    #[arg(long, default_value_t = 150, value_parser = crate::ranges::at_least_one())]
    effect_evals: usize,
    /// Evaluations per free-support family of the nominal fit (all three support points
    /// free; then their friction loads), tried while the held-out error is above the floor.
    #[arg(long, default_value_t = Options::default().support_evals, value_parser = crate::ranges::at_least_one())]
    support_evals: usize,
    /// The model the nominal fit starts from (e.g. what `identify` wrote); default: the
    /// part's uniform-pressure support (the paper's default model for the paper's peg).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fit on the plain prediction error from the measured restart poses, not profiled
    /// over their tracker noise (docs/diagnose.md; for comparison).
    #[arg(long)]
    plain_starts: bool,
    /// Probe travel per simulator step in the replays, µm, for the paper's peg (scaled with
    /// the part's size).
    #[arg(long, default_value_t = Options::default().settings.step_um, value_parser = crate::ranges::step_um())]
    sim_step_um: f64,
    /// Finer step, µm for the paper's peg, at which a nominal fit already within the floor
    /// band is refitted before the verdict (docs/diagnose.md, "A finer step near the
    /// floor"); 0 turns the polish off.
    #[arg(long, default_value_t = Options::default().polish_step_um, value_parser = crate::ranges::length_um(1000.0))]
    polish_step_um: f64,
    /// Fit the effect that leads on the training trials about the nominal support only, as
    /// every other effect (docs/diagnose.md; for comparison): by default it is refitted with
    /// the three support points free as well.
    #[arg(long)]
    fixed_lead_support: bool,
}

impl Budgets {
    pub(crate) fn options(&self) -> Result<Options> {
        let start_model = self.model.as_deref().map(mesopush_sim::Model::load).transpose()?;
        Ok(Options {
            nominal_evals: self.nominal_evals,
            effect_evals: self.effect_evals,
            support_evals: self.support_evals,
            start_model,
            profile_start_poses: !self.plain_starts,
            polish_step_um: self.polish_step_um,
            refit_lead_support: !self.fixed_lead_support,
            settings: mesopush_sim::SimSettings {
                step_um: self.sim_step_um,
                ..Options::default().settings
            },
            ..Options::default()
        })
    }
}

#[derive(Debug, Args)]
struct RunArgs {
    /// Trial directories (trial.json, probe.csv, pose.csv); even positions train, odd ones
    /// are held out.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Output directory (report.md, summary.json, residuals.png, extended_model.toml).
    #[arg(long, default_value = "runs/diagnose")]
    out: PathBuf,
    /// Print the JSON summary instead of text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    budgets: Budgets,
}

#[derive(Debug, Args)]
struct SynthArgs {
    /// The undeclared effect: a library name, or `none`.
    effect: String,
    /// Output directory (one `trial-NNN` directory per trial).
    #[arg(long, default_value = "runs/diagnose")]
    out: PathBuf,
    /// Trials in the batch.
    #[arg(long, default_value_t = 6, value_parser = crate::ranges::count(2, 100_000))]
    n_trials: usize,
    /// Strokes per trial.
    #[arg(long, default_value_t = 3, value_parser = crate::ranges::count(1, 1000))]
    strokes: usize,
    /// Seed of the batch (true model, strokes, noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Debug, Args)]
struct RigArgs {
    /// The world file (its `[effects]` are the undeclared ones).
    world: PathBuf,
    /// Output directory (one `trial-NNN` directory per trial).
    #[arg(long, default_value = "runs/diagnose")]
    out: PathBuf,
    /// Trials in the batch.
    #[arg(long, default_value_t = 6, value_parser = crate::ranges::count(2, 100_000))]
    n_trials: usize,
    /// Seed of the batch (plans, world noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The effect called `name` (a library name, or `none` for the nominal model).
pub(crate) fn effect(name: &str) -> Result<Effect> {
    Effect::from_name(name).with_context(|| {
        let names: Vec<_> = Effect::EFFECTS.iter().map(|c| c.name()).collect();
        format!("unknown effect {name:?}; the library has none, {}", names.join(", "))
    })
}

fn run_dirs(dirs: &[PathBuf], opts: &Options, quiet: bool) -> Result<Diagnosis> {
    let (train, test) = load_split(dirs)?;
    let pb = if quiet { ProgressBar::hidden() } else { ProgressBar::new_spinner() };
    pb.set_style(
        ProgressStyle::with_template("{spinner} {elapsed} fitting {msg}").expect("template"),
    );
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    let d = diagnose(&train, &test, opts, &|m| pb.set_message(m.to_string()))?;
    pb.finish_and_clear();
    Ok(d)
}

fn write_outputs(d: &Diagnosis, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    d.best.model.save(&out.join("extended_model.toml"))?;
    d.nominal.model.save(&out.join("nominal_model.toml"))?;
    std::fs::write(out.join("report.md"), report::text(d))?;
    std::fs::write(out.join("summary.json"), serde_json::to_string_pretty(&report::json(d))?)?;
    mesopush_diagnose::figure::plot(d, &out.join("residuals.png"))?;
    Ok(())
}

fn run_trials(args: &RunArgs) -> Result<()> {
    let d = run_dirs(&args.trials, &args.budgets.options()?, args.json)?;
    write_outputs(&d, &args.out)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report::json(&d))?);
    } else {
        print!("{}", report::text(&d));
        println!(
            "\nwrote {}/{{report.md, summary.json, residuals.png, extended_model.toml}}",
            args.out.display()
        );
    }
    Ok(())
}

pub(crate) fn run(args: &DiagnoseArgs) -> Result<()> {
    match &args.mode {
        Mode::Run(a) => run_trials(a),
        Mode::Synth(a) => {
            let dirs = write_batch(&a.out, effect(&a.effect)?, a.n_trials, a.strokes, a.seed)?;
            println!("wrote {} trials under {}", dirs.len(), a.out.display());
            Ok(())
        }
        Mode::Rig(a) => {
            let world = mesopush_rig::WorldFile::load(&a.world)?;
            let dirs = write_rig_batch(&a.out, &world, a.n_trials, a.seed)?;
            println!("wrote {} trials under {}", dirs.len(), a.out.display());
            Ok(())
        }
        Mode::Confusion(a) => run_confusion(a),
        Mode::Heldout(a) => run_heldout(a),
    }
}

#[derive(Debug, Args)]
struct HeldoutArgs {
    /// Trial directories; a run's group is its directory name without the part after the
    /// last `__` (the importer writes `<set-up>__<start>__<date>`), or the whole name.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    budgets: Budgets,
}

/// A run's group: its directory name up to its last `__`.
fn group_of(dir: &Path) -> String {
    let name = dir.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    name.rsplit_once("__").map_or(name.clone(), |(g, _)| g.to_string())
}

fn run_heldout(args: &HeldoutArgs) -> Result<()> {
    let mut groups: Vec<(String, Vec<mesopush_diagnose::TrialData>)> = Vec::new();
    for (i, dir) in args.trials.iter().enumerate() {
        let t = mesopush_diagnose::TrialData::load(dir, i)?;
        let g = group_of(dir);
        match groups.iter_mut().find(|(n, _)| *n == g) {
            Some((_, runs)) => runs.push(t),
            None => groups.push((g, vec![t])),
        }
    }
    let opts = args.budgets.options()?;
    let part = &groups[0].1[0].part;
    let prior = match &opts.start_model {
        Some(m) => m.clone(),
        None => mesopush_diagnose::candidates::base_model(part),
    };
    let pb = if args.json { ProgressBar::hidden() } else { ProgressBar::new_spinner() };
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    let rows =
        heldout_by_group(&groups, &prior, &opts, &|g| pb.set_message(format!("holding out {g}")))?;
    pb.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!(
        "| held-out start | runs | family | median final error | repeat spread | target | within |"
    );
    println!("|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {} | {:.2} mm, {:.2}° | {:.2} mm, {:.2}° | {:.2} mm, {:.2}° | {} |",
            r.group,
            r.runs.len(),
            r.support_fit.family,
            r.median_final_error_um / 1000.0,
            r.median_final_error_deg,
            r.spread_um / 1000.0,
            r.spread_deg,
            r.target[0] / 1000.0,
            r.target[1],
            if r.within_target { "yes" } else { "no" }
        );
    }
    Ok(())
}

// `diagnose confusion`: the experiment's settings, a log line per batch and a progress bar
// on stderr, then the confusion matrix and the per-batch errors.

#[derive(Debug, Args)]
struct ConfusionArgs {
    /// Batches per true effect (seeds --seed, --seed + 1, ...).
    #[arg(long, default_value_t = 3, value_parser = crate::ranges::count(1, 10_000))]
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
    #[arg(long, default_value_t = 6, value_parser = crate::ranges::count(2, 100_000))]
    n_trials: usize,
    /// Strokes per synthetic trial.
    #[arg(long, default_value_t = 3, value_parser = crate::ranges::count(1, 1000))]
    strokes: usize,
    /// Print one JSON object (the true effects, a row per batch with its verdict and
    /// held-out errors before and after, the failed batches) instead of the tables.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    budgets: Budgets,
}

fn run_confusion(args: &ConfusionArgs) -> Result<()> {
    let mut settings = ConfusionSettings::new(&args.out);
    if !args.only.is_empty() {
        settings.truths = args.only.iter().map(|n| effect(n)).collect::<Result<_>>()?;
    }
    settings.seeds = args.seeds;
    settings.first_seed = args.seed;
    settings.n_trials = args.n_trials;
    settings.strokes = args.strokes;
    settings.options = args.budgets.options()?;
    let started = std::time::Instant::now();
    let pb = ProgressBar::new((settings.truths.len() * settings.seeds) as u64);
    let report = confusion::run(&settings, &mut |truth, seed, outcome| {
        pb.suspend(|| eprintln!("{}", confusion::batch_line(truth, seed, outcome)));
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    eprintln!("{} batches in {:.0} s", report.rows.len(), started.elapsed().as_secs_f64());
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.text());
    }
    Ok(())
}
