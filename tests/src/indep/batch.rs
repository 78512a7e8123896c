//! Batches: six trials (by default) in one world with one effect (or none), each its own
//! directory `trial-NNN`; several batches under one output directory with a
//! `manifest.json` naming each batch's true effect and parameters (the answer key of a
//! confusion matrix). Seeds: batch `b` of effect `e` has `derive(seed, e·65536 + b)`; trial
//! `i`'s plan `derive(batch, 2i + 1)`, its camera `derive(batch, 2i + 2)`, the effect's drawn
//! parts `derive(batch, 0)`.

use super::Error;
use super::camera::{Frame, Noise, frames};
use super::effects::{EFFECT_NAMES, Effect};
use super::physics::{Truth, simulate};
use super::plan::{PushPlan, push_plan};
use super::rng::{Rng, derive};
use super::world::World;
use super::writer::{SOURCE, TrialRecord, write_trial};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Trials per batch.
pub const TRIALS_PER_BATCH: usize = 6;

/// What one batch is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchSpec {
    /// The world (before any drift).
    pub world: World,
    /// The effect.
    pub effect: Effect,
    /// The batch's seed.
    pub seed: u64,
    /// Trials.
    pub n_trials: usize,
    /// Tracker noise.
    pub noise: Noise,
}

impl BatchSpec {
    /// A batch of [`TRIALS_PER_BATCH`] trials with default noise; the effect `name` at its
    /// standard size, drawn from `seed`.
    pub fn standard(world: World, name: &str, seed: u64) -> Result<Self, Error> {
        let effect = Effect::standard(name, &mut Rng::new(derive(seed, 0)))?;
        Ok(Self { world, effect, seed, n_trials: TRIALS_PER_BATCH, noise: Noise::default() })
    }
}

/// One trial, made but not written.
#[derive(Debug, Clone, PartialEq)]
pub struct MadeTrial {
    /// The world it ran in (drift applied).
    pub world: World,
    /// Its plan.
    pub plan: PushPlan,
    /// The true motion.
    pub truth: Truth,
    /// The tracked frames.
    pub frames: Vec<Frame>,
    /// Plan and camera seeds.
    pub seeds: [u64; 2],
}

/// Makes trial `index` of the batch `spec`.
pub fn make_trial(spec: &BatchSpec, index: usize) -> Result<MadeTrial, Error> {
    let k = index as u64;
    let seeds = [derive(spec.seed, 2 * k + 1), derive(spec.seed, 2 * k + 2)];
    let plan = push_plan(&spec.world, seeds[0]);
    let world = match spec.effect {
        Effect::Drift { per_trial_um } => spec
            .world
            .with_supports_moved([per_trial_um[0] * k as f64, per_trial_um[1] * k as f64])?,
        _ => spec.world.clone(),
    };
    let truth = simulate(&world, &spec.effect, plan.start, &plan.path);
    let frames = frames(&truth, &spec.effect, &spec.noise, &mut Rng::new(seeds[1]));
    Ok(MadeTrial { world, plan, truth, frames, seeds })
}

/// Writes the batch into `dir/trial-NNN`; returns the trial directories.
pub fn write_batch(dir: &Path, spec: &BatchSpec) -> Result<Vec<PathBuf>, Error> {
    (0..spec.n_trials)
        .map(|i| {
            let t = make_trial(spec, i)?;
            let id = format!("trial-{i:03}");
            let record = TrialRecord {
                id: &id,
                index: i,
                world: &t.world,
                effect: &spec.effect,
                start: t.plan.start,
                path: &t.plan.path,
                truth: &t.truth,
                frames: &t.frames,
                seeds: t.seeds,
            };
            let d = dir.join(&id);
            write_trial(&d, &record)?;
            Ok(d)
        })
        .collect()
}

/// What [`write_batches`] makes.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// Output directory.
    pub out: PathBuf,
    /// Master seed.
    pub seed: u64,
    /// Effect names (`all`: every one of [`EFFECT_NAMES`]).
    pub effects: Vec<String>,
    /// Batches per effect.
    pub batches: usize,
    /// World name, or `mixed` (batch `b` in world `b mod 3`).
    pub world: String,
    /// Needle radius, µm (`None`: the world's 12.5).
    pub pusher_radius_um: Option<f64>,
}

fn world_for(req: &Request, b: usize) -> Result<World, Error> {
    let name = if req.world == "mixed" {
        super::world::WORLD_NAMES[b % super::world::WORLD_NAMES.len()]
    } else {
        req.world.as_str()
    };
    let mut w = World::named(name)?;
    if let Some(r) = req.pusher_radius_um {
        w.pusher_radius_um = r;
        w.validate()?;
    }
    Ok(w)
}

/// Writes `batches` batches per effect under `out/<effect>-<b>` and `out/manifest.json`;
/// returns the manifest.
pub fn write_batches(req: &Request) -> Result<Value, Error> {
    let names: Vec<&str> = if req.effects.iter().any(|e| e == "all") {
        EFFECT_NAMES.to_vec()
    } else {
        req.effects.iter().map(String::as_str).collect()
    };
    let mut entries = Vec::new();
    for name in names {
        let e = EFFECT_NAMES.iter().position(|n| *n == name).ok_or_else(|| {
            Error::invalid("effect", format!("{name:?}; known: all, {}", EFFECT_NAMES.join(", ")))
        })?;
        for b in 0..req.batches {
            let seed = derive(req.seed, (e as u64) << 16 | b as u64);
            let spec = BatchSpec::standard(world_for(req, b)?, name, seed)?;
            let rel = format!("{name}-{b:02}");
            let trials = write_batch(&req.out.join(&rel), &spec)?;
            let trial_names: Vec<String> = trials
                .iter()
                .filter_map(|t| t.file_name().map(|n| format!("{rel}/{}", n.to_string_lossy())))
                .collect();
            entries.push(json!({
                "dir": rel,
                "trials": trial_names,
                "truth": spec.effect.to_json(),
                "world": spec.world.name,
                "pusher_radius_um": spec.world.pusher_radius_um,
                "seed": seed,
            }));
        }
    }
    let manifest = json!({
        "format": "indep-batches",
        "generator": SOURCE,
        "seed": req.seed,
        "batches": entries,
    });
    let path = req.out.join("manifest.json");
    let text = serde_json::to_string_pretty(&manifest)
        .map_err(|e| Error::invalid("manifest", e.to_string()))?;
    std::fs::create_dir_all(&req.out).map_err(|e| Error::io(&req.out, e))?;
    std::fs::write(&path, text + "\n").map_err(|e| Error::io(&path, e))?;
    Ok(manifest)
}
