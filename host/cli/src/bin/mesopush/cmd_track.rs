//! `mesopush track`: measures the peg's pose and the probe tip in every frame of a trial's
//! frame store (`frames.tif`) or of a folder of PNG frames against a background frame, and
//! writes pose.csv (and optionally overlays and a JSON summary). See
//! `mesopush_vision::frame_source` for where frames and their times are read from.

use mesopush_core::check::Allowed;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use mesopush_core::geom::{ConvexPolygon, Vec2};
use mesopush_vision::FrameSet;
use mesopush_vision::folder::{POSE_CSV_HEADER, pose_csv_row};
use mesopush_vision::overlay::draw_overlay;
use mesopush_vision::{Calibration, Threshold, TrackSettings, Tracker};

/// Track the peg and the probe tip in a folder of microscope frames.
#[derive(Debug, Args)]
pub(crate) struct TrackArgs {
    /// A trial directory holding a frame store (`frames.tif`), a store file itself, or a
    /// folder of PNG frames (8-bit grayscale; processed in file-name order).
    frames_dir: PathBuf,
    /// Reference frame of the empty fixture (same size and lighting as the frames).
    #[arg(long)]
    background: PathBuf,
    /// Where to write pose.csv.
    #[arg(long)]
    out: PathBuf,
    /// Field of view W,H in µm spread over the image (default 3370,2520).
    #[arg(long, value_name = "W,H", conflicts_with = "um_per_px")]
    field_um: Option<String>,
    /// Scale per axis SX,SY in µm per pixel (instead of --field-um).
    #[arg(long, value_name = "SX,SY")]
    um_per_px: Option<String>,
    /// Where the fixture frame's origin lies in the image, pixels X,Y (default 0,0: the
    /// image's top-left corner).
    #[arg(long, value_name = "X,Y", default_value = "0,0")]
    origin_px: String,
    /// A calibration file (written by `mesopush calibrate`; its `[calibration]` table) instead
    /// of --field-um, --um-per-px and --origin-px.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["field_um", "um_per_px", "origin_px"])]
    calibration: Option<PathBuf>,
    /// Fixed threshold on the darkening, share of the plate's light (default: automatic).
    #[arg(long)]
    threshold: Option<f32>,
    /// Peg size L,W in µm (a rectangle; default 1615,985).
    #[arg(long, value_name = "L,W", default_value = "1615,985")]
    peg_um: String,
    /// Orientation the first frame is taken to be near, degrees (as `plan --start`; the
    /// ellipse gives θ modulo 180°, so this picks the branch).
    #[arg(long, default_value_t = 0.0, value_parser = crate::ranges::real(Allowed::closed(-360.0, 360.0, "°")))]
    theta0_deg: f64,
    /// Also write each frame with the detected outline and tip drawn on it to this folder.
    #[arg(long)]
    overlay: Option<PathBuf>,
    /// Print a JSON summary instead of the text one.
    #[arg(long)]
    json: bool,
}

/// Parses "A,B" into two finite numbers, naming the flag on error.
fn pair(flag: &str, text: &str) -> anyhow::Result<(f64, f64)> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let bad = || anyhow::anyhow!("{flag} wants two numbers as A,B, got {text:?}");
    if parts.len() != 2 {
        return Err(bad());
    }
    let a: f64 = parts[0].parse().map_err(|_| bad())?;
    let b: f64 = parts[1].parse().map_err(|_| bad())?;
    if !(a.is_finite() && b.is_finite()) {
        return Err(bad());
    }
    Ok((a, b))
}

fn settings(args: &TrackArgs, width: u32, height: u32) -> anyhow::Result<TrackSettings> {
    let (ox, oy) = pair("--origin-px", &args.origin_px)?;
    let calibration = if let Some(path) = &args.calibration {
        crate::cmd_run::load_calibration(path)?
    } else if let Some(s) = &args.um_per_px {
        let (sx, sy) = pair("--um-per-px", s)?;
        Calibration::new(sx, sy, Vec2::new(ox, oy))?
    } else {
        let (fw, fh) = pair("--field-um", args.field_um.as_deref().unwrap_or("3370,2520"))?;
        Calibration::from_field(fw, fh, width, height)?.with_origin(Vec2::new(ox, oy))?
    };
    let (l, w) = pair("--peg-um", &args.peg_um)?;
    if !(l > 0.0 && w > 0.0 && l <= 1e5 && w <= 1e5) {
        bail!("invalid --peg-um = {l},{w}: allowed: both in (0, 100000] µm");
    }
    let peg = ConvexPolygon::rectangle(l, w).with_context(|| format!("--peg-um {l},{w}"))?;
    let threshold = match args.threshold {
        Some(t) if !(t > 0.0 && t < 1.0) => bail!("--threshold must be in (0, 1), got {t}"),
        Some(t) => Threshold::Fixed(t),
        None => Threshold::default(),
    };
    Ok(TrackSettings {
        calibration,
        threshold,
        peg,
        theta_hint_rad: args.theta0_deg.to_radians(),
        ..Default::default()
    })
}

fn load_gray(path: &std::path::Path) -> anyhow::Result<image::GrayImage> {
    let img = image::open(path).with_context(|| format!("reading {}", path.display()))?;
    if !matches!(img, image::DynamicImage::ImageLuma8(_)) {
        let got = mesopush_vision::frame_source::describe_pixels(img.color());
        bail!("{}: expected an 8-bit grayscale PNG, got {got}", path.display());
    }
    Ok(img.into_luma8())
}

pub(crate) fn run(args: &TrackArgs) -> anyhow::Result<()> {
    let bg = load_gray(&args.background)?;
    let settings = settings(args, bg.width(), bg.height())?;
    let mut frames = FrameSet::open(&args.frames_dir, Some(&args.background))?;
    if let Some(note) = frames.damage() {
        eprintln!("warning: {}: {note}", args.frames_dir.display());
    }
    if let Some(dir) = &args.overlay {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let peg = settings.peg.clone();
    let calib = settings.calibration;
    let mut tracker = Tracker::new(&bg, settings).context("background")?;
    let mut out = csv::Writer::from_path(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    out.write_record(POSE_CSV_HEADER)?;
    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    if args.json || frames.len() < 30 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut flag_counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut tip_flag_counts: BTreeMap<String, usize> = BTreeMap::new();
    let (mut flagged, mut conf_sum, mut busy_s) = (0usize, 0.0, 0.0);
    let mut with_time = 0usize;
    for k in 0..frames.len() {
        let (stem, t_us) = (frames.label(k), frames.time_us(k));
        let frame = frames.image(k)?;
        let start = Instant::now();
        let m = tracker.track(&frame).with_context(|| frames.location(k))?;
        busy_s += start.elapsed().as_secs_f64();
        with_time += usize::from(t_us.is_some());
        out.write_record(pose_csv_row(&stem, t_us, &m))?;
        flagged += usize::from(m.is_flagged());
        conf_sum += m.confidence;
        for f in &m.flags {
            *flag_counts.entry(f.as_str().to_string()).or_default() += 1;
        }
        if let Some(f) = m.tip_flag {
            *tip_flag_counts.entry(f.as_str().to_string()).or_default() += 1;
        }
        if let Some(dir) = &args.overlay {
            let p = dir.join(format!("{stem}.png"));
            draw_overlay(&frame, &m, &peg, &calib)
                .save(&p)
                .with_context(|| format!("writing {}", p.display()))?;
        }
        bar.inc(1);
    }
    out.flush().with_context(|| format!("writing {}", args.out.display()))?;
    bar.finish_and_clear();
    let n = frames.len();
    let tip_flagged: usize = tip_flag_counts.values().sum();
    let summary = serde_json::json!({
        "frames": n,
        "flagged": flagged,
        "flags": flag_counts,
        "tip_flagged": tip_flagged,
        "tip_flags": tip_flag_counts,
        "mean_confidence": conf_sum / n as f64,
        "with_time": with_time,
        "tracking_ms_per_frame": 1e3 * busy_s / n as f64,
        "out": args.out,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "tracked {n} frames ({flagged} flagged, {tip_flagged} probe tips withheld, mean \
             confidence {:.3}, {:.2} ms/frame) → {}",
            conf_sum / n as f64,
            1e3 * busy_s / n as f64,
            args.out.display()
        );
    }
    Ok(())
}
