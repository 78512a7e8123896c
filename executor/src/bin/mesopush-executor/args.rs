//! The command line of `mesopush-executor`: its flags and the executor configuration they
//! make, each value checked with the flag, the value and the allowed range named.

use anyhow::{Context, Result, bail};
use clap::Args as ClapArgs;
use mesopush_executor::ExecutorConfig;
use mesopush_executor::shell::ShellOptions;
use mesopush_executor::shell::rt::{RtApplied, RtOptions};
use std::path::{Path, PathBuf};

#[derive(Debug, ClapArgs)]
pub(crate) struct BenchArgs {
    /// Setpoints per second (1..=1000).
    #[arg(long, default_value_t = 1000)]
    pub(crate) rate_hz: u32,
    /// Length of the streamed plan, s.
    #[arg(long, default_value_t = 10.0)]
    pub(crate) seconds: f64,
    /// Run a busy-looping thread beside the shell (pinned to the other CPU with --pin-cpu).
    #[arg(long)]
    pub(crate) hog: bool,
    /// Print the figures as one JSON object.
    #[arg(long)]
    pub(crate) json: bool,
    #[command(flatten)]
    pub(crate) rt: RtArgs,
}

/// Real-time set-up of the loop thread; each step fails soft (a message, no abort).
#[derive(Debug, Clone, Copy, ClapArgs)]
pub(crate) struct RtArgs {
    /// Run the loop thread (and its line readers) at this SCHED_FIFO priority (1..=99).
    #[arg(long, value_name = "N")]
    pub(crate) rt_priority: Option<i32>,
    /// Pin the loop thread (and its line readers) to this CPU.
    #[arg(long, value_name = "C")]
    pub(crate) pin_cpu: Option<usize>,
    /// Lock the process's memory (mlockall); implied by --rt-priority.
    #[arg(long)]
    pub(crate) mlock: bool,
    /// Spin this long on the clock before a send deadline instead of sleeping, µs
    /// [default: 300].
    #[arg(long, value_name = "US")]
    pub(crate) spin_us: Option<u64>,
}

impl RtArgs {
    pub(crate) fn options(&self) -> RtOptions {
        RtOptions {
            fifo_priority: self.rt_priority,
            pin_cpu: self.pin_cpu,
            lock_memory: self.mlock || self.rt_priority.is_some(),
        }
    }

    pub(crate) fn shell(&self) -> ShellOptions {
        ShellOptions { spin_us: self.spin_us.unwrap_or(ShellOptions::DEFAULT.spin_us) }
    }
}

/// Prints what the OS refused of the real-time set-up.
pub(crate) fn warn_rt(applied: &RtApplied) {
    for r in &applied.refused {
        eprintln!("mesopush-executor: real-time set-up refused, continuing without: {r}");
    }
}

#[derive(Debug, ClapArgs)]
pub(crate) struct Args {
    /// The host line: a serial port (a device or a pseudo-terminal), or `unix:PATH` to
    /// listen on a Unix socket that one host at a time connects to (`mesopush flash/run`).
    #[arg(long)]
    pub(crate) host_port: String,
    /// The motion controller's line: a serial port, or `udp:HOST:PORT` for a controller on
    /// the network (Sensapex).
    #[arg(long)]
    pub(crate) ctrl_port: String,
    /// The motion controller: `native` (the project's streaming controller, e.g.
    /// `mesopush-fwsim`) or a point-to-point one: `mpc200`, `mp285`, `scientifica`,
    /// `sensapex` (with `--ctrl-port udp:HOST:55555`); docs/hardware.md.
    #[arg(long, default_value = "native")]
    pub(crate) controller: String,
    /// Baud rate of the host line (and of a native controller's).
    #[arg(long, default_value_t = 1_000_000)]
    pub(crate) baud: u32,
    /// Baud rate of the controller line [default: the controller's documented rate].
    #[arg(long, value_name = "BAUD")]
    pub(crate) ctrl_baud: Option<u32>,
    /// File keeping the accepted plan across restarts (replaced atomically).
    #[arg(long, default_value = "executor-plan.bin")]
    pub(crate) plan_store: PathBuf,
    /// Run the loop thread (and its line readers) at this SCHED_FIFO priority (1..=99).
    #[arg(long, value_name = "N")]
    pub(crate) rt_priority: Option<i32>,
    /// Pin the loop thread (and its line readers) to this CPU.
    #[arg(long, value_name = "C")]
    pub(crate) pin_cpu: Option<usize>,
    /// Lock the process's memory (mlockall); implied by --rt-priority.
    #[arg(long)]
    pub(crate) mlock: bool,
    /// Spin this long on the clock before a send deadline instead of sleeping, µs
    /// [default: 300].
    #[arg(long, value_name = "US")]
    pub(crate) spin_us: Option<u64>,
    /// Setpoints per second sent to the controller (1..=1000).
    #[arg(long, default_value_t = 100)]
    pub(crate) setpoint_rate_hz: u32,
    /// Look-ahead horizon: each segment goes out this many setpoint periods before its
    /// start (≤ 32).
    #[arg(long, default_value_t = 16)]
    pub(crate) lookahead_segments: u16,
    /// Stop after this many seconds (default: run until a line closes).
    #[arg(long)]
    pub(crate) duration_s: Option<f64>,
    /// Camera: `unix:PATH`, a camera serving frames on a Unix socket (`mesopush-fwsim`
    /// prints it), or `v4l:/dev/videoN`, a V4L2 camera (GREY or YUYV; needs an executor built
    /// with `--features v4l`). Frames are stamped with the driver's CLOCK_MONOTONIC stamp
    /// converted to the executor's clock (docs/hil.md); gaps in the driver's frame sequence
    /// are counted as dropped frames.
    #[arg(long, value_name = "unix:PATH|v4l:DEVICE")]
    pub(crate) camera: Option<String>,
    /// Frame size asked of a V4L2 camera, WxH (e.g. 640x480) [default: the size the camera
    /// is set to].
    #[arg(long, value_name = "WxH")]
    pub(crate) camera_size: Option<String>,
    /// Record each trial's frames.csv, frames/*.png, events.csv and recording.json into
    /// DIR/trial-<plan id>-<start µs>/ (docs/trial-log.md); `mesopush run` completes it.
    #[arg(long, value_name = "DIR")]
    pub(crate) record_dir: Option<PathBuf>,
    /// The fixture frame's origin in stage coordinates, µm (recorded probe positions are in
    /// the fixture frame; `mesopush-fwsim` prints its world's).
    #[arg(long, value_name = "X,Y", default_value = "1000,1000")]
    pub(crate) fixture_origin_um: String,
    /// Longest clock-sync round trip accepted, µs (raise it on a heavily loaded machine,
    /// where replies through another process come back late).
    #[arg(long, default_value_t = ExecutorConfig::DEFAULT.sync_max_rtt_us)]
    pub(crate) sync_max_rtt_us: u64,
    /// Frames recorded after a trial's end, ms.
    #[arg(long, default_value_t = 500)]
    pub(crate) record_tail_ms: u64,
    /// Arming is refused when the probe is farther than this from the plan's stated start,
    /// µm (move it with `mesopush rig goto`).
    #[arg(long, default_value_t = 5.0)]
    pub(crate) start_tolerance_um: f64,
    /// Speed of `rig goto` / `rig home` moves, µm/s (its start from rest must stay within
    /// the acceleration limit at the setpoint rate: ≤ 200 mm/s² ÷ rate).
    #[arg(long, default_value_t = 200.0)]
    pub(crate) goto_speed_um_s: f64,
    /// `rig home`'s park position, stage µm [default: the workspace's centre, 5000,5000].
    #[arg(long, value_name = "X,Y")]
    pub(crate) home_um: Option<String>,
}

/// Increments the boot counter kept beside the plan store; link sessions must differ
/// from the previous run's.
pub(crate) fn next_session(plan_store: &Path) -> Result<u16> {
    let mut name = plan_store.file_name().unwrap_or_default().to_os_string();
    name.push(".boot");
    let path = plan_store.with_file_name(name);
    let last = std::fs::read_to_string(&path).ok().and_then(|s| s.trim().parse::<u16>().ok());
    let session = last.map_or(1, |s| s.wrapping_add(1));
    std::fs::write(&path, session.to_string())
        .with_context(|| format!("writing the boot counter {}", path.display()))?;
    Ok(session)
}

pub(crate) fn open(path: &str, baud: u32) -> Result<serialport::TTYPort> {
    serialport::new(path, baud).open_native().with_context(|| format!("opening serial port {path}"))
}

/// The executor's configuration from the flags, each checked with the flag, value and
/// allowed range named.
pub(crate) fn motion_config(args: &Args) -> Result<ExecutorConfig> {
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

pub(crate) fn parse_pair(flag: &str, text: &str) -> Result<(f64, f64)> {
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

impl Args {
    /// The real-time flags. (They are repeated in `Args` rather than flattened from
    /// [`RtArgs`]: a flattened struct breaks clap's optional default subcommand.)
    pub(crate) fn rt(&self) -> RtArgs {
        RtArgs {
            rt_priority: self.rt_priority,
            pin_cpu: self.pin_cpu,
            mlock: self.mlock,
            spin_us: self.spin_us,
        }
    }
}
