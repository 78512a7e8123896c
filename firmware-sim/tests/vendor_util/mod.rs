//! Helpers shared by the vendor-emulator tests: read what a controller has sent by a time.

#![allow(dead_code)]

use mesopush_firmware_sim::vendor::VendorController;

/// Every serial byte released by `now_us`.
pub(crate) fn take(c: &mut impl VendorController, now_us: u64) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; 64];
    while let Some(n) = c.transmit(now_us, &mut buf) {
        out.extend_from_slice(&buf[..n]);
    }
    out
}

/// Every datagram released by `now_us`, in order.
pub(crate) fn datagrams(c: &mut impl VendorController, now_us: u64) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut buf = [0u8; 2048];
    while let Some(n) = c.transmit(now_us, &mut buf) {
        out.push(buf[..n].to_vec());
    }
    out
}

/// `v` as 4 little-endian bytes.
pub(crate) fn le(v: i32) -> [u8; 4] {
    v.to_le_bytes()
}

/// Seconds → µs through the project's one conversion module.
pub(crate) fn us(s: f64) -> u64 {
    mesopush_protocol::units::s_to_us("test duration", s).unwrap()
}

/// Duration of a rest-to-rest trapezoidal move over `d` at peak `v` and acceleration `a`
/// (triangular when `d < v²/a`), s. Written out here, independently of the emulators'
/// motion model.
pub(crate) fn trapezoid_s(d: f64, v: f64, a: f64) -> f64 {
    if d >= v * v / a { d / v + v / a } else { 2.0 * (d / a).sqrt() }
}
