//! `mesopush batch` data honesty from the outside, as separate processes: two `batch run`
//! on one `--out` (a Slurm requeue, a cron job firing twice) — the second refused at once
//! naming the holder, the first's result a clean run's; a SIGKILLed holder leaves no stale
//! lock; a deleted, truncated, duplicated or foreign final record counted by `batch report`
//! and by the resume (exit 1) until a resume has run the trials again (exit 0); `batch
//! merge` re-run after its journal was written, or before; bad numeric input exit 2.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const TRIALS: u64 = 120; // the batch size

fn mesopush(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).output().expect("mesopush runs")
}

fn write_batch(dir: &Path, trials: u64) -> PathBuf {
    let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
    let text = format!(
        "name = \"integrity\"\nseed = 19\ntrials = {trials}\nrunner = \"sim\"\nplans = [{plan:?}]\n\
         [camera]\nmax_frames = 2\nframe_drop = 0.2\nframe_black = 0.2\n"
    );
    let path = dir.join(format!("b{trials}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn spawn(batch: &Path, out: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["batch", "run", "--json", "--out"])
        .arg(out)
        .arg(batch)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mesopush runs")
}

fn run(batch: &Path, out: &Path) -> Output {
    mesopush(&["batch", "run", "--json", "--out", out.to_str().unwrap(), batch.to_str().unwrap()])
}

fn journal_lines(out: &Path) -> usize {
    std::fs::read(out.join("journal.jsonl"))
        .map_or(0, |b| b.iter().filter(|c| **c == b'\n').count())
}

fn wait_for_lines(out: &Path, k: usize) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while journal_lines(out) < k {
        assert!(Instant::now() < deadline, "the batch never wrote {k} journal lines");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Every final record line of the journal, wall times removed (they differ run to run).
fn final_records(out: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    text.lines()
        .filter(|l| l.contains("\"type\":\"trial\""))
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("wall_time_s");
            v.to_string()
        })
        .collect()
}

/// The final records that count (verified, not voided), wall times removed.
fn accepted_records(out: &Path) -> Vec<String> {
    let b = mesopush_batch::stats::Loaded::load(out).unwrap();
    b.finals()
        .values()
        .map(|a| {
            let r = mesopush_batch::journal::Record::Trial((*a).clone());
            let mut v = serde_json::to_value(r).unwrap();
            v.as_object_mut().unwrap().remove("wall_time_s");
            v.to_string()
        })
        .collect()
}

fn summary(o: &Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "{e}: {}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    })
}

#[test]
fn a_second_run_on_one_directory_is_refused_naming_the_holder_and_a_killed_one_holds_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let batch = write_batch(tmp.path(), TRIALS);
    let reference = tmp.path().join("reference");
    assert!(run(&batch, &reference).status.success());
    let clean = final_records(&reference);
    assert_eq!(clean.len() as u64, TRIALS);

    let out = tmp.path().join("twice");
    let mut first = spawn(&batch, &out);
    wait_for_lines(&out, 1); // the journal exists only under the lock
    let second = run(&batch, &out);
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first run ended before the second started: make the batch longer"
    );
    assert_eq!(second.status.code(), Some(2), "{err}");
    for needle in ["in use", &format!("pid {}", first.id()), "since", "batch run", "host"] {
        assert!(err.contains(needle), "{needle:?} not in: {err}");
    }
    assert!(first.wait().unwrap().success());
    assert_eq!(final_records(&out), clean, "the first run's result is a clean run's");

    // SIGKILL the holder mid-batch: the very next run is not refused (kernel flock).
    let killed = tmp.path().join("killed");
    let mut child = spawn(&batch, &killed);
    wait_for_lines(&killed, 20);
    child.kill().unwrap();
    child.wait().unwrap();
    let resumed = run(&batch, &killed);
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert_eq!(final_records(&killed), clean);
}

fn final_dir(out: &Path, index: u64) -> PathBuf {
    let line = final_line(out, index);
    let v: serde_json::Value = serde_json::from_str(&line).unwrap();
    out.join(v["dir"].as_str().unwrap())
}

fn final_line(out: &Path, index: u64) -> String {
    std::fs::read_to_string(out.join("journal.jsonl"))
        .unwrap()
        .lines()
        .find(|l| l.contains("\"type\":\"trial\"") && l.contains(&format!("\"index\":{index},")))
        .unwrap()
        .to_string()
}

fn append_line(out: &Path, line: &str) {
    let mut j = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    j.push_str(line);
    j.push('\n');
    std::fs::write(out.join("journal.jsonl"), j).unwrap();
}

fn report(out: &Path) -> Output {
    mesopush(&["batch", "report", "--json", out.to_str().unwrap()])
}

/// Damages a batch directory.
type Harm<'a> = &'a dyn Fn(&Path);

#[test]
fn lost_damaged_duplicated_and_foreign_records_exit_1_until_a_resume_reruns_them() {
    let tmp = tempfile::tempdir().unwrap();
    let batch = write_batch(tmp.path(), 4);
    let reference = tmp.path().join("reference");
    assert!(run(&batch, &reference).status.success());
    let harms: [(&str, Harm); 4] = [
        ("lost", &|out| std::fs::remove_dir_all(final_dir(out, 1)).unwrap()),
        ("damaged", &|out| {
            let pose = final_dir(out, 2).join("pose.csv");
            let text = std::fs::read(&pose).unwrap();
            std::fs::write(&pose, &text[..text.len() / 2]).unwrap();
        }),
        ("duplicates", &|out| append_line(out, &final_line(out, 3))),
        ("foreign", &|out| {
            append_line(out, &final_line(out, 0).replace("\"index\":0,", "\"index\":999,"));
        }),
    ];
    for (field, harm) in harms {
        let out = tmp.path().join(field);
        assert!(run(&batch, &out).status.success());
        harm(&out);
        let r = report(&out);
        assert_eq!(r.status.code(), Some(1), "{field}: report exits 1");
        let v = summary(&r);
        assert_eq!(v[field].as_u64(), Some(1), "{field}: {v}");
        assert_eq!(v["expected"].as_u64(), Some(4), "{field}");
        assert!(v["trials"].as_u64().unwrap() <= 4, "{field}: never more trials than the batch");
        assert_eq!(v["findings"].as_array().map(Vec::len), Some(1), "{field}: {v}");
        let text = mesopush(&["batch", "report", out.to_str().unwrap()]);
        let said = String::from_utf8_lossy(&text.stdout);
        let word = if field == "duplicates" { "duplicated 1" } else { &format!("1 {field}") };
        let word = if field == "foreign" { "foreign 1" } else { word };
        assert!(said.contains(word), "{field}: {word:?} not in {said}");
        let resume = run(&batch, &out);
        assert_eq!(resume.status.code(), Some(1), "{field}: the resume that found it exits 1");
        let v = summary(&resume);
        assert_eq!(v["session"]["found_on_resume"].as_array().map(Vec::len), Some(1), "{v}");
        assert_eq!(v["voided"].as_u64(), Some(1));
        assert_eq!((v[field].as_u64(), v["trials"].as_u64()), (Some(0), Some(4)), "{field}");
        assert!(run(&batch, &out).status.success(), "{field}: the next resume is clean");
        assert_eq!(report(&out).status.code(), Some(0), "{field}: and so is the report");
        assert_eq!(accepted_records(&out), final_records(&reference), "{field}: a clean run's");
    }
}

#[test]
fn merge_rerun_after_its_journal_was_written_or_before_completes_with_exit_0() {
    let tmp = tempfile::tempdir().unwrap();
    let batch = write_batch(tmp.path(), 4);
    let b = batch.to_str().unwrap();
    let sharded = tmp.path().join("sharded");
    for i in 0..2 {
        let shard = format!("{i}/2");
        let o =
            mesopush(&["batch", "run", b, "--shard", &shard, "--out", sharded.to_str().unwrap()]);
        assert!(o.status.success());
    }
    let merged = tmp.path().join("merged");
    let merge = || {
        mesopush(&[
            "batch",
            "merge",
            "--out",
            merged.to_str().unwrap(),
            sharded.join("shard-00-of-02").to_str().unwrap(),
            sharded.join("shard-01-of-02").to_str().unwrap(),
        ])
    };
    assert!(merge().status.success());
    let journal = std::fs::read(merged.join("journal.jsonl")).unwrap();
    let again = merge();
    let said = String::from_utf8_lossy(&again.stdout);
    assert_eq!(again.status.code(), Some(0), "{}", String::from_utf8_lossy(&again.stderr));
    assert!(said.contains("already complete"), "{said}");
    assert_eq!(std::fs::read(merged.join("journal.jsonl")).unwrap(), journal);
    std::fs::remove_file(merged.join("journal.jsonl")).unwrap(); // killed before its last write
    assert!(merge().status.success());
    assert_eq!(std::fs::read(merged.join("journal.jsonl")).unwrap(), journal);
    assert_eq!(report(&merged).status.code(), Some(0));
}

#[test]
fn zero_and_out_of_range_numbers_are_refused_with_exit_2_naming_them() {
    let tmp = tempfile::tempdir().unwrap();
    let batch = write_batch(tmp.path(), 4);
    let out = tmp.path().join("o");
    let o = mesopush(&[
        "batch",
        "run",
        batch.to_str().unwrap(),
        "--max-trials",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--max-trials") && err.contains('0'), "{err}");
    let zero = write_batch(tmp.path(), 0);
    let o = run(&zero, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("trials = 0") && err.contains("1..="), "{err}");
}
