//! Golden-byte vectors: the exact bytes of one frame per message variant are committed in
//! `tests/golden/frames.txt`; any change to the wire format fails here.
//!
//! To accept an intended change, run with `MESOPUSH_BLESS=1`. Blessing refuses when bytes
//! changed but `SCHEMA_HASH` did not, because peers would then accept each other's handshake
//! while disagreeing on the format: edit `SCHEMA` in `src/lib.rs` first. When only the
//! sample values in `tests/common` changed, `MESOPUSH_BLESS=force` skips that guard.

mod common;

use mesopush_protocol::{
    CtrlToExec, ExecToCtrl, ExecToHost, Frame, FrameKind, HostToExec, SCHEMA_HASH, decode_frame,
};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/frames.txt")
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

fn unhex(text: &str) -> Vec<u8> {
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).expect("golden file holds hex"))
        .collect()
}

struct Golden {
    schema_hash: Option<u32>,
    frames: BTreeMap<String, Vec<u8>>,
}

fn read_golden() -> Golden {
    let text = std::fs::read_to_string(golden_path()).unwrap_or_default();
    let mut golden = Golden { schema_hash: None, frames: BTreeMap::new() };
    for line in text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        let (name, value) = line.split_once(' ').expect("lines are `name value`");
        if name == "schema_hash" {
            let digits = value.trim_start_matches("0x");
            golden.schema_hash = Some(u32::from_str_radix(digits, 16).expect("hex schema hash"));
        } else {
            golden.frames.insert(name.to_string(), unhex(value.trim()));
        }
    }
    golden
}

fn write_golden(frames: &[(String, Vec<u8>)]) {
    let mut text = String::from(
        "# Golden frames: `name hex`, one data/ack/nack frame per message variant.\n\
         # Regenerate with MESOPUSH_BLESS=1 cargo test -p mesopush-protocol --test golden\n",
    );
    let _ = writeln!(text, "schema_hash {SCHEMA_HASH:#010x}");
    for (name, bytes) in frames {
        let _ = writeln!(text, "{name} {}", hex(bytes));
    }
    std::fs::create_dir_all(golden_path().parent().expect("has parent")).expect("mkdir");
    std::fs::write(golden_path(), text).expect("write golden file");
}

#[test]
fn frames_match_golden_vectors() {
    let current = common::all_sample_frames();
    let golden = read_golden();
    let changed: Vec<&str> = current
        .iter()
        .filter(|(name, bytes)| golden.frames.get(name) != Some(bytes))
        .map(|(name, _)| name.as_str())
        .collect();
    let removed: Vec<&String> =
        golden.frames.keys().filter(|k| !current.iter().any(|(n, _)| n == *k)).collect();
    if let Some(bless) = std::env::var_os("MESOPUSH_BLESS") {
        let bytes_changed = changed.iter().any(|n| golden.frames.contains_key(*n));
        assert!(
            bless == "force" || !(bytes_changed && golden.schema_hash == Some(SCHEMA_HASH)),
            "wire bytes of {changed:?} changed but SCHEMA_HASH did not: update SCHEMA in \
             src/lib.rs (or, if only sample values in tests/common changed, MESOPUSH_BLESS=force)"
        );
        write_golden(&current);
        return;
    }
    assert_eq!(golden.schema_hash, Some(SCHEMA_HASH), "SCHEMA changed: re-bless the vectors");
    assert!(
        changed.is_empty() && removed.is_empty(),
        "wire format changed for {changed:?}, vectors without a sample {removed:?}; \
         if intended, update SCHEMA and run with MESOPUSH_BLESS=1"
    );
}

/// The committed bytes decode to the sample values, so a decoder change that still encodes
/// identically but reads differently is caught too.
#[test]
fn golden_vectors_decode_to_samples() {
    let golden = read_golden();
    let bytes_of = |name: &str| golden.frames.get(name).cloned().expect("vector exists");
    for (name, msg) in common::host_to_exec() {
        let frame = decode_frame::<HostToExec>(&mut bytes_of(name));
        assert_eq!(frame, Ok(common::data(1, 2, msg)), "{name}");
    }
    for (name, msg) in common::exec_to_host() {
        let frame = decode_frame::<ExecToHost>(&mut bytes_of(&name));
        assert_eq!(frame, Ok(common::data(300, 65_535, msg)), "{name}");
    }
    for (name, msg) in common::exec_to_ctrl() {
        let frame = decode_frame::<ExecToCtrl>(&mut bytes_of(name));
        assert_eq!(frame, Ok(common::data(65_535, 0, msg)), "{name}");
    }
    for (name, msg) in common::ctrl_to_exec() {
        let frame = decode_frame::<CtrlToExec>(&mut bytes_of(&name));
        assert_eq!(frame, Ok(common::data(5, 6, msg)), "{name}");
    }
    let ack = decode_frame::<CtrlToExec>(&mut bytes_of("link.ack"));
    let expected = Frame {
        sender_session: common::SENDER_SESSION,
        receiver_session: common::RECEIVER_SESSION,
        ack: 513,
        kind: FrameKind::Ack,
    };
    assert_eq!(ack, Ok(expected));
    let nack = decode_frame::<HostToExec>(&mut bytes_of("link.nack"));
    assert_eq!(nack.map(|f| (f.ack, f.kind)), Ok((7, FrameKind::Nack)));
    let fresh = decode_frame::<ExecToCtrl>(&mut bytes_of("link.ack_fresh"));
    let fresh_expected =
        Frame { sender_session: 7, receiver_session: None, ack: 0, kind: FrameKind::Ack };
    assert_eq!(fresh, Ok(fresh_expected));
}

/// Names are unique, so no vector silently shadows another.
#[test]
fn sample_names_are_unique() {
    let frames = common::all_sample_frames();
    let names: std::collections::BTreeSet<&String> = frames.iter().map(|(n, _)| n).collect();
    assert_eq!(names.len(), frames.len());
}

/// Index of each variant. The matches are exhaustive, so a new variant does not compile
/// until it is listed here, and the test below then fails until a sample covers it.
fn host_variant(m: &HostToExec) -> usize {
    match m {
        HostToExec::Hello(_) => 0,
        HostToExec::FlashBegin(_) => 1,
        HostToExec::FlashChunk(_) => 2,
        HostToExec::FlashCommit { .. } => 3,
        HostToExec::Arm { .. } => 4,
        HostToExec::Start { .. } => 5,
        HostToExec::Abort => 6,
        HostToExec::StatusQuery => 7,
        HostToExec::Heartbeat { .. } => 8,
        HostToExec::Goto { .. } => 9,
        HostToExec::Home => 10,
        HostToExec::Stop => 11,
    }
}

fn exec_variant(m: &ExecToHost) -> usize {
    match m {
        ExecToHost::HelloReply { .. } => 0,
        ExecToHost::FlashProgress { .. } => 1,
        ExecToHost::FlashAccepted { .. } => 2,
        ExecToHost::FlashRejected { .. } => 3,
        ExecToHost::CommandRejected(_) => 4,
        ExecToHost::Status(_) => 5,
        ExecToHost::Trial(_) => 6,
        ExecToHost::Frame(_) => 7,
        ExecToHost::Telemetry(_) => 8,
        ExecToHost::Motion(_) => 9,
    }
}

fn ctrl_cmd_variant(m: &ExecToCtrl) -> usize {
    match m {
        ExecToCtrl::Move(_) => 0,
        ExecToCtrl::Stop => 1,
        ExecToCtrl::ClockSyncQuery { .. } => 2,
        ExecToCtrl::StatusQuery => 3,
        ExecToCtrl::Heartbeat { .. } => 4,
        ExecToCtrl::ClearFault => 5,
    }
}

fn ctrl_variant(m: &CtrlToExec) -> usize {
    match m {
        CtrlToExec::Position(_) => 0,
        CtrlToExec::Status(_) => 1,
        CtrlToExec::ClockSyncReply { .. } => 2,
        CtrlToExec::Heartbeat { .. } => 3,
        CtrlToExec::Fault(_) => 4,
    }
}

fn covered(indices: impl Iterator<Item = usize>) -> std::collections::BTreeSet<usize> {
    indices.collect()
}

#[test]
fn samples_cover_every_top_level_variant() {
    let all = |n: usize| (0..n).collect::<std::collections::BTreeSet<_>>();
    assert_eq!(covered(common::host_to_exec().iter().map(|(_, m)| host_variant(m))), all(12));
    assert_eq!(covered(common::exec_to_host().iter().map(|(_, m)| exec_variant(m))), all(10));
    assert_eq!(covered(common::exec_to_ctrl().iter().map(|(_, m)| ctrl_cmd_variant(m))), all(6));
    assert_eq!(covered(common::ctrl_to_exec().iter().map(|(_, m)| ctrl_variant(m))), all(5));
}
