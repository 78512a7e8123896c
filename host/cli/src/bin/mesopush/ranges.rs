//! Value parsers for the numeric command-line options: every number is checked as clap
//! parses it, so a NaN, an infinity, a zero count or a value out of range is refused before
//! anything runs — by clap, with exit status 2 and a message naming the option, the value
//! and the allowed range (`invalid value 'NaN' for '--theta0-deg <THETA0_DEG>': allowed:
//! [-360, 360] °`). The ranges are those of [`mesopush_core::check`], the loaders' checks.

use mesopush_core::check::Allowed;

/// A parser of a finite `f64` inside `allowed`.
pub(crate) fn real(
    allowed: Allowed,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let v: f64 = s.trim().parse().map_err(|e| format!("{e}; allowed: {allowed}"))?;
        if allowed.contains(v) { Ok(v) } else { Err(format!("allowed: {allowed}")) }
    }
}

/// A parser of a count in `lo..=hi`.
pub(crate) fn count(
    lo: usize,
    hi: usize,
) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let v: usize = s.trim().parse().map_err(|e| format!("{e}; allowed: {lo}..={hi}"))?;
        if (lo..=hi).contains(&v) { Ok(v) } else { Err(format!("allowed: {lo}..={hi}")) }
    }
}

/// A simulator step, µm: (0, 1000].
pub(crate) fn step_um() -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    real(Allowed::positive_to(1000.0, "µm"))
}

/// A friction coefficient: [0, 2] (the model's range).
pub(crate) fn mu() -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    real(Allowed::closed(0.0, 2.0, ""))
}

/// A non-negative length, µm, at most `hi`.
pub(crate) fn length_um(
    hi: f64,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    real(Allowed::closed(0.0, hi, "µm"))
}

/// A count of at least one, at most ten million (a bounded loop).
pub(crate) fn at_least_one()
-> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    count(1, 10_000_000)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_infinity_zero_and_out_of_range_are_refused_with_the_range() {
        let p = step_um();
        assert_eq!(p("2.5"), Ok(2.5));
        for bad in ["NaN", "inf", "0", "-1", "1e300", "x"] {
            let e = p(bad).unwrap_err();
            assert!(e.contains("(0, 1000] µm"), "{bad}: {e}");
        }
        let c = count(2, 10);
        assert_eq!(c("2"), Ok(2));
        assert_eq!(c("0").unwrap_err(), "allowed: 2..=10");
        assert!(c("-1").unwrap_err().contains("2..=10"));
    }
}
