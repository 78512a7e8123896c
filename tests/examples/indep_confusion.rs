//! The confusion matrix of `diagnose` on batches of the independent generator: reads a
//! directory written by the `indep_batches` example (its `manifest.json` names each batch's
//! true effect; diagnosis never sees it), diagnoses every batch as `mesopush diagnose run
//! DIR/<batch>/trial-*` would (even trials train, odd ones are held out; default options),
//! and prints one line per batch and the matrix:
//!
//! ```text
//! cargo run --release -p mesopush-tests --example indep_batches -- --out DIR --seed N --batches K
//! cargo run --release -p mesopush-tests --example indep_confusion -- --dir DIR [--json FILE]
//! ```
//!
//! A library effect counts as attributed when the verdict is `effect` and names its project
//! counterpart; a clean batch when the verdict is `none`; the lead-screw error (outside the
//! library) when the verdict is `unexplained`. Exit code 2 on invalid arguments or data.

use mesopush_diagnose::data::load_split;
use mesopush_diagnose::residual::{Mse, Noise};
use mesopush_diagnose::{Options, TrialData, Verdict, diagnose};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// The project's name for each of the generator's effects (`none`: nothing to name; `-`:
/// outside the library, `unexplained` is right).
fn expected(truth: &str) -> &'static str {
    match truth {
        "clean" => "none",
        "backlash" => "backlash",
        "latency" => "camera_latency",
        "scale" => "scale_error",
        "stripe" => "friction_patch",
        "adhesion" => "adhesion",
        "speed_friction" => "speed_friction",
        "drift" => "support_drift",
        _ => "unexplained",
    }
}

/// What the diagnosis said, in the matrix's words.
fn said(v: Verdict, effect: Option<&str>) -> String {
    match (v, effect) {
        (Verdict::Effect, Some(e)) => e.to_owned(),
        (Verdict::None, _) => "none".into(),
        _ => "unexplained".into(),
    }
}

fn trial_dirs(root: &Path, batch: &Value) -> Result<Vec<PathBuf>, String> {
    let trials = batch["trials"].as_array().ok_or("manifest batch without \"trials\"")?;
    trials
        .iter()
        .map(|t| t.as_str().map(|s| root.join(s)).ok_or_else(|| "a trial is not a path".into()))
        .collect()
}

fn diagnose_batch(root: &Path, batch: &Value) -> Result<Value, String> {
    let dirs = trial_dirs(root, batch)?;
    let (train, test) = load_split(&dirs).map_err(|e| e.to_string())?;
    let all: Vec<TrialData> = train.iter().chain(&test).cloned().collect();
    let noise = Noise::estimate(&all);
    let t0 = Instant::now();
    let d = diagnose(&train, &test, &Options::default(), &|_| {}).map_err(|e| e.to_string())?;
    let wall_s = t0.elapsed().as_secs_f64();
    let floor = 2.0 * noise.xy_um * noise.xy_um;
    let (before, after) = (Mse::of(&d.residuals.0), Mse::of(&d.residuals.1));
    let truth = batch["truth"]["name"].as_str().unwrap_or("?").to_owned();
    let verdict = said(d.verdict, d.effect.map(|e| e.name()));
    let scores: Vec<Value> = d
        .scores
        .iter()
        .map(|s| {
            let params: BTreeMap<&str, f64> =
                s.params.iter().map(|p| (p.0.as_str(), p.1)).collect();
            json!({"candidate": s.candidate.name(), "bic": s.bic,
                   "heldout_norm": s.heldout_norm, "params": params,
                   "heldout_tip_norm": s.heldout.tip_um2 / (noise.tip_um * noise.tip_um),
                   "heldout_xy_norm": s.heldout.xy_um2 / (noise.xy_um * noise.xy_um)})
        })
        .collect();
    Ok(json!({
        "batch": batch["dir"], "world": batch["world"], "truth": truth,
        "expected": expected(&truth), "said": verdict,
        "right": verdict == expected(&truth),
        "nominal_family": d.support_fit.family,
        "heldout_xy_mse_um2_nominal": before.xy_um2, "heldout_xy_mse_um2_after": after.xy_um2,
        "floor_um2": floor, "nominal_over_floor": before.xy_um2 / floor,
        "wall_s": wall_s, "support_fit": d.support_fit.heldout_norm,
        "floor_band": d.floor_band, "scores": scores,
    }))
}

fn run(dir: &Path) -> Result<Vec<Value>, String> {
    let text = std::fs::read_to_string(dir.join("manifest.json"))
        .map_err(|e| format!("{}: {e}", dir.join("manifest.json").display()))?;
    let manifest: Value = serde_json::from_str(&text).map_err(|e| format!("manifest.json: {e}"))?;
    let batches = manifest["batches"].as_array().ok_or("manifest.json without \"batches\"")?;
    let mut rows = Vec::new();
    for b in batches {
        let r = diagnose_batch(dir, b)?;
        println!(
            "{:<20} {:<9} truth {:<15} said {:<16} {} nominal {:<12} held-out {:>8.2} µm² \
             ({:>6.1}× floor) after {:>8.2}  {:>5.1} s",
            r["batch"].as_str().unwrap_or("?"),
            r["world"].as_str().unwrap_or("?"),
            r["truth"].as_str().unwrap_or("?"),
            r["said"].as_str().unwrap_or("?"),
            if r["right"].as_bool() == Some(true) { "right" } else { "WRONG" },
            r["nominal_family"].as_str().unwrap_or("?"),
            r["heldout_xy_mse_um2_nominal"].as_f64().unwrap_or(f64::NAN),
            r["nominal_over_floor"].as_f64().unwrap_or(f64::NAN),
            r["heldout_xy_mse_um2_after"].as_f64().unwrap_or(f64::NAN),
            r["wall_s"].as_f64().unwrap_or(f64::NAN),
        );
        rows.push(r);
    }
    Ok(rows)
}

fn print_matrix(rows: &[Value]) {
    let mut m: BTreeMap<(String, String), usize> = BTreeMap::new();
    for r in rows {
        let k =
            (r["truth"].as_str().unwrap_or("?").into(), r["said"].as_str().unwrap_or("?").into());
        *m.entry(k).or_default() += 1;
    }
    println!("\n| truth (generator) | said | batches |\n|---|---|---|");
    for ((t, s), n) in &m {
        println!("| {t} | {s} | {n} |");
    }
    let right = rows.iter().filter(|r| r["right"].as_bool() == Some(true)).count();
    println!("\nright: {right} of {}", rows.len());
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut dir, mut json_out) = (None, None);
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let Some(value) = it.next() else {
            eprintln!("indep_confusion: {flag} needs a value");
            return ExitCode::from(2);
        };
        match flag.as_str() {
            "--dir" => dir = Some(PathBuf::from(value)),
            "--json" => json_out = Some(PathBuf::from(value)),
            _ => {
                eprintln!("indep_confusion: unknown argument {flag:?} (--dir DIR [--json FILE])");
                return ExitCode::from(2);
            }
        }
    }
    let Some(dir) = dir else {
        eprintln!("indep_confusion: --dir DIR is required (a directory indep_batches wrote)");
        return ExitCode::from(2);
    };
    let rows = match run(&dir) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("indep_confusion: {e}");
            return ExitCode::from(2);
        }
    };
    print_matrix(&rows);
    if let Some(p) = json_out {
        let text = serde_json::to_string_pretty(&rows).unwrap_or_default();
        if let Err(e) = std::fs::write(&p, text) {
            eprintln!("indep_confusion: {}: {e}", p.display());
            return ExitCode::from(2);
        }
    }
    ExitCode::SUCCESS
}
