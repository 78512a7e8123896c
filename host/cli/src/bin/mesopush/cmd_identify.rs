//! `mesopush identify`: identify μ and the three-point support from unconstrained pushing
//! trials (Table I, cross-trial matrix, nominal model TOML), optionally refine them jointly
//! and write the set of supports consistent with the data; `--synthesize DIR` writes a demo
//! dataset of simulated trials with known truth.

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mesopush_core::geom::{ConvexPolygon, Vec2};
use mesopush_core::shard::Shard;
use mesopush_ident::figure::{Fig5Trial, draw_fig5};
use mesopush_ident::shard::{self, SweepKey, SweepShard};
use mesopush_ident::sweep::{grid, score_jobs};
use mesopush_ident::synth::{SynthSpec, demo_truth, hexagon, write_trials};
use mesopush_ident::{
    IdentTrial, IdentifySettings, OptimizeSettings, ScoreSettings, Sweep, SweepSettings, Ticks,
    identify, identify_from,
};
use mesopush_sim::{Model, Part, SimSettings};
use rand::SeedableRng;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Identify probe friction and support distribution from unconstrained pushing trials.
#[derive(Debug, Args)]
pub(crate) struct IdentifyArgs {
    /// Trial directories (each with trial.json, probe.csv, pose.csv), or directories holding
    /// such trial directories.
    #[arg(required_unless_present = "synthesize")]
    trials: Vec<PathBuf>,
    /// μ grid step over [0, --mu-max].
    #[arg(long, default_value_t = 0.05)]
    mu_step: f64,
    /// Largest μ of the grid.
    #[arg(long, default_value_t = 1.0)]
    mu_max: f64,
    /// Random three-point supports per μ (the paper: 100–150).
    #[arg(long, default_value_t = 120)]
    supports: usize,
    /// Surface friction of the sampled supports.
    #[arg(long, default_value_t = 0.3)]
    mu_surface: f64,
    /// Seed of every random choice (supports, optimiser restarts, synthetic noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Refine μ and the support points jointly (Nelder–Mead) from the sweep's nominal.
    #[arg(long)]
    optimize: bool,
    /// Optimiser budget: objective evaluations (each simulates every trial).
    #[arg(long, default_value_t = 600)]
    max_evals: usize,
    /// Let the optimiser fit the (shared) surface friction too.
    #[arg(long)]
    fit_surface: bool,
    /// Probe travel per simulation step, µm.
    #[arg(long, default_value_t = SimSettings::default().step_um)]
    step_um: f64,
    /// Model TOML to write with the chosen parameters.
    #[arg(long, default_value = "runs/identify/model.toml")]
    out: PathBuf,
    /// Supports TOML to write with the consistent set (`[[supports]]` list).
    #[arg(long, default_value = "runs/identify/supports.toml")]
    consistent_out: PathBuf,
    /// Directory for the Fig. 5 figure (best and worst trial, simulation vs measurement).
    #[arg(long)]
    fig: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Write a demo dataset of simulated trials (known truth, tracking noise) to DIR and exit.
    #[arg(long, value_name = "DIR")]
    synthesize: Option<PathBuf>,
    /// Part of the synthetic trials: `peg` (1615 × 985 µm) or `hexagon`.
    #[arg(long, default_value = "peg")]
    synth_part: String,
    /// Scale factor of the synthetic part and push lengths.
    #[arg(long, default_value_t = 1.0)]
    synth_scale: f64,
    /// Probe speed of the synthetic trials, µm/s.
    #[arg(long, default_value_t = 200.0)]
    synth_speed_um_s: f64,
    /// Score only the sweep's candidates k ≡ I (mod N) (`I/N`), write them to
    /// `--sweep-out` and exit; `--sweep-from` merges the shards (docs/batch.md, Scale).
    #[arg(long, value_name = "I/N", conflicts_with = "sweep_from")]
    shard: Option<String>,
    /// Where `--shard` writes its scores [default: runs/identify/sweep-shard-I-of-N.json].
    #[arg(long, requires = "shard")]
    sweep_out: Option<PathBuf>,
    /// Take the sweep from these `--shard` outputs (same trials, seed and settings) instead
    /// of running it; the rest (optimiser, report, model) runs as usual.
    #[arg(long, num_args = 1.., value_name = "FILE")]
    sweep_from: Option<Vec<PathBuf>>,
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

/// Expands directories holding trial directories into the trials themselves.
fn trial_dirs(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.join("trial.json").exists() {
            out.push(p.clone());
            continue;
        }
        let rd = std::fs::read_dir(p)
            .with_context(|| format!("{}: not a trial directory", p.display()))?;
        let mut sub: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|d| d.join("trial.json").exists())
            .collect();
        if sub.is_empty() {
            bail!("{}: no trial.json in it or in its subdirectories", p.display());
        }
        sub.sort();
        out.extend(sub);
    }
    Ok(out)
}

fn synthesize(args: &IdentifyArgs, dir: &Path) -> Result<()> {
    let s = args.synth_scale;
    if !(s.is_finite() && s > 0.0) {
        bail!("--synth-scale must be > 0");
    }
    let mut truth = demo_truth();
    truth.part = match args.synth_part.as_str() {
        "peg" => truth.part,
        "hexagon" => hexagon(650.0),
        other => bail!("--synth-part {other}: use peg or hexagon"),
    };
    let verts: Vec<Vec2> = truth.part.polygon().vertices().iter().map(|v| v * s).collect();
    truth.part = Part::from_polygon(&ConvexPolygon::new(verts)?);
    truth.support.points_um = truth.support.points_um.map(|[x, y]| [x * s, y * s]);
    if args.synth_part == "hexagon" {
        truth.support.points_um =
            [[-300.0 * s, 250.0 * s], [-150.0 * s, -350.0 * s], [420.0 * s, 60.0 * s]];
    }
    truth.validate().context("synthetic truth")?;
    let mut spec = SynthSpec::paper_like(truth.clone(), 900.0 * s);
    spec.speed_um_s = args.synth_speed_um_s;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let dirs = write_trials(&spec, dir, &mut rng)?;
    truth.save(&dir.join("true_model.toml"))?;
    if args.json {
        println!("{}", json!({ "trials": dirs, "true_model": truth }));
    } else {
        println!(
            "wrote {} synthetic trials to {} (truth: {})",
            dirs.len(),
            dir.display(),
            dir.join("true_model.toml").display()
        );
    }
    Ok(())
}

fn sweep_key(args: &IdentifyArgs, trials: &[IdentTrial], s: &IdentifySettings) -> SweepKey {
    SweepKey {
        trials: trials.iter().map(|t| t.id.clone()).collect(),
        seed: args.seed,
        mu_step: s.sweep.mu_step,
        mu_max: s.sweep.mu_max,
        n_supports: s.sweep.n_supports,
        mu_surface: s.sweep.mu_surface,
        step_um: s.score.sim.step_um,
        mu_wall: s.score.mu_wall,
    }
}

/// `--shard I/N`: scores this shard's candidates and writes them.
fn run_shard(
    args: &IdentifyArgs,
    trials: &[IdentTrial],
    settings: &IdentifySettings,
    shard: Shard,
    rng: &mut impl rand::Rng,
    tick: &(dyn Fn() + Sync),
) -> Result<()> {
    let (mus, supports) = grid(trials, &settings.sweep, rng)?;
    let n = mus.len() * supports.len();
    let ks = SweepShard::owned(shard, n);
    let flat = score_jobs(trials, &mus, &supports, &settings.score, &ks, tick);
    let key = sweep_key(args, trials, settings);
    let file = SweepShard::new(key, shard, n, &ks, &flat);
    let default = format!("runs/identify/sweep-{}.json", shard.dir_name());
    let out = args.sweep_out.clone().unwrap_or_else(|| PathBuf::from(default));
    write_parent(&out)?;
    file.save(&out)?;
    let v = json!({"shard": format!("{}/{}", shard.index, shard.count), "candidates": ks.len(),
        "trials": trials.len(), "sweep_out": out});
    if args.json {
        println!("{v}")
    } else {
        println!("sweep shard written: {}", out.display())
    }
    Ok(())
}

/// `--sweep-from`: the sweep assembled from shard files (the grid re-drawn from the seed,
/// which also leaves `rng` where the unsplit sweep leaves it).
fn merged_sweep(
    args: &IdentifyArgs,
    trials: &[IdentTrial],
    settings: &IdentifySettings,
    rng: &mut impl rand::Rng,
    paths: &[PathBuf],
) -> Result<Sweep> {
    let (mus, supports) = grid(trials, &settings.sweep, rng)?;
    let files = paths
        .iter()
        .map(|p| SweepShard::load(p).map(|f| (p.clone(), f)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(shard::merge(&files, &sweep_key(args, trials, settings), mus, supports)?)
}

fn settings(args: &IdentifyArgs) -> IdentifySettings {
    IdentifySettings {
        sweep: SweepSettings {
            mu_step: args.mu_step,
            mu_max: args.mu_max,
            n_supports: args.supports,
            mu_surface: args.mu_surface,
        },
        optimize: args.optimize.then(|| OptimizeSettings {
            max_evals: args.max_evals,
            fit_surface: args.fit_surface,
            ..OptimizeSettings::default()
        }),
        score: ScoreSettings {
            sim: SimSettings { step_um: args.step_um, ..SimSettings::default() },
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

pub(crate) fn run(args: &IdentifyArgs) -> Result<()> {
    if let Some(dir) = &args.synthesize {
        return synthesize(args, dir);
    }
    let dirs = trial_dirs(&args.trials)?;
    let trials: Vec<IdentTrial> =
        dirs.iter().map(|d| IdentTrial::load(d)).collect::<Result<_, _>>()?;
    let settings = settings(args);
    let mus = settings.sweep.mus()?.len();
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?;
    let candidates = mus * settings.sweep.n_supports;
    let candidates = shard.map_or(candidates, |s| SweepShard::owned(s, candidates).len());
    let n_sweep = (trials.len() * candidates) as u64;
    let sweep_bar = bar(n_sweep, "sweep", args.json);
    let opt_bar = bar(
        if args.optimize { args.max_evals as u64 } else { 0 },
        "optimize",
        args.json || !args.optimize,
    );
    let ticks = Ticks { sweep: &|| sweep_bar.inc(1), optimize: &|| opt_bar.inc(1) };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    if let Some(s) = shard {
        let done = run_shard(args, &trials, &settings, s, &mut rng, ticks.sweep);
        sweep_bar.finish_and_clear();
        return done;
    }
    let t0 = Instant::now();
    let report = match &args.sweep_from {
        None => identify(&trials, &settings, &mut rng, &ticks)?,
        Some(paths) => {
            let sw = merged_sweep(args, &trials, &settings, &mut rng, paths)?;
            identify_from(&trials, sw, &settings, &mut rng, &ticks)?
        }
    };
    let runtime_s = t0.elapsed().as_secs_f64();
    sweep_bar.finish_and_clear();
    opt_bar.finish_and_clear();
    let model: Model = report.model(&trials[0], &settings);
    write_parent(&args.out)?;
    model.save(&args.out)?;
    write_parent(&args.consistent_out)?;
    report.consistent.save(&args.consistent_out)?;
    let figs = match &args.fig {
        Some(dir) => figures(&trials, &report, &settings, dir)?,
        None => Vec::new(),
    };
    if args.json {
        let v = json!({
            "report": report, "model": model, "model_file": args.out,
            "consistent": { "count": report.consistent.members.len(), "examined": report.consistent.examined,
                "mu_range": report.consistent.mu_range, "point_bounds_um": report.consistent.point_bounds_um,
                "noise_var_um2": report.consistent.noise_var_um2, "threshold_um2": report.consistent.threshold_um2,
                "file": args.consistent_out },
            "figures": figs, "runtime_s": runtime_s, "seed": args.seed,
        });
        println!("{v}");
    } else {
        print!("{}", report.text());
        println!(
            "model: {}  consistent supports: {}  ({runtime_s:.1} s)",
            args.out.display(),
            args.consistent_out.display()
        );
        for f in &figs {
            println!("figure: {}", f.display());
        }
    }
    Ok(())
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
