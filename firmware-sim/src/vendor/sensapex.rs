//! Emulator of a Sensapex uMp micromanipulator speaking SMCP1 over UDP.
//!
//! Sources (controller-protocol notes, section 4): Sensapex umsdk `smcp1.h` (frame, types,
//! options, ACK rules: "ACK is sent (if requested) when message received and understood …
//! error bit set if an unicast message was received, but can not be parsed"; "0 = unicast
//! to the sender"), `libum.c` (how the SDK encodes GOTO_POS/TAKE_STEP, accepts ACKs,
//! responses and notifications, de-duplicates NOTIFY 104 by message id), sensapex-py
//! (`simultaneous` = all axes start together, `linear` = per-axis speeds scaled by the
//! host, so one shared speed moves every axis at that speed).
//!
//! Emulated (one datagram in, datagrams out; no network latency):
//! - frames with a version other than 0x10, shorter than 16 bytes, not requests, or
//!   addressed to another id (accepted: the device id, 0x00FF all devices, 0x07FF all) are
//!   dropped silently;
//! - REQ_ACK → an ACK first: the request header with receiver = the requester, sender = the
//!   device, options `0x00000002`, no sub-blocks, same type and message id. A unicast frame
//!   that does not decode (bad sub-block lengths, unknown type, bad arguments, speed 0)
//!   gets ACK|ERROR (`0x0000000A`) and is not acted on;
//! - REQ_RESP → a response (options 0, same type and id, to the requester): PING echoes the
//!   request's sub-blocks; GET_POSITIONS → INT32 × 4 (x, y, z, w nm, the sensed = true
//!   position); GET_PARAMETER (MEM_SPEED, DEV_ID, AXIS_COUNT = 4) → (id, value);
//!   GET_VERSION → UINT32 × 4;
//! - GOTO_POS: mode 0 (default) moves x, then y, then z, then w (order inferred); mode 1
//!   moves all axes together, each at its own speed (a dog-leg unless the host scales the
//!   speeds). With REQ_NOTIFY, NOTIFY 104 (UINT32 code) goes to the requester at the end:
//!   0 reached, [`CODE_INTERRUPTED`] = 1 stopped or replaced by another move, [`CODE_MISSED`]
//!   = 3 ended off target (a stall) (codes 1 and 3 inferred; the SDK counts only 0 and 2 as
//!   success). TAKE_STEP moves relative, all axes together, ACK only;
//! - STOP stops dead at once (then the 104 of the move, if one was requested);
//! - while moving, NOTIFY 101 (INT32 × 4 nm) every [`SensapexSettings::notify_period_us`]
//!   (20 ms = the SDK's cache age, the device rate is inferred) and once at the end; NOTIFY
//!   102 with the status bits (BUSY 0x01 | X 0x10 | Y 0x20 | Z 0x40 | W 0x80) at the start
//!   and 0 at the end. Pushed notifications go to receiver 0x02FF (all PCs) (inferred);
//!   every notification carries the device's own incrementing message id.
//!
//! Positions are whole multiples of [`SensapexSettings::resolution_nm`] (5 nm, inferred);
//! targets beyond the travel (0..20 mm, inferred) are clamped. Not emulated: REQ_BCAST
//! (the IP destination is outside this model), memory drives, INIT_ZERO, features,
//! the uMp's "speed < 1 crashes" report (the SDK's negative nm/s encoding is supported).

use super::controller::{VendorController, to_i32};
use super::motion::{AxisLimits, Path, Stage};
use super::smcp::{self, ALL, ALL_DEVICES, ALL_PCS, DATA_INT32, DATA_UINT32, Header, kind, opt};
use super::umprequest::{self, Request, param};
use crate::error::SimError;
use mesopush_protocol::units::um_to_nm_i64;
use std::collections::VecDeque;

/// NOTIFY 104 code: the move reached its target.
pub const CODE_OK: i32 = 0;
/// NOTIFY 104 code: stopped by STOP or replaced by another move.
pub const CODE_INTERRUPTED: i32 = 1;
/// NOTIFY 104 code: the move ended away from its target (stall).
pub const CODE_MISSED: i32 = 3;
/// Status bit: busy.
pub const STATUS_BUSY: i32 = 0x01;

/// Settings of an emulated uMp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensapexSettings {
    /// Device id (1..254 legacy ids).
    pub dev_id: u16,
    /// Start position x, y, z, w, nm.
    pub start_nm: [i64; 4],
    /// Travel of every axis (min, max), nm.
    pub travel_nm: (i64, i64),
    /// Position resolution, nm (> 0).
    pub resolution_nm: i64,
    /// Period of NOTIFY 101 while moving, µs (> 0).
    pub notify_period_us: u64,
    /// MEM_SPEED at power-on (speed of a GOTO_POS without one), µm/s (> 0).
    pub mem_speed_um_s: i32,
    /// Acceleration when a request gives none, nm/s² (> 0).
    pub accel_nm_s2: i64,
    /// GET_VERSION answer.
    pub version: [i32; 4],
}

impl SensapexSettings {
    /// Device 1 at mid travel, 5 nm, 20 ms notifications, 1000 µm/s, 10 mm/s².
    pub const DEFAULT: Self = Self {
        dev_id: 1,
        start_nm: [10_000_000; 4],
        travel_nm: (0, 20_000_000),
        resolution_nm: 5,
        notify_period_us: 20_000,
        mem_speed_um_s: 1000,
        accel_nm_s2: 10_000_000,
        version: [1, 0, 0, 1],
    };
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Job {
    requester: u16,
    notify: bool,
}

/// An emulated Sensapex uMp on its UDP link.
#[derive(Debug, Clone)]
pub struct Sensapex {
    cfg: SensapexSettings,
    now_us: u64,
    stage: Stage<4>,
    out: VecDeque<(u64, Vec<u8>)>,
    msg_counter: u16,
    job: Option<Job>,
    next_push_us: u64,
    mem_speed_um_s: i32,
}

impl Sensapex {
    /// Powered on at `now_us`.
    pub fn new(cfg: SensapexSettings, now_us: u64) -> Result<Self, SimError> {
        let bad = |field| Err(SimError::BadConfig { field });
        if cfg.resolution_nm <= 0 {
            return bad("sensapex.resolution_nm");
        }
        if cfg.notify_period_us == 0 {
            return bad("sensapex.notify_period_us");
        }
        if cfg.mem_speed_um_s <= 0 || cfg.accel_nm_s2 <= 0 {
            return bad("sensapex.mem_speed_um_s/accel_nm_s2");
        }
        if cfg.travel_nm.0 >= cfg.travel_nm.1 {
            return bad("sensapex.travel_nm");
        }
        let start = cfg.start_nm.map(|v| (v as f64 / cfg.resolution_nm as f64).round() as i64);
        Ok(Self {
            cfg,
            now_us,
            stage: Stage::new(start),
            out: VecDeque::new(),
            msg_counter: 0,
            job: None,
            next_push_us: now_us,
            mem_speed_um_s: cfg.mem_speed_um_s,
        })
    }

    /// Starts or ends a stall at `now_us` (see [`Stage::set_stalled`]); the sensed position
    /// stays where the stage stopped.
    pub fn set_stalled(&mut self, now_us: u64, stalled: bool) {
        self.advance(now_us);
        self.stage.set_stalled(self.now_us, stalled);
    }

    fn addressed(&self, receiver: u16) -> bool {
        receiver == self.cfg.dev_id || receiver == ALL_DEVICES || receiver == ALL
    }

    fn positions_nm(&self, t_us: u64) -> [i32; 4] {
        self.stage.true_pos(t_us).map(|s| to_i32(s.saturating_mul(self.cfg.resolution_nm)))
    }

    fn header(&mut self, receiver: u16, options: u32, kind_: u16, id: Option<u16>) -> Header {
        let message_id = id.unwrap_or_else(|| {
            self.msg_counter = self.msg_counter.wrapping_add(1);
            self.msg_counter
        });
        Header {
            version: smcp::VERSION,
            extra: 0,
            receiver,
            sender: self.cfg.dev_id,
            message_id,
            options,
            kind: kind_,
            sub_blocks: 0,
        }
    }

    fn emit(&mut self, t_us: u64, h: Header, blocks: &[(u16, &[i32])]) {
        self.out.push_back((t_us, smcp::encode(h, blocks)));
    }

    fn notify(&mut self, t_us: u64, receiver: u16, kind_: u16, data_type: u16, v: &[i32]) {
        let h = self.header(receiver, opt::NOTIFY, kind_, None);
        self.emit(t_us, h, &[(data_type, v)]);
    }

    fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        while let Some(job) = self.job {
            let end = self.stage.end_us().unwrap_or(self.now_us);
            if self.next_push_us < end && self.next_push_us <= self.now_us {
                let t = self.next_push_us;
                let p = self.positions_nm(t);
                self.notify(t, ALL_PCS, kind::NOTIFY_POSITION_CHANGED, DATA_INT32, &p);
                self.next_push_us = t.saturating_add(self.cfg.notify_period_us);
                continue;
            }
            if end > self.now_us {
                break;
            }
            let reached = self.stage.target() == Some(self.stage.true_pos(end));
            self.stage.settle(end);
            self.finish(end, job, if reached { CODE_OK } else { CODE_MISSED });
        }
    }

    /// Ends the current move at `t_us`: closed-loop re-sync of the counter on the sensed
    /// position, last positions, idle status, and the 104 if requested.
    fn finish(&mut self, t_us: u64, job: Job, code: i32) {
        self.stage.stop(t_us);
        self.stage.set_counter(self.stage.true_pos(t_us));
        self.job = None;
        let p = self.positions_nm(t_us);
        self.notify(t_us, ALL_PCS, kind::NOTIFY_POSITION_CHANGED, DATA_INT32, &p);
        self.notify(t_us, ALL_PCS, kind::NOTIFY_STATUS_CHANGED, DATA_UINT32, &[0]);
        if job.notify {
            self.notify(t_us, job.requester, kind::NOTIFY_GOTO_POS_COMPLETED, DATA_UINT32, &[code]);
        }
    }

    fn handle(&mut self, frame: &[u8]) {
        let Some(h) = Header::parse(frame) else { return };
        if h.version != smcp::VERSION || !self.addressed(h.receiver) || h.options & opt::REQ == 0 {
            return;
        }
        let req = smcp::parse_blocks(frame, &h)
            .ok_or(umprequest::Rejected)
            .and_then(|b| umprequest::decode(h.kind, &b).map(|r| (r, b)));
        let ack = h.options & opt::REQ_ACK != 0;
        match req {
            Err(_) if ack && h.receiver == self.cfg.dev_id => self.ack(&h, opt::ERROR),
            Err(_) => {}
            Ok((r, blocks)) => {
                if ack {
                    self.ack(&h, 0);
                }
                self.apply(&h, r, &blocks);
            }
        }
    }

    fn ack(&mut self, req: &Header, extra: u32) {
        let h = self.header(req.sender, opt::ACK | extra, req.kind, Some(req.message_id));
        self.emit(self.now_us, h, &[]);
    }

    fn apply(&mut self, req: &Header, r: Request, blocks: &[smcp::SubBlock]) {
        let now = self.now_us;
        let resp = |s: &mut Self, blocks: &[(u16, &[i32])]| {
            if req.options & opt::REQ_RESP != 0 {
                let h = s.header(req.sender, 0, req.kind, Some(req.message_id));
                s.emit(now, h, blocks);
            }
        };
        match r {
            Request::Ping => {
                let echo: Vec<(u16, &[i32])> =
                    blocks.iter().map(|b| (b.data_type, b.values.as_slice())).collect();
                resp(self, &echo);
            }
            Request::GetPositions => resp(self, &[(DATA_INT32, &self.positions_nm(now))]),
            Request::GetVersion => {
                let v = self.cfg.version;
                resp(self, &[(DATA_UINT32, &v)]);
            }
            Request::GetParameter(id) => {
                let v = match id {
                    param::MEM_SPEED => self.mem_speed_um_s,
                    param::DEV_ID => i32::from(self.cfg.dev_id),
                    _ => 4,
                };
                resp(self, &[(DATA_INT32, &[id, v])]);
            }
            Request::SetMemSpeed(v) => self.mem_speed_um_s = v,
            Request::Stop => {
                if let Some(job) = self.job {
                    self.finish(now, job, CODE_INTERRUPTED);
                }
            }
            Request::Goto { target_nm, speed_nm_s, simultaneous, max_acc_um_s2 } => {
                let cur = self.stage.true_pos(now);
                let res = self.cfg.resolution_nm as f64;
                let to = core::array::from_fn(|i| {
                    target_nm[i].map_or(cur[i], |nm| (nm as f64 / res).round() as i64)
                });
                let path = if simultaneous { Path::PerAxis } else { Path::Sequential };
                let notify = req.options & opt::REQ_NOTIFY != 0;
                self.start(req.sender, to, speed_nm_s, path, max_acc_um_s2, notify);
            }
            Request::Step { delta_nm, speed_nm_s, max_acc_um_s2 } => {
                let cur = self.stage.true_pos(now);
                let res = self.cfg.resolution_nm as f64;
                let to =
                    core::array::from_fn(|i| cur[i] + (delta_nm[i] as f64 / res).round() as i64);
                self.start(req.sender, to, speed_nm_s, Path::PerAxis, max_acc_um_s2, false);
            }
        }
    }

    fn start(
        &mut self,
        requester: u16,
        to: [i64; 4],
        speed_nm_s: [Option<f64>; 4],
        path: Path,
        max_acc_um_s2: Option<i32>,
        notify: bool,
    ) {
        let now = self.now_us;
        if let Some(old) = self.job {
            self.finish(now, old, CODE_INTERRUPTED);
        }
        let res = self.cfg.resolution_nm as f64;
        let (lo, hi) = self.cfg.travel_nm;
        let to =
            to.map(|s| s.clamp((lo as f64 / res).ceil() as i64, (hi as f64 / res).floor() as i64));
        let mem_nm_s = umprequest::speed_nm_s(self.mem_speed_um_s).unwrap_or(1.0);
        let accel_nm_s2 = max_acc_um_s2
            .and_then(|a| um_to_nm_i64("sensapex max_acc", f64::from(a)).ok())
            .unwrap_or(self.cfg.accel_nm_s2) as f64;
        let lim: [AxisLimits; 4] = core::array::from_fn(|i| AxisLimits {
            speed_steps_s: speed_nm_s[i].unwrap_or(mem_nm_s) / res,
            accel_steps_s2: accel_nm_s2 / res,
        });
        let from = self.stage.counter(now);
        self.stage.start(now, to, path, lim);
        self.job = Some(Job { requester, notify });
        self.next_push_us = now.saturating_add(self.cfg.notify_period_us);
        let status = (0..4).fold(STATUS_BUSY, |s, i| s | i32::from(from[i] != to[i]) << (4 + i));
        self.notify(now, ALL_PCS, kind::NOTIFY_STATUS_CHANGED, DATA_UINT32, &[status]);
        self.advance(now);
    }
}

impl VendorController for Sensapex {
    fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        self.advance(now_us);
        self.handle(bytes);
    }

    fn poll(&mut self, now_us: u64) {
        self.advance(now_us);
    }

    fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        self.advance(now_us);
        if self.out.front().is_none_or(|(t, _)| *t > self.now_us) {
            return None;
        }
        let (_, d) = self.out.pop_front()?;
        let n = d.len().min(buf.len());
        buf[..n].copy_from_slice(&d[..n]);
        Some(n)
    }

    fn probe_nm(&self) -> (i32, i32) {
        let p = self.positions_nm(self.now_us);
        (p[0], p[1])
    }

    fn probe_z_nm(&self) -> i32 {
        self.positions_nm(self.now_us)[2]
    }

    fn next_deadline_us(&self) -> Option<u64> {
        let push = self.job.map(|_| self.next_push_us);
        let end = self.job.and_then(|_| self.stage.end_us());
        [self.out.front().map(|(t, _)| *t), push, end].into_iter().flatten().min()
    }
}
