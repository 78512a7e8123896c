//! `mesopush demo`: the main command for a new user. Runs a plan (default: the paper's Table
//! II) through the whole loop on the firmware simulator — flash, executor, controller over a
//! pseudo-terminal, simulated stage, world and camera, recorder, tracker — and prints the
//! verdict, writing the trial directory and a trajectory figure (tracked vs simulated).
//! Exit status: 0 done and inserted; 1 not inserted, not judged or faulted; 2 a plan the
//! executor refused (unsafe) or invalid input.

use anyhow::Context;
use clap::Args;
use mesopush_rig::drive::figure::{TrialFigure, draw_trial};
use mesopush_rig::drive::spec::ControllerKind;
use mesopush_rig::plant::world_check::check_plan_on_stage;
use mesopush_rig::{ClockMode, TrialReport, TrialSpec, WorldFile, run_trial};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use mesopush_trial::{FrameRetention, TrialState, retention};
use std::path::{Path, PathBuf};

/// The paper's Table II plan, embedded.
const TABLE2_TOML: &str = include_str!("../../../../../plans/table2.toml");

/// Run a plan through the whole loop on the firmware simulator (no hardware needed).
#[derive(Debug, Args)]
pub(crate) struct DemoArgs {
    /// Plan TOML (default: the paper's Table II, embedded).
    #[arg(long)]
    plan: Option<PathBuf>,
    /// World file (default: worlds/default.toml, embedded).
    #[arg(long)]
    world: Option<PathBuf>,
    /// Trial directory to write (default: a fresh runs/demo-SEED-N).
    #[arg(long)]
    out: Option<PathBuf>,
    /// The one seed (faults, noise, start perturbation).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run in real time (≈ 50 s of motion for Table II) instead of simulated time.
    #[arg(long)]
    realtime: bool,
    /// The motion controller the executor drives, emulated byte for byte from its public
    /// documentation: `native` (the project's streaming controller) or a point-to-point one
    /// (`mpc200`); docs/hardware.md.
    #[arg(long, default_value = "native", value_parser = ControllerKind::parse)]
    controller: ControllerKind,
    /// Frame images to keep: all, failed (only if not inserted), "every N", none. Poses are
    /// tracked while the trial runs, so the verdict and pose.csv never depend on it.
    #[arg(long, default_value = "all", value_name = "all|failed|every N|none")]
    frames: FrameRetention,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    json: bool,
}

fn fresh_dir(seed: u64) -> PathBuf {
    (1..)
        .map(|n| PathBuf::from(format!("runs/demo-{seed}-{n}")))
        .find(|p| !p.exists())
        .expect("some number is free")
}

fn figure(report: &TrialReport, plan: &Plan, dir: &Path) -> anyhow::Result<PathBuf> {
    let fixture = Fixture::paper();
    let model = Model::default();
    let part = model.part.polygon().clone();
    let mut sim = Simulator::new(model, fixture.clone(), SimSettings::default())?;
    let predicted = replay(&mut sim, plan, None)?;
    let simulated: Vec<_> = predicted.samples.iter().map(|s| s.peg).collect();
    let fig = TrialFigure {
        title: "Table II on the firmware simulator: tracked (blue) vs simulated (orange)",
        walls: &fixture.walls,
        part: &part,
        tracked: &report.tracked_poses,
        simulated: &simulated,
    };
    let png = dir.join("trajectory.png");
    draw_trial(&fig, &png)?;
    draw_trial(&fig, &dir.join("trajectory.svg"))?;
    Ok(png)
}

pub(crate) fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let plan = match &args.plan {
        Some(p) => Plan::load(p)?,
        None => Plan::from_toml(TABLE2_TOML, Path::new("plans/table2.toml (embedded)"))?,
    };
    let world = match &args.world {
        Some(p) => WorldFile::load(p)?,
        None => WorldFile::default_world(),
    };
    check_plan_on_stage(&plan, world.spec.stage.offset_um)?;
    let out = args.out.clone().unwrap_or_else(|| fresh_dir(args.seed));
    let spec = TrialSpec {
        trial_id: format!("demo-{}", args.seed),
        plan: plan.clone(),
        world,
        seed: args.seed,
        clock: if args.realtime { ClockMode::Realtime } else { ClockMode::Simulated },
        peg_start: None,
        controller: args.controller,
    };
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {msg} [{elapsed_precise}]")
            .expect("valid template"),
    );
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut progress = |p: mesopush_rig::TrialProgress| {
        bar.set_position((1000.0 * (p.t_s / p.total_s).min(1.0)) as u64);
        bar.set_message(format!("{:.1} s of {:.0} s trial time", p.t_s, p.total_s));
    };
    let report = run_trial(&spec, &out, &mut progress)
        .with_context(|| format!("running the trial into {}", out.display()))?;
    bar.finish_and_clear();
    if report.refused {
        let why = report.reason.as_deref().unwrap_or("refused");
        anyhow::bail!("the executor refused the plan: {why} (trial directory {})", out.display());
    }
    let success = report.state == TrialState::Done && report.inserted == Some(true);
    let kept = retention::apply(&report.dir, args.frames, success)?;
    let fig = figure(&report, &plan, &report.dir)?;
    if args.json {
        let mut v = serde_json::to_value(&report)?;
        v["frames_kept"] = serde_json::to_value(&kept)?;
        v["trial_dir"] = serde_json::json!(report.dir);
        v["figure"] = serde_json::json!(fig);
        v["seed"] = serde_json::json!(args.seed);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_summary(&report, &fig, args.seed);
        println!(
            "  frame images kept: {} of {} (frames = {})",
            kept.kept, kept.stored, kept.retention
        );
    }
    Ok(crate::verdict::trial_verdict(report.state, report.inserted)?)
}

fn print_summary(r: &TrialReport, fig: &Path, seed: u64) {
    crate::verdict::print_head(r.state, Some(seed), r.inserted, r.reason.as_deref(), r.final_pose);
    println!(
        "  frames {} (dropped {}), tracking error max {:.1} µm / {:.2}° over {} frames",
        r.frames,
        r.dropped_frames,
        r.track_error_um_max,
        r.track_error_rad_max.to_degrees(),
        r.frames_compared
    );
    println!(
        "  faults injected {}, detected {}; {:.1} s trial time in {:.1} s",
        r.faults_injected, r.faults_detected, r.sim_time_s, r.wall_time_s
    );
    println!("  trial directory: {}", r.dir.display());
    println!("  figure: {}", fig.display());
}
