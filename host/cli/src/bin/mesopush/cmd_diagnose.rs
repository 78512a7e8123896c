//! `mesopush diagnose`: find what the model lacks in measured trials (held-out residuals,
//! their structure, attribution to a library effect), report before/after errors and write
//! the extended model TOML. `--synth` makes a synthetic batch with one undeclared effect;
//! `--confusion` runs blind diagnoses over synthetic batches of every effect.

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_diagnose::report;
use mesopush_diagnose::rig_batch::write_rig_batch;
use mesopush_diagnose::synth::{SynthNoise, batch_truth, write_trial};
use mesopush_diagnose::{Diagnosis, Effect, Options, TrialData, diagnose};
use rand::SeedableRng;
use std::path::{Path, PathBuf};

/// Diagnose trials: residuals, their structure, the missing effect, before/after errors.
#[derive(Debug, Args)]
pub(crate) struct DiagnoseArgs {
    /// Trial directories (trial.json, probe.csv, pose.csv); even positions train, odd ones
    /// are held out.
    trials: Vec<PathBuf>,
    /// Output directory (report.md, summary.json, residuals.png, extended_model.toml).
    #[arg(long, default_value = "runs/diagnose")]
    out: PathBuf,
    /// Print the JSON summary instead of text.
    #[arg(long)]
    json: bool,
    /// Simplex evaluations of the nominal fit.
    #[arg(long, default_value_t = 300)]
    nominal_evals: usize,
    /// Evaluations per effect fit.
    #[arg(long, default_value_t = 150)]
    effect_evals: usize,
    /// Make a synthetic batch into --out with this undeclared effect (a library name, or
    /// `none`) instead of diagnosing.
    #[arg(long, value_name = "EFFECT")]
    synth: Option<String>,
    /// Make a batch into --out through the whole loop (executor, firmware simulator,
    /// camera, tracker; simulated time) in this world file, whose `[effects]` the host is
    /// never told, instead of diagnosing.
    #[arg(long, value_name = "WORLD")]
    rig_world: Option<PathBuf>,
    /// Trials per synthetic (or --rig-world) batch.
    #[arg(long, default_value_t = 6)]
    n_trials: usize,
    /// Strokes per synthetic trial.
    #[arg(long, default_value_t = 3)]
    strokes: usize,
    /// Run blind diagnoses of synthetic batches (every effect and clean controls, this many
    /// seeds each) and print the confusion matrix and before/after errors.
    #[arg(long, value_name = "SEEDS")]
    confusion: Option<usize>,
    /// With --confusion: only these true effects (comma-separated library names, `none` for
    /// the clean control); default every effect and the clean control.
    #[arg(long, value_delimiter = ',', value_name = "EFFECTS")]
    pub(crate) only: Vec<String>,
    /// Seed of the synthetic batches.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
}

pub(crate) fn candidate(name: &str) -> Result<Effect> {
    if name == "none" {
        return Ok(Effect::Nominal);
    }
    Effect::EFFECTS.into_iter().find(|c| c.name() == name).with_context(|| {
        let names: Vec<_> = Effect::EFFECTS.iter().map(|c| c.name()).collect();
        format!("unknown effect {name:?}; the library has none, {}", names.join(", "))
    })
}

fn synth_batch(
    out: &Path,
    effect: Effect,
    n: usize,
    strokes: usize,
    seed: u64,
) -> Result<Vec<PathBuf>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = batch_truth(effect, n, &mut rng);
    (0..n)
        .map(|i| {
            let id = format!("trial-{i:03}");
            let dir = out.join(&id);
            write_trial(
                &dir,
                &id,
                i,
                &truth,
                strokes,
                &SynthNoise::default(),
                seed * 1000 + i as u64,
            )?;
            Ok(dir)
        })
        .collect()
}

fn run_dirs(dirs: &[PathBuf], opts: &Options, quiet: bool) -> Result<Diagnosis> {
    if dirs.len() < 2 {
        bail!("diagnose needs at least two trials (one to train on, one held out)");
    }
    let trials: Vec<TrialData> =
        dirs.iter().enumerate().map(|(i, d)| TrialData::load(d, i)).collect::<Result<_, _>>()?;
    let (train, test): (Vec<_>, Vec<_>) = trials.into_iter().partition(|t| t.index % 2 == 0);
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
    report::plot(d, &out.join("residuals.png"))?;
    Ok(())
}

pub(crate) fn run(args: &DiagnoseArgs) -> Result<()> {
    let opts = Options {
        nominal_evals: args.nominal_evals,
        effect_evals: args.effect_evals,
        ..Options::default()
    };
    if let Some(name) = &args.synth {
        let dirs =
            synth_batch(&args.out, candidate(name)?, args.n_trials, args.strokes, args.seed)?;
        println!("wrote {} trials under {}", dirs.len(), args.out.display());
        return Ok(());
    }
    if let Some(path) = &args.rig_world {
        let world = mesopush_rig::WorldFile::load(path)?;
        let dirs = write_rig_batch(&args.out, &world, args.n_trials, args.seed)?;
        println!("wrote {} trials under {}", dirs.len(), args.out.display());
        return Ok(());
    }
    if let Some(seeds) = args.confusion {
        return super::cmd_diagnose_confusion::run(args, &opts, seeds);
    }
    let d = run_dirs(&args.trials, &opts, args.json)?;
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

/// For the confusion run: generate and diagnose one batch.
pub(crate) fn blind(
    args: &DiagnoseArgs,
    opts: &Options,
    effect: Effect,
    seed: u64,
) -> Result<Diagnosis> {
    let dir = args.out.join(format!("{}-{seed}", effect.name()));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    let dirs = synth_batch(&dir, effect, args.n_trials, args.strokes, seed)?;
    run_dirs(&dirs, opts, true)
}
