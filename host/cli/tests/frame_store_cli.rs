//! `mesopush track` reads a trial's frame store exactly as the PNG frames it was made from:
//! frames rendered by `mesopush render` (PNG files) are packed into a store by this test, and
//! tracking the store — given as a directory or as the file — gives the same pose.csv, digit
//! for digit, with the times the store's pages carry.

use mesopush_framestore::{PageMeta, StoreWriter};
use std::path::Path;
use std::process::Command;

fn mesopush(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).output().expect("mesopush runs")
}

fn track(frames: &str, bg: &str, out: &Path) -> Vec<csv::StringRecord> {
    let o =
        mesopush(&["track", frames, "--background", bg, "--out", out.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((summary["frames"].as_u64(), summary["with_time"].as_u64()), (Some(8), Some(8)));
    csv::Reader::from_path(out).unwrap().records().map(Result::unwrap).collect()
}

#[test]
fn track_gives_identical_poses_from_the_store_and_from_the_pngs() {
    let tmp = tempfile::tempdir().unwrap();
    let pngs = tmp.path().join("pngs");
    let p = pngs.to_str().unwrap();
    let o = mesopush(&["render", "--out", p, "--frames", "8", "--seed", "4"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let trial = tmp.path().join("trial");
    std::fs::create_dir(&trial).unwrap();
    let mut w = StoreWriter::create(&trial.join("frames.tif")).unwrap();
    let rows: Vec<csv::StringRecord> = csv::Reader::from_path(pngs.join("frames.csv"))
        .unwrap()
        .records()
        .map(Result::unwrap)
        .collect();
    for r in &rows {
        let img = image::open(pngs.join(&r[1])).unwrap().into_luma8();
        let meta =
            PageMeta { index: r[0].parse().unwrap(), t_capture_us: Some(r[2].parse().unwrap()) };
        w.push(meta, img.width(), img.height(), img.as_raw()).unwrap();
    }
    w.finish().unwrap();
    let bg = format!("{p}/bg.png");
    let from_pngs = track(p, &bg, &tmp.path().join("a.csv"));
    let from_dir = track(trial.to_str().unwrap(), &bg, &tmp.path().join("b.csv"));
    let from_file =
        track(trial.join("frames.tif").to_str().unwrap(), &bg, &tmp.path().join("c.csv"));
    assert_eq!(from_dir, from_file);
    assert_eq!(from_pngs.len(), 8);
    for (k, (a, b)) in from_pngs.iter().zip(&from_dir).enumerate() {
        assert_eq!(&a[0], format!("frame_{k:05}"));
        assert_eq!(&b[0], format!("frames.tif#{k}"));
        assert_eq!(
            a.iter().skip(1).collect::<Vec<_>>(),
            b.iter().skip(1).collect::<Vec<_>>(),
            "frame {k}"
        );
        assert!(!a[2].is_empty(), "frame {k} tracked");
    }
}
