//! Issue 22: shards on a real scheduler. A private single-node Slurm (`slurm/mod.rs`: munged,
//! slurmctld, slurmd, configured here) runs `batch run --shard`, `robustness run --shard` and
//! `identify shard` as job arrays (`sbatch --wait --array=0-2`, the scripts docs/batch.md
//! shows); their merges equal the one-process runs digit for digit. Ignored by default (needs
//! Debian's slurm-wlm and munge): `.ci/run`'s Slurm step installs them and runs
//! `cargo test -p mesopush-cli --test slurm_arrays -- --ignored`.

mod slurm;

use serde_json::Value;
use slurm::Cluster;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Tasks per array: divides none of the trial or candidate counts, more tasks than CPUs.
const TASKS: u32 = 3;
/// CPUs of the test node.
const CPUS: u32 = 2;
/// Longest wait for one array.
const LIMIT: Duration = Duration::from_secs(240);

/// Runs `mesopush args` in `cwd` and parses its `--json` output.
fn mesopush(cwd: &Path, args: &[&str]) -> Value {
    let bin = env!("CARGO_BIN_EXE_mesopush");
    let o = Command::new(bin).args(args).current_dir(cwd).output().expect("mesopush runs");
    let line = args.join(" ");
    assert!(o.status.success(), "mesopush {line}: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("mesopush {line}: not JSON: {e}"))
}

/// An array job script as docs/batch.md shows it: one `mesopush` line per task.
fn script(dir: &Path, name: &str, line: &str) -> PathBuf {
    let text = format!(
        "#!/bin/bash\n\
         #SBATCH --job-name=mesopush-{name}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --requeue\n\
         set -euo pipefail\n\
         export RAYON_NUM_THREADS=\"$SLURM_CPUS_PER_TASK\"\n\
         {line}\n",
        last = TASKS - 1
    );
    let path = dir.join(format!("{name}.sbatch"));
    fs::write(&path, text).unwrap();
    path
}

/// The `--json` outputs of array task `task` (`slurm-JOB_TASK.out` in `dir`), oldest job first.
fn task_outputs(dir: &Path, task: u32) -> Vec<Value> {
    let mut jobs: Vec<(u64, PathBuf)> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.strip_prefix("slurm-")?.to_string();
            let job = name.strip_suffix(&format!("_{task}.out"))?.parse().ok()?;
            Some((job, p))
        })
        .collect();
    jobs.sort();
    let parse = |p: &PathBuf| serde_json::from_slice(&fs::read(p).unwrap()).unwrap();
    jobs.iter().map(|(_, p)| parse(p)).collect()
}

/// The array of every task, `0-(TASKS-1)`.
fn all_tasks() -> String {
    format!("0-{}", TASKS - 1)
}

/// `value` without the top-level `keys`.
fn without(mut value: Value, keys: &[&str]) -> Value {
    if let Some(o) = value.as_object_mut() {
        for k in keys {
            o.remove(*k);
        }
    }
    value
}

/// Every file under `a` has a byte-identical twin under `b`, and the other way round.
fn assert_same_tree(what: &str, a: &Path, b: &Path) {
    let list = |root: &Path| {
        let mut files = Vec::new();
        let mut stack = vec![root.to_path_buf()];
        while let Some(d) = stack.pop() {
            for e in fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else {
                    files.push(p.strip_prefix(root).unwrap().to_path_buf());
                }
            }
        }
        files.sort();
        files
    };
    let (fa, fb) = (list(a), list(b));
    assert_eq!(fa, fb, "{what}: the two runs wrote different files");
    for f in &fa {
        let same = fs::read(a.join(f)).unwrap() == fs::read(b.join(f)).unwrap();
        assert!(same, "{what}: {} differs between one process and the Slurm array", f.display());
    }
}

/// The directories under `dir` whose names start with `prefix`, sorted (a shell glob).
fn glob(dir: &Path, prefix: &str) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect();
    v.sort();
    v
}

/// Where the test works: `slurm/` (the arrays' working directory) and `one/` (the
/// one-process runs), each with a copy of the plan, and the synthetic trials beside them.
struct Dirs {
    slurm: PathBuf,
    one: PathBuf,
    bin: PathBuf,
}

impl Dirs {
    fn new(root: &Path) -> Dirs {
        let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
        let (slurm, one) = (root.join("slurm"), root.join("one"));
        for d in [&slurm, &one] {
            fs::create_dir_all(d).unwrap();
            fs::copy(&plan, d.join("table2.toml")).unwrap();
        }
        let bin = Path::new(env!("CARGO_BIN_EXE_mesopush")).parent().unwrap().to_path_buf();
        Dirs { slurm, one, bin }
    }
}

fn timed(what: &str, f: impl FnOnce()) {
    let t0 = Instant::now();
    f();
    eprintln!("{what}: {:.1} s", t0.elapsed().as_secs_f64());
}

#[test]
#[ignore = "needs slurm-wlm and munge: .ci/run's Slurm step runs it with --ignored"]
fn slurm_job_arrays_merge_to_the_one_process_results() {
    let tmp = tempfile::tempdir().unwrap();
    let cluster = Cluster::start(&tmp.path().join("cluster"), CPUS);
    let d = Dirs::new(tmp.path());
    timed("batch array", || batch(&cluster, &d));
    timed("robustness array", || robustness(&cluster, &d));
    timed("identify array", || identify(&cluster, &d));
}

/// The batch (seed 11): 25 sim trials with camera faults, shards `runs/batch/shard-0I-of-03`.
fn batch(cluster: &Cluster, d: &Dirs) {
    let spec = "name = \"slurm\"\nseed = 11\ntrials = 25\nrunner = \"sim\"\n\
                out = \"runs/batch\"\nplans = [\"table2.toml\"]\n\
                [camera]\nframe_drop = 0.2\nframe_black = 0.2\n";
    for dir in [&d.slurm, &d.one] {
        fs::write(dir.join("batch.toml"), spec).unwrap();
    }
    let line = "mesopush batch run batch.toml --shard \"$SLURM_ARRAY_TASK_ID/3\" --json";
    let s = script(&d.slurm, "batch", line);
    cluster.run_array(&s, &all_tasks(), &d.slurm, &d.bin, LIMIT);
    // A task submitted again (requeued, or `sbatch --array=1`) resumes its finished shard:
    // nothing is re-run, and the merge below is unchanged.
    cluster.run_array(&s, "1", &d.slurm, &d.bin, LIMIT);
    let runs: Vec<Value> = task_outputs(&d.slurm, 1).iter().map(|v| v["session"].clone()).collect();
    assert_eq!(runs.len(), 2, "task 1's outputs: {runs:?}");
    assert_eq!((&runs[0]["ran"], &runs[1]["ran"]), (&8.into(), &0.into()), "{runs:?}");
    assert_eq!(runs[1]["resumed"], 8, "{runs:?}");
    let shards = glob(&d.slurm.join("runs/batch"), "shard-");
    assert_eq!(shards, ["shard-00-of-03", "shard-01-of-03", "shard-02-of-03"]);
    let mut args = vec!["batch", "merge", "--json", "--out", "runs/batch-all"];
    let inputs: Vec<String> = shards.iter().map(|s| format!("runs/batch/{s}")).collect();
    args.extend(inputs.iter().map(String::as_str));
    let merged = mesopush(&d.slurm, &args);
    let whole = mesopush(&d.one, &["batch", "run", "batch.toml", "--json"]);
    // Wall-clock figures, and what only one side has: this run's session and directory,
    // the merge's inputs and outcome.
    let wall = ["wall_time_s", "trials_per_s", "session", "dir", "inputs", "outcome"];
    assert_eq!(without(merged, &wall), without(whole, &wall), "seed 11: batch summaries differ");
    let report = |dir: &Path, b: &str| mesopush(dir, &["batch", "report", "--json", b]);
    let (a, b) = (report(&d.slurm, "runs/batch-all"), report(&d.one, "runs/batch"));
    let (a, b) = (without(a["summary"].clone(), &wall), without(b["summary"].clone(), &wall));
    assert_eq!(a, b, "seed 11: the reports' summaries differ");
    assert_same_trials(&d.one.join("runs/batch"), &d.slurm.join("runs/batch-all"));
}

/// Every row of the reports' trials.csv (wall time and directory aside) and every trial's
/// pose.csv are the same.
fn assert_same_trials(whole: &Path, merged: &Path) {
    let rows = |dir: &Path| {
        let mut r = csv::Reader::from_path(dir.join("report/trials.csv")).unwrap();
        let head = r.headers().unwrap().clone();
        let col = |name: &str| head.iter().position(|h| h == name).unwrap();
        let (wall, dir_col) = (col("wall_time_s"), col("dir"));
        r.records()
            .map(|rec| {
                let rec = rec.unwrap();
                let cells: Vec<&str> = (0..rec.len())
                    .filter(|&i| i != wall && i != dir_col)
                    .map(|i| &rec[i])
                    .collect();
                (cells.join(","), rec[dir_col].to_string())
            })
            .collect::<Vec<_>>()
    };
    let (a, b) = (rows(whole), rows(merged));
    assert_eq!(a.len(), 25, "trials.csv of the one-process batch");
    assert_eq!(a.len(), b.len(), "trials.csv row counts differ");
    for ((ra, da), (rb, db)) in a.iter().zip(&b) {
        assert_eq!(ra, rb, "trials.csv rows differ");
        let pose = |base: &Path, dir: &str| fs::read(base.join(dir).join("pose.csv")).unwrap();
        assert_eq!(pose(whole, da), pose(merged, db), "pose.csv of {da} differs");
    }
}

/// Monte Carlo robustness (seed 21): 100 samples of Table II's plan, shards `runs/rob/I`.
fn robustness(cluster: &Cluster, d: &Dirs) {
    let common = "--samples 100 --seed 21 --json";
    let line = format!(
        "mesopush robustness run table2.toml {common} --shard \"$SLURM_ARRAY_TASK_ID/3\" \\\n  \
         --out \"runs/rob/$SLURM_ARRAY_TASK_ID\""
    );
    let s = script(&d.slurm, "robustness", &line);
    cluster.run_array(&s, &all_tasks(), &d.slurm, &d.bin, LIMIT);
    let shards = glob(&d.slurm.join("runs/rob"), "");
    assert_eq!(shards, ["0", "1", "2"]);
    let mut args = vec!["robustness", "merge", "--out", "runs/rob-all", "--json"];
    let inputs: Vec<String> = shards.iter().map(|s| format!("runs/rob/{s}")).collect();
    args.extend(inputs.iter().map(String::as_str));
    let merged = mesopush(&d.slurm, &args);
    let mut args = vec!["robustness", "run", "table2.toml", "--out", "runs/rob-all"];
    args.extend(common.split(' '));
    let whole = mesopush(&d.one, &args);
    // What the row was read from (the plan file, the shard files' name) and the merge's
    // shard count differ; every number and the files must not.
    let source = ["plan", "shards"];
    assert_eq!(
        without(merged, &source),
        without(whole, &source),
        "seed 21: robustness estimates differ"
    );
    assert_same_tree("robustness", &d.one.join("runs/rob-all"), &d.slurm.join("runs/rob-all"));
}

/// The identification sweep and the joint fit after it (seed 4), on synthetic trials; shards
/// `sweeps/sweep-I.json`.
fn identify(cluster: &Cluster, d: &Dirs) {
    let trials = d.slurm.parent().unwrap().join("trials");
    mesopush(&d.slurm, &["identify", "synth", trials.to_str().unwrap(), "--seed", "4", "--json"]);
    let sweep = "../trials --mu-step 0.25 --supports 5 --seed 4";
    let line = format!(
        "mesopush identify shard \"$SLURM_ARRAY_TASK_ID/3\" {sweep} \\\n  \
         --sweep-out \"sweeps/sweep-$SLURM_ARRAY_TASK_ID.json\" --json"
    );
    let s = script(&d.slurm, "identify", &line);
    cluster.run_array(&s, &all_tasks(), &d.slurm, &d.bin, LIMIT);
    let shards = glob(&d.slurm.join("sweeps"), "sweep-");
    assert_eq!(shards, ["sweep-0.json", "sweep-1.json", "sweep-2.json"]);
    let fit = "--optimize --max-evals 40 --bootstrap 2 --bootstrap-evals 10 \
               --out ident/model.toml --consistent-out ident/supports.toml --json";
    let mut args = vec!["identify", "merge"];
    args.extend(sweep.split(' ').chain(fit.split_whitespace()));
    args.push("--sweep-from");
    let inputs: Vec<String> = shards.iter().map(|s| format!("sweeps/{s}")).collect();
    args.extend(inputs.iter().map(String::as_str));
    let merged = mesopush(&d.slurm, &args);
    let mut args = vec!["identify", "run"];
    args.extend(sweep.split(' ').chain(fit.split_whitespace()));
    let whole = mesopush(&d.one, &args);
    let wall = ["runtime_s"];
    assert_eq!(
        without(merged, &wall),
        without(whole, &wall),
        "seed 4: identification reports differ"
    );
    assert_same_tree("identify", &d.one.join("ident"), &d.slurm.join("ident"));
}
