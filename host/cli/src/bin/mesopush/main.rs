//! `mesopush`: the host command line. Thin over the host crates (`mesopush-sim`, `-plan`,
//! `-ident`, `-diagnose`, `-rig`, `-batch`, ...): each subcommand module parses its flags,
//! calls a library function and prints. The cli crate is the only one that depends on clap,
//! anyhow and indicatif; nothing depends on it. Exit status: 0 success, 1 a negative verdict
//! ([`verdict::Negative`]), 2 invalid input or a refusal (any other error).

mod cmd_batch;
mod cmd_calibrate;
mod cmd_demo;
mod cmd_diagnose;
mod cmd_flash;
mod cmd_identify;
mod cmd_import;
mod cmd_lcp;
mod cmd_plan;
mod cmd_render;
mod cmd_replay;
mod cmd_rig;
mod cmd_robustness;
mod cmd_run;
mod cmd_sim;
mod cmd_track;
mod ranges;
mod verdict;

use clap::{Parser, Subcommand};

/// Design, execute and verify open-loop pushing plans for meso-scale assembly.
#[derive(Debug, Parser)]
#[command(name = "mesopush", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a plan (default: Table II) through the whole loop on the firmware simulator.
    Demo(cmd_demo::DemoArgs),
    /// Replay a plan in the quasi-static simulator (trajectory CSV, figure, verdict).
    Sim(cmd_sim::SimArgs),
    /// Complementarity problems: solve LCP files with our solver.
    Lcp(cmd_lcp::LcpArgs),
    /// Render a synthetic microscope sequence (PNG frames, frames.csv, truth.csv, bg.png).
    Render(cmd_render::RenderArgs),
    /// Design a pushing plan, written as plan TOML: `plan rrt` (the paper's RRT) or `plan robust`.
    Plan(cmd_plan::PlanArgs),
    /// Monte Carlo success probability of plans under start-pose, support and friction error.
    Robustness(cmd_robustness::RobustnessArgs),
    /// Track the peg and the probe tip in a frame store (frames.tif) or a folder of PNG frames; writes pose.csv.
    Track(cmd_track::TrackArgs),
    Replay(cmd_replay::ReplayArgs),
    /// Identify probe friction and supports from unconstrained pushing trials (Table I).
    Identify(cmd_identify::IdentifyArgs),
    /// Diagnose trials: held-out residuals, their structure, the missing effect, before/after.
    Diagnose(cmd_diagnose::DiagnoseArgs),
    /// Unattended trial batches: run (resumable, shardable), merge shards, report.
    Batch(cmd_batch::BatchArgs),
    /// Upload a plan to a running mesopush-executor (hardware-in-the-loop, docs/hil.md).
    Flash(cmd_flash::FlashArgs),
    /// Arm, start and record the flashed plan on a running executor; print the verdict.
    Run(cmd_run::RunArgs),
    /// Rig commands between trials on a running executor: status, goto, home, stop.
    Rig(cmd_rig::RigArgs),
    /// Measure the camera's pixel size and rotation on a rig (move the probe, track its tip).
    ///
    /// Moves the probe from where it is (backlash take-up, rest, x move, rest, y move, rest)
    /// on a running executor that records frames, tracks its tip at the three rests and fits
    /// the pixel size, the camera's rotation and the fixture origin in the image; writes the
    /// calibration file that `track --calibration` and `run --calibration` read. The moves
    /// replace the executor's flashed plan: flash the trial's plan again afterwards.
    Calibrate(cmd_calibrate::CalibrateArgs),
    /// Convert recordings of real pushes (Zhou & Mason 2017, ...) into trial logs.
    Import(cmd_import::ImportArgs),
}

/// Runs the command; errors are printed as one `error: …` line (with their causes) and exit
/// code 2 (a negative verdict: `verdict: …` and exit code 1), never as a panic or a
/// backtrace dump.
fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<verdict::Negative>().is_some() => {
            eprintln!("verdict: {e:#}");
            std::process::ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(args) => cmd_demo::run(&args),
        Command::Sim(args) => cmd_sim::run(&args),
        Command::Lcp(args) => cmd_lcp::run(args),
        Command::Render(args) => cmd_render::run(&args),
        Command::Track(args) => cmd_track::run(&args),
        Command::Replay(args) => cmd_replay::run(&args),
        Command::Identify(args) => cmd_identify::run(&args),
        Command::Diagnose(args) => cmd_diagnose::run(&args),
        Command::Batch(args) => cmd_batch::run(&args),
        Command::Plan(args) => cmd_plan::run(&args),
        Command::Robustness(args) => cmd_robustness::run(&args),
        Command::Flash(args) => cmd_flash::run(&args),
        Command::Run(args) => cmd_run::run(&args),
        Command::Rig(args) => cmd_rig::run(&args),
        Command::Calibrate(args) => cmd_calibrate::run(&args),
        Command::Import(args) => cmd_import::run(&args),
    }
}
