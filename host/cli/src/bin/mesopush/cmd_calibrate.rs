//! `mesopush calibrate --port P --out FILE`: measures the camera's pixel size, its rotation
//! relative to the stage axes and the fixture origin in the image on a running
//! `mesopush-executor` (with `--camera` and `--record-dir`): moves the probe a known distance
//! along x, then along y, tracks its tip at rest at the three positions and writes the
//! calibration file `track --calibration` and `run --calibration` read (docs/vision.md,
//! "Calibrating pixel size on a rig"). Thin over `mesopush_rig::client::calibrate`. Exit
//! status: 0 written; 2 refused (the tip not found at a position, bad moves, the executor
//! refusing the moves) or invalid input — nothing is written then. The moves are flashed as
//! a plan of their own: flash the trial's plan again afterwards.

use anyhow::Context;
use clap::Args;
use mesopush_core::geom::Vec2;
use mesopush_executor::ExecutorConfig;
use mesopush_rig::client::calib_plan::CalibrationMoves;
use mesopush_rig::client::calibrate::{CalibrateOptions, CalibrateReport, calibrate};
use mesopush_rig::client::rig::Registration;
use mesopush_vision::Calibration;
use std::path::PathBuf;

/// Measure the camera's pixel size and rotation on a rig; write the calibration file.
#[derive(Debug, Args)]
pub(crate) struct CalibrateArgs {
    /// The executor's host line: `unix:PATH` or a serial device.
    #[arg(long)]
    port: String,
    /// Where to write the calibration (TOML).
    #[arg(long, default_value = "calibration.toml")]
    out: PathBuf,
    /// The executor's `--record-dir` (the calibration moves are recorded there).
    #[arg(long, default_value = "runs/executor")]
    record_dir: PathBuf,
    /// The empty fixture's frame, probe out of view (mesopush-fwsim prints its own).
    #[arg(long, default_value = "runs/fwsim/background.png")]
    background: PathBuf,
    /// The move along x, then the one along y, µm (signed; each at least 100 µm). The tip
    /// must stay in view and clear of the peg and the walls at the start and after each
    /// move; the longer the moves, the more exact the pixel size.
    #[arg(long, value_name = "DX,DY", default_value = "1000,1000", allow_hyphen_values = true)]
    move_um: String,
    /// Speed of the moves, µm/s.
    #[arg(long, default_value_t = 100.0)]
    speed_um_s: f64,
    /// Rest at each position, s (at least 0.6; frames in its first 0.3 s are not used).
    #[arg(long, default_value_t = 1.5)]
    rest_s: f64,
    /// Backlash take-up before the first rest, µm per axis, in the moves' directions (0: none).
    #[arg(long, default_value_t = 20.0)]
    takeup_um: f64,
    /// The stage registration: the fixture origin in stage coordinates, µm (the executor's
    /// `--fixture-origin-um`; mesopush-fwsim prints its world's).
    #[arg(long, value_name = "X,Y", default_value = "1000,1000")]
    fixture_origin_um: String,
    /// The nominal pixel size the tip is tracked with, SX,SY µm/px (the objective's; only the
    /// needle's size in pixels depends on it).
    #[arg(long, value_name = "SX,SY", default_value = "5.265625,5.25")]
    um_per_px: String,
    /// The executor's --setpoint-rate-hz (rebuilds the commanded positions).
    #[arg(long, default_value_t = 100)]
    setpoint_rate_hz: u32,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

fn pair(flag: &str, text: &str) -> anyhow::Result<Vec2> {
    let v: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} wants two numbers X,Y, got {text:?}"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok(Vec2::new(x, y)),
        _ => anyhow::bail!("{flag} wants two finite numbers X,Y, got {text:?}"),
    }
}

pub(crate) fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=1000).contains(&args.setpoint_rate_hz),
        "--setpoint-rate-hz must be in 1..=1000, got {}",
        args.setpoint_rate_hz
    );
    let config =
        ExecutorConfig { setpoint_rate_hz: args.setpoint_rate_hz, ..ExecutorConfig::DEFAULT };
    let s = pair("--um-per-px", &args.um_per_px)?;
    let opts = CalibrateOptions {
        addr: args.port.clone(),
        record_dir: args.record_dir.clone(),
        background: args.background.clone(),
        nominal: Calibration::new(s.x, s.y, Vec2::zeros()).context("--um-per-px")?,
        registration: Registration {
            fixture_origin_um: pair("--fixture-origin-um", &args.fixture_origin_um)?,
        },
        moves: CalibrationMoves {
            move_um: pair("--move-um", &args.move_um)?,
            speed_um_s: args.speed_um_s,
            rest_s: args.rest_s,
            takeup_um: args.takeup_um,
        },
        period_us: config.setpoint_period_us(),
        lead_us: config.start_lead_us,
    };
    let bar = crate::cmd_run::phase_bar();
    let report = calibrate(&opts, &mut |p| crate::cmd_run::show_phase(&bar, p));
    bar.finish_and_clear();
    let report = report.with_context(|| format!("calibrating on {}", args.port))?;
    report.file.write(&args.out)?;
    if args.json {
        let v = serde_json::json!({
            "out": args.out,
            "calibration": report.file.calibration,
            "fit": report.file.fit,
            "positions": report.file.positions,
            "trial_dir": report.trial_dir,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_summary(args, &report, s);
    }
    if let Some(w) = report.file.rotation_warning() {
        eprintln!("warning: {w}");
    }
    Ok(())
}

fn print_summary(args: &CalibrateArgs, r: &CalibrateReport, nominal: Vec2) {
    let c = &r.file.calibration;
    let pct = |v: f64, n: f64| 100.0 * (v / n - 1.0);
    println!("calibration written to {}", args.out.display());
    println!(
        "  pixel size {:.5} × {:.5} µm/px (nominal {} × {}: {:+.2} %, {:+.2} %)",
        c.sx_um_per_px,
        c.sy_um_per_px,
        nominal.x,
        nominal.y,
        pct(c.sx_um_per_px, nominal.x),
        pct(c.sy_um_per_px, nominal.y)
    );
    if let Some(f) = &r.file.fit {
        println!(
            "  camera rotation {:.4}° relative to the stage axes",
            f.rotation_rad.to_degrees()
        );
        println!("  fixture origin at ({:.2}, {:.2}) px", c.origin_px[0], c.origin_px[1]);
        println!(
            "  fit residual {:.3} µm RMS, {:.3} µm max over {} positions",
            f.residual_um_rms, f.residual_um_max, f.positions
        );
    }
    for (k, p) in r.file.positions.iter().enumerate() {
        println!(
            "  position {}: fixture ({:.2}, {:.2}) µm, tip at ({:.3}, {:.3}) px in {} frames \
             (spread {:.3} px)",
            k + 1,
            p.fixture_um[0],
            p.fixture_um[1],
            p.tip_px[0],
            p.tip_px[1],
            p.frames,
            p.spread_px
        );
    }
    println!("  frames of the moves: {}", r.trial_dir.display());
}
