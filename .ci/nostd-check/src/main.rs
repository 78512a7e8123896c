//! Proves the mesopush no_std crates need neither `std` nor an allocator.
//!
//! A `#![no_std]` `#![no_main]` binary with its own panic handler: if any crate in the graph
//! links `std`, the build fails with a duplicate `panic_impl` lang item (host target) or a
//! missing `std` crate (bare-metal target). It calls the encoder, decoder and link so their
//! code is really compiled and linked, not just type-checked.
#![no_std]
#![no_main]

#[cfg(feature = "canary-std")]
extern crate std;


use core::hint::black_box;
use mesopush_protocol::ctrl::{CtrlToExec, ExecToCtrl, MoveSegment};
use mesopush_protocol::flash::{FlashHeader, image_crc32};
use mesopush_protocol::{FRAME_BUF_LEN, FrameReader, Link, LinkConfig, decode_frame, encode_frame};

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    loop {}
}

fn exercise() -> u32 {
    let mut link: Link<ExecToCtrl, CtrlToExec, 4> = Link::new(LinkConfig::DEFAULT, black_box(1));
    let segment = black_box(MoveSegment {
        segment_id: 1,
        start_ctrl_time_us: 10_000,
        target_x_nm: -25_000,
        target_y_nm: 40_000,
        speed_nm_s: 50_000,
    });
    if link.send(ExecToCtrl::Move(segment)).is_err() {
        return 0;
    }
    let mut buf = [0u8; FRAME_BUF_LEN];
    let len = match link.poll_transmit(black_box(0)) {
        Some(frame) => encode_frame(&frame, &mut buf).map(|b| b.len()).unwrap_or(0),
        None => 0,
    };
    let mut reader = FrameReader::<FRAME_BUF_LEN>::new();
    let mut speed_nm_s = 0;
    for &byte in black_box(&buf[..len]) {
        if let Some(Ok(frame)) = reader.push_byte(byte) {
            let decoded = decode_frame::<ExecToCtrl>(frame).ok().and_then(|f| f.into_msg());
            if let Some(ExecToCtrl::Move(m)) = decoded {
                speed_nm_s = m.speed_nm_s;
            }
        }
    }
    let image = black_box([1u8; 24]);
    let header_ok = FlashHeader::for_image(7, &image).and_then(|h| h.verify_image(&image));
    speed_nm_s ^ image_crc32(&image) ^ u32::from(header_ok.is_ok())
}

/// Runs the executor core on one input so its state machine is compiled and linked.
#[cfg(feature = "mesopush-executor")]
fn exercise_executor() -> u32 {
    use mesopush_executor::{Executor, ExecutorConfig, Input, MemStore, Outputs};
    let store = MemStore::<240>::new();
    let Ok(mut exec) = Executor::<_, 240, 8>::new(ExecutorConfig::DEFAULT, store) else {
        return 0;
    };
    let mut out = Outputs::<16>::new();
    let _ = exec.handle(black_box(5), Input::Tick, &mut out);
    out.len() as u32
}

#[cfg(not(feature = "mesopush-executor"))]
fn exercise_executor() -> u32 {
    0
}

/// The host target's precompiled `core` references the unwinding personality routine even
/// under panic=abort; it is never called, and without `std` nothing else provides it.
#[cfg(not(target_os = "none"))]
#[unsafe(no_mangle)]
extern "C" fn rust_eh_personality() {}

/// Entry point; never run, only linked.
#[unsafe(no_mangle)]
pub extern "C" fn _start() -> ! {
    black_box(exercise() ^ exercise_executor());
    loop {}
}
