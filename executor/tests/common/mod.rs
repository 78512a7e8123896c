//! Test rig: the executor core driven against a scripted controller at message level.
//!
//! The scripted controller is deliberately simple and allocation-free (heapless): it answers
//! clock-sync queries with its own clock (`ctrl = exec + offset`), queues moves, finishes
//! each at `start + length / speed`, and reports status and position every `report_us`.
//! It records the segments it received so tests can check order and flow control.
#![allow(dead_code, unreachable_pub)]

use heapless::{Deque, Vec as HVec};
use mesopush_executor::{Executor, ExecutorConfig, Input, LogEvent, MemStore, Output, Outputs};
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::{
    CtrlState, CtrlStatus, CtrlToExec, FaultCode, FaultReport, MoveSegment, PositionReport,
};
use mesopush_protocol::flash::{FlashHeader, PlanStep, image_chunks};
use mesopush_protocol::host::{ExecToHost, Hello, HostToExec, StagePoint};

pub const CAP: usize = 12 * 256;
pub const LA: usize = 16;
pub const OUT: usize = LA + 16;
pub type Exec = Executor<MemStore<CAP>, CAP, LA>;
/// Where the rig's scripted controller starts the probe, and so the plans' stated start.
pub const START: StagePoint = StagePoint { x_nm: 1_000_000, y_nm: 1_000_000 };

/// Image bytes of `steps`.
pub fn image(steps: &[PlanStep]) -> std::vec::Vec<u8> {
    steps.iter().flat_map(|s| s.to_image_bytes()).collect()
}

/// A square-ish plan of `n` steps of 20 µm at 140 µm/s, alternating +x, +y, −x, −y.
pub fn square_plan(n: usize) -> std::vec::Vec<PlanStep> {
    let d = 20_000;
    let dirs = [(d, 0), (0, d), (-d, 0), (0, -d)];
    (0..n)
        .map(|i| PlanStep { dx_nm: dirs[i % 4].0, dy_nm: dirs[i % 4].1, speed_nm_s: 140_000 })
        .collect()
}

pub struct ScriptedCtrl {
    pub offset_us: i64,
    pub capacity: u16,
    pub report_us: u64,
    pub silent: bool,
    pub mute_status: bool,
    queue: Deque<(MoveSegment, (i32, i32)), 64>,
    pub pos: (i32, i32),
    last_done: Option<u32>,
    next_report_ctrl_us: u64,
    outbox: Deque<CtrlToExec, 128>,
    pub received: HVec<u32, 4096>,
    pub max_queue: usize,
    pub overflowed: bool,
    pub stopped: bool,
    pub fault_next: Option<FaultCode>,
    pub faulted: bool,
}

impl ScriptedCtrl {
    pub fn new(offset_us: i64, start: (i32, i32)) -> Self {
        Self {
            offset_us,
            capacity: 32,
            report_us: 10_000,
            silent: false,
            mute_status: false,
            queue: Deque::new(),
            pos: start,
            last_done: None,
            next_report_ctrl_us: 0,
            outbox: Deque::new(),
            received: HVec::new(),
            max_queue: 0,
            overflowed: false,
            stopped: false,
            fault_next: None,
            faulted: false,
        }
    }

    pub fn ctrl_us(&self, exec_us: u64) -> u64 {
        (exec_us as i64 + self.offset_us) as u64
    }

    pub fn on_msg(&mut self, exec_us: u64, msg: &ExecToCtrl) {
        let now = self.ctrl_us(exec_us);
        match *msg {
            ExecToCtrl::ClockSyncQuery { query_id } => {
                self.send(CtrlToExec::ClockSyncReply { query_id, ctrl_time_us: now });
            }
            ExecToCtrl::Move(seg) => {
                let _ = self.received.push(seg.segment_id);
                let from =
                    self.queue.back().map_or(self.pos, |(s, _)| (s.target_x_nm, s.target_y_nm));
                if self.queue.len() >= usize::from(self.capacity) {
                    self.overflowed = true;
                } else {
                    let _ = self.queue.push_back((seg, from));
                }
                self.max_queue = self.max_queue.max(self.queue.len());
            }
            ExecToCtrl::Stop => {
                self.queue.clear();
                self.stopped = true;
            }
            ExecToCtrl::StatusQuery => self.send_status(now),
            ExecToCtrl::ClearFault => self.faulted = false,
            ExecToCtrl::Heartbeat { .. } => {}
        }
    }

    fn send(&mut self, msg: CtrlToExec) {
        if !self.silent {
            let _ = self.outbox.push_back(msg);
        }
    }

    fn send_status(&mut self, now: u64) {
        let len = self.queue.len() as u16;
        let status = CtrlStatus {
            ctrl_time_us: now,
            state: match (self.faulted, len) {
                (true, _) => CtrlState::Faulted,
                (false, 0) => CtrlState::Idle,
                (false, _) => CtrlState::Moving,
            },
            queue_free_slots: self.capacity - len,
            queue_len: len,
            last_done_segment_id: self.last_done,
        };
        self.send(CtrlToExec::Status(status));
    }

    pub fn tick(&mut self, exec_us: u64) {
        let now = self.ctrl_us(exec_us);
        while let Some(&(seg, from)) = self.queue.front() {
            let dx = i64::from(seg.target_x_nm - from.0);
            let dy = i64::from(seg.target_y_nm - from.1);
            let len = ((dx * dx + dy * dy) as f64).sqrt();
            let dur = (len * 1e6 / f64::from(seg.speed_nm_s)).ceil() as u64;
            if now < seg.start_ctrl_time_us + dur {
                if now >= seg.start_ctrl_time_us {
                    let f = (now - seg.start_ctrl_time_us) as f64 / dur.max(1) as f64;
                    self.pos = (from.0 + (dx as f64 * f) as i32, from.1 + (dy as f64 * f) as i32);
                }
                break;
            }
            self.pos = (seg.target_x_nm, seg.target_y_nm);
            self.last_done = Some(seg.segment_id);
            self.queue.pop_front();
        }
        if let Some(code) = self.fault_next.take() {
            self.queue.clear();
            self.faulted = true;
            let report = FaultReport {
                ctrl_time_us: now,
                code,
                segment_id: self.last_done,
                x_nm: self.pos.0,
                y_nm: self.pos.1,
            };
            self.send(CtrlToExec::Fault(report));
        }
        if now >= self.next_report_ctrl_us {
            self.next_report_ctrl_us = now + self.report_us;
            let report = PositionReport {
                ctrl_time_us: now,
                x_nm: self.pos.0,
                y_nm: self.pos.1,
                active_segment_id: None,
            };
            self.send(CtrlToExec::Position(report));
            if !self.mute_status {
                self.send_status(now);
            }
            self.send(CtrlToExec::Heartbeat { ctrl_time_us: now });
        }
    }

    pub fn pop(&mut self) -> Option<CtrlToExec> {
        self.outbox.pop_front()
    }
}

/// Executor + scripted controller + a record of what the host saw.
pub struct Rig {
    pub exec: Exec,
    pub ctrl: ScriptedCtrl,
    pub now_us: u64,
    pub step_us: u64,
    pub host_heartbeats: bool,
    pub to_host: std::vec::Vec<(u64, ExecToHost)>,
    pub logs: std::vec::Vec<LogEvent>,
    pub stops: std::vec::Vec<u64>,
}

impl Rig {
    pub fn new(config: ExecutorConfig) -> Self {
        Self::with_store(config, MemStore::new())
    }

    pub fn with_store(config: ExecutorConfig, store: MemStore<CAP>) -> Self {
        Self {
            exec: Exec::new(config, store).expect("valid config"),
            ctrl: ScriptedCtrl::new(7_000_000, (START.x_nm, START.y_nm)),
            now_us: 1_000,
            step_us: 1_000,
            host_heartbeats: true,
            to_host: std::vec::Vec::new(),
            logs: std::vec::Vec::new(),
            stops: std::vec::Vec::new(),
        }
    }

    fn dispatch(&mut self, out: &mut Outputs<OUT>) {
        for o in out.iter() {
            match o {
                Output::Host(m) => self.to_host.push((self.now_us, m.clone())),
                Output::Ctrl(m) => {
                    if *m == ExecToCtrl::Stop {
                        self.stops.push(self.now_us);
                    }
                    self.ctrl.on_msg(self.now_us, m);
                }
                Output::Log(e) => self.logs.push(*e),
            }
        }
        out.clear();
    }

    pub fn input(&mut self, input: Input<'_>) {
        let mut out = Outputs::<OUT>::new();
        self.exec.handle(self.now_us, input, &mut out).expect("room for outputs");
        self.dispatch(&mut out);
    }

    /// Sends a host message; returns what the host received in reply.
    pub fn host(&mut self, msg: HostToExec) -> std::vec::Vec<ExecToHost> {
        let before = self.to_host.len();
        self.input(Input::Host(&msg));
        self.to_host[before..].iter().map(|(_, m)| m.clone()).collect()
    }

    /// One time step: controller, executor tick, replies.
    pub fn step(&mut self) {
        self.now_us += self.step_us;
        if self.host_heartbeats && self.now_us % 100_000 < self.step_us {
            self.input(Input::Host(&HostToExec::Heartbeat { host_time_us: self.now_us }));
        }
        self.ctrl.tick(self.now_us);
        while let Some(m) = self.ctrl.pop() {
            self.input(Input::Ctrl(&m));
        }
        self.input(Input::Tick);
    }

    pub fn run_for(&mut self, dt_us: u64) {
        let end = self.now_us + dt_us;
        while self.now_us < end {
            self.step();
        }
    }

    pub fn run_until(&mut self, max_us: u64, mut done: impl FnMut(&Rig) -> bool) -> bool {
        let end = self.now_us + max_us;
        while self.now_us < end {
            if done(self) {
                return true;
            }
            self.step();
        }
        done(self)
    }

    pub fn hello(&mut self) {
        let reply = self.host(HostToExec::Hello(Hello::CURRENT));
        assert_eq!(reply, vec![ExecToHost::HelloReply { hello: Hello::CURRENT, accepted: true }]);
    }

    /// Uploads `image` under `header`; returns the last reply.
    pub fn flash(&mut self, header: FlashHeader, image: &[u8]) -> ExecToHost {
        self.host(HostToExec::FlashBegin(header));
        for chunk in image_chunks(header.plan_id, image) {
            self.host(HostToExec::FlashChunk(chunk));
        }
        let reply = self.host(HostToExec::FlashCommit { plan_id: header.plan_id });
        reply.last().cloned().expect("commit is answered")
    }

    pub fn flash_steps(&mut self, plan_id: u32, steps: &[PlanStep]) -> ExecToHost {
        let image = image(steps);
        let header = FlashHeader::for_image(plan_id, &image).expect("whole steps");
        self.flash(header, &image)
    }
}
