//! The confusion-matrix experiment: blind diagnoses of synthetic batches ([`crate::synth`]),
//! a few seeds per true effect with clean controls, summarised as a confusion matrix (true
//! effect × verdict) and each batch's held-out errors before and after. It measures how
//! often diagnosis names the right effect, says `unexplained`, or invents one on clean data.
//!
//! A batch that cannot be made or diagnosed is recorded as a failure and the run goes on: one
//! bad batch must not lose the others.

use crate::Error;
use crate::attribute::{Diagnosis, diagnose};
use crate::candidates::Effect;
use crate::data::load_split;
use crate::decide::Verdict;
use crate::options::Options;
use crate::report::mse_before_after;
use crate::residual::Mse;
use crate::synth::write_batch;
use serde::Serialize;
use std::fmt::Write;
use std::path::PathBuf;

/// What the experiment runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfusionSettings {
    /// True effects, one set of batches each ([`Effect::Nominal`]: the clean control).
    /// Default: the clean control, then every effect of [`Effect::EFFECTS`].
    pub truths: Vec<Effect>,
    /// Batches per true effect. Default 3.
    pub seeds: usize,
    /// Seed of each effect's first batch; batch k uses `first_seed + k`. Default 1.
    pub first_seed: u64,
    /// Trials per batch (even ones train, odd ones are held out). Default 6.
    pub n_trials: usize,
    /// Strokes per synthetic trial. Default 3.
    pub strokes: usize,
    /// The diagnosis run on each batch. Default [`Options::default`].
    pub options: Options,
    /// Where the batches are written, as `<out>/<effect>-<seed>` (cleared first).
    pub out: PathBuf,
}

impl ConfusionSettings {
    /// The documented defaults, writing batches under `out`.
    pub fn new(out: impl Into<PathBuf>) -> Self {
        Self {
            truths: std::iter::once(Effect::Nominal).chain(Effect::EFFECTS).collect(),
            seeds: 3,
            first_seed: 1,
            n_trials: 6,
            strokes: 3,
            options: Options::default(),
            out: out.into(),
        }
    }
}

/// One diagnosed batch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfusionRow {
    /// The effect the batch carries (serialised as the table's row label: `clean` for the
    /// control).
    #[serde(serialize_with = "truth_label")]
    pub truth: Effect,
    /// The batch's seed.
    pub seed: u64,
    /// The verdict's column: an effect's library name, `unexplained` or `none`.
    pub verdict: String,
    /// Held-out errors of the nominal model.
    pub before: Mse,
    /// Held-out errors of the diagnosis's model.
    pub after: Mse,
}

/// A batch that could not be made or diagnosed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfusionFailure {
    /// The effect the batch was to carry (serialised as the table's row label).
    #[serde(serialize_with = "truth_label")]
    pub truth: Effect,
    /// The batch's seed.
    pub seed: u64,
    /// What went wrong (the error and its causes).
    pub message: String,
}

/// What the experiment found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfusionReport {
    /// The true effects, in the order run (the matrix's rows; serialised as their labels).
    #[serde(serialize_with = "truth_labels")]
    pub truths: Vec<Effect>,
    /// Every diagnosed batch, in the order run.
    pub rows: Vec<ConfusionRow>,
    /// Every batch that failed, in the order run.
    pub failures: Vec<ConfusionFailure>,
}

/// How one batch ended: its diagnosis, or why it could not be made or diagnosed.
pub type BatchOutcome<'a> = Result<&'a Diagnosis, &'a Error>;

/// The verdict's column name of a diagnosis.
pub fn verdict_name(d: &Diagnosis) -> String {
    match d.verdict {
        Verdict::Effect => d.best.candidate.name().to_string(),
        Verdict::Unexplained => "unexplained".into(),
        Verdict::None => "none".into(),
    }
}

/// An error and its causes on one line (`error: cause: cause`).
fn chain(e: &Error) -> String {
    let mut s = e.to_string();
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        let _ = write!(s, ": {c}");
        cause = c.source();
    }
    s
}

/// A batch's log line: the verdict and every candidate's held-out error, BIC and parameters,
/// or the error.
pub fn batch_line(truth: Effect, seed: u64, outcome: BatchOutcome<'_>) -> String {
    let d = match outcome {
        Ok(d) => d,
        Err(e) => return format!("{} seed {seed}: error: {}", truth.name(), chain(e)),
    };
    let scores: Vec<String> = d
        .scores
        .iter()
        .map(|s| {
            let v: Vec<String> = s.params.iter().map(|p| format!("{:.3}", p.1)).collect();
            format!(
                "{} held-out {:.1} bic {:.0} ({})",
                s.candidate.name(),
                s.heldout_norm,
                s.bic,
                v.join(" ")
            )
        })
        .collect();
    format!("{} seed {seed}: {}\n  {}", truth.name(), verdict_name(d), scores.join("\n  "))
}

/// Makes and diagnoses one batch.
fn blind(s: &ConfusionSettings, truth: Effect, seed: u64) -> Result<Diagnosis, Error> {
    let dir = s.out.join(format!("{}-{seed}", truth.name()));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    }
    let dirs = write_batch(&dir, truth, s.n_trials, s.strokes, seed)?;
    let (train, heldout) = load_split(&dirs)?;
    diagnose(&train, &heldout, &s.options, &|_| {})
}

/// Runs the experiment; `on_batch` hears of every batch as it ends (for a log and progress).
pub fn run(
    s: &ConfusionSettings,
    on_batch: &mut dyn FnMut(Effect, u64, BatchOutcome<'_>),
) -> Result<ConfusionReport, Error> {
    if s.n_trials < 2 {
        return Err(Error::invalid(
            "n_trials",
            format!("{} per batch; diagnosis needs at least two", s.n_trials),
        ));
    }
    let mut report = ConfusionReport { truths: s.truths.clone(), rows: vec![], failures: vec![] };
    for &truth in &s.truths {
        for k in 0..s.seeds {
            let seed = s.first_seed + k as u64;
            match blind(s, truth, seed) {
                Ok(d) => {
                    on_batch(truth, seed, Ok(&d));
                    let (before, after) = mse_before_after(&d);
                    let verdict = verdict_name(&d);
                    report.rows.push(ConfusionRow { truth, seed, verdict, before, after });
                }
                Err(e) => {
                    on_batch(truth, seed, Err(&e));
                    let message = chain(&e);
                    report.failures.push(ConfusionFailure { truth, seed, message });
                }
            }
        }
    }
    Ok(report)
}

/// A true effect's row label: `clean` for the control.
fn label(t: Effect) -> &'static str {
    if t == Effect::Nominal { "clean" } else { t.name() }
}

fn truth_label<S: serde::Serializer>(t: &Effect, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(label(*t))
}

fn truth_labels<S: serde::Serializer>(t: &[Effect], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(t.iter().map(|t| label(*t)))
}

impl ConfusionReport {
    /// The matrix's columns: every effect's library name, `unexplained`, `none`.
    pub fn columns() -> Vec<String> {
        Effect::EFFECTS
            .iter()
            .map(|c| c.name().to_string())
            .chain(["unexplained".into(), "none".into()])
            .collect()
    }

    /// Batches of `truth` whose verdict is `column`.
    pub fn count(&self, truth: Effect, column: &str) -> usize {
        self.rows.iter().filter(|r| r.truth == truth && r.verdict == column).count()
    }

    /// The confusion matrix and the per-batch errors as Markdown tables.
    pub fn text(&self) -> String {
        let cols = Self::columns();
        let mut s = format!("| true \\ verdict | {} |\n", cols.join(" | "));
        let _ = writeln!(s, "|---|{}", "---|".repeat(cols.len()));
        for &t in &self.truths {
            let counts: Vec<String> = cols.iter().map(|c| self.count(t, c).to_string()).collect();
            let _ = writeln!(s, "| {} | {} |", label(t), counts.join(" | "));
        }
        s.push_str(
            "\n| true effect | seed | verdict | X,Y MSE before (µm²) | after | θ MSE before (rad²) | after |\n",
        );
        s.push_str("|---|---|---|---|---|---|---|\n");
        for r in &self.rows {
            let (b, a) = (&r.before, &r.after);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.2} | {:.2} | {:.2e} | {:.2e} |",
                label(r.truth),
                r.seed,
                r.verdict,
                b.xy_um2,
                a.xy_um2,
                b.theta_rad2,
                a.theta_rad2
            );
        }
        s
    }
}
