//! `mesopush lcp solve`: JSON fields, exit status, named failures and parse errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn suite(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/lcp-suite/lcp").join(file)
}

fn run(args: &[&str], file: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["lcp", "solve"])
        .arg(file)
        .args(args)
        .output()
        .expect("run mesopush")
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}", String::from_utf8_lossy(&out.stdout));
    })
}

#[test]
fn solved_file_reports_z_pivots_residual_and_timing() {
    let out = run(&["--json", "--bench", "5"], &suite("lcp_CPS_3.dat"));
    assert_eq!(out.status.code(), Some(0));
    let v = json(&out);
    assert_eq!(v["status"], "solved");
    let z: Vec<f64> = serde_json::from_value(v["z"].clone()).unwrap();
    assert_eq!(z, vec![0.1, 0.0, 0.1, 0.0]);
    assert!(v["pivots"].as_u64().is_some());
    assert!(v["residual"].as_f64().unwrap() <= 1e-9);
    assert!(v["solve_us_median"].as_f64().unwrap() > 0.0);
}

#[test]
fn problem_without_solution_is_a_negative_verdict_with_exit_1() {
    let out = run(&["--json"], &suite("lcp_Pang_isolated_sol_perturbed.dat"));
    assert_eq!(out.status.code(), Some(1));
    let v = json(&out);
    assert_eq!(v["status"], "no_solution_found");
    assert!(v["z"].is_null());
}

#[test]
fn block_storage_and_bad_files_are_clear_errors() {
    let out = run(&["--json"], &suite("lcp_ortiz_block.dat"));
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("lcp_ortiz_block.dat") && err.contains("sparse-block"), "{err}");

    let dir = tempfile::tempdir().unwrap();
    for (name, text, want) in [
        ("nan.dat", "2 0 2 2 2 2 1 0 0 1 NaN -1", "not finite"),
        ("short.dat", "3 0 3 3 3 3 1 2 3", "3 of the 9 values of M"),
        ("sizes.dat", "2 0 2 3 2 2 1 0 0 1 -1 -1", "size1 = 3"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let out = run(&["--json"], &path);
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(name) && err.contains(want), "{name}: {err}");
    }
}

#[test]
fn mlcp_files_are_solved_with_the_mlcp_flag() {
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/lcp-suite/mlcp/m2n1_mlcp.dat");
    let out = run(&["--mlcp", "--json"], &file);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v = json(&out);
    assert_eq!((v["status"].as_str(), v["n_free"].as_u64()), (Some("solved"), Some(1)));
}

#[test]
fn steps_benchmark_reports_every_problem_solved() {
    let out = Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["lcp", "steps", "--count", "20", "--runs", "3", "--json"])
        .output()
        .expect("run mesopush");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v = json(&out);
    assert_eq!((v["solved"].as_u64(), v["failed"].as_u64()), (Some(20), Some(0)));
    assert!(v["solve_us_median"].as_f64().unwrap() > 0.0);
}
