//! `mesopush rig status|goto|home|stop --port P`: rig commands between trials on a running
//! `mesopush-executor` (docs/hil.md). Thin over `mesopush_rig::client::rig`. Positions are
//! given and printed in the fixture frame (the frame plans are written in) using the stage
//! registration of `--world` (default worlds/default.toml), with the stage frame beside.
//! Exit status: 0 done; 1 a goto that stopped or faulted before arriving; 2 a refusal.

use anyhow::Context;
use clap::{Args, Subcommand};
use mesopush_core::geom::Vec2;
use mesopush_protocol::host::{ExecState, ExecStatus, MotionEventKind, StagePoint};
use mesopush_rig::WorldFile;
use mesopush_rig::client::rig::{self, Registration, stage_um};
use mesopush_sim::Plan;
use std::path::PathBuf;
use std::time::Duration;

/// Rig commands between trials: status, goto, home, stop.
#[derive(Debug, Args)]
pub(crate) struct RigArgs {
    #[command(subcommand)]
    command: RigCommand,
}

#[derive(Debug, Subcommand)]
enum RigCommand {
    /// The executor's state, the probe's absolute position, the controller's state and the
    /// last fault.
    Status(Common),
    /// Move the probe to X,Y (fixture µm; `--stage`: stage µm) or to a plan's start, in a
    /// straight line at the executor's goto speed, and wait until it is there.
    Goto(GotoArgs),
    /// Move the probe to the executor's home (park) position and wait.
    Home(MoveArgs),
    /// Stop the probe now, from any state (a running trial ends aborted).
    Stop(Common),
}

#[derive(Debug, Args)]
struct Common {
    /// The executor's host line: `unix:PATH` or a serial device.
    #[arg(long)]
    port: String,
    /// Stage registration from a world file's `[stage] offset_um` (default: worlds/default.toml,
    /// embedded).
    #[arg(long)]
    world: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct MoveArgs {
    #[command(flatten)]
    common: Common,
    /// Give up waiting after this many seconds (the move goes on; `rig stop` ends it).
    #[arg(long, default_value_t = 120.0)]
    timeout_s: f64,
}

#[derive(Debug, Args)]
struct GotoArgs {
    /// Target `X,Y`, µm (fixture frame unless --stage).
    #[arg(value_name = "X,Y", required_unless_present = "plan", conflicts_with = "plan")]
    target: Option<String>,
    /// Go to this plan's start (its `probe_start_um`).
    #[arg(long)]
    plan: Option<PathBuf>,
    /// X,Y is in the stage frame (what the controller reports), not the fixture frame.
    #[arg(long)]
    stage: bool,
    #[command(flatten)]
    moving: MoveArgs,
}

pub(crate) fn run(args: &RigArgs) -> anyhow::Result<()> {
    match &args.command {
        RigCommand::Status(c) => {
            let reg = registration(c)?;
            let s = rig::status(&c.port).with_context(|| format!("status of {}", c.port))?;
            print_status(&s, &reg, c.json)
        }
        RigCommand::Stop(c) => {
            let reg = registration(c)?;
            let s = rig::stop(&c.port).with_context(|| format!("stopping {}", c.port))?;
            print_status(&s, &reg, c.json)
        }
        RigCommand::Home(m) => {
            let reg = registration(&m.common)?;
            let bar = spinner("homing: moving the probe to the executor's park position");
            let end = rig::home(&m.common.port, timeout(m.timeout_s)?);
            bar.finish_and_clear();
            let end = end.with_context(|| format!("homing {}", m.common.port))?;
            motion_end(end, &reg, m.common.json)
        }
        RigCommand::Goto(g) => goto(g),
    }
}

fn goto(g: &GotoArgs) -> anyhow::Result<()> {
    let c = &g.moving.common;
    let reg = registration(c)?;
    let target = match (&g.target, &g.plan) {
        (_, Some(plan)) => reg.to_stage(Plan::load(plan)?.probe_start())?,
        (Some(text), None) => {
            let p = parse_xy(text)?;
            if g.stage { Registration { fixture_origin_um: Vec2::new(0.0, 0.0) } } else { reg }
                .to_stage(p)?
        }
        (None, None) => anyhow::bail!("give a target X,Y or --plan PLAN"),
    };
    let bar = spinner(&format!("moving the probe to stage {target}"));
    let end = rig::goto(&c.port, target, timeout(g.moving.timeout_s)?);
    bar.finish_and_clear();
    let end = end.with_context(|| format!("moving the probe to stage {target} on {}", c.port))?;
    motion_end(end, &reg, c.json)
}

/// A spinner on stderr while a move runs (hidden when stderr is no terminal; stdout stays
/// clean for `--json`).
fn spinner(what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
    {
        bar.set_style(style);
    }
    bar.set_message(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn registration(c: &Common) -> anyhow::Result<Registration> {
    let world = match &c.world {
        Some(p) => WorldFile::load(p)?,
        None => WorldFile::default_world(),
    };
    let [x, y] = world.spec.stage.offset_um;
    Ok(Registration { fixture_origin_um: Vec2::new(x, y) })
}

fn timeout(s: f64) -> anyhow::Result<Duration> {
    anyhow::ensure!(s.is_finite() && s > 0.0, "--timeout-s must be a positive number, got {s}");
    Ok(Duration::from_secs_f64(s))
}

fn parse_xy(text: &str) -> anyhow::Result<Vec2> {
    let v: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("the target wants two numbers X,Y in µm, got {text:?}"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok(Vec2::new(x, y)),
        _ => anyhow::bail!("the target wants two finite numbers X,Y in µm, got {text:?}"),
    }
}

fn both(p: StagePoint, reg: &Registration) -> String {
    let f = reg.to_fixture(p);
    format!("fixture ({:.1}, {:.1}) µm = stage {p}", f.x, f.y)
}

/// The executor's state as a JSON key (snake case, as trial.json's states).
fn state_key(s: ExecState) -> &'static str {
    match s {
        ExecState::Idle => "idle",
        ExecState::Flashing => "flashing",
        ExecState::PlanFlashed => "plan_flashed",
        ExecState::Armed => "armed",
        ExecState::Running => "running",
        ExecState::Done => "done",
        ExecState::Aborted => "aborted",
        ExecState::Faulted => "faulted",
        ExecState::Moving => "moving",
    }
}

fn print_status(s: &ExecStatus, reg: &Registration, json: bool) -> anyhow::Result<()> {
    if json {
        let v = serde_json::json!({
            "state": state_key(s.state),
            "state_text": s.state.to_string(),
            "plan_id": s.plan_id,
            "step_count": s.step_count,
            "step_index": s.step_index,
            "probe_stage_um": s.probe.map(|p| { let u = stage_um(p); [u.x, u.y] }),
            "probe_fixture_um": s.probe.map(|p| { let f = reg.to_fixture(p); [f.x, f.y] }),
            "controller": s.ctrl_state.map(|c| c.to_string()),
            "last_fault": s.last_fault.map(|f| f.to_string()),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    match s.plan_id {
        Some(id) => println!("executor: {} (plan {id:08x}, {} steps)", s.state, s.step_count),
        None => println!("executor: {}", s.state),
    }
    match s.probe {
        Some(p) => println!("probe: {}", both(p, reg)),
        None => println!("probe: unknown (no position report from the controller yet)"),
    }
    match s.ctrl_state {
        Some(c) => println!("controller: {c}"),
        None => println!("controller: not heard yet"),
    }
    match &s.last_fault {
        Some(f) => println!("last fault: {f}"),
        None => println!("last fault: none"),
    }
    Ok(())
}

fn motion_end(end: MotionEventKind, reg: &Registration, json: bool) -> anyhow::Result<()> {
    let (ok, text) = match end {
        MotionEventKind::Arrived { at } => (true, format!("arrived: {}", both(at, reg))),
        other => (false, other.to_string()),
    };
    if json {
        println!("{}", serde_json::json!({ "arrived": ok, "detail": text }));
    } else {
        println!("{text}");
    }
    if ok {
        Ok(())
    } else {
        Err(crate::verdict::Negative(format!("the move did not arrive: {text}")).into())
    }
}
