//! Removal of the probe by its geometry (paper §IV): the needle is a thin structure entering
//! from the frame edge, so it is what a morphological opening with a disc wider than the needle
//! but much narrower than the peg takes away. The needle's far end is its tip, located to
//! sub-pixel precision from the darkening mass near the end and the known tip diameter.

use crate::background::Background;
use crate::morph::{
    Component, Roi, UNREACHABLE, chamfer_rows, dilate_square, label_components_into, mask_bounds,
};
use crate::tip::LocatedTip;
use mesopush_core::geom::Vec2;

/// What the tracker knows about the probe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeSettings {
    /// Half-width of the widest part of the needle in view, µm: the opening radius. Must stay
    /// well below the peg's half-width (default 105 µm, 20 px at the paper's scale).
    pub max_half_width_um: f64,
    /// Diameter of the probe's tip, µm (default 25).
    pub tip_diameter_um: f64,
}

impl Default for ProbeSettings {
    fn default() -> Self {
        Self { max_half_width_um: 105.0, tip_diameter_um: 25.0 }
    }
}

/// Working images of the probe removal, reused from frame to frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct ProbeBuffers {
    /// Needle pixels.
    pub(crate) needle: Vec<bool>,
    /// Chamfer distance (thirds of a pixel) from each mask pixel to the nearest non-mask one.
    pub(crate) depth: Vec<u16>,
    /// Bounding box of the mask, grown by a pixel (empty when the mask is).
    pub(crate) bounds: Roi,
    thin: Vec<bool>,
    labels: Vec<u32>,
}

fn reset<T: Copy>(v: &mut Vec<T>, n: usize, value: T) {
    v.clear();
    v.resize(n, value);
}

/// Splits `mask` (`w × h`) into needle (`buf.needle`) and rest, fills `buf.depth`, and
/// returns the needle's end as located (its centre, the shaft's direction towards it, its
/// distance from the shaft's axis and whether it merges with something), if there is a needle.
pub(crate) fn separate_probe(
    mask: &[bool],
    darkening: &[f32],
    bg: &Background,
    open_radius_px: f64,
    tip_radius_px: f64,
    buf: &mut ProbeBuffers,
) -> Option<LocatedTip> {
    let (w, h) = (bg.width(), bg.height());
    reset(&mut buf.depth, w * h, 0);
    reset(&mut buf.needle, w * h, false);
    reset(&mut buf.thin, w * h, false);
    buf.bounds = Roi::default();
    // one pixel more: non-mask pixels around the blobs are the depth's sources, while the
    // image border is not (a peg cut by the border must not look thin there)
    let roi = mask_bounds(mask, w, h)?.grown(1, w, h);
    buf.bounds = roi;
    open_away(mask, w, roi, open_radius_px, buf);
    let comps = label_components_into(&buf.thin, w, h, roi, &mut buf.labels);
    // Corner slivers of the peg left by the opening are at most (1 − π/4) r² in area.
    let min_area = (0.5 * open_radius_px.powi(2)).max(12.0) as usize;
    let on_border =
        |c: &Component| c.bbox.x0 == 0 || c.bbox.y0 == 0 || c.bbox.x1 == w || c.bbox.y1 == h;
    let needle_labels: Vec<u32> = comps
        .iter()
        .filter(|c| c.area >= min_area || (on_border(c) && c.area >= 12))
        .map(|c| c.label)
        .collect();
    let labels = &buf.labels;
    for y in roi.y0..roi.y1 {
        let span = y * w + roi.x0..y * w + roi.x1;
        for (n, l) in buf.needle[span.clone()].iter_mut().zip(&labels[span]) {
            *n = *l != 0 && needle_labels.contains(l);
        }
    }
    let biggest =
        comps.iter().filter(|c| needle_labels.contains(&c.label)).max_by_key(|c| c.area)?;
    let c = biggest;
    let pixels: Vec<(usize, usize)> = (c.bbox.y0..c.bbox.y1)
        .flat_map(|y| (c.bbox.x0..c.bbox.x1).map(move |x| (x, y)))
        .filter(|&(x, y)| labels[y * w + x] == c.label)
        .collect();
    let shaft = Shaft::find(&pixels, bg, tip_radius_px + 2.5)?;
    // What lies off the shaft is a corner sliver of the peg the tip touches: give it back, so
    // the probe removal does not bite into the peg.
    for &p in &pixels {
        if !shaft.covers(&centre(p)) {
            buf.needle[p.1 * w + p.0] = false;
        }
    }
    let depth = &buf.depth;
    let tip = TipInput { pixels: &pixels, mask, needle: &buf.needle, darkening, depth, bg };
    let centre_px = refine_tip(&tip, &shaft, tip_radius_px);
    Some(LocatedTip {
        centre_px,
        toward_tip: shaft.u,
        off_axis_px: off_axis(&tip, &shaft, centre_px, tip_radius_px),
        merged: merges_ahead(&tip, centre_px, shaft.u, tip_radius_px),
    })
}

/// How far the located tip lies beside the shaft just behind it: its lateral distance from
/// the centroid of the needle's pixels 2 to 30 px behind its round end (the whole shaft's
/// axis, fitted near the entry, drifts by a pixel or two over the length of the needle).
fn off_axis(t: &TipInput<'_>, shaft: &Shaft, centre: Vec2, r_px: f64) -> f64 {
    let w = t.bg.width();
    let lat = Vec2::new(-shaft.u.y, shaft.u.x);
    let (mut n, mut sum) = (0usize, 0.0);
    for &(x, y) in t.pixels {
        let d = centre - self::centre((x, y));
        let back = d.dot(&shaft.u);
        if t.needle[y * w + x] && back >= r_px + 2.0 && back <= r_px + 30.0 {
            n += 1;
            sum += -d.dot(&lat);
        }
    }
    if n >= 10 { -(sum / n as f64) } else { (centre - shaft.mean).dot(&lat) }
}

/// Whether a pixel of the mask that is not needle lies 1.5 px beyond the round tip's edge
/// anywhere on its front half (within 80° of the shaft's direction): where the tip's
/// silhouette joins the peg's (or a wall's), its end is not seen against the plate.
fn merges_ahead(t: &TipInput<'_>, centre: Vec2, u: Vec2, r_px: f64) -> bool {
    let (w, h) = (t.bg.width() as f64, t.bg.height() as f64);
    (-8..=8).any(|k| {
        let (s, c) = (f64::from(k) * 10f64.to_radians()).sin_cos();
        let dir = Vec2::new(c * u.x - s * u.y, s * u.x + c * u.y);
        let p = centre + dir * (r_px + 1.5);
        if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h) {
            return false;
        }
        let k = p.y as usize * t.bg.width() + p.x as usize;
        t.mask[k] && !t.needle[k]
    })
}

/// Where the needle is near the peg: pixels within `band + 1` of it are left out of the band,
/// and peg pixels within `band + 4` are not judged for occlusion. Computed only around the
/// needle pixels that come near the peg's region, usually a small patch or none.
pub(crate) struct NeedleZone {
    zone: Option<Zone>,
}

struct Zone {
    roi: Roi,
    near: Vec<bool>,
    beside: Vec<bool>,
}

impl NeedleZone {
    pub(crate) fn new(needle: &[bool], w: usize, h: usize, roi: Roi, band: usize) -> Self {
        let reach = roi.grown(band + 4, w, h);
        let mut found: Option<Roi> = None;
        for y in reach.y0..reach.y1 {
            let row = &needle[y * w + reach.x0..y * w + reach.x1];
            if let (Some(a), Some(b)) = (row.iter().position(|&n| n), row.iter().rposition(|&n| n))
            {
                let (x0, x1) = (reach.x0 + a, reach.x0 + b + 1);
                found = Some(match found {
                    None => Roi { x0, y0: y, x1, y1: y + 1 },
                    Some(f) => Roi { x0: f.x0.min(x0), y0: f.y0, x1: f.x1.max(x1), y1: y + 1 },
                });
            }
        }
        let zone = found.map(|f| {
            let z = f.grown(band + 4, w, h);
            let near = dilate_square(z, band + 1, |x, y| needle[y * w + x]);
            let beside = dilate_square(z, band + 4, |x, y| needle[y * w + x]);
            Zone { roi: z, near, beside }
        });
        Self { zone }
    }

    fn index(&self, x: usize, y: usize) -> Option<(usize, &Zone)> {
        let z = self.zone.as_ref()?;
        let r = z.roi;
        (x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1)
            .then(|| ((y - r.y0) * r.width() + (x - r.x0), z))
    }

    /// Within `band + 1` px of a needle pixel.
    pub(crate) fn near(&self, x: usize, y: usize) -> bool {
        self.index(x, y).is_some_and(|(i, z)| z.near[i])
    }

    /// Within `band + 4` px of a needle pixel.
    pub(crate) fn beside(&self, x: usize, y: usize) -> bool {
        self.index(x, y).is_some_and(|(i, z)| z.beside[i])
    }
}

/// The opening by a disc of the needle's half-width, as two chamfer transforms: fills
/// `buf.depth` (distance to the outside of the mask) and `buf.thin` (mask pixels the opening
/// takes away) inside `roi`.
fn open_away(mask: &[bool], w: usize, roi: Roi, open_radius_px: f64, buf: &mut ProbeBuffers) {
    let local = chamfer_rows(roi, false, |y, x0, row| {
        for (v, &m) in row.iter_mut().zip(&mask[y * w + x0..]) {
            *v = if m { UNREACHABLE } else { 0 };
        }
    });
    for (j, row) in local.chunks_exact(roi.width()).enumerate() {
        let k = (roi.y0 + j) * w + roi.x0;
        buf.depth[k..k + roi.width()].copy_from_slice(row);
    }
    let r3 = (3.0 * open_radius_px).round() as u16;
    let depth = &buf.depth;
    let to_core_local = chamfer_rows(roi, false, |y, x0, row| {
        for (v, &d) in row.iter_mut().zip(&depth[y * w + x0..]) {
            *v = if d > r3 && d != UNREACHABLE { 0 } else { UNREACHABLE };
        }
    });
    for (j, row) in to_core_local.chunks_exact(roi.width()).enumerate() {
        let k = (roi.y0 + j) * w + roi.x0;
        let span = k..k + roi.width();
        for ((t, &m), &d) in buf.thin[span.clone()].iter_mut().zip(&mask[span]).zip(row) {
            *t = m & (d > r3.saturating_add(1));
        }
    }
}

struct TipInput<'a> {
    pixels: &'a [(usize, usize)],
    mask: &'a [bool],
    needle: &'a [bool],
    darkening: &'a [f32],
    depth: &'a [u16],
    bg: &'a Background,
}

fn centre(p: (usize, usize)) -> Vec2 {
    Vec2::new(p.0 as f64 + 0.5, p.1 as f64 + 0.5)
}

/// The needle's shaft as a line: where it enters, its direction and its far end's pixel.
#[derive(Debug, Clone, Copy)]
struct Shaft {
    /// A point on the shaft's centre line.
    mean: Vec2,
    /// Unit direction from the entry towards the tip.
    u: Vec2,
    /// Centre of the furthest shaft pixel.
    far: Vec2,
    /// Half-width at the tip plus a margin, px.
    half_width_px: f64,
}

/// Half-width growth per pixel back from the tip allowed for (the taper, with margin).
const TAPER_ALLOWANCE: f64 = 0.06;

impl Shaft {
    /// Entry at the frame edge or a wall (else the thicker end), axis from the pixels nearer
    /// the entry (the far end may carry a corner sliver of a touched peg), tip the furthest
    /// pixel on that axis.
    fn find(pixels: &[(usize, usize)], bg: &Background, half_width_px: f64) -> Option<Self> {
        let entry = entry_point(pixels, bg)?;
        let centres: Vec<Vec2> = pixels.iter().map(|&p| centre(p)).collect();
        let dist = |p: &Vec2| (p - entry).norm();
        let far = *centres.iter().max_by(|a, b| dist(a).total_cmp(&dist(b)))?;
        let reach = dist(&far);
        let near: Vec<Vec2> = centres.iter().copied().filter(|p| dist(p) < 0.7 * reach).collect();
        let (u, mean) = if near.len() >= 8 {
            let mean = near.iter().sum::<Vec2>() / near.len() as f64;
            let axis = principal_axis(&near, &mean);
            (if axis.dot(&(far - entry)) < 0.0 { -axis } else { axis }, mean)
        } else {
            ((far - entry).try_normalize(1e-9)?, entry)
        };
        let mut shaft = Self { mean, u, far, half_width_px };
        let lat = Vec2::new(-u.y, u.x);
        let loose = |p: &&Vec2| {
            let d = *p - mean;
            d.dot(&lat).abs() <= half_width_px + d.dot(&u).abs() * TAPER_ALLOWANCE
        };
        let along = |p: &Vec2| (p - entry).dot(&u);
        shaft.far = *centres.iter().filter(loose).max_by(|a, b| along(a).total_cmp(&along(b)))?;
        Some(shaft)
    }

    /// Whether `p` lies within the shaft's outline (tip half-width growing back from the tip).
    fn covers(&self, p: &Vec2) -> bool {
        let lat = Vec2::new(-self.u.y, self.u.x);
        let back = (self.far - p).dot(&self.u);
        back >= -1.0
            && (p - self.mean).dot(&lat).abs()
                <= self.half_width_px + back.max(0.0) * TAPER_ALLOWANCE
    }
}

/// Where the needle comes into view: the mean of its pixels on the frame edge or beside a
/// wall, else (a needle reaching neither) the thicker end of its long axis.
fn entry_point(pixels: &[(usize, usize)], bg: &Background) -> Option<Vec2> {
    let (w, h) = (bg.width(), bg.height());
    let anchors: Vec<Vec2> = pixels
        .iter()
        .filter(|&&(x, y)| {
            x == 0 || y == 0 || x + 1 == w || y + 1 == h || bg.is_near_wall(y * w + x)
        })
        .map(|&p| centre(p))
        .collect();
    if anchors.is_empty() {
        thick_end(pixels)
    } else {
        Some(anchors.iter().sum::<Vec2>() / anchors.len() as f64)
    }
}

/// Unit vector along the major axis of a point cloud about `mean`.
fn principal_axis(points: &[Vec2], mean: &Vec2) -> Vec2 {
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p - mean;
        sxx += d.x * d.x;
        syy += d.y * d.y;
        sxy += d.x * d.y;
    }
    let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Vec2::new(phi.cos(), phi.sin())
}

/// For a needle that reaches neither edge nor wall: the end of its long axis where it is wider.
fn thick_end(pixels: &[(usize, usize)]) -> Option<Vec2> {
    if pixels.is_empty() {
        return None;
    }
    let pts: Vec<Vec2> = pixels.iter().map(|&p| centre(p)).collect();
    let mean = pts.iter().sum::<Vec2>() / pts.len() as f64;
    let u = principal_axis(&pts, &mean);
    let s: Vec<f64> = pts.iter().map(|p| (p - mean).dot(&u)).collect();
    let (lo, hi) =
        s.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let near_lo = s.iter().filter(|&&v| v < lo + 8.0).count();
    let near_hi = s.iter().filter(|&&v| v > hi - 8.0).count();
    Some(if near_lo >= near_hi { mean + u * lo } else { mean + u * hi })
}

/// Sub-pixel centre of the rounded tip: the darkening mass in a window behind the far end,
/// read as a cylinder of the tip's diameter capped by a half disc. The needle's contrast is
/// read where it is opaque over the bare plate: over a wall it darkens the already dark
/// acrylic less, and counting those pixels made the mass look too large (a tip near a wall
/// was placed up to 6 px ahead of itself on frames of an independent renderer).
fn refine_tip(t: &TipInput<'_>, shaft: &Shaft, r_px: f64) -> Vec2 {
    let w = t.bg.width();
    let (u, far) = (shaft.u, shaft.far);
    let lat = Vec2::new(-u.y, u.x);
    let deep: Vec<f32> = t
        .pixels
        .iter()
        .map(|&(x, y)| y * w + x)
        .filter(|&k| t.depth[k] >= 6 && t.needle[k] && !t.bg.is_near_wall(k))
        .map(|k| t.darkening[k])
        .collect();
    let contrast = if deep.len() >= 10 {
        f64::from(deep.iter().sum::<f32>()) / deep.len() as f64
    } else {
        f64::from(t.pixels.iter().map(|&(x, y)| t.darkening[y * w + x]).fold(0.0f32, f32::max))
    };
    if contrast <= 0.05 {
        return far;
    }
    let (s0, s1, half) = (-6.0, 4.0, r_px + 3.0);
    let (mut mass, mut lat_sum) = (0.0, 0.0);
    let (x0, y0) = (far.x.floor() as isize - 12, far.y.floor() as isize - 12);
    for y in y0.max(0)..(y0 + 25).min(t.bg.height() as isize) {
        for x in x0.max(0)..(x0 + 25).min(w as isize) {
            let k = y as usize * w + x as usize;
            let d = Vec2::new(x as f64 + 0.5, y as f64 + 0.5) - far;
            let (s, l) = (d.dot(&u), d.dot(&lat));
            if s < s0 || s > s1 || l.abs() > half || (t.mask[k] && !t.needle[k]) {
                continue;
            }
            let wgt = (f64::from(t.darkening[k]) / contrast).clamp(-0.5, 1.5);
            mass += wgt;
            lat_sum += wgt * l;
        }
    }
    if mass <= 0.0 {
        return far;
    }
    let s_centre = s0 + (mass - std::f64::consts::FRAC_PI_2 * r_px * r_px) / (2.0 * r_px);
    far + u * s_centre + lat * (lat_sum / mass)
}
