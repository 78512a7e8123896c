//! The loop in real time: the executor's std shell ([`Shell::run`], the same allocation-free
//! core) on its own thread with its controller line on the pseudo-terminal's slave (opened by
//! path like a serial device) and its host line on in-memory pipes; this thread serves the
//! pty's master as the firmware simulator's controller node in real time (monotonic clock),
//! moves the world, runs the camera (driver stamps in the shared clock) and the host session,
//! and forwards log records and frames to the recorder without ever blocking: a full
//! recorder queue drops the frame and counts it.
//!
//! Line faults of the world file are not injected in real time (the lines are real); stage
//! faults (stall, limit switch, reboot) and camera drops are.

use super::ctrl_serve::ServedController;
use super::painter::Deferred;
use super::pty::PtyLine;
use super::recorder::RecMsg;
use super::session::{HostSession, SessionGoal};
use super::simloop::{CAP, EW, LA, Q};
use super::trial::{Finished, Progress, TAIL_US, TrialReport, TrialSpec, finish, prepare};
use super::world::TruthSample;
use crate::Error;
use crossbeam_channel::{Sender, TrySendError, bounded};
use image::GrayImage;
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::port::{CHUNK_BYTES, Chunk, PipeReader, PipeWriter, split_tty};
use mesopush_executor::shell::{Shell, ShellStats};
use mesopush_executor::{CameraFrame, Executor, LogEvent, MemStore, StampedFrame};
use mesopush_firmware_sim::camera::SimCamera;
use mesopush_firmware_sim::{ControllerNode, CtrlConfig, FaultConfig};
use mesopush_protocol::{FRAME_BUF_LEN, LinkConfig};
use std::io;
use std::path::Path;
use std::sync::Arc;

/// Frames queued for the painter thread (more: the frame is counted lost).
const PAINT_QUEUE: usize = 4;
/// How long a stamped frame waits for its image before it is given up, µs.
const STAMP_WAIT_US: u64 = 500_000;

/// Runs `spec` in real time.
pub fn run_realtime(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrialReport, Error> {
    let prep = prepare(spec, out_dir)?;
    let faults = FaultConfig {
        link_drop: 0.0,
        link_corrupt: 0.0,
        link_duplicate: 0.0,
        link_delay: 0.0,
        ..super::world_file::validated_faults(&spec.world.spec.faults)?
    };
    let clock = Arc::new(MonotonicClock::new());
    let pty = PtyLine::open()?;
    let path = pty.path().to_string();
    let (master, ctrl_port, _slave) = pty.into_parts();
    let ctrl =
        split_tty(ctrl_port).map_err(|e| Error::io(&path, io::Error::other(e.to_string())))?;
    let (to_exec_tx, to_exec_rx) = bounded(1024);
    let (to_host_tx, to_host_rx) = bounded::<Chunk>(1024);
    let (frame_tx, frame_rx) = bounded::<CameraFrame>(64);
    let (log_tx, log_rx) = bounded::<LogEvent>(4096);
    let (stop_tx, stop_rx) = bounded::<()>(1);
    let core = Executor::<_, CAP, LA>::new(prep.config, MemStore::<CAP>::new())
        .map_err(|e| Error::invalid("executor config", format!("{e:?}")))?;
    let mut endpoint = Endpoint::<_, CAP, LA, EW>::new(core, LinkConfig::DEFAULT, 1);
    let shell_clock = clock.clone();
    let shell = std::thread::spawn(move || {
        let mut stats = ShellStats::default();
        let host = (PipeReader::from(to_exec_rx), PipeWriter::from(to_host_tx));
        let end = Shell::run(
            &mut endpoint,
            &*shell_clock,
            host,
            ctrl,
            Some(frame_rx),
            log_tx,
            stop_rx,
            &mut stats,
        );
        (end, stats)
    });
    let (rec_tx, rec_rx) = bounded(256);
    let recorder = prep.recorder;
    let rec = std::thread::spawn(move || recorder.run(rec_rx));
    let node: ControllerNode<Q, EW> = ControllerNode::new(
        CtrlConfig::DEFAULT,
        faults,
        LinkConfig::DEFAULT,
        prep.rng.fork(1),
        clock.now_us(),
        prep.probe_start_nm,
    );
    let c = prep.camera;
    let camera = SimCamera::new(c.period_us, c.readout_us, c.start_us, prep.rng.fork(6), faults);
    let mut ctrl =
        ServedController::new(master, node, camera).map_err(|e| Error::io("pty master", e))?;
    let mut world = prep.world;
    let (paint_tx, paint_rx) = bounded::<(u32, TruthSample)>(PAINT_QUEUE);
    let (image_tx, image_rx) = bounded::<(u32, GrayImage)>(PAINT_QUEUE);
    let mut painter = world.painter();
    let painting = std::thread::spawn(move || {
        for (seq, truth) in paint_rx {
            if image_tx.send((seq, painter.paint_image(&truth))).is_err() {
                break;
            }
        }
    });
    let mut stamped_waiting: Vec<(StampedFrame, u64)> = Vec::new();
    let mut host = HostSession::new(&spec.plan, SessionGoal::FlashAndRun, 7_001)?;
    let mut images: Vec<(u32, Option<GrayImage>)> = Vec::new();
    let mut lost = 0u64;
    let mut out = [0u8; FRAME_BUF_LEN];
    let total_s = prep.plan_duration_s + 2.0;
    let max_us = ((prep.plan_duration_s + 30.0) * 1e6) as u64;
    let (mut ended_at, mut next_progress) = (None, 0);
    let forward = |tx: &Sender<RecMsg>, msg: RecMsg, lost: &mut u64| match tx.try_send(msg) {
        Ok(()) => {}
        Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => *lost += 1,
    };
    let result: Result<(), Error> = loop {
        let now = clock.now_us();
        let frame = match ctrl.step(now, &mut Deferred { world: &mut world }) {
            Ok((_, frame)) => frame,
            Err(e) => break Err(Error::io("pty master", e)),
        };
        if let Some(frame) = frame {
            let cam = CameraFrame {
                frame_seq: frame.frame_seq,
                driver_stamp_us: Some(world.driver_stamp_us(frame.exposure_sim_us)),
                black: frame.black,
            };
            if frame_tx.try_send(cam).is_err() {
                lost += 1;
            }
            // Drawn on the painter thread (a full queue skips it: its stamp then waits in
            // vain and is counted lost below); a black frame (no truth) has no image.
            match frame.image {
                Some(t) => drop(paint_tx.try_send((frame.frame_seq, t))),
                None => images.push((frame.frame_seq, None)),
            }
        }
        while let Ok((seq, image)) = image_rx.try_recv() {
            images.push((seq, Some(image)));
        }
        if images.len() > 8 {
            images.drain(..images.len() - 8);
        }
        while let Ok(c) = to_host_rx.try_recv() {
            host.on_bytes(now, c.bytes());
        }
        if let Err(e) = host.poll(now) {
            break Err(e);
        }
        while let Some(f) = host.transmit(now, &mut out) {
            for piece in f.chunks(CHUNK_BYTES) {
                let _ = to_exec_tx.send(Chunk::new(piece));
            }
        }
        for (t, msg) in std::mem::take(&mut host.inbox) {
            forward(&rec_tx, RecMsg::Host(t, msg), &mut lost);
        }
        while let Ok(e) = log_rx.try_recv() {
            if let LogEvent::Frame(stamped) = e {
                stamped_waiting.push((stamped, now));
            }
            forward(&rec_tx, RecMsg::Log(now, e), &mut lost);
        }
        // A stamped frame goes to the recorder with its image once the painter drew it.
        stamped_waiting.retain(|(stamped, arrival_us)| {
            let seq = stamped.stamp.frame_seq;
            let Some(i) = images.iter().position(|(s, _)| *s == seq) else {
                let waiting = now < arrival_us + STAMP_WAIT_US;
                lost += u64::from(!waiting);
                return waiting;
            };
            let image = images.remove(i).1;
            let msg = RecMsg::Frame { stamped: *stamped, arrival_us: *arrival_us, image };
            forward(&rec_tx, msg, &mut lost);
            false
        });
        if now >= next_progress {
            next_progress = now + 100_000;
            progress(Progress { t_s: now as f64 * 1e-6, total_s });
        }
        if host.end().is_some() && ended_at.is_none() {
            ended_at = Some(now);
        }
        if ended_at.is_some_and(|t| now >= t + TAIL_US) || now > max_us {
            break Ok(());
        }
    };
    let _ = stop_tx.send(());
    let _ = shell.join();
    drop(paint_tx);
    let _ = painting.join();
    drop(rec_tx);
    let recorded =
        rec.join().map_err(|_| Error::invalid("recorder", "the recorder panicked"))??;
    result?;
    let done = Finished {
        end: host.end().cloned(),
        applied: super::simloop::applied_segments(&ctrl.node.events),
        segments_expected: prep.segments_expected,
        faults_injected: ctrl.camera.dropped + ctrl.camera.black,
        records_lost: lost,
        sim_time_s: clock.now_us() as f64 * 1e-6,
        camera_latency_us: world.camera_latency_us(),
    };
    finish(out_dir, recorded, world.truth(), world.fixture(), done)
}
