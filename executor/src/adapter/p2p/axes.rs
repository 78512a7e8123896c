//! A straight move's axes: its fastest axis and its length, and the conversion between the
//! speed along the line (what a plan step asks for) and the speed of the fastest axis (what
//! most point-to-point controllers are told: Sutter's speed settings are per axis, and a
//! Sensapex's single speed argument is shared by its axes). Device units in, device units
//! (or nm/s, unit-free ratios) out; no conversion between units here ([`super::scale`]).

/// Per-axis distances `|target − from|`, device units.
pub fn deltas(from: [i32; 3], target: [i32; 3]) -> [u64; 3] {
    core::array::from_fn(|k| (i64::from(target[k]) - i64::from(from[k])).unsigned_abs())
}

/// (Longest axis, line length) of `from → target`, device units.
pub fn lengths(from: [i32; 3], target: [i32; 3]) -> (u64, u64) {
    let d = deltas(from, target);
    let sq: u128 = d.iter().map(|&v| u128::from(v) * u128::from(v)).sum();
    (d.into_iter().max().unwrap_or(0), u64::try_from(sq.isqrt()).unwrap_or(u64::MAX))
}

/// The speed the fastest axis needs for `line_nm_s` along `from → target`, nm/s (a move of
/// zero length: `line_nm_s`).
pub fn fastest_axis_nm_s(from: [i32; 3], target: [i32; 3], line_nm_s: u32) -> u64 {
    let (max_axis, norm) = lengths(from, target);
    if norm == 0 {
        return u64::from(line_nm_s);
    }
    let axis = u128::from(line_nm_s) * u128::from(max_axis) / u128::from(norm);
    u64::try_from(axis).unwrap_or(u64::MAX)
}

/// The speed along `from → target` when its fastest axis runs at `axis_nm_s`, nm/s
/// (saturating; a move of zero length: `axis_nm_s`).
pub fn line_nm_s(from: [i32; 3], target: [i32; 3], axis_nm_s: u64) -> u32 {
    let (max_axis, norm) = lengths(from, target);
    if max_axis == 0 {
        return u32::try_from(axis_nm_s).unwrap_or(u32::MAX);
    }
    let line = u128::from(axis_nm_s) * u128::from(norm) / u128::from(max_axis);
    u32::try_from(line).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_diagonal_asks_less_of_each_axis_than_of_the_line() {
        let o = [0, 0, 0];
        assert_eq!(lengths(o, [300, -400, 0]), (400, 500));
        assert_eq!(fastest_axis_nm_s(o, [300, -400, 0], 100_000), 80_000);
        assert_eq!(line_nm_s(o, [300, -400, 0], 80_000), 100_000);
        assert_eq!(fastest_axis_nm_s(o, [0, 0, 0], 7), 7);
        assert_eq!(line_nm_s(o, [0, 0, 0], 7), 7);
    }
}
