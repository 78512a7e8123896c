//! How well the project's simulator, given the independent generator's *true* parameters,
//! predicts the held-out trials of clean batches, at several simulator steps: the best any
//! fitted three-point model can do under the diagnosis's replay (restarts from the measured
//! resting poses). docs/diagnose.md, "A finer step near the floor".
//!
//! ```text
//! cargo run --release -p mesopush-tests --example indep_truth_heldout -- \
//!     --world peg|pentagon --seeds S1,S2,... [--steps-um 5,2.5,1]
//! ```
//!
//! The seeds are batch seeds (`seed` in `indep_batches`' manifest.json, or any u64). Prints
//! one line per batch: held-out X,Y MSE over the floor 2σ² at each step (σ estimated from the
//! batch, as the diagnosis does; steps for the paper's peg, scaled to the part). Exit code 2 on
//! invalid arguments.

#[path = "../tests/common/mod.rs"]
mod common;

use common::project_model;
use mesopush_diagnose::TrialData;
use mesopush_diagnose::data::load_split;
use mesopush_diagnose::objective::residuals;
use mesopush_diagnose::residual::{Mse, Noise};
use mesopush_sim::SimSettings;
use mesopush_tests::indep::batch::{BatchSpec, write_batch};
use mesopush_tests::indep::world::World;
use std::process::ExitCode;

struct Request {
    world: String,
    seeds: Vec<u64>,
    steps_um: Vec<f64>,
}

fn parse(args: &[String]) -> Result<Request, String> {
    let mut req = Request { world: "peg".into(), seeds: Vec::new(), steps_um: vec![5.0, 2.5, 1.0] };
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let bad = |what: &str| format!("{flag} = {value:?}: not {what}");
        match flag.as_str() {
            "--world" => req.world = value.clone(),
            "--seeds" => {
                req.seeds = value
                    .split(',')
                    .map(|s| s.trim().parse::<u64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| bad("a comma-separated list of u64 seeds"))?
            }
            "--steps-um" => {
                req.steps_um = value
                    .split(',')
                    .map(|s| s.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| bad("a comma-separated list of steps in µm"))?;
                if req.steps_um.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                    return Err(bad("a list of steps above 0 µm"));
                }
            }
            _ => return Err(format!("unknown argument {flag:?}")),
        }
    }
    if req.seeds.is_empty() {
        return Err("--seeds S1,S2,... is required".into());
    }
    if !matches!(req.world.as_str(), "peg" | "pentagon") {
        return Err(format!("--world = {:?}: allowed peg or pentagon (three supports)", req.world));
    }
    Ok(req)
}

/// Held-out X,Y MSE over the floor at each step, for the clean batch `seed` of `world`.
fn ratios(world: &World, seed: u64, steps_um: &[f64]) -> Result<Vec<f64>, String> {
    let tmp = tempfile::tempdir().map_err(|e| e.to_string())?;
    let spec = BatchSpec::standard(world.clone(), "clean", seed).map_err(|e| e.to_string())?;
    let dirs = write_batch(tmp.path(), &spec).map_err(|e| e.to_string())?;
    let (train, test) = load_split(&dirs).map_err(|e| e.to_string())?;
    let all: Vec<TrialData> = train.iter().chain(&test).cloned().collect();
    let noise = Noise::estimate(&all);
    let floor = 2.0 * noise.xy_um * noise.xy_um;
    let model = project_model(world);
    let base = SimSettings::default().scaled_to(&model.part);
    let scale = base.step_um / SimSettings::default().step_um;
    steps_um
        .iter()
        .map(|s| {
            let settings = SimSettings { step_um: s * scale, ..base.clone() };
            let r = residuals(&test, &model, &settings).map_err(|e| e.to_string())?;
            Ok(Mse::of(&r).xy_um2 / floor)
        })
        .collect()
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let req = match parse(&args) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("indep_truth_heldout: {e}");
            return ExitCode::from(2);
        }
    };
    let world = match World::named(&req.world) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("indep_truth_heldout: --world {:?}: {e}", req.world);
            return ExitCode::from(2);
        }
    };
    let head: Vec<String> = req.steps_um.iter().map(|s| format!("{s} µm")).collect();
    println!("| {} seed | {} |", req.world, head.join(" | "));
    println!("|---|{}", "---|".repeat(req.steps_um.len()));
    for seed in &req.seeds {
        match ratios(&world, *seed, &req.steps_um) {
            Ok(r) => {
                let cells: Vec<String> = r.iter().map(|x| format!("{x:.2} ×")).collect();
                println!("| {seed} | {} |", cells.join(" | "));
            }
            Err(e) => {
                eprintln!("indep_truth_heldout: seed {seed}: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}
