//! `mesopush batch` from the outside: help, clear errors for bad batch files, the `--json`
//! fields the issue asks for, shards run as separate processes and merged, the report.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn mesopush(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).output().expect("mesopush runs")
}

fn batch_file(dir: &Path, extra: &str) -> PathBuf {
    let extra = if extra.contains("runner") {
        extra.to_string()
    } else {
        format!("runner = \"sim\"\n{extra}")
    };
    let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
    let text = format!(
        "name = \"cli\"\nseed = 9\ntrials = 4\nplans = [{plan:?}]\n{extra}\n\
         [camera]\nframe_drop = 0.2\nframe_black = 0.2\n"
    );
    let path = dir.join("b.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn help_names_every_subcommand() {
    let o = mesopush(&["batch", "--help"]);
    let text = String::from_utf8_lossy(&o.stdout);
    for sub in ["run", "report", "merge"] {
        assert!(text.contains(sub), "{text}");
    }
    let o = mesopush(&["batch", "run", "--help"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("--shard"));
}

#[test]
fn bad_batch_files_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let b = batch_file(tmp.path(), "trails = 3");
    let o = mesopush(&["batch", "run", b.to_str().unwrap(), "--out", "x"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("trails") && err.starts_with("error:"), "{err}");
    let b = batch_file(tmp.path(), "runner = \"warp\"");
    let o = mesopush(&["batch", "run", b.to_str().unwrap(), "--out", "x"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("\"warp\""));
    let b = batch_file(tmp.path(), "");
    let o = mesopush(&["batch", "run", b.to_str().unwrap(), "--shard", "2/2"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("I/N"));
}

#[test]
fn shards_run_as_processes_merge_and_match_the_whole_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let b = batch_file(tmp.path(), "");
    let b = b.to_str().unwrap();
    let whole = tmp.path().join("whole");
    let v = json(&mesopush(&["batch", "run", b, "--json", "--out", whole.to_str().unwrap()]));
    for key in
        ["trials", "succeeded", "faulted", "faults_injected", "faults_detected", "records_lost"]
    {
        assert!(v[key].is_u64(), "{key} missing in {v}");
    }
    assert_eq!((v["trials"].as_u64(), v["records_lost"].as_u64()), (Some(4), Some(0)));
    let sharded = tmp.path().join("sharded");
    for i in 0..2 {
        let shard = format!("{i}/2");
        let o = mesopush(&[
            "batch",
            "run",
            b,
            "--json",
            "--shard",
            &shard,
            "--out",
            sharded.to_str().unwrap(),
        ]);
        assert_eq!(json(&o)["trials"].as_u64(), Some(2));
    }
    let merged = tmp.path().join("merged");
    let o = mesopush(&[
        "batch",
        "merge",
        "--json",
        "--out",
        merged.to_str().unwrap(),
        sharded.join("shard-00-of-02").to_str().unwrap(),
        sharded.join("shard-01-of-02").to_str().unwrap(),
    ]);
    let m = json(&o);
    for key in
        ["trials", "succeeded", "faulted", "faults_injected", "faults_detected", "records_lost"]
    {
        assert_eq!(m[key], v[key], "{key}");
    }
    let r = json(&mesopush(&["batch", "report", "--json", merged.to_str().unwrap()]));
    assert_eq!(r["figures"].as_array().map(Vec::len), Some(3));
    assert!(merged.join("report/report.md").exists());
    json(&mesopush(&["batch", "report", "--json", whole.to_str().unwrap()]));
    assert_bit_identical(&whole, &merged);
}

/// Every per-trial figure of the merged shards equals the one-process batch's, digit for
/// digit (wall times and directories aside), and so do the trial logs' poses.
fn assert_bit_identical(whole: &Path, merged: &Path) {
    let rows = |dir: &Path| {
        let mut r = csv::Reader::from_path(dir.join("report/trials.csv")).unwrap();
        let head = r.headers().unwrap().clone();
        let keep: Vec<usize> =
            (0..head.len()).filter(|&i| !matches!(&head[i], "wall_time_s" | "dir")).collect();
        let dirs: Vec<String> = r
            .records()
            .map(|x| x.unwrap())
            .map(|rec| {
                let cells: Vec<&str> = keep.iter().map(|&i| &rec[i]).collect();
                format!(
                    "{}\t{}",
                    cells.join(","),
                    &rec[head.iter().position(|h| h == "dir").unwrap()]
                )
            })
            .collect();
        dirs
    };
    let (a, b) = (rows(whole), rows(merged));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        let (xa, xdir) = x.split_once('\t').unwrap();
        let (ya, ydir) = y.split_once('\t').unwrap();
        assert_eq!(xa, ya, "trials.csv rows differ between one process and merged shards");
        let pose = |base: &Path, d: &str| std::fs::read(base.join(d).join("pose.csv")).ok();
        assert_eq!(pose(whole, xdir), pose(merged, ydir), "pose.csv of {xdir} differs");
    }
}
