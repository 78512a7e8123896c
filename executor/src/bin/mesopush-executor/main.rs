//! `mesopush-executor`: the executor between the host's line (serial, or a Unix socket) and
//! the motion controller's serial line, in real time. Plans persist in `--plan-store`;
//! camera frames come from `--camera unix:PATH` or `--camera v4l:/dev/videoN` (feature
//! `v4l`); trials are recorded under `--record-dir` (frames.csv, frames/*.png, events.csv,
//! recording.json); other log records are printed to stdout, one per line.
//!
//! Subcommands: `run` (the default: `mesopush-executor --host-port …` still works) and
//! `bench` (send-time deviation of the std shell in real time; docs/executor.md).

mod args;
mod sidecar;

use anyhow::{Context, Result, bail};
use args::{Args, BenchArgs, motion_config, next_session, open, warn_rt};
use clap::{Parser, Subcommand};
use crossbeam_channel::bounded;
use mesopush_executor::adapter::ControllerAdapter;
use mesopush_executor::adapter::native::NativeAdapter;
use mesopush_executor::adapter::p2p::Protocol;
use mesopush_executor::adapter::p2p::driver::{P2pSettings, PointToPointAdapter};
use mesopush_executor::adapter::p2p::mp285::Mp285;
use mesopush_executor::adapter::p2p::mpc200::Mpc200;
use mesopush_executor::adapter::p2p::scientifica::Scientifica;
use mesopush_executor::adapter::p2p::sensapex::{Sensapex, SensapexSettings};
use mesopush_executor::bench::{BenchOptions, run_bench};
use mesopush_executor::clock::MonotonicClock;
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::camera_source::{CameraCounters, CameraEnd};
use mesopush_executor::shell::controller::{ControllerKind, Line as ControllerLine, open_line};
use mesopush_executor::shell::port::{ByteRead, ByteWrite, split_tty};
use mesopush_executor::shell::rt::apply;
use mesopush_executor::shell::rt_queue;
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::unix_line::{LineAddr, listen};
use mesopush_executor::shell::{Shell, ShellOptions, ShellStats};
use mesopush_executor::store::file::FileStore;
use mesopush_executor::{CameraFrame, Executor, LogEvent, PlanStore, Segmenting};
use mesopush_protocol::LinkConfig;
use sidecar::sidecar;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// Plan memory: 4096 steps.
const CAP: usize = 12 * 4096;
/// Look-ahead queue.
const LA: usize = 32;
/// Link window.
const W: usize = 48;
/// Camera frames queued for the loop.
const FRAME_QUEUE: usize = 16;
/// Images queued for the recorder (a 928 × 480 frame is 445 KB).
const IMAGE_QUEUE: usize = 32;

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

// Parsed once at start-up: the size difference costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Command {
    /// Run the executor on two serial lines (the default).
    Run(Args),
    /// Measure setpoint send times against their schedule in real time: the std shell
    /// streams a plan to an in-process controller; prints p50/p99/max deviation, µs.
    Bench(BenchArgs),
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
    let opts = BenchOptions {
        rate_hz: b.rate_hz,
        seconds: b.seconds,
        hog: b.hog,
        rt: b.rt.options(),
        spin_us: b.rt.shell().spin_us,
    };
    let r = run_bench(opts).context("bench")?;
    warn_rt(&r.rt);
    if b.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "{} Hz, {} s{}: {} segments; send deviation (write − schedule) p50 {} µs, p99 {} \
             µs, max {} µs over {} timed sends; arrival at the controller p50 {} µs, p99 {} \
             µs, max {} µs; min margin {} µs; trial {}",
            r.rate_hz,
            r.seconds,
            if r.hog { ", hog" } else { "" },
            r.segments,
            r.p50_us,
            r.p99_us,
            r.max_us,
            r.timed_sends,
            r.arrival_p50_us,
            r.arrival_p99_us,
            r.arrival_max_us,
            r.min_margin_us,
            r.trial_end
        );
    }
    Ok(())
}

fn run(args: Args) -> Result<()> {
    if usize::from(args.lookahead_segments) > LA {
        bail!("--lookahead-segments {} exceeds the queue of {LA}", args.lookahead_segments);
    }
    let kind = ControllerKind::parse(&args.controller)
        .map_err(|e| anyhow::anyhow!("--controller: {e}"))?;
    let mut config = motion_config(&args)?;
    if kind.point_to_point() {
        config.segmenting = Segmenting::PlanSteps;
    }
    let store = FileStore::new(&args.plan_store);
    let core = Executor::<_, CAP, LA>::new(config, store).context("executor configuration")?;
    if let Some(issue) = core.startup_issue() {
        eprintln!("stored plan not loaded: {issue}");
    }
    let session = next_session(&args.plan_store)?;
    let baud = args.ctrl_baud.unwrap_or(match kind {
        ControllerKind::Native => args.baud,
        k => k.default_baud(),
    });
    let ctrl = open_line(&args.ctrl_port, baud)
        .with_context(|| format!("controller line {}", args.ctrl_port))?;
    match kind {
        ControllerKind::Native => {
            let adapter = NativeAdapter::<W>::new(LinkConfig::DEFAULT, session);
            run_on(&args, Endpoint::with_adapter(core, LinkConfig::DEFAULT, session, adapter), ctrl)
        }
        ControllerKind::Mpc200 => run_p2p(&args, core, session, ctrl, Mpc200::new()),
        ControllerKind::Mp285 => run_p2p(&args, core, session, ctrl, Mp285::new()),
        ControllerKind::Scientifica => run_p2p(&args, core, session, ctrl, Scientifica::new()),
        ControllerKind::Sensapex => {
            run_p2p(&args, core, session, ctrl, Sensapex::new(SensapexSettings::DEFAULT))
        }
    }
}

/// The loop with a point-to-point controller speaking `proto`.
fn run_p2p<P: Protocol>(
    args: &Args,
    core: Executor<FileStore, CAP, LA>,
    session: u16,
    ctrl: ControllerLine,
    proto: P,
) -> Result<()> {
    let adapter = PointToPointAdapter::<P, LA>::new(proto, P2pSettings::DEFAULT);
    run_on(args, Endpoint::with_adapter(core, LinkConfig::DEFAULT, session, adapter), ctrl)
}

/// The loop on `ctrl` with the controller behind `endpoint`'s adapter.
fn run_on<A: ControllerAdapter>(
    args: &Args,
    mut endpoint: Endpoint<FileStore, CAP, LA, W, A>,
    ctrl: ControllerLine,
) -> Result<()> {
    let clock = Arc::new(MonotonicClock::new());
    let (log_tx, log_rx) = bounded(4096);
    let mut side = sidecar(args, &clock, log_rx)?;
    let (stop_tx, stop_rx) = rt_queue::bounded(1);
    if let Some(s) = args.duration_s {
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs_f64(s.max(0.0)));
            let _ = stop_tx.send(());
        });
    }
    let mut stats = ShellStats::default();
    // The recorder and camera threads keep the normal scheduler; the loop and its readers
    // get the real-time set-up.
    let rt = args.rt();
    warn_rt(&apply(&rt.options()));
    let opts = rt.shell();
    let lines = Lines { ctrl, frames: side.frames.take(), log_tx, stop_rx, opts };
    let end = match LineAddr::parse(&args.host_port) {
        LineAddr::Unix(path) => {
            let host = listen(&path).context("host line")?;
            eprintln!("host line: unix:{}", path.display());
            serve(&mut endpoint, &clock, host, lines, &mut stats)
        }
        LineAddr::Serial(p) => {
            let host = split_tty(open(&p, args.baud)?).context("host port")?;
            serve(&mut endpoint, &clock, host, lines, &mut stats)
        }
    };
    side.stop.store(true, Ordering::Relaxed);
    let camera_end = side.camera.map(|t| t.join());
    let recorded = side.recorder.join();
    report_stop(&end, &stats, &endpoint, camera_end, &side.counters);
    match recorded {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(e).context("recorder"),
        Err(_) => bail!("the recorder thread panicked"),
    }
    match end {
        ShellEnd::Stopped => Ok(()),
        ShellEnd::HostLine(e) => Err(e).context("host line"),
        ShellEnd::CtrlLine(e) => Err(e).context("controller line"),
    }
}

/// What the executor says on stderr when it stops: the loop's timing and the camera's counts.
fn report_stop<S: PlanStore, A: ControllerAdapter>(
    end: &ShellEnd,
    stats: &ShellStats,
    endpoint: &Endpoint<S, CAP, LA, W, A>,
    camera_end: Option<std::thread::Result<CameraEnd>>,
    c: &CameraCounters,
) {
    let sends = &stats.sends;
    eprintln!(
        "executor stopped: {end}; loop: {} passes, max late {} µs, {} log records ({} \
         lost); send deviation (write − schedule) p50 {} µs, p99 {} µs, max {} µs over {} \
         timed sends ({} batched, {} released by flow control)",
        stats.iterations,
        stats.max_late_us,
        stats.logged,
        stats.log_dropped,
        sends.quantile_us(0.5),
        sends.quantile_us(0.99),
        sends.max_us,
        sends.timed,
        sends.batched,
        sends.flow_released,
    );
    let camera = match camera_end {
        None => "none".to_string(),
        Some(Ok(e)) => e.to_string(),
        Some(Err(_)) => "its thread panicked".to_string(),
    };
    let s = endpoint.stats();
    eprintln!(
        "links: {} messages to the host and {} to the controller lost to a full outbox, host \
         line down {} times, controller line down {} times, {} overlong frames skipped",
        s.host_dropped, s.ctrl_dropped, s.host_link_downs, s.ctrl_link_downs, s.overlong_frames
    );
    eprintln!(
        "camera {camera}: {} frames, {} not \
         stamped (loop queue full), {} images not recorded (recorder queue full)",
        c.received.load(Ordering::Relaxed),
        c.loop_dropped.load(Ordering::Relaxed),
        c.recorder_dropped.load(Ordering::Relaxed),
    );
}

struct Lines {
    ctrl: ControllerLine,
    frames: Option<rt_queue::Receiver<CameraFrame>>,
    log_tx: crossbeam_channel::Sender<LogEvent>,
    stop_rx: rt_queue::Receiver<()>,
    opts: ShellOptions,
}

fn serve<S: PlanStore, A: ControllerAdapter>(
    endpoint: &mut Endpoint<S, CAP, LA, W, A>,
    clock: &MonotonicClock,
    host: (impl ByteRead + 'static, impl ByteWrite),
    l: Lines,
    stats: &mut ShellStats,
) -> ShellEnd {
    let lines = (host, l.ctrl, l.frames);
    Shell::run_with(endpoint, clock, lines, l.log_tx, l.stop_rx, l.opts, stats)
}
