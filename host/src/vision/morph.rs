//! Binary-image morphology for the tracker: connected components (8-connected) and chamfer
//! distance transforms (3-4 weights, so a distance of 3 is one pixel) on a rectangular region
//! of interest, from which erosion, dilation and opening follow by thresholding.

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Roi {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Roi {
    /// The whole `w × h` image.
    pub fn full(w: usize, h: usize) -> Self {
        Self { x0: 0, y0: 0, x1: w, y1: h }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.y1 - self.y0
    }

    /// Grown by `m` pixels on every side, clipped to `w × h`.
    pub fn grown(&self, m: usize, w: usize, h: usize) -> Self {
        Self {
            x0: self.x0.saturating_sub(m),
            y0: self.y0.saturating_sub(m),
            x1: (self.x1 + m).min(w),
            y1: (self.y1 + m).min(h),
        }
    }
}

/// One connected component.
#[derive(Debug, Clone, PartialEq)]
pub struct Component {
    /// Its label in the label image (≥ 1).
    pub label: u32,
    /// Number of pixels.
    pub area: usize,
    /// Bounding box.
    pub bbox: Roi,
}

/// Labels the 8-connected components of `mask` (`w × h`); 0 is background. Returns the label
/// image and the components in label order.
pub fn label_components(mask: &[bool], w: usize, h: usize) -> (Vec<u32>, Vec<Component>) {
    let mut labels = vec![0u32; w * h];
    let mut comps = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask[start] || labels[start] != 0 {
            continue;
        }
        let label = comps.len() as u32 + 1;
        let mut c = Component { label, area: 0, bbox: Roi { x0: w, y0: h, x1: 0, y1: 0 } };
        labels[start] = label;
        stack.push(start);
        while let Some(k) = stack.pop() {
            let (x, y) = (k % w, k / w);
            c.area += 1;
            c.bbox = Roi {
                x0: c.bbox.x0.min(x),
                y0: c.bbox.y0.min(y),
                x1: c.bbox.x1.max(x + 1),
                y1: c.bbox.y1.max(y + 1),
            };
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let n = ny * w + nx;
                    if mask[n] && labels[n] == 0 {
                        labels[n] = label;
                        stack.push(n);
                    }
                }
            }
        }
        comps.push(c);
    }
    (labels, comps)
}

/// Chamfer distance (3 per pixel step, 4 per diagonal) inside `roi` from every pixel to the
/// nearest pixel where `is_source` holds. Pixels outside the ROI count as sources when
/// `outside_is_source`, else as unreachable. Returns a ROI-sized row-major buffer; unreachable
/// pixels hold `u16::MAX`.
pub fn chamfer(
    roi: Roi,
    outside_is_source: bool,
    is_source: impl Fn(usize, usize) -> bool,
) -> Vec<u16> {
    let (w, h) = (roi.width(), roi.height());
    let far = u16::MAX;
    let edge = if outside_is_source { 0 } else { far };
    let mut d = vec![far; w * h];
    for j in 0..h {
        for i in 0..w {
            if is_source(roi.x0 + i, roi.y0 + j) {
                d[j * w + i] = 0;
            }
        }
    }
    let get = |d: &[u16], i: isize, j: isize| -> u16 {
        if i < 0 || j < 0 || i >= w as isize || j >= h as isize {
            edge
        } else {
            d[j as usize * w + i as usize]
        }
    };
    for j in 0..h as isize {
        for i in 0..w as isize {
            let k = j as usize * w + i as usize;
            if d[k] == 0 {
                continue;
            }
            let m = [
                (get(&d, i - 1, j), 3),
                (get(&d, i - 1, j - 1), 4),
                (get(&d, i, j - 1), 3),
                (get(&d, i + 1, j - 1), 4),
            ]
            .iter()
            .map(|&(v, c)| v.saturating_add(c))
            .min()
            .unwrap_or(far);
            d[k] = d[k].min(m);
        }
    }
    for j in (0..h as isize).rev() {
        for i in (0..w as isize).rev() {
            let k = j as usize * w + i as usize;
            if d[k] == 0 {
                continue;
            }
            let m = [
                (get(&d, i + 1, j), 3),
                (get(&d, i + 1, j + 1), 4),
                (get(&d, i, j + 1), 3),
                (get(&d, i - 1, j + 1), 4),
            ]
            .iter()
            .map(|&(v, c)| v.saturating_add(c))
            .min()
            .unwrap_or(far);
            d[k] = d[k].min(m);
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_blobs_are_two_components() {
        let (w, h) = (8, 4);
        let mut m = vec![false; w * h];
        for k in [0, 1, 9, 6, 7, 15] {
            m[k] = true;
        }
        let (labels, comps) = label_components(&m, w, h);
        assert_eq!(comps.len(), 2);
        assert_eq!(comps[0].area, 3);
        assert_eq!(labels[9], labels[0]);
        assert_ne!(labels[6], labels[0]);
        assert_eq!(comps[1].bbox, Roi { x0: 6, y0: 0, x1: 8, y1: 2 });
    }

    #[test]
    fn chamfer_measures_thirds_of_pixels() {
        let roi = Roi::full(9, 9);
        let d = chamfer(roi, false, |x, y| x == 4 && y == 4);
        assert_eq!(d[4 * 9 + 4], 0);
        assert_eq!(d[4 * 9 + 7], 9);
        assert_eq!(d[7 * 9 + 7], 12);
        // inside distance with the outside as source: the border ring is 3 from it
        let inside = chamfer(roi, true, |_, _| false);
        assert_eq!(inside[0], 3);
        assert_eq!(inside[4 * 9 + 4], 15);
    }
}
