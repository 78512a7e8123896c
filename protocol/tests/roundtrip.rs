//! proptest round-trips: every message type, over the full range of every field, encodes to
//! a frame within its compile-time bound and decodes back to itself.

mod common;

use common::strategies as st;
use mesopush_protocol::flash::{PlanStep, image_steps};
use mesopush_protocol::frame::frame_len_max;
use mesopush_protocol::{
    CtrlToExec, ExecToCtrl, ExecToHost, FRAME_BUF_LEN, Frame, FrameKind, FrameReader, HostToExec,
    MaxSize, decode_frame, encode_frame,
};
use proptest::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Debug;

/// Sender session, receiver session, ack.
type Header = (u16, Option<u16>, u16);

fn roundtrip<M>(header: Header, seq: u16, msg: M) -> Result<(), TestCaseError>
where
    M: Serialize + DeserializeOwned + MaxSize + PartialEq + Debug + Clone,
{
    let mut scratch = [0u8; FRAME_BUF_LEN];
    let body_len = postcard::to_slice(&msg, &mut scratch).map(|b| b.len());
    prop_assert!(
        body_len.as_ref().is_ok_and(|&n| n <= M::MAX_SIZE),
        "body {body_len:?} > MAX_SIZE {}",
        M::MAX_SIZE
    );
    let (sender_session, receiver_session, ack) = header;
    let kind = FrameKind::Data { seq, msg };
    let frame = Frame { sender_session, receiver_session, ack, kind };
    let mut buf = [0u8; FRAME_BUF_LEN];
    let len = encode_frame(&frame, &mut buf).map(|b| b.len());
    let len = len.map_err(|e| TestCaseError::fail(format!("encode: {e}")))?;
    prop_assert!(len <= frame_len_max::<M>(), "frame {len} > bound {}", frame_len_max::<M>());
    prop_assert_eq!(buf[len - 1], 0, "frame ends with the delimiter");
    prop_assert!(!buf[..len - 1].contains(&0), "no delimiter inside a frame");
    let decoded: Frame<M> =
        decode_frame(&mut buf[..len]).map_err(|e| TestCaseError::fail(format!("decode: {e}")))?;
    prop_assert_eq!(decoded, frame);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2_000))]

    #[test]
    fn host_to_exec_roundtrips(header: Header, seq: u16, msg in st::host_to_exec()) {
        roundtrip::<HostToExec>(header, seq, msg)?;
    }

    #[test]
    fn exec_to_host_roundtrips(header: Header, seq: u16, msg in st::exec_to_host()) {
        roundtrip::<ExecToHost>(header, seq, msg)?;
    }

    #[test]
    fn exec_to_ctrl_roundtrips(header: Header, seq: u16, msg in st::exec_to_ctrl()) {
        roundtrip::<ExecToCtrl>(header, seq, msg)?;
    }

    #[test]
    fn ctrl_to_exec_roundtrips(header: Header, seq: u16, msg in st::ctrl_to_exec()) {
        roundtrip::<CtrlToExec>(header, seq, msg)?;
    }

    #[test]
    fn ack_and_nack_frames_roundtrip(header: Header, nack: bool) {
        let (sender_session, receiver_session, ack) = header;
        let kind = if nack { FrameKind::Nack } else { FrameKind::Ack };
        let frame: Frame<HostToExec> = Frame { sender_session, receiver_session, ack, kind };
        let mut buf = [0u8; FRAME_BUF_LEN];
        let len = encode_frame(&frame, &mut buf).map(|b| b.len()).expect("fits");
        prop_assert_eq!(decode_frame::<HostToExec>(&mut buf[..len]), Ok(frame));
    }

    #[test]
    fn plan_steps_roundtrip_through_image_layout(
        steps in proptest::collection::vec((any::<i32>(), any::<i32>(), any::<u32>()), 0..40)
    ) {
        let steps: Vec<PlanStep> = steps
            .into_iter()
            .map(|(dx_nm, dy_nm, speed_nm_s)| PlanStep { dx_nm, dy_nm, speed_nm_s })
            .collect();
        let image: Vec<u8> = steps.iter().flat_map(|s| s.to_image_bytes()).collect();
        prop_assert_eq!(image_steps(&image).collect::<Vec<_>>(), steps);
    }

    /// Frames concatenated on a stream and cut into arbitrary pieces come out of the reader
    /// whole and decode to the messages sent.
    #[test]
    fn frame_reader_reassembles_split_stream(
        msgs in proptest::collection::vec(st::exec_to_ctrl(), 1..20),
        cuts in proptest::collection::vec(1usize..40, 1..50),
    ) {
        let mut stream = vec![0u8]; // leading delimiter, as a receiver resync would see
        for (i, msg) in msgs.iter().enumerate() {
            stream.extend_from_slice(&common::data_frame(i as u16, 0, *msg));
        }
        let mut reader = FrameReader::<FRAME_BUF_LEN>::new();
        let mut received = Vec::new();
        let mut pos = 0;
        let mut cut = cuts.iter().cycle();
        while pos < stream.len() {
            let end = (pos + cut.next().copied().unwrap_or(1)).min(stream.len());
            for &byte in &stream[pos..end] {
                if let Some(frame) = reader.push_byte(byte) {
                    let bytes = frame.map_err(|e| TestCaseError::fail(e.to_string()))?;
                    match decode_frame::<ExecToCtrl>(bytes) {
                        Ok(Frame { kind: FrameKind::Data { msg, .. }, .. }) => received.push(msg),
                        other => return Err(TestCaseError::fail(format!("{other:?}"))),
                    }
                }
            }
            pos = end;
        }
        prop_assert_eq!(received, msgs);
    }
}

/// The bound is exact for the largest variants: a full flash chunk with maximal varints
/// takes exactly `HostToExec::MAX_SIZE` bytes, so the constant is neither too small (the
/// proptests) nor padded.
#[test]
fn max_size_is_tight_for_full_flash_chunk() {
    use mesopush_protocol::flash::{FLASH_CHUNK_MAX_BYTES, FlashChunk};
    let mut data = heapless::Vec::new();
    data.resize(FLASH_CHUNK_MAX_BYTES, 0xA5).expect("capacity");
    let msg =
        HostToExec::FlashChunk(FlashChunk { plan_id: u32::MAX, offset_bytes: u32::MAX, data });
    let mut buf = [0u8; FRAME_BUF_LEN];
    assert_eq!(postcard::to_slice(&msg, &mut buf).map(|b| b.len()), Ok(HostToExec::MAX_SIZE));
    let kind = FrameKind::Data { seq: u16::MAX, msg };
    let frame =
        Frame { sender_session: u16::MAX, receiver_session: Some(u16::MAX), ack: u16::MAX, kind };
    let len = encode_frame(&frame, &mut buf).map(|b| b.len()).expect("fits");
    assert!(len <= frame_len_max::<HostToExec>(), "{len}");
    assert!(frame_len_max::<HostToExec>() <= FRAME_BUF_LEN);
}

#[test]
fn encode_into_small_buffer_is_an_error_not_a_panic() {
    let frame = common::data(1, 2, ExecToCtrl::Stop);
    let mut full = [0u8; FRAME_BUF_LEN];
    let needed = encode_frame(&frame, &mut full).map(|b| b.len()).expect("fits");
    for len in 0..needed {
        let mut buf = vec![0u8; len];
        let result = encode_frame(&frame, &mut buf).map(|b| b.len());
        assert_eq!(result, Err(mesopush_protocol::WireError::BufferTooSmall), "buffer of {len}");
    }
    let mut exact = vec![0u8; needed];
    assert_eq!(encode_frame(&frame, &mut exact), Ok(&full[..needed]));
}
