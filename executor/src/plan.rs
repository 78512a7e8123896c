//! A verified plan in executor memory and the geometry of its steps.
//!
//! The image stays in its flash layout (fixed-width little-endian steps, see
//! `mesopush_protocol::flash`), so step `i` is read in place without parsing or allocating.
//! Geometry is integer-only (no floating point or libm in `no_std`): lengths in nm via an
//! integer square root, durations in µs rounded up.

use heapless::Vec;
use mesopush_protocol::flash::{FlashHeader, FlashRejectReason, PLAN_STEP_LEN_BYTES, PlanStep};

/// A verified plan: its header and image, at most `CAP` bytes.
#[derive(Debug, Clone)]
pub struct FlashedPlan<const CAP: usize> {
    header: FlashHeader,
    image: Vec<u8, CAP>,
}

impl<const CAP: usize> FlashedPlan<CAP> {
    /// Wraps `image` once [`FlashHeader::verify_image`] accepts it.
    pub fn from_verified(
        header: FlashHeader,
        image: Vec<u8, CAP>,
    ) -> Result<Self, FlashRejectReason> {
        header.verify_image(&image)?;
        Ok(Self { header, image })
    }

    /// The plan's header.
    pub fn header(&self) -> &FlashHeader {
        &self.header
    }

    /// The plan's id.
    pub fn plan_id(&self) -> u32 {
        self.header.plan_id
    }

    /// The raw image.
    pub fn image(&self) -> &[u8] {
        &self.image
    }

    /// Number of steps.
    pub fn step_count(&self) -> u32 {
        self.header.step_count
    }

    /// Step `i`, if it exists.
    pub fn step(&self, i: u32) -> Option<PlanStep> {
        let start = usize::try_from(i).ok()?.checked_mul(PLAN_STEP_LEN_BYTES)?;
        let bytes = self.image.get(start..start + PLAN_STEP_LEN_BYTES)?;
        <&[u8; PLAN_STEP_LEN_BYTES]>::try_from(bytes).ok().map(PlanStep::from_image_bytes)
    }

    /// The steps in order.
    pub fn steps(&self) -> impl Iterator<Item = PlanStep> + '_ {
        mesopush_protocol::flash::image_steps(&self.image)
    }
}

/// Derived geometry of one plan step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepGeometry {
    /// Path length, nm (integer square root, rounded down).
    pub len_nm: u64,
    /// Time to travel it at the step's speed, µs, rounded up; 0 for a zero speed or length.
    pub duration_us: u64,
    /// Velocity x component, nm/s (0 for a zero-length step).
    pub vx_nm_s: i64,
    /// Velocity y component, nm/s.
    pub vy_nm_s: i64,
}

impl StepGeometry {
    /// Geometry of `step`.
    pub fn of(step: &PlanStep) -> Self {
        let (dx, dy) = (i64::from(step.dx_nm), i64::from(step.dy_nm));
        let len_nm = hypot_nm(dx, dy);
        let speed = u64::from(step.speed_nm_s);
        if len_nm == 0 || speed == 0 {
            return Self { len_nm, duration_us: 0, vx_nm_s: 0, vy_nm_s: 0 };
        }
        let duration_us = (len_nm * 1_000_000).div_ceil(speed);
        let len = len_nm as i64; // ≤ 2^33: fits
        let speed = speed as i64;
        Self { len_nm, duration_us, vx_nm_s: dx * speed / len, vy_nm_s: dy * speed / len }
    }
}

/// `sqrt(dx² + dy²)` rounded down, for displacements within ±2^32 nm.
pub fn hypot_nm(dx: i64, dy: i64) -> u64 {
    let sq = u128::from(dx.unsigned_abs()).pow(2) + u128::from(dy.unsigned_abs()).pow(2);
    u64::try_from(sq.isqrt()).unwrap_or(u64::MAX)
}

/// Point at fraction `num / den` along `from → to` (integer, rounded toward zero).
pub fn lerp_nm(from: (i64, i64), to: (i64, i64), num: u64, den: u64) -> (i64, i64) {
    if den == 0 {
        return to;
    }
    let f = |a: i64, b: i64| {
        let delta = i128::from(b - a) * i128::from(num) / i128::from(den);
        a + delta as i64
    };
    (f(from.0, to.0), f(from.1, to.1))
}

/// Commanded path position `rel_us` after the start of a plan of `steps` begun at
/// `start_nm`: the same schedule the streamer sends (each step at its speed, durations
/// rounded up to the µs, linear within a step; the end point after the last step). Stateless,
/// for recorders and tests that rebuild the commanded path.
pub fn path_position_nm(
    steps: impl IntoIterator<Item = PlanStep>,
    start_nm: (i64, i64),
    rel_us: u64,
) -> (i64, i64) {
    let (mut at, mut t0) = (start_nm, 0u64);
    for step in steps {
        let g = StepGeometry::of(&step);
        let end = (at.0 + i64::from(step.dx_nm), at.1 + i64::from(step.dy_nm));
        if rel_us < t0 + g.duration_us {
            return lerp_nm(at, end, rel_us - t0, g.duration_us);
        }
        at = end;
        t0 += g.duration_us;
    }
    at
}

#[cfg(test)]
mod tests {
    use super::path_position_nm;

    #[test]
    fn path_position_follows_the_steps_and_stops_at_the_end() {
        let steps = [
            PlanStep { dx_nm: 1_400, dy_nm: 0, speed_nm_s: 140_000 },
            PlanStep { dx_nm: 0, dy_nm: -700, speed_nm_s: 140_000 },
        ];
        assert_eq!(path_position_nm(steps, (10, 20), 0), (10, 20));
        assert_eq!(path_position_nm(steps, (10, 20), 5_000), (710, 20));
        assert_eq!(path_position_nm(steps, (10, 20), 12_500), (1_410, -330));
        assert_eq!(path_position_nm(steps, (10, 20), 99_000), (1_410, -680));
    }

    use super::*;

    #[test]
    fn geometry_of_a_diagonal_step() {
        let g = StepGeometry::of(&PlanStep { dx_nm: 3_000, dy_nm: -4_000, speed_nm_s: 1_000 });
        assert_eq!(g.len_nm, 5_000);
        assert_eq!(g.duration_us, 5_000_000);
        assert_eq!((g.vx_nm_s, g.vy_nm_s), (600, -800));
    }

    #[test]
    fn duration_rounds_up() {
        let g = StepGeometry::of(&PlanStep { dx_nm: 1, dy_nm: 0, speed_nm_s: 3 });
        assert_eq!(g.duration_us, 333_334);
    }

    #[test]
    fn hypot_handles_extremes() {
        let max = i64::from(i32::MAX) - i64::from(i32::MIN);
        assert_eq!(hypot_nm(max, 0), max as u64);
        let r = u128::from(hypot_nm(-max, -max));
        let sq = 2 * (max as u128).pow(2);
        assert!(r * r <= sq && (r + 1) * (r + 1) > sq, "floor(sqrt) of {sq}: got {r}");
    }

    #[test]
    fn lerp_endpoints_and_middle() {
        assert_eq!(lerp_nm((0, 0), (10, -10), 0, 4), (0, 0));
        assert_eq!(lerp_nm((0, 0), (10, -10), 2, 4), (5, -5));
        assert_eq!(lerp_nm((0, 0), (10, -10), 4, 4), (10, -10));
    }
}
