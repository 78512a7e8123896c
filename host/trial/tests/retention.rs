//! Frame retention keeps what it says: for each mode, the frame images left in the store (or,
//! in an older trial, as PNG files), the `file` cells of frames.csv, and the counts recorded in
//! trial.json; kept frames are bit-identical with their originals and keep their times.

use mesopush_framestore::{FrameStore, PageMeta};
use mesopush_sim::Part;
use mesopush_trial::{
    FrameRetention, FrameRow, Outcome, Trial, TrialMeta, TrialState, TrialWriter,
};
use std::path::Path;

const FRAMES: u64 = 10;

/// Frame `k`'s pixels: an independent pattern (not the renderer), different per frame.
fn pixels(k: u64) -> Vec<u8> {
    (0..48u64).map(|i| ((i * 37 + k * 101) % 251) as u8).collect()
}

fn row(index: u64, file: Option<String>) -> FrameRow {
    FrameRow {
        index,
        frame_seq: index as u32,
        t_capture_us: Some(33_333 * index as i64),
        t_arrival_us: Some(33_333 * index as i64 + 900),
        stamp_source: "driver".into(),
        dropped: file.is_none(),
        black: false,
        probe_x_um: Some(1.0),
        probe_y_um: Some(2.0),
        file,
    }
}

/// A finished trial of FRAMES stored frames plus one dropped row (index 3, no image).
fn trial(dir: &Path) {
    let meta = TrialMeta::new("t", "test", Part::default_peg());
    let mut w = TrialWriter::create(dir, meta).unwrap();
    for index in 0..=FRAMES {
        let file = (index != 3).then(|| {
            let page = PageMeta { index, t_capture_us: Some(33_333 * index as i64) };
            w.frame_image(page, 8, 6, &pixels(index)).unwrap()
        });
        w.frame(&row(index, file)).unwrap();
    }
    w.finish(Outcome { state: TrialState::Done, reason: None, inserted: Some(true) }).unwrap();
}

/// The row indices whose image the trial still has, checked against the store's pages.
fn kept_rows(dir: &Path) -> Vec<u64> {
    let t = Trial::load(dir).unwrap();
    let with_file: Vec<&FrameRow> = t.frames.iter().filter(|f| f.file.is_some()).collect();
    assert_eq!(t.frames.len() as u64, FRAMES + 1, "every row stays");
    if with_file.is_empty() {
        assert!(!dir.join("frames.tif").exists(), "no image kept, no store left");
        return Vec::new();
    }
    let mut store = FrameStore::open(&dir.join("frames.tif")).unwrap();
    assert_eq!(store.len(), with_file.len());
    for (page, f) in with_file.iter().enumerate() {
        assert_eq!(f.file.as_deref(), Some(format!("frames.tif#{page}").as_str()));
        let frame = store.read(page).unwrap();
        assert_eq!(frame.meta, PageMeta { index: f.index, t_capture_us: f.t_capture_us });
        assert!(frame.pixels == pixels(f.index), "row {} pixels", f.index);
    }
    with_file.iter().map(|f| f.index).collect()
}

fn applied(mode: &str, success: bool) -> (Vec<u64>, (u64, u64)) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("t");
    trial(&dir);
    let r: FrameRetention = mode.parse().unwrap();
    let rec = mesopush_trial::retention::apply(&dir, r, success).unwrap();
    let meta = Trial::load(&dir).unwrap().meta;
    assert_eq!(meta.frames_kept.as_ref(), Some(&rec), "recorded in trial.json");
    assert_eq!(rec.retention, mode);
    (kept_rows(&dir), (rec.stored, rec.kept))
}

#[test]
fn each_retention_mode_keeps_what_it_says_and_records_the_counts() {
    let all: Vec<u64> = (0..=FRAMES).filter(|&i| i != 3).collect();
    assert_eq!(applied("all", true), (all.clone(), (10, 10)));
    assert_eq!(applied("failed", false), (all.clone(), (10, 10)));
    assert_eq!(applied("failed", true), (vec![], (10, 0)));
    assert_eq!(applied("none", false), (vec![], (10, 0)));
    assert_eq!(applied("every 1", true), (all, (10, 10)));
    // every 3rd stored frame, counted over stored frames (row 3 has none): rows 0, 4, 7, 10
    assert_eq!(applied("every 3", true), (vec![0, 4, 7, 10], (10, 4)));
    assert_eq!(applied("every 20", false), (vec![0], (10, 1)));
}

#[test]
fn an_older_trial_of_png_frames_loses_the_files_that_go() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let meta = TrialMeta::new("old", "test", Part::default_peg());
    let mut w = TrialWriter::create(dir, meta).unwrap();
    std::fs::create_dir(dir.join("frames")).unwrap();
    for index in 0..4 {
        let name = format!("frames/{index:06}.png");
        std::fs::write(dir.join(&name), b"png bytes").unwrap();
        w.frame(&row(index, Some(name))).unwrap();
    }
    w.finish(Outcome { state: TrialState::Done, reason: None, inserted: Some(false) }).unwrap();
    let rec = mesopush_trial::retention::apply(dir, FrameRetention::Every(2), false).unwrap();
    assert_eq!((rec.stored, rec.kept), (4, 2));
    let left: Vec<bool> = (0..4).map(|i| dir.join(format!("frames/{i:06}.png")).exists()).collect();
    assert_eq!(left, [true, false, true, false]);
    let files: Vec<Option<String>> =
        Trial::load(dir).unwrap().frames.into_iter().map(|f| f.file).collect();
    assert_eq!(files[1], None);
    assert_eq!(files[2].as_deref(), Some("frames/000002.png"));
}

#[test]
fn a_bad_setting_names_the_field_the_value_and_the_allowed_forms() {
    for bad in ["every 0", "every", "every -2", "sometimes", "every 2.5", ""] {
        let err = bad.parse::<FrameRetention>().unwrap_err().to_string();
        assert!(err.contains("frames") && err.contains(&format!("{bad:?}")), "{err}");
        assert!(err.contains("all, failed, every N"), "{err}");
    }
    assert_eq!(" every  7 ".parse::<FrameRetention>().unwrap(), FrameRetention::Every(7));
    assert_eq!(FrameRetention::Every(7).to_string(), "every 7");
}
