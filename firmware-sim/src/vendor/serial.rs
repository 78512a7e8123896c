//! The transmit side of a controller's UART: reply bytes leave one at a time at the baud
//! rate, so a reply is not complete before its bytes could have been sent.
//!
//! Each byte takes 10 bit times (8N1: start bit, 8 data bits, stop bit), e.g. 1041.67 µs at
//! 9600 baud and 78.125 µs at 128000. A reply queued with a due time starts when it is due
//! or when the line is free, whichever is later; [`SerialTx::transmit`] hands out only the
//! bytes whose last bit has left by `now`. Times are kept in ns to avoid drift.

use std::collections::VecDeque;

/// Bits on the wire per byte (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// A UART transmitter with byte timing.
#[derive(Debug, Clone)]
pub struct SerialTx {
    byte_ns: u64,
    free_at_ns: u64,
    queue: VecDeque<(u64, u8)>,
}

impl SerialTx {
    /// A transmitter at `baud` (bits per second; 0 is taken as 1).
    pub fn new(baud: u32) -> Self {
        Self { byte_ns: Self::byte_ns(baud), free_at_ns: 0, queue: VecDeque::new() }
    }

    fn byte_ns(baud: u32) -> u64 {
        (BITS_PER_BYTE * 1_000_000_000).div_ceil(u64::from(baud.max(1)))
    }

    /// Changes the baud rate for bytes queued from now on.
    pub fn set_baud(&mut self, baud: u32) {
        self.byte_ns = Self::byte_ns(baud);
    }

    /// Queues `bytes` to start leaving at `due_us` (or when the line is free).
    pub fn send(&mut self, due_us: u64, bytes: &[u8]) {
        let mut t = self.free_at_ns.max(due_us.saturating_mul(1000));
        for &b in bytes {
            t = t.saturating_add(self.byte_ns);
            self.queue.push_back((t, b));
        }
        self.free_at_ns = t;
    }

    /// Copies into `buf` the bytes fully sent by `now_us`; `None` when there are none (or
    /// `buf` is empty).
    pub fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        let now_ns = now_us.saturating_mul(1000);
        let mut n = 0;
        while n < buf.len() {
            match self.queue.front() {
                Some(&(t, b)) if t <= now_ns => {
                    buf[n] = b;
                    n += 1;
                    self.queue.pop_front();
                }
                _ => break,
            }
        }
        (n > 0).then_some(n)
    }

    /// When the next byte will have been sent, µs (rounded up).
    pub fn next_release_us(&self) -> Option<u64> {
        self.queue.front().map(|&(t, _)| t.div_ceil(1000))
    }

    /// Drops every byte not yet handed out (a power cycle).
    pub fn clear(&mut self) {
        self.queue.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thirteen_bytes_at_9600_take_13_5_ms() {
        let mut tx = SerialTx::new(9600);
        tx.send(1_000, &[7; 13]);
        let mut buf = [0; 32];
        assert_eq!(tx.transmit(1_000 + 13_541, &mut buf), Some(12));
        assert_eq!(tx.next_release_us(), Some(1_000 + 13_542));
        assert_eq!(tx.transmit(1_000 + 13_542, &mut buf), Some(1));
        assert_eq!(tx.transmit(u64::MAX / 2000, &mut buf), None);
    }
}
