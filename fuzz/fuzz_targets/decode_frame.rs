//! Fuzzes the frame decoder: arbitrary bytes, decoded as each of the four message types,
//! must never panic, and any frame that decodes must re-encode to exactly the input bytes
//! (the decoder accepts only canonical frames). The same bytes are also pushed through a
//! `FrameReader` and a `Link`, which must not panic either.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mesopush_protocol::{
    CtrlToExec, ExecToCtrl, ExecToHost, FRAME_BUF_LEN, FrameReader, HostToExec, Link, LinkConfig,
    MaxSize, decode_frame, encode_frame,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

fn check<M: Serialize + DeserializeOwned + MaxSize>(data: &[u8]) {
    let mut buf = data.to_vec();
    if let Ok(frame) = decode_frame::<M>(&mut buf) {
        let mut out = [0u8; FRAME_BUF_LEN];
        let encoded = encode_frame(&frame, &mut out).expect("a decoded frame re-encodes");
        let body = data.strip_suffix(&[0]).unwrap_or(data);
        assert_eq!(&encoded[..encoded.len() - 1], body, "decoder accepted a non-canonical frame");
    }
}

fuzz_target!(|data: &[u8]| {
    check::<HostToExec>(data);
    check::<ExecToHost>(data);
    check::<ExecToCtrl>(data);
    check::<CtrlToExec>(data);

    let mut reader = FrameReader::<FRAME_BUF_LEN>::new();
    let mut link = Link::<ExecToCtrl, CtrlToExec, 4>::new(LinkConfig::DEFAULT, 1);
    for (i, &byte) in data.iter().enumerate() {
        if let Some(Ok(frame)) = reader.push_byte(byte) {
            let _ = link.on_bytes(i as u64 * 100, frame);
        }
        let _ = link.poll(i as u64 * 100);
        while link.poll_transmit(i as u64 * 100).is_some() {}
    }
});
