//! The trial recorder: a thread that turns what the loop observes — the executor's log
//! records, the host's received messages (probe telemetry), camera frames — into a trial
//! directory through [`TrialWriter`], stores the frames in the trial's frame store, and tracks every frame with
//! the host's tracker (calibration as the host believes it) into pose.csv.
//!
//! Rows are written from the trial's start (the executor's `Started` event) on; everything
//! before (upload, arming) is in events.csv only. probe.csv holds one row per setpoint of the
//! executor's schedule (rebuilt from the flashed plan and the start time with the executor's
//! own `path_position_nm`), with a controller position report attached to the setpoint row
//! nearest its receive time. The loop hands messages over a bounded channel: in real time a
//! full channel drops the frame (counted, never waited for); in simulated time the loop waits
//! (time is not real, and the run stays deterministic).
//!
//! It belongs to the drive module, not the client: it records what the in-process loop
//! observes of the in-process executor (its log records, handed over as [`RecMsg`]); a real
//! executor records its own frames, which the client completes. It shares the client's
//! setpoint [`Schedule`] and pose rows ([`pose_row`]) so both trial logs read the same.

use crate::Error;
use crate::client::schedule::Schedule;
use crate::client::tracking::pose_row;
use image::GrayImage;
use mesopush_core::geom::Vec2;
use mesopush_executor::LogEvent;
use mesopush_executor::camera::{SeqCheck, StampSource, StampedFrame};
use mesopush_framestore::PageMeta;
use mesopush_protocol::host::{ExecToHost, TrialEventKind};
use mesopush_protocol::units::nm_to_um;
use mesopush_trial::{EventRow, FrameRow, PoseRow, ProbeRow, TrialWriter};
use mesopush_vision::{TrackSettings, Tracker};

/// One thing for the recorder.
#[derive(Debug)]
pub enum RecMsg {
    /// An executor log record, at executor time `now_us`.
    Log(u64, LogEvent),
    /// A message the host received.
    Host(u64, ExecToHost),
    /// A camera frame: its stamp, arrival time, the image (absent when black) and, in
    /// simulation, the truth at its exposure.
    Frame {
        /// The executor's stamp.
        stamped: StampedFrame,
        /// Arrival at the executor, µs.
        arrival_us: u64,
        /// The image.
        image: Option<GrayImage>,
    },
    /// Something outside the executor happened (injected fault, line failure).
    Event(u64, String, String),
    /// Several messages in order (simulated time hands them over in batches: one channel
    /// operation, one wake-up of the recorder, per batch instead of per record).
    Batch(Vec<RecMsg>),
}

/// A tracked frame (kept for the verdict and the figure).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tracked {
    /// The pose row written.
    pub row: PoseRow,
    /// Exposure time, executor µs (absolute).
    pub t_exposure_us: u64,
    /// Whether the tracker flagged it.
    pub flagged: bool,
}

/// What the recorder did.
#[derive(Debug)]
pub struct RecorderResult {
    /// The writer, to finish the trial.
    pub writer: TrialWriter,
    /// Tracked frames in order.
    pub tracked: Vec<Tracked>,
    /// Frames recorded (with or without image).
    pub frames: u64,
    /// Frames the camera or the executor reported missing.
    pub dropped_frames: u64,
    /// Faults seen in the executor's trial events.
    pub faults_detected: u64,
    /// The trial's end event and its time.
    pub end: Option<(u64, TrialEventKind)>,
    /// `Started` time, executor µs.
    pub t0_us: Option<u64>,
}

/// The recorder's state (runs on its own thread; see [`Recorder::run`]).
#[derive(Debug)]
pub struct Recorder {
    writer: TrialWriter,
    tracker: Tracker,
    schedule: Schedule,
    t0_us: Option<u64>,
    next_row: u64,
    rows: u64,
    index: u64,
    /// Frame index of the last frame handed to the tracker (the gap scales its jump check).
    last_tracked: Option<u64>,
    /// Whether the tracker's learned apparent scale went into events.csv.
    scale_said: bool,
    out: RecorderResult0,
}

#[derive(Debug, Default)]
struct RecorderResult0 {
    tracked: Vec<Tracked>,
    frames: u64,
    dropped_frames: u64,
    faults_detected: u64,
    end: Option<(u64, TrialEventKind)>,
}

impl Recorder {
    /// A recorder writing to `writer`, tracking against `background` with `track`.
    pub fn new(
        writer: TrialWriter,
        background: &GrayImage,
        track: TrackSettings,
        schedule: Schedule,
    ) -> Result<Self, Error> {
        let tracker = Tracker::new(background, track)?;
        let rows = schedule.rows();
        Ok(Self {
            writer,
            tracker,
            schedule,
            t0_us: None,
            next_row: 0,
            rows,
            index: 0,
            last_tracked: None,
            scale_said: false,
            out: RecorderResult0::default(),
        })
    }

    /// Consumes messages until the channel closes; returns what was recorded.
    pub fn run(mut self, rx: crossbeam_channel::Receiver<RecMsg>) -> Result<RecorderResult, Error> {
        for msg in rx {
            self.handle(msg)?;
        }
        let end_us = self.out.end.map(|(t, _)| t);
        self.emit_rows_until(end_us.map_or(u64::MAX, |t| t.saturating_add(1)), None)?;
        self.writer.flush()?;
        let o = self.out;
        Ok(RecorderResult {
            writer: self.writer,
            tracked: o.tracked,
            frames: o.frames,
            dropped_frames: o.dropped_frames,
            faults_detected: o.faults_detected,
            end: o.end,
            t0_us: self.t0_us,
        })
    }

    fn rel(&self, t_us: u64) -> i64 {
        t_us as i64 - self.t0_us.unwrap_or(0) as i64
    }

    fn event(&mut self, t_us: u64, kind: &str, detail: String) -> Result<(), Error> {
        let t_us = self.rel(t_us);
        Ok(self.writer.event(&EventRow { t_us, kind: kind.into(), detail })?)
    }

    fn handle(&mut self, msg: RecMsg) -> Result<(), Error> {
        match msg {
            RecMsg::Log(now, e) => self.on_log(now, e),
            RecMsg::Host(_, ExecToHost::Telemetry(t)) if self.t0_us.is_some() => {
                let pos = Vec2::new(nm_to_um(t.probe_x_nm), nm_to_um(t.probe_y_nm))
                    - self.schedule.offset_um;
                self.emit_rows_until(t.exec_time_us, Some(pos))
            }
            RecMsg::Host(..) => Ok(()),
            RecMsg::Frame { stamped, arrival_us, image } => {
                self.on_frame(&stamped, arrival_us, image.as_ref())
            }
            RecMsg::Event(t, kind, detail) => self.event(t, &kind, detail),
            RecMsg::Batch(msgs) => msgs.into_iter().try_for_each(|m| self.handle(m)),
        }
    }

    fn on_log(&mut self, now: u64, e: LogEvent) -> Result<(), Error> {
        match e {
            LogEvent::Trial(t) => {
                let (kind, detail) = match t.kind {
                    TrialEventKind::Started => {
                        self.t0_us = Some(t.exec_time_us);
                        ("started", format!("plan {}", t.plan_id))
                    }
                    TrialEventKind::Done => ("done", format!("step {}", t.step_index)),
                    TrialEventKind::Aborted => ("aborted", format!("step {}", t.step_index)),
                    TrialEventKind::Faulted(f) => {
                        self.out.faults_detected += 1;
                        ("fault", format!("step {}: {f}", t.step_index))
                    }
                };
                if t.kind != TrialEventKind::Started {
                    self.out.end = Some((t.exec_time_us, t.kind));
                }
                self.event(t.exec_time_us, kind, detail)
            }
            LogEvent::PlanAccepted { plan_id, step_count } => {
                self.event(now, "plan_accepted", format!("plan {plan_id}, {step_count} steps"))
            }
            LogEvent::PlanRefused { plan_id, refusal } => {
                self.event(now, "plan_refused", format!("plan {plan_id:08x}: {refusal}"))
            }
            LogEvent::ArmRefused { plan_id, violation } => {
                self.event(now, "arm_refused", format!("plan {plan_id:08x}: {violation}"))
            }
            LogEvent::Motion(m) => self.event(m.exec_time_us, "goto", m.kind.to_string()),
            LogEvent::Frame(_) => Ok(()), // recorded with its image
        }
    }

    /// Writes the setpoint rows due by executor time `until_us` (rows within half a period
    /// after it count as due); `report` goes on the last of them.
    fn emit_rows_until(&mut self, until_us: u64, report: Option<Vec2>) -> Result<(), Error> {
        let Some(t0) = self.t0_us else { return Ok(()) };
        let (period, first) = (self.schedule.period(), t0 + self.schedule.lead_us);
        let horizon = until_us.saturating_add(period / 2);
        if horizon < first || self.rows == 0 {
            return Ok(());
        }
        let last = ((horizon - first) / period).min(self.rows - 1);
        while self.next_row <= last {
            let k = self.next_row;
            let cmd = self.schedule.row_cmd_um(k);
            let rep = if k == last { report } else { None };
            let row = ProbeRow {
                t_us: self.rel(first + k * period),
                cmd_x_um: cmd.x,
                cmd_y_um: cmd.y,
                rep_x_um: rep.map(|p| p.x),
                rep_y_um: rep.map(|p| p.y),
                cmd_theta_rad: None,
            };
            self.writer.probe(&row)?;
            self.next_row += 1;
        }
        Ok(())
    }

    fn on_frame(
        &mut self,
        stamped: &StampedFrame,
        arrival_us: u64,
        image: Option<&GrayImage>,
    ) -> Result<(), Error> {
        if self.t0_us.is_none() {
            return Ok(()); // before the trial
        }
        if let SeqCheck::Gap { dropped } = stamped.seq {
            for i in 0..dropped {
                let seq = stamped.stamp.frame_seq.wrapping_sub(dropped - i);
                self.writer.frame(&FrameRow {
                    index: self.index,
                    frame_seq: seq,
                    t_capture_us: None,
                    t_arrival_us: None,
                    stamp_source: String::new(),
                    dropped: true,
                    black: false,
                    probe_x_um: None,
                    probe_y_um: None,
                    file: None,
                })?;
                self.index += 1;
            }
            self.out.dropped_frames += u64::from(dropped);
            self.event(
                arrival_us,
                "frames_dropped",
                format!("{dropped} before {}", stamped.stamp.frame_seq),
            )?;
        }
        let index = self.index;
        self.index += 1;
        self.out.frames += 1;
        let st = &stamped.stamp;
        let t_capture = self.rel(st.frame_stamp_us);
        let file = match image {
            Some(img) => {
                let page = PageMeta { index, t_capture_us: Some(t_capture) };
                Some(self.writer.frame_image(page, img.width(), img.height(), img.as_raw())?)
            }
            None => None,
        };
        let probe =
            Vec2::new(nm_to_um(st.probe_x_nm), nm_to_um(st.probe_y_nm)) - self.schedule.offset_um;
        self.writer.frame(&FrameRow {
            index,
            frame_seq: st.frame_seq,
            t_capture_us: Some(t_capture),
            t_arrival_us: Some(self.rel(arrival_us)),
            stamp_source: match stamped.source {
                StampSource::Driver => "driver".into(),
                StampSource::Arrival => "arrival".into(),
            },
            dropped: false,
            black: stamped.black,
            probe_x_um: Some(probe.x),
            probe_y_um: Some(probe.y),
            file,
        })?;
        if let Some(img) = image {
            self.track(index, t_capture, st.frame_stamp_us, img)?;
        }
        Ok(())
    }

    fn track(
        &mut self,
        index: u64,
        t_capture: i64,
        t_abs: u64,
        img: &GrayImage,
    ) -> Result<(), Error> {
        let periods = self.last_tracked.map_or(1, |i| index.saturating_sub(i));
        self.last_tracked = Some(index);
        let m = self.tracker.track_after(img, u32::try_from(periods).unwrap_or(u32::MAX))?;
        if let (false, Some(r)) = (self.scale_said, self.tracker.apparent_scale()) {
            self.scale_said = true;
            self.event(t_abs, "apparent_scale", mesopush_vision::scale_lock::describe(r))?;
        }
        let Some(row) = pose_row(t_capture, index, &m) else { return Ok(()) };
        self.writer.pose(&row)?;
        self.out.tracked.push(Tracked { row, t_exposure_us: t_abs, flagged: m.is_flagged() });
        Ok(())
    }
}
