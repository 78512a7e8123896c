//! Coverage-weighted moments of the peg's blob: its thresholded pixels plus a band around
//! them (where partial coverage and blur put the edge), each weighed by its darkening over the
//! peg interior's (its covered share), leaving out the needle, its surroundings and other
//! blobs. Also counts what the flags need (pixels in walls, pixels darker than the peg).

use crate::background::Background;
use crate::calib::Calibration;
use crate::moments::{MomentSums, Moments};
use crate::morph::Component;
use crate::probe::NeedleZone;
use mesopush_core::geom::Vec2;

/// The pieces of one frame the peg's moments are computed from (full-image buffers).
pub(crate) struct Blob<'a> {
    pub(crate) peg: &'a Component,
    pub(crate) labels: &'a [u32],
    pub(crate) rest: &'a [bool],
    pub(crate) needle: &'a [bool],
    pub(crate) depth: &'a [u16],
}

/// What the weighted pass over the peg found.
pub(crate) struct Weighed {
    pub(crate) moments: Option<Moments>,
    /// Peg pixels well inside it that are darker than the peg can be.
    pub(crate) occluded_px: usize,
    /// Peg pixels inside a wall.
    pub(crate) wall_px: usize,
    /// Peg pixels within 2 px of a wall.
    pub(crate) wall_adjacent_px: usize,
}

/// Per image row, the span `[lo, hi)` of the columns the peg's blob occupies.
struct Rows {
    y0: usize,
    spans: Vec<(usize, usize)>,
}

impl Rows {
    fn of(blob: &Blob<'_>, w: usize) -> Self {
        let b = blob.peg.bbox;
        let label = blob.peg.label;
        let spans = (b.y0..b.y1)
            .map(|y| {
                let row = &blob.labels[y * w + b.x0..y * w + b.x1];
                match (row.iter().position(|&l| l == label), row.iter().rposition(|&l| l == label))
                {
                    (Some(a), Some(z)) => (b.x0 + a, b.x0 + z + 1),
                    _ => (usize::MAX, 0),
                }
            })
            .collect();
        Self { y0: b.y0, spans }
    }

    /// Columns within `band` px (both axes) of the blob in row `y`, clipped to `w`: exact for a
    /// convex blob, a superset otherwise.
    fn band(&self, y: usize, band: usize, w: usize) -> Option<(usize, usize)> {
        let first = y.saturating_sub(band).max(self.y0);
        let last = (y + band + 1).min(self.y0 + self.spans.len());
        let (lo, hi) = (first..last)
            .map(|r| self.spans[r - self.y0])
            .fold((usize::MAX, 0), |(a, b), (lo, hi)| (a.min(lo), b.max(hi)));
        (lo < hi).then(|| (lo.saturating_sub(band), (hi + band).min(w)))
    }
}

/// The weighted pass; `band` px around the blob are included.
pub(crate) fn weigh(
    blob: &Blob<'_>,
    dark: &[f32],
    bg: &Background,
    calib: &Calibration,
    band: usize,
) -> Weighed {
    let (w, h) = (bg.width(), bg.height());
    let roi = blob.peg.bbox.grown(band + 1, w, h);
    let label = blob.peg.label;
    let rows = Rows::of(blob, w);
    let needle = NeedleZone::new(blob.needle, w, h, roi, band);
    let contrast = interior_contrast(blob, dark, &rows, w);
    let occl_level = contrast + (0.5 * (1.0 - contrast)).max(0.1);
    let origin = Vec2::new(0.5 * (roi.x0 + roi.x1) as f64, 0.5 * (roi.y0 + roi.y1) as f64);
    let mut sums = MomentSums::new(origin, calib.sx_um_per_px, calib.sy_um_per_px);
    let (mut occluded_px, mut wall_px, mut wall_adjacent_px) = (0, 0, 0);
    let inv_contrast = 1.0 / contrast;
    let mut weights = vec![0f32; roi.width()];
    for y in roi.y0..roi.y1 {
        let Some((x0, x1)) = rows.band(y, band, w) else { continue };
        let row = &mut weights[..x1 - x0];
        for (x, wt) in (x0..x1).zip(row.iter_mut()) {
            let k = y * w + x;
            *wt = 0.0;
            if blob.labels[k] == label {
                wall_px += usize::from(bg.is_wall_core(k));
                wall_adjacent_px += usize::from(bg.is_near_wall(k));
                let deep = blob.depth[k] >= 9 && !needle.beside(x, y);
                occluded_px += usize::from(deep && dark[k] > occl_level);
            } else if blob.rest[k] || blob.needle[k] || needle.near(x, y) {
                continue;
            }
            *wt = (dark[k] * inv_contrast).clamp(-0.5, 1.5);
        }
        sums.add_weights(y, x0, row);
    }
    let moments = sums.finish().map(|(area_um2, c_px, second)| Moments {
        area_um2,
        centroid: calib.px_to_um(&c_px),
        second,
    });
    Weighed { moments, occluded_px, wall_px, wall_adjacent_px }
}

/// Median darkening of the peg's pixels at least 3 px inside its outline (every other pixel
/// of every other row): the value a fully covered pixel has, so edge pixels weigh by their
/// covered share.
fn interior_contrast(blob: &Blob<'_>, dark: &[f32], rows: &Rows, w: usize) -> f32 {
    let mut hist = [0u32; 512];
    let (mut n, mut all, mut seen) = (0u32, 0.0f64, 0u32);
    for (j, &(lo, hi)) in rows.spans.iter().enumerate().step_by(2) {
        let y = rows.y0 + j;
        for x in (lo..hi).step_by(2) {
            let k = y * w + x;
            if blob.labels[k] == blob.peg.label {
                all += f64::from(dark[k]);
                seen += 1;
                if blob.depth[k] >= 9 {
                    hist[((dark[k] * 340.0).clamp(0.0, 511.0)) as usize] += 1;
                    n += 1;
                }
            }
        }
    }
    if n < 20 {
        return ((all / f64::from(seen.max(1))) as f32).max(0.05);
    }
    let mut acc = 0;
    for (i, c) in hist.iter().enumerate() {
        acc += c;
        if 2 * acc >= n {
            return ((i as f32 + 0.5) / 340.0).max(0.05);
        }
    }
    0.05
}
