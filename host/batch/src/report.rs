//! `mesopush batch report DIR`: the summary as Markdown with PNG figures (`report.md`,
//! `success.png`, `final_poses.png`, `timing.png`), plus `summary.json` and `trials.csv`
//! (one row per trial, for pandas).

use super::figures;
use super::journal::AttemptRecord;
use super::stats::{Loaded, Summary, summarize};
use crate::Error;
use mesopush_trial::Trial;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the report wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// The summary.
    pub summary: Summary,
    /// `report.md`.
    pub markdown: PathBuf,
    /// The figures.
    pub figures: Vec<PathBuf>,
}

#[derive(Debug, Serialize)]
struct Row<'a> {
    index: u64,
    trial_id: &'a str,
    verdict: &'a str,
    reason: &'a str,
    attempts: u32,
    start_x_um: f64,
    start_y_um: f64,
    start_theta_rad: f64,
    est_x_um: Option<f64>,
    est_y_um: Option<f64>,
    final_x_um: Option<f64>,
    final_y_um: Option<f64>,
    final_theta_rad: Option<f64>,
    faults_injected: u64,
    faults_detected: u64,
    records_lost: u64,
    sim_time_s: f64,
    wall_time_s: f64,
    dir: &'a str,
}

fn write_csv(finals: &[&AttemptRecord], path: &Path) -> Result<(), Error> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for a in finals {
        let r = &a.result;
        let row = Row {
            index: a.index,
            trial_id: &a.trial_id,
            verdict: r.verdict.as_str(),
            reason: &r.reason,
            attempts: a.attempt,
            start_x_um: a.peg_start.x_um,
            start_y_um: a.peg_start.y_um,
            start_theta_rad: a.peg_start.theta_rad,
            est_x_um: r.estimated_start.map(|p| p.x_um),
            est_y_um: r.estimated_start.map(|p| p.y_um),
            final_x_um: r.final_pose.map(|p| p.x_um),
            final_y_um: r.final_pose.map(|p| p.y_um),
            final_theta_rad: r.final_pose.map(|p| p.theta_rad),
            faults_injected: r.faults_injected,
            faults_detected: r.faults_detected,
            records_lost: r.records_lost,
            sim_time_s: r.sim_time_s,
            wall_time_s: a.wall_time_s,
            dir: &a.dir,
        };
        w.serialize(row).map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
    }
    let bytes = w.into_inner().map_err(|e| Error::io(path, e.into_error()))?;
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    mesopush_core::stats::percentile(v, q).unwrap_or(0.0)
}

fn markdown(b: &Loaded, s: &Summary, finals: &[&AttemptRecord]) -> String {
    let spec = &b.manifest.spec;
    let pct = |x: f64| 100.0 * x;
    let mut m = String::new();
    let _ =
        writeln!(m, "# Batch report: {}\n", if s.name.is_empty() { "(unnamed)" } else { &s.name });
    let runner = finals.first().map_or("-", |a| a.runner.as_str());
    let plans: Vec<_> = b.manifest.plans.iter().map(|p| p.name.as_str()).collect();
    let _ = writeln!(m, "- runner `{runner}`, seed {}, plans: {}", spec.seed, plans.join("; "));
    let _ = writeln!(
        m,
        "- trials with a verified verdict: **{}** of {} expected ({} missing; final records \
         lost {}, damaged {}, duplicated {}, foreign {})",
        s.trials, s.expected, s.missing, s.lost, s.damaged, s.duplicates, s.foreign
    );
    let _ = writeln!(
        m,
        "- **success: {} / {} = {:.1} %** (Wilson 95 % interval {:.1} – {:.1} %)\n",
        s.succeeded,
        s.trials,
        pct(s.success_rate),
        pct(s.success_ci95[0]),
        pct(s.success_ci95[1])
    );
    m.push_str("| verdict | trials |\n|---|---:|\n");
    for (v, n) in [
        ("inserted", s.succeeded),
        ("missed", s.missed),
        ("faulted", s.faulted),
        ("timeout", s.timeouts),
        ("error", s.errors),
    ] {
        let _ = writeln!(m, "| {v} | {n} |");
    }
    faults_and_reasons(&mut m, s);
    integrity(&mut m, s);
    timing(&mut m, s, finals, &spec.runner);
    m.push_str("## Figures\n\n![success over time](success.png)\n\n![final poses](final_poses.png)\n\n![timing](timing.png)\n\n");
    m.push_str("Per-trial rows: `trials.csv`; summary: `summary.json`.\n");
    m
}

fn faults_and_reasons(m: &mut String, s: &Summary) {
    m.push_str("\n## Faults and data\n\n| | |\n|---|---:|\n");
    let _ = writeln!(
        m,
        "| attempts run | {} |\n| attempts retried | {} |\n| interrupted attempts set aside | {} |",
        s.attempts,
        s.attempts.saturating_sub(s.trials),
        s.discarded
    );
    let _ = writeln!(
        m,
        "| faults injected | {} |\n| faults detected | {} |\n| **records lost** | **{}** |\n",
        s.faults_injected, s.faults_detected, s.records_lost
    );
    let c = &s.faults_by_class;
    m.push_str("| fault class | injected | detected |\n|---|---:|---:|\n");
    for (name, f) in [
        ("camera (dropped, black frames)", c.camera),
        ("controller (stall, limit switch, reboot)", c.controller),
        ("executor-controller link (detections are link events)", c.exec_ctrl_link),
        ("host-executor link (detections are link events)", c.host_exec_link),
    ] {
        let _ = writeln!(m, "| {name} | {} | {} |", f.injected, f.detected);
    }
    m.push('\n');
    m.push_str("## Failure reasons\n\n| verdict | reason | trials |\n|---|---|---:|\n");
    for r in s.reasons.iter().filter(|r| r.verdict != super::TrialVerdict::Inserted) {
        let _ = writeln!(
            m,
            "| {} | {} | {} |",
            r.verdict.as_str(),
            r.reason.replace('|', "/"),
            r.trials
        );
    }
}

/// Findings shown in report.md (all of them are in summary.json).
const MAX_FINDINGS_SHOWN: usize = 50;

fn integrity(m: &mut String, s: &Summary) {
    m.push_str("## Data integrity\n\nEvery final record checked against its trial directory's checksum (docs/batch.md).\n\n| | |\n|---|---:|\n");
    for (what, n) in [
        ("final records lost (directory gone)", s.lost),
        ("final records damaged (checksum mismatch)", s.damaged),
        ("final records duplicated", s.duplicates),
        ("final records foreign (not a trial of this batch)", s.foreign),
        ("accepted without a checksum to verify", s.unverified),
        ("set aside by earlier resumes and run again", s.voided),
    ] {
        let _ = writeln!(m, "| {what} | {n} |");
    }
    if s.findings.is_empty() {
        m.push('\n');
        return;
    }
    m.push_str(
        "\n| journal record | trial | problem | directory | evidence |\n|---:|---|---|---|---|\n",
    );
    for f in s.findings.iter().take(MAX_FINDINGS_SHOWN) {
        let _ = writeln!(
            m,
            "| {} | {} | **{}** | {} | {} |",
            f.record,
            f.trial_id,
            f.problem.as_str(),
            f.dir,
            f.detail.replace('|', "/")
        );
    }
    if s.findings.len() > MAX_FINDINGS_SHOWN {
        let _ = writeln!(m, "\n… {} more in summary.json", s.findings.len() - MAX_FINDINGS_SHOWN);
    }
    m.push('\n');
}

fn timing(m: &mut String, s: &Summary, finals: &[&AttemptRecord], runner: &str) {
    let mut wall: Vec<f64> = finals.iter().map(|a| a.wall_time_s * 1e3).collect();
    let _ = writeln!(m, "\n## Timing\n\n| | |\n|---|---:|");
    let _ = writeln!(
        m,
        "| wall time, all attempts | {:.1} s |\n| **trials per second** | **{:.2}** |\n| timed | {} |",
        s.wall_time_s,
        s.trials_per_s,
        figures::what_is_timed(runner)
    );
    let _ = writeln!(
        m,
        "| per trial: median / 95th pct / max | {:.1} / {:.1} / {:.1} ms |",
        percentile(&mut wall, 0.5),
        percentile(&mut wall, 0.95),
        percentile(&mut wall, 1.0)
    );
    let ratio = if s.wall_time_s > 0.0 { s.sim_time_s / s.wall_time_s } else { 0.0 };
    let _ =
        writeln!(m, "| simulated time covered | {:.0} s ({ratio:.0}× real time) |\n", s.sim_time_s);
}

/// Writes the report of the batch in `dir` into `out`.
pub fn write(dir: &Path, out: &Path) -> Result<Written, Error> {
    let b = Loaded::load(dir)?;
    let s = summarize(&b);
    let finals_map = b.finals();
    let finals: Vec<&AttemptRecord> = finals_map.values().copied().collect();
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let fixture = finals.iter().find_map(|a| Trial::load(&dir.join(&a.dir)).ok()?.meta.fixture);
    let figs = [out.join("success.png"), out.join("final_poses.png"), out.join("timing.png")];
    figures::success_over_time(&finals, &figs[0])?;
    let walls = fixture.as_ref().map_or(&[][..], |f| f.walls.as_slice());
    figures::final_poses(&finals, walls, fixture.as_ref().map(|f| &f.goal), &figs[1])?;
    figures::timing(&finals, &b.manifest.spec.runner, &figs[2])?;
    write_csv(&finals, &out.join("trials.csv"))?;
    let json = serde_json::to_string_pretty(&s).expect("summary serialises");
    std::fs::write(out.join("summary.json"), json).map_err(|e| Error::io(out, e))?;
    let md = out.join("report.md");
    std::fs::write(&md, markdown(&b, &s, &finals)).map_err(|e| Error::io(&md, e))?;
    Ok(Written { summary: s, markdown: md, figures: figs.to_vec() })
}
