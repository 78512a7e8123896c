//! System identification from unconstrained pushing trials (the paper's section IV-A, Table I)
//! and beyond it: a joint optimiser and the set of supports consistent with the data.
//!
//! Pipeline ([`identify`]): load trial logs ([`data`]) → sweep μ × random supports
//! ([`mod@sweep`], [`score`], [`sample`]; split into processes by [`shard`]) → optionally
//! refine jointly ([`joint`]) → the consistent set ([`consistent`]) → the report
//! ([`report`]: Table I, cross-trial matrix, chosen model). Only the trial-log format is
//! read, so any convex part at any scale and speed is identified the same way. [`synth`]
//! writes simulated trials with known truth for tests and demos; [`figure`] draws the paper's
//! Fig. 5 from the identified model. [`optim`] holds the minimisers (Nelder–Mead, evolution
//! strategy, Levenberg–Marquardt) the joint fit and `mesopush-diagnose` share.
//!
//! May depend on: `mesopush-core`, `mesopush-sim`, `mesopush-trial` (what it reads),
//! `mesopush-plot` and `mesopush-protocol` (its `units`, for the trial log's µs). Never on
//! planning, the rig, diagnosis or batches.

pub mod bootstrap;
pub mod consistent;
pub mod data;
pub mod error;
pub mod figure;
pub mod joint;
pub mod optim;
pub mod report;
pub mod sample;
pub mod score;
pub mod shard;
pub mod sweep;
pub mod synth;

pub use consistent::{ConsistentSet, consistent_set};
pub use data::IdentTrial;
pub use error::Error;
pub use joint::{OptimizeSettings, Optimized, optimize};
pub use report::Report;
pub use score::{Candidate, Score, ScoreSettings};
pub use sweep::{Sweep, SweepSettings, sweep};

use rand::Rng;

/// Everything [`identify`] needs besides the trials.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IdentifySettings {
    /// The paper's sweep.
    pub sweep: SweepSettings,
    /// The joint optimiser (None: sweep only).
    pub optimize: Option<OptimizeSettings>,
    /// Simulator settings and fixed friction.
    pub score: ScoreSettings,
    /// Refits on bootstrap resamples of the trials (after the joint fit; none without it).
    pub bootstrap: bootstrap::BootstrapSettings,
}

/// Progress callbacks, one per stage (each called once per simulation or evaluation).
pub struct Ticks<'a> {
    /// Sweep simulations.
    pub sweep: &'a (dyn Fn() + Sync),
    /// Optimiser objective evaluations.
    pub optimize: &'a (dyn Fn() + Sync),
}

impl std::fmt::Debug for Ticks<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Ticks")
    }
}

/// No progress reporting.
pub const NO_TICKS: Ticks<'static> = Ticks { sweep: &|| {}, optimize: &|| {} };

/// Runs the whole identification.
pub fn identify(
    trials: &[IdentTrial],
    settings: &IdentifySettings,
    rng: &mut impl Rng,
    ticks: &Ticks<'_>,
) -> Result<Report, Error> {
    let sw = sweep(trials, &settings.sweep, &settings.score, rng, ticks.sweep)?;
    identify_from(trials, sw, settings, rng, ticks)
}

/// [`identify`] from a sweep already made (e.g. merged from shards, [`shard`]); `rng`
/// must be where [`identify`]'s is after the sweep (past `sweep::grid`'s draws).
pub fn identify_from(
    trials: &[IdentTrial],
    sw: Sweep,
    settings: &IdentifySettings,
    rng: &mut impl Rng,
    ticks: &Ticks<'_>,
) -> Result<Report, Error> {
    if !sw.total_sse_um2(sw.nominal()).is_finite() {
        // Name a cause: the first trial the sweep's first candidate cannot simulate.
        let c = sw.candidate(sw.nominal());
        let why = trials
            .iter()
            .find_map(|t| score::simulate_or_why(t, &c, &settings.score).err().map(|e| (t, e)))
            .map_or(String::new(), |(t, e)| {
                format!("; e.g. with μ = {:.2}, trial {}: {e}", c.mu_probe, t.id)
            });
        return Err(Error::invalid(
            "identify",
            format!(
                "no sampled candidate could simulate every trial (are the trials unconstrained \
                 pushes of the part recorded in trial.json?){why}"
            ),
        ));
    }
    let opt = settings.optimize.as_ref().map(|o| {
        let starts: Vec<Candidate> =
            sw.ranked(o.starts).into_iter().map(|k| sw.candidate(k)).collect();
        optimize(trials, &starts, o, &settings.score, rng, ticks.optimize)
    });
    let boot = opt.as_ref().zip(settings.optimize.as_ref()).and_then(|(o, os)| {
        let (b, s) = (&settings.bootstrap, &settings.score);
        bootstrap::bootstrap(trials, &o.best, os.layout(), b, s, rng, ticks.optimize)
    });
    Report::new(trials, sw, opt, boot, settings)
}
