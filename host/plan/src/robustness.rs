//! Robustness runs as `mesopush robustness` makes them, as library calls returning report
//! rows: every plan's Monte Carlo estimate with its failures figure, per-trial CSV and
//! summary row (and, on request, the sweep over the uncertainty box's size); one shard of
//! such a run written to its file; and shard files merged back into the unsplit run's rows,
//! figures and CSVs.

use crate::Error;
use crate::figures::{SweepCurve, draw_failures, draw_sweep};
use crate::montecarlo::{MonteCarlo, SuccessEstimate, SweepPoint, write_trials_csv};
use crate::pushes::pushing_moves;
use crate::sampler::Uncertainty;
use crate::shard;
use mesopush_core::shard::Shard;
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One plan's summary (its JSON field names are the CLI's output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanRow {
    /// The plan file (for a merge: the shard files' name).
    pub plan: PathBuf,
    /// The plan's name.
    pub name: String,
    /// Successes / samples.
    pub success_rate: f64,
    /// Wilson 95 % interval, lower end.
    pub ci_low: f64,
    /// Wilson 95 % interval, upper end.
    pub ci_high: f64,
    /// Trials run.
    pub samples: usize,
    /// Trials that inserted the peg.
    pub successes: usize,
    /// Trials in which the probe jammed.
    pub jammed: usize,
    /// Trials that bent the needle beyond the model's `probe_deflection_limit_um`: failures
    /// even when the peg ended in the goal.
    pub overloaded: usize,
    /// Trials whose replay failed in the simulator.
    pub sim_errors: usize,
    /// The plan's probe moves.
    pub moves: usize,
    /// The plan's probe travel, µm.
    pub travel_um: f64,
    /// The failures figure.
    pub failures_figure: PathBuf,
    /// Moves of the nominal replay during which the probe pushes the peg.
    pub pushes_nominal: usize,
    /// The success rate against the uncertainty box's scale, when swept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sweep: Option<Vec<SweepPoint>>,
    /// Shard files merged, for a merge.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shards: Option<usize>,
}

/// What one shard of a run wrote.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShardRow {
    /// The plan's name.
    pub plan: String,
    /// The shard, `I/N`.
    pub shard: String,
    /// Trials in the shard.
    pub trials: usize,
    /// Of them, the ones that inserted the peg.
    pub successes: usize,
    /// The shard file.
    pub shard_file: PathBuf,
}

/// A robustness run of one or more plans (plain data; the plans are given to the calls).
#[derive(Debug, Clone, Copy)]
pub struct RobustnessRun<'a> {
    /// The nominal model.
    pub model: &'a Model,
    /// The fixture.
    pub fixture: &'a Fixture,
    /// Candidate supports (empty: the model's, perturbed).
    pub supports: &'a [SupportSample],
    /// The uncertainty box.
    pub uncertainty: Uncertainty,
    /// Trials per plan (and per sweep scale).
    pub samples: usize,
    /// Master seed.
    pub seed: u64,
    /// Also sweep the box's scale over [`crate::montecarlo::SWEEP_SCALES`].
    pub sweep: bool,
    /// Directory for the figures, CSVs and shard files (created when missing).
    pub out: &'a Path,
}

/// What [`RobustnessRun::run`] made.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustnessReport {
    /// One row per plan, in the order given.
    pub rows: Vec<PlanRow>,
    /// The sweep figure, when swept.
    pub sweep_figure: Option<PathBuf>,
}

impl RobustnessRun<'_> {
    /// Checks the run's numbers: at least one sample, every half-width finite and ≥ 0.
    pub fn validate(&self) -> Result<(), Error> {
        self.uncertainty.validate()?;
        if self.samples == 0 {
            return Err(Error::invalid("samples", "0: a robustness run needs at least 1 trial"));
        }
        Ok(())
    }

    /// Trials [`RobustnessRun::run`] simulates for `plans` plans (for a progress display).
    pub fn trial_count(&self, plans: usize) -> u64 {
        let scales = if self.sweep { 1 + crate::montecarlo::SWEEP_SCALES.len() } else { 1 };
        (plans * scales * self.samples) as u64
    }

    /// Trials [`RobustnessRun::run_shard`] simulates for `plans` plans.
    pub fn shard_trial_count(&self, plans: usize, shard: Shard) -> u64 {
        plans as u64 * (0..self.samples as u64).filter(|&i| shard.owns(i)).count() as u64
    }

    fn monte_carlo<'p>(&'p self, plan: &'p Plan, settings: &'p SimSettings) -> MonteCarlo<'p> {
        MonteCarlo {
            plan,
            model: self.model,
            fixture: self.fixture,
            settings,
            uncertainty: self.uncertainty,
            supports: self.supports,
        }
    }

    /// Estimates every plan of `plans` (files), writing each one's failures figure and
    /// per-trial CSV into `out`, and the sweep figure when swept; `tick` after each trial.
    pub fn run(
        &self,
        plans: &[PathBuf],
        tick: &(dyn Fn() + Sync),
    ) -> Result<RobustnessReport, Error> {
        self.validate()?;
        create_dir(self.out)?;
        let settings = SimSettings::default();
        let (mut rows, mut curves) = (Vec::new(), Vec::new());
        for path in plans {
            let plan = Plan::load(path)?;
            let mc = self.monte_carlo(&plan, &settings);
            let est = mc.estimate(self.samples, self.seed, tick)?;
            let files = Outputs { out: self.out, model: self.model, fixture: self.fixture };
            let mut row = files.write(path, &stem(path), &plan, &est)?;
            if self.sweep {
                let pts = mc.sweep(self.samples, self.seed, tick)?;
                curves.push((stem(path), pts.clone()));
                row.sweep = Some(pts);
            }
            rows.push(row);
        }
        let sweep_figure = if self.sweep {
            let fig = self.out.join("success_vs_uncertainty.png");
            let c: Vec<SweepCurve<'_>> =
                curves.iter().map(|(n, p)| (n.as_str(), p.as_slice())).collect();
            draw_sweep(&c, &fig)?;
            Some(fig)
        } else {
            None
        };
        Ok(RobustnessReport { rows, sweep_figure })
    }

    /// Runs shard `shard` of every plan of `plans`, writing `shard_STEM.json` into `out` for
    /// [`merge_shards`]; `tick` after each trial. The sweep is not sharded.
    pub fn run_shard(
        &self,
        plans: &[PathBuf],
        shard: Shard,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Vec<ShardRow>, Error> {
        self.validate()?;
        if self.sweep {
            return Err(Error::invalid("sweep", "the sweep cannot be sharded"));
        }
        create_dir(self.out)?;
        let settings = SimSettings::default();
        let mut rows = Vec::new();
        for path in plans {
            let plan = Plan::load(path)?;
            let mc = self.monte_carlo(&plan, &settings);
            let f = shard::run(&mc, self.samples as u64, self.seed, shard, tick)?;
            let file = self.out.join(format!("shard_{}.json", stem(path)));
            f.write(&file)?;
            rows.push(ShardRow {
                plan: plan.name.clone(),
                shard: format!("{}/{}", shard.index, shard.count),
                trials: f.items.len(),
                successes: f.items.iter().filter(|(_, t)| t.inserted).count(),
                shard_file: file,
            });
        }
        Ok(rows)
    }
}

/// Merges `robustness run --shard` outputs: `paths` are shard files or directories holding
/// `shard_*.json`; files of the same name are one plan's shards. Writes each plan's merged
/// failures figure and per-trial CSV into `out`; one row per plan, by file name.
pub fn merge_shards(paths: &[PathBuf], out: &Path) -> Result<Vec<PlanRow>, Error> {
    let mut groups: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for p in paths {
        let files: Vec<PathBuf> = if p.is_dir() {
            let rd = std::fs::read_dir(p).map_err(|e| Error::io(p, e))?;
            rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|f| is_shard_file(f)).collect()
        } else {
            vec![p.clone()]
        };
        for f in files {
            let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            groups.entry(name).or_default().push(f);
        }
    }
    if groups.is_empty() {
        return Err(Error::invalid("shard files", "no shard_*.json files in the given paths"));
    }
    create_dir(out)?;
    let mut rows = Vec::new();
    for (name, paths) in groups {
        let files: Vec<(PathBuf, shard::TrialShard)> =
            paths.into_iter().map(|p| shard::load(&p).map(|f| (p, f))).collect::<Result<_, _>>()?;
        let n = files.len();
        let (key, est) = shard::merge(files)?;
        let stem = name.trim_start_matches("shard_").trim_end_matches(".json");
        let ctx = Outputs { out, model: &key.model, fixture: &key.fixture };
        let mut row = ctx.write(Path::new(&name), stem, &key.plan, &est)?;
        row.shards = Some(n);
        rows.push(row);
    }
    Ok(rows)
}

fn is_shard_file(p: &Path) -> bool {
    let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
    name.starts_with("shard_") && name.ends_with(".json")
}

/// A plan file's stem (`plan` when it has none), naming its outputs.
fn stem(path: &Path) -> String {
    path.file_stem().and_then(|s| s.to_str()).unwrap_or("plan").to_string()
}

fn create_dir(dir: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Where a plan's figure and CSV go, and the world its nominal replay runs in.
struct Outputs<'a> {
    out: &'a Path,
    model: &'a Model,
    fixture: &'a Fixture,
}

impl Outputs<'_> {
    /// Writes the failures figure and the per-trial CSV; returns the plan's summary row.
    fn write(
        &self,
        path: &Path,
        stem: &str,
        plan: &Plan,
        est: &SuccessEstimate,
    ) -> Result<PlanRow, Error> {
        let fig = self.out.join(format!("failures_{stem}.png"));
        let title = format!("{}: {}/{} inserted", plan.name, est.successes, est.samples);
        draw_failures(&title, &est.trials, &fig)?;
        let csv = self.out.join(format!("trials_{stem}.csv"));
        let file = std::fs::File::create(&csv).map_err(|e| Error::io(&csv, e))?;
        write_trials_csv(&est.trials, std::io::BufWriter::new(file))
            .map_err(|e| Error::io(&csv, e))?;
        let mut sim =
            Simulator::new(self.model.clone(), self.fixture.clone(), SimSettings::default())?;
        Ok(PlanRow {
            plan: path.to_path_buf(),
            name: plan.name.clone(),
            success_rate: est.success_rate,
            ci_low: est.ci_low,
            ci_high: est.ci_high,
            samples: est.samples,
            successes: est.successes,
            jammed: est.trials.iter().filter(|t| t.jammed).count(),
            overloaded: est.trials.iter().filter(|t| t.overloaded).count(),
            sim_errors: est.trials.iter().filter(|t| t.error.is_some()).count(),
            moves: plan.moves_um.len(),
            travel_um: plan.travel_um(),
            failures_figure: fig,
            pushes_nominal: pushing_moves(&replay(&mut sim, plan, None)?),
            sweep: None,
            shards: None,
        })
    }
}
