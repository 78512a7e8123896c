//! `mesopush run --port P`: arms and starts the plan flashed into a running
//! `mesopush-executor`, follows the trial to its end, then completes the executor's
//! recording into a trial log (trial.json, probe.csv, pose.csv) and prints the verdict.
//! Thin over `mesopush_rig::client::hil::run`. Exit status: 0 done and inserted; 1 not
//! inserted, not judged, faulted or aborted; 2 refused (the probe not at the plan's start,
//! an unsafe plan, the executor not ready) or invalid input.

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_core::geom::Vec2;
use mesopush_executor::ExecutorConfig;
use mesopush_rig::WorldFile;
use mesopush_rig::client::hil::{self, RunOptions, RunPhase, RunReport};
use mesopush_sim::Plan;
use mesopush_trial::{CalibrationFile, FrameRetention, TrialState, retention};
use std::path::{Path, PathBuf};

/// The paper's Table II plan, embedded.
const TABLE2_TOML: &str = include_str!("../../../../../plans/table2.toml");

/// Arm, start and record the flashed plan on a running executor; print the verdict.
#[derive(Debug, Args)]
pub(crate) struct RunArgs {
    /// The executor's host line: `unix:PATH` or a serial device.
    #[arg(long)]
    port: String,
    /// The plan that was flashed (default: Table II, embedded).
    #[arg(long)]
    plan: Option<PathBuf>,
    /// The executor's `--record-dir`.
    #[arg(long, default_value = "runs/executor")]
    record_dir: PathBuf,
    /// Trial directory to write (default: complete the recording where the executor wrote it).
    #[arg(long)]
    out: Option<PathBuf>,
    /// The empty fixture's frame to track against (mesopush-fwsim prints its own).
    #[arg(long, default_value = "runs/fwsim/background.png")]
    background: PathBuf,
    /// Camera calibration and stage registration: a world file's `[camera]` and `[stage]` (its
    /// effects and faults are never read). Default: worlds/default.toml, embedded.
    #[arg(long)]
    world: Option<PathBuf>,
    /// The camera calibration from a calibration file (`mesopush calibrate`'s) instead of the
    /// world file's `[camera]`.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// The executor's --setpoint-rate-hz (rebuilds the setpoint schedule for probe.csv).
    #[arg(long, default_value_t = 100)]
    setpoint_rate_hz: u32,
    /// The firmware simulator's fwsim-truth.csv: report frame-stamp and tracking errors.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// The firmware simulator's fwsim-world.json: record the simulated world (its
    /// description and seed) in trial.json's `world` (mesopush-fwsim prints the path).
    #[arg(long)]
    sim_world: Option<PathBuf>,
    /// Frame images to keep once the recording is tracked: all, failed (only if not
    /// inserted), "every N", none. Applies to the completed trial directory (with --out,
    /// the copy; the executor's recording under --record-dir is left as it was).
    #[arg(long, default_value = "all", value_name = "all|failed|every N|none")]
    frames: FrameRetention,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &RunArgs) -> anyhow::Result<()> {
    let plan = match &args.plan {
        Some(p) => Plan::load(p)?,
        None => Plan::from_toml(TABLE2_TOML, Path::new("plans/table2.toml (embedded)"))?,
    };
    let world = match &args.world {
        Some(p) => WorldFile::load(p)?,
        None => WorldFile::default_world(),
    };
    let config =
        ExecutorConfig { setpoint_rate_hz: args.setpoint_rate_hz, ..ExecutorConfig::DEFAULT };
    anyhow::ensure!(
        (1..=1000).contains(&args.setpoint_rate_hz),
        "--setpoint-rate-hz must be in 1..=1000, got {}",
        args.setpoint_rate_hz
    );
    let [ox, oy] = world.spec.stage.offset_um;
    let opts = RunOptions {
        addr: args.port.clone(),
        plan,
        record_dir: args.record_dir.clone(),
        out: args.out.clone(),
        background: args.background.clone(),
        calibration: match &args.calibration {
            Some(path) => load_calibration(path)?,
            None => world.spec.camera.calibration()?,
        },
        fixture_origin_um: Vec2::new(ox, oy),
        frame_period_us: world.spec.camera.period_us,
        period_us: config.setpoint_period_us(),
        lead_us: config.start_lead_us,
        truth: args.truth.clone(),
        sim_world: args.sim_world.clone(),
    };
    let bar = phase_bar();
    let report = hil::run_with(&opts, &mut |p| show_phase(&bar, p));
    bar.finish_and_clear();
    let report = report.with_context(|| format!("running the trial on {}", args.port))?;
    let t = &report.trial;
    let success = t.state == TrialState::Done && t.inserted == Some(true);
    let kept = retention::apply(&t.trial_dir, args.frames, success)?;
    if args.json {
        let mut v = serde_json::to_value(&report)?;
        v["frames_kept"] = serde_json::to_value(&kept)?;
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_summary(&report);
        println!(
            "  frame images kept: {} of {} (frames = {})",
            kept.kept, kept.stored, kept.retention
        );
    }
    Ok(crate::verdict::trial_verdict(report.trial.state, report.trial.inserted)?)
}

/// The calibration of a calibration file, with a warning on stderr when the camera's
/// fitted rotation is more than the tracker should ignore.
pub(crate) fn load_calibration(path: &Path) -> anyhow::Result<mesopush_vision::Calibration> {
    let file = CalibrationFile::load(path)?;
    if let Some(w) = file.rotation_warning() {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(file.checked_calibration()?)
}

/// A spinner on stderr (so `--json` keeps stdout clean; when stderr is no terminal, one line
/// per phase instead) saying what the run waits for: up to a minute and more would otherwise
/// pass in silence.
pub(crate) fn phase_bar() -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    if let Ok(style) = ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}") {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

pub(crate) fn show_phase(bar: &ProgressBar, phase: RunPhase) {
    let msg = match phase {
        RunPhase::Connecting => "connecting to the executor".to_string(),
        RunPhase::Arming => "arming the flashed plan (probe at its start?) and starting".into(),
        RunPhase::Running { elapsed_s, expected_s } => {
            format!("running the trial: {elapsed_s:.1} s of ≈ {expected_s:.1} s")
        }
        RunPhase::WaitingForRecording => "trial ended; waiting for the executor's recording".into(),
        RunPhase::Completing => "tracking the frames and writing the trial log".into(),
        _ => return,
    };
    // Off a terminal the spinner is hidden: a log (a batch job, a CI run) gets one line per
    // phase instead (not one per progress update).
    let kind = |m: &str| m.split(':').next().unwrap_or_default().to_string();
    if bar.is_hidden() && kind(&bar.message()) != kind(&msg) {
        eprintln!("mesopush run: {msg}");
    }
    bar.set_message(msg);
}

fn print_summary(r: &RunReport) {
    let t = &r.trial;
    crate::verdict::print_head(t.state, None, t.inserted, t.reason.as_deref(), t.final_pose);
    println!(
        "  frames {} (dropped {}), {} tracked; {} position reports; {:.1} s",
        t.frames, t.dropped_frames, t.tracked, r.telemetry, r.wall_time_s
    );
    if let Some(f) = &r.truth {
        println!(
            "  vs the simulator's truth over {} frames: stamp error median {} µs, max |{}| µs; \
             arrival − exposure median {} µs, max {} µs; tracking error max {:.2} µm",
            f.frames_compared,
            f.stamp_error_us_p50,
            f.stamp_error_us_max_abs,
            f.arrival_latency_us_p50,
            f.arrival_latency_us_max,
            f.track_error_um_max
        );
    }
    println!("  trial directory: {}", t.trial_dir.display());
}
