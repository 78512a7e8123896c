//! The size table in `docs/protocol.md` is checked against the compile-time constants, so
//! the documentation cannot drift from the code.

use mesopush_protocol::ctrl::{CtrlStatus, FaultCode, FaultReport, MoveSegment, PositionReport};
use mesopush_protocol::flash::{FlashChunk, FlashHeader, FlashRejectReason, PlanStep};
use mesopush_protocol::frame::frame_len_max;
use mesopush_protocol::host::{
    ExecStatus, FrameStamp, Hello, MotionEvent, ProbeTelemetry, StagePoint, TrialEvent, TrialFault,
};
use mesopush_protocol::{CtrlToExec, ExecToCtrl, ExecToHost, FRAME_BUF_LEN, HostToExec, MaxSize};

fn sizes() -> Vec<(&'static str, usize, Option<usize>)> {
    vec![
        ("HostToExec", HostToExec::MAX_SIZE, Some(frame_len_max::<HostToExec>())),
        ("ExecToHost", ExecToHost::MAX_SIZE, Some(frame_len_max::<ExecToHost>())),
        ("ExecToCtrl", ExecToCtrl::MAX_SIZE, Some(frame_len_max::<ExecToCtrl>())),
        ("CtrlToExec", CtrlToExec::MAX_SIZE, Some(frame_len_max::<CtrlToExec>())),
        ("Hello", Hello::MAX_SIZE, None),
        ("FlashHeader", FlashHeader::MAX_SIZE, None),
        ("FlashChunk", FlashChunk::MAX_SIZE, None),
        ("FlashRejectReason", FlashRejectReason::MAX_SIZE, None),
        ("PlanStep", PlanStep::MAX_SIZE, None),
        ("ExecStatus", ExecStatus::MAX_SIZE, None),
        ("TrialEvent", TrialEvent::MAX_SIZE, None),
        ("TrialFault", TrialFault::MAX_SIZE, None),
        ("FrameStamp", FrameStamp::MAX_SIZE, None),
        ("ProbeTelemetry", ProbeTelemetry::MAX_SIZE, None),
        ("StagePoint", StagePoint::MAX_SIZE, None),
        ("MotionEvent", MotionEvent::MAX_SIZE, None),
        ("MoveSegment", MoveSegment::MAX_SIZE, None),
        ("PositionReport", PositionReport::MAX_SIZE, None),
        ("CtrlStatus", CtrlStatus::MAX_SIZE, None),
        ("FaultCode", FaultCode::MAX_SIZE, None),
        ("FaultReport", FaultReport::MAX_SIZE, None),
    ]
}

#[test]
fn size_table_in_docs_matches_constants() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/protocol.md");
    let doc = std::fs::read_to_string(path).expect("docs/protocol.md exists");
    let mut expected = String::new();
    for (name, max, frame) in sizes() {
        let frame = frame.map_or("–".to_string(), |n| n.to_string());
        expected.push_str(&format!("| `{name}` | {max} | {frame} |\n"));
    }
    assert!(
        doc.contains(&expected),
        "docs/protocol.md size table is stale; it should contain:\n{expected}"
    );
    let buf_line = format!("`FRAME_BUF_LEN` = {FRAME_BUF_LEN}");
    assert!(doc.contains(&buf_line), "docs/protocol.md should state {buf_line}");
}
