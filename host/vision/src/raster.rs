//! Anti-aliased rasterisation for the renderer: the exact area of a pixel square covered by a
//! half-plane, convex polygons with rough edges, and the tapered probe needle. Partial pixel
//! coverage is what lets the tracker reach sub-pixel accuracy, so it is computed exactly for
//! straight edges (and as a product of edge coverages at corners).

use crate::calib::Calibration;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};

/// A row-major `f32` plane (transmission or radiance), `width × height`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plane {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) data: Vec<f32>,
}

impl Plane {
    pub(crate) fn filled(width: usize, height: usize, value: f32) -> Self {
        Self { width, height, data: vec![value; width * height] }
    }
}

/// Fraction of the unit pixel square centred on the origin lying in `{x : n·x <= t}`, for a
/// unit normal `n`. The projection of a uniform point of the square on `n` has a trapezoidal
/// density, so the answer is its distribution function: quadratic ends, linear middle.
pub(crate) fn half_plane_coverage(nx: f64, ny: f64, t: f64) -> f64 {
    let (ax, ay) = (nx.abs(), ny.abs());
    let (a, b) = if ax >= ay { (ax, ay) } else { (ay, ax) };
    let outer = 0.5 * (a + b);
    if t <= -outer {
        return 0.0;
    }
    if t >= outer {
        return 1.0;
    }
    let inner = 0.5 * (a - b);
    if b < 1e-9 {
        return (0.5 + t / a).clamp(0.0, 1.0);
    }
    if t < -inner {
        (t + outer).powi(2) / (2.0 * a * b)
    } else if t <= inner {
        0.5 + t / a
    } else {
        1.0 - (outer - t).powi(2) / (2.0 * a * b)
    }
}

/// Per-edge displacement profiles (µm, outward positive) sampled along each edge of a body-
/// frame polygon; models laser-cut roughness.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Roughness {
    /// Sample spacing along the edge, µm.
    step_um: f64,
    /// One profile per edge, sampled from the edge's start vertex.
    profiles: Vec<Vec<f64>>,
}

impl Roughness {
    /// Profiles of the given RMS built from a few random sinusoids (wavelengths 15–300 µm),
    /// deterministic from `seed`.
    pub(crate) fn new(poly: &ConvexPolygon, rms_um: f64, seed: u64) -> Self {
        use rand::{RngExt, SeedableRng};
        let step_um = 2.0;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let profiles = (0..poly.len())
            .map(|i| {
                let (a, b) = poly.edge(i);
                let n = ((b - a).norm() / step_um).ceil() as usize + 2;
                let waves: Vec<(f64, f64, f64)> = (0..8)
                    .map(|_| {
                        let lambda = 15.0 * 20f64.powf(rng.random_range(0.0..1.0));
                        let phase = rng.random_range(0.0..std::f64::consts::TAU);
                        (lambda, phase, lambda.sqrt())
                    })
                    .collect();
                let mut p: Vec<f64> = (0..n)
                    .map(|k| {
                        let t = k as f64 * step_um;
                        waves.iter().map(|&(l, ph, amp)| amp * (t / l * TAU + ph).sin()).sum()
                    })
                    .collect();
                let mean = p.iter().sum::<f64>() / n as f64;
                let rms = (p.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
                let k = if rms > 0.0 { rms_um / rms } else { 0.0 };
                p.iter_mut().for_each(|v| *v = (*v - mean) * k);
                p
            })
            .collect();
        Self { step_um, profiles }
    }

    /// Displacement of edge `i` at `t_um` along it (linear interpolation, clamped).
    fn at(&self, i: usize, t_um: f64) -> f64 {
        let p = &self.profiles[i];
        let x = (t_um / self.step_um).clamp(0.0, (p.len() - 2) as f64);
        let k = x as usize;
        let f = x - k as f64;
        p[k] * (1.0 - f) + p[k + 1] * f
    }
}

const TAU: f64 = std::f64::consts::TAU;

/// A polygon edge in pixel space: outward unit normal and offset (`n·p <= c` inside), and
/// how many pixels along `n` one µm of outward displacement in the fixture frame moves it.
#[derive(Debug, Clone, Copy)]
struct PxEdge {
    n: Vec2,
    c: f64,
    px_per_um: f64,
}

/// Composites a body-frame polygon placed at `pose` onto `plane`: each pixel moves towards
/// `value` by its coverage. `rough` displaces the edges (body-frame profiles).
pub(crate) fn fill_polygon(
    plane: &mut Plane,
    calib: &Calibration,
    body: &ConvexPolygon,
    pose: &Pose,
    rough: Option<&Roughness>,
    value: f32,
) {
    let world = body.transformed(pose);
    let px: Vec<Vec2> = world.vertices().iter().map(|v| calib.um_to_px(v)).collect();
    let m = px.len();
    let edges: Vec<PxEdge> = (0..m)
        .map(|i| {
            let (a, b) = (px[i], px[(i + 1) % m]);
            let d = (b - a).normalize();
            let n = Vec2::new(d.y, -d.x);
            let px_per_um =
                ((n.x / calib.sx_um_per_px).powi(2) + (n.y / calib.sy_um_per_px).powi(2)).sqrt();
            PxEdge { n, c: n.dot(&a), px_per_um }
        })
        .collect();
    let margin = 1.5 + rough.map_or(0.0, |r| r.max_abs() / calib.mean_um_per_px());
    let Some((x0, y0, x1, y1)) = pixel_bounds(plane, &px, margin) else { return };
    for j in y0..y1 {
        for i in x0..x1 {
            let p = Vec2::new(i as f64 + 0.5, j as f64 + 0.5);
            let cov = polygon_pixel(&edges, &p, margin, |k| {
                rough.map_or(0.0, |r| {
                    let b = pose.inverse_transform_point(&calib.px_to_um(&p));
                    let (a0, a1) = body.edge(k);
                    r.at(k, (b - a0).dot(&(a1 - a0).normalize())) * edges[k].px_per_um
                })
            });
            if cov > 0.0 {
                let v = &mut plane.data[j * plane.width + i];
                *v += cov as f32 * (value - *v);
            }
        }
    }
}

/// Coverage of the pixel centred at `p` by the intersection of the edges' half-planes, each
/// edge displaced outward by `rough(k)` pixels.
fn polygon_pixel(edges: &[PxEdge], p: &Vec2, margin: f64, rough: impl Fn(usize) -> f64) -> f64 {
    let mut cov = 1.0;
    for (k, e) in edges.iter().enumerate() {
        let s = e.n.dot(p) - e.c;
        if s > margin {
            return 0.0;
        }
        if s > -margin {
            cov *= half_plane_coverage(e.n.x, e.n.y, rough(k) - s);
            if cov == 0.0 {
                return 0.0;
            }
        }
    }
    cov
}

impl Roughness {
    fn max_abs(&self) -> f64 {
        self.profiles.iter().flatten().fold(0.0, |m, v| m.max(v.abs()))
    }
}

/// Pixel index bounds `[x0, x1) × [y0, y1)` of points grown by `margin` px, clipped.
fn pixel_bounds(plane: &Plane, px: &[Vec2], margin: f64) -> Option<(usize, usize, usize, usize)> {
    let (mut lo, mut hi) = (Vec2::repeat(f64::INFINITY), Vec2::repeat(f64::NEG_INFINITY));
    for p in px {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let clip = |v: f64, n: usize| v.clamp(0.0, n as f64) as usize;
    let (x0, x1) =
        (clip((lo.x - margin).floor(), plane.width), clip((hi.x + margin).ceil(), plane.width));
    let (y0, y1) =
        (clip((lo.y - margin).floor(), plane.height), clip((hi.y + margin).ceil(), plane.height));
    (x0 < x1 && y0 < y1).then_some((x0, y0, x1, y1))
}
