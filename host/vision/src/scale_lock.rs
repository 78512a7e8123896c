//! The peg's apparent size, learned once per tracker. An image scale that is off by a couple
//! of per cent (a calibration error, issue 7's "scale error 1–3 %") makes every frame's blob
//! uniformly larger or smaller than the part file says. The shape check, tuned to catch a
//! blob merged with a wall or bitten by the needle, would then flag every frame
//! `shape_mismatch` and no trial could be judged. A sequence's first frames that show the
//! whole peg *uniformly* scaled (its area and both principal second moments off by the same
//! factor, which an occlusion or a merge does not do) fix the apparent scale; the shape
//! check uses it from then on, and [`super::Tracker::apparent_scale`] reports it, so the
//! calibration error is said rather than hidden.

use super::moments::Moments;

/// When to learn the apparent scale. Plain data; see `Default`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleLearning {
    /// Consecutive uniformly scaled frames needed to fix the scale (default 5; 0: never
    /// learn, the part file's size is taken as it is).
    pub frames: usize,
    /// Largest apparent area error learned, relative (default 0.08, about 4 % in length): a
    /// larger one is not a calibration slip and stays flagged.
    pub max_area_error: f64,
    /// How far the three ratios (area, both principal moments) of one frame, and the
    /// frames' ratios among each other, may spread, relative (default 0.01).
    pub spread: f64,
}

impl Default for ScaleLearning {
    fn default() -> Self {
        Self { frames: 5, max_area_error: 0.08, spread: 0.01 }
    }
}

/// The learning's state.
#[derive(Debug, Clone, Default)]
pub(crate) struct ScaleLock {
    samples: Vec<f64>,
    locked: Option<f64>,
}

impl ScaleLock {
    /// The fixed area ratio (apparent ÷ part file), once learned.
    pub(crate) fn locked(&self) -> Option<f64> {
        self.locked
    }

    /// Feeds one frame's moments (a frame showing the whole peg, with no flag other than a
    /// shape mismatch); a frame that breaks the run (`None`) restarts it. Returns the ratio
    /// when this frame fixes it.
    pub(crate) fn observe(
        &mut self,
        measured: Option<&Moments>,
        part: &Moments,
        s: &ScaleLearning,
    ) -> Option<f64> {
        if self.locked.is_some() || s.frames == 0 {
            return None;
        }
        let Some(r) = measured.and_then(|m| uniform_ratio(m, part, s.spread)) else {
            self.samples.clear();
            return None;
        };
        if (r - 1.0).abs() > s.max_area_error {
            self.samples.clear();
            return None;
        }
        self.samples.push(r);
        if self.samples.len() > s.frames {
            self.samples.remove(0);
        }
        let (lo, hi) =
            self.samples.iter().fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
        if self.samples.len() < s.frames || hi - lo > s.spread {
            return None;
        }
        let mut sorted = self.samples.clone();
        // The upper median (a measured value): rank round((n − 1)/2) = n/2.
        let r = mesopush_core::stats::percentile(&mut sorted, 0.5)?;
        self.locked = Some(r);
        Some(r)
    }
}

/// The common ratio of the area and both principal second moments of `m` to `part`'s, when
/// the three agree within `spread`.
fn uniform_ratio(m: &Moments, part: &Moments, spread: f64) -> Option<f64> {
    let (m1, m2) = m.principal();
    let (p1, p2) = part.principal();
    let ratios = [m.area_um2 / part.area_um2, m1 / p1, m2 / p2];
    if !ratios.iter().all(|r| r.is_finite() && *r > 0.0) {
        return None;
    }
    let lo = ratios.iter().copied().fold(f64::MAX, f64::min);
    let hi = ratios.iter().copied().fold(f64::MIN, f64::max);
    (hi - lo <= spread).then(|| ratios.iter().sum::<f64>() / 3.0)
}

/// Length error below which the imaged size is said to agree with the part file (half a
/// per cent: a few tenths of a pixel across the peg).
const AGREES_LENGTH: f64 = 0.005;

/// The trial-log event's detail for a learned area ratio `r` (events.csv kind
/// `apparent_scale`).
pub fn describe(r: f64) -> String {
    let length = r.sqrt() - 1.0;
    let (area_pct, length_pct) = (100.0 * (r - 1.0), 100.0 * length);
    if length.abs() < AGREES_LENGTH {
        return format!(
            "area_ratio={r:.4}; the peg's imaged size agrees with its part file \
             ({length_pct:+.2} % in length)"
        );
    }
    format!(
        "area_ratio={r:.4}; the peg appears {area_pct:+.2} % in area ({length_pct:+.2} % in \
         length) against its part file: image scale calibration off by about that much"
    )
}

/// `part`'s moments seen at an area ratio `r`: the area and the second moments per unit
/// area both grow by `r` under a uniform scale of `√r`.
pub(crate) fn scaled(part: &Moments, r: f64) -> Moments {
    let (xx, yy, xy) = part.second;
    Moments {
        area_um2: part.area_um2 * r,
        centroid: part.centroid,
        second: (xx * r, yy * r, xy * r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::Vec2;

    fn part() -> Moments {
        Moments { area_um2: 1000.0, centroid: Vec2::zeros(), second: (40.0, 10.0, 0.0) }
    }

    #[test]
    fn a_uniformly_scaled_run_locks_its_ratio() {
        let (p, s) = (part(), ScaleLearning::default());
        let mut lock = ScaleLock::default();
        let seen = scaled(&p, 1.04);
        for k in 0..4 {
            assert_eq!(lock.observe(Some(&seen), &p, &s), None, "frame {k}");
        }
        let r = lock.observe(Some(&seen), &p, &s).unwrap();
        assert!((r - 1.04).abs() < 1e-12);
        assert_eq!(lock.locked(), Some(r));
    }

    #[test]
    fn an_occluded_blob_is_not_taken_for_a_scale() {
        // 4 % less area but the moments barely change: a bite, not a scale
        let (p, s) = (part(), ScaleLearning::default());
        let bitten = Moments { area_um2: 960.0, ..p };
        let mut lock = ScaleLock::default();
        for _ in 0..10 {
            assert_eq!(lock.observe(Some(&bitten), &p, &s), None);
        }
        assert_eq!(lock.locked(), None);
    }

    #[test]
    fn a_broken_run_restarts_and_a_large_error_is_refused() {
        let (p, s) = (part(), ScaleLearning::default());
        let mut lock = ScaleLock::default();
        for _ in 0..4 {
            lock.observe(Some(&scaled(&p, 1.03)), &p, &s);
        }
        lock.observe(None, &p, &s);
        for _ in 0..4 {
            assert_eq!(lock.observe(Some(&scaled(&p, 1.03)), &p, &s), None);
        }
        let mut far = ScaleLock::default();
        for _ in 0..10 {
            assert_eq!(far.observe(Some(&scaled(&p, 1.2)), &p, &s), None);
        }
        let off = ScaleLearning { frames: 0, ..s };
        let mut never = ScaleLock::default();
        for _ in 0..10 {
            assert_eq!(never.observe(Some(&scaled(&p, 1.03)), &p, &off), None);
        }
    }

    #[test]
    fn the_report_says_agreement_or_the_calibration_error() {
        assert!(describe(1.0010).contains("agrees with its part file"), "{}", describe(1.001));
        let off = describe(1.0404);
        assert!(
            off.contains("+4.04 % in area")
                && off.contains("+2.00 % in")
                && off.contains("calibration"),
            "{off}"
        );
    }
}
