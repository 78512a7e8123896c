//! Where the executor's time (`exec_time_us`) comes from.
//!
//! The core never reads a clock: callers pass `now_us`. Shells and simulations get it from a
//! [`Clock`]: [`ManualClock`] for tests and simulations (advanced by hand), and, with the
//! `std` feature, [`MonotonicClock`] for the real shell.

use core::cell::Cell;

/// A monotonic source of executor time, µs.
pub trait Clock {
    /// Current time, µs since the clock's epoch; never decreases.
    fn now_us(&self) -> u64;
}

/// A clock tests and simulations advance by hand.
#[derive(Debug, Default)]
pub struct ManualClock {
    now_us: Cell<u64>,
}

impl ManualClock {
    /// A clock reading `start_us`.
    pub const fn new(start_us: u64) -> Self {
        Self { now_us: Cell::new(start_us) }
    }

    /// Moves time forward by `dt_us`.
    pub fn advance(&self, dt_us: u64) {
        self.now_us.set(self.now_us.get().saturating_add(dt_us));
    }

    /// Sets the time; refuses (returns false) to go backwards.
    pub fn set(&self, now_us: u64) -> bool {
        if now_us < self.now_us.get() {
            return false;
        }
        self.now_us.set(now_us);
        true
    }
}

impl Clock for ManualClock {
    fn now_us(&self) -> u64 {
        self.now_us.get()
    }
}

/// `CLOCK_MONOTONIC` now, µs: the time domain every process on one machine shares (the
/// clock V4L2 stamps camera buffers with, and the one the camera channel's
/// `capture_mono_us` is in; see `mesopush_protocol::camera`).
#[cfg(feature = "std")]
pub fn monotonic_now_us() -> u64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    let us = i128::from(t.tv_sec) * 1_000_000 + i128::from(t.tv_nsec) / 1_000;
    u64::try_from(us).unwrap_or(0)
}

/// The machine's monotonic clock (`CLOCK_MONOTONIC`), µs since this value was created.
///
/// The epoch is kept as a `CLOCK_MONOTONIC` reading, so times from other processes on the
/// same machine (camera driver stamps) convert exactly: `exec_time_us = mono_us − epoch`.
#[cfg(feature = "std")]
#[derive(Debug)]
pub struct MonotonicClock {
    epoch_mono_us: u64,
}

#[cfg(feature = "std")]
impl MonotonicClock {
    /// A clock reading 0 now.
    pub fn new() -> Self {
        Self { epoch_mono_us: monotonic_now_us() }
    }

    /// The epoch, µs of `CLOCK_MONOTONIC`.
    pub fn epoch_mono_us(&self) -> u64 {
        self.epoch_mono_us
    }

    /// A `CLOCK_MONOTONIC` time in this clock (`None` before the epoch).
    pub fn from_mono_us(&self, mono_us: u64) -> Option<u64> {
        mono_us.checked_sub(self.epoch_mono_us)
    }

    /// This clock's time as `CLOCK_MONOTONIC` µs.
    pub fn to_mono_us(&self, exec_time_us: u64) -> u64 {
        self.epoch_mono_us.saturating_add(exec_time_us)
    }
}

#[cfg(feature = "std")]
impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(feature = "std")]
impl Clock for MonotonicClock {
    fn now_us(&self) -> u64 {
        monotonic_now_us().saturating_sub(self.epoch_mono_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_clock_refuses_to_go_back() {
        let clock = ManualClock::new(10);
        clock.advance(5);
        assert_eq!(clock.now_us(), 15);
        assert!(!clock.set(14));
        assert!(clock.set(20));
        assert_eq!(clock.now_us(), 20);
    }

    #[cfg(feature = "std")]
    #[test]
    fn monotonic_clock_converts_machine_time_both_ways() {
        let clock = MonotonicClock::new();
        let mono = monotonic_now_us();
        let t = clock.from_mono_us(mono).expect("after the epoch");
        assert_eq!(clock.to_mono_us(t), mono);
        assert!(clock.now_us() >= t, "never behind a reading taken earlier");
        assert_eq!(clock.from_mono_us(clock.epoch_mono_us() - 1), None);
    }
}
