//! The host's side of the executor's line as a sans-IO state machine: handshake, flash the
//! plan in chunks, arm at the plan's stated start (retrying while the executor is not
//! ready), start, heartbeat, and wait for the trial's end — or one rig command between
//! trials (status, goto, home, stop) and its answer. Bytes in, bytes out, time passed in —
//! the same code drives the simulated-time loop, the real-time loop and `mesopush flash` /
//! `run` / `rig`.

use crate::Error;
use mesopush_core::geom::Vec2;
use mesopush_protocol::flash::{FlashHeader, PlanStep, image_chunks};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecStatus, ExecToHost, Hello, HostToExec, MotionEventKind,
    StagePoint, TrialEventKind,
};
use mesopush_protocol::units::{um_s_to_nm_s, um_to_nm};
use mesopush_protocol::{FRAME_BUF_LEN, FrameReader, Link, LinkConfig, LinkStats, encode_frame};
use mesopush_sim::Plan;
use std::collections::VecDeque;

/// Link window of the host line.
pub const HOST_WINDOW: usize = 32;
/// Heartbeat period, µs.
const HEARTBEAT_US: u64 = 100_000;
/// Wait after the plan is accepted before arming (clock sync needs a few round trips), µs.
const ARM_DELAY_US: u64 = 300_000;
/// Retry period of a refused arm (not ready yet), µs.
const ARM_RETRY_US: u64 = 50_000;
/// Arm attempts before giving up.
const ARM_ATTEMPTS: u32 = 100;

/// What the session should do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionGoal {
    /// Flash the plan and stop there.
    Flash,
    /// Arm and start the plan already flashed (by id).
    Run,
    /// Flash, arm, start.
    FlashAndRun,
    /// One rig command between trials.
    Command(RigCommand),
}

/// A rig command between trials.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RigCommand {
    /// Ask for the status (state, absolute position, last fault).
    Status,
    /// Move the probe to a stage position and wait until it is there.
    Goto(StagePoint),
    /// Move the probe to the executor's home position.
    Home,
    /// Stop the probe now.
    Stop,
}

/// How the session ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SessionEnd {
    /// The plan was accepted (goal `Flash`).
    Accepted {
        /// Steps in it.
        step_count: u32,
    },
    /// The executor refused the upload or the handshake; the text says what and why.
    Refused(String),
    /// The executor refused a command (arm, start, goto, ...); its `Display` says why and
    /// what to do.
    Rejected(CommandRejectReason),
    /// The trial ended.
    Trial(TrialEventKind),
    /// The executor's status (answer to `Status` and `Stop`).
    Status(ExecStatus),
    /// A goto or home ended (arrived, stopped or faulted).
    Motion(MotionEventKind),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Hello,
    Flashing,
    Arming,
    Starting,
    Running,
    Command,
    Moving,
    Over,
}

/// The host's session with an executor.
#[derive(Debug)]
pub struct HostSession {
    link: Link<HostToExec, ExecToHost, HOST_WINDOW>,
    reader: FrameReader<FRAME_BUF_LEN>,
    goal: SessionGoal,
    image: Vec<u8>,
    plan_id: u32,
    start: StagePoint,
    phase: Phase,
    next_action_us: u64,
    next_heartbeat_us: u64,
    arm_attempts: u32,
    end: Option<SessionEnd>,
    outbox: VecDeque<HostToExec>,
    /// Every message received, in order, with its receive time (for the recorder).
    pub inbox: Vec<(u64, ExecToHost)>,
}

/// The plan as the executor's steps (wire units; moves relative to the probe's start).
pub fn plan_steps(plan: &Plan) -> Result<Vec<PlanStep>, Error> {
    let speed_nm_s = um_s_to_nm_s("plan speed", plan.speed_um_s)?;
    plan.moves_um
        .iter()
        .map(|[dx, dy]| {
            Ok(PlanStep {
                dx_nm: um_to_nm("plan move x", *dx)?,
                dy_nm: um_to_nm("plan move y", *dy)?,
                speed_nm_s,
            })
        })
        .collect()
}

/// Where `plan` starts in the stage's frame: its `probe_start_um` (fixture frame) plus the
/// fixture origin in stage coordinates (`offset_um`, the stage registration), in nm —
/// refused, naming the value, when it does not fit the wire.
pub fn plan_start(plan: &Plan, offset_um: Vec2) -> Result<StagePoint, Error> {
    let p = plan.probe_start() + offset_um;
    Ok(StagePoint {
        x_nm: um_to_nm("plan start x + stage offset x", p.x)?,
        y_nm: um_to_nm("plan start y + stage offset y", p.y)?,
    })
}

/// The plan's flash image and its id (the image's CRC: the same plan, the same id).
pub fn plan_image(plan: &Plan) -> Result<(u32, Vec<u8>), Error> {
    steps_image(&plan_steps(plan)?)
}

/// The flash image of `steps` and its id (the image's CRC).
pub fn steps_image(steps: &[PlanStep]) -> Result<(u32, Vec<u8>), Error> {
    let image: Vec<u8> = steps.iter().flat_map(|s| s.to_image_bytes()).collect();
    let header = FlashHeader::for_image(0, &image)
        .map_err(|e| Error::invalid("plan image", e.to_string()))?;
    Ok((header.image_crc32.max(1), image))
}

impl HostSession {
    /// A session for `plan` towards `goal`; `start` is the plan's start in the stage frame
    /// ([`plan_start`]), stated when arming; `session_id` is the link session (differs from
    /// the last one's).
    pub fn new(
        plan: &Plan,
        goal: SessionGoal,
        start: StagePoint,
        session_id: u16,
    ) -> Result<Self, Error> {
        let (plan_id, image) = plan_image(plan)?;
        Ok(Self::with(goal, image, plan_id, start, session_id))
    }

    /// A session for executor steps built by the host itself (each with its own speed, which
    /// a [`Plan`] cannot express; e.g. `mesopush calibrate`'s moves and pauses).
    pub fn with_steps(
        steps: &[PlanStep],
        goal: SessionGoal,
        start: StagePoint,
        session_id: u16,
    ) -> Result<Self, Error> {
        let (plan_id, image) = steps_image(steps)?;
        Ok(Self::with(goal, image, plan_id, start, session_id))
    }

    /// A session that sends one rig command and waits for its answer (a goto: its end).
    pub fn command(command: RigCommand, session_id: u16) -> Self {
        let origin = StagePoint { x_nm: 0, y_nm: 0 };
        Self::with(SessionGoal::Command(command), Vec::new(), 0, origin, session_id)
    }

    fn with(
        goal: SessionGoal,
        image: Vec<u8>,
        plan_id: u32,
        start: StagePoint,
        session_id: u16,
    ) -> Self {
        Self {
            link: Link::new(LinkConfig::DEFAULT, session_id),
            reader: FrameReader::new(),
            goal,
            image,
            plan_id,
            start,
            phase: Phase::Hello,
            next_action_us: 0,
            next_heartbeat_us: 0,
            arm_attempts: 0,
            end: None,
            outbox: VecDeque::new(),
            inbox: Vec::new(),
        }
    }

    /// The host end's link counters (corrupt frames, duplicates, retransmissions, ...).
    pub fn link_stats(&self) -> LinkStats {
        self.link.stats()
    }

    /// The plan's id.
    pub fn plan_id(&self) -> u32 {
        self.plan_id
    }

    /// How the session ended, once it has.
    pub fn end(&self) -> Option<&SessionEnd> {
        self.end.as_ref()
    }

    /// Whether the trial is running.
    pub fn running(&self) -> bool {
        self.phase == Phase::Running
    }

    /// Asks the executor to abort the trial.
    pub fn abort(&mut self) {
        self.send(HostToExec::Abort);
    }

    /// Bytes from the executor.
    pub fn on_bytes(&mut self, now_us: u64, bytes: &[u8]) {
        for &b in bytes {
            let Some(Ok(frame)) = self.reader.push_byte(b) else { continue };
            if let Some(msg) = self.link.on_bytes(now_us, frame) {
                self.on_msg(now_us, &msg);
                self.inbox.push((now_us, msg));
            }
        }
    }

    /// Timers: heartbeats, scheduled actions, link retransmissions. A link that gives up is
    /// an error.
    pub fn poll(&mut self, now_us: u64) -> Result<(), Error> {
        if self.link.poll(now_us).is_err() {
            return Err(Error::invalid("host link", "the executor stopped answering"));
        }
        if now_us >= self.next_heartbeat_us {
            self.next_heartbeat_us = now_us + HEARTBEAT_US;
            self.send(HostToExec::Heartbeat { host_time_us: now_us });
        }
        if now_us >= self.next_action_us {
            self.next_action_us = u64::MAX;
            self.act();
        }
        Ok(())
    }

    /// Queues a message (sent as the link's window allows; never lost).
    fn send(&mut self, msg: HostToExec) {
        self.outbox.push_back(msg);
        self.flush();
    }

    fn flush(&mut self) {
        while let Some(msg) = self.outbox.pop_front() {
            if let Err(msg) = self.link.send(msg) {
                self.outbox.push_front(msg);
                break;
            }
        }
    }

    /// The next frame for the executor, encoded into `buf`.
    pub fn transmit<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        self.flush();
        let frame = self.link.poll_transmit(now_us)?;
        encode_frame(&frame, buf).ok()
    }

    fn act(&mut self) {
        match self.phase {
            Phase::Hello => {
                self.send(HostToExec::Hello(Hello::CURRENT));
            }
            Phase::Flashing => self.send_flash(),
            Phase::Arming => {
                self.arm_attempts += 1;
                self.send(HostToExec::Arm { plan_id: self.plan_id, start: self.start });
            }
            Phase::Command => {
                self.arm_attempts += 1;
                let SessionGoal::Command(command) = self.goal else { return };
                self.send(match command {
                    RigCommand::Status => HostToExec::StatusQuery,
                    RigCommand::Goto(target) => HostToExec::Goto { target },
                    RigCommand::Home => HostToExec::Home,
                    RigCommand::Stop => HostToExec::Stop,
                });
            }
            Phase::Starting | Phase::Running | Phase::Moving | Phase::Over => {}
        }
    }

    fn send_flash(&mut self) {
        let header = FlashHeader::for_image(self.plan_id, &self.image).expect("checked at new");
        self.send(HostToExec::FlashBegin(header));
        let chunks: Vec<_> = image_chunks(self.plan_id, &self.image).collect();
        for chunk in chunks {
            self.send(HostToExec::FlashChunk(chunk));
        }
        self.send(HostToExec::FlashCommit { plan_id: self.plan_id });
    }

    fn finish(&mut self, end: SessionEnd) {
        self.phase = Phase::Over;
        self.end = Some(end);
    }

    fn on_msg(&mut self, now_us: u64, msg: &ExecToHost) {
        match (self.phase, msg) {
            (Phase::Hello, ExecToHost::HelloReply { accepted: true, .. }) => {
                self.phase = match self.goal {
                    SessionGoal::Run => Phase::Arming,
                    SessionGoal::Command(_) => Phase::Command,
                    _ => Phase::Flashing,
                };
                self.next_action_us = now_us;
            }
            (Phase::Hello, ExecToHost::HelloReply { accepted: false, hello }) => {
                self.finish(SessionEnd::Refused(format!(
                    "the executor speaks protocol {} (schema {:08x}), this host {} (schema \
                     {:08x}); install matching builds",
                    hello.protocol_version,
                    hello.schema_hash,
                    Hello::CURRENT.protocol_version,
                    Hello::CURRENT.schema_hash
                )))
            }
            (Phase::Flashing, ExecToHost::FlashAccepted { step_count, .. }) => {
                if self.goal == SessionGoal::Flash {
                    self.finish(SessionEnd::Accepted { step_count: *step_count });
                } else {
                    self.phase = Phase::Arming;
                    self.next_action_us = now_us + ARM_DELAY_US;
                }
            }
            (Phase::Flashing, ExecToHost::FlashRejected { reason, .. }) => {
                self.finish(SessionEnd::Refused(format!("plan refused: {reason}")))
            }
            (
                Phase::Arming | Phase::Command,
                ExecToHost::CommandRejected(CommandRejectReason::NotReady { .. }),
            ) if self.arm_attempts < ARM_ATTEMPTS => {
                self.next_action_us = now_us + ARM_RETRY_US;
            }
            (Phase::Arming | Phase::Starting | Phase::Command, ExecToHost::CommandRejected(r)) => {
                self.finish(SessionEnd::Rejected(*r))
            }
            (Phase::Command, ExecToHost::Status(s)) => self.finish(SessionEnd::Status(*s)),
            (Phase::Command | Phase::Moving, ExecToHost::Motion(m)) => match m.kind {
                MotionEventKind::Started { .. } => self.phase = Phase::Moving,
                kind => self.finish(SessionEnd::Motion(kind)),
            },
            (Phase::Arming, ExecToHost::Status(s)) if s.state == ExecState::Armed => {
                self.phase = Phase::Starting;
                self.send(HostToExec::Start { plan_id: self.plan_id });
            }
            (Phase::Starting | Phase::Running, ExecToHost::Trial(t)) => match t.kind {
                TrialEventKind::Started => self.phase = Phase::Running,
                kind => self.finish(SessionEnd::Trial(kind)),
            },
            _ => {}
        }
    }
}
