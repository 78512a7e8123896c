//! `mesopush-fwsim`: the firmware simulator as its own process, as on a rig. Serves the
//! simulated motion controller on a pseudo-terminal (prints its path) and the 30 Hz camera on
//! a Unix socket (prints its address) in real time, until the executor closes the line or the
//! process is killed. Thin over `mesopush_rig::plant::fwsim` (docs/hil.md). Exit status 0
//! when the line closed, 2 for invalid input or a start that failed (as `mesopush`).

use anyhow::Context;
use clap::Parser;
use mesopush_executor::shell::controller::ControllerKind;
use mesopush_executor::shell::rt::{RtOptions, apply};
use mesopush_rig::WorldFile;
use mesopush_rig::plant::fwsim::{Fwsim, FwsimOptions};
use mesopush_rig::plant::world_check::check_plan_on_stage;
use mesopush_sim::Plan;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// The paper's Table II plan, embedded (its start places the peg and the probe).
const TABLE2_TOML: &str = include_str!("../../../../../plans/table2.toml");

/// Serve the simulated motion controller (pseudo-terminal) and camera (Unix socket) in real
/// time for `mesopush-executor`.
#[derive(Debug, Parser)]
#[command(
    name = "mesopush-fwsim",
    version,
    about = "The firmware simulator as its own process: the simulated motion controller on a \
             pseudo-terminal, the 30 Hz camera on a Unix socket, the stage and the world they share"
)]
struct Args {
    /// World file (default: worlds/default.toml, embedded).
    #[arg(long)]
    world: Option<PathBuf>,
    /// Plan whose start pose the peg and probe are placed at (default: Table II, embedded).
    #[arg(long)]
    plan: Option<PathBuf>,
    /// The one seed (camera noise, start perturbation, stage and camera faults).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory for camera.sock, background.png and fwsim-truth.csv.
    #[arg(long, default_value = "runs/fwsim")]
    run_dir: PathBuf,
    /// Run the controller loop at this SCHED_FIFO priority (1..=99), as the controller's own
    /// microcontroller would not be starved by a loaded host; the renderer and camera threads
    /// keep the normal scheduler. Refused by the OS: a message, and it runs without.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(i32).range(1..=99))]
    rt_priority: Option<i32>,
    /// The controller to serve: `native` (the project's streaming controller) or an emulated
    /// commercial one, byte for byte from its public protocol: `mpc200`, `mp285`,
    /// `scientifica` (on the pseudo-terminal), `sensapex` (on a loopback UDP socket). Start
    /// the executor with the same `--controller` (docs/hardware.md).
    #[arg(long, default_value = "native", value_parser = ControllerKind::parse)]
    controller: ControllerKind,
}

fn main() -> std::process::ExitCode {
    match run(Args::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let world = match &args.world {
        Some(p) => WorldFile::load(p)?,
        None => WorldFile::default_world(),
    };
    let plan = match &args.plan {
        Some(p) => Plan::load(p)?,
        None => Plan::from_toml(TABLE2_TOML, Path::new("plans/table2.toml (embedded)"))?,
    };
    check_plan_on_stage(&plan, world.spec.stage.offset_um)?;
    let opts = FwsimOptions {
        world,
        plan,
        seed: args.seed,
        run_dir: args.run_dir.clone(),
        controller: args.controller,
    };
    let sim = Fwsim::start(&opts).context("starting the firmware simulator")?;
    let a = sim.addrs();
    println!("controller: {}", a.controller);
    println!("controller kind: {}", args.controller.name());
    println!("camera: unix:{}", a.camera.display());
    println!("background: {}", a.background.display());
    println!("truth: {}", a.truth.display());
    println!("world: {}", a.world.display());
    println!("fixture origin: {},{}", a.fixture_origin_um.x, a.fixture_origin_um.y);
    // After start: the renderer and camera threads exist already and keep their scheduler.
    let rt = RtOptions { fifo_priority: args.rt_priority, ..RtOptions::default() };
    for r in apply(&rt).refused {
        eprintln!("mesopush-fwsim: real-time set-up refused, continuing without: {r}");
    }
    println!("serving in real time until the executor closes the line (Ctrl-C to stop)");
    let summary = sim.serve(&AtomicBool::new(false))?;
    println!(
        "line closed: {} frames ({} dropped, renderer behind; {} not sent), {} segments \
         applied, {} physics advances jammed, {} controller frames dropped (the executor \
         did not read the line)",
        summary.frames,
        summary.frames_render_dropped,
        summary.frames_unsent,
        summary.segments_applied,
        summary.jams,
        summary.line_frames_dropped
    );
    Ok(())
}
