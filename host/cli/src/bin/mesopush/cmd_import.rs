//! `mesopush import SOURCE DIR --out OUT`: converts foreign recordings of real pushes into
//! version-2 trial logs (library: `mesopush_trial::import`). Exit 0 when every run was
//! imported, 2 when the input is refused (the message names the file, line, field and value).

use anyhow::Context;
use clap::{Args, Subcommand};
use mesopush_core::check::Allowed;
use mesopush_trial::import::zhou_mason::{self, ImportOptions, ImportReport};
use std::path::PathBuf;

/// Convert recordings of real pushes into trial logs (one directory per run).
#[derive(Debug, Args)]
pub(crate) struct ImportArgs {
    #[command(subcommand)]
    source: Source,
}

#[derive(Debug, Subcommand)]
enum Source {
    /// Zhou & Mason 2017 two-finger pushing logs (../shared/real-pushes/zhou-mason-2017):
    /// one trial per log*.txt, plus OUT/runs.csv (docs/import-zhou-mason.md).
    #[command(name = "zhou-mason")]
    ZhouMason(ZhouMasonArgs),
}

#[derive(Debug, Args)]
struct ZhouMasonArgs {
    /// The data root, a set-up folder, a start folder or one run file (searched recursively
    /// for log*.txt).
    dir: PathBuf,
    /// Output folder: one trial directory per run and runs.csv (existing trials are never
    /// overwritten).
    #[arg(long)]
    out: PathBuf,
    /// How much later than the hand the object's pose is logged, ms (pose.csv stamps are
    /// moved earlier by it; 0 keeps the logged pairing).
    #[arg(long, default_value_t = 150.0, value_parser = crate::ranges::real(Allowed::closed(-10_000.0, 10_000.0, "ms")))]
    vision_latency_ms: f64,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &ImportArgs) -> anyhow::Result<()> {
    match &args.source {
        Source::ZhouMason(a) => zhou_mason_cmd(a),
    }
}

fn zhou_mason_cmd(a: &ZhouMasonArgs) -> anyhow::Result<()> {
    let options = ImportOptions { vision_latency_s: a.vision_latency_ms / 1000.0 };
    let report = match zhou_mason::import(&a.dir, &a.out, &options) {
        Ok(r) => r,
        Err(e @ mesopush_trial::Error::Io { .. }) => return Err(e.into()),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding JSON")?);
    } else {
        print_text(&report, a);
    }
    Ok(())
}

fn print_text(r: &ImportReport, a: &ZhouMasonArgs) {
    let t = &r.totals;
    println!(
        "imported {} runs into {} (index: {})",
        r.runs.len(),
        a.out.display(),
        a.out.join(zhou_mason::INDEX).display()
    );
    for set_up in zhou_mason::setup::SetUp::ALL {
        let runs: Vec<_> = r.runs.iter().filter(|s| s.set_up == set_up.name()).collect();
        if runs.is_empty() {
            continue;
        }
        let sum =
            |f: fn(&zhou_mason::RunSummary) -> usize| runs.iter().map(|s| f(s)).sum::<usize>();
        println!(
            "  {:<14} {:>2} runs  {:>5} rows: {:>5} poses kept, {:>4} vision dropouts, {:>4} \
             stale repeats, {:>2} first rows dropped",
            set_up.name(),
            runs.len(),
            sum(|s| s.counts.file_rows),
            sum(|s| s.counts.pose_rows),
            sum(|s| s.counts.vision_dropouts),
            sum(|s| s.counts.stale_repeats),
            sum(|s| s.counts.first_row_dropped),
        );
    }
    println!(
        "  total          {:>2} runs  {:>5} rows: {:>5} poses kept, {:>4} vision dropouts, {:>4} \
         stale repeats; {} probe rows; object stamps moved {} ms earlier (vision latency)",
        r.runs.len(),
        t.file_rows,
        t.pose_rows,
        t.vision_dropouts,
        t.stale_repeats,
        t.probe_rows,
        r.vision_latency_s * 1000.0
    );
}
