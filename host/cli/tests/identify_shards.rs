//! The identification sweep split into shards by candidate index and merged
//! (`identify shard I/N`, then `identify merge --sweep-from`): the same report and model as
//! one process, and a bad shard set refused with the problem named.

use std::path::Path;
use std::process::{Command, Output};

const SEED: &str = "4";

fn mesopush(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).current_dir(dir).output().unwrap()
}

fn ok(o: Output) -> serde_json::Value {
    assert!(o.status.success(), "seed {SEED}: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A small sweep over the synthetic trials in `mode` (`run`, `merge`, `shard I/N`), with
/// extra arguments.
fn identify(dir: &Path, mode: &[&str], extra: &[&str]) -> Output {
    let mut a = vec!["identify"];
    a.extend_from_slice(mode);
    a.extend_from_slice(&["trials", "--mu-step", "0.25", "--supports", "5", "--seed", SEED]);
    a.extend_from_slice(extra);
    a.push("--json");
    mesopush(&a, dir)
}

#[test]
fn sharded_sweep_merges_to_the_one_process_report_and_bad_sets_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    ok(mesopush(&["identify", "synth", "trials", "--seed", SEED, "--json"], d));
    let whole =
        ok(identify(d, &["run"], &["--out", "whole.toml", "--consistent-out", "whole-s.toml"]));
    for i in 0..3 {
        let (shard, out) = (format!("{i}/3"), format!("shard{i}.json"));
        let v = ok(identify(d, &["shard", &shard], &["--sweep-out", &out]));
        assert_eq!(v["shard"], shard.as_str(), "{v}");
    }
    let from = ["--sweep-from", "shard2.json", "shard0.json", "shard1.json"];
    let mut args = vec!["--out", "merged.toml", "--consistent-out", "merged-s.toml"];
    args.extend_from_slice(&from);
    let merged = ok(identify(d, &["merge"], &args));
    assert_eq!(merged["report"], whole["report"], "seed {SEED}: merged sweep's report differs");
    let read = |f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    assert_eq!(read("merged.toml"), read("whole.toml"), "seed {SEED}: model differs");
    assert_eq!(read("merged-s.toml"), read("whole-s.toml"), "seed {SEED}: consistent set differs");

    let err = |o: Output| {
        assert!(!o.status.success(), "seed {SEED}: a bad shard set was accepted");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = err(identify(d, &["merge"], &["--sweep-from", "shard0.json", "shard1.json"]));
    assert!(e.contains("missing shards 2/3"), "{e}");
    let twice = ["--sweep-from", "shard0.json", "shard0.json", "shard1.json"];
    let e = err(identify(d, &["merge"], &twice));
    assert!(e.contains("given twice"), "{e}");
    let other_seed = mesopush(
        &["identify", "merge", "trials", "--mu-step", "0.25", "--supports", "5", "--seed", "5"]
            .iter()
            .copied()
            .chain(from)
            .collect::<Vec<_>>(),
        d,
    );
    let e = err(other_seed);
    assert!(e.contains("a different sweep"), "{e}");
}
