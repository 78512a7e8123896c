//! `mesopush batch`: run (or resume) a trial batch from a batch file, shard it, merge shard
//! outputs, and write its report. Thin over `mesopush_batch`.

use anyhow::Result;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use mesopush_batch::integrity::Finding;
use mesopush_batch::stats::{Loaded, Summary, summarize};
use mesopush_batch::{BatchConfig, BatchProgress, Session, merge, report};
use mesopush_core::shard::Shard;
use mesopush_trial::FrameRetention;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Unattended trial batches: run, resume, shard, merge, report.
#[derive(Debug, Args)]
pub(crate) struct BatchArgs {
    #[command(subcommand)]
    command: BatchCommand,
}

#[derive(Debug, Subcommand)]
enum BatchCommand {
    /// Run a batch file; re-running the same command resumes where it stopped.
    Run(RunArgs),
    /// Write the report (Markdown + PNG figures, summary.json, trials.csv) of a batch dir.
    Report(ReportArgs),
    /// Combine shard directories into one batch directory (then `batch report` it).
    Merge(MergeArgs),
}

#[derive(Debug, Args)]
struct RunArgs {
    /// Batch TOML (plans, trials, seed, world, camera, policy), e.g. batches/table2.toml.
    batch: PathBuf,
    /// Output directory (default: the batch file's `out`, else runs/batch-NAME).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run only trials with index ≡ I mod N, into OUT/shard-I-of-N (e.g. 3/16).
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Stop after this many trials in this session (≥ 1; run again to continue).
    #[arg(long)]
    max_trials: Option<u64>,
    /// Frame images each trial keeps: all, failed (trials not inserted), "every N", none
    /// (default: the batch file's `frames`, else all).
    #[arg(long, value_name = "all|failed|every N|none")]
    frames: Option<FrameRetention>,
    /// Start even when the estimated size of the trials left exceeds the free space (the
    /// batch still stops cleanly before a trial when the disk is nearly full).
    #[arg(long)]
    ignore_free_space: bool,
    /// Print one JSON summary instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct ReportArgs {
    /// Batch directory (a run's, a shard's or a merge's).
    dir: PathBuf,
    /// Where to write the report (default DIR/report).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct MergeArgs {
    /// Shard (or batch) directories of the same batch.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// The merged batch directory (new, or an earlier merge of the same batch: re-running a
    /// merge completes it or finds it complete).
    #[arg(long)]
    out: PathBuf,
    /// Print the merged summary as JSON.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &BatchArgs) -> Result<()> {
    match &args.command {
        BatchCommand::Run(a) => run_batch(a),
        BatchCommand::Report(a) => run_report(a),
        BatchCommand::Merge(a) => run_merge(a),
    }
}

fn bar(json: bool) -> ProgressBar {
    let pb = if json { ProgressBar::hidden() } else { ProgressBar::new(0) };
    let style = ProgressStyle::with_template(
        "{bar:40} {pos}/{len} trials [{elapsed_precise} < ETA {eta_precise}] {msg}",
    )
    .expect("valid template");
    pb.set_style(style);
    pb
}

fn run_batch(a: &RunArgs) -> Result<()> {
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?.unwrap_or(Shard::ALL);
    let (cfg, factory) = BatchConfig::from_file(
        &a.batch,
        a.out.clone(),
        shard,
        a.max_trials,
        a.frames,
        a.ignore_free_space,
    )?;
    let out = cfg.out.clone();
    let pb = bar(a.json);
    let mut on_progress = |p: &BatchProgress| {
        pb.set_length(p.total);
        if p.done == p.resumed {
            pb.reset_eta();
        }
        pb.set_position(p.done);
        let rate = if p.done > 0 { 100.0 * p.succeeded as f64 / p.done as f64 } else { 0.0 };
        pb.set_message(format!("success {rate:.1} % ({}/{})", p.succeeded, p.done));
    };
    let session = mesopush_batch::run(&cfg, factory, &mut on_progress)?;
    pb.finish_and_clear();
    let s = summarize(&Loaded::load(&out)?);
    print_run(&out, &s, &session, a.json);
    if let Some(why) = &session.stopped {
        anyhow::bail!("{why}");
    }
    if !session.found.is_empty() {
        return Err(crate::verdict::Negative(format!(
            "data integrity: this resume found {} (set aside and run again; {})",
            found_counts(&session.found),
            s.integrity_line()
        ))
        .into());
    }
    integrity_verdict(&s)
}

/// `1 lost, 2 damaged` from a list of findings.
fn found_counts(found: &[Finding]) -> String {
    let mut n: BTreeMap<&str, usize> = BTreeMap::new();
    for f in found {
        *n.entry(f.problem.as_str()).or_default() += 1;
    }
    let parts: Vec<String> = n.iter().map(|(p, k)| format!("{k} {p}")).collect();
    format!("{} final record(s) not good: {}", found.len(), parts.join(", "))
}

/// Exit 1 (a negative verdict) when any record is lost, damaged, duplicated or foreign.
fn integrity_verdict(s: &Summary) -> Result<()> {
    if s.has_integrity_problems() {
        return Err(
            crate::verdict::Negative(format!("data integrity: {}", s.integrity_line())).into()
        );
    }
    Ok(())
}

fn print_findings(findings: &[Finding], head: &str) {
    if findings.is_empty() {
        return;
    }
    eprintln!("{head}");
    for f in findings.iter().take(20) {
        eprintln!(
            "  {} {} (journal record {}, {}): {}",
            f.trial_id,
            f.problem.as_str(),
            f.record,
            f.dir,
            f.detail
        );
    }
    if findings.len() > 20 {
        eprintln!("  … {} more (--json lists them all)", findings.len() - 20);
    }
}

fn print_run(out: &Path, s: &Summary, session: &Session, json: bool) {
    print_findings(
        &session.found,
        "final records found not good on resume (set aside, run again):",
    );
    print_findings(&s.findings, "final records that do not count:");
    let session_rate =
        if session.elapsed_s > 0.0 { session.ran as f64 / session.elapsed_s } else { 0.0 };
    if json {
        let mut v = serde_json::to_value(s).expect("summary serialises");
        v["dir"] = json!(out);
        v["session"] = json!({"ran": session.ran, "resumed": session.resumed,
            "discarded": session.discarded, "restarts": session.restarts,
            "found_on_resume": session.found,
            "torn_journal_line_saved_to": session.torn_saved_to,
            "elapsed_s": session.elapsed_s, "trials_per_s": session_rate});
        println!("{v}");
    } else {
        println!(
            "batch {}: {} of {} trials have a verdict ({} this session, {} resumed, {} interrupted attempts set aside)",
            out.display(),
            s.trials,
            s.expected,
            session.ran,
            session.resumed,
            session.discarded
        );
        println!(
            "success: {} / {} = {:.1} % (95 % CI {:.1}–{:.1} %); missed {}, faulted {}, timeout {}, error {}",
            s.succeeded,
            s.trials,
            100.0 * s.success_rate,
            100.0 * s.success_ci95[0],
            100.0 * s.success_ci95[1],
            s.missed,
            s.faulted,
            s.timeouts,
            s.errors
        );
        println!("faults injected {}, detected {}", s.faults_injected, s.faults_detected);
        println!("{}", s.integrity_line());
        if !session.found.is_empty() {
            println!(
                "found on resume: {}; set aside (voided) and run again",
                found_counts(&session.found)
            );
        }
        println!("this session: {:.1} s, {session_rate:.2} trials/s", session.elapsed_s);
        println!("report: mesopush batch report {}", out.display());
    }
}

fn run_report(a: &ReportArgs) -> Result<()> {
    let out = a.out.clone().unwrap_or_else(|| a.dir.join("report"));
    let w = report::write(&a.dir, &out)?;
    if a.json {
        let mut v = serde_json::to_value(&w.summary)?;
        v["markdown"] = json!(w.markdown);
        v["figures"] = json!(w.figures);
        println!("{v}");
    } else {
        let s = &w.summary;
        println!(
            "{} of {} trials with a verified verdict ({} missing), success {:.1} % (95 % CI {:.1}–{:.1} %)",
            s.trials,
            s.expected,
            s.missing,
            100.0 * s.success_rate,
            100.0 * s.success_ci95[0],
            100.0 * s.success_ci95[1],
        );
        println!("{}", s.integrity_line());
        println!("report: {}", w.markdown.display());
    }
    print_findings(&w.summary.findings, "final records that do not count:");
    integrity_verdict(&w.summary)
}

fn run_merge(a: &MergeArgs) -> Result<()> {
    let m = merge::merge(&a.dirs, &a.out)?;
    let s = summarize(&Loaded::load(&a.out)?);
    if a.json {
        let mut v = serde_json::to_value(&s)?;
        v["inputs"] = json!(m.inputs);
        v["outcome"] = json!(m.outcome);
        println!("{v}");
    } else {
        let what = match m.outcome {
            merge::Outcome::Written => "merged",
            merge::Outcome::AlreadyComplete => "already complete (identical; nothing written):",
            merge::Outcome::Updated => "updated (inputs progressed since the last merge):",
        };
        println!(
            "{what} {} directories: {} of {} trials ({} missing) into {}",
            m.inputs,
            s.trials,
            s.expected,
            s.missing,
            a.out.display()
        );
        println!("{}", s.integrity_line());
        println!("report: mesopush batch report {}", a.out.display());
    }
    print_findings(&s.findings, "final records that do not count:");
    integrity_verdict(&s)
}
