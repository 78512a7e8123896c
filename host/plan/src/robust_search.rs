//! The robust design as `mesopush plan robust` runs it: seeded, from a chosen start (Table
//! II's skeleton, the shipped design, or any plan's moves), under a budget of replays (so the
//! same seed gives the same plan on any machine), optionally cut short by a wall-clock limit
//! (which then says so), then checked on fresh Monte Carlo draws (a master seed the design
//! never drew from) and replayed once nominally. Returns everything the command reports.

use crate::Error;
use crate::family::{PathFamily, PlanFamily, Table2Family, default_radius_um};
use crate::feasible::plan_is_feasible;
use crate::montecarlo::{MonteCarlo, SuccessEstimate};
use crate::press_start::press_on_rotated_peg;
use crate::pushes::pushing_moves;
use crate::robust::{RobustResult, design_robust};
use crate::robust_settings::RobustSettings;
use crate::skeleton::Skeleton;
use crate::staged::{
    DEFAULT_FIRST_STAGE_SHARE, Refine, Stage2, Stage2Input, first_stage_budget, second_stage,
};
use crate::world::UncertainWorld;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Overload, Plan, Simulator, replay};
use rand::SeedableRng;
use std::time::Instant;

/// Where a robust search starts, and so which family of plans it searches.
#[derive(Debug, Clone, PartialEq)]
pub enum Init {
    /// Table II's skeleton from the paper's numbers ([`Skeleton::table2_like`]);
    /// `press_on_rotated`: its press first moved onto the nominally rotated peg
    /// ([`press_on_rotated_peg`]).
    Table2 {
        /// Move the press onto the rotated peg before the search.
        press_on_rotated: bool,
    },
    /// Table II's skeleton from the shipped design ([`Skeleton::best_known`]).
    Shipped,
    /// Any plan (an RRT's, a file's): every move's end free within
    /// [`RobustSearch::move_radius_um`] along its axis ([`PathFamily`]).
    Plan {
        /// The plan the search starts from.
        plan: Plan,
    },
}

impl Default for Init {
    fn default() -> Self {
        Init::Table2 { press_on_rotated: true }
    }
}

/// A robust search with its budget and its check (plain data, documented defaults).
#[derive(Debug, Clone, PartialEq)]
pub struct RobustSearch {
    /// The design's settings (its replay budget: [`RobustSettings::max_replays`]).
    pub design: RobustSettings,
    /// Where the search starts. Default: Table II's numbers, press on the rotated peg.
    pub init: Init,
    /// How far each move's end may move when the search runs over a plan's moves (from
    /// [`Init::Plan`], or after wall presses), µm. Default none: [`default_radius_um`] of
    /// the part.
    pub move_radius_um: Option<f64>,
    /// A second stage after the design over the start family ([`crate::staged`]): search
    /// the moves of its plan again, with the best-screened press against a wall inserted
    /// ([`Refine::WallPress`]) or as it is ([`Refine::Moves`]); the two stages share
    /// [`RobustSettings::max_replays`] (stage 1 gets [`RobustSearch::first_stage_share`]).
    /// Default none: one stage.
    pub refine: Option<Refine>,
    /// Stage 1's share of [`RobustSettings::max_replays`] when there are two stages, in
    /// [0.05, 0.95]. Default [`DEFAULT_FIRST_STAGE_SHARE`] (0.35; until 2026-11-28 it was
    /// 0.5, which reproduces the designs measured before).
    pub first_stage_share: f64,
    /// Seed of the design's ChaCha8 stream (same seed, same plan). Default 1.
    pub seed: u64,
    /// Wall-clock limit, s: when it passes, no further generation starts (the finalists
    /// are still validated and confirmed) and the report says `stopped_by_time`. The
    /// result then depends on the machine's speed. Default none: the replay budget alone
    /// decides.
    pub time_limit_s: Option<f64>,
    /// Fresh Monte Carlo trials of the designed plan. Default 400 (at least 1 run).
    pub check_samples: usize,
    /// Master seed of the check; `None`: [`check_seed_for`] the design's seed.
    pub check_seed: Option<u64>,
}

impl Default for RobustSearch {
    fn default() -> Self {
        Self {
            design: RobustSettings::default(),
            init: Init::default(),
            move_radius_um: None,
            refine: None,
            first_stage_share: DEFAULT_FIRST_STAGE_SHARE,
            seed: 1,
            time_limit_s: None,
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
    /// The design: plan, parameters, training / validation / confirmation rates and counts.
    pub design: RobustResult,
    /// Names of the design's parameters ([`PlanFamily::names`]).
    pub param_names: Vec<String>,
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
    /// Whether the wall-clock limit stopped the search before its budget or its last
    /// generation (the plan then depends on the machine's speed).
    pub stopped_by_time: bool,
    /// Training worlds per candidate ([`RobustSettings::samples`]).
    pub training_samples: usize,
    /// Validation worlds ([`RobustSettings::validation_samples`]).
    pub validation_samples: usize,
    /// Confirmation worlds ([`RobustSettings::confirm_samples`]).
    pub confirmation_samples: usize,
    /// The replay budget ([`RobustSettings::max_replays`]) of both stages.
    pub max_replays: usize,
    /// Replays of every stage, screening and choice together (the design's own `trials`
    /// count only the returned stage's).
    pub total_replays: usize,
    /// The second stage, when asked for (`design` is its plan if it won the choice, else
    /// stage 1's).
    pub stage2: Option<Stage2>,
    /// Stage 1's share of the replay budget, when there were two stages.
    pub first_stage_share: Option<f64>,
}

/// The family `init` searches, and its start parameters for a peg starting at `start`;
/// `radius_um`: how far a plan family's move ends may move.
pub fn family_for(
    init: &Init,
    world: &UncertainWorld<'_>,
    start: PegStart,
    radius_um: f64,
) -> Result<StartPoint, Error> {
    Ok(match init {
        Init::Table2 { press_on_rotated: false } => {
            (Box::new(Table2Family), Skeleton::table2_like().params.to_vec())
        }
        Init::Table2 { press_on_rotated: true } => {
            let s = press_on_rotated_peg(Skeleton::table2_like(), world, start)?;
            (Box::new(Table2Family), s.params.to_vec())
        }
        Init::Shipped => (Box::new(Table2Family), Skeleton::best_known().params.to_vec()),
        Init::Plan { plan } => {
            plan.validate()?;
            let f = PathFamily::around(plan, radius_um);
            let initial = f.initial().to_vec();
            (Box::new(f), initial)
        }
    })
}

/// A family and its start parameters.
pub type StartPoint = (Box<dyn PlanFamily>, Vec<f64>);

/// Designs a robust plan for a peg starting at `start` in `world` under `search`'s budget,
/// then checks it; `progress(generation, best_training_rate)` sees every generation.
pub fn search_robust(
    world: &UncertainWorld<'_>,
    start: PegStart,
    search: &RobustSearch,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<RobustReport, Error> {
    let mut settings = search.design;
    let radius_um = search.move_radius_um.unwrap_or(default_radius_um(world.model.part.polygon()));
    if !(radius_um.is_finite() && radius_um > 0.0) {
        let why = format!("{radius_um} µm: allowed a finite length above 0");
        return Err(Error::invalid("move_radius_um", why));
    }
    let (family, initial) = family_for(&search.init, world, start, radius_um)?;
    let t0 = Instant::now();
    if search.refine.is_some() {
        let share = search.first_stage_share;
        if !(0.05..=0.95).contains(&share) {
            let why = format!("{share}: allowed a share of the replays in [0.05, 0.95]");
            return Err(Error::invalid("first_stage_share", why));
        }
        settings.max_replays = first_stage_budget(search.design.max_replays, share);
        // Stage 1 must hold one generation with its validation and confirmation (stage 2
        // is skipped, and says so, when what is left cannot).
        let min = crate::cem::min_replays(&settings);
        if settings.max_replays < min {
            let mut least = (min as f64 / share).ceil() as usize;
            while first_stage_budget(least, share) < min {
                least += 1; // rounding: at most a step or two
            }
            let why = format!(
                "{} replays cannot hold the first of two stages (it gets {share} of them): \
                 allowed at least {least}",
                search.design.max_replays
            );
            return Err(Error::invalid("max_replays", why));
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(search.seed);
    let mut on_progress = |g: usize, best: f64| {
        progress(g, best);
        search.time_limit_s.is_none_or(|limit| t0.elapsed().as_secs_f64() < limit)
    };
    let first =
        design_robust(world, start, &*family, &initial, &settings, &mut rng, &mut on_progress)?;
    let (design, param_names, stage2) = match search.refine {
        None => (first, family.names(), None),
        Some(refine) => {
            let input = Stage2Input {
                world,
                start,
                settings: &search.design,
                radius_um,
                seed: search.seed,
            };
            let first = (first, family.names());
            let st = second_stage(&input, refine, first, &mut rng, &mut on_progress)?;
            let (design, names) = match (&st.second, &st.choice) {
                (Some(d), Some(c)) if c.second_wins() => (d.clone(), st.second_param_names.clone()),
                _ => (st.first.clone(), st.first_param_names.clone()),
            };
            (design, names, Some(st))
        }
    };
    let total_replays = stage2.as_ref().map_or(design.trials, |st| {
        st.first.trials + st.second.as_ref().map_or(0, |d| d.trials) + st.extra_replays
    });
    let stopped_by_time = stage2.as_ref().map_or(design.stopped_by_time, |st| {
        st.first.stopped_by_time || st.second.as_ref().is_some_and(|d| d.stopped_by_time)
    });
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
        param_names,
        stopped_by_time,
        design,
        check,
        check_seed,
        nominal_feasible,
        nominal_overload: nominal.overload,
        pushes,
        planning_ms,
        training_samples: settings.samples,
        validation_samples: settings.validation_samples,
        confirmation_samples: settings.confirm_samples,
        max_replays: search.design.max_replays,
        total_replays,
        stage2,
        first_stage_share: search.refine.map(|_| search.first_stage_share),
    })
}
