//! The point-to-point adapter driving a Sensapex uMp over SMCP v1, against datagrams written
//! by hand in hex from the documented frame layout (16-byte big-endian header, sub-blocks of
//! INT32), with the worked packets of the SDK's encoder as golden bytes.

mod p2p_common;

use mesopush_executor::adapter::AdapterEvent;
use mesopush_executor::adapter::ControllerAdapter;
use mesopush_executor::adapter::p2p::sensapex::{Sensapex, SensapexSettings};
use mesopush_executor::adapter::p2p::{Protocol, Reply, Request, Script};
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::FaultCode;
use p2p_common::{Adapter, adapter, events, fault, last_done, raw_events, segment, written};

/// Bytes from spaced hex.
fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).expect("hex byte")).collect()
}

/// One datagram.
fn datagram(a: &mut Adapter<Sensapex>, now: u64, s: &str) {
    let d = hex(s);
    assert_eq!(a.receive(now, &d), d.len());
}

fn encoded(p: &mut Sensapex, request: Request) -> Vec<u8> {
    let mut script = Script::new();
    p.encode(&request, &mut script);
    assert_eq!(script.len(), 1, "one datagram");
    script[0].bytes.to_vec()
}

/// GET_POSITIONS with message id `id` (REQ | REQ_ACK | REQ_RESP).
fn get_positions(id: u8) -> Vec<u8> {
    hex(&format!("10 00 00 01 02 37 00 {id:02X} 00 00 00 31 00 0E 00 00"))
}

/// The device's bare ACK of message `id` of type `kind`.
fn ack(id: u8, kind: u8) -> String {
    format!("10 00 02 37 00 01 00 {id:02X} 00 00 00 02 00 {kind:02X} 00 00")
}

/// The response to GET_POSITIONS `id`: INT32 × 4, nm (x, y given in hex; z 3 mm, w 0).
fn positions(id: u8, x: &str, y: &str) -> String {
    format!(
        "10 00 02 37 00 01 00 {id:02X} 00 00 00 00 00 0E 00 01 00 06 00 04 {x} {y} \
         00 2D C6 C0 00 00 00 00"
    )
}

const X_1000_UM: &str = "00 0F 42 40";
const X_1030_UM: &str = "00 0F B7 70";
const X_1090_UM: &str = "00 10 A1 D0";
const X_1100_UM: &str = "00 10 C8 E0";
const Y_2000_UM: &str = "00 1E 84 80";

/// At rest at (1000, 2000, 3000) µm after GET_POSITIONS id 1.
fn ready() -> Adapter<Sensapex> {
    let mut a = adapter(Sensapex::new(SensapexSettings::DEFAULT));
    assert_eq!(written(&mut a, 0), vec![get_positions(1)]);
    datagram(&mut a, 500, &ack(1, 0x0E));
    assert_eq!(a.measured_units(), None, "the ACK is not the answer");
    datagram(&mut a, 1_000, &positions(1, X_1000_UM, Y_2000_UM));
    assert_eq!(a.measured_units(), Some([1_000_000, 2_000_000, 3_000_000]));
    let _ = events(&mut a);
    a
}

/// GOTO_POS id 2 to (1100, 2000) µm at 100 µm/s, z and w not moved, simultaneous; ACKed.
fn move_100_um(a: &mut Adapter<Sensapex>, id: u32) {
    a.command(2_000, &segment(id, 50_000, 1_100_000, 2_000_000, 100_000));
    let goto = hex(&format!(
        "10 00 00 01 02 37 00 02 00 00 00 51 00 21 00 01 00 06 00 06 \
         {X_1100_UM} {Y_2000_UM} 7F FF FF FF 7F FF FF FF 00 00 00 64 00 00 00 01"
    ));
    assert_eq!(written(a, 50_000), vec![goto]);
    datagram(a, 51_000, &ack(2, 0x21));
}

#[test]
fn the_sdk_worked_packets_are_encoded_byte_for_byte() {
    let mut p = Sensapex::new(SensapexSettings::DEFAULT);
    // Only z moves (x and y are where they are): one sub-block, as `um_goto_position`.
    let goto = Request::MoveTo {
        from: [1_000_000, 2_000_000, 0],
        target: [1_000_000, 2_000_000, 3_000_000],
        speed_nm_s: 100_000,
    };
    let golden = hex("10 00 00 01 02 37 00 01 00 00 00 51 00 21 00 01 00 06 00 06 \
         00 0F 42 40 00 1E 84 80 00 2D C6 C0 7F FF FF FF 00 00 00 64 00 00 00 01");
    assert_eq!(encoded(&mut p, goto), golden);
    let ack = hex("10 00 02 37 00 01 00 01 00 00 00 02 00 21 00 00");
    assert_eq!(p.decode(&goto, &ack).reply, Some(Reply::Accepted));
    assert_eq!(
        encoded(&mut p, Request::Position),
        hex("10 00 00 01 02 37 00 02 00 00 00 31 00 0E 00 00")
    );
    assert_eq!(
        encoded(&mut p, Request::Stop),
        hex("10 00 00 01 02 37 00 03 00 00 00 11 00 01 00 00")
    );
    let done = hex("10 00 02 FF 00 01 12 34 00 00 00 04 00 68 00 01 00 05 00 01 00 00 00 00");
    assert_eq!(p.unsolicited(&done), Some(Reply::Busy(false)));
}

#[test]
fn notifications_are_read_only_from_the_device_and_whatever_their_code() {
    let mut p = Sensapex::new(SensapexSettings::DEFAULT);
    // A failed drive (code 5) ends the move as well: the position check decides.
    let failed = hex("10 00 02 FF 00 01 00 09 00 00 00 04 00 68 00 01 00 05 00 01 00 00 00 05");
    assert_eq!(p.unsolicited(&failed), Some(Reply::Busy(false)));
    // From device 2, or without the NOTIFY option, or to another host: not ours.
    let other = hex("10 00 02 FF 00 02 00 09 00 00 00 04 00 68 00 01 00 05 00 01 00 00 00 00");
    assert_eq!(p.unsolicited(&other), None);
    let plain = hex("10 00 02 FF 00 01 00 09 00 00 00 00 00 68 00 01 00 05 00 01 00 00 00 00");
    assert_eq!(p.unsolicited(&plain), None);
    let elsewhere = hex("10 00 02 38 00 01 00 09 00 00 00 04 00 68 00 01 00 05 00 01 00 00 00 00");
    assert_eq!(p.unsolicited(&elsewhere), None);
    // A single-axis position notification cannot place the probe.
    let one = hex("10 00 02 FF 00 01 00 0A 00 00 00 04 00 65 00 01 00 06 00 01 00 0F 42 40");
    assert_eq!(p.unsolicited(&one), None);
}

#[test]
fn a_move_is_acked_polled_by_position_and_ends_on_the_notification() {
    let mut a = ready();
    move_100_um(&mut a, 10);
    // No busy query: Busy is a GET_POSITIONS, every 30 ms from 80 ms.
    assert_eq!(written(&mut a, 80_000), vec![get_positions(3)]);
    datagram(&mut a, 80_500, &ack(3, 0x0E));
    datagram(&mut a, 81_000, &positions(3, X_1030_UM, Y_2000_UM));
    assert_eq!(a.measured_units(), Some([1_030_000, 2_000_000, 3_000_000]));
    // Positions the device pushes while it moves (to all PCs, NOTIFY).
    datagram(
        &mut a,
        900_000,
        &format!(
            "10 00 02 FF 00 01 00 07 00 00 00 04 00 65 00 01 00 06 00 04 {X_1090_UM} \
             {Y_2000_UM} 00 2D C6 C0 00 00 00 00"
        ),
    );
    assert_eq!(a.measured_units(), Some([1_090_000, 2_000_000, 3_000_000]));
    // The move completed (code 0): the position is read and checked.
    datagram(
        &mut a,
        1_050_000,
        "10 00 02 FF 00 01 00 08 00 00 00 04 00 68 00 01 00 05 00 01 00 00 00 00",
    );
    assert_eq!(written(&mut a, 1_050_000), vec![get_positions(4)]);
    datagram(&mut a, 1_051_000, &positions(4, X_1100_UM, Y_2000_UM));
    assert_eq!(last_done(&events(&mut a)), Some(10));
}

#[test]
fn without_the_notification_a_poll_at_the_target_ends_the_move() {
    let mut a = ready();
    move_100_um(&mut a, 11);
    assert_eq!(written(&mut a, 1_100_000), vec![get_positions(3)]);
    datagram(&mut a, 1_101_000, &positions(3, X_1100_UM, Y_2000_UM));
    assert_eq!(written(&mut a, 1_130_000), vec![get_positions(4)]);
    datagram(&mut a, 1_131_000, &positions(4, X_1100_UM, Y_2000_UM));
    assert_eq!(last_done(&events(&mut a)), Some(11));
}

#[test]
fn frames_that_are_not_the_answer_are_skipped() {
    let mut a = ready();
    move_100_um(&mut a, 12);
    assert_eq!(written(&mut a, 80_000), vec![get_positions(3)]);
    // Another version, another message id, another device, another receiver, another type.
    datagram(&mut a, 80_100, &positions(3, X_1100_UM, Y_2000_UM).replacen("10", "02", 1));
    datagram(&mut a, 80_200, &positions(2, X_1100_UM, Y_2000_UM));
    datagram(
        &mut a,
        80_300,
        &positions(3, X_1100_UM, Y_2000_UM).replacen("00 01 00 03", "00 02 00 03", 1),
    );
    datagram(&mut a, 80_400, &positions(3, X_1100_UM, Y_2000_UM).replacen("02 37", "02 38", 1));
    datagram(&mut a, 80_500, &positions(3, X_1100_UM, Y_2000_UM).replacen("00 0E", "00 0F", 1));
    assert_eq!(a.measured_units(), Some([1_000_000, 2_000_000, 3_000_000]));
    assert_eq!(a.stats().unreadable, 0, "other traffic is not an error");
    datagram(&mut a, 80_600, &positions(3, X_1030_UM, Y_2000_UM));
    assert_eq!(a.measured_units(), Some([1_030_000, 2_000_000, 3_000_000]));
}

#[test]
fn a_move_short_at_its_deadline_is_a_stall() {
    let mut a = ready();
    move_100_um(&mut a, 13);
    // Deadline: 50 ms + 150 % of 1 s + 1 s = 2.55 s. The stage stops at 1030 µm.
    let mut id = 3;
    let mut evs = Vec::new();
    for t in (80_000..2_800_000).step_by(30_000) {
        for w in written(&mut a, t) {
            if w == get_positions(id) {
                datagram(&mut a, t + 1_000, &positions(id, X_1030_UM, Y_2000_UM));
            } else {
                let stop = format!("10 00 00 01 02 37 00 {id:02X} 00 00 00 11 00 01 00 00");
                assert_eq!(w, hex(&stop), "after the fault, the stop");
                datagram(&mut a, t + 1_000, &ack(id, 0x01));
            }
            id += 1;
        }
        evs.extend(events(&mut a));
        if t < 2_550_000 {
            assert_eq!(fault(&evs), None, "at {t} µs");
        }
    }
    assert_eq!(fault(&evs), Some(FaultCode::Stall));
}

#[test]
fn an_unanswered_position_request_is_a_silent_controller() {
    let mut a = ready();
    assert_eq!(written(&mut a, 100_000), vec![get_positions(2)]); // the idle poll
    datagram(&mut a, 100_500, &ack(2, 0x0E)); // acknowledged, never answered
    let _ = written(&mut a, 300_001);
    assert!(raw_events(&mut a).contains(&AdapterEvent::LinkDown));
    assert!(!a.is_alive());
}

#[test]
fn stop_is_acked_and_the_position_read_again() {
    let mut a = ready();
    move_100_um(&mut a, 14);
    a.command(60_000, &ExecToCtrl::Stop);
    assert_eq!(
        written(&mut a, 60_000),
        vec![hex("10 00 00 01 02 37 00 03 00 00 00 11 00 01 00 00")]
    );
    datagram(&mut a, 61_000, &ack(3, 0x01));
    assert_eq!(written(&mut a, 80_000), vec![get_positions(4)]);
}

#[test]
fn a_diagonal_carries_per_axis_speeds_and_a_crawl_negative_nm_s() {
    let mut a = ready();
    // 30 µm along x and 40 µm along y at 100 µm/s: x 60 µm/s, y 80 µm/s (the fastest).
    a.command(2_000, &segment(15, 50_000, 1_030_000, 2_040_000, 100_000));
    let goto = hex(&format!(
        "10 00 00 01 02 37 00 02 00 00 00 51 00 21 00 02 00 06 00 06 \
         {X_1030_UM} 00 1F 20 C0 7F FF FF FF 7F FF FF FF 00 00 00 50 00 00 00 01 \
         00 06 00 02 00 00 00 3C 00 00 00 50"
    ));
    assert_eq!(written(&mut a, 50_000), vec![goto]);
    let mut a = ready();
    // 1 µm along x at 0.5 µm/s: −500 nm/s.
    a.command(2_000, &segment(16, 50_000, 1_001_000, 2_000_000, 500));
    let goto = hex(&format!(
        "10 00 00 01 02 37 00 02 00 00 00 51 00 21 00 01 00 06 00 06 \
         00 0F 46 28 {Y_2000_UM} 7F FF FF FF 7F FF FF FF FF FF FE 0C 00 00 00 01"
    ));
    assert_eq!(written(&mut a, 50_000), vec![goto]);
}

#[test]
fn an_error_ack_refuses_the_move() {
    let mut a = ready();
    a.command(2_000, &segment(17, 50_000, 1_100_000, 2_000_000, 100_000));
    let _ = written(&mut a, 50_000);
    datagram(&mut a, 51_000, "10 00 02 37 00 01 00 02 00 00 00 0A 00 21 00 00"); // ACK | ERROR
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::BadSegment));
}
