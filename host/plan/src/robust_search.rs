//! The robust design as `mesopush plan robust` runs it: seeded, under a wall-clock budget
//! that stops the search while the validation and confirmation of its finalists still fit,
//! then checked on fresh Monte Carlo draws (a master seed the design never drew from) and
//! replayed once nominally. Returns everything the command reports.

use crate::Error;
use crate::feasible::plan_is_feasible;
use crate::montecarlo::{MonteCarlo, SuccessEstimate};
use crate::pushes::pushing_moves;
use crate::robust::{RobustResult, design_robust};
use crate::robust_settings::RobustSettings;
use crate::world::UncertainWorld;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Overload, Simulator, replay};
use rand::SeedableRng;
use std::time::Instant;

/// A robust search with its budget and its check (plain data, documented defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustSearch {
    /// The design's settings.
    pub design: RobustSettings,
    /// Seed of the design's ChaCha8 stream (same seed, same plan). Default 1.
    pub seed: u64,
    /// Wall-clock budget, s: no generation starts that would leave too little time for the
    /// validation and confirmation after it. Default 60.
    pub time_limit_s: f64,
    /// Fresh Monte Carlo trials of the designed plan. Default 400 (at least 1 run).
    pub check_samples: usize,
    /// Master seed of the check; `None`: [`check_seed_for`] the design's seed.
    pub check_seed: Option<u64>,
}

impl Default for RobustSearch {
    fn default() -> Self {
        Self {
            design: RobustSettings::default(),
            seed: 1,
            time_limit_s: 60.0,
            check_samples: 400,
            check_seed: None,
        }
    }
}

/// The check's master seed for design seed `seed`: a different stream from every world the
/// design drew, for an honest figure.
pub fn check_seed_for(seed: u64) -> u64 {
    seed.wrapping_add(0x005E_ED0F_C4EC)
}

/// What a robust search designed and how it checked.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustReport {
    /// The design: plan, skeleton, training / validation / confirmation rates and counts.
    pub design: RobustResult,
    /// The fresh check of the designed plan.
    pub check: SuccessEstimate,
    /// The check's master seed.
    pub check_seed: u64,
    /// Whether the nominal replay inserts the peg (within the needle's limit) and keeps the
    /// probe clear.
    pub nominal_feasible: bool,
    /// The nominal replay's needle overload, when it bends the needle beyond the model's
    /// limit: `mesopush plan robust` then refuses the plan.
    pub nominal_overload: Option<Overload>,
    /// Moves of the nominal replay during which the probe pushes the peg.
    pub pushes: usize,
    /// Wall-clock time of the design (not the check), ms.
    pub planning_ms: f64,
    /// Whether the budget stopped the search before its last generation.
    pub time_limited: bool,
    /// Training worlds per candidate ([`RobustSettings::samples`]).
    pub training_samples: usize,
    /// Validation worlds ([`RobustSettings::validation_samples`]).
    pub validation_samples: usize,
    /// Confirmation worlds ([`RobustSettings::confirm_samples`]).
    pub confirmation_samples: usize,
}

/// Designs a robust plan for a peg starting at `start` in `world` under `search`'s budget,
/// then checks it; `progress(generation, best_training_rate)` sees every generation.
pub fn search_robust(
    world: &UncertainWorld<'_>,
    start: PegStart,
    search: &RobustSearch,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<RobustReport, Error> {
    let settings = &search.design;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(search.seed);
    let t0 = Instant::now();
    let mut time_limited = false;
    let mut on_progress = |g: usize, best: f64| {
        progress(g, best);
        let elapsed_s = t0.elapsed().as_secs_f64();
        let go_on = fits_another_generation(settings, g, elapsed_s, search.time_limit_s);
        time_limited |= !go_on && g < settings.generations * settings.rounds;
        go_on
    };
    let design = design_robust(world, start, settings, &mut rng, &mut on_progress)?;
    let planning_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut sim =
        Simulator::new(world.model.clone(), world.fixture.clone(), world.settings.clone())?;
    let nominal_feasible = plan_is_feasible(&mut sim, &design.plan)?;
    let mc = MonteCarlo {
        plan: &design.plan,
        model: world.model,
        fixture: world.fixture,
        settings: world.settings,
        uncertainty: world.uncertainty,
        supports: world.supports,
    };
    let check_seed = search.check_seed.unwrap_or(check_seed_for(search.seed));
    let check = mc.estimate(search.check_samples.max(1), check_seed, &|| ())?;
    let nominal = replay(&mut sim, &design.plan, None)?;
    let pushes = pushing_moves(&nominal);
    Ok(RobustReport {
        design,
        check,
        check_seed,
        nominal_feasible,
        nominal_overload: nominal.overload,
        pushes,
        planning_ms,
        time_limited,
        training_samples: settings.samples,
        validation_samples: settings.validation_samples,
        confirmation_samples: settings.confirm_samples,
    })
}

/// Whether generation `g + 1` and the validation still fit in `limit_s` after `elapsed_s`.
fn fits_another_generation(
    settings: &RobustSettings,
    g: usize,
    elapsed_s: f64,
    limit_s: f64,
) -> bool {
    // A generation is about 16 candidates on 96 worlds × 3/4 each (racing).
    let per_gen = (settings.population * settings.samples * 3 / 4).max(1) as f64;
    let val = (settings.finalists * settings.validation_samples) as f64;
    let conf = (settings.confirm_top * settings.confirm_samples) as f64;
    let gen_s = elapsed_s / g.max(1) as f64;
    // Validation runs at the fine step, on the default box: about 1.7 times the cost of a
    // training replay (one core: 1000 fine replays take 3.35 s in `mesopush robustness`, and
    // one search ran 7400 training and 6000 fine replays in 35 s); 2 keeps a margin (3 stopped
    // that search after 6 of its 12 generations). At the end of a round its own validation
    // runs before the next round's first generation: reserve both. The confirmation runs
    // once, at the very end.
    let fine_s = |replays: f64| gen_s * 2.0 * replays / per_gen;
    let round_end = g.is_multiple_of(settings.generations.max(1));
    let next = gen_s + fine_s(val * if round_end { 2.0 } else { 1.0 } + conf);
    elapsed_s + 1.2 * next < limit_s
}
