//! Writing a trial crash-safely: `trial.json` goes down first (outcome `incomplete`) so a
//! directory is never anonymous; CSV rows are appended and flushed as they come (a crash
//! loses at most the rows still in the OS cache, never earlier ones); [`TrialWriter::finish`]
//! fsyncs every file and replaces `trial.json` atomically (write, fsync, rename, fsync dir)
//! with the final outcome. A directory whose `trial.json` still says `incomplete` is a trial
//! that did not finish.

use super::meta::{Outcome, TrialMeta};
use super::records::{EventRow, FrameRow, PoseRow, ProbeRow};
use super::{Trial, files};
use crate::Error;
use mesopush_core::fsx::write_atomic;
use mesopush_framestore::{PageMeta, STORE_FILE, StoreWriter, page_ref};
use serde::Serialize;
use std::fs::{self, File};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

fn io_err(path: &Path, cause: std::io::Error) -> Error {
    Error::Io { path: path.to_path_buf(), cause }
}

/// One CSV file being appended to.
#[derive(Debug)]
struct CsvFile {
    path: PathBuf,
    w: csv::Writer<BufWriter<File>>,
}

impl CsvFile {
    fn create(path: PathBuf) -> Result<Self, Error> {
        let f = File::create(&path).map_err(|e| io_err(&path, e))?;
        Ok(Self { w: csv::Writer::from_writer(BufWriter::new(f)), path })
    }

    fn write(&mut self, row: &impl Serialize) -> Result<(), Error> {
        self.w
            .serialize(row)
            .map_err(|e| Error::Parse { path: self.path.clone(), message: e.to_string() })
    }

    fn flush(&mut self) -> Result<(), Error> {
        self.w.flush().map_err(|e| io_err(&self.path, e))
    }

    fn sync(&mut self) -> Result<(), Error> {
        self.flush()?;
        self.w.get_ref().get_ref().sync_all().map_err(|e| io_err(&self.path, e))
    }
}

/// Writes one trial directory.
#[derive(Debug)]
pub struct TrialWriter {
    dir: PathBuf,
    meta: TrialMeta,
    probe: CsvFile,
    frames: CsvFile,
    events: CsvFile,
    pose: Option<CsvFile>,
    /// The frame store, created with the first frame image.
    store: Option<StoreWriter>,
    rows_since_flush: usize,
    /// Probe rows written, and whether they carry `cmd_theta_rad` (set by the first).
    probe_rows: u64,
    theta_column: Option<bool>,
}

/// Rows between flushes to the OS.
const FLUSH_EVERY: usize = 64;

impl TrialWriter {
    /// Creates `dir` (which must not hold a trial already) and writes the metadata (refused,
    /// naming the field, when it breaks [`TrialMeta::check`]).
    pub fn create(dir: &Path, meta: TrialMeta) -> Result<Self, Error> {
        meta.check()?;
        if dir.join(files::META).exists() {
            return Err(Error::invalid(
                "trial directory",
                format!("{} already holds a trial; refusing to overwrite it", dir.display()),
            ));
        }
        fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
        let w = Self {
            probe: CsvFile::create(dir.join(files::PROBE))?,
            frames: CsvFile::create(dir.join(files::FRAMES))?,
            events: CsvFile::create(dir.join(files::EVENTS))?,
            pose: None,
            store: None,
            dir: dir.to_path_buf(),
            meta,
            rows_since_flush: 0,
            probe_rows: 0,
            theta_column: None,
        };
        w.write_meta()?;
        Ok(w)
    }

    /// The trial directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The metadata as it will be written.
    pub fn meta_mut(&mut self) -> &mut TrialMeta {
        &mut self.meta
    }

    fn write_meta(&self) -> Result<(), Error> {
        let text = serde_json::to_string_pretty(&self.meta).expect("metadata serialises");
        Ok(write_atomic(&self.dir.join(files::META), text.as_bytes())?)
    }

    fn counted(&mut self) -> Result<(), Error> {
        self.rows_since_flush += 1;
        if self.rows_since_flush >= FLUSH_EVERY {
            self.flush()?;
        }
        Ok(())
    }

    /// Hands everything written so far to the OS.
    pub fn flush(&mut self) -> Result<(), Error> {
        self.rows_since_flush = 0;
        self.probe.flush()?;
        self.frames.flush()?;
        self.events.flush()?;
        self.pose.as_mut().map_or(Ok(()), CsvFile::flush)
    }

    /// Appends a probe row. `cmd_theta_rad` is all or nothing: the first row decides whether
    /// the column exists, and a later row that disagrees is refused (not written).
    pub fn probe(&mut self, row: &ProbeRow) -> Result<(), Error> {
        let has_theta = row.cmd_theta_rad.is_some();
        let column = *self.theta_column.get_or_insert(has_theta);
        if column != has_theta {
            return Err(Error::invalid(
                "probe.csv cmd_theta_rad",
                format!(
                    "row {}: cmd_theta_rad = {:?}, but the first row {} it; every row gives \
                     the angle or none does",
                    self.probe_rows + 1,
                    row.cmd_theta_rad,
                    if column { "gave" } else { "did not give" }
                ),
            ));
        }
        self.probe.write(row)?;
        self.probe_rows += 1;
        self.counted()
    }

    /// Appends a frame row.
    pub fn frame(&mut self, row: &FrameRow) -> Result<(), Error> {
        self.frames.write(row)?;
        self.counted()
    }

    /// Appends an 8-bit grey frame image (row-major pixels) to the trial's frame store
    /// (`frames.tif`, created with the first frame); returns `frames.csv`'s `file` cell for
    /// it, `frames.tif#PAGE`.
    pub fn frame_image(
        &mut self,
        meta: PageMeta,
        width_px: u32,
        height_px: u32,
        pixels: &[u8],
    ) -> Result<String, Error> {
        if self.store.is_none() {
            self.store = Some(StoreWriter::create(&self.dir.join(STORE_FILE))?);
        }
        let store = self.store.as_mut().expect("created above");
        Ok(page_ref(store.push(meta, width_px, height_px, pixels)?))
    }

    /// Appends an event (flushed at once: events are rare and matter most after a crash).
    pub fn event(&mut self, row: &EventRow) -> Result<(), Error> {
        self.events.write(row)?;
        self.flush()
    }

    /// Appends a tracked pose (pose.csv is created on the first one).
    pub fn pose(&mut self, row: &PoseRow) -> Result<(), Error> {
        if self.pose.is_none() {
            self.pose = Some(CsvFile::create(self.dir.join(files::POSE))?);
        }
        self.pose.as_mut().expect("just created").write(row)?;
        self.counted()
    }

    /// Syncs every file and writes the final metadata with `outcome`.
    pub fn finish(mut self, outcome: Outcome) -> Result<PathBuf, Error> {
        self.probe.sync()?;
        self.frames.sync()?;
        self.events.sync()?;
        if let Some(p) = self.pose.as_mut() {
            p.sync()?;
        }
        if let Some(store) = self.store.take() {
            store.finish()?;
        }
        self.meta.outcome = outcome;
        self.write_meta()?;
        Ok(self.dir)
    }
}

/// Writes `poses` as the trial's pose.csv (replacing any) atomically, e.g. after tracking a
/// recorded trial offline.
pub fn write_pose_csv(trial: &Trial, poses: &[PoseRow]) -> Result<(), Error> {
    let path = trial.dir.join(files::POSE);
    let mut w = csv::Writer::from_writer(Vec::new());
    for p in poses {
        w.serialize(p).map_err(|e| Error::Parse { path: path.clone(), message: e.to_string() })?;
    }
    let bytes =
        w.into_inner().map_err(|e| Error::Parse { path: path.clone(), message: e.to_string() })?;
    Ok(write_atomic(&path, &bytes)?)
}
