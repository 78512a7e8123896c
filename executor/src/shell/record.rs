//! The executor's recorder thread: the raw frame part of a trial log.
//!
//! Fed the shell's log records (never blocking the loop: the shell `try_send`s) and the
//! camera thread's images (bounded queue, drops counted there), it writes one directory per
//! trial, `RECORD_DIR/trial-<plan_id as 8 hex digits>-<t0 exec µs>/`, from the trial's
//! `Started` event until `tail_us` after its end (frames of the peg at rest):
//!
//! - `frames.csv`, `frames.tif` (the frame store, `mesopush_framestore`: one page per frame,
//!   `frames.csv`'s `file` = `frames.tif#PAGE`), `events.csv` — exactly the trial-log format
//!   (`docs/trial-log.md`): times in µs since the trial's start, the probe at exposure in
//!   the fixture frame (stage µm − the fixture origin given to the executor);
//! - `recording.json` — written atomically when the directory is closed: which trial, the
//!   executor clock's epoch on `CLOCK_MONOTONIC`, counts, how it ended.
//!
//! The host (`mesopush run`) completes the directory into a trial log (trial.json, probe.csv,
//! pose.csv) once `recording.json` exists. Log records outside a trial are printed to stdout.

use super::camera_source::FrameImage;
use super::fsx::write_atomic;
use crate::LogEvent;
use crate::camera::{SeqCheck, StampSource, StampedFrame};
use crate::clock::{Clock, MonotonicClock};
use crate::recording::{
    EventRow, FrameRow, RECORDING_FORMAT, RECORDING_FORMAT_VERSION, Recording, files,
};
use crossbeam_channel::{Receiver, select};
use mesopush_framestore::{PageMeta, STORE_FILE, StoreWriter, page_ref};
use mesopush_protocol::host::{TrialEvent, TrialEventKind};
use mesopush_protocol::units::nm_to_um;
use std::collections::VecDeque;
use std::fs::{self, File};
use std::io;
use std::path::PathBuf;
use std::string::{String, ToString};
use std::sync::Arc;
use std::time::Duration;
use std::{format, println};

/// Images kept while their stamped frame is on its way through the loop.
const PENDING_IMAGES: usize = 16;

/// Where and how to record.
#[derive(Debug, Clone)]
pub struct RecordConfig {
    /// Directory holding one sub-directory per trial.
    pub root: PathBuf,
    /// The fixture frame's origin in stage coordinates, µm.
    pub fixture_origin_um: (f64, f64),
    /// Frames kept after the trial's end, µs.
    pub tail_us: u64,
}

/// The directory a trial is recorded into (the host finds it from the `Started` event).
pub fn trial_dir_name(plan_id: u32, t0_exec_us: u64) -> String {
    format!("trial-{plan_id:08x}-{t0_exec_us}")
}

struct TrialRec {
    dir: PathBuf,
    t0_us: u64,
    plan_id: u32,
    frames: csv::Writer<File>,
    events: csv::Writer<File>,
    /// The frame store, created with the first image.
    store: Option<StoreWriter>,
    index: u64,
    recorded: u64,
    gap_dropped: u64,
    images_missing: u64,
    end: Option<(u64, TrialEventKind)>,
}

/// The recorder's state.
#[derive(Debug)]
pub struct ExecRecorder {
    config: Option<RecordConfig>,
    clock: Arc<MonotonicClock>,
    pending: VecDeque<FrameImage>,
    trial: Option<TrialRec>,
}

impl core::fmt::Debug for TrialRec {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TrialRec").field("dir", &self.dir).finish_non_exhaustive()
    }
}

impl ExecRecorder {
    /// A recorder writing under `config` (or only printing records when `None`).
    pub fn new(config: Option<RecordConfig>, clock: Arc<MonotonicClock>) -> Self {
        Self { config, clock, pending: VecDeque::new(), trial: None }
    }

    /// Runs until both channels close; closes an open trial directory at the end.
    pub fn run(mut self, log: Receiver<LogEvent>, images: Receiver<FrameImage>) -> io::Result<()> {
        let (mut log_open, mut img_open) = (true, true);
        while log_open || img_open {
            let log_rx = if log_open { log.clone() } else { crossbeam_channel::never() };
            let img_rx = if img_open { images.clone() } else { crossbeam_channel::never() };
            select! {
                recv(log_rx) -> e => match e {
                    Ok(e) => self.on_log(e)?,
                    Err(_) => log_open = false,
                },
                recv(img_rx) -> i => match i {
                    Ok(i) => self.on_image(i),
                    Err(_) => img_open = false,
                },
                default(Duration::from_millis(100)) => {}
            }
            self.close_after_tail()?;
        }
        self.close(false)
    }

    fn on_image(&mut self, image: FrameImage) {
        if self.pending.len() >= PENDING_IMAGES {
            self.pending.pop_front();
        }
        self.pending.push_back(image);
    }

    fn close_after_tail(&mut self) -> io::Result<()> {
        let tail = self.config.as_ref().map_or(0, |c| c.tail_us);
        let due = self
            .trial
            .as_ref()
            .and_then(|t| t.end)
            .is_some_and(|(t, _)| self.clock.now_us() > t.saturating_add(tail));
        if due { self.close(true) } else { Ok(()) }
    }

    fn on_log(&mut self, e: LogEvent) -> io::Result<()> {
        match e {
            LogEvent::Trial(t) if t.kind == TrialEventKind::Started => self.open(&t),
            LogEvent::Trial(t) => {
                println!("{e}");
                let (kind, detail) = match t.kind {
                    TrialEventKind::Done => ("done", format!("step {}", t.step_index)),
                    TrialEventKind::Aborted => ("aborted", format!("step {}", t.step_index)),
                    TrialEventKind::Faulted(f) => ("fault", format!("step {}: {f}", t.step_index)),
                    TrialEventKind::Started => unreachable!("matched above"),
                };
                if let Some(rec) = self.trial.as_mut() {
                    rec.end = Some((t.exec_time_us, t.kind));
                }
                self.event(t.exec_time_us, kind, &detail)
            }
            LogEvent::Frame(f) => self.on_frame(&f),
            other => {
                println!("{other}");
                let now = self.clock.now_us();
                self.event(now, "executor", &other.to_string())
            }
        }
    }

    fn open(&mut self, t: &TrialEvent) -> io::Result<()> {
        println!("{}", LogEvent::Trial(*t));
        self.close(false)?;
        let Some(c) = &self.config else { return Ok(()) };
        let dir = c.root.join(trial_dir_name(t.plan_id, t.exec_time_us));
        fs::create_dir_all(&dir)?;
        let create = |name: &str| -> io::Result<csv::Writer<File>> {
            Ok(csv::Writer::from_writer(File::create(dir.join(name))?))
        };
        let frames = create(files::FRAMES)?;
        let events = create(files::EVENTS)?;
        self.trial = Some(TrialRec {
            dir,
            t0_us: t.exec_time_us,
            plan_id: t.plan_id,
            frames,
            events,
            store: None,
            index: 0,
            recorded: 0,
            gap_dropped: 0,
            images_missing: 0,
            end: None,
        });
        self.event(t.exec_time_us, "started", &format!("plan {}", t.plan_id))
    }

    fn event(&mut self, t_us: u64, kind: &str, detail: &str) -> io::Result<()> {
        let Some(rec) = self.trial.as_mut() else { return Ok(()) };
        let t_us = t_us as i64 - rec.t0_us as i64;
        let row = EventRow { t_us, kind: kind.to_string(), detail: detail.to_string() };
        rec.events.serialize(row).map_err(io::Error::other)?;
        rec.events.flush()
    }

    fn on_frame(&mut self, f: &StampedFrame) -> io::Result<()> {
        let Some(origin) = self.config.as_ref().map(|c| c.fixture_origin_um) else {
            return Ok(());
        };
        let pos = self.pending.iter().position(|i| i.frame_seq == f.stamp.frame_seq);
        let image = pos.and_then(|i| self.pending.remove(i));
        let Some(rec) = self.trial.as_mut() else { return Ok(()) };
        if let SeqCheck::Gap { dropped } = f.seq {
            for i in 0..dropped {
                let seq = f.stamp.frame_seq.wrapping_sub(dropped - i);
                rec.frames
                    .serialize(FrameRow::dropped(rec.index, seq))
                    .map_err(io::Error::other)?;
                rec.index += 1;
            }
            rec.gap_dropped += u64::from(dropped);
        }
        let index = rec.index;
        rec.index += 1;
        let rel = |t: u64| t as i64 - rec.t0_us as i64;
        let t_capture_us = rel(f.stamp.frame_stamp_us);
        let file = match &image {
            Some(img) if !f.black => Some(store_frame(rec, index, t_capture_us, img)?),
            _ => None,
        };
        let missing = image.is_none();
        rec.images_missing += u64::from(missing);
        rec.recorded += 1;
        let rel = |t: u64| t as i64 - rec.t0_us as i64;
        let source = match f.source {
            StampSource::Driver => "driver",
            StampSource::Arrival => "arrival",
        };
        let row = FrameRow {
            index,
            frame_seq: f.stamp.frame_seq,
            t_capture_us: Some(t_capture_us),
            t_arrival_us: image.as_ref().map(|i| rel(i.arrival_us)),
            stamp_source: source.to_string(),
            dropped: missing && !f.black,
            black: f.black,
            probe_x_um: Some(nm_to_um(f.stamp.probe_x_nm) - origin.0),
            probe_y_um: Some(nm_to_um(f.stamp.probe_y_nm) - origin.1),
            file,
        };
        rec.frames.serialize(row).map_err(io::Error::other)?;
        if index % 32 == 0 {
            rec.frames.flush()?;
        }
        Ok(())
    }

    /// Closes the open trial directory: syncs the CSVs, writes `recording.json`.
    fn close(&mut self, complete: bool) -> io::Result<()> {
        let Some(mut rec) = self.trial.take() else { return Ok(()) };
        for w in [&mut rec.frames, &mut rec.events] {
            w.flush()?;
            w.get_ref().sync_all()?;
        }
        if let Some(store) = rec.store.take() {
            store.finish().map_err(io::Error::other)?;
        }
        let (end_kind, end_reason, end_t_us) = match rec.end {
            Some((t, k)) => {
                let (kind, reason) = end_words(k);
                (kind.to_string(), reason, Some(t as i64 - rec.t0_us as i64))
            }
            None => ("none".to_string(), None, None),
        };
        let recording = Recording {
            format: RECORDING_FORMAT.to_string(),
            format_version: RECORDING_FORMAT_VERSION,
            plan_id: rec.plan_id,
            t0_exec_us: rec.t0_us,
            exec_epoch_mono_us: self.clock.epoch_mono_us(),
            end: end_kind,
            end_reason,
            end_t_us,
            complete,
            frames: rec.recorded,
            dropped_frames: rec.gap_dropped,
            images_missing: rec.images_missing,
        };
        let text = serde_json::to_string_pretty(&recording).map_err(io::Error::other)?;
        write_atomic(&rec.dir.join(files::RECORDING_JSON), text.as_bytes())?;
        println!("recorded {} ({} frames)", rec.dir.display(), rec.recorded);
        Ok(())
    }
}

/// Appends the image to the trial's frame store (created with the first image); returns
/// `frames.csv`'s `file` cell.
fn store_frame(
    rec: &mut TrialRec,
    index: u64,
    t_capture_us: i64,
    img: &FrameImage,
) -> io::Result<String> {
    if rec.store.is_none() {
        let store = StoreWriter::create(&rec.dir.join(STORE_FILE)).map_err(io::Error::other)?;
        rec.store = Some(store);
    }
    let store = rec.store.as_mut().expect("created above");
    let meta = PageMeta { index, t_capture_us: Some(t_capture_us) };
    let page =
        store.push(meta, img.width_px, img.height_px, &img.pixels).map_err(io::Error::other)?;
    Ok(page_ref(page))
}

/// `recording.json`'s `end` (a key: `done`, `aborted`, `faulted`) and, for a fault, what
/// happened in words (the protocol's operator text, never Rust debug text).
fn end_words(k: TrialEventKind) -> (&'static str, Option<String>) {
    match k {
        TrialEventKind::Started => ("started", None),
        TrialEventKind::Done => ("done", None),
        TrialEventKind::Aborted => ("aborted", None),
        TrialEventKind::Faulted(f) => ("faulted", Some(f.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_protocol::ctrl::{FaultCode, FaultReport};
    use mesopush_protocol::host::TrialFault;

    #[test]
    fn a_faulted_end_is_a_key_and_the_fault_in_words() {
        let report = FaultReport {
            ctrl_time_us: 5,
            code: FaultCode::Stall,
            segment_id: Some(3),
            x_nm: -49_000_000,
            y_nm: 1_000,
        };
        let (kind, reason) = end_words(TrialEventKind::Faulted(TrialFault::Controller(report)));
        assert_eq!(kind, "faulted");
        let reason = reason.unwrap();
        assert!(reason.contains("the stage stalled") && reason.contains("(move 3)"), "{reason}");
        assert!(!reason.contains('{') && !reason.contains("Controller("), "{reason}");
        assert_eq!(end_words(TrialEventKind::Done), ("done", None));
    }
}
