//! The batch journal, `journal.jsonl`: one JSON record per line, append-only, each record
//! fsynced before the engine moves on. It is the batch's memory across crashes: a trial is
//! done exactly when its `trial` record is in the journal. A line torn by a crash (the
//! process killed mid-write) is moved aside to `journal.torn-N` on open and cut off, so the
//! journal always ends on a whole record and nothing written is deleted.
//!
//! Records are numbered by position (0-based, whole records only; a torn tail is never a
//! record), which is how a `voided` record names the final record it sets aside.

use super::digest::DirChecksum;
use super::runner::TrialResult;
use crate::Error;
use mesopush_core::geom::Pose;
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The journal's file name inside a batch directory.
pub const JOURNAL: &str = "journal.jsonl";

/// One journal line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Record {
    /// An attempt is about to start writing into `dir`.
    Begin {
        /// Trial index.
        index: u64,
        /// Attempt number (1-based).
        attempt: u32,
        /// Trial directory, relative to the batch directory.
        dir: String,
    },
    /// A directory left by an interrupted run is set aside (renamed, never deleted) so its
    /// attempt can run again from scratch. Written (fsynced) *before* the rename: a kill
    /// between the two leaves the directory under its old name and this record, and the
    /// next run completes the rename to `renamed_to` without a second record.
    Discarded {
        /// Trial index.
        index: u64,
        /// Attempt the directory belonged to.
        attempt: u32,
        /// Where it is now, relative to the batch directory.
        renamed_to: String,
        /// What its `trial.json` said (`incomplete`, `done`, … or `unreadable`).
        found: String,
    },
    /// An attempt ended with a verdict the policy retries.
    Attempt(AttemptRecord),
    /// The trial's final record: exactly one per trial.
    Trial(AttemptRecord),
    /// A resume found the final record number `record` lost, damaged, duplicated or
    /// foreign and set it aside: it no longer counts, and a trial of this batch left
    /// without a good final record runs again.
    Voided {
        /// Position of the voided `trial` record in this journal (0-based).
        record: u64,
        /// Its trial index.
        index: u64,
        /// Its directory.
        dir: String,
        /// What was wrong.
        problem: Problem,
        /// Details (recorded and found checksums, the missing path, …).
        detail: String,
    },
}

/// What can be wrong with a final record (`batch report`, a resume; docs/batch.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Problem {
    /// Its trial directory is gone.
    Lost,
    /// Its trial directory no longer matches the recorded checksum (truncated, changed,
    /// unreadable).
    Damaged,
    /// Another good final record of the same trial came first.
    Duplicated,
    /// Not a trial of this batch directory: index outside the batch or its shard, or a
    /// trial id or seed that does not belong to the index.
    Foreign,
}

impl Problem {
    /// Lower-case name.
    pub fn as_str(self) -> &'static str {
        match self {
            Problem::Lost => "lost",
            Problem::Damaged => "damaged",
            Problem::Duplicated => "duplicated",
            Problem::Foreign => "foreign",
        }
    }
}

/// An ended attempt (final or retried).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AttemptRecord {
    /// Trial index.
    pub index: u64,
    /// `trial-000007`.
    pub trial_id: String,
    /// Attempt number (1-based).
    pub attempt: u32,
    /// Trial seed.
    pub trial_seed: u64,
    /// Attempt seed.
    pub attempt_seed: u64,
    /// Runner name.
    pub runner: String,
    /// Where the world put the peg.
    pub peg_start: Pose,
    /// Trial directory, relative to the batch directory (in a merged batch: relative to the
    /// merged directory).
    pub dir: String,
    /// What the runner (and the engine's checks) found.
    pub result: TrialResult,
    /// Wall-clock time of the attempt including its log checks, s.
    pub wall_time_s: f64,
    /// The checksum of `dir` when the record was written (absent in journals written
    /// before checksums: such records are counted `unverified`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checksum: Option<DirChecksum>,
}

/// An open journal.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
}

/// What opening found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Opened {
    /// The whole records, in order.
    pub records: Vec<Record>,
    /// Where a torn last line was saved, when there was one.
    pub torn_saved_to: Option<PathBuf>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

/// Parses journal text (whole lines only); errors name the line.
pub fn parse(path: &Path, text: &str) -> Result<Vec<Record>, Error> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let r = serde_json::from_str(line).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            message: format!("line {}: {e}", i + 1),
        })?;
        out.push(r);
    }
    Ok(out)
}

/// Reads a journal without opening it for writing (reports, merges).
pub fn read(path: &Path) -> Result<Vec<Record>, Error> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    let whole = text.rfind('\n').map_or("", |n| &text[..=n]);
    parse(path, whole)
}

fn save_torn(path: &Path, tail: &[u8]) -> Result<PathBuf, Error> {
    let mut k = 1;
    let saved = loop {
        let p = path.with_extension(format!("torn-{k}"));
        if !p.exists() {
            break p;
        }
        k += 1;
    };
    mesopush_core::fsx::write_synced(&saved, tail)?;
    Ok(saved)
}

impl Journal {
    /// Opens (creating) the journal at `path`, recovering from a torn last line.
    pub fn open(path: &Path) -> Result<(Self, Opened), Error> {
        let bytes = if path.exists() { std::fs::read(path).map_err(io(path))? } else { vec![] };
        let whole_len = bytes.iter().rposition(|b| *b == b'\n').map_or(0, |n| n + 1);
        let mut opened = Opened::default();
        if whole_len < bytes.len() {
            opened.torn_saved_to = Some(save_torn(path, &bytes[whole_len..])?);
            let f = OpenOptions::new().write(true).open(path).map_err(io(path))?;
            f.set_len(whole_len as u64).and_then(|()| f.sync_all()).map_err(io(path))?;
        }
        let text = std::str::from_utf8(&bytes[..whole_len]).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            message: format!("not UTF-8: {e}"),
        })?;
        opened.records = parse(path, text)?;
        let file = OpenOptions::new().create(true).append(true).open(path).map_err(io(path))?;
        if let Some(dir) = path.parent() {
            mesopush_core::fsx::sync_dir(dir)?;
        }
        Ok((Self { path: path.to_path_buf(), file }, opened))
    }

    /// Appends one record and fsyncs it.
    pub fn append(&mut self, record: &Record) -> Result<(), Error> {
        let mut line = serde_json::to_string(record).expect("records serialise");
        line.push('\n');
        self.file.write_all(line.as_bytes()).map_err(io(&self.path))?;
        self.file.sync_data().map_err(io(&self.path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn begin(index: u64) -> Record {
        Record::Begin { index, attempt: 1, dir: format!("trials/{index}") }
    }

    #[test]
    fn torn_tail_is_saved_aside_and_cut() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(JOURNAL);
        let (mut j, o) = Journal::open(&path).unwrap();
        assert!(o.records.is_empty());
        j.append(&begin(1)).unwrap();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"{\"type\":\"begin\",\"ind").unwrap();
        drop(f);
        let (mut j, o) = Journal::open(&path).unwrap();
        assert_eq!(o.records, vec![begin(1)]);
        let saved = o.torn_saved_to.unwrap();
        assert_eq!(std::fs::read(&saved).unwrap(), b"{\"type\":\"begin\",\"ind");
        j.append(&begin(2)).unwrap();
        assert_eq!(read(&path).unwrap(), vec![begin(1), begin(2)]);
    }

    #[test]
    fn a_corrupt_whole_line_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(JOURNAL);
        std::fs::write(
            &path,
            "{\"type\":\"begin\",\"index\":1,\"attempt\":1,\"dir\":\"x\"}\nnope\n",
        )
        .unwrap();
        let e = Journal::open(&path).unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
    }

    /// Caught: a batch run as shards and merged differed from the same batch in one process
    /// in the last bit of a final θ. `batch merge` parses the shards' journals and writes
    /// them again, and serde_json's default float parser may be one ulp off; with its
    /// `float_roundtrip` feature every value the journal holds reads back bit for bit.
    #[test]
    fn journal_floats_read_back_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let seed = 8;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut result =
            crate::supervise::engine_verdict(crate::TrialVerdict::Inserted, "x".into());
        let mut text = String::new();
        let mut records = Vec::new();
        for index in 0..5000 {
            let mut v = || {
                let scale = 10f64.powi(rng.random_range(-12..5));
                (rng.random::<f64>() - 0.5) * scale
            };
            let peg_start = Pose::new(v(), v(), v());
            result.final_pose = Some(Pose::new(v(), v(), v()));
            result.track_error_um_max = v();
            let r = Record::Trial(AttemptRecord {
                index,
                trial_id: format!("trial-{index:06}"),
                attempt: 1,
                trial_seed: index,
                attempt_seed: index,
                runner: "sim".into(),
                peg_start,
                dir: String::new(),
                result: result.clone(),
                wall_time_s: v(),
                checksum: None,
            });
            text.push_str(&serde_json::to_string(&r).unwrap());
            text.push('\n');
            records.push(r);
        }
        let back = parse(Path::new(JOURNAL), &text).unwrap();
        for (a, b) in records.iter().zip(&back) {
            assert_eq!(a, b, "seed {seed}: a float changed on the way through the journal");
        }
    }
}
