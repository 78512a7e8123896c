//! `mesopush import zhou-mason`: imports a start folder of the shared real data (exit 0, the
//! JSON report, runs.csv, trials that load), refuses to overwrite and bad input (exit 2,
//! named).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/real-pushes/zhou-mason-2017")
        .join(rel)
}

fn import(dir: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["import", "zhou-mason"])
        .arg(dir)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("run mesopush")
}

#[test]
fn a_start_folder_imports_with_a_json_report_and_an_index() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("zm");
    let o = import(&data("tri/tri_0_0_90"), &out, &["--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 5);
    assert_eq!(runs[0]["trial_dir"], "tri__0_0_90__2017-05-23_20-25-09");
    assert_eq!(runs[0]["file_rows"], 365);
    assert_eq!(v["vision_latency_s"], 0.15);
    let index = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert_eq!(index.lines().count(), 6);
    for r in runs {
        let t = mesopush_trial::Trial::load(&out.join(r["trial_dir"].as_str().unwrap())).unwrap();
        assert_eq!(t.meta.source, "zhou-mason-2017");
    }
    // Text output, and a second import into the same folder is refused, not overwritten.
    let o = import(&data("tri/tri_0_0_90"), &out, &[]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("refusing to overwrite"), "{e}");
    let o = import(&data("tri/tri_0_0_90"), &tmp.path().join("text"), &[]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("imported 5 runs") && text.contains("tri "), "{text}");
}

#[test]
fn bad_input_exits_2_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let o = import(&tmp.path().join("missing"), &tmp.path().join("o"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not exist"));
    let o = import(tmp.path(), &tmp.path().join("o"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no run file (log*.txt)"));
    let o = import(&data("tri/tri_0_0_90"), &tmp.path().join("o"), &["--vision-latency-ms=-5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("vision latency"));
}
