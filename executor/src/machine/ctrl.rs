//! Controller messages and camera frames.

use super::{Executor, push};
use crate::camera::{CameraFrame, PositionSource};
use crate::io::{LogEvent, Output, Outputs};
use crate::plan::lerp_nm;
use crate::store::PlanStore;
use mesopush_protocol::ExecToHost;
use mesopush_protocol::ctrl::{CtrlToExec, FaultCode, PositionReport};
use mesopush_protocol::host::{ExecState, ProbeTelemetry, TrialFault};

impl<S: PlanStore, const CAP: usize, const LA: usize> Executor<S, CAP, LA> {
    pub(super) fn on_ctrl<const N: usize>(
        &mut self,
        now_us: u64,
        msg: &CtrlToExec,
        out: &mut Outputs<N>,
    ) {
        self.ctrl_last_heard_us = Some(now_us);
        match *msg {
            CtrlToExec::Position(report) => self.on_position(now_us, report, out),
            CtrlToExec::Status(status) => {
                self.ctrl_status = Some(status);
                if let Some(stream) = self.stream.as_mut() {
                    let capacity = status.queue_free_slots.saturating_add(status.queue_len);
                    stream.on_status(status.last_done_segment_id, capacity);
                }
            }
            CtrlToExec::ClockSyncReply { query_id, ctrl_time_us } => {
                self.sync.on_reply(now_us, query_id, ctrl_time_us, &self.config);
            }
            CtrlToExec::Heartbeat { .. } => {}
            CtrlToExec::Fault(report) => {
                if report.code == FaultCode::Reboot {
                    // Its clock and queue restarted: nothing we knew about it holds.
                    self.sync.reset();
                    self.positions.clear();
                    self.ctrl_status = None;
                }
                if let Some(status) = self.ctrl_status.as_mut() {
                    status.state = mesopush_protocol::ctrl::CtrlState::Faulted;
                }
                if self.in_motion() {
                    self.fault(now_us, TrialFault::Controller(report), out);
                }
            }
        }
    }

    fn on_position<const N: usize>(
        &mut self,
        now_us: u64,
        report: PositionReport,
        out: &mut Outputs<N>,
    ) {
        if self.latest_position().is_some_and(|last| report.ctrl_time_us <= last.ctrl_time_us) {
            return; // stale or duplicate
        }
        if self.positions.is_full() {
            self.positions.pop_front();
        }
        let _ = self.positions.push_back(report); // room made above
        if self.state == ExecState::Running {
            let telemetry = ProbeTelemetry {
                exec_time_us: now_us,
                ctrl_time_us: report.ctrl_time_us,
                probe_x_nm: report.x_nm,
                probe_y_nm: report.y_nm,
                step_index: self.status(now_us).step_index,
                ctrl_queue_free_slots: self.ctrl_status.map_or(0, |s| s.queue_free_slots),
            };
            push(out, Output::Host(ExecToHost::Telemetry(telemetry)));
        }
    }

    pub(super) fn on_frame<const N: usize>(
        &mut self,
        now_us: u64,
        frame: &CameraFrame,
        out: &mut Outputs<N>,
    ) {
        let (stamp_us, _) = crate::camera::FrameStamper::stamp_time(frame, now_us);
        let probe = self.probe_at(stamp_us);
        let stamped = self.stamper.stamp(frame, now_us, probe);
        push(out, Output::Host(ExecToHost::Frame(stamped.stamp)));
        push(out, Output::Log(LogEvent::Frame(stamped)));
    }

    /// Probe position at executor time `exec_time_us`: interpolated between the reports
    /// around it, else the commanded schedule after the latest report while running, else
    /// the latest report.
    fn probe_at(&self, exec_time_us: u64) -> (PositionSource, (i32, i32)) {
        let Some(last) = self.latest_position() else {
            return (PositionSource::Unknown, (0, 0));
        };
        let latest = (PositionSource::LatestReport, (last.x_nm, last.y_nm));
        let Some(t) = self.sync.to_ctrl_us(exec_time_us) else { return latest };
        let mut pairs = self.positions.iter().zip(self.positions.iter().skip(1));
        if let Some((prev, last)) = pairs.find(|(a, b)| a.ctrl_time_us <= t && t <= b.ctrl_time_us)
        {
            let span = last.ctrl_time_us - prev.ctrl_time_us;
            let from = (i64::from(prev.x_nm), i64::from(prev.y_nm));
            let to = (i64::from(last.x_nm), i64::from(last.y_nm));
            let (x, y) = lerp_nm(from, to, t - prev.ctrl_time_us, span);
            return (PositionSource::Interpolated, (x as i32, y as i32));
        }
        if t > last.ctrl_time_us
            && let Some((x, y)) = self.stream.as_ref().and_then(|s| s.commanded_at(t))
        {
            return (PositionSource::Scheduled, (x as i32, y as i32));
        }
        latest
    }
}
