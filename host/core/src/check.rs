//! Checks of input values at the boundary (loaders, command-line options): one place that
//! says how a number is refused, so every refusal names the field, the value and what is
//! allowed ([`Error::Invalid`]) instead of a later panic or a misleading downstream error.

use crate::Error;

/// The values a field allows: a finite interval whose ends may be open or unbounded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Allowed {
    /// Lower end (`None`: unbounded below) and whether it is included.
    pub lo: Option<(f64, bool)>,
    /// Upper end (`None`: unbounded above) and whether it is included.
    pub hi: Option<(f64, bool)>,
    /// Unit for the message (`""` for none).
    pub unit: &'static str,
}

impl Allowed {
    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self { lo: Some((lo, true)), hi: Some((hi, true)), unit }
    }

    /// `(lo, hi]`.
    pub const fn above_to(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self { lo: Some((lo, false)), hi: Some((hi, true)), unit }
    }

    /// `(0, hi]`: positive and at most `hi`.
    pub const fn positive_to(hi: f64, unit: &'static str) -> Self {
        Self::above_to(0.0, hi, unit)
    }

    /// Any finite number.
    pub const fn finite(unit: &'static str) -> Self {
        Self { lo: None, hi: None, unit }
    }

    /// Whether `v` is finite and inside.
    pub fn contains(&self, v: f64) -> bool {
        let lo_ok = self.lo.is_none_or(|(lo, incl)| if incl { v >= lo } else { v > lo });
        let hi_ok = self.hi.is_none_or(|(hi, incl)| if incl { v <= hi } else { v < hi });
        v.is_finite() && lo_ok && hi_ok
    }
}

impl std::fmt::Display for Allowed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let unit = if self.unit.is_empty() { String::new() } else { format!(" {}", self.unit) };
        match (self.lo, self.hi) {
            (None, None) => write!(f, "a finite number{unit}"),
            (Some((lo, incl)), None) => {
                write!(f, "a finite number {} {}{unit}", if incl { "≥" } else { ">" }, show(lo))
            }
            (None, Some((hi, incl))) => {
                write!(f, "a finite number {} {}{unit}", if incl { "≤" } else { "<" }, show(hi))
            }
            (Some((lo, li)), Some((hi, hi_incl))) => {
                let (a, b) = (if li { '[' } else { '(' }, if hi_incl { ']' } else { ')' });
                write!(f, "{a}{}, {}{b}{unit}", show(lo), show(hi))
            }
        }
    }
}

/// `value` if it is finite and `allowed` holds it, else [`Error::Invalid`] naming `field`.
pub fn finite_in(field: &str, value: f64, allowed: Allowed) -> Result<f64, Error> {
    if allowed.contains(value) {
        Ok(value)
    } else {
        Err(Error::invalid(field, show(value), allowed))
    }
}

/// A number as a message shows it: plain, or in exponent form when very large or small
/// (`1e300`, not three hundred digits).
pub fn show(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && (a >= 1e7 || (a < 1e-4 && a > 0.0)) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Every component of `values` checked by [`finite_in`], named `field[i]`.
pub fn all_finite_in(field: &str, values: &[f64], allowed: Allowed) -> Result<(), Error> {
    for (i, v) in values.iter().enumerate() {
        finite_in(&format!("{field}[{i}]"), *v, allowed)?;
    }
    Ok(())
}

/// `value` if it lies in `lo..=hi` (integers: counts, sizes, periods).
pub fn int_in<T>(field: &str, value: T, lo: T, hi: T, unit: &str) -> Result<T, Error>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    if value >= lo && value <= hi {
        return Ok(value);
    }
    let unit = if unit.is_empty() { String::new() } else { format!(" {unit}") };
    Err(Error::invalid(field, value, format!("{lo}..={hi}{unit}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_name_the_field_the_value_and_the_range() {
        let e = finite_in("speed_um_s", f64::NAN, Allowed::positive_to(1e4, "µm/s")).unwrap_err();
        assert_eq!(e.to_string(), "invalid speed_um_s = NaN: allowed (0, 10000] µm/s");
        let e = finite_in("x", f64::INFINITY, Allowed::finite("µm")).unwrap_err().to_string();
        assert!(e.contains("x = inf") && e.contains("a finite number µm"), "{e}");
        let e = all_finite_in("offset_um", &[1.0, -1.0], Allowed::closed(0.0, 5.0, "µm"));
        assert!(e.unwrap_err().to_string().contains("offset_um[1] = -1"));
        let e = finite_in("y", 1e300, Allowed::closed(0.0, 1.0, "")).unwrap_err().to_string();
        assert_eq!(e, "invalid y = 1e300: allowed [0, 1]");
        let e = int_in("population", 0usize, 2, 10_000, "").unwrap_err().to_string();
        assert_eq!(e, "invalid population = 0: allowed 2..=10000");
    }

    #[test]
    fn ends_are_open_or_closed_as_declared() {
        let a = Allowed::positive_to(1.0, "");
        assert!(!a.contains(0.0) && a.contains(1.0) && a.contains(1e-300));
        let b = Allowed { lo: Some((0.0, true)), hi: None, unit: "" };
        assert!(b.contains(0.0) && b.contains(1e300) && !b.contains(f64::INFINITY));
        assert!(!Allowed::finite("").contains(f64::NAN));
    }
}
