//! The loop in real time: the executor's std shell
//! ([`mesopush_executor::shell::Shell::run`], the same allocation-free core) on its own
//! thread with its controller line on the pseudo-terminal's slave (opened by path like a
//! serial device) and its host line on in-memory pipes; this thread serves the pty's master
//! as the firmware simulator's controller node in real time (monotonic clock), moves the
//! world, runs the camera (driver stamps in the shared clock) and the host session, and
//! forwards log records and frames to the recorder without ever blocking: a full recorder
//! queue drops the frame and counts it.
//!
//! Line faults of the world file are not injected in real time (the lines are real); stage
//! faults (stall, limit switch, reboot) and camera drops are.

mod threads;

use super::finish::{Finished, finish};
use super::prepare::{Limits, TAIL_US, prepare};
use super::pty::PtyLine;
use super::recorder::RecMsg;
use super::spec::{TrialProgress, TrialReport, TrialSpec};
use crate::Error;
use crate::client::session::{HostSession, SessionGoal};
use crate::plant::controller::{applied_segments, controller};
use crate::plant::ctrl_serve::{ServedController, ServedLine};
use crate::plant::painter::{Deferred, Painter};
use crate::plant::truth::TruthSample;
use crate::plant::vendor::Plant;
use crate::plant::world::RigWorld;
use crate::plant::world_file::realtime_faults;
use crossbeam_channel::{Sender, bounded};
use image::GrayImage;
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_executor::shell::port::{CHUNK_BYTES, Chunk};
use mesopush_executor::{CameraFrame, LogEvent, StampedFrame};
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_protocol::FRAME_BUF_LEN;
use mesopush_protocol::host::StagePoint;
use mesopush_protocol::units::us_to_s;
use std::path::Path;
use std::sync::Arc;
use threads::{PainterThread, ShellThread};

/// How long a stamped frame waits for its image before it is given up, µs.
const STAMP_WAIT_US: u64 = 500_000;

/// What goes to the recorder: never blocks (a full queue counts the record lost), and pairs
/// each stamped frame with its image once the painter has drawn it.
struct Relay {
    rec: Sender<RecMsg>,
    lost: u64,
    images: Vec<(u32, Option<GrayImage>)>,
    stamped_waiting: Vec<(StampedFrame, u64)>,
}

impl Relay {
    fn forward(&mut self, msg: RecMsg) {
        if self.rec.try_send(msg).is_err() {
            self.lost += 1;
        }
    }

    /// A frame the camera delivered: its stamp to the executor, its truth to the painter (a
    /// full queue skips it: its stamp then waits in vain and is counted lost); a black frame
    /// (no truth) has no image.
    fn on_camera_frame(
        &mut self,
        frame: SimFrame<TruthSample>,
        stamp_us: u64,
        shell: &ShellThread,
        painter: &PainterThread,
    ) {
        let cam = CameraFrame {
            frame_seq: frame.frame_seq,
            driver_stamp_us: Some(stamp_us),
            black: frame.black,
        };
        if shell.frames.try_send(cam).is_err() {
            self.lost += 1;
        }
        match frame.image {
            Some(t) => drop(painter.truth.try_send((frame.frame_seq, t))),
            None => self.images.push((frame.frame_seq, None)),
        }
    }

    /// The executor's log records to the recorder; frames it stamped wait for their image.
    fn on_log(&mut self, now: u64, e: LogEvent) {
        if let LogEvent::Frame(stamped) = e {
            self.stamped_waiting.push((stamped, now));
        }
        self.forward(RecMsg::Log(now, e));
    }

    /// Sends each stamped frame whose image the painter has drawn; gives up on one after
    /// [`STAMP_WAIT_US`].
    fn release_frames(&mut self, now: u64, painter: &PainterThread) {
        while let Ok((seq, image)) = painter.images.try_recv() {
            self.images.push((seq, Some(image)));
        }
        if self.images.len() > 8 {
            self.images.drain(..self.images.len() - 8);
        }
        let mut waiting = std::mem::take(&mut self.stamped_waiting);
        waiting.retain(|(stamped, arrival_us)| {
            let seq = stamped.stamp.frame_seq;
            let Some(i) = self.images.iter().position(|(s, _)| *s == seq) else {
                let still = now < arrival_us + STAMP_WAIT_US;
                self.lost += u64::from(!still);
                return still;
            };
            let image = self.images.remove(i).1;
            self.forward(RecMsg::Frame { stamped: *stamped, arrival_us: *arrival_us, image });
            false
        });
        self.stamped_waiting = waiting;
    }
}

/// Runs `spec` in real time.
pub fn run_realtime(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(TrialProgress),
) -> Result<TrialReport, Error> {
    let prep = prepare(spec, out_dir)?;
    let faults = realtime_faults(&spec.world.spec.faults)?;
    let clock = Arc::new(MonotonicClock::new());
    let pty = PtyLine::open()?;
    let path = pty.path().to_string();
    let (master, ctrl_port, _slave) = pty.into_parts();
    let shell = ShellThread::spawn(prep.config, ctrl_port, &path, clock.clone())?;
    let (rec_tx, rec_rx) = bounded(256);
    let recorder = prep.recorder;
    let rec = std::thread::spawn(move || recorder.run(rec_rx));
    let limit_um = prep.world.deflection_limit_um();
    let node = controller(faults, prep.rng.fork(1), clock.now_us(), prep.probe_start_nm, limit_um)?;
    let c = prep.camera;
    let camera = SimCamera::new(c.period_us, c.readout_us, c.start_us, prep.rng.fork(6), faults);
    let mut ctrl =
        ServedController::new(ServedLine::Pty(master), Plant::Native(Box::new(node)), camera)
            .map_err(|e| Error::io("pty master", e))?;
    let mut world = prep.world;
    let painter = PainterThread::spawn(Painter::for_world(&mut world));
    let start = StagePoint { x_nm: prep.probe_start_nm.0, y_nm: prep.probe_start_nm.1 };
    let mut host = HostSession::new(&spec.plan, SessionGoal::FlashAndRun, start, 7_001)?;
    let mut relay = Relay { rec: rec_tx, lost: 0, images: Vec::new(), stamped_waiting: Vec::new() };
    let limits = prep.limits;
    let mut lp = Loop { ctrl: &mut ctrl, world: &mut world, host: &mut host, relay: &mut relay };
    let result = lp.run(&clock, &shell, &painter, limits, progress);
    shell.join();
    painter.join();
    let lost = relay.lost;
    drop(relay);
    let recorded =
        rec.join().map_err(|_| Error::invalid("recorder", "the recorder panicked"))??;
    result?;
    let done = Finished {
        end: host.end().cloned(),
        applied: applied_segments(ctrl.node.events()),
        segments_expected: prep.segments_expected,
        faults_injected: ctrl.camera.dropped + ctrl.camera.black,
        records_lost: lost,
        sim_time_s: us_to_s(clock.now_us()),
        camera_latency_us: world.camera_latency_us(),
        deflection_limit_um: world.deflection_limit_um(),
    };
    finish(out_dir, recorded, world.truth(), (world.fixture(), world.peg_body()), done)
}

/// This thread's loop: the controller on the pty master, the world, the host session.
struct Loop<'a> {
    ctrl: &'a mut ServedController,
    world: &'a mut RigWorld,
    host: &'a mut HostSession,
    relay: &'a mut Relay,
}

impl Loop<'_> {
    fn run(
        &mut self,
        clock: &MonotonicClock,
        shell: &ShellThread,
        painter: &PainterThread,
        limits: Limits,
        progress: &mut dyn FnMut(TrialProgress),
    ) -> Result<(), Error> {
        let mut out = [0u8; FRAME_BUF_LEN];
        let (mut ended_at, mut next_progress) = (None, 0);
        loop {
            let now = clock.now_us();
            self.serve_controller(now, shell, painter)?;
            self.relay.release_frames(now, painter);
            self.serve_host(now, shell, &mut out)?;
            while let Ok(e) = shell.log.try_recv() {
                self.relay.on_log(now, e);
            }
            if now >= next_progress {
                next_progress = now + 100_000;
                progress(TrialProgress { t_s: us_to_s(now), total_s: limits.total_s });
            }
            if self.host.end().is_some() && ended_at.is_none() {
                ended_at = Some(now);
            }
            if ended_at.is_some_and(|t| now >= t + TAIL_US) || now > limits.max_us {
                return Ok(());
            }
        }
    }

    fn serve_controller(
        &mut self,
        now: u64,
        shell: &ShellThread,
        painter: &PainterThread,
    ) -> Result<(), Error> {
        let (_, frame) = self
            .ctrl
            .step(now, &mut Deferred { world: self.world })
            .map_err(|e| Error::io("pty master", e))?;
        if let Some(frame) = frame {
            let stamp_us = self.world.driver_stamp_us(frame.exposure_sim_us);
            self.relay.on_camera_frame(frame, stamp_us, shell, painter);
        }
        Ok(())
    }

    fn serve_host(
        &mut self,
        now: u64,
        shell: &ShellThread,
        out: &mut [u8; FRAME_BUF_LEN],
    ) -> Result<(), Error> {
        while let Ok(c) = shell.to_host.try_recv() {
            self.host.on_bytes(now, c.bytes());
        }
        self.host.poll(now)?;
        while let Some(f) = self.host.transmit(now, out) {
            for piece in f.chunks(CHUNK_BYTES) {
                let _ = shell.to_exec.send(Chunk::new(piece));
            }
        }
        for (t, msg) in std::mem::take(&mut self.host.inbox) {
            self.relay.forward(RecMsg::Host(t, msg));
        }
        Ok(())
    }
}
