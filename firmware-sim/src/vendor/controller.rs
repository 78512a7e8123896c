//! The interface every vendor emulator offers to a test harness or the simulated world:
//! bytes and time in, reply bytes out, and the true stage position.

/// A vendor controller on its link, fed bytes and time, emitting reply bytes.
///
/// Time is the controller's simulated clock in µs; calls must not go back in time (an
/// earlier `now_us` is treated as the latest one seen). Every method first advances the
/// controller to `now_us`, so calling [`poll`](Self::poll) is only needed to make time pass
/// when nothing is sent or read.
pub trait VendorController {
    /// Bytes from the host arriving at `now_us`: serial bytes in any chunking, or exactly one
    /// whole UDP datagram.
    fn receive(&mut self, now_us: u64, bytes: &[u8]);

    /// Advances motion and timers to `now_us`.
    fn poll(&mut self, now_us: u64);

    /// The next reply due by `now_us`: for a serial link, the bytes fully sent by then (as
    /// many as fit in `buf`); for UDP, one whole datagram (cut to `buf`'s length, as a
    /// socket does). `None` when nothing is due.
    fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize>;

    /// The true x, y position of the probe (stage) in nm at the last time seen, for the
    /// simulated world. After a stall this differs from what the controller reports.
    fn probe_nm(&self) -> (i32, i32);

    /// The true z position in nm (held by the pushing task; reported for completeness).
    fn probe_z_nm(&self) -> i32;

    /// The next time something changes without input (a reply byte leaves, a move ends, a
    /// notification is due), µs; `None` when nothing is pending.
    fn next_deadline_us(&self) -> Option<u64>;
}

/// Steps × `nm_per_step` as nm, rounded and saturated to `i32`.
pub(crate) fn steps_to_nm(steps: i64, nm_per_step: f64) -> i32 {
    let nm = (steps as f64 * nm_per_step).round();
    nm.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

/// Saturates a step count to the `i32` a device reports.
pub(crate) fn to_i32(v: i64) -> i32 {
    i32::try_from(v).unwrap_or(if v < 0 { i32::MIN } else { i32::MAX })
}
