//! Frame retention: which frame images a trial keeps once it is over, `frames = all |
//! failed | every N | none` (`mesopush demo`, `run`, `batch`). Poses are tracked while the
//! trial runs (`demo`, `batch`) or from the full recording before retention applies (`run`),
//! so pose.csv, frames.csv (every row, with its times) and the verdict are complete whatever
//! is kept; only images go. What was kept is recorded in `trial.json` (`frames_kept`), and
//! `frames.csv`'s `file` cell of a frame whose image went is emptied, so nothing is
//! miscounted: a reader sees `stored` and `kept`, and which rows have an image.

use super::files;
use super::records::FrameRow;
use crate::Error;
use mesopush_core::fsx::write_atomic;
use mesopush_framestore::{FrameStore, STORE_FILE, StoreWriter, page_ref, parse_page_ref};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Which frame images a trial keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum FrameRetention {
    /// Every frame (the default).
    #[default]
    All,
    /// Every frame of a trial whose verdict is not success (done and inserted); none of a
    /// successful one.
    Failed,
    /// The first stored frame and every Nth stored frame after it (N ≥ 1; `every 1` is all).
    Every(u32),
    /// No frame.
    None,
}

const ALLOWED: &str = "allowed: all, failed, every N (N a whole number ≥ 1), none";

impl std::str::FromStr for FrameRetention {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self, Error> {
        let t = text.trim();
        let bad = || Error::invalid("frames", format!("frames = {text:?}: {ALLOWED}"));
        Ok(match t {
            "all" => Self::All,
            "failed" => Self::Failed,
            "none" => Self::None,
            _ => {
                let n = t.strip_prefix("every").ok_or_else(bad)?.trim();
                match n.parse::<u32>() {
                    Ok(n) if n >= 1 => Self::Every(n),
                    _ => return Err(bad()),
                }
            }
        })
    }
}

impl std::fmt::Display for FrameRetention {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::All => f.write_str("all"),
            Self::Failed => f.write_str("failed"),
            Self::Every(n) => write!(f, "every {n}"),
            Self::None => f.write_str("none"),
        }
    }
}

impl TryFrom<String> for FrameRetention {
    type Error = Error;
    fn try_from(s: String) -> Result<Self, Error> {
        s.parse()
    }
}

impl From<FrameRetention> for String {
    fn from(r: FrameRetention) -> String {
        r.to_string()
    }
}

/// `trial.json`'s `frames_kept`: the setting applied and its effect.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FramesKept {
    /// The retention setting, as written (`all`, `failed`, `every N`, `none`).
    pub retention: String,
    /// Frame images the trial stored.
    pub stored: u64,
    /// Frame images kept.
    pub kept: u64,
}

impl FrameRetention {
    /// Whether the `k`-th stored frame (0-based, in frames.csv order) is kept by a trial whose
    /// verdict was `success`.
    pub fn keeps(self, k: u64, success: bool) -> bool {
        match self {
            Self::All => true,
            Self::Failed => !success,
            Self::Every(n) => k.is_multiple_of(u64::from(n)),
            Self::None => false,
        }
    }
}

/// Applies `retention` to the finished trial in `dir` (verdict `success`): rewrites the frame
/// store with the kept frames only (or removes it; PNG frames of older trials are deleted
/// one by one), empties the `file` cells of the frames that went, and records
/// [`FramesKept`] in `trial.json`.
pub fn apply(dir: &Path, retention: FrameRetention, success: bool) -> Result<FramesKept, Error> {
    let csv_path = dir.join(files::FRAMES);
    let mut rows = read_frames(&csv_path)?;
    let stored = rows.iter().filter(|r| r.file.is_some()).count() as u64;
    let keep: Vec<bool> = (0..stored).map(|k| retention.keeps(k, success)).collect();
    let kept = keep.iter().filter(|&&k| k).count() as u64;
    if kept < stored {
        thin(dir, &mut rows, &keep)?;
        write_atomic(&csv_path, &frames_csv(&csv_path, &rows)?)?;
    }
    let record = FramesKept { retention: retention.to_string(), stored, kept };
    let meta_path = dir.join(files::META);
    let text = std::fs::read_to_string(&meta_path)
        .map_err(|e| Error::Io { path: meta_path.clone(), cause: e })?;
    let bad =
        |e: serde_json::Error| Error::Parse { path: meta_path.clone(), message: e.to_string() };
    let mut meta: super::TrialMeta = serde_json::from_str(&text).map_err(bad)?;
    meta.frames_kept = Some(record.clone());
    let text = serde_json::to_string_pretty(&meta).map_err(bad)?;
    write_atomic(&meta_path, text.as_bytes())?;
    Ok(record)
}

/// Drops the images `keep` says go (indexed over stored frames in row order) and rewrites
/// the rows' `file` cells.
fn thin(dir: &Path, rows: &mut [FrameRow], keep: &[bool]) -> Result<(), Error> {
    let store_path = dir.join(STORE_FILE);
    let tmp = dir.join(format!("{STORE_FILE}.thinning"));
    let mut old = store_path.is_file().then(|| FrameStore::open(&store_path)).transpose()?;
    let _ = std::fs::remove_file(&tmp); // a leftover of an interrupted earlier attempt
    let mut new: Option<StoreWriter> = None;
    let stored = rows.iter_mut().filter(|r| r.file.is_some());
    for (row, &k) in stored.zip(keep) {
        let file = row.file.take().expect("filtered");
        match (parse_page_ref(&file), old.as_mut()) {
            (Some(page), Some(store)) if k => {
                let f = store.read(usize::try_from(page).unwrap_or(usize::MAX))?;
                let w = match new.as_mut() {
                    Some(w) => w,
                    None => new.insert(StoreWriter::create(&tmp)?),
                };
                row.file = Some(page_ref(w.push(f.meta, f.width, f.height, &f.pixels)?));
            }
            (Some(_), _) => {}
            (None, _) if k => row.file = Some(file),
            (None, _) => {
                let png = dir.join(&file);
                std::fs::remove_file(&png).map_err(|e| Error::Io { path: png, cause: e })?;
            }
        }
    }
    if let Some(w) = new {
        w.finish()?;
        std::fs::rename(&tmp, &store_path).map_err(|e| Error::Io { path: store_path, cause: e })?;
    } else if old.take().is_some() {
        std::fs::remove_file(&store_path).map_err(|e| Error::Io { path: store_path, cause: e })?;
    }
    Ok(())
}

fn read_frames(path: &Path) -> Result<Vec<FrameRow>, Error> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let parse = |m: String| Error::Parse { path: path.to_path_buf(), message: m };
    let mut r = csv::Reader::from_path(path).map_err(|e| parse(e.to_string()))?;
    r.deserialize().map(|row| row.map_err(|e| parse(e.to_string()))).collect()
}

fn frames_csv(path: &Path, rows: &[FrameRow]) -> Result<Vec<u8>, Error> {
    let parse = |m: String| Error::Parse { path: path.to_path_buf(), message: m };
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| parse(e.to_string()))?;
    }
    w.into_inner().map_err(|e| parse(e.to_string()))
}
