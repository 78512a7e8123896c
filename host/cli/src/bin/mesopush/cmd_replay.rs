//! `mesopush replay`: a model's prediction of recorded trials against their measured poses
//! (final-pose and RMS errors per trial, a figure per trial), thin over
//! `mesopush_diagnose::replay`.

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_core::check::Allowed;
use mesopush_diagnose::replay::{ReplayOptions, ReplayReport, replay_dirs};
use mesopush_ident::figure::draw_tracks;
use mesopush_sim::{Model, SimSettings};
use std::path::PathBuf;

/// Replay recorded trials with a model and compare with what was measured.
#[derive(Debug, Args)]
pub(crate) struct ReplayArgs {
    /// The model TOML (any that `identify` or `diagnose` writes, or models/*.toml).
    #[arg(long)]
    model: PathBuf,
    /// Trial directories, or directories holding them (nested up to 4 levels).
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Output directory: `replay.json` and one figure per trial (`<trial id>.png`).
    #[arg(long, default_value = "runs/replay")]
    out: PathBuf,
    /// Do not draw the figures.
    #[arg(long)]
    no_fig: bool,
    /// How far a recorded pusher may start inside the part, as a fraction of the part's size
    /// (the part is moved clear first); default: the trial's `registration_tol_um`, else the
    /// simulator's (0.02).
    #[arg(long, value_parser = crate::ranges::real(Allowed::closed(0.0, 0.5, "")))]
    registration_tol: Option<f64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &ReplayArgs) -> Result<()> {
    let model = Model::load(&a.model)?;
    let dirs = mesopush_trial::trial_dirs(&a.trials)?;
    let options =
        ReplayOptions { base: SimSettings::default(), registration_tol: a.registration_tol };
    let mut check = options.base.clone();
    check.registration_tol = a.registration_tol.unwrap_or(check.registration_tol);
    check.validate()?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let pb = ProgressBar::new(dirs.len() as u64);
    pb.set_style(ProgressStyle::with_template("replay {bar:30} {pos}/{len} {msg}")?);
    let mut fig_errors = Vec::new();
    let report = replay_dirs(&model, &dirs, &options, |_, r, data| {
        pb.inc(1);
        if let (Some(r), false) = (r, a.no_fig) {
            let file = a.out.join(format!("{}.png", r.trial.replace(['/', '\\'], "_")));
            if let Err(e) = draw_tracks(&[r.panel(data)], &file) {
                fig_errors.push(format!("{}: {e}", file.display()));
            }
        }
    });
    pb.finish_and_clear();
    let text = serde_json::to_string_pretty(&report)?;
    mesopush_core::fsx::write_atomic(&a.out.join("replay.json"), text.as_bytes())?;
    if a.json {
        println!("{text}");
    } else {
        print_text(&report, &a.out);
    }
    if let Some(e) = fig_errors.first() {
        anyhow::bail!("{} figure(s) could not be drawn, first: {e}", fig_errors.len());
    }
    if let Some(first) = report.failures.first() {
        anyhow::bail!(
            "{} of {} trials could not be replayed (all listed above), first: {}: {}",
            report.failures.len(),
            dirs.len(),
            first.trial,
            first.reason
        );
    }
    Ok(())
}

fn print_text(r: &ReplayReport, out: &std::path::Path) {
    println!(
        "{:<40} {:>12} {:>10} {:>10} {:>8}",
        "trial", "final µm", "final °", "RMS µm", "RMS °"
    );
    for t in &r.trials {
        println!(
            "{:<40} {:>12.1} {:>10.2} {:>10.1} {:>8.2}",
            t.trial, t.final_error_um, t.final_error_deg, t.rms_um, t.rms_deg
        );
    }
    if let (Some(f), Some(fd), Some(rm), Some(rd)) =
        (r.median_final_error_um, r.median_abs_final_error_deg, r.median_rms_um, r.median_rms_deg)
    {
        println!(
            "median over {} trials: final {f:.1} µm, {fd:.2}°; RMS {rm:.1} µm, {rd:.2}°",
            r.trials.len()
        );
    }
    let dropped: usize = r.trials.iter().map(|t| t.pose_rows_dropped).sum();
    if dropped > 0 {
        println!("pose.csv rows dropped for recording jitter (not compared): {dropped}");
    }
    for f in &r.failures {
        println!("NOT replayed: {}: {}", f.trial, f.reason);
    }
    println!("wrote {}/replay.json and the figures", out.display());
}
