//! `mesopush-executor`: the executor between the host's serial line and the motion
//! controller's, in real time. Plans persist in `--plan-store`; log records are printed
//! to stdout, one per line, until the trial recorder exists.
//!
//! Subcommands: `run` (the default: `mesopush-executor --host-port …` still works) and
//! `bench` (send-time deviation of the std shell in real time; docs/executor.md).

use anyhow::{Context, Result, bail};
use clap::{Args as ClapArgs, Parser, Subcommand};
use crossbeam_channel::bounded;
use mesopush_executor::bench::{BenchOptions, run_bench};
use mesopush_executor::clock::MonotonicClock;
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::port::split_tty;
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::{Shell, ShellStats};
use mesopush_executor::store::file::FileStore;
use mesopush_executor::{Executor, ExecutorConfig};
use mesopush_protocol::LinkConfig;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Plan memory: 4096 steps.
const CAP: usize = 12 * 4096;
/// Look-ahead queue.
const LA: usize = 32;
/// Link window.
const W: usize = 48;

/// Streams flashed plans to the motion controller and stamps camera frames.
///
/// Without a subcommand, `run` is assumed: `mesopush-executor --host-port A --ctrl-port B`.
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: Option<Args>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the executor on two serial lines (the default).
    Run(Args),
    /// Measure setpoint send times against their schedule in real time: the std shell
    /// streams a plan to an in-process controller; prints p50/p99/max deviation, µs.
    Bench(BenchArgs),
}

#[derive(Debug, ClapArgs)]
struct BenchArgs {
    /// Setpoints per second (1..=1000).
    #[arg(long, default_value_t = 1000)]
    rate_hz: u32,
    /// Length of the streamed plan, s.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Run a busy-looping thread beside the shell (load on the other core).
    #[arg(long)]
    hog: bool,
    /// Print the figures as one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, ClapArgs)]
struct Args {
    /// Serial port of the host line (a device or a pseudo-terminal).
    #[arg(long)]
    host_port: String,
    /// Serial port of the motion controller line.
    #[arg(long)]
    ctrl_port: String,
    /// Baud rate of both lines.
    #[arg(long, default_value_t = 1_000_000)]
    baud: u32,
    /// File keeping the accepted plan across restarts (replaced atomically).
    #[arg(long, default_value = "executor-plan.bin")]
    plan_store: PathBuf,
    /// Setpoints per second sent to the controller (1..=1000).
    #[arg(long, default_value_t = 100)]
    setpoint_rate_hz: u32,
    /// Segments kept in flight ahead of the controller (≤ 32).
    #[arg(long, default_value_t = 16)]
    lookahead_segments: u16,
    /// Stop after this many seconds (default: run until a line closes).
    #[arg(long)]
    duration_s: Option<f64>,
}

/// Increments the boot counter kept beside the plan store; link sessions must differ
/// from the previous run's.
fn next_session(plan_store: &Path) -> Result<u16> {
    let mut name = plan_store.file_name().unwrap_or_default().to_os_string();
    name.push(".boot");
    let path = plan_store.with_file_name(name);
    let last = std::fs::read_to_string(&path).ok().and_then(|s| s.trim().parse::<u16>().ok());
    let session = last.map_or(1, |s| s.wrapping_add(1));
    std::fs::write(&path, session.to_string())
        .with_context(|| format!("writing the boot counter {}", path.display()))?;
    Ok(session)
}

fn open(path: &str, baud: u32) -> Result<serialport::TTYPort> {
    serialport::new(path, baud).open_native().with_context(|| format!("opening serial port {path}"))
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match (cli.command, cli.run) {
        (Some(Command::Run(args)), _) | (None, Some(args)) => run(args),
        (Some(Command::Bench(b)), _) => bench(&b),
        (None, None) => bail!("give --host-port and --ctrl-port, or a subcommand (see --help)"),
    }
}

fn bench(b: &BenchArgs) -> Result<()> {
    let opts = BenchOptions { rate_hz: b.rate_hz, seconds: b.seconds, hog: b.hog };
    let r = run_bench(opts).context("bench")?;
    if b.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "{} Hz, {} s{}: {} segments; send deviation p50 {} µs, p99 {} µs, max {} µs; \
             min margin {} µs; shell max late {} µs; trial {}",
            r.rate_hz,
            r.seconds,
            if r.hog { ", hog" } else { "" },
            r.segments,
            r.p50_us,
            r.p99_us,
            r.max_us,
            r.min_margin_us,
            r.shell_max_late_us,
            r.trial_end
        );
    }
    Ok(())
}

fn run(args: Args) -> Result<()> {
    if usize::from(args.lookahead_segments) > LA {
        bail!("--lookahead-segments {} exceeds the queue of {LA}", args.lookahead_segments);
    }
    let config = ExecutorConfig {
        setpoint_rate_hz: args.setpoint_rate_hz,
        lookahead_segments: args.lookahead_segments,
        ..ExecutorConfig::DEFAULT
    };
    let store = FileStore::new(&args.plan_store);
    let core = Executor::<_, CAP, LA>::new(config, store).context("executor configuration")?;
    if let Some(issue) = core.startup_issue() {
        eprintln!("stored plan not loaded: {issue:?}");
    }
    let session = next_session(&args.plan_store)?;
    let mut endpoint = Endpoint::<_, CAP, LA, W>::new(core, LinkConfig::DEFAULT, session);
    let host = split_tty(open(&args.host_port, args.baud)?).context("host port")?;
    let ctrl = split_tty(open(&args.ctrl_port, args.baud)?).context("controller port")?;
    let (log_tx, log_rx) = bounded(4096);
    let printer = std::thread::spawn(move || {
        for record in log_rx {
            println!("{record:?}");
        }
    });
    let (stop_tx, stop_rx) = bounded(1);
    if let Some(s) = args.duration_s {
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs_f64(s.max(0.0)));
            let _ = stop_tx.send(());
        });
    }
    let mut stats = ShellStats::default();
    let clock = MonotonicClock::new();
    let end = Shell::run(&mut endpoint, &clock, host, ctrl, None, log_tx, stop_rx, &mut stats);
    let _ = printer.join();
    eprintln!("executor stopped: {end:?}; {stats:?}; {:?}", endpoint.stats());
    match end {
        ShellEnd::Stopped => Ok(()),
        ShellEnd::HostLine(e) => Err(e).context("host line"),
        ShellEnd::CtrlLine(e) => Err(e).context("controller line"),
    }
}
