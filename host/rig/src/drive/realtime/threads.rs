//! The threads beside the real-time loop: the executor's std shell ([`ShellThread`], the
//! same allocation-free core on its own thread) and the painter ([`PainterThread`], which
//! draws frames so the controller's loop never renders).

use crate::Error;
use crate::drive::endpoint::endpoint;
use crate::plant::painter::Painter;
use crate::plant::truth::TruthSample;
use crossbeam_channel::{Receiver, Sender, bounded};
use image::GrayImage;
use mesopush_executor::clock::MonotonicClock;
use mesopush_executor::shell::port::{Chunk, PipeReader, PipeWriter, split_tty};
use mesopush_executor::shell::rt_queue;
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::{Shell, ShellStats};
use mesopush_executor::{CameraFrame, ExecutorConfig, LogEvent};
use serialport::TTYPort;
use std::io;
use std::sync::Arc;
use std::thread::JoinHandle;

/// Frames queued for the painter thread (more: the frame is counted lost).
const PAINT_QUEUE: usize = 4;

/// The executor's std shell on its own thread, and this thread's ends of its lines.
pub(super) struct ShellThread {
    handle: JoinHandle<(ShellEnd, ShellStats)>,
    pub(super) to_exec: rt_queue::Sender<Chunk>,
    pub(super) to_host: rt_queue::Receiver<Chunk>,
    pub(super) frames: rt_queue::Sender<CameraFrame>,
    pub(super) log: Receiver<LogEvent>,
    stop: rt_queue::Sender<()>,
}

impl ShellThread {
    /// Starts the shell with `config`, its controller line on `ctrl_port` (the pty's slave).
    pub(super) fn spawn(
        config: ExecutorConfig,
        ctrl_port: TTYPort,
        ctrl_path: &str,
        clock: Arc<MonotonicClock>,
    ) -> Result<Self, Error> {
        let ctrl = split_tty(ctrl_port)
            .map_err(|e| Error::io(ctrl_path, io::Error::other(e.to_string())))?;
        let (to_exec, to_exec_rx) = rt_queue::bounded(1024);
        let (to_host_tx, to_host) = rt_queue::bounded::<Chunk>(1024);
        let (frames, frame_rx) = rt_queue::bounded::<CameraFrame>(64);
        let (log_tx, log) = bounded::<LogEvent>(4096);
        let (stop, stop_rx) = rt_queue::bounded::<()>(1);
        let mut endpoint = endpoint(config, 1)?;
        let handle = std::thread::spawn(move || {
            let mut stats = ShellStats::default();
            let host = (PipeReader::from(to_exec_rx), PipeWriter::from(to_host_tx));
            let end = Shell::run(
                &mut endpoint,
                &*clock,
                host,
                ctrl,
                Some(frame_rx),
                log_tx,
                stop_rx,
                &mut stats,
            );
            (end, stats)
        });
        Ok(Self { handle, to_exec, to_host, frames, log, stop })
    }

    pub(super) fn join(self) {
        let _ = self.stop.send(());
        let _ = self.handle.join();
    }
}

/// The painter thread: truth in, image out (the controller's loop never renders).
pub(super) struct PainterThread {
    pub(super) truth: Sender<(u32, TruthSample)>,
    pub(super) images: Receiver<(u32, GrayImage)>,
    handle: JoinHandle<()>,
}

impl PainterThread {
    pub(super) fn spawn(mut painter: Painter) -> Self {
        Self::spawn_with(move |t| painter.paint_image(t))
    }

    fn spawn_with(mut paint: impl FnMut(&TruthSample) -> GrayImage + Send + 'static) -> Self {
        let (truth, truth_rx) = bounded::<(u32, TruthSample)>(PAINT_QUEUE);
        let (image_tx, images) = bounded::<(u32, GrayImage)>(PAINT_QUEUE);
        let handle = std::thread::spawn(move || {
            for (seq, t) in truth_rx {
                if image_tx.send((seq, paint(&t))).is_err() {
                    break;
                }
            }
        });
        Self { truth, images, handle }
    }

    /// Stops the painter: both queues are dropped first, so a painter blocked on a full
    /// image queue (the loop ended with frames still in the painter's hands) gets an error
    /// and ends instead of waiting forever on a receiver nobody reads.
    pub(super) fn join(self) {
        let Self { truth, images, handle } = self;
        drop(truth);
        drop(images);
        let _ = handle.join();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::{Pose, Vec2};

    /// Caught by `hil_processes` under load: `demo --realtime` hung for good after its loop
    /// ended, the main thread joining a painter blocked on a full image queue whose receiver
    /// the join kept alive. The join must return; a hang fails the wait below.
    #[test]
    fn the_painter_stops_when_its_image_queue_is_full_and_unread() {
        let painter = PainterThread::spawn_with(|_| GrayImage::new(4, 4));
        let t = TruthSample {
            t_us: 0,
            peg: Pose::new(0.0, 0.0, 0.0),
            probe_um: Vec2::zeros(),
            deflection_um: 0.0,
            jams: 0,
        };
        for seq in 0..(2 * PAINT_QUEUE as u32 + 2) {
            if painter.truth.send_timeout((seq, t), std::time::Duration::from_secs(5)).is_err() {
                break; // the painter is blocked and its truth queue is full too
            }
        }
        let (done_tx, done_rx) = bounded(1);
        std::thread::spawn(move || {
            painter.join();
            let _ = done_tx.send(());
        });
        let joined = done_rx.recv_timeout(std::time::Duration::from_secs(60));
        assert!(joined.is_ok(), "the painter thread did not stop");
    }
}
