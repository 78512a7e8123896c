//! Monte Carlo robustness split into shards by trial index and merged: the merge equals the
//! unsplit run trial for trial (through the shard files on disk), and bad shard sets are
//! refused with the problem named, never merged into a partial estimate.

use mesopush_core::shard::Shard;
use mesopush_plan::shard::{self, TrialShard, merge};
use mesopush_plan::{MonteCarlo, Uncertainty};
use mesopush_sim::{Fixture, Model, Plan, SimSettings};
use std::path::PathBuf;

const SEED: u64 = 5;
const SAMPLES: u64 = 10;

fn shards(plan: &Plan, seed: u64, count: u64) -> Vec<(PathBuf, TrialShard)> {
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let mc = MonteCarlo {
        plan,
        model: &model,
        fixture: &fixture,
        settings: &settings,
        uncertainty: Uncertainty::default(),
        supports: &[],
    };
    (0..count)
        .map(|index| {
            let s = Shard { index, count };
            let f = shard::run(&mc, SAMPLES, seed, s, &|| ()).unwrap();
            (PathBuf::from(s.dir_name()), f)
        })
        .collect()
}

#[test]
fn merged_shards_equal_the_unsplit_run_through_their_files() {
    let plan = Plan::table2();
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let mc = MonteCarlo {
        plan: &plan,
        model: &model,
        fixture: &fixture,
        settings: &settings,
        uncertainty: Uncertainty::default(),
        supports: &[],
    };
    let whole = mc.estimate(SAMPLES as usize, SEED, &|| ()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (name, f) in shards(&plan, SEED, 3).into_iter().rev() {
        let path = dir.path().join(format!("{}.json", name.display()));
        f.write(&path).unwrap();
        let back = shard::load(&path).unwrap();
        assert_eq!(back, f, "seed {SEED}: {} did not read back bit for bit", path.display());
        files.push((path, back));
    }
    let (key, merged) = merge(files).unwrap();
    assert_eq!((key.seed, key.samples), (SEED, SAMPLES));
    assert_eq!(merged, whole, "seed {SEED}: merged shards differ from the unsplit run");
}

#[test]
fn a_missing_duplicated_or_foreign_shard_is_refused_by_name() {
    let plan = Plan::table2();
    let three = shards(&plan, SEED, 3);
    let err = merge(three[..2].to_vec()).unwrap_err().to_string();
    assert!(err.contains("missing shards 2/3"), "{err}");
    let twice = vec![three[0].clone(), three[1].clone(), three[1].clone()];
    let err = merge(twice).unwrap_err().to_string();
    assert!(err.contains("given twice"), "{err}");
    let mut foreign = three.clone();
    foreign[2] = shards(&plan, SEED + 1, 3).swap_remove(2);
    let err = merge(foreign).unwrap_err().to_string();
    assert!(err.contains("belongs to another run"), "{err}");
    let mut mixed = three.clone();
    mixed.push(shards(&plan, SEED, 4).swap_remove(3));
    let err = merge(mixed).unwrap_err().to_string();
    assert!(err.contains("among shards of 3"), "{err}");
    let mut tampered = three;
    let moved = tampered[0].1.items.pop().unwrap();
    tampered[1].1.items.push(moved);
    let err = merge(tampered).unwrap_err().to_string();
    assert!(err.contains("does not belong to shard 1/3"), "{err}");
    assert!(merge(Vec::new()).is_err());
}

/// The CLI round trip a scheduler would run: `robustness run --shard I/N` per task, then
/// `robustness merge`; the merged per-trial CSV equals the unsplit run's byte for byte.
#[test]
fn cli_shards_merge_to_the_unsplit_runs_csv() {
    let bin = env!("CARGO_BIN_EXE_mesopush");
    let dir = tempfile::tempdir().unwrap();
    let plan = concat!(env!("CARGO_MANIFEST_DIR"), "/../../plans/table2.toml");
    let run = |extra: &[&str], out: &str| {
        let o = std::process::Command::new(bin)
            .args(["robustness", "run", plan, "--samples", "8", "--seed", "21", "--json", "--out"])
            .arg(dir.path().join(out))
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["--shard", "0/2"], "s0");
    run(&["--shard", "1/2"], "s1");
    run(&[], "whole");
    let o = std::process::Command::new(bin)
        .args(["robustness", "merge"])
        .args([dir.path().join("s0"), dir.path().join("s1")])
        .arg("--out")
        .arg(dir.path().join("merged"))
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["samples"], 8, "{v}");
    let read = |d: &str| std::fs::read(dir.path().join(d).join("trials_table2.csv")).unwrap();
    assert_eq!(read("merged"), read("whole"), "seed 21: merged CSV differs from the unsplit run");
}
