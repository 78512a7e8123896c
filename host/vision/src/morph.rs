//! Binary-image morphology for the tracker: connected components (8-connected) and chamfer
//! distance transforms (3-4 weights, so a distance of 3 is one pixel) on a rectangular region
//! of interest, from which erosion, dilation and opening follow by thresholding.

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
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

/// Labels the 8-connected components of `mask` (`w × h`) inside `roi`; 0 is background (and
/// everything outside the ROI). Returns the full-size label image and the components in the
/// order their first pixel appears in a row-major scan. Works on runs of set pixels joined
/// with union–find, so a large blob costs one step per row, not per pixel.
pub fn label_components(mask: &[bool], w: usize, h: usize, roi: Roi) -> (Vec<u32>, Vec<Component>) {
    let mut labels = Vec::new();
    let comps = label_components_into(mask, w, h, roi, &mut labels);
    (labels, comps)
}

/// [`label_components`] into a reused label buffer (resized to `w × h` and cleared).
pub fn label_components_into(
    mask: &[bool],
    w: usize,
    h: usize,
    roi: Roi,
    labels: &mut Vec<u32>,
) -> Vec<Component> {
    debug_assert!(roi.x1 <= w && roi.y1 <= h && mask.len() == w * h);
    // runs as (y, x0, x1), rows in order; row_start[j] indexes the first run of ROI row j
    let mut runs: Vec<(usize, usize, usize)> = Vec::new();
    let mut row_start = Vec::with_capacity(roi.height() + 1);
    for y in roi.y0..roi.y1 {
        row_start.push(runs.len());
        let row = &mask[y * w..(y + 1) * w];
        let mut x = roi.x0;
        while x < roi.x1 {
            if row[x] {
                let x0 = x;
                while x < roi.x1 && row[x] {
                    x += 1;
                }
                runs.push((y, x0, x));
            }
            x += 1;
        }
    }
    row_start.push(runs.len());
    let mut parent: Vec<usize> = (0..runs.len()).collect();
    for j in 1..roi.height() {
        let (prev, cur) = (row_start[j - 1]..row_start[j], row_start[j]..row_start[j + 1]);
        let mut p = prev.start;
        for c in cur {
            let (_, cx0, cx1) = runs[c];
            // skip previous-row runs ending left of this one's diagonal reach
            while p < prev.end && runs[p].2 < cx0 {
                p += 1;
            }
            let mut q = p;
            while q < prev.end && runs[q].1 <= cx1 {
                union(&mut parent, q, c);
                q += 1;
            }
        }
    }
    labels.clear();
    labels.resize(w * h, 0);
    let mut comps: Vec<Component> = Vec::new();
    let mut label_of_root = vec![0u32; runs.len()];
    for (r, &(y, x0, x1)) in runs.iter().enumerate() {
        let root = find(&mut parent, r);
        if label_of_root[root] == 0 {
            let label = comps.len() as u32 + 1;
            label_of_root[root] = label;
            comps.push(Component { label, area: 0, bbox: Roi { x0: w, y0: h, x1: 0, y1: 0 } });
        }
        let label = label_of_root[root];
        labels[y * w + x0..y * w + x1].fill(label);
        let c = &mut comps[label as usize - 1];
        c.area += x1 - x0;
        c.bbox = Roi {
            x0: c.bbox.x0.min(x0),
            y0: c.bbox.y0.min(y),
            x1: c.bbox.x1.max(x1),
            y1: c.bbox.y1.max(y + 1),
        };
    }
    comps
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // the earlier run stays root, so labels follow scan order
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi] = lo;
    }
}

/// Bounding box of the set pixels of `mask` (`w × h`), `None` when there are none.
pub fn mask_bounds(mask: &[bool], w: usize, h: usize) -> Option<Roi> {
    let mut b = Roi { x0: w, y0: h, x1: 0, y1: 0 };
    for (y, row) in mask.chunks_exact(w).enumerate().take(h) {
        let Some(first) = row.iter().position(|&m| m) else { continue };
        let last = row.iter().rposition(|&m| m).unwrap_or(first);
        b = Roi { x0: b.x0.min(first), y0: b.y0.min(y), x1: b.x1.max(last + 1), y1: y + 1 };
    }
    (b.x0 < b.x1).then_some(b)
}

/// Dilation by a `(2r + 1)`-pixel square inside `roi`: whether any pixel where `is_set` holds
/// lies within `r` pixels along both axes. ROI-sized, row-major. Sliding-window counts, so
/// the cost does not grow with `r`.
pub fn dilate_square(roi: Roi, r: usize, is_set: impl Fn(usize, usize) -> bool) -> Vec<bool> {
    let (w, h) = (roi.width(), roi.height());
    let mut horiz = vec![0u16; w * h];
    let mut prefix = vec![0u32; w + 1];
    for j in 0..h {
        for i in 0..w {
            prefix[i + 1] = prefix[i] + u32::from(is_set(roi.x0 + i, roi.y0 + j));
        }
        for (i, v) in horiz[j * w..(j + 1) * w].iter_mut().enumerate() {
            *v = u16::from(prefix[(i + r + 1).min(w)] > prefix[i.saturating_sub(r)]);
        }
    }
    let mut count = vec![0u16; w];
    let mut out = vec![false; w * h];
    // window rows [j - r, j + r]: add the row entering, drop the row leaving
    for j in 0..h + r {
        if j < h {
            for (c, v) in count.iter_mut().zip(&horiz[j * w..(j + 1) * w]) {
                *c += v;
            }
        }
        if j > 2 * r {
            let gone = j - 2 * r - 1;
            for (c, v) in count.iter_mut().zip(&horiz[gone * w..(gone + 1) * w]) {
                *c -= v;
            }
        }
        if j >= r {
            let row = j - r;
            for (o, c) in out[row * w..(row + 1) * w].iter_mut().zip(&count) {
                *o = *c > 0;
            }
        }
    }
    out
}

/// Marks chamfer distances that no source reaches.
pub const UNREACHABLE: u16 = u16::MAX - 8;

/// Chamfer distance (3 per pixel step, 4 per diagonal) inside `roi` from every pixel to the
/// nearest pixel where `is_source` holds. Pixels outside the ROI count as sources when
/// `outside_is_source`, else as unreachable. Returns a ROI-sized row-major buffer; pixels no
/// source reaches hold [`UNREACHABLE`].
pub fn chamfer(
    roi: Roi,
    outside_is_source: bool,
    is_source: impl Fn(usize, usize) -> bool,
) -> Vec<u16> {
    chamfer_rows(roi, outside_is_source, |y, x0, row| {
        for (i, v) in row.iter_mut().enumerate() {
            *v = if is_source(x0 + i, y) { 0 } else { UNREACHABLE };
        }
    })
}

/// [`chamfer`] with the sources given a row at a time: `init(y, x0, row)` sets each pixel of
/// image row `y` (from column `x0`) to 0 for a source, [`UNREACHABLE`] otherwise.
pub fn chamfer_rows(
    roi: Roi,
    outside_is_source: bool,
    mut init: impl FnMut(usize, usize, &mut [u16]),
) -> Vec<u16> {
    let (w, h) = (roi.width(), roi.height());
    // UNREACHABLE + 4 cannot overflow, so the passes need no saturating arithmetic; real
    // distances stay far below it (≤ 4 per pixel of an image at most 8192 wide).
    const FAR: u16 = UNREACHABLE;
    let edge = if outside_is_source { 0 } else { FAR };
    let mut d = vec![FAR; w * h];
    for j in 0..h {
        init(roi.y0 + j, roi.x0, &mut d[j * w..(j + 1) * w]);
    }
    if w == 0 {
        return d;
    }
    let mut tmp = vec![0u16; w];
    for j in 0..h {
        if j == 0 {
            tmp.fill(edge + 3);
        } else {
            let (done, _) = d.split_at(j * w);
            neighbours_of_row(&done[(j - 1) * w..], edge, &mut tmp);
        }
        let mut left = edge;
        for (v, t) in d[j * w..(j + 1) * w].iter_mut().zip(&tmp) {
            *v = (*v).min(*t).min(left + 3);
            left = *v;
        }
    }
    for j in (0..h).rev() {
        if j + 1 == h {
            tmp.fill(edge + 3);
        } else {
            neighbours_of_row(&d[(j + 1) * w..(j + 2) * w], edge, &mut tmp);
        }
        let mut right = edge;
        for (v, t) in d[j * w..(j + 1) * w].iter_mut().zip(&tmp).rev() {
            *v = (*v).min(*t).min(right + 3);
            right = *v;
        }
    }
    d
}

/// For each pixel of a row, the best distance offered by the adjacent row `nb`: straight
/// (+3) or diagonal (+4), with `edge` beyond the row's ends.
fn neighbours_of_row(nb: &[u16], edge: u16, out: &mut [u16]) {
    let w = out.len();
    let nb = &nb[..w];
    if w == 1 {
        out[0] = (nb[0] + 3).min(edge + 4);
        return;
    }
    out[0] = (nb[0] + 3).min(nb[1] + 4).min(edge + 4);
    out[w - 1] = (nb[w - 1] + 3).min(nb[w - 2] + 4).min(edge + 4);
    for (o, t) in out[1..w - 1].iter_mut().zip(nb.windows(3)) {
        *o = (t[1] + 3).min(t[0] + 4).min(t[2] + 4);
    }
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
        let (labels, comps) = label_components(&m, w, h, Roi::full(w, h));
        assert_eq!(mask_bounds(&m, w, h), Some(Roi { x0: 0, y0: 0, x1: 8, y1: 2 }));
        assert_eq!(comps.len(), 2);
        assert_eq!(comps[0].area, 3);
        assert_eq!(labels[9], labels[0]);
        assert_ne!(labels[6], labels[0]);
        assert_eq!(comps[1].bbox, Roi { x0: 6, y0: 0, x1: 8, y1: 2 });
    }

    #[test]
    fn runs_join_diagonally_and_a_u_shape_is_one_component() {
        let rows = ["#...#....", "#...#..#.", "#####.#..", ".........", "..##....."];
        let (w, h) = (rows[0].len(), rows.len());
        let m: Vec<bool> = rows.iter().flat_map(|r| r.chars().map(|c| c == '#')).collect();
        let (labels, comps) = label_components(&m, w, h, Roi::full(w, h));
        assert_eq!(comps.len(), 3, "{comps:?}");
        assert_eq!(comps[0].area, 9);
        assert_eq!(labels[4], labels[0], "the U's arms are one component");
        assert_eq!(labels[w + 7], labels[2 * w + 6], "diagonal neighbours join");
        assert_eq!(comps[2].bbox, Roi { x0: 2, y0: 4, x1: 4, y1: 5 });
        let (inner, c) = label_components(&m, w, h, Roi { x0: 5, y0: 0, x1: 9, y1: 3 });
        assert_eq!(c.len(), 1);
        assert_eq!(inner[0], 0, "outside the ROI stays unlabelled");
    }

    #[test]
    fn square_dilation_reaches_r_pixels_in_both_axes() {
        let roi = Roi { x0: 2, y0: 1, x1: 12, y1: 10 };
        let d = dilate_square(roi, 2, |x, y| x == 6 && y == 5);
        let at = |x: usize, y: usize| d[(y - roi.y0) * roi.width() + (x - roi.x0)];
        assert!(at(6, 5) && at(4, 3) && at(8, 7) && at(8, 3));
        assert!(!at(3, 5) && !at(9, 5) && !at(6, 2) && !at(6, 8));
        assert_eq!(d.iter().filter(|&&v| v).count(), 25);
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
