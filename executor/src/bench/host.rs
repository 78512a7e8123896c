//! The bench's host: flashes a plan of back-and-forth x moves lasting about the bench's
//! length, arms and starts it, and waits for the trial's end, over the executor's host line.

use crate::clock::{Clock, MonotonicClock};
use crate::shell::port::{CHUNK_BYTES, Chunk};
use crate::shell::rt_queue::{Receiver, RecvTimeoutError, Sender};
use mesopush_protocol::flash::{FlashHeader, PlanStep, image_chunks};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecToHost, Hello, HostToExec, StagePoint,
};
use mesopush_protocol::{FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame};
use std::io;
use std::prelude::rust_2024::*;
use std::sync::Arc;
use std::time::Duration;

/// Plan id the bench flashes.
const PLAN_ID: u32 = 9;
/// Where the bench's controller starts the probe, and so the plan's stated start, nm.
pub(crate) const START_NM: (i32, i32) = (0, 0);
/// Probe speed of the bench plan, nm/s.
const SPEED_NM_S: u32 = 140_000;

/// A square walked in 1 s sides (+x, +y, −x, −y, …), `seconds` long in all (at least one
/// side; right-angle turns pass the executor's safety check, reversals do not).
pub(crate) fn bench_plan(seconds: f64) -> Vec<PlanStep> {
    let n = seconds.ceil().max(1.0) as usize;
    let d = SPEED_NM_S as i32;
    let dirs = [(d, 0), (0, d), (-d, 0), (0, -d)];
    (0..n)
        .map(|i| PlanStep { dx_nm: dirs[i % 4].0, dy_nm: dirs[i % 4].1, speed_nm_s: SPEED_NM_S })
        .collect()
}

/// Runs the host side until the trial ends; the trial's end event, or an error.
pub(crate) fn drive(
    clock: Arc<MonotonicClock>,
    steps: &[PlanStep],
    rx: Receiver<Chunk>,
    tx: Sender<Chunk>,
    give_up_us: u64,
) -> io::Result<ExecToHost> {
    let mut link: Link<HostToExec, ExecToHost, 32> = Link::new(LinkConfig::DEFAULT, 601);
    let mut outbox = flash_messages(steps)?;
    let (mut reader, mut out) = (FrameReader::<FRAME_BUF_LEN>::new(), [0u8; FRAME_BUF_LEN]);
    let mut next_arm_us = clock.now_us() + 300_000;
    let mut next_heartbeat_us = 0;
    while clock.now_us() < give_up_us {
        let now = clock.now_us();
        while let Some(m) = outbox.pop() {
            if let Err(m) = link.send(m) {
                outbox.push(m);
                break;
            }
        }
        let mut got = Vec::new();
        match rx.recv_timeout(Duration::from_millis(5)) {
            Ok(chunk) => {
                for &b in chunk.bytes() {
                    if let Some(Ok(f)) = reader.push_byte(b)
                        && let Some(m) = link.on_bytes(now, f)
                    {
                        got.push(m);
                    }
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                return Err(io::Error::other("host line closed"));
            }
        }
        for m in got {
            if let Some(end) = on_message(m, now, &mut next_arm_us, &mut outbox)? {
                return Ok(end);
            }
        }
        if outbox.is_empty() && now >= next_arm_us {
            next_arm_us = u64::MAX;
            let start = StagePoint { x_nm: START_NM.0, y_nm: START_NM.1 };
            outbox.push(HostToExec::Arm { plan_id: PLAN_ID, start });
        }
        if now >= next_heartbeat_us {
            next_heartbeat_us = now + 100_000;
            let _ = link.send(HostToExec::Heartbeat { host_time_us: now });
        }
        let _ = link.poll(now);
        while let Some(frame) = link.poll_transmit(now) {
            let Ok(bytes) = encode_frame(&frame, &mut out) else { continue };
            for piece in bytes.chunks(CHUNK_BYTES) {
                tx.send(Chunk::new(piece)).map_err(|_| io::Error::other("host line closed"))?;
            }
        }
    }
    Err(io::Error::other("the bench trial did not end in time"))
}

/// Hello, then the bench plan's flash messages, in reverse order (popped from the back).
fn flash_messages(steps: &[PlanStep]) -> io::Result<Vec<HostToExec>> {
    let image: Vec<u8> = steps.iter().flat_map(|s| s.to_image_bytes()).collect();
    let header = FlashHeader::for_image(PLAN_ID, &image)
        .map_err(|e| io::Error::other(format!("bench plan: {e:?}")))?;
    let mut outbox = vec![HostToExec::Hello(Hello::CURRENT), HostToExec::FlashBegin(header)];
    outbox.extend(image_chunks(PLAN_ID, &image).map(HostToExec::FlashChunk));
    outbox.push(HostToExec::FlashCommit { plan_id: PLAN_ID });
    outbox.reverse();
    Ok(outbox)
}

/// One message from the executor: a refusal is an error, `Armed` queues the start, a
/// not-ready arm is retried in 50 ms; the trial's end event is returned.
fn on_message(
    m: ExecToHost,
    now: u64,
    next_arm_us: &mut u64,
    outbox: &mut Vec<HostToExec>,
) -> io::Result<Option<ExecToHost>> {
    match m {
        ExecToHost::FlashRejected { reason, .. } => {
            Err(io::Error::other(format!("the bench plan was refused: {reason:?}")))
        }
        ExecToHost::CommandRejected(CommandRejectReason::NotReady { .. }) => {
            *next_arm_us = now + 50_000;
            Ok(None)
        }
        ExecToHost::CommandRejected(r) => {
            Err(io::Error::other(format!("the executor refused a command: {r:?}")))
        }
        ExecToHost::Status(s) if s.state == ExecState::Armed => {
            outbox.insert(0, HostToExec::Start { plan_id: PLAN_ID });
            Ok(None)
        }
        ExecToHost::Trial(t) if t.kind != mesopush_protocol::host::TrialEventKind::Started => {
            Ok(Some(ExecToHost::Trial(t)))
        }
        _ => Ok(None),
    }
}
