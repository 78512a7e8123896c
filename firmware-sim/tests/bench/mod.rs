//! A deterministic test bench: executor endpoint + simulated controller + scripted host +
//! camera + a trivial world, over four simulated serial lines, in one loop on simulated
//! time. Everything random comes from one seed.
#![allow(dead_code, unreachable_pub)]

use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::{CameraFrame, Executor, ExecutorConfig, LogEvent, MemStore};
use mesopush_firmware_sim::camera::SimCamera;
use mesopush_firmware_sim::line::SimLine;
use mesopush_firmware_sim::{
    ControllerNode, CtrlConfig, CtrlEvent, FaultConfig, NodeEvent, PegPose, SimRng, World,
};
use mesopush_protocol::flash::{FlashHeader, PlanStep, image_chunks};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecToHost, Hello, HostToExec, StagePoint, TrialEventKind,
};
use mesopush_protocol::{FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame};

pub const CAP: usize = 12 * 512;
pub const LA: usize = 16;
pub const W: usize = 32;
pub const STEP_US: u64 = 100;
pub const PROBE_START_NM: (f64, f64) = (2_000_000.0, 3_000_000.0);

/// [`PROBE_START_NM`] as the plan's stated start.
fn start_point() -> StagePoint {
    StagePoint { x_nm: PROBE_START_NM.0 as i32, y_nm: PROBE_START_NM.1 as i32 }
}

/// A world whose peg never moves; frames are the probe position the camera saw. With
/// `wall_x_nm` set, a wall at that x holds the needle's tip: a probe further left bends the
/// needle by how far it is past the wall, which the world reports.
#[derive(Default)]
pub struct StillWorld {
    probe_nm: (i32, i32),
    /// True probe position at every step.
    pub history: Vec<(u64, (i32, i32))>,
    /// The wall that holds the tip, stage x nm (none: nothing bends the needle).
    pub wall_x_nm: Option<i32>,
}

impl World for StillWorld {
    type Frame = (i32, i32);
    fn step(&mut self, sim_time_us: u64, probe_nm: (i32, i32)) -> PegPose {
        self.probe_nm = probe_nm;
        self.history.push((sim_time_us, probe_nm));
        PegPose { x_um: 2_330.0, y_um: 1_210.0, theta_rad: 89f64.to_radians() }
    }
    fn render(&mut self, _sim_time_us: u64) -> (i32, i32) {
        self.probe_nm
    }
    fn needle_deflection_nm(&self) -> Option<i32> {
        self.wall_x_nm.map(|w| (w - self.probe_nm.0).max(0))
    }
}

/// One line of the run's log (compared between runs for determinism).
#[derive(Debug, Clone, PartialEq)]
pub enum Entry {
    Exec(LogEvent),
    Host(ExecToHost),
}

pub struct Bench {
    pub now_us: u64,
    pub exec: Endpoint<MemStore<CAP>, CAP, LA, W>,
    pub node: ControllerNode<32, W>,
    pub lines: [SimLine; 4], // exec→ctrl, ctrl→exec, host→exec, exec→host
    host: Link<HostToExec, ExecToHost, W>,
    host_reader: FrameReader<FRAME_BUF_LEN>,
    pub camera: SimCamera,
    pub world: StillWorld,
    pub log: Vec<(u64, Entry)>,
    plan: Vec<PlanStep>,
    phase: Phase,
    next_host_action_us: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Hello,
    Flashing,
    Arming,
    Running,
    Over,
}

impl Bench {
    pub fn new(seed: u64, faults: FaultConfig, plan: Vec<PlanStep>) -> Self {
        Self::with_config(seed, faults, plan, ExecutorConfig::DEFAULT)
    }

    pub fn with_config(
        seed: u64,
        faults: FaultConfig,
        plan: Vec<PlanStep>,
        config: ExecutorConfig,
    ) -> Self {
        Self::with_configs(seed, faults, plan, config, CtrlConfig::DEFAULT)
    }

    pub fn with_configs(
        seed: u64,
        faults: FaultConfig,
        plan: Vec<PlanStep>,
        config: ExecutorConfig,
        ctrl: CtrlConfig,
    ) -> Self {
        let rng = SimRng::new(seed);
        let link = LinkConfig::DEFAULT;
        let core = Executor::new(config, MemStore::new()).expect("config");
        let exec_session = rng.fork(10).below(1000) as u16;
        let node = ControllerNode::new(ctrl, faults, link, rng.fork(1), 0, PROBE_START_NM);
        Self {
            now_us: 0,
            exec: Endpoint::new(core, link, exec_session),
            node,
            lines: [2, 3, 4, 5].map(|s| SimLine::new(rng.fork(s), faults)),
            host: Link::new(link, 7_000 + rng.fork(11).below(1000) as u16),
            host_reader: FrameReader::new(),
            camera: SimCamera::new(33_333, 15_000, 10_000, rng.fork(6), faults),
            world: StillWorld::default(),
            log: Vec::new(),
            plan,
            phase: Phase::Hello,
            next_host_action_us: 1_000,
        }
    }

    pub fn state(&self) -> ExecState {
        self.exec.core().state()
    }

    /// Runs until the trial is over (done, aborted or faulted) or `max_us` passes.
    pub fn run(&mut self, max_us: u64) {
        while self.now_us < max_us && self.phase != Phase::Over {
            self.step();
        }
    }

    /// Runs `dt_us` more.
    pub fn run_for(&mut self, dt_us: u64) {
        let end = self.now_us + dt_us;
        while self.now_us < end {
            self.step();
        }
    }

    pub fn step(&mut self) {
        self.now_us += STEP_US;
        let now = self.now_us;
        let mut entries = Vec::new();
        let mut log = |e: &LogEvent| entries.push((now, Entry::Exec(*e)));
        while let Some(b) = self.lines[0].recv(now) {
            self.node.on_bytes(now, &b);
        }
        while let Some(b) = self.lines[1].recv(now) {
            self.exec.on_ctrl_bytes(now, &b, &mut log).expect("room");
        }
        while let Some(b) = self.lines[2].recv(now) {
            self.exec.on_host_bytes(now, &b, &mut log).expect("room");
        }
        self.node.tick(now);
        if let Some(frame) = self.camera.poll(now, &mut self.world) {
            let cam = CameraFrame {
                frame_seq: frame.frame_seq,
                driver_stamp_us: Some(frame.exposure_sim_us),
                black: frame.black,
            };
            self.exec.on_frame(now, cam, &mut log).expect("room");
        }
        self.exec.poll(now, &mut log).expect("room");
        self.log.extend(entries);
        self.host_side(now);
        self.transmit(now);
        self.node.step_world(now, &mut self.world);
    }

    fn transmit(&mut self, now: u64) {
        let mut buf = [0u8; FRAME_BUF_LEN];
        while let Some(f) = self.exec.transmit_ctrl(now, &mut buf) {
            self.lines[0].send(now, f);
        }
        while let Some(f) = self.node.transmit(now, &mut buf) {
            self.lines[1].send(now, f);
        }
        while let Some(f) = self.exec.transmit_host(now, &mut buf) {
            self.lines[3].send(now, f);
        }
        while let Some(frame) = self.host.poll_transmit(now) {
            let f = encode_frame(&frame, &mut buf).expect("fits");
            self.lines[2].send(now, f);
        }
    }

    fn host_side(&mut self, now: u64) {
        let _ = self.host.poll(now);
        while let Some(b) = self.lines[3].recv(now) {
            for &byte in &b {
                let Some(Ok(frame)) = self.host_reader.push_byte(byte) else { continue };
                if let Some(msg) = self.host.on_bytes(now, frame) {
                    self.on_host_msg(now, msg);
                }
            }
        }
        if now % 100_000 < STEP_US {
            let _ = self.host.send(HostToExec::Heartbeat { host_time_us: now });
        }
        if now >= self.next_host_action_us {
            self.host_action(now);
        }
    }

    fn host_action(&mut self, now: u64) {
        self.next_host_action_us = u64::MAX;
        match self.phase {
            Phase::Hello => {
                let _ = self.host.send(HostToExec::Hello(Hello::CURRENT));
            }
            Phase::Flashing => {
                let image: Vec<u8> = self.plan.iter().flat_map(|s| s.to_image_bytes()).collect();
                let header = FlashHeader::for_image(42, &image).expect("whole steps");
                let _ = self.host.send(HostToExec::FlashBegin(header));
                for chunk in image_chunks(42, &image) {
                    self.host.send(HostToExec::FlashChunk(chunk)).expect("window holds the plan");
                }
                let _ = self.host.send(HostToExec::FlashCommit { plan_id: 42 });
            }
            Phase::Arming => {
                let _ = self.host.send(HostToExec::Arm { plan_id: 42, start: start_point() });
            }
            Phase::Running | Phase::Over => {}
        }
        let _ = now;
    }

    fn on_host_msg(&mut self, now: u64, msg: ExecToHost) {
        self.log.push((now, Entry::Host(msg.clone())));
        match msg {
            ExecToHost::HelloReply { accepted: true, .. } => self.next(Phase::Flashing, now),
            ExecToHost::FlashAccepted { .. } => self.next(Phase::Arming, now + 300_000),
            ExecToHost::CommandRejected(CommandRejectReason::NotReady { .. }) => {
                self.next(Phase::Arming, now + 50_000)
            }
            ExecToHost::Status(s) if s.state == ExecState::Armed && self.phase == Phase::Arming => {
                self.phase = Phase::Running;
                let _ = self.host.send(HostToExec::Start { plan_id: 42 });
            }
            ExecToHost::Trial(t) if t.kind != TrialEventKind::Started => self.phase = Phase::Over,
            _ => {}
        }
    }

    fn next(&mut self, phase: Phase, at_us: u64) {
        self.phase = phase;
        self.next_host_action_us = at_us;
    }

    /// Segment ids the controller applied, in order.
    pub fn applied(&self) -> Vec<u32> {
        self.node
            .events
            .iter()
            .filter_map(|(_, e)| match e {
                NodeEvent::Ctrl(CtrlEvent::Applied(id)) => Some(*id),
                _ => None,
            })
            .collect()
    }

    /// Trial events the host received.
    pub fn trial_events(&self) -> Vec<TrialEventKind> {
        self.log
            .iter()
            .filter_map(|(_, e)| match e {
                Entry::Host(ExecToHost::Trial(t)) => Some(t.kind),
                _ => None,
            })
            .collect()
    }
}
