//! `mesopush identify run|shard|merge|synth`: identify μ and the three-point support from
//! unconstrained pushing trials (Table I, cross-trial matrix, nominal model TOML), optionally
//! refine them jointly and write the set of supports consistent with the data; split the
//! sweep into shards and merge them; write a demo dataset of simulated trials with known
//! truth.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mesopush_core::check::Allowed;
use mesopush_core::shard::Shard;
use mesopush_ident::bootstrap::BootstrapSettings;
use mesopush_ident::figure::{Fig5Trial, draw_fig5};
use mesopush_ident::shard::{merged_sweep, owned, save, score_shard};
use mesopush_ident::synth::{DemoPart, DemoSettings, write_demo};
use mesopush_ident::{
    IdentTrial, IdentifySettings, OptimizeSettings, ScoreSettings, SweepSettings, Ticks, identify,
    identify_from,
};
use mesopush_sim::{Model, SimSettings};
use rand::SeedableRng;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Identify probe friction and support distribution from unconstrained pushing trials.
#[derive(Debug, Args)]
pub(crate) struct IdentifyArgs {
    #[command(subcommand)]
    mode: Mode,
}

#[derive(Debug, Subcommand)]
enum Mode {
    /// Identify from trials: the sweep, optionally the joint optimiser, the report, the
    /// model and the consistent supports.
    Run(RunArgs),
    /// Score one shard of the sweep (candidates k ≡ I mod N) and write it to a file, for
    /// `identify merge` (docs/batch.md, Scale).
    Shard(ShardArgs),
    /// As `identify run`, with the sweep assembled from `identify shard` files.
    Merge(MergeArgs),
    /// Write a demo dataset of simulated trials (known truth, tracking noise).
    Synth(SynthArgs),
}

/// The trials and the sweep over them (shared by every mode that reads trials).
#[derive(Debug, Args)]
struct SweepArgs {
    /// Trial directories (each with trial.json, probe.csv, pose.csv), or directories holding
    /// such trial directories.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// μ grid step over [0, --mu-max].
    #[arg(long, default_value_t = 0.05, value_parser = crate::ranges::real(Allowed::positive_to(2.0, "")))]
    mu_step: f64,
    /// Largest μ of the grid.
    #[arg(long, default_value_t = 1.0, value_parser = crate::ranges::mu())]
    mu_max: f64,
    /// Random three-point supports per μ (the paper: 100–150).
    #[arg(long, default_value_t = 120, value_parser = crate::ranges::count(1, 1_000_000))]
    supports: usize,
    /// Surface friction of the sampled supports.
    #[arg(long, default_value_t = 0.3, value_parser = crate::ranges::mu())]
    mu_surface: f64,
    /// Seed of every random choice (supports, optimiser).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Probe travel per simulation step, µm.
    #[arg(long, default_value_t = SimSettings::default().step_um, value_parser = crate::ranges::step_um())]
    step_um: f64,
}

/// Everything after the sweep: the optimiser and the outputs.
#[derive(Debug, Args)]
struct FitArgs {
    /// Refine μ and the support points jointly from the sweep's best candidates: an
    /// evolution strategy, then Levenberg–Marquardt, then Nelder–Mead restarts.
    #[arg(long)]
    optimize: bool,
    /// Optimiser budget: objective evaluations (each simulates every trial).
    #[arg(long, default_value_t = 600, requires = "optimize", value_parser = crate::ranges::at_least_one())]
    max_evals: usize,
    /// Let the optimiser fit the (shared) surface friction too.
    #[arg(long, requires = "optimize")]
    fit_surface: bool,
    /// The richer support family: each of the three supports its own friction load (the
    /// centre of friction may leave the COM; docs/identification.md).
    #[arg(long, requires = "optimize")]
    free_loads: bool,
    /// Refits on bootstrap resamples of the trials after the joint fit (0: none; needs at
    /// least three trials): the ± of every parameter and members of the consistent set.
    #[arg(long, default_value_t = 8, requires = "optimize", value_parser = crate::ranges::count(0, 1000))]
    bootstrap: usize,
    /// Objective evaluations per bootstrap refit.
    #[arg(long, default_value_t = 100, requires = "optimize", value_parser = crate::ranges::at_least_one())]
    bootstrap_evals: usize,
    /// Model TOML to write with the chosen parameters.
    #[arg(long, default_value = "runs/identify/model.toml")]
    out: PathBuf,
    /// Support-set TOML to write with the consistent set (`[[support]]` tables, each with its
    /// probe friction; `mesopush robustness --supports` reads it).
    #[arg(long, default_value = "runs/identify/supports.toml")]
    consistent_out: PathBuf,
    /// Directory for the Fig. 5 figure (best and worst trial, simulation vs measurement).
    #[arg(long)]
    fig: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct RunArgs {
    #[command(flatten)]
    sweep: SweepArgs,
    #[command(flatten)]
    fit: FitArgs,
}

#[derive(Debug, Args)]
struct ShardArgs {
    /// The shard, `I/N`: scores the sweep's candidates k ≡ I (mod N).
    #[arg(value_name = "I/N")]
    shard: String,
    #[command(flatten)]
    sweep: SweepArgs,
    /// Where to write the scores [default: runs/identify/sweep-shard-I-of-N.json].
    #[arg(long)]
    sweep_out: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct MergeArgs {
    #[command(flatten)]
    sweep: SweepArgs,
    /// The `identify shard` files of this sweep (same trials, seed and settings), all N.
    #[arg(long, required = true, num_args = 1.., value_name = "FILE")]
    sweep_from: Vec<PathBuf>,
    #[command(flatten)]
    fit: FitArgs,
}

#[derive(Debug, Args)]
struct SynthArgs {
    /// Directory to write the trials (`synth-NN/`) and `true_model.toml` into.
    dir: PathBuf,
    /// The part: `peg` (1615 × 985 µm) or `hexagon`.
    #[arg(long, default_value = "peg")]
    part: DemoPart,
    /// Scale factor of the part, its support and the push lengths.
    #[arg(long, default_value_t = 1.0, value_parser = crate::ranges::real(Allowed::positive_to(100.0, "")))]
    scale: f64,
    /// Probe speed, µm/s.
    #[arg(long, default_value_t = 200.0, value_parser = crate::ranges::real(Allowed::positive_to(10_000.0, "µm/s")))]
    speed_um_s: f64,
    /// Seed of the tracking noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn bar(n: u64, msg: &'static str, hidden: bool) -> ProgressBar {
    let b = ProgressBar::new(n);
    if hidden {
        b.set_draw_target(ProgressDrawTarget::hidden());
    }
    if let Ok(style) = ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} {eta}") {
        b.set_style(style.progress_chars("=> "));
    }
    b.set_message(msg);
    b
}

fn load_trials(args: &SweepArgs) -> Result<Vec<IdentTrial>> {
    let dirs = mesopush_trial::trial_dirs(&args.trials)?;
    Ok(dirs.iter().map(|d| IdentTrial::load(d)).collect::<Result<_, _>>()?)
}

fn synthesize(args: &SynthArgs) -> Result<()> {
    let settings = DemoSettings { part: args.part, scale: args.scale, speed_um_s: args.speed_um_s };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let demo = write_demo(&settings, &args.dir, &mut rng)?;
    if args.json {
        println!("{}", json!({ "trials": demo.trials, "true_model": demo.truth }));
    } else {
        println!(
            "wrote {} synthetic trials to {} (truth: {})",
            demo.trials.len(),
            args.dir.display(),
            demo.truth_file.display()
        );
    }
    Ok(())
}

fn settings(sweep: &SweepArgs, fit: Option<&FitArgs>) -> IdentifySettings {
    IdentifySettings {
        sweep: SweepSettings {
            mu_step: sweep.mu_step,
            mu_max: sweep.mu_max,
            n_supports: sweep.supports,
            mu_surface: sweep.mu_surface,
        },
        optimize: fit.filter(|f| f.optimize).map(|f| OptimizeSettings {
            max_evals: f.max_evals,
            fit_surface: f.fit_surface,
            free_loads: f.free_loads,
            ..OptimizeSettings::default()
        }),
        bootstrap: BootstrapSettings {
            resamples: fit.map_or(0, |f| f.bootstrap),
            evals: fit.map_or(0, |f| f.bootstrap_evals),
        },
        score: ScoreSettings {
            sim: SimSettings { step_um: sweep.step_um, ..SimSettings::default() },
            ..ScoreSettings::default()
        },
    }
}

fn write_parent(path: &Path) -> Result<()> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    Ok(())
}

/// `identify shard I/N`: scores this shard's candidates and writes them.
fn run_shard(args: &ShardArgs) -> Result<()> {
    let shard = Shard::parse(&args.shard)?;
    let trials = load_trials(&args.sweep)?;
    let settings = settings(&args.sweep, None);
    let candidates = settings.sweep.mus()?.len() * settings.sweep.n_supports;
    let n_owned = owned(shard, candidates).len();
    let sweep_bar = bar((trials.len() * n_owned) as u64, "sweep", args.json);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.sweep.seed);
    let tick = || sweep_bar.inc(1);
    let file = score_shard(&trials, &settings, args.sweep.seed, shard, &mut rng, &tick)?;
    sweep_bar.finish_and_clear();
    let default = format!("runs/identify/sweep-{}.json", shard.dir_name());
    let out = args.sweep_out.clone().unwrap_or_else(|| PathBuf::from(default));
    write_parent(&out)?;
    save(&file, &out)?;
    let v = json!({"shard": format!("{}/{}", shard.index, shard.count), "candidates": n_owned,
        "trials": trials.len(), "sweep_out": out});
    if args.json {
        println!("{v}")
    } else {
        println!("sweep shard written: {}", out.display())
    }
    Ok(())
}

/// `identify run` (no shard files) and `identify merge` (the sweep from `shards`).
fn run_identify(sweep: &SweepArgs, fit: &FitArgs, shards: Option<&[PathBuf]>) -> Result<()> {
    let trials = load_trials(sweep)?;
    let settings = settings(sweep, Some(fit));
    let n_sweep = (trials.len() * settings.sweep.mus()?.len() * settings.sweep.n_supports) as u64;
    let sweep_bar = bar(n_sweep, "sweep", fit.json);
    let boot_evals = if trials.len() >= 3 { fit.bootstrap * fit.bootstrap_evals } else { 0 };
    let opt_evals = if fit.optimize { (fit.max_evals + boot_evals) as u64 } else { 0 };
    let opt_bar = bar(opt_evals, "optimize", fit.json || !fit.optimize);
    let ticks = Ticks { sweep: &|| sweep_bar.inc(1), optimize: &|| opt_bar.inc(1) };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(sweep.seed);
    let t0 = Instant::now();
    let report = match shards {
        None => identify(&trials, &settings, &mut rng, &ticks)?,
        Some(paths) => {
            let sw = merged_sweep(&trials, &settings, sweep.seed, &mut rng, paths)?;
            identify_from(&trials, sw, &settings, &mut rng, &ticks)?
        }
    };
    let runtime_s = t0.elapsed().as_secs_f64();
    sweep_bar.finish_and_clear();
    opt_bar.finish_and_clear();
    let model: Model = report.model(&trials[0], &settings);
    write_parent(&fit.out)?;
    model.save(&fit.out)?;
    write_parent(&fit.consistent_out)?;
    report.consistent.save(&fit.consistent_out)?;
    let figs = match &fit.fig {
        Some(dir) => figures(&trials, &report, &settings, dir)?,
        None => Vec::new(),
    };
    print_report(&report, &model, fit, &figs, runtime_s, sweep.seed)
}

fn print_report(
    report: &mesopush_ident::Report,
    model: &Model,
    fit: &FitArgs,
    figs: &[PathBuf],
    runtime_s: f64,
    seed: u64,
) -> Result<()> {
    if fit.json {
        let c = &report.consistent;
        let v = json!({
            "report": report, "model": model, "model_file": fit.out,
            "consistent": { "count": c.members.len(), "examined": c.examined,
                "mu_range": c.mu_range, "point_bounds_um": c.point_bounds_um,
                "noise_var_um2": c.noise_var_um2, "threshold_um2": c.threshold_um2,
                "file": fit.consistent_out },
            "figures": figs, "runtime_s": runtime_s, "seed": seed,
        });
        println!("{v}");
    } else {
        print!("{}", report.text());
        println!(
            "model: {}  consistent supports: {}  ({runtime_s:.1} s)",
            fit.out.display(),
            fit.consistent_out.display()
        );
        for f in figs {
            println!("figure: {}", f.display());
        }
    }
    Ok(())
}

pub(crate) fn run(args: &IdentifyArgs) -> Result<()> {
    match &args.mode {
        Mode::Run(a) => run_identify(&a.sweep, &a.fit, None),
        Mode::Shard(a) => run_shard(a),
        Mode::Merge(a) => run_identify(&a.sweep, &a.fit, Some(&a.sweep_from)),
        Mode::Synth(a) => synthesize(a),
    }
}

/// Fig. 5: the best and the worst trial under the chosen parameters.
fn figures(
    trials: &[IdentTrial],
    report: &mesopush_ident::Report,
    settings: &IdentifySettings,
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let chosen = report.chosen();
    let costs: Vec<f64> = chosen.per_trial.iter().map(|s| s.cost_um2).collect();
    let best = mesopush_ident::sweep::argmin(costs.iter().copied());
    let worst =
        mesopush_ident::sweep::argmin(costs.iter().map(|c| if c.is_nan() { 0.0 } else { -c }));
    let panels: Vec<Fig5Trial<'_>> = [(best, "best"), (worst, "worst")]
        .into_iter()
        .map(|(i, label)| Fig5Trial { trial: &trials[i], label, score: chosen.per_trial[i] })
        .collect();
    let mut out = Vec::new();
    for ext in ["png", "svg"] {
        let path = dir.join(format!("fig5.{ext}"));
        draw_fig5(&panels, &chosen.candidate, &settings.score, &path)?;
        out.push(path);
    }
    Ok(out)
}
