//! A seeded faulty serial line for link tests: loses, duplicates, corrupts and reorders
//! frames, with delivery times on a manual clock.

use mesopush_protocol::{FRAME_BUF_LEN, Link, MaxSize, encode_frame};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn chance(&mut self, p: f64) -> bool {
        ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64) < p
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

#[derive(Clone, Copy, Debug)]
pub struct Faults {
    pub loss: f64,
    pub duplicate: f64,
    pub corrupt: f64,
    pub base_latency_us: u64,
    pub jitter_us: u64,
}

/// One direction of a serial line that loses, duplicates, corrupts and reorders frames.
#[derive(Default)]
pub struct Channel {
    queue: BinaryHeap<Reverse<(u64, u64, Vec<u8>)>>,
    counter: u64,
}

impl Channel {
    pub fn push(&mut self, rng: &mut Rng, faults: Faults, now_us: u64, bytes: &[u8]) {
        let copies = if rng.chance(faults.duplicate) { 2 } else { 1 };
        for _ in 0..copies {
            if rng.chance(faults.loss) {
                continue;
            }
            let mut bytes = bytes.to_vec();
            if rng.chance(faults.corrupt) {
                let bit = rng.below(bytes.len() as u64 * 8) as usize;
                bytes[bit / 8] ^= 1 << (bit % 8);
            }
            let at_us = now_us + faults.base_latency_us + rng.below(faults.jitter_us + 1);
            self.counter += 1;
            self.queue.push(Reverse((at_us, self.counter, bytes)));
        }
    }

    pub fn pop_due(&mut self, now_us: u64) -> Option<Vec<u8>> {
        if self.queue.peek().is_some_and(|Reverse((at, _, _))| *at <= now_us) {
            self.queue.pop().map(|Reverse((_, _, bytes))| bytes)
        } else {
            None
        }
    }
}

/// Sends every frame the link has ready into the channel.
pub fn flush<Tx: Serialize + MaxSize, Rx: DeserializeOwned, const W: usize>(
    link: &mut Link<Tx, Rx, W>,
    channel: &mut Channel,
    rng: &mut Rng,
    faults: Faults,
    now_us: u64,
) {
    let mut buf = [0u8; FRAME_BUF_LEN];
    while let Some(frame) = link.poll_transmit(now_us) {
        let bytes = encode_frame(&frame, &mut buf).expect("frames fit the buffer");
        channel.push(rng, faults, now_us, bytes);
    }
}
