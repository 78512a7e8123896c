//! `mesopush-executor`: the executor between the host's line (serial, or a Unix socket) and
//! the motion controller's serial line, in real time. Plans persist in `--plan-store`;
//! camera frames come from `--camera unix:PATH` or `--camera v4l:/dev/videoN` (feature
//! `v4l`); trials are recorded under `--record-dir` (frames.csv, frames/*.png, events.csv,
//! recording.json); other log records are printed to stdout, one per line.
//!
//! Subcommands: `run` (the default: `mesopush-executor --host-port …` still works) and
//! `bench` (send-time deviation of the std shell in real time; docs/executor.md).

use anyhow::{Context, Result, bail};
use clap::{Args as ClapArgs, Parser, Subcommand};
use crossbeam_channel::{Receiver, bounded};
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
use mesopush_executor::shell::camera_addr::{CameraAddr, parse_size};
use mesopush_executor::shell::camera_source::{CameraCounters, CameraEnd, CameraSinks};
use mesopush_executor::shell::controller::{ControllerKind, Line as ControllerLine, open_line};
use mesopush_executor::shell::port::{ByteRead, ByteWrite, split_tty};
use mesopush_executor::shell::record::{ExecRecorder, RecordConfig};
use mesopush_executor::shell::rt::{RtApplied, RtOptions, apply};
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::unix_line::{LineAddr, listen};
use mesopush_executor::shell::{Shell, ShellOptions, ShellStats};
use mesopush_executor::store::file::FileStore;
use mesopush_executor::{CameraFrame, Executor, ExecutorConfig, LogEvent, PlanStore, Segmenting};
use mesopush_protocol::LinkConfig;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
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

#[derive(Debug, ClapArgs)]
struct BenchArgs {
    /// Setpoints per second (1..=1000).
    #[arg(long, default_value_t = 1000)]
    rate_hz: u32,
    /// Length of the streamed plan, s.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Run a busy-looping thread beside the shell (pinned to the other CPU with --pin-cpu).
    #[arg(long)]
    hog: bool,
    /// Print the figures as one JSON object.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    rt: RtArgs,
}

/// Real-time set-up of the loop thread; each step fails soft (a message, no abort).
#[derive(Debug, Clone, Copy, ClapArgs)]
struct RtArgs {
    /// Run the loop thread (and its line readers) at this SCHED_FIFO priority (1..=99).
    #[arg(long, value_name = "N")]
    rt_priority: Option<i32>,
    /// Pin the loop thread (and its line readers) to this CPU.
    #[arg(long, value_name = "C")]
    pin_cpu: Option<usize>,
    /// Lock the process's memory (mlockall); implied by --rt-priority.
    #[arg(long)]
    mlock: bool,
    /// Spin this long on the clock before a send deadline instead of sleeping, µs
    /// [default: 300].
    #[arg(long, value_name = "US")]
    spin_us: Option<u64>,
}

impl RtArgs {
    fn options(&self) -> RtOptions {
        RtOptions {
            fifo_priority: self.rt_priority,
            pin_cpu: self.pin_cpu,
            lock_memory: self.mlock || self.rt_priority.is_some(),
        }
    }

    fn shell(&self) -> ShellOptions {
        ShellOptions { spin_us: self.spin_us.unwrap_or(ShellOptions::DEFAULT.spin_us) }
    }
}

/// Prints what the OS refused of the real-time set-up.
fn warn_rt(applied: &RtApplied) {
    for r in &applied.refused {
        eprintln!("mesopush-executor: real-time set-up refused, continuing without: {r}");
    }
}

#[derive(Debug, ClapArgs)]
struct Args {
    /// The host line: a serial port (a device or a pseudo-terminal), or `unix:PATH` to
    /// listen on a Unix socket that one host at a time connects to (`mesopush flash/run`).
    #[arg(long)]
    host_port: String,
    /// The motion controller's line: a serial port, or `udp:HOST:PORT` for a controller on
    /// the network (Sensapex).
    #[arg(long)]
    ctrl_port: String,
    /// The motion controller: `native` (the project's streaming controller, e.g.
    /// `mesopush-fwsim`) or a point-to-point one: `mpc200`, `mp285`, `scientifica`,
    /// `sensapex` (with `--ctrl-port udp:HOST:55555`); docs/hardware.md.
    #[arg(long, default_value = "native")]
    controller: String,
    /// Baud rate of the host line (and of a native controller's).
    #[arg(long, default_value_t = 1_000_000)]
    baud: u32,
    /// Baud rate of the controller line [default: the controller's documented rate].
    #[arg(long, value_name = "BAUD")]
    ctrl_baud: Option<u32>,
    /// File keeping the accepted plan across restarts (replaced atomically).
    #[arg(long, default_value = "executor-plan.bin")]
    plan_store: PathBuf,
    /// Run the loop thread (and its line readers) at this SCHED_FIFO priority (1..=99).
    #[arg(long, value_name = "N")]
    rt_priority: Option<i32>,
    /// Pin the loop thread (and its line readers) to this CPU.
    #[arg(long, value_name = "C")]
    pin_cpu: Option<usize>,
    /// Lock the process's memory (mlockall); implied by --rt-priority.
    #[arg(long)]
    mlock: bool,
    /// Spin this long on the clock before a send deadline instead of sleeping, µs
    /// [default: 300].
    #[arg(long, value_name = "US")]
    spin_us: Option<u64>,
    /// Setpoints per second sent to the controller (1..=1000).
    #[arg(long, default_value_t = 100)]
    setpoint_rate_hz: u32,
    /// Look-ahead horizon: each segment goes out this many setpoint periods before its
    /// start (≤ 32).
    #[arg(long, default_value_t = 16)]
    lookahead_segments: u16,
    /// Stop after this many seconds (default: run until a line closes).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Camera: `unix:PATH`, a camera serving frames on a Unix socket (`mesopush-fwsim`
    /// prints it), or `v4l:/dev/videoN`, a V4L2 camera (GREY or YUYV; needs an executor built
    /// with `--features v4l`). Frames are stamped with the driver's CLOCK_MONOTONIC stamp
    /// converted to the executor's clock (docs/hil.md); gaps in the driver's frame sequence
    /// are counted as dropped frames.
    #[arg(long, value_name = "unix:PATH|v4l:DEVICE")]
    camera: Option<String>,
    /// Frame size asked of a V4L2 camera, WxH (e.g. 640x480) [default: the size the camera
    /// is set to].
    #[arg(long, value_name = "WxH")]
    camera_size: Option<String>,
    /// Record each trial's frames.csv, frames/*.png, events.csv and recording.json into
    /// DIR/trial-<plan id>-<start µs>/ (docs/trial-log.md); `mesopush run` completes it.
    #[arg(long, value_name = "DIR")]
    record_dir: Option<PathBuf>,
    /// The fixture frame's origin in stage coordinates, µm (recorded probe positions are in
    /// the fixture frame; `mesopush-fwsim` prints its world's).
    #[arg(long, value_name = "X,Y", default_value = "1000,1000")]
    fixture_origin_um: String,
    /// Longest clock-sync round trip accepted, µs (raise it on a heavily loaded machine,
    /// where replies through another process come back late).
    #[arg(long, default_value_t = ExecutorConfig::DEFAULT.sync_max_rtt_us)]
    sync_max_rtt_us: u64,
    /// Frames recorded after a trial's end, ms.
    #[arg(long, default_value_t = 500)]
    record_tail_ms: u64,
    /// Arming is refused when the probe is farther than this from the plan's stated start,
    /// µm (move it with `mesopush rig goto`).
    #[arg(long, default_value_t = 5.0)]
    start_tolerance_um: f64,
    /// Speed of `rig goto` / `rig home` moves, µm/s (its start from rest must stay within
    /// the acceleration limit at the setpoint rate: ≤ 200 mm/s² ÷ rate).
    #[arg(long, default_value_t = 200.0)]
    goto_speed_um_s: f64,
    /// `rig home`'s park position, stage µm [default: the workspace's centre, 5000,5000].
    #[arg(long, value_name = "X,Y")]
    home_um: Option<String>,
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

/// The executor's configuration from the flags, each checked with the flag, value and
/// allowed range named.
fn motion_config(args: &Args) -> Result<ExecutorConfig> {
    use mesopush_protocol::units::{um_s_to_nm_s, um_to_nm};
    let d = ExecutorConfig::DEFAULT;
    let tol = args.start_tolerance_um;
    if !(tol.is_finite() && (0.0..=10_000.0).contains(&tol)) {
        bail!("--start-tolerance-um must be in 0..=10000 µm, got {tol}");
    }
    let start_tolerance_nm = u32::try_from(um_to_nm("--start-tolerance-um", tol)?)?;
    let speed = args.goto_speed_um_s;
    let goto_speed_nm_s = um_s_to_nm_s("--goto-speed-um-s", speed)?;
    let accel = u64::from(goto_speed_nm_s) * u64::from(args.setpoint_rate_hz);
    if goto_speed_nm_s == 0 || goto_speed_nm_s > d.max_speed_nm_s || accel > d.max_accel_nm_s2 {
        bail!(
            "--goto-speed-um-s {speed} is out of range: above 0, at most {} µm/s and at most {} \
             µm/s at --setpoint-rate-hz {} (the acceleration limit)",
            d.max_speed_nm_s / 1000,
            d.max_accel_nm_s2 / 1000 / u64::from(args.setpoint_rate_hz.max(1)),
            args.setpoint_rate_hz
        );
    }
    let home_nm = match &args.home_um {
        Some(text) => {
            let (x, y) = parse_pair("--home-um", text)?;
            (um_to_nm("--home-um x", x)?, um_to_nm("--home-um y", y)?)
        }
        None => d.home_nm,
    };
    let w = d.workspace;
    if !w.contains(i64::from(home_nm.0), i64::from(home_nm.1)) {
        bail!(
            "--home-um must lie in the workspace {}..={} × {}..={} µm",
            w.min_x_nm / 1000,
            w.max_x_nm / 1000,
            w.min_y_nm / 1000,
            w.max_y_nm / 1000
        );
    }
    Ok(ExecutorConfig {
        setpoint_rate_hz: args.setpoint_rate_hz,
        lookahead_segments: args.lookahead_segments,
        sync_max_rtt_us: args.sync_max_rtt_us,
        start_tolerance_nm,
        goto_speed_nm_s,
        home_nm,
        ..d
    })
}

fn parse_pair(flag: &str, text: &str) -> Result<(f64, f64)> {
    let v: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} wants two numbers X,Y, got {text:?}"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok((x, y)),
        _ => bail!("{flag} wants two finite numbers X,Y, got {text:?}"),
    }
}

/// What runs beside the shell: the recorder and, with `--camera`, the camera reader.
struct Sidecar {
    frames: Option<Receiver<CameraFrame>>,
    camera: Option<std::thread::JoinHandle<CameraEnd>>,
    counters: Arc<CameraCounters>,
    stop: Arc<AtomicBool>,
    recorder: std::thread::JoinHandle<std::io::Result<()>>,
}

fn sidecar(
    args: &Args,
    clock: &Arc<MonotonicClock>,
    log_rx: Receiver<LogEvent>,
) -> Result<Sidecar> {
    let record = match &args.record_dir {
        Some(root) => {
            std::fs::create_dir_all(root)
                .with_context(|| format!("creating the record directory {}", root.display()))?;
            Some(RecordConfig {
                root: root.clone(),
                fixture_origin_um: parse_pair("--fixture-origin-um", &args.fixture_origin_um)?,
                tail_us: args.record_tail_ms.saturating_mul(1000),
            })
        }
        None => None,
    };
    let (img_tx, img_rx) = bounded(IMAGE_QUEUE);
    let counters = Arc::new(CameraCounters::default());
    let stop = Arc::new(AtomicBool::new(false));
    let (frames, camera) = match &args.camera {
        Some(addr) => {
            let addr = CameraAddr::parse(addr).map_err(anyhow::Error::msg)?;
            let size = args.camera_size.as_deref().map(parse_size).transpose();
            let size = size.map_err(|e| anyhow::anyhow!("--camera-size: {e}"))?;
            let (tx, rx) = bounded(FRAME_QUEUE);
            let sinks = CameraSinks {
                clock: clock.clone(),
                to_loop: tx,
                to_recorder: record.is_some().then_some(img_tx),
                counters: counters.clone(),
                stop: stop.clone(),
            };
            let t = addr.spawn(size, sinks).context("--camera")?;
            (Some(rx), Some(t))
        }
        None if args.camera_size.is_some() => bail!("--camera-size needs --camera v4l:DEVICE"),
        None => (None, None),
    };
    let rec = ExecRecorder::new(record, clock.clone());
    let recorder = std::thread::spawn(move || rec.run(log_rx, img_rx));
    Ok(Sidecar { frames, camera, counters, stop, recorder })
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
    let side = sidecar(args, &clock, log_rx)?;
    let (stop_tx, stop_rx) = bounded(1);
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
    let lines = Lines { ctrl, frames: side.frames.clone(), log_tx, stop_rx, opts };
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

impl Args {
    /// The real-time flags. (They are repeated in `Args` rather than flattened from
    /// [`RtArgs`]: a flattened struct breaks clap's optional default subcommand.)
    fn rt(&self) -> RtArgs {
        RtArgs {
            rt_priority: self.rt_priority,
            pin_cpu: self.pin_cpu,
            mlock: self.mlock,
            spin_us: self.spin_us,
        }
    }
}

struct Lines {
    ctrl: ControllerLine,
    frames: Option<Receiver<CameraFrame>>,
    log_tx: crossbeam_channel::Sender<LogEvent>,
    stop_rx: Receiver<()>,
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
