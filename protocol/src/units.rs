//! The one place where host units (µm, rad, s as `f64`) meet the wire's sized integers
//! (nm as `i32`/`i64`, µs as `u64`/`i64`, nm/s as `u32`). Every conversion is checked: a value
//! that does not fit is an error naming the quantity, never a silent wrap or saturation.
//!
//! It lives in the protocol crate because the wire defines the integer units and every
//! peer (host, executor recorder, firmware simulator) converts through it. `no_std`: rounding
//! is written here (half away from zero, as `f64::round`), exact for every finite input.

use core::fmt;

/// A value that does not fit the wire's integer type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutOfRange {
    /// The quantity's name (a field name, e.g. `probe_start_x`).
    pub quantity: &'static str,
    /// The value, in host units.
    pub value: f64,
    /// The host unit (`um`, `s`, `um/s`).
    pub unit: &'static str,
    /// The integer type it had to fit (`i32 nm`, `u64 us`, ...).
    pub target: &'static str,
}

impl fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} = {} {} does not fit the wire format ({}; it must be finite and in range)",
            self.quantity, self.value, self.unit, self.target
        )
    }
}

impl core::error::Error for OutOfRange {}

/// `x` rounded to the nearest integer, halves away from zero (as `f64::round`), for finite
/// `x` of magnitude below 2^62; `None` otherwise.
fn round_i64(x: f64) -> Option<i64> {
    const LIMIT: f64 = 4_611_686_018_427_387_904.0; // 2^62
    if !x.is_finite() || x.abs() >= LIMIT {
        return None;
    }
    let t = x as i64; // truncation toward zero, exact in range
    let frac = x - t as f64; // exact: x and t share the exponent range
    Some(if frac >= 0.5 {
        t + 1
    } else if frac <= -0.5 {
        t - 1
    } else {
        t
    })
}

fn scaled<T: TryFrom<i64>>(
    quantity: &'static str,
    value: f64,
    factor: f64,
    unit: &'static str,
    target: &'static str,
) -> Result<T, OutOfRange> {
    round_i64(value * factor).and_then(|v| T::try_from(v).ok()).ok_or(OutOfRange {
        quantity,
        value,
        unit,
        target,
    })
}

/// µm → nm as `i32`, rounded to the nearest nm.
pub fn um_to_nm(quantity: &'static str, um: f64) -> Result<i32, OutOfRange> {
    scaled(quantity, um, 1000.0, "um", "i32 nm")
}

/// µm → nm as `i64` (recorded positions that may exceed the wire's `i32`).
pub fn um_to_nm_i64(quantity: &'static str, um: f64) -> Result<i64, OutOfRange> {
    scaled(quantity, um, 1000.0, "um", "i64 nm")
}

/// nm → µm.
pub fn nm_to_um(nm: i32) -> f64 {
    f64::from(nm) / 1000.0
}

/// nm (`i64`) → µm.
pub fn nm_i64_to_um(nm: i64) -> f64 {
    nm as f64 / 1000.0
}

/// s → µs as `u64`, rounded; negative or non-finite times are refused.
pub fn s_to_us(quantity: &'static str, s: f64) -> Result<u64, OutOfRange> {
    scaled(quantity, s, 1e6, "s", "u64 us")
}

/// s → µs as `i64` (signed times relative to a trial's start), rounded.
pub fn s_to_us_i64(quantity: &'static str, s: f64) -> Result<i64, OutOfRange> {
    scaled(quantity, s, 1e6, "s", "i64 us")
}

/// µs → s.
pub fn us_to_s(us: u64) -> f64 {
    us as f64 / 1e6
}

/// µs (`i64`, relative) → s.
pub fn us_i64_to_s(us: i64) -> f64 {
    us as f64 / 1e6
}

/// µm/s → nm/s as `u32`; speeds are magnitudes and must be ≥ 0.
pub fn um_s_to_nm_s(quantity: &'static str, um_s: f64) -> Result<u32, OutOfRange> {
    scaled(quantity, um_s, 1000.0, "um/s", "u32 nm/s")
}

/// nm/s → µm/s.
pub fn nm_s_to_um_s(nm_s: u32) -> f64 {
    f64::from(nm_s) / 1000.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_rounding() {
        assert_eq!(um_to_nm("x", 1.2345).unwrap(), 1235);
        assert_eq!(um_to_nm("x", -0.0004).unwrap(), 0);
        assert_eq!(um_to_nm("x", -1.2345).unwrap(), -1235);
        assert_eq!(um_to_nm("x", 0.0025).unwrap(), 3, "half away from zero");
        assert_eq!(um_to_nm("x", -0.0025).unwrap(), -3, "half away from zero");
        assert_eq!(nm_to_um(-2_500), -2.5);
        assert_eq!(s_to_us("t", 1.5).unwrap(), 1_500_000);
        assert_eq!(s_to_us_i64("t", -0.25).unwrap(), -250_000);
        assert_eq!(us_to_s(250), 0.000_25);
        assert_eq!(um_s_to_nm_s("v", 140.0).unwrap(), 140_000);
        assert_eq!(nm_s_to_um_s(140_000), 140.0);
        assert_eq!(um_to_nm_i64("x", 5.0e6).unwrap(), 5_000_000_000);
    }

    #[test]
    fn rounding_matches_f64_round_exactly() {
        // The host rounded with std's f64::round before; the no_std rounding must agree bit
        // for bit, ties and the largest value below one half included.
        extern crate std;
        let mut xs = std::vec![0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.499_999_999_999_999_94];
        xs.push(-0.499_999_999_999_999_94);
        xs.push(4_503_599_627_370_495.5); // 2^52 - 0.5
        let mut x = 0.123_456_789_f64;
        for _ in 0..20_000 {
            x = (x * 1.618_034 + 0.37) % 9.0e5 - 4.0e5;
            xs.push(x);
            xs.push(x * 1000.0);
        }
        for x in xs {
            assert_eq!(round_i64(x).unwrap() as f64, x.round(), "{x}");
        }
    }

    #[test]
    fn out_of_range_is_an_error_not_a_wrap() {
        assert!(um_to_nm("x", 3.0e6).is_err());
        assert!(um_to_nm("x", f64::NAN).is_err());
        assert!(um_to_nm("x", f64::INFINITY).is_err());
        assert!(s_to_us("t", -1.0).is_err());
        assert!(um_s_to_nm_s("v", -1.0).is_err());
        let e = um_to_nm("probe_x", 1e9).unwrap_err();
        assert_eq!(e.quantity, "probe_x");
        assert_eq!(e.target, "i32 nm");
    }
}
