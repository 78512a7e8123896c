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

/// The host's monotonic clock, µs since this value was created.
#[cfg(feature = "std")]
#[derive(Debug)]
pub struct MonotonicClock {
    epoch: std::time::Instant,
}

#[cfg(feature = "std")]
impl MonotonicClock {
    /// A clock reading 0 now.
    pub fn new() -> Self {
        Self { epoch: std::time::Instant::now() }
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
        u64::try_from(self.epoch.elapsed().as_micros()).unwrap_or(u64::MAX)
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
}
