//! `mesopush diagnose confusion --json`: one JSON object a pandas user loads (the true
//! effects by the table's row labels, a row per batch with its verdict and held-out errors
//! before and after, the failures), the tables not printed. A clean control at tiny budgets
//! (the verdict itself is the confusion tests' business, not this one's).

use std::process::Command;

#[test]
fn confusion_json_is_one_object_with_a_row_per_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mesopush"))
        .args(["diagnose", "confusion", "--only", "none", "--seeds", "2", "--seed", "4"])
        .args(["--n-trials", "2", "--strokes", "1", "--nominal-evals", "10"])
        .args(["--effect-evals", "10", "--json", "--out"])
        .arg(tmp.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status.code());
    let stdout = String::from_utf8(out.stdout).unwrap();
    // The whole of stdout parses as one object: no table beside it.
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("stdout is one JSON object");
    assert_eq!(v["truths"], serde_json::json!(["clean"]));
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "{v}");
    for (row, seed) in rows.iter().zip([4, 5]) {
        assert_eq!(row["truth"], "clean");
        assert_eq!(row["seed"], seed);
        assert!(row["verdict"].is_string());
        for when in ["before", "after"] {
            for channel in ["xy_um2", "theta_rad2"] {
                let x = row[when][channel].as_f64().unwrap();
                assert!(x.is_finite() && x >= 0.0, "{when}.{channel} = {x}");
            }
        }
    }
    assert_eq!(v["failures"], serde_json::json!([]));
}
