//! The controller on the wire: [`Controller`] plus its clock, reliable link, framing and the
//! injected stage faults and reboots, in simulation time.
//!
//! Clocks: the simulation's time `sim_us` is also the executor's clock in the test loops;
//! the controller's clock is `ctrl = epoch + (sim − boot) × (1 + drift_ppm · 10⁻⁶)`, with a
//! new epoch at every boot, so the executor really has to sync. Injected faults (stall and
//! limit switch per second of motion, reboot per second) are drawn every tick from the
//! node's own random stream; a reboot restarts the clock, the queue and the link (new
//! session) and the fresh controller reports `Fault(Reboot)`. Messages wait in a bounded
//! outbox while the link window is full; overflow is counted, never silent.

use crate::config::{CtrlConfig, FaultConfig};
use crate::controller::{Controller, CtrlEvent, CtrlOutput};
use crate::rng::SimRng;
use crate::world::{PegPose, World};
use mesopush_protocol::{
    CtrlToExec, ExecToCtrl, FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame,
};
use std::collections::VecDeque;

/// Outbox bound, messages.
const OUTBOX: usize = 256;

/// Something the node did or had done to it, for the simulation log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeEvent {
    /// From the controller core.
    Ctrl(CtrlEvent),
    /// Injected: the stage stalls.
    InjectedStall,
    /// Injected: a limit switch trips.
    InjectedLimitSwitch,
    /// Injected: the controller reboots.
    Rebooted {
        /// Boots so far.
        boot_count: u16,
    },
    /// The controller's link gave up and was restarted.
    LinkDown,
    /// An outgoing message was dropped because the outbox was full.
    OutboxOverflow,
}

/// The controller's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeClock {
    /// Controller time at boot, µs.
    pub epoch_us: u64,
    /// Simulation time of the boot, µs.
    pub boot_sim_us: u64,
    /// Rate error of the controller's crystal, parts per million.
    pub drift_ppm: i64,
}

impl NodeClock {
    /// Controller time at simulation time `sim_us`.
    pub fn ctrl_us(&self, sim_us: u64) -> u64 {
        let since = sim_us.saturating_sub(self.boot_sim_us) as i64;
        (self.epoch_us as i64 + since + since * self.drift_ppm / 1_000_000) as u64
    }
}

/// A simulated controller on a serial line; `Q` queue slots, link window `W`.
#[derive(Debug)]
pub struct ControllerNode<const Q: usize, const W: usize> {
    cfg: CtrlConfig,
    faults: FaultConfig,
    rng: SimRng,
    ctrl: Controller<Q>,
    link: Link<CtrlToExec, ExecToCtrl, W>,
    link_config: LinkConfig,
    reader: FrameReader<FRAME_BUF_LEN>,
    outbox: VecDeque<CtrlToExec>,
    clock: NodeClock,
    session_base: u16,
    boot_count: u16,
    last_tick_sim_us: u64,
    /// Everything that happened, with simulation time, in order.
    pub events: Vec<(u64, NodeEvent)>,
}

impl<const Q: usize, const W: usize> ControllerNode<Q, W> {
    /// Powers up at `sim_us` with the probe at `probe_nm`; randomness from `rng`.
    pub fn new(
        cfg: CtrlConfig,
        faults: FaultConfig,
        link_config: LinkConfig,
        mut rng: SimRng,
        sim_us: u64,
        probe_nm: (f64, f64),
    ) -> Self {
        let epoch_us = rng.below(10_000_000);
        let drift_ppm = rng.below(101) as i64 - 50;
        let session_base = rng.below(u64::from(u16::MAX / 2)) as u16;
        let clock = NodeClock { epoch_us, boot_sim_us: sim_us, drift_ppm };
        let mut events = Vec::new();
        let ctrl = Controller::boot(cfg, clock.ctrl_us(sim_us), probe_nm, false, &mut |o| {
            if let CtrlOutput::Event(e) = o {
                events.push((sim_us, NodeEvent::Ctrl(e)));
            }
        });
        Self {
            cfg,
            faults,
            rng,
            ctrl,
            link: Link::new(link_config, session_base),
            link_config,
            reader: FrameReader::new(),
            outbox: VecDeque::new(),
            clock,
            session_base,
            boot_count: 0,
            last_tick_sim_us: sim_us,
            events,
        }
    }

    /// The controller core.
    pub fn controller(&self) -> &Controller<Q> {
        &self.ctrl
    }

    /// Mutable access to the core (to inject a fault by hand).
    pub fn controller_mut(&mut self) -> &mut Controller<Q> {
        &mut self.ctrl
    }

    /// The controller's clock.
    pub fn clock(&self) -> NodeClock {
        self.clock
    }

    /// True probe position, nm (rounded).
    pub fn probe_nm(&self) -> (i32, i32) {
        let p = self.ctrl.stage().pos_nm;
        (p.0.round() as i32, p.1.round() as i32)
    }

    /// Steps `world` to `sim_us` with the probe where the stage is, then senses the needle's
    /// deflection when the world reports it ([`Controller::sense_needle`]); returns the peg's
    /// pose. Every loop reaches the world through this, so the controller sees what the
    /// world's needle does.
    pub fn step_world<P: World>(&mut self, sim_us: u64, world: &mut P) -> PegPose {
        let pose = world.step(sim_us, self.probe_nm());
        if let Some(d) = world.needle_deflection_nm() {
            self.sense_needle(sim_us, d);
        }
        pose
    }

    /// The needle's deflection sensed at `sim_us`, nm (see [`Controller::sense_needle`]).
    pub fn sense_needle(&mut self, sim_us: u64, deflection_nm: i32) {
        let now_ctrl = self.clock.ctrl_us(sim_us);
        let (ctrl, outbox, events) = (&mut self.ctrl, &mut self.outbox, &mut self.events);
        ctrl.sense_needle(now_ctrl, deflection_nm, &mut |o| route(o, sim_us, outbox, events));
    }

    /// Bytes from the executor's line.
    pub fn on_bytes(&mut self, sim_us: u64, bytes: &[u8]) {
        let now_ctrl = self.clock.ctrl_us(sim_us);
        for &byte in bytes {
            let Some(Ok(frame)) = self.reader.push_byte(byte) else { continue };
            if let Some(msg) = self.link.on_bytes(sim_us, frame) {
                let (ctrl, outbox, events) = (&mut self.ctrl, &mut self.outbox, &mut self.events);
                ctrl.handle(now_ctrl, &msg, &mut |o| route(o, sim_us, outbox, events));
            }
        }
    }

    /// Advances to `sim_us`: injected faults, the controller, link timeouts.
    pub fn tick(&mut self, sim_us: u64) {
        let dt_s = sim_us.saturating_sub(self.last_tick_sim_us) as f64 * 1e-6;
        self.last_tick_sim_us = sim_us;
        self.inject(sim_us, dt_s);
        let now_ctrl = self.clock.ctrl_us(sim_us);
        let (ctrl, outbox, events) = (&mut self.ctrl, &mut self.outbox, &mut self.events);
        ctrl.tick(now_ctrl, &mut |o| route(o, sim_us, outbox, events));
        if self.link.poll(sim_us).is_err() {
            self.events.push((sim_us, NodeEvent::LinkDown));
            let session = self.link.session().wrapping_add(1);
            self.link.reset(session);
        }
    }

    fn inject(&mut self, sim_us: u64, dt_s: f64) {
        let moving = self.ctrl.state() == mesopush_protocol::ctrl::CtrlState::Moving;
        let f = self.faults;
        if moving && self.rng.chance(f.stall_per_s * dt_s) {
            self.events.push((sim_us, NodeEvent::InjectedStall));
            self.ctrl.inject_stall();
        }
        if moving && self.rng.chance(f.limit_switch_per_s * dt_s) {
            self.events.push((sim_us, NodeEvent::InjectedLimitSwitch));
            self.ctrl.inject_limit_switch();
        }
        if self.rng.chance(f.reboot_per_s * dt_s) {
            self.reboot(sim_us);
        }
    }

    /// Reboots now: new clock epoch, empty queue, new link session, `Fault(Reboot)`.
    pub fn reboot(&mut self, sim_us: u64) {
        self.boot_count = self.boot_count.wrapping_add(1);
        self.events.push((sim_us, NodeEvent::Rebooted { boot_count: self.boot_count }));
        self.clock.epoch_us = self.rng.below(10_000_000);
        self.clock.boot_sim_us = sim_us;
        self.outbox.clear();
        self.reader.clear();
        self.link = Link::new(self.link_config, self.session_base.wrapping_add(self.boot_count));
        let pos = self.ctrl.stage().pos_nm;
        let now_ctrl = self.clock.ctrl_us(sim_us);
        let (outbox, events) = (&mut self.outbox, &mut self.events);
        self.ctrl = Controller::boot(self.cfg, now_ctrl, pos, true, &mut |o| {
            route(o, sim_us, outbox, events)
        });
    }

    /// The next frame for the executor, encoded into `buf`.
    pub fn transmit<'b>(&mut self, sim_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        while let Some(msg) = self.outbox.pop_front() {
            if let Err(msg) = self.link.send(msg) {
                self.outbox.push_front(msg);
                break;
            }
        }
        let frame = self.link.poll_transmit(sim_us)?;
        encode_frame(&frame, buf).ok()
    }
}

fn route(
    o: CtrlOutput,
    sim_us: u64,
    outbox: &mut VecDeque<CtrlToExec>,
    events: &mut Vec<(u64, NodeEvent)>,
) {
    match o {
        CtrlOutput::Msg(m) if outbox.len() < OUTBOX => outbox.push_back(m),
        CtrlOutput::Msg(_) => events.push((sim_us, NodeEvent::OutboxOverflow)),
        CtrlOutput::Event(e) => events.push((sim_us, NodeEvent::Ctrl(e))),
    }
}
