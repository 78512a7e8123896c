//! Device units ↔ nm: the one place a point-to-point adapter converts between the core's
//! positions (nm, `i32`) and a controller's steps or ticks (`units_per_um` per µm).
//! Rounded to the nearest unit (halves away from zero); saturating at the `i32` range, which
//! no stage's travel approaches (25 mm at 100 ticks/µm is 2.5 × 10⁶ ticks).

/// nm → device units, nearest.
pub fn nm_to_units(nm: i32, units_per_um: u32) -> i32 {
    let num = i64::from(nm) * i64::from(units_per_um);
    let units = if num >= 0 { (num + 500) / 1000 } else { (num - 500) / 1000 };
    units.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// Device units → nm, nearest.
pub fn units_to_nm(units: i32, units_per_um: u32) -> i32 {
    let per = i64::from(units_per_um.max(1));
    let num = i64::from(units) * 1000;
    let nm = if num >= 0 { (num + per / 2) / per } else { (num - per / 2) / per };
    nm.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_microsteps_per_um_round_to_the_nearest_step() {
        assert_eq!(nm_to_units(1_000, 16), 16);
        assert_eq!(nm_to_units(31, 16), 0); // 0.496 steps
        assert_eq!(nm_to_units(32, 16), 1); // 0.512 steps
        assert_eq!(nm_to_units(-32, 16), -1);
        assert_eq!(units_to_nm(1, 16), 63); // 62.5 nm, half away from zero
        assert_eq!(units_to_nm(-1, 16), -63);
        assert_eq!(units_to_nm(400_000, 16), 25_000_000); // 25 mm of travel
    }

    #[test]
    fn a_round_trip_is_within_half_a_unit() {
        for per in [10, 16, 25, 100, 1000] {
            for nm in [-12_345_678, -1, 0, 7, 499, 1_234_567] {
                let back = units_to_nm(nm_to_units(nm, per), per);
                let half_unit_nm = 1000 / (2 * i32::try_from(per).unwrap()) + 1;
                assert!((back - nm).abs() <= half_unit_nm, "{nm} nm at {per}/µm → {back}");
            }
        }
    }
}
