//! The bench's in-process controller: a minimal motion controller at message level on its own
//! thread, in the shared real-time clock. It answers clock-sync and status queries, queues
//! moves, finishes each at `start + length / speed` and reports its status the moment a move
//! finishes (so flow control never waits on a report period), plus position, status and
//! heartbeat every 10 ms. It stamps every move's arrival.

use crate::clock::{Clock, MonotonicClock};
use crate::shell::port::Chunk;
use crate::shell::rt_queue::{Receiver, RecvTimeoutError, Sender};
use mesopush_protocol::ctrl::{CtrlState, CtrlStatus, CtrlToExec, MoveSegment, PositionReport};
use mesopush_protocol::{ExecToCtrl, FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame};
use std::collections::VecDeque;
use std::prelude::rust_2024::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Queue capacity the controller reports.
const CAPACITY: u16 = 32;
/// Period of position/status/heartbeat reports, µs.
const REPORT_US: u64 = 10_000;

/// One received move: its arrival and its scheduled start, µs of the shared clock.
#[derive(Debug, Clone, Copy)]
pub struct Arrival {
    /// Segment id.
    pub segment_id: u32,
    /// When its frame arrived.
    pub arrival_us: u64,
    /// Its start in the controller's clock (= the shared clock).
    pub start_us: u64,
}

/// State of the bench controller.
pub(crate) struct BenchCtrl {
    link: Link<CtrlToExec, ExecToCtrl, 48>,
    reader: FrameReader<FRAME_BUF_LEN>,
    queue: VecDeque<(MoveSegment, u64)>,
    pos: (i32, i32),
    last_done: Option<u32>,
    next_report_us: u64,
    /// Every move received, in order.
    pub arrivals: Vec<Arrival>,
}

impl BenchCtrl {
    pub(crate) fn new(start_nm: (i32, i32), expected_moves: usize) -> Self {
        Self {
            link: Link::new(LinkConfig::DEFAULT, 501),
            reader: FrameReader::new(),
            queue: VecDeque::with_capacity(usize::from(CAPACITY) + 8),
            pos: start_nm,
            last_done: None,
            next_report_us: 0,
            arrivals: Vec::with_capacity(expected_moves + 64),
        }
    }

    fn on_msg(&mut self, now: u64, msg: ExecToCtrl) {
        match msg {
            ExecToCtrl::ClockSyncQuery { query_id } => {
                let _ = self.link.send(CtrlToExec::ClockSyncReply { query_id, ctrl_time_us: now });
            }
            ExecToCtrl::Move(seg) => {
                self.arrivals.push(Arrival {
                    segment_id: seg.segment_id,
                    arrival_us: now,
                    start_us: seg.start_ctrl_time_us,
                });
                let from =
                    self.queue.back().map_or(self.pos, |(s, _)| (s.target_x_nm, s.target_y_nm));
                let (dx, dy) =
                    (f64::from(seg.target_x_nm - from.0), f64::from(seg.target_y_nm - from.1));
                let dur = (dx.hypot(dy) * 1e6 / f64::from(seg.speed_nm_s.max(1))).ceil() as u64;
                let begin =
                    self.queue.back().map_or(0, |&(_, end)| end).max(seg.start_ctrl_time_us);
                self.queue.push_back((seg, begin + dur));
            }
            ExecToCtrl::Stop => self.queue.clear(),
            ExecToCtrl::StatusQuery => self.status(now),
            ExecToCtrl::ClearFault | ExecToCtrl::Heartbeat { .. } => {}
        }
    }

    fn status(&mut self, now: u64) {
        let len = self.queue.len().min(usize::from(CAPACITY)) as u16;
        let state = if len == 0 { CtrlState::Idle } else { CtrlState::Moving };
        let s = CtrlStatus {
            ctrl_time_us: now,
            state,
            queue_free_slots: CAPACITY - len,
            queue_len: len,
            last_done_segment_id: self.last_done,
        };
        let _ = self.link.send(CtrlToExec::Status(s));
    }

    fn tick(&mut self, now: u64) {
        let mut finished = false;
        while let Some(&(seg, end)) = self.queue.front() {
            if now < end {
                break;
            }
            self.pos = (seg.target_x_nm, seg.target_y_nm);
            self.last_done = Some(seg.segment_id);
            self.queue.pop_front();
            finished = true;
        }
        if finished {
            self.status(now);
        }
        if now >= self.next_report_us {
            self.next_report_us = now + REPORT_US;
            let (x_nm, y_nm) = self.pos;
            let p = PositionReport { ctrl_time_us: now, x_nm, y_nm, active_segment_id: None };
            let _ = self.link.send(CtrlToExec::Position(p));
            self.status(now);
            let _ = self.link.send(CtrlToExec::Heartbeat { ctrl_time_us: now });
        }
    }

    /// Serves the controller line until `stop`; wakes at least every 200 µs.
    pub(crate) fn serve(
        mut self,
        clock: Arc<MonotonicClock>,
        rx: Receiver<Chunk>,
        tx: Sender<Chunk>,
        stop: Arc<AtomicBool>,
    ) -> Self {
        let mut out = [0u8; FRAME_BUF_LEN];
        while !stop.load(Ordering::Relaxed) {
            let got = rx.recv_timeout(Duration::from_micros(200));
            let now = clock.now_us();
            match got {
                Ok(chunk) => {
                    for &b in chunk.bytes() {
                        if let Some(Ok(frame)) = self.reader.push_byte(b)
                            && let Some(msg) = self.link.on_bytes(now, frame)
                        {
                            self.on_msg(now, msg);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.tick(now);
            let _ = self.link.poll(now);
            while let Some(frame) = self.link.poll_transmit(now) {
                let Ok(bytes) = encode_frame(&frame, &mut out) else { continue };
                for piece in bytes.chunks(crate::shell::port::CHUNK_BYTES) {
                    if tx.send(Chunk::new(piece)).is_err() {
                        return self;
                    }
                }
            }
        }
        self
    }
}
