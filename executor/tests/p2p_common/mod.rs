//! Shared harness of the point-to-point protocol tests: drive a `PointToPointAdapter` at
//! given times, collect what it writes and what it tells the core.
#![allow(dead_code, unreachable_pub)]

use mesopush_executor::adapter::p2p::Protocol;
use mesopush_executor::adapter::p2p::driver::{P2pSettings, PointToPointAdapter};
use mesopush_executor::adapter::{AdapterEvent, ControllerAdapter};
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::{CtrlToExec, FaultCode, MoveSegment};

/// The adapter under test: 32 queued segments.
pub type Adapter<P> = PointToPointAdapter<P, 32>;

/// An adapter over `proto` with the documented settings.
pub fn adapter<P: Protocol>(proto: P) -> Adapter<P> {
    PointToPointAdapter::new(proto, P2pSettings::DEFAULT)
}

/// Everything the adapter writes at `now` (after a poll).
pub fn written<P: Protocol>(a: &mut Adapter<P>, now: u64) -> Vec<Vec<u8>> {
    a.poll(now);
    let mut buf = [0u8; 256];
    std::iter::from_fn(|| a.transmit(now, &mut buf).map(<[u8]>::to_vec)).collect()
}

/// All events; panics on a link-down (tests that expect one drain with `raw_events`).
pub fn events<P: Protocol>(a: &mut Adapter<P>) -> Vec<CtrlToExec> {
    raw_events(a)
        .into_iter()
        .map(|e| match e {
            AdapterEvent::Ctrl(m) => m,
            AdapterEvent::LinkDown => panic!("link down"),
        })
        .collect()
}

/// All events as they are.
pub fn raw_events<P: Protocol>(a: &mut Adapter<P>) -> Vec<AdapterEvent> {
    std::iter::from_fn(|| a.next_event()).collect()
}

/// Serial bytes, fed until all are consumed.
pub fn feed<P: Protocol>(a: &mut Adapter<P>, now: u64, mut bytes: &[u8]) {
    while !bytes.is_empty() {
        let n = a.receive(now, bytes);
        bytes = &bytes[n..];
    }
}

/// A segment to `(x_nm, y_nm)` at `speed_nm_s`, due at `start_us`.
pub fn segment(id: u32, start_us: u64, x_nm: i32, y_nm: i32, speed_nm_s: u32) -> ExecToCtrl {
    ExecToCtrl::Move(MoveSegment {
        segment_id: id,
        start_ctrl_time_us: start_us,
        target_x_nm: x_nm,
        target_y_nm: y_nm,
        speed_nm_s,
    })
}

/// The last status's last-done segment.
pub fn last_done(evs: &[CtrlToExec]) -> Option<u32> {
    evs.iter().rev().find_map(|e| match e {
        CtrlToExec::Status(s) => Some(s.last_done_segment_id),
        _ => None,
    })?
}

/// The first fault's code.
pub fn fault(evs: &[CtrlToExec]) -> Option<FaultCode> {
    evs.iter().find_map(|e| match e {
        CtrlToExec::Fault(f) => Some(f.code),
        _ => None,
    })
}

/// The last reported position, nm.
pub fn reported(evs: &[CtrlToExec]) -> Option<(i32, i32)> {
    evs.iter().rev().find_map(|e| match e {
        CtrlToExec::Position(p) => Some((p.x_nm, p.y_nm)),
        _ => None,
    })
}
