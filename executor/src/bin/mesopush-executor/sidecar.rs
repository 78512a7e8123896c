//! What runs beside the executor's loop: the recorder and, with `--camera`, the camera
//! reader.

use crate::args::{Args, parse_pair};
use crate::{FRAME_QUEUE, IMAGE_QUEUE};
use anyhow::{Context, Result, bail};
use crossbeam_channel::{Receiver, bounded};
use mesopush_executor::clock::MonotonicClock;
use mesopush_executor::shell::camera_addr::{CameraAddr, parse_size};
use mesopush_executor::shell::camera_source::{CameraCounters, CameraEnd, CameraSinks};
use mesopush_executor::shell::record::{ExecRecorder, RecordConfig};
use mesopush_executor::shell::rt_queue;
use mesopush_executor::{CameraFrame, LogEvent};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// What runs beside the shell: the recorder and, with `--camera`, the camera reader.
pub(crate) struct Sidecar {
    pub(crate) frames: Option<rt_queue::Receiver<CameraFrame>>,
    pub(crate) camera: Option<std::thread::JoinHandle<CameraEnd>>,
    pub(crate) counters: Arc<CameraCounters>,
    pub(crate) stop: Arc<AtomicBool>,
    pub(crate) recorder: std::thread::JoinHandle<std::io::Result<()>>,
}

pub(crate) fn sidecar(
    args: &Args,
    clock: &Arc<MonotonicClock>,
    log_rx: Receiver<LogEvent>,
) -> Result<Sidecar> {
    let record = match &args.record_dir {
        Some(root) => {
            std::fs::create_dir_all(root)
                .with_context(|| format!("creating the record directory {}", root.display()))?;
            Some(RecordConfig {
                root: root.clone(),
                fixture_origin_um: parse_pair("--fixture-origin-um", &args.fixture_origin_um)?,
                tail_us: args.record_tail_ms.saturating_mul(1000),
            })
        }
        None => None,
    };
    let (img_tx, img_rx) = bounded(IMAGE_QUEUE);
    let counters = Arc::new(CameraCounters::default());
    let stop = Arc::new(AtomicBool::new(false));
    let (frames, camera) = match &args.camera {
        Some(addr) => {
            let addr = CameraAddr::parse(addr).map_err(anyhow::Error::msg)?;
            let size = args.camera_size.as_deref().map(parse_size).transpose();
            let size = size.map_err(|e| anyhow::anyhow!("--camera-size: {e}"))?;
            let (tx, rx) = rt_queue::bounded(FRAME_QUEUE);
            let sinks = CameraSinks {
                clock: clock.clone(),
                to_loop: tx,
                to_recorder: record.is_some().then_some(img_tx),
                counters: counters.clone(),
                stop: stop.clone(),
            };
            let t = addr.spawn(size, sinks).context("--camera")?;
            (Some(rx), Some(t))
        }
        None if args.camera_size.is_some() => bail!("--camera-size needs --camera v4l:DEVICE"),
        None => (None, None),
    };
    let rec = ExecRecorder::new(record, clock.clone());
    let recorder = std::thread::spawn(move || rec.run(log_rx, img_rx));
    Ok(Sidecar { frames, camera, counters, stop, recorder })
}
