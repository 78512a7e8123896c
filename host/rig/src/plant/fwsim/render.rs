//! The simulator process's renderer side: the renderer thread ([`render_frames`], drawing
//! what [`crate::plant::painter::Deferred`] handed back) and the camera socket's writer
//! ([`serve_camera`]).

use crate::Error;
use crate::plant::painter::Painter;
use crate::plant::truth::TruthSample;
use crossbeam_channel::{Receiver, Sender};
use mesopush_executor::shell::rt_queue;
use mesopush_protocol::camera::CameraFrameHeader;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// One frame for the renderer: its header and what it shows (`None`: black).
pub(super) struct RenderJob {
    pub(super) header: CameraFrameHeader,
    pub(super) exposure_mono_us: u64,
    pub(super) truth: Option<TruthSample>,
}

/// The renderer thread: draws each queued frame, queues it for the camera socket (a full
/// queue: counted unsent, not waited for) and writes its truth row (flushed per row).
pub(super) fn render_frames(
    mut painter: Painter,
    rx: &rt_queue::Receiver<RenderJob>,
    camera_tx: &Sender<(CameraFrameHeader, Vec<u8>)>,
    unsent: &AtomicU64,
    (mut truth, truth_path): (BufWriter<File>, &Path),
) -> Result<(), Error> {
    while let Some(job) = rx.recv() {
        let pixels = job.truth.as_ref().map(|t| painter.paint(t)).unwrap_or_default();
        let stamp_mono = job.header.capture_mono_us.unwrap_or(0);
        if camera_tx.try_send((job.header, pixels)).is_err() {
            unsent.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(t) = job.truth {
            writeln!(
                truth,
                "{},{},{stamp_mono},{},{},{},{},{}",
                job.header.frame_seq,
                job.exposure_mono_us,
                t.peg.x_um,
                t.peg.y_um,
                t.peg.theta_rad,
                t.probe_um.x,
                t.probe_um.y
            )
            .and_then(|()| truth.flush())
            .map_err(|e| Error::io(truth_path, e))?;
        }
    }
    truth.flush().map_err(|e| Error::io(truth_path, e))
}

pub(super) fn bind_camera(path: &Path) -> Result<UnixListener, Error> {
    mesopush_executor::shell::unix_line::remove_stale_socket(path)
        .map_err(|e| Error::io(path, e))?;
    let l = UnixListener::bind(path).map_err(|e| Error::io(path, e))?;
    l.set_nonblocking(true).map_err(|e| Error::io(path, e))?;
    Ok(l)
}

/// The camera socket's writer: one client at a time; frames with no client are discarded
/// (counted), a client that hangs up is replaced by the next.
pub(super) fn serve_camera(
    listener: &UnixListener,
    rx: &Receiver<(CameraFrameHeader, Vec<u8>)>,
    unsent: &AtomicU64,
) {
    let mut client: Option<UnixStream> = None;
    loop {
        let msg = match rx.recv_timeout(Duration::from_millis(20)) {
            Ok(m) => Some(m),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => None,
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => return,
        };
        if client.is_none()
            && let Ok((s, _)) = listener.accept()
            && s.set_nonblocking(false).is_ok()
        {
            client = Some(s);
        }
        let Some((header, pixels)) = msg else { continue };
        let sent = client.as_mut().is_some_and(|s| {
            s.write_all(&header.encode()).and_then(|()| s.write_all(&pixels)).is_ok()
        });
        if !sent {
            client = None;
            unsent.fetch_add(1, Ordering::Relaxed);
        }
    }
}
