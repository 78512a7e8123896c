//! Frame folders on disk: the PNG frames of a recording (sorted by name), their capture times
//! from a `frames.csv` beside them, and the `pose.csv` the tracker writes.
//!
//! `frames.csv` (optional): a header row, then one row per frame. The frame is identified by a
//! column `file`, `frame` or `stem` (a file name, with or without `.png`, matched on its stem)
//! or, failing those, `index` (matched against the number the file stem ends with, e.g.
//! `frame_00042` → 42). The time is read from `t_capture_us` (integer µs; an empty cell means
//! unknown). Other columns are ignored. Frames with no row get an empty time.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::Error;
use crate::assess::Measurement;

/// The PNG files in `dir` sorted by name, leaving out `exclude` (e.g. the background frame
/// when it sits in the same folder).
pub fn list_frames(dir: &Path, exclude: Option<&Path>) -> Result<Vec<PathBuf>, Error> {
    let excluded = exclude.and_then(|p| p.canonicalize().ok());
    let mut frames = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let path = entry.map_err(|e| Error::io(dir, e))?.path();
        let is_png = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png || !path.is_file() {
            continue;
        }
        if excluded.is_some() && path.canonicalize().ok() == excluded {
            continue;
        }
        frames.push(path);
    }
    frames.sort();
    if frames.is_empty() {
        return Err(Error::invalid("frames folder", format!("no PNG frames in {}", dir.display())));
    }
    Ok(frames)
}

/// The file stem of a frame path, as written in pose.csv's `frame` column.
pub fn frame_stem(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

/// The number a stem ends with (`frame_00042` → 42).
fn trailing_number(stem: &str) -> Option<u64> {
    let digits: String = stem.chars().rev().take_while(char::is_ascii_digit).collect();
    digits.chars().rev().collect::<String>().parse().ok()
}

/// Capture times of `frames` (µs) from `frames.csv` in their folder; all `None` when the file
/// does not exist. A malformed file is an error naming the row.
pub fn read_capture_times(dir: &Path, frames: &[PathBuf]) -> Result<Vec<Option<u64>>, Error> {
    let path = dir.join("frames.csv");
    if !path.exists() {
        return Ok(vec![None; frames.len()]);
    }
    let parse = |message: String| Error::Parse { path: path.clone(), message };
    let mut reader = csv::Reader::from_path(&path).map_err(|e| parse(e.to_string()))?;
    let headers = reader.headers().map_err(|e| parse(e.to_string()))?.clone();
    let col = |names: &[&str]| headers.iter().position(|h| names.contains(&h.trim()));
    let t_col = col(&["t_capture_us"]).ok_or_else(|| parse("no column t_capture_us".into()))?;
    let (key_col, by_name) = match (col(&["file", "frame", "stem"]), col(&["index"])) {
        (Some(c), _) => (c, true),
        (None, Some(c)) => (c, false),
        (None, None) => return Err(parse("needs a column file, frame, stem or index".into())),
    };
    let mut by_stem: HashMap<String, Option<u64>> = HashMap::new();
    let mut by_index: HashMap<u64, Option<u64>> = HashMap::new();
    for (row, record) in reader.records().enumerate() {
        let record = record.map_err(|e| parse(e.to_string()))?;
        let line = row + 2;
        let t_text = record.get(t_col).unwrap_or("").trim();
        let t = if t_text.is_empty() {
            None
        } else {
            Some(t_text.parse::<u64>().map_err(|_| {
                parse(format!("line {line}: t_capture_us {t_text:?} is not a whole number of µs"))
            })?)
        };
        let key = record.get(key_col).unwrap_or("").trim();
        if by_name {
            by_stem.insert(frame_stem(Path::new(key)), t);
        } else {
            let i = key
                .parse::<u64>()
                .map_err(|_| parse(format!("line {line}: index {key:?} is not a number")))?;
            by_index.insert(i, t);
        }
    }
    Ok(frames
        .iter()
        .map(|f| {
            let stem = frame_stem(f);
            if by_name {
                by_stem.get(&stem).copied().flatten()
            } else {
                trailing_number(&stem).and_then(|i| by_index.get(&i).copied().flatten())
            }
        })
        .collect())
}

/// The header of pose.csv.
pub const POSE_CSV_HEADER: [&str; 9] = [
    "frame",
    "t_us",
    "x_um",
    "y_um",
    "theta_rad",
    "probe_tip_x_um",
    "probe_tip_y_um",
    "confidence",
    "flag",
];

/// One pose.csv row (empty cells for what is unknown).
pub fn pose_csv_row(stem: &str, t_us: Option<i64>, m: &Measurement) -> [String; 9] {
    let f = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
    let pose = m.pose;
    let tip = m.probe_tip_um;
    [
        stem.to_string(),
        t_us.map_or(String::new(), |t| t.to_string()),
        f(pose.map(|p| p.x_um), 3),
        f(pose.map(|p| p.y_um), 3),
        f(pose.map(|p| p.theta_rad), 6),
        f(tip.map(|t| t.x), 3),
        f(tip.map(|t| t.y), 3),
        format!("{:.3}", m.confidence),
        m.flag_text(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(dir: &Path, name: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, b"").unwrap();
        p
    }

    #[test]
    fn times_by_index_and_by_file() {
        let dir = tempfile::tempdir().unwrap();
        let frames = vec![touch(dir.path(), "f_0001.png"), touch(dir.path(), "f_0002.png")];
        std::fs::write(dir.path().join("frames.csv"), "index,t_capture_us\n2,500\n1,\n").unwrap();
        assert_eq!(read_capture_times(dir.path(), &frames).unwrap(), vec![None, Some(500)]);
        std::fs::write(dir.path().join("frames.csv"), "file,t_capture_us,x\nf_0001.png,7,a\n")
            .unwrap();
        assert_eq!(read_capture_times(dir.path(), &frames).unwrap(), vec![Some(7), None]);
    }

    #[test]
    fn malformed_frames_csv_names_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let frames = vec![touch(dir.path(), "a.png")];
        std::fs::write(dir.path().join("frames.csv"), "index,t_capture_us\n0,soon\n").unwrap();
        let e = read_capture_times(dir.path(), &frames).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("soon"), "{e}");
        std::fs::write(dir.path().join("frames.csv"), "index\n0\n").unwrap();
        let e = read_capture_times(dir.path(), &frames).unwrap_err().to_string();
        assert!(e.contains("t_capture_us"), "{e}");
    }

    #[test]
    fn listing_sorts_and_skips_the_background() {
        let dir = tempfile::tempdir().unwrap();
        touch(dir.path(), "b.png");
        touch(dir.path(), "a.png");
        touch(dir.path(), "notes.txt");
        let bg = touch(dir.path(), "bg.png");
        let frames = list_frames(dir.path(), Some(&bg)).unwrap();
        let names: Vec<String> = frames.iter().map(|p| frame_stem(p)).collect();
        assert_eq!(names, ["a", "b"]);
        let empty = tempfile::tempdir().unwrap();
        assert!(list_frames(empty.path(), None).is_err());
    }
}
