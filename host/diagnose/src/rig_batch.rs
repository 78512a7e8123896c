//! A batch generator through the whole loop: short pushes run by [`mesopush_rig::run_trial`]
//! (executor, pseudo-terminal, firmware simulator, camera, tracker) in simulated time, in a
//! world whose `[effects]` the host is never told. The trial directories are what a rig
//! records, so diagnosing them tests diagnosis on data our synthetic generator did not
//! make: rendered and tracked frames, the executor's time base and setpoint schedule.
//!
//! Each trial pushes the paper's peg (at the Table II start, in the fixture) from its right
//! side: push in, back off (a reversal), push again, retract (a release) — at a speed and a
//! contact point drawn per trial, so velocity, reversals and rotation all vary over the
//! batch.

use crate::Error;
use mesopush_rig::{ClockMode, TrialSpec, WorldFile, run_trial};
use mesopush_sim::Plan;
use mesopush_trial::TrialState;
use rand::{Rng, RngExt, SeedableRng};
use std::path::{Path, PathBuf};

/// The probe starts this far right of the Table II peg's right edge, µm.
const CLEARANCE_UM: f64 = 70.0;
/// The Table II peg's right edge (peg at x 2330 µm, θ 89°, 1 mm wide), µm.
const PEG_RIGHT_EDGE_UM: f64 = 2830.0;

/// One trial's plan: push, back off, push again, retract, from the peg's right side.
pub fn push_plan(rng: &mut impl Rng) -> Plan {
    let y = rng.random_range(900.0..1500.0);
    let push = rng.random_range(150.0..250.0);
    let back = rng.random_range(30.0..60.0);
    let again = rng.random_range(80.0..140.0);
    Plan {
        name: "diagnose rig batch: push, back off, push, retract".into(),
        speed_um_s: rng.random_range(150.0..400.0),
        probe_start_um: [PEG_RIGHT_EDGE_UM + CLEARANCE_UM, y],
        moves_um: vec![[-push, 0.0], [back, 0.0], [-again, 0.0], [150.0, 0.0]],
        ..Plan::table2()
    }
}

/// Runs `n_trials` trials of `world` into `out/trial-NNN` (simulated time; trial `k` uses
/// seed `seed · 1000 + k`) and returns their directories. A trial that does not finish
/// (`done`) is an error naming it.
pub fn write_rig_batch(
    out: &Path,
    world: &WorldFile,
    n_trials: usize,
    seed: u64,
) -> Result<Vec<PathBuf>, Error> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n_trials)
        .map(|k| {
            let id = format!("trial-{k:03}");
            let spec = TrialSpec {
                trial_id: id.clone(),
                plan: push_plan(&mut rng),
                world: world.clone(),
                seed: seed.wrapping_mul(1000).wrapping_add(k as u64),
                clock: ClockMode::Simulated,
                peg_start: None,
                controller: mesopush_rig::drive::spec::ControllerKind::Native,
            };
            let report = run_trial(&spec, &out.join(&id), &mut |_| {})?;
            if report.state != TrialState::Done {
                return Err(Error::invalid(
                    "rig batch",
                    format!(
                        "{id} ended {}: {}",
                        report.state,
                        report.reason.as_deref().unwrap_or("no reason recorded")
                    ),
                ));
            }
            Ok(report.dir)
        })
        .collect()
}
