//! The identification report: Table I (per trial: simulations, X,Y MSE in µm², θ MSE in
//! deg² and rad² of its best candidate), the cross-trial matrix, the nominal parameters (the
//! sweep's least total error), the optimiser's result, the consistent set, and the model
//! chosen (the optimiser's when it ran and did better, else the sweep's nominal).

use super::IdentifySettings;
use super::bootstrap::{Bootstrap, named};
use super::consistent::{ConsistentSet, consistent_set, effective_count};
use super::data::IdentTrial;
use super::joint::Optimized;
use super::score::{Candidate, Score, residuals, score};
use super::sweep::Sweep;
use crate::Error;
use mesopush_sim::Model;
use serde::Serialize;
use std::fmt::Write;

/// One row of Table I.
#[derive(Debug, Clone, Serialize)]
pub struct TableRow {
    /// Trial id.
    pub trial: String,
    /// Simulations run for the trial (μ values × supports).
    pub simulations: usize,
    /// Of which failed (the simulator refused or wedged).
    pub failed: usize,
    /// μ of the trial's best candidate.
    pub best_mu_probe: f64,
    /// X,Y MSE of the best candidate, µm².
    pub xy_mse_um2: f64,
    /// θ MSE of the best candidate, deg².
    pub theta_mse_deg2: f64,
    /// θ MSE of the best candidate, rad².
    pub theta_mse_rad2: f64,
}

/// A candidate with its per-trial scores.
#[derive(Debug, Clone, Serialize)]
pub struct Scored {
    /// The parameters.
    pub candidate: Candidate,
    /// Total squared residual over all trials, µm².
    pub total_sse_um2: f64,
    /// Per trial, in trial order.
    pub per_trial: Vec<Score>,
}

/// Everything identification found.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Trial ids, in order.
    pub trials: Vec<String>,
    /// Table I.
    pub table: Vec<TableRow>,
    /// `[i][j]`: X,Y MSE (µm²) of trial i's best sweep candidate on trial j.
    pub cross_xy_mse_um2: Vec<Vec<f64>>,
    /// `[i][j]`: θ MSE (deg²) of trial i's best sweep candidate on trial j.
    pub cross_theta_mse_deg2: Vec<Vec<f64>>,
    /// The sweep's nominal choice (least total error over all trials).
    pub nominal: Scored,
    /// The joint optimiser's result, when run.
    pub optimized: Option<Scored>,
    /// Optimiser evaluations used.
    pub optimizer_evals: usize,
    /// The parameters written to the model: `"optimizer"` or `"sweep"`.
    pub chosen_from: &'static str,
    /// The consistent set (members are written to the supports file, not here).
    #[serde(skip)]
    pub consistent: ConsistentSet,
    /// Size of the consistent set.
    pub consistent_count: usize,
    /// Effective number of independent residuals behind the consistent set's threshold.
    pub consistent_n_effective: f64,
    /// Refits on bootstrap resamples of the trials (None: no joint fit, or < 3 trials).
    pub bootstrap: Option<Bootstrap>,
    /// The sweep's simulations.
    #[serde(skip)]
    pub sweep: Sweep,
}

fn scored(trials: &[IdentTrial], c: &Candidate, s: &IdentifySettings) -> Scored {
    let per_trial: Vec<Score> = trials.iter().map(|t| score(t, c, &s.score)).collect();
    let total_sse_um2 = per_trial.iter().map(Score::sse_um2).sum();
    Scored { candidate: c.clone(), total_sse_um2, per_trial }
}

impl Report {
    /// Assembles the report from the sweep and the optimiser's result.
    pub fn new(
        trials: &[IdentTrial],
        sweep: Sweep,
        opt: Option<Optimized>,
        boot: Option<Bootstrap>,
        settings: &IdentifySettings,
    ) -> Result<Self, Error> {
        let table = trials
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let row = &sweep.scores[i];
                let k = sweep.best_on(i);
                TableRow {
                    trial: t.id.clone(),
                    simulations: row.len(),
                    failed: row.iter().filter(|s| !s.ok()).count(),
                    best_mu_probe: sweep.candidate(k).mu_probe,
                    xy_mse_um2: row[k].xy_mse_um2,
                    theta_mse_deg2: row[k].theta_mse_deg2(),
                    theta_mse_rad2: row[k].theta_mse_rad2,
                }
            })
            .collect();
        let cross = sweep.cross();
        let nominal = scored(trials, &sweep.candidate(sweep.nominal()), settings);
        let optimized = opt.as_ref().map(|o| scored(trials, &o.best, settings));
        let chosen_from = match &optimized {
            Some(o) if o.total_sse_um2 < nominal.total_sse_um2 => "optimizer",
            _ => "sweep",
        };
        let mut candidates: Vec<(Candidate, f64)> = (0..sweep.n_candidates())
            .map(|k| (sweep.candidate(k), sweep.total_sse_um2(k)))
            .collect();
        if let Some(o) = &opt {
            candidates.extend(o.visited.iter().cloned());
        }
        let n_residuals = 3 * trials.iter().map(|t| t.measured.len()).sum::<usize>();
        let n_params = settings.optimize.as_ref().map_or(7, |o| o.layout().len());
        let chosen = match &optimized {
            Some(o) if o.total_sse_um2 < nominal.total_sse_um2 => &o.candidate,
            _ => &nominal.candidate,
        };
        let n_eff = effective_count(&residual_series(trials, chosen, settings));
        let mut consistent = consistent_set(&candidates, n_residuals, n_eff, n_params)?;
        if let Some(b) = &boot {
            // The refits join the set (what the trials cannot pin down), after its members.
            for (c, _) in &b.fits {
                if !consistent.members.iter().any(|m| &m.0 == c) {
                    let sse = scored(trials, c, settings).total_sse_um2;
                    consistent.members.push((c.clone(), sse));
                }
            }
        }
        Ok(Self {
            trials: trials.iter().map(|t| t.id.clone()).collect(),
            table,
            cross_xy_mse_um2: cross
                .iter()
                .map(|r| r.iter().map(|s| s.xy_mse_um2).collect())
                .collect(),
            cross_theta_mse_deg2: cross
                .iter()
                .map(|r| r.iter().map(Score::theta_mse_deg2).collect())
                .collect(),
            nominal,
            optimized,
            optimizer_evals: opt.as_ref().map_or(0, |o| o.evals),
            chosen_from,
            consistent_count: consistent.members.len(),
            consistent_n_effective: n_eff,
            consistent,
            bootstrap: boot,
            sweep,
        })
    }

    /// The chosen parameters and their scores.
    pub fn chosen(&self) -> &Scored {
        match (&self.optimized, self.chosen_from) {
            (Some(o), "optimizer") => o,
            _ => &self.nominal,
        }
    }

    /// The chosen model for `trial`'s part and probe (mu_wall from `settings`).
    pub fn model(&self, trial: &IdentTrial, settings: &IdentifySettings) -> Model {
        super::score::model_for(trial, &self.chosen().candidate, &settings.score)
    }

    /// Table I, the cross-trial matrix and the chosen parameters as text.
    pub fn text(&self) -> String {
        let mut s =
            String::from("TABLE I  MSE for unconstrained motion (best candidate per trial)\n");
        let _ = writeln!(
            s,
            "{:<14} {:>8} {:>7} {:>14} {:>14}",
            "trial", "sims", "best μ", "X,Y MSE [µm²]", "θ MSE [deg²]"
        );
        for r in &self.table {
            let _ = writeln!(
                s,
                "{:<14} {:>8} {:>7.2} {:>14.4} {:>14.6}",
                r.trial,
                r.simulations - r.failed,
                r.best_mu_probe,
                r.xy_mse_um2,
                r.theta_mse_deg2
            );
        }
        s.push_str("\nCross-trial X,Y MSE [µm²] (row: best support of trial i, column: scored on trial j)\n");
        for (i, row) in self.cross_xy_mse_um2.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|v| format!("{v:>10.2}")).collect();
            let _ = writeln!(s, "{:<14} {}", self.trials[i], cells.join(" "));
        }
        let line = |s: &mut String, name: &str, c: &Scored| {
            let xy = mean(c.per_trial.iter().map(|p| p.xy_mse_um2));
            let th = mean(c.per_trial.iter().map(Score::theta_mse_deg2));
            let p = c.candidate.support.points_um;
            let _ = writeln!(
                s,
                "{name:<10} μ = {:.3}, supports [{:.0}, {:.0}] [{:.0}, {:.0}] [{:.0}, {:.0}] µm, μ_s = {:.3}; \
                 mean X,Y MSE {xy:.4} µm², mean θ MSE {th:.6} deg², total SSE {:.1} µm²",
                c.candidate.mu_probe,
                p[0][0],
                p[0][1],
                p[1][0],
                p[1][1],
                p[2][0],
                p[2][1],
                c.candidate.support.mu_surface[0],
                c.total_sse_um2
            );
        };
        s.push('\n');
        line(&mut s, "nominal", &self.nominal);
        if let Some(o) = &self.optimized {
            line(&mut s, "optimized", o);
        }
        let c = &self.consistent;
        let _ = writeln!(
            s,
            "chosen from the {}; consistent set: {} of {} candidates (μ {:.3}..{:.3}, noise s = {:.3} µm per component)",
            self.chosen_from,
            c.members.len(),
            c.examined,
            c.mu_range[0],
            c.mu_range[1],
            c.noise_var_um2.sqrt()
        );
        s.push_str(&self.uncertainty_text());
        s
    }

    /// Each chosen parameter with its bootstrap ± (1 sd over the refits) beside its range over
    /// the consistent set.
    pub fn uncertainty_text(&self) -> String {
        let mut s = String::new();
        let members: Vec<Vec<(String, f64)>> =
            self.consistent.members.iter().map(|m| named(&m.0)).collect();
        let _ = writeln!(
            s,
            "\nparameter            chosen   bootstrap ±  consistent-set range ({} members, n_eff = {:.0} of {})",
            members.len(),
            self.consistent_n_effective,
            self.consistent.n_residuals
        );
        for (k, (name, v)) in named(&self.chosen().candidate).into_iter().enumerate() {
            let sd = self
                .bootstrap
                .as_ref()
                .map_or(String::from("(none)"), |b| format!("{:.4}", b.spread[k].sd));
            let (lo, hi) = members
                .iter()
                .map(|m| m[k].1)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
            let _ = writeln!(s, "{name:<18} {v:>10.4} {sd:>12}  {lo:.4} .. {hi:.4}");
        }
        if self.bootstrap.is_none() {
            s.push_str(
                "(no bootstrap: it needs the joint fit (--optimize) and at least three trials)\n",
            );
        }
        s
    }
}

/// The chosen candidate's residuals per trial and component (Δx, Δy, L·Δθ series).
fn residual_series(trials: &[IdentTrial], c: &Candidate, s: &IdentifySettings) -> Vec<Vec<f64>> {
    trials
        .iter()
        .filter_map(|t| residuals(t, c, &s.score))
        .flat_map(|r| (0..3).map(move |k| r.iter().skip(k).step_by(3).copied().collect()))
        .collect()
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    sum / n.max(1) as f64
}
