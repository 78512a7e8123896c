//! `mesopush render`: writes a synthetic microscope sequence (the demo fixture, the paper's peg
//! pushed by the probe) as PNG frames with `frames.csv`, `truth.csv` and a background `bg.png`.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use mesopush_vision::demo::demo_sequence_frame;
use mesopush_vision::{DemoFixture, RenderSettings, Renderer, Scene, paper_peg};
use rand::SeedableRng;

/// Frame period of the paper's 30 Hz camera, µs.
const FRAME_PERIOD_US: u64 = 33_333;

/// Render a synthetic microscope sequence with ground truth.
#[derive(Debug, Args)]
pub(crate) struct RenderArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Number of frames.
    #[arg(long, default_value_t = 30)]
    frames: usize,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

pub(crate) fn run(args: &RenderArgs) -> anyhow::Result<()> {
    if args.frames == 0 || args.frames > 100_000 {
        anyhow::bail!("--frames must be in 1..=100000, got {}", args.frames);
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let walls = DemoFixture::default().walls()?;
    let peg = paper_peg();
    let settings = RenderSettings::default();
    let needle = settings.needle;
    let mut renderer = Renderer::new(settings, &walls)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let empty = Scene { walls: &walls, peg: None, peg_pose: Default::default(), probe_tip: None };
    let bg = renderer.render_averaged(&empty, 16, &mut rng);
    let bg_path = args.out.join("bg.png");
    bg.image.save(&bg_path).with_context(|| format!("writing {}", bg_path.display()))?;
    let mut frames_csv = csv::Writer::from_path(args.out.join("frames.csv"))?;
    frames_csv.write_record(["index", "file", "t_capture_us"])?;
    let mut truth_csv = csv::Writer::from_path(args.out.join("truth.csv"))?;
    // pose.csv's columns up to the tip, so truth and tracking line up column by column
    truth_csv.write_record(&mesopush_vision::folder::POSE_CSV_HEADER[..7])?;
    for k in 0..args.frames {
        let (pose, tip) = demo_sequence_frame(&peg, &needle, k, args.frames);
        let scene = Scene { peg: Some(&peg), peg_pose: pose, probe_tip: Some(tip), ..empty };
        let frame = renderer.render(&scene, &mut rng);
        let stem = format!("frame_{k:05}");
        let path = args.out.join(format!("{stem}.png"));
        frame.image.save(&path).with_context(|| format!("writing {}", path.display()))?;
        let t_us = (k as u64 * FRAME_PERIOD_US).to_string();
        frames_csv.write_record([k.to_string(), format!("{stem}.png"), t_us.clone()])?;
        let f = |v: f64| format!("{v:.3}");
        truth_csv.write_record([
            stem,
            t_us,
            f(pose.x_um),
            f(pose.y_um),
            format!("{:.6}", pose.theta_rad),
            f(tip.x),
            f(tip.y),
        ])?;
    }
    frames_csv.flush()?;
    truth_csv.flush()?;
    println!(
        "wrote {} frames, bg.png, frames.csv and truth.csv to {}",
        args.frames,
        args.out.display()
    );
    Ok(())
}
