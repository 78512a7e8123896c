//! `mesopush robustness`: Monte Carlo success probability of one or more plans under the
//! paper's uncertainty (start pose, supports, friction), with a 95 % Wilson interval, a plot
//! of where failures come from and, with `--sweep`, success against the uncertainty's size.

use crate::cmd_plan::bar;
use anyhow::{Context, Result};
use clap::Args;
use mesopush_core::shard::Shard;
use mesopush_plan::figures::{draw_failures, draw_sweep};
use mesopush_plan::montecarlo::write_trials_csv;
use mesopush_plan::pushes::pushing_moves;
use mesopush_plan::shard::{self, ShardFile};
use mesopush_plan::{Estimate, MonteCarlo, SupportSet, Uncertainty};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Monte Carlo success probability of plans under start-pose, support and friction error.
#[derive(Debug, Args)]
pub(crate) struct RobustnessArgs {
    /// Plan TOML files (several: one row each, `--markdown` prints them as a table).
    #[arg(required = true)]
    plans: Vec<PathBuf>,
    /// Trials per plan.
    #[arg(long, default_value_t = 200)]
    samples: usize,
    /// Master seed (trial i draws from its own stream: same seed, same result).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Model TOML; default: the nominal model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Candidate support distributions (TOML `[[support]]` or JSON list; docs/planning.md);
    /// default: the model's support perturbed by ±`--support-um`.
    #[arg(long)]
    supports: Option<PathBuf>,
    /// Fixture TOML; default: the reconstructed paper fixture.
    #[arg(long)]
    fixture: Option<PathBuf>,
    /// Start x error, ± µm.
    #[arg(long, default_value_t = Uncertainty::default().dx_um)]
    dx_um: f64,
    /// Start y error, ± µm.
    #[arg(long, default_value_t = Uncertainty::default().dy_um)]
    dy_um: f64,
    /// Start orientation error, ± degrees.
    #[arg(long, default_value_t = Uncertainty::default().dtheta_deg)]
    dtheta_deg: f64,
    /// Friction error, ± (on μ_probe, μ_wall and each support's μ).
    #[arg(long, default_value_t = Uncertainty::default().dmu)]
    dmu: f64,
    /// Support point error when no --supports set is given, ± µm per coordinate.
    #[arg(long, default_value_t = Uncertainty::default().support_um)]
    support_um: f64,
    /// Also sweep the uncertainty box's scale over 0.5, 0.75, 1, 1.5, 2 and plot it.
    #[arg(long)]
    sweep: bool,
    /// Output directory for the figures and the per-trial CSV (`trials_PLAN.csv`).
    #[arg(long, default_value = "runs/robustness")]
    out: PathBuf,
    /// Print a Markdown table row per plan (name, success, interval, pushes, travel).
    #[arg(long)]
    markdown: bool,
    /// Print JSON (one object; with several plans, `{"plans": [...]}`).
    #[arg(long)]
    json: bool,
    /// Run only trials i ≡ I (mod N) of the `--samples` (`I/N`), writing
    /// `shard_PLAN.json` into `--out` for `mesopush robustness-merge` (docs/batch.md, Scale).
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
}

/// Merge `robustness --shard` outputs of one run.
#[derive(Debug, Args)]
pub(crate) struct MergeArgs {
    /// Shard files (`shard_PLAN.json`) or directories holding them; files of the same name
    /// are one plan's shards.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Output directory for the merged figures and per-trial CSV.
    #[arg(long, default_value = "runs/robustness-merged")]
    out: PathBuf,
    /// Print a Markdown table row per plan.
    #[arg(long)]
    markdown: bool,
    /// Print JSON (one object; with several plans, `{"plans": [...]}`).
    #[arg(long)]
    json: bool,
}

const SWEEP: [f64; 5] = [0.5, 0.75, 1.0, 1.5, 2.0];

pub(crate) fn run(args: &RobustnessArgs) -> Result<()> {
    let model = args.model.as_deref().map_or_else(|| Ok(Model::default()), Model::load)?;
    let fixture = args.fixture.as_deref().map_or_else(|| Ok(Fixture::paper()), Fixture::load)?;
    let supports = match &args.supports {
        Some(p) => SupportSet::load(p, &model)?.support,
        None => Vec::new(),
    };
    let unc = Uncertainty {
        dx_um: args.dx_um,
        dy_um: args.dy_um,
        dtheta_deg: args.dtheta_deg,
        dmu: args.dmu,
        support_um: args.support_um,
    };
    anyhow::ensure!(
        [unc.dx_um, unc.dy_um, unc.dtheta_deg, unc.dmu, unc.support_um]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0),
        "uncertainty half-widths must be finite and ≥ 0"
    );
    anyhow::ensure!(args.samples > 0, "--samples must be at least 1");
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let settings = SimSettings::default();
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?;
    anyhow::ensure!(!(shard.is_some() && args.sweep), "--sweep cannot be sharded; drop --shard");
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    for path in &args.plans {
        let plan = Plan::load(path)?;
        let mc = MonteCarlo {
            plan: &plan,
            model: &model,
            fixture: &fixture,
            settings: &settings,
            uncertainty: unc,
            supports: &supports,
        };
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("plan");
        if let Some(s) = shard {
            rows.push(run_shard(&mc, args, s, stem)?);
            continue;
        }
        let est = estimate(&mc, args.samples, args.seed, args.json)?;
        let ctx = Outputs { out: &args.out, model: &model, fixture: &fixture };
        let mut row = outputs(&ctx, path, stem, &plan, &est)?;
        if args.sweep {
            let pts = sweep(&mc, args.samples, args.seed, args.json)?;
            row["sweep"] = json!(pts.iter().map(|p| json!({"scale": p.0, "success_rate": p.1, "ci_low": p.2, "ci_high": p.3})).collect::<Vec<_>>());
            curves.push((stem.to_string(), pts));
        }
        rows.push(row);
    }
    if args.sweep {
        let fig = args.out.join("success_vs_uncertainty.png");
        let c: Vec<_> = curves.iter().map(|(n, p)| (n.as_str(), p.as_slice())).collect();
        draw_sweep(&c, &fig)?;
        if !args.json {
            println!("sweep figure: {}", fig.display());
        }
    }
    print(&rows, args.json, args.markdown);
    Ok(())
}

/// Where a plan's figure and CSV go, and the world its nominal replay runs in.
struct Outputs<'a> {
    out: &'a Path,
    model: &'a Model,
    fixture: &'a Fixture,
}

/// Writes the failures figure and the per-trial CSV; returns the plan's summary row.
fn outputs(c: &Outputs<'_>, path: &Path, stem: &str, plan: &Plan, est: &Estimate) -> Result<Value> {
    let fig = c.out.join(format!("failures_{stem}.png"));
    let title = format!("{}: {}/{} inserted", plan.name, est.successes, est.samples);
    draw_failures(&title, &est.trials, &fig)?;
    let csv = c.out.join(format!("trials_{stem}.csv"));
    let file =
        std::fs::File::create(&csv).with_context(|| format!("creating {}", csv.display()))?;
    write_trials_csv(&est.trials, std::io::BufWriter::new(file))
        .with_context(|| format!("writing {}", csv.display()))?;
    let mut row = summary(path, plan, est, &fig);
    let mut sim = Simulator::new(c.model.clone(), c.fixture.clone(), SimSettings::default())?;
    row["pushes_nominal"] = json!(pushing_moves(&replay(&mut sim, plan, None)?));
    Ok(row)
}

/// Runs one shard of a plan's trials and writes `shard_STEM.json`.
fn run_shard(mc: &MonteCarlo<'_>, args: &RobustnessArgs, s: Shard, stem: &str) -> Result<Value> {
    let n = (0..args.samples as u64).filter(|&i| s.owns(i)).count();
    let bar = bar(n as u64, args.json);
    let f = ShardFile::run(mc, args.samples as u64, args.seed, s, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let file = args.out.join(format!("shard_{stem}.json"));
    f.save(&file)?;
    let ok = f.trials.iter().filter(|(_, t)| t.inserted).count();
    Ok(json!({"plan": mc.plan.name, "shard": format!("{}/{}", s.index, s.count),
        "trials": f.trials.len(), "successes": ok, "shard_file": file}))
}

/// `mesopush robustness-merge`: one plan per shard file name, its shards merged.
pub(crate) fn merge(args: &MergeArgs) -> Result<()> {
    let mut groups: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for p in &args.shards {
        let files: Vec<PathBuf> = if p.is_dir() {
            let rd = std::fs::read_dir(p).with_context(|| format!("reading {}", p.display()))?;
            rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|f| is_shard_file(f)).collect()
        } else {
            vec![p.clone()]
        };
        for f in files {
            let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            groups.entry(name).or_default().push(f);
        }
    }
    anyhow::ensure!(!groups.is_empty(), "no shard_*.json files in the given paths");
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut rows = Vec::new();
    for (name, paths) in groups {
        let files = paths
            .into_iter()
            .map(|p| ShardFile::load(&p).map(|f| (p, f)))
            .collect::<Result<Vec<_>, _>>()?;
        let (key, est) = shard::merge(&files)?;
        let stem = name.trim_start_matches("shard_").trim_end_matches(".json");
        let ctx = Outputs { out: &args.out, model: &key.model, fixture: &key.fixture };
        let mut row = outputs(&ctx, Path::new(&name), stem, &key.plan, &est)?;
        row["shards"] = json!(files.len());
        rows.push(row);
    }
    print(&rows, args.json, args.markdown);
    Ok(())
}

fn is_shard_file(p: &Path) -> bool {
    let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
    name.starts_with("shard_") && name.ends_with(".json")
}

fn estimate(mc: &MonteCarlo<'_>, samples: usize, seed: u64, quiet: bool) -> Result<Estimate> {
    let bar = bar(samples as u64, quiet);
    let tick = || bar.inc(1);
    let est = mc.estimate(samples, seed, &tick)?;
    bar.finish_and_clear();
    Ok(est)
}

fn sweep(
    mc: &MonteCarlo<'_>,
    samples: usize,
    seed: u64,
    quiet: bool,
) -> Result<Vec<(f64, f64, f64, f64)>> {
    let mut pts = Vec::new();
    for k in SWEEP {
        let scaled = MonteCarlo { uncertainty: mc.uncertainty.scaled(k), ..*mc };
        let e = estimate(&scaled, samples, seed, quiet)?;
        pts.push((k, e.success_rate, e.ci_low, e.ci_high));
    }
    Ok(pts)
}

fn summary(path: &Path, plan: &Plan, est: &Estimate, fig: &Path) -> Value {
    let jammed = est.trials.iter().filter(|t| t.jammed).count();
    let errors = est.trials.iter().filter(|t| t.error.is_some()).count();
    let pushes = plan.moves_um.len();
    json!({
        "plan": path, "name": plan.name, "success_rate": est.success_rate,
        "ci_low": est.ci_low, "ci_high": est.ci_high, "samples": est.samples,
        "successes": est.successes, "jammed": jammed, "sim_errors": errors,
        "moves": pushes, "travel_um": plan.travel_um(), "failures_figure": fig,
    })
}

fn print(rows: &[Value], as_json: bool, markdown: bool) {
    if as_json {
        let v = if rows.len() == 1 { rows[0].clone() } else { json!({ "plans": rows }) };
        println!("{v}");
        return;
    }
    if markdown {
        println!("| plan | success | 95 % interval | pushes | moves | probe travel [µm] |");
        println!("|---|---|---|---|---|---|");
    }
    for r in rows {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        if markdown {
            println!(
                "| {} | {:.1} % | {:.1}–{:.1} % | {} | {} | {:.0} |",
                r["name"].as_str().unwrap_or(""),
                100.0 * f("success_rate"),
                100.0 * f("ci_low"),
                100.0 * f("ci_high"),
                r["pushes_nominal"],
                r["moves"],
                f("travel_um")
            );
            continue;
        }
        println!("{} ({}):", r["name"].as_str().unwrap_or(""), r["plan"].as_str().unwrap_or(""));
        println!(
            "  success {}/{} = {:.1} % (95 % Wilson interval {:.1}–{:.1} %), jammed {}, simulator errors {}",
            r["successes"],
            r["samples"],
            100.0 * f("success_rate"),
            100.0 * f("ci_low"),
            100.0 * f("ci_high"),
            r["jammed"],
            r["sim_errors"]
        );
        println!("  failures figure: {}", r["failures_figure"].as_str().unwrap_or(""));
    }
}
