//! The one place where host units (µm, rad, s as `f64`) meet the wire's sized integers
//! (nm as `i32`, µs as `u64`, nm/s as `u32`). Every conversion is checked: a value that does
//! not fit is an error naming the quantity, never a silent wrap or saturation.

use crate::Error;

/// µm → nm as `i32`, rounded to the nearest nm.
pub fn um_to_nm(quantity: &'static str, um: f64) -> Result<i32, Error> {
    let nm = (um * 1000.0).round();
    if nm.is_finite() && nm >= i32::MIN as f64 && nm <= i32::MAX as f64 {
        Ok(nm as i32)
    } else {
        Err(Error::OutOfRange { quantity, value: um, unit: "um" })
    }
}

/// nm → µm.
pub fn nm_to_um(nm: i32) -> f64 {
    f64::from(nm) / 1000.0
}

/// s → µs as `u64`, rounded; negative or non-finite times are refused.
pub fn s_to_us(quantity: &'static str, s: f64) -> Result<u64, Error> {
    let us = (s * 1e6).round();
    if us.is_finite() && us >= 0.0 && us <= u64::MAX as f64 {
        Ok(us as u64)
    } else {
        Err(Error::OutOfRange { quantity, value: s, unit: "s" })
    }
}

/// µs → s.
pub fn us_to_s(us: u64) -> f64 {
    us as f64 / 1e6
}

/// µm/s → nm/s as `u32`; speeds are magnitudes and must be ≥ 0.
pub fn um_s_to_nm_s(quantity: &'static str, um_s: f64) -> Result<u32, Error> {
    let nm_s = (um_s * 1000.0).round();
    if nm_s.is_finite() && nm_s >= 0.0 && nm_s <= u32::MAX as f64 {
        Ok(nm_s as u32)
    } else {
        Err(Error::OutOfRange { quantity, value: um_s, unit: "um/s" })
    }
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
        assert_eq!(nm_to_um(-2_500), -2.5);
        assert_eq!(s_to_us("t", 1.5).unwrap(), 1_500_000);
        assert_eq!(us_to_s(250), 0.000_25);
        assert_eq!(um_s_to_nm_s("v", 140.0).unwrap(), 140_000);
        assert_eq!(nm_s_to_um_s(140_000), 140.0);
    }

    #[test]
    fn out_of_range_is_an_error_not_a_wrap() {
        assert!(um_to_nm("x", 3.0e6).is_err());
        assert!(um_to_nm("x", f64::NAN).is_err());
        assert!(s_to_us("t", -1.0).is_err());
        assert!(um_s_to_nm_s("v", -1.0).is_err());
        let e = um_to_nm("probe_x", 1e9).unwrap_err().to_string();
        assert!(e.contains("probe_x"), "{e}");
    }
}
