//! `mesopush render` then `mesopush track` end to end: pose.csv agrees with truth.csv, the
//! JSON summary is machine-readable, overlays are written, and bad input gets a clear error.

use std::path::Path;
use std::process::Command;

fn mesopush(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).output().expect("mesopush runs")
}

fn read_csv(path: &Path) -> Vec<csv::StringRecord> {
    csv::Reader::from_path(path).unwrap().records().map(Result::unwrap).collect()
}

#[test]
fn tracked_sequence_matches_its_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let out = mesopush(&["render", "--out", d, "--frames", "6", "--seed", "9"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bg = format!("{d}/bg.png");
    let pose = format!("{d}/pose.csv");
    let overlay = format!("{d}/overlay");
    let out = mesopush(&[
        "track",
        d,
        "--background",
        &bg,
        "--out",
        &pose,
        "--json",
        "--overlay",
        &overlay,
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["frames"], 6);
    assert_eq!(summary["flagged"], 0);
    assert_eq!(summary["with_time"], 6);
    let header = csv::Reader::from_path(&pose).unwrap().headers().unwrap().clone();
    assert_eq!(
        header.iter().collect::<Vec<_>>(),
        [
            "frame",
            "t_us",
            "x_um",
            "y_um",
            "theta_rad",
            "probe_tip_x_um",
            "probe_tip_y_um",
            "confidence",
            "flag"
        ]
    );
    let got = read_csv(Path::new(&pose));
    let truth = read_csv(&dir.path().join("truth.csv"));
    assert_eq!(got.len(), truth.len());
    for (g, t) in got.iter().zip(&truth) {
        assert_eq!(&g[0], &t[0]);
        assert_eq!(&g[1], &t[1], "time from frames.csv");
        let f = |r: &csv::StringRecord, i: usize| r[i].parse::<f64>().unwrap();
        let err = ((f(g, 2) - f(t, 2)).powi(2) + (f(g, 3) - f(t, 3)).powi(2)).sqrt();
        assert!(err < 2.0, "frame {}: {err} µm", &g[0]);
        assert!((f(g, 4) - f(t, 4)).abs() < 0.005, "frame {}", &g[0]);
        let tip = ((f(g, 5) - f(t, 5)).powi(2) + (f(g, 6) - f(t, 6)).powi(2)).sqrt();
        assert!(tip < 15.0, "frame {}: tip off by {tip} µm", &g[0]);
        assert_eq!(&g[8], "");
    }
    assert!(Path::new(&overlay).join("frame_00000.png").exists());
}

#[test]
fn bad_input_gets_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let out = mesopush(&["track", d, "--background", "/nonexistent/bg.png", "--out", "/tmp/x.csv"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/bg.png"));
    let out = mesopush(&["render", "--out", d, "--frames", "1"]);
    assert!(out.status.success());
    let bg = format!("{d}/bg.png");
    let out = mesopush(&[
        "track",
        d,
        "--background",
        &bg,
        "--out",
        &format!("{d}/p.csv"),
        "--field-um",
        "3370",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--field-um"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
