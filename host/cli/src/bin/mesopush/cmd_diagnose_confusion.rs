//! `mesopush diagnose --confusion N`: blind diagnoses of synthetic batches, N seeds per true
//! effect (clean controls included), summarised as a confusion matrix (true effect ×
//! verdict) and the mean held-out errors before and after.

use super::cmd_diagnose::{DiagnoseArgs, blind, candidate};
use anyhow::Result;
use indicatif::ProgressBar;
use mesopush_diagnose::report::mse_before_after;
use mesopush_diagnose::{Effect, Options, Verdict};

pub(crate) fn run(args: &DiagnoseArgs, opts: &Options, seeds: usize) -> Result<()> {
    let truths: Vec<Effect> = if args.only.is_empty() {
        std::iter::once(Effect::Nominal).chain(Effect::EFFECTS).collect()
    } else {
        args.only.iter().map(|n| candidate(n)).collect::<Result<_>>()?
    };
    let started = std::time::Instant::now();
    let pb = ProgressBar::new((truths.len() * seeds) as u64);
    let mut rows = Vec::new();
    for &t in &truths {
        for k in 0..seeds {
            let seed = args.seed + k as u64;
            let d = match blind(args, opts, t, seed) {
                Ok(d) => d,
                Err(e) => {
                    // One batch that cannot be made or diagnosed must not lose the others.
                    eprintln!("{} seed {seed}: error: {e:#}", t.name());
                    pb.inc(1);
                    continue;
                }
            };
            let (b, a) = mse_before_after(&d);
            let called = match d.verdict {
                Verdict::Effect => d.best.candidate.name().to_string(),
                Verdict::Unexplained => "unexplained".into(),
                Verdict::None => "none".into(),
            };
            let scores: Vec<String> = d
                .scores
                .iter()
                .map(|s| {
                    let v: Vec<String> = s.params.iter().map(|p| format!("{:.3}", p.1)).collect();
                    format!(
                        "{} held-out {:.1} bic {:.0} ({})",
                        s.candidate.name(),
                        s.heldout_norm,
                        s.bic,
                        v.join(" ")
                    )
                })
                .collect();
            eprintln!("{} seed {seed}: {called}\n  {}", t.name(), scores.join("\n  "));
            rows.push((t, seed, called, b, a));
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    eprintln!("{} batches in {:.0} s", rows.len(), started.elapsed().as_secs_f64());
    let cols: Vec<String> = Effect::EFFECTS
        .iter()
        .map(|c| c.name().to_string())
        .chain(["unexplained".into(), "none".into()])
        .collect();
    println!("| true \\ verdict | {} |", cols.join(" | "));
    println!("|---|{}", "---|".repeat(cols.len()));
    for &t in &truths {
        let name = if t == Effect::Nominal { "clean" } else { t.name() };
        let counts: Vec<String> = cols
            .iter()
            .map(|c| rows.iter().filter(|r| r.0 == t && &r.2 == c).count().to_string())
            .collect();
        println!("| {name} | {} |", counts.join(" | "));
    }
    println!(
        "\n| true effect | seed | verdict | X,Y MSE before (µm²) | after | θ MSE before (rad²) | after |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (t, seed, called, b, a) in &rows {
        let name = if *t == Effect::Nominal { "clean" } else { t.name() };
        println!(
            "| {name} | {seed} | {called} | {:.2} | {:.2} | {:.2e} | {:.2e} |",
            b.xy_um2, a.xy_um2, b.theta_rad2, a.theta_rad2
        );
    }
    Ok(())
}
