//! One round of the cross-entropy method over a [`PlanFamily`]'s parameters, with racing and
//! fresh training worlds every generation (`robust` runs the rounds and chooses the plan
//! among their finalists). Every generation first checks that it and everything the search
//! must still run after it (the round's final mean, validation, confirmation) fit the budget
//! of replays: the budget counts simulations, so a seed gives the same plan on any machine.

use crate::family::PlanFamily;
use crate::montecarlo::draws;
use crate::robust_settings::RobustSettings;
use crate::sampler::Draw;
use crate::score::successes;
use crate::world::UncertainWorld;
use mesopush_sim::plan::PegStart;
use rand::RngExt;

fn gaussian(rng: &mut impl rand::Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A scored candidate: parameters and successes on all training worlds.
pub(crate) type Scored = (Vec<f64>, usize);

/// One raced generation: returns the candidates that ran on every training world, best first
/// (stable: ties keep sampling order), and the number of replays simulated.
fn race(
    cands: &[Vec<f64>],
    worlds: &[Draw],
    keep: usize,
    ctx: &Ctx<'_, '_>,
) -> (Vec<Scored>, usize) {
    let half = worlds.len() / 2;
    let first = successes(ctx.family, cands, &worlds[..half], ctx.world, ctx.start);
    let mut order: Vec<usize> = (0..cands.len()).collect();
    order.sort_by(|a, b| first[*b].cmp(&first[*a]));
    order.truncate(keep.min(cands.len()));
    let survivors: Vec<Vec<f64>> = order.iter().map(|&i| cands[i].clone()).collect();
    let second = successes(ctx.family, &survivors, &worlds[half..], ctx.world, ctx.start);
    let mut scored: Vec<Scored> =
        order.iter().zip(&second).map(|(&i, s2)| (cands[i].clone(), first[i] + s2)).collect();
    scored.sort_by_key(|a| std::cmp::Reverse(a.1));
    let replays = cands.len() * half + survivors.len() * (worlds.len() - half);
    (scored, replays)
}

/// `n` candidates drawn around `mean` with spreads `sigma`, clamped into the family's box.
fn sample(
    mean: &[f64],
    sigma: &[f64],
    n: usize,
    family: &dyn PlanFamily,
    rng: &mut impl rand::Rng,
) -> Vec<Vec<f64>> {
    (0..n)
        .map(|_| {
            let p: Vec<f64> = mean.iter().zip(sigma).map(|(m, s)| m + s * gaussian(rng)).collect();
            family.clamped(&p)
        })
        .collect()
}

/// Moves the sampling distribution to the elite's mean and (smoothed) spread.
fn update(mean: &mut [f64], sigma: &mut [f64], elite: &[Scored]) {
    let n = elite.len() as f64;
    for (k, (m, s)) in mean.iter_mut().zip(sigma.iter_mut()).enumerate() {
        let mu = elite.iter().map(|e| e.0[k]).sum::<f64>() / n;
        let var = elite.iter().map(|e| (e.0[k] - mu).powi(2)).sum::<f64>() / n;
        *m = mu;
        *s = (0.7 * *s + 0.3 * var.sqrt()).max(5.0);
    }
}

/// Counters of a search.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Counts {
    pub(crate) evaluations: usize,
    pub(crate) replays: usize,
    pub(crate) generations: usize,
    pub(crate) rounds: usize,
    /// Whether the caller's `progress` or the target rate ended the search.
    pub(crate) stopped: bool,
    /// Whether `progress` asked to stop (a wall-clock limit).
    pub(crate) stop_asked: bool,
    /// Whether that stop cut work that would otherwise have run.
    pub(crate) stopped_by_time: bool,
    /// Whether the replay budget ended the search before its last generation.
    pub(crate) out_of_budget: bool,
}

/// What a round works on.
pub(crate) struct Ctx<'a, 'w> {
    pub(crate) world: &'a UncertainWorld<'w>,
    pub(crate) start: PegStart,
    pub(crate) family: &'a dyn PlanFamily,
    /// Where every round starts (the first generation's sampling mean; always a finalist).
    pub(crate) initial: &'a [f64],
}

/// The smallest budget that holds the first round's start, one generation and everything
/// after it: below it a search could not keep its budget.
pub(crate) fn min_replays(settings: &RobustSettings) -> usize {
    settings.samples.max(2) + generation_replays(settings) + reserve(settings)
}

/// Replays the search must keep for after any generation: the round's final mean and its
/// validation, and the confirmation at the end.
pub(crate) fn reserve(settings: &RobustSettings) -> usize {
    settings.samples.max(2)
        + settings.finalists.max(1) * settings.validation_samples
        + settings.confirm_top.max(1) * settings.confirm_samples
}

/// Replays one generation may use at most: every candidate (and the incumbent) on the first
/// half of the training worlds, the survivors on the second.
pub(crate) fn generation_replays(settings: &RobustSettings) -> usize {
    let n = settings.samples.max(2);
    let keep = settings.elite.max(1).max(settings.population / 2);
    (settings.population + 1) * (n / 2) + keep.min(settings.population + 1) * (n - n / 2)
}

/// One CEM round from [`Ctx::initial`]; returns its finalists (the best trained,
/// the final sampling mean, the initial skeleton, then the next best distinct ones), adding to
/// `counts`.
///
/// `reserve(counts)` is the number of replays the search must keep for after this
/// generation; a generation runs only while it fits [`RobustSettings::max_replays`].
pub(crate) fn cem_round(
    ctx: &Ctx<'_, '_>,
    settings: &RobustSettings,
    rng: &mut impl rand::Rng,
    progress: &mut dyn FnMut(usize, f64) -> bool,
    reserve: usize,
    counts: &mut Counts,
) -> Vec<Scored> {
    let (world, family) = (ctx.world, ctx.family);
    let n_train = settings.samples.max(2);
    let train_unc = world.uncertainty.scaled(settings.train_scale.max(0.0));
    let new_worlds = |seed: u64| draws(world.model, &train_unc, world.supports, n_train, seed);
    let mut worlds = new_worlds(rng.random());
    let s0 = family.clamped(ctx.initial);
    let s0_scored =
        (s0.clone(), successes(family, std::slice::from_ref(&s0), &worlds, world, ctx.start)[0]);
    let mut hall: Vec<Scored> = vec![s0_scored.clone()];
    counts.evaluations += 1;
    counts.replays += n_train;
    let mut mean = s0;
    let mut sigma: Vec<f64> = family.bounds().iter().map(|(lo, hi)| (hi - lo) / 6.0).collect();
    let elite_n = settings.elite.max(1);
    let keep = elite_n.max(settings.population / 2);
    // The incumbent: the best so far, scored on the current worlds.
    let mut incumbent = hall[0].clone();
    for g in 0..settings.generations {
        if counts.replays + generation_replays(settings) + reserve > settings.max_replays {
            counts.out_of_budget = true;
            break;
        }
        counts.generations += 1;
        let mut cands = sample(&mean, &sigma, settings.population, family, rng);
        let fresh = settings.resample && g > 0;
        if fresh {
            // New worlds each generation: the incumbent races again on them (last, so ties
            // go to a new candidate), and no score is compared across world sets.
            worlds = new_worlds(rng.random());
            cands.push(incumbent.0.clone());
        }
        counts.evaluations += cands.len();
        let (scored, used) = race(&cands, &worlds, keep, ctx);
        counts.replays += used;
        // The incumbent stays in the elite (stable merge: on ties the older one first).
        let mut pool: Vec<Scored> = if fresh { Vec::new() } else { vec![incumbent.clone()] };
        pool.extend(scored.iter().cloned());
        pool.sort_by_key(|a| std::cmp::Reverse(a.1));
        update(&mut mean, &mut sigma, &pool[..elite_n.min(pool.len())]);
        incumbent = pool[0].clone();
        hall.extend(scored);
        hall.sort_by_key(|a| std::cmp::Reverse(a.1));
        let best_rate = incumbent.1 as f64 / n_train as f64;
        let reached = settings.target_rate < 1.0 && best_rate >= settings.target_rate;
        let go_on = progress(counts.generations, best_rate);
        if !go_on || reached {
            counts.stopped = true;
            counts.stop_asked |= !go_on;
            counts.stopped_by_time |= !go_on && g + 1 < settings.generations;
            break;
        }
    }
    // The sampling distribution's mean is a finalist too: the centre of the region the elite
    // found, less likely than the single best to owe its score to lucky draws.
    let centre = family.clamped(&mean);
    let centre_train =
        successes(family, std::slice::from_ref(&centre), &worlds, world, ctx.start)[0];
    counts.replays += n_train;
    Finalists { incumbent, centre: (centre, centre_train), start: s0_scored, hall: &hall }
        .pick(settings.finalists.max(1))
}

/// The candidates a round hands to validation.
struct Finalists<'a> {
    /// The best trained.
    incumbent: Scored,
    /// The final sampling mean.
    centre: Scored,
    /// The round's start.
    start: Scored,
    /// Every candidate that ran on all training worlds, best first.
    hall: &'a [Scored],
}

impl Finalists<'_> {
    /// The incumbent, the centre and the start (distinct, in that order), then the next best
    /// distinct ones of the hall, `n` in all.
    fn pick(&self, n: usize) -> Vec<Scored> {
        // The start too: the search never returns worse than where it started on the
        // validation worlds (its training score is from the first generation's worlds).
        let mut finalists: Vec<Scored> = Vec::new();
        for f in [&self.incumbent, &self.centre, &self.start] {
            if !finalists.iter().any(|g| g.0 == f.0) {
                finalists.push(f.clone());
            }
        }
        finalists.truncate(n);
        for h in self.hall {
            if finalists.len() >= n {
                break;
            }
            if !finalists.iter().any(|f| f.0 == h.0) {
                finalists.push(h.clone());
            }
        }
        finalists
    }
}
