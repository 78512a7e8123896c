//! The whole loop in simulated time, on one thread: host session → executor endpoint (the
//! allocation-free core) → controller line over a real pseudo-terminal (lock-stepped, see
//! [`super::pty`]) → firmware-simulator controller node → stage → world → camera → executor
//! stamps → recorder. Every line passes a seeded [`SimLine`] that injects the world file's
//! faults on the way; one seed drives everything, so the same seed gives the same run.

use super::ctrl_line::CtrlLine;
use super::endpoint::{ExecEndpoint, endpoint_for};
use super::faults::{FaultClasses, FaultCount};
use super::pty::PtyLine;
use super::recorder::RecMsg;
use super::udp::UdpLine;
use crate::Error;
use crate::client::session::HostSession;
use crate::plant::assemble::CameraTiming;
use crate::plant::controller::{applied_segments, controller};
use crate::plant::vendor::{EmulatorBox, Plant, emulator};
use crate::plant::world::RigWorld;
use crossbeam_channel::Sender;
use mesopush_executor::shell::controller::ControllerKind;
use mesopush_executor::{CameraFrame, ExecutorConfig, LogEvent};
use mesopush_firmware_sim::camera::SimCamera;
use mesopush_firmware_sim::line::SimLine;
use mesopush_firmware_sim::{CtrlEvent, FaultConfig, NodeEvent, SimRng};
use mesopush_protocol::{FRAME_BUF_LEN, LinkStats};

/// Simulation step, µs.
pub const STEP_US: u64 = 100;

/// Everything in the loop.
#[derive(Debug)]
pub struct SimLoop {
    /// Simulated time, µs (also the executor's clock).
    pub now_us: u64,
    /// The executor.
    pub exec: ExecEndpoint,
    /// The controller.
    pub node: Plant,
    /// The controller's line.
    pub pty: CtrlLine,
    /// Simulated lines: exec→ctrl, ctrl→exec, host→exec, exec→host.
    pub lines: [SimLine; 4],
    /// The host.
    pub host: HostSession,
    /// The camera.
    pub camera: SimCamera,
    /// The world.
    pub world: RigWorld,
    tx: Sender<RecMsg>,
    logs: Vec<LogEvent>,
    scratch: Vec<u8>,
    node_events_seen: usize,
    /// Camera faults the executor reported while stamping frames: frames missing from the
    /// counter, and frames the camera delivered black.
    camera_detected: u64,
    /// Records not yet handed to the recorder (see [`SimLoop::flush`]).
    pending: Vec<RecMsg>,
}

/// Records handed to the recorder in one batch at most (also flushed at every frame).
const BATCH_RECORDS: usize = 512;

impl SimLoop {
    /// Builds the loop; `probe_start_nm` is the stage's start, stage nm.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        rng: &SimRng,
        kind: ControllerKind,
        config: ExecutorConfig,
        faults: FaultConfig,
        probe_start_nm: (i32, i32),
        host: HostSession,
        world: RigWorld,
        camera: CameraTiming,
        tx: Sender<RecMsg>,
    ) -> Result<Self, Error> {
        let session = 1 + rng.fork(10).below(1000) as u16;
        let exec = endpoint_for(kind, config, session)?;
        let limit_um = world.deflection_limit_um();
        let (node, line) = match kind {
            ControllerKind::Native => {
                let node = controller(faults, rng.fork(1), 0, probe_start_nm, limit_um)?;
                (Plant::Native(Box::new(node)), CtrlLine::Pty(PtyLine::open()?))
            }
            k => {
                let seed = rng.fork(1).below(u64::MAX);
                let emu = EmulatorBox(emulator(k, probe_start_nm, 0, seed)?);
                let line = match k {
                    ControllerKind::Sensapex => CtrlLine::Udp(UdpLine::open()?),
                    _ => CtrlLine::Pty(PtyLine::open()?),
                };
                (Plant::Vendor(emu), line)
            }
        };
        let cam = SimCamera::new(
            camera.period_us,
            camera.readout_us,
            camera.start_us,
            rng.fork(6),
            faults,
        );
        Ok(Self {
            now_us: 0,
            exec,
            node,
            pty: line,
            lines: [2, 3, 4, 5].map(|s| SimLine::new(rng.fork(s), faults)),
            host,
            camera: cam,
            world,
            tx,
            logs: Vec::with_capacity(64),
            scratch: Vec::with_capacity(FRAME_BUF_LEN),
            node_events_seen: 0,
            camera_detected: 0,
            pending: Vec::with_capacity(BATCH_RECORDS),
        })
    }

    fn send(&mut self, msg: RecMsg) -> Result<(), Error> {
        let frame = matches!(msg, RecMsg::Frame { .. });
        self.pending.push(msg);
        if frame || self.pending.len() >= BATCH_RECORDS { self.flush() } else { Ok(()) }
    }

    /// Hands the pending records to the recorder in one message. Simulated time waits for
    /// the recorder (deterministic; time is not real here); order is kept.
    pub fn flush(&mut self) -> Result<(), Error> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let batch = std::mem::replace(&mut self.pending, Vec::with_capacity(BATCH_RECORDS));
        self.tx
            .send(RecMsg::Batch(batch))
            .map_err(|_| Error::invalid("recorder", "the recorder thread stopped early"))
    }

    /// One step of simulated time.
    pub fn step(&mut self) -> Result<(), Error> {
        self.now_us += STEP_US;
        let now = self.now_us;
        let logs = &mut self.logs;
        let mut log = |e: &LogEvent| logs.push(*e);
        let full = |e: mesopush_executor::ExecError| Error::invalid("executor", e.to_string());
        while let Some(b) = self.lines[0].recv(now) {
            self.node.on_bytes(now, &b);
        }
        while let Some(b) = self.lines[1].recv(now) {
            self.exec.on_ctrl_bytes(now, &b, &mut log).map_err(full)?;
        }
        while let Some(b) = self.lines[2].recv(now) {
            self.exec.on_host_bytes(now, &b, &mut log).map_err(full)?;
        }
        while let Some(b) = self.lines[3].recv(now) {
            self.host.on_bytes(now, &b);
        }
        self.node.tick(now);
        let mut frame_msg = None;
        if let Some(frame) = self.camera.poll(now, &mut self.world) {
            let cam = CameraFrame {
                frame_seq: frame.frame_seq,
                // Late by the world's camera latency, if it has one.
                driver_stamp_us: Some(self.world.driver_stamp_us(frame.exposure_sim_us)),
                black: frame.black,
            };
            self.exec.on_frame(now, cam, &mut log).map_err(full)?;
            frame_msg = Some(frame.image.map(|f| f.image));
        }
        self.exec.poll(now, &mut log).map_err(full)?;
        self.host.poll(now)?;
        self.transmit(now)?;
        self.node.step_world(now, &mut self.world);
        self.forward(now, frame_msg)
    }

    fn transmit(&mut self, now: u64) -> Result<(), Error> {
        let mut buf = [0u8; FRAME_BUF_LEN];
        while let Some(f) = self.exec.transmit_ctrl(now, &mut buf) {
            self.pty.exec_to_sim(f, &mut self.scratch)?;
            self.lines[0].send(now, &self.scratch);
        }
        while let Some(f) = self.node.transmit(now, &mut buf) {
            self.pty.sim_to_exec(f, &mut self.scratch)?;
            self.lines[1].send(now, &self.scratch);
        }
        while let Some(f) = self.exec.transmit_host(now, &mut buf) {
            self.lines[3].send(now, f);
        }
        while let Some(f) = self.host.transmit(now, &mut buf) {
            self.lines[2].send(now, f);
        }
        Ok(())
    }

    fn forward(&mut self, now: u64, frame: Option<Option<image::GrayImage>>) -> Result<(), Error> {
        let mut stamped = None;
        for e in std::mem::take(&mut self.logs) {
            if let LogEvent::Frame(s) = e {
                if let mesopush_executor::camera::SeqCheck::Gap { dropped } = s.seq {
                    self.camera_detected += u64::from(dropped);
                }
                self.camera_detected += u64::from(s.black);
                stamped = Some(s);
            }
            self.send(RecMsg::Log(now, e))?;
        }
        if let (Some(image), Some(stamped)) = (frame, stamped) {
            self.send(RecMsg::Frame { stamped, arrival_us: now, image })?;
        }
        for (t, msg) in std::mem::take(&mut self.host.inbox) {
            self.send(RecMsg::Host(t, msg))?;
        }
        let events = self.node.events();
        let new: Vec<(u64, NodeEvent)> = events[self.node_events_seen..].to_vec();
        self.node_events_seen = events.len();
        for (t, e) in new {
            let (kind, detail) = match e {
                NodeEvent::InjectedStall => {
                    ("injected_stall", "the world stalled the stage (injected)".to_string())
                }
                NodeEvent::InjectedLimitSwitch => (
                    "injected_limit_switch",
                    "the world tripped a limit switch (injected)".to_string(),
                ),
                NodeEvent::Rebooted { boot_count } => (
                    "injected_reboot",
                    format!("the world rebooted the controller (injected; boot {boot_count})"),
                ),
                NodeEvent::LinkDown => (
                    "ctrl_link_down",
                    "the controller's link gave up and was restarted".to_string(),
                ),
                NodeEvent::OutboxOverflow => (
                    "ctrl_outbox_overflow",
                    "the controller dropped a message (its outbox was full)".to_string(),
                ),
                // The controller's own fault (it halts the stage and reports it): where the
                // executor's stop bound starts for a stall or a limit switch.
                NodeEvent::Ctrl(CtrlEvent::Faulted(code)) => ("ctrl_fault", code.to_string()),
                NodeEvent::Ctrl(_) => continue,
            };
            self.send(RecMsg::Event(t, kind.into(), detail))?;
        }
        Ok(())
    }

    /// Segments the controller applied, and whether their ids ran consecutively (every
    /// move exactly once, in order). A point-to-point controller: the moves its adapter saw
    /// completed at their targets (one per plan step; the adapter runs them in order).
    pub fn applied(&self) -> (u64, bool) {
        match self.exec.moves_done() {
            Some(done) => (done, true),
            None => applied_segments(self.node.events()),
        }
    }

    /// Ends the loop (handing over the pending records, then closing the recorder's
    /// channel) and hands back the world.
    pub fn into_world(mut self) -> Result<RigWorld, Error> {
        let flushed = self.flush();
        let Self { world, .. } = self;
        flushed.map(|()| world)
    }

    /// Faults the world injected so far (line faults, stage faults, camera drops and black
    /// frames).
    pub fn faults_injected(&self) -> u64 {
        self.fault_classes().total().injected
    }

    /// Faults by class: injected ones (every line, the stage, the camera), and the
    /// detections the loop can see — the executor's controller-link counters and the camera
    /// faults it reported while stamping frames. The controller's detections (trial faults)
    /// are the recorder's; the trial adds them.
    pub fn fault_classes(&self) -> FaultClasses {
        let line = |l: &SimLine| {
            let s = l.stats();
            s.dropped + s.corrupted + s.duplicated + s.delayed
        };
        let stage = self
            .node
            .events()
            .iter()
            .filter(|(_, e)| {
                matches!(
                    e,
                    NodeEvent::InjectedStall
                        | NodeEvent::InjectedLimitSwitch
                        | NodeEvent::Rebooted { .. }
                )
            })
            .count() as u64;
        let seen = |l: LinkStats| l.corrupt + l.duplicates + l.out_of_order + l.retransmissions;
        FaultClasses {
            camera: FaultCount {
                injected: self.camera.dropped + self.camera.black,
                detected: self.camera_detected,
            },
            controller: FaultCount { injected: stage, detected: 0 },
            exec_ctrl_link: FaultCount {
                injected: line(&self.lines[0]) + line(&self.lines[1]),
                detected: seen(self.exec.ctrl_link_stats()),
            },
            host_exec_link: FaultCount {
                injected: line(&self.lines[2]) + line(&self.lines[3]),
                detected: seen(self.exec.host_link_stats()) + seen(self.host.link_stats()),
            },
        }
    }
}
