//! A simulated serial line (one direction) with seeded fault injection.
//!
//! Frames (encoded, delimiter included) are put on the line whole; each one may be lost,
//! have one bit flipped, be duplicated or be held back by an extra delay, with the rates of
//! [`FaultConfig`], then arrives after the base latency plus jitter. As on a real serial
//! line, delivery is first in, first out: a frame never arrives before one sent earlier, so
//! a delayed frame holds back the frames behind it (a line stall), and jitter never
//! reorders.
//! Every injected fault is counted and, when a log is attached, recorded.

use crate::config::FaultConfig;
use crate::rng::SimRng;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// What the line did to a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineFault {
    /// Lost.
    Dropped,
    /// One bit flipped (bit index in the frame).
    Corrupted(u32),
    /// Delivered twice.
    Duplicated,
    /// Held back.
    Delayed,
}

/// Counters of a line.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct LineStats {
    /// Frames put on the line.
    pub sent: u64,
    /// Frames lost.
    pub dropped: u64,
    /// Frames corrupted.
    pub corrupted: u64,
    /// Extra copies delivered.
    pub duplicated: u64,
    /// Frames delayed.
    pub delayed: u64,
}

/// One direction of a serial line.
#[derive(Debug)]
pub struct SimLine {
    rng: SimRng,
    faults: FaultConfig,
    in_flight: BinaryHeap<Reverse<(u64, u64, Vec<u8>)>>,
    counter: u64,
    last_arrival_us: u64,
    stats: LineStats,
    /// Faults injected, with the send time, in order.
    pub log: Vec<(u64, LineFault)>,
}

impl SimLine {
    /// A line drawing its faults from `rng`.
    pub fn new(rng: SimRng, faults: FaultConfig) -> Self {
        Self {
            rng,
            faults,
            in_flight: BinaryHeap::new(),
            counter: 0,
            last_arrival_us: 0,
            stats: LineStats::default(),
            log: Vec::new(),
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> LineStats {
        self.stats
    }

    /// Puts one frame on the line at `now_us`.
    pub fn send(&mut self, now_us: u64, frame: &[u8]) {
        self.stats.sent += 1;
        let f = self.faults;
        let copies = if self.rng.chance(f.link_duplicate) {
            self.stats.duplicated += 1;
            self.log.push((now_us, LineFault::Duplicated));
            2
        } else {
            1
        };
        for _ in 0..copies {
            if self.rng.chance(f.link_drop) {
                self.stats.dropped += 1;
                self.log.push((now_us, LineFault::Dropped));
                continue;
            }
            let mut bytes = frame.to_vec();
            if !bytes.is_empty() && self.rng.chance(f.link_corrupt) {
                let bit = self.rng.below(bytes.len() as u64 * 8) as usize;
                bytes[bit / 8] ^= 1 << (bit % 8);
                self.stats.corrupted += 1;
                self.log.push((now_us, LineFault::Corrupted(bit as u32)));
            }
            let mut at_us = now_us + f.link_latency_us + self.rng.below(f.link_jitter_us + 1);
            if self.rng.chance(f.link_delay) {
                at_us += f.link_delay_us;
                self.stats.delayed += 1;
                self.log.push((now_us, LineFault::Delayed));
            }
            at_us = at_us.max(self.last_arrival_us); // FIFO
            self.last_arrival_us = at_us;
            self.counter += 1;
            self.in_flight.push(Reverse((at_us, self.counter, bytes)));
        }
    }

    /// The next frame that has arrived by `now_us`.
    pub fn recv(&mut self, now_us: u64) -> Option<Vec<u8>> {
        if self.in_flight.peek().is_some_and(|Reverse((at, _, _))| *at <= now_us) {
            self.in_flight.pop().map(|Reverse((_, _, bytes))| bytes)
        } else {
            None
        }
    }

    /// Frames still on the line.
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clean_line_delivers_in_order_after_the_latency() {
        let mut line =
            SimLine::new(SimRng::new(1), FaultConfig { link_jitter_us: 0, ..FaultConfig::NONE });
        line.send(0, b"ab\0");
        line.send(10, b"cd\0");
        assert_eq!(line.recv(199), None);
        assert_eq!(line.recv(200).as_deref(), Some(&b"ab\0"[..]));
        assert_eq!(line.recv(205), None);
        assert_eq!(line.recv(210).as_deref(), Some(&b"cd\0"[..]));
    }

    #[test]
    fn delays_and_jitter_never_reorder() {
        let faults = FaultConfig { link_delay: 0.3, link_jitter_us: 500, ..FaultConfig::NONE };
        let mut line = SimLine::new(SimRng::new(3), faults);
        for i in 0..200u8 {
            line.send(u64::from(i) * 10, &[i, 0]);
        }
        let mut got = Vec::new();
        for t in 0..100_000 {
            while let Some(b) = line.recv(t) {
                got.push(b[0]);
            }
        }
        assert_eq!(got, (0..200).collect::<Vec<u8>>());
        assert!(line.stats().delayed > 30);
    }

    #[test]
    fn faults_follow_the_seed() {
        let faults = FaultConfig {
            link_drop: 0.2,
            link_corrupt: 0.2,
            link_duplicate: 0.2,
            link_delay: 0.2,
            ..FaultConfig::NONE
        };
        let run = |seed| {
            let mut line = SimLine::new(SimRng::new(seed), faults);
            for i in 0..500 {
                line.send(i * 100, &[1, 2, 3, 4, 0]);
            }
            (line.log.clone(), line.stats())
        };
        assert_eq!(run(9), run(9));
        assert_ne!(run(9).0, run(10).0);
        let stats = run(9).1;
        assert!(
            stats.dropped > 50
                && stats.corrupted > 50
                && stats.duplicated > 50
                && stats.delayed > 50,
            "{stats:?}"
        );
    }
}
