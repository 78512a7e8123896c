//! `mesopush robustness`: Monte Carlo success probability of one or more plans under the
//! paper's uncertainty (start pose, supports, friction), with a 95 % Wilson interval, a plot
//! of where failures come from and, with `--sweep`, success against the uncertainty's size.

use crate::cmd_plan::bar;
use anyhow::{Context, Result};
use clap::Args;
use mesopush_host::plan::figures::{draw_failures, draw_sweep};
use mesopush_host::plan::montecarlo::write_trials_csv;
use mesopush_host::plan::pushes::pushing_moves;
use mesopush_host::plan::{Estimate, MonteCarlo, SupportSet, Uncertainty};
use mesopush_host::sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use serde_json::{Value, json};
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
        let est = estimate(&mc, args.samples, args.seed, args.json)?;
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("plan");
        let fig = args.out.join(format!("failures_{stem}.png"));
        let title = format!("{}: {}/{} inserted", plan.name, est.successes, est.samples);
        draw_failures(&title, &est.trials, &fig)?;
        let csv = args.out.join(format!("trials_{stem}.csv"));
        let file =
            std::fs::File::create(&csv).with_context(|| format!("creating {}", csv.display()))?;
        write_trials_csv(&est.trials, std::io::BufWriter::new(file))
            .with_context(|| format!("writing {}", csv.display()))?;
        let mut row = summary(path, &plan, &est, &fig);
        let mut sim = Simulator::new(model.clone(), fixture.clone(), settings.clone())?;
        row["pushes_nominal"] = json!(pushing_moves(&replay(&mut sim, &plan, None)?));
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
    print(&rows, args);
    Ok(())
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

fn print(rows: &[Value], args: &RobustnessArgs) {
    if args.json {
        let v = if rows.len() == 1 { rows[0].clone() } else { json!({ "plans": rows }) };
        println!("{v}");
        return;
    }
    if args.markdown {
        println!("| plan | success | 95 % interval | pushes | moves | probe travel [µm] |");
        println!("|---|---|---|---|---|---|");
    }
    for r in rows {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        if args.markdown {
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
