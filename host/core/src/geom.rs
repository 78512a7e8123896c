//! Planar geometry shared by the simulator, the renderer, the tracker and the planner.
//!
//! Frame convention (the paper's): the fixture frame has its origin at the fixture's top-left
//! corner as seen in the image, x to the right, y down, lengths in µm. An angle θ turns the
//! x axis towards the y axis (so a positive θ looks clockwise on screen). A polygon's vertices
//! are listed with positive signed area in these coordinates.

use nalgebra::{Rotation2, Vector2};
use serde::{Deserialize, Serialize};

/// A point or vector in the plane, µm.
pub type Vec2 = Vector2<f64>;

/// Planar pose of a rigid part: position of its reference point (the centre of mass) in µm and
/// orientation in rad.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Pose {
    /// x of the centre of mass in the fixture frame, µm.
    pub x_um: f64,
    /// y of the centre of mass in the fixture frame, µm.
    pub y_um: f64,
    /// orientation, rad.
    pub theta_rad: f64,
}

impl Pose {
    /// A pose from its three coordinates (µm, µm, rad).
    pub const fn new(x_um: f64, y_um: f64, theta_rad: f64) -> Self {
        Self { x_um, y_um, theta_rad }
    }

    /// Position as a vector, µm.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x_um, self.y_um)
    }

    /// Maps a point given in the body frame to the fixture frame.
    pub fn transform_point(&self, body: &Vec2) -> Vec2 {
        self.rotate(body) + self.position()
    }

    /// Rotates a body-frame vector into the fixture frame.
    pub fn rotate(&self, body: &Vec2) -> Vec2 {
        Rotation2::new(self.theta_rad) * body
    }

    /// Maps a fixture-frame point into the body frame.
    pub fn inverse_transform_point(&self, world: &Vec2) -> Vec2 {
        Rotation2::new(-self.theta_rad) * (world - self.position())
    }
}

/// For people: `x -277.7 µm, y 1508.2 µm, θ 3.74°` (θ in degrees, as operators give it).
impl std::fmt::Display for Pose {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let deg = self.theta_rad.to_degrees();
        write!(f, "x {:.1} µm, y {:.1} µm, θ {deg:.2}°", self.x_um, self.y_um)
    }
}

/// 2D cross product (z component of the 3D cross product).
pub fn cross(a: &Vec2, b: &Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Why a polygon was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PolygonError {
    /// Fewer than three vertices.
    #[error("a polygon needs at least 3 vertices, got {0}")]
    TooFewVertices(usize),
    /// A coordinate is NaN or infinite.
    #[error("vertex {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// The polygon is not strictly convex (or its vertices are not in order).
    #[error("polygon is not strictly convex at vertex {0} (vertices must go round in order)")]
    NotConvex(usize),
    /// Zero or near-zero area.
    #[error("polygon has (near) zero area")]
    Degenerate,
}

/// A convex polygon. Vertices are stored with positive signed area (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<[f64; 2]>", into = "Vec<[f64; 2]>")]
pub struct ConvexPolygon {
    vertices: Vec<Vec2>,
}

impl ConvexPolygon {
    /// Builds a polygon from vertices in either winding; checks convexity and finiteness.
    pub fn new(mut vertices: Vec<Vec2>) -> Result<Self, PolygonError> {
        let n = vertices.len();
        if n < 3 {
            return Err(PolygonError::TooFewVertices(n));
        }
        if let Some(i) = vertices.iter().position(|v| !(v.x.is_finite() && v.y.is_finite())) {
            return Err(PolygonError::NonFinite(i));
        }
        let area = signed_area(&vertices);
        let scale = vertices.iter().map(|v| v.norm()).fold(0.0, f64::max).max(1e-300);
        if area.abs() <= 1e-12 * scale * scale {
            return Err(PolygonError::Degenerate);
        }
        if area < 0.0 {
            vertices.reverse();
        }
        for i in 0..n {
            let a = vertices[i];
            let b = vertices[(i + 1) % n];
            let c = vertices[(i + 2) % n];
            if cross(&(b - a), &(c - b)) <= 0.0 {
                return Err(PolygonError::NotConvex((i + 1) % n));
            }
        }
        Ok(Self { vertices })
    }

    /// An axis-aligned rectangle centred on the origin (width along x, height along y), µm.
    pub fn rectangle(width_um: f64, height_um: f64) -> Result<Self, PolygonError> {
        let (w, h) = (width_um / 2.0, height_um / 2.0);
        Self::new(vec![Vec2::new(-w, -h), Vec2::new(w, -h), Vec2::new(w, h), Vec2::new(-w, h)])
    }

    /// The vertices, positive signed area order.
    pub fn vertices(&self) -> &[Vec2] {
        &self.vertices
    }

    /// Number of vertices (= number of edges).
    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    /// Always false: a valid polygon has at least three vertices.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Edge `i` as (start, end).
    pub fn edge(&self, i: usize) -> (Vec2, Vec2) {
        (self.vertices[i], self.vertices[(i + 1) % self.vertices.len()])
    }

    /// Outward unit normal of edge `i`.
    pub fn edge_normal(&self, i: usize) -> Vec2 {
        let (a, b) = self.edge(i);
        let d = (b - a).normalize();
        // Positive signed area: interior lies to the left of each edge in (x, y) coordinates,
        // so the outward normal is the edge direction turned to the right.
        Vec2::new(d.y, -d.x)
    }

    /// Area, µm².
    pub fn area(&self) -> f64 {
        signed_area(&self.vertices)
    }

    /// Area centroid.
    pub fn centroid(&self) -> Vec2 {
        let n = self.vertices.len();
        let mut c = Vec2::zeros();
        let mut a2 = 0.0;
        for i in 0..n {
            let p = self.vertices[i];
            let q = self.vertices[(i + 1) % n];
            let w = cross(&p, &q);
            a2 += w;
            c += (p + q) * w;
        }
        c / (3.0 * a2)
    }

    /// Whether `p` lies inside or on the boundary (within `tol_um`).
    pub fn contains(&self, p: &Vec2, tol_um: f64) -> bool {
        (0..self.len()).all(|i| {
            let (a, _) = self.edge(i);
            self.edge_normal(i).dot(&(p - a)) <= tol_um
        })
    }

    /// Signed distance from `p` to the boundary: negative inside (depth), positive outside.
    pub fn signed_distance(&self, p: &Vec2) -> f64 {
        let inside_depth = (0..self.len())
            .map(|i| self.edge_normal(i).dot(&(p - self.edge(i).0)))
            .fold(f64::NEG_INFINITY, f64::max);
        if inside_depth <= 0.0 {
            return inside_depth;
        }
        (0..self.len())
            .map(|i| {
                let (a, b) = self.edge(i);
                point_segment_distance(p, &a, &b)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The polygon with every vertex mapped by `pose` into the fixture frame.
    pub fn transformed(&self, pose: &Pose) -> ConvexPolygon {
        ConvexPolygon { vertices: self.vertices.iter().map(|v| pose.transform_point(v)).collect() }
    }

    /// The polygon translated so that `origin` becomes (0, 0).
    pub fn translated(&self, offset: &Vec2) -> ConvexPolygon {
        ConvexPolygon { vertices: self.vertices.iter().map(|v| v + offset).collect() }
    }

    /// The largest distance between two vertices (the polygon's diameter).
    pub fn diameter(&self) -> f64 {
        let v = &self.vertices;
        v.iter().flat_map(|a| v.iter().map(move |b| (a - b).norm())).fold(0.0, f64::max)
    }

    /// Axis-aligned bounding box as (min, max).
    pub fn bounds(&self) -> (Vec2, Vec2) {
        let mut lo = Vec2::repeat(f64::INFINITY);
        let mut hi = Vec2::repeat(f64::NEG_INFINITY);
        for v in &self.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        (lo, hi)
    }
}

impl TryFrom<Vec<[f64; 2]>> for ConvexPolygon {
    type Error = PolygonError;
    fn try_from(v: Vec<[f64; 2]>) -> Result<Self, Self::Error> {
        Self::new(v.into_iter().map(|[x, y]| Vec2::new(x, y)).collect())
    }
}

impl From<ConvexPolygon> for Vec<[f64; 2]> {
    fn from(p: ConvexPolygon) -> Self {
        p.vertices.iter().map(|v| [v.x, v.y]).collect()
    }
}

/// Signed area of a closed polygon (positive for the stored winding).
pub fn signed_area(vertices: &[Vec2]) -> f64 {
    let n = vertices.len();
    (0..n).map(|i| cross(&vertices[i], &vertices[(i + 1) % n])).sum::<f64>() / 2.0
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: &Vec2, a: &Vec2, b: &Vec2) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_is_valid_and_centred() {
        let r = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        assert!((r.area() - 1615.0 * 985.0).abs() < 1e-6);
        assert!(r.centroid().norm() < 1e-9);
        assert!(r.contains(&Vec2::new(800.0, 490.0), 0.0));
        assert!(!r.contains(&Vec2::new(810.0, 0.0), 0.0));
    }

    #[test]
    fn winding_is_normalised_and_normals_point_out() {
        let r = ConvexPolygon::new(vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
        ])
        .unwrap();
        assert!(r.area() > 0.0);
        let c = r.centroid();
        for i in 0..r.len() {
            let (a, _) = r.edge(i);
            assert!(r.edge_normal(i).dot(&(a - c)) > 0.0);
        }
    }

    #[test]
    fn non_convex_and_degenerate_are_refused() {
        let bad = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(2.0, 0.0),
            Vec2::new(1.0, 0.2),
            Vec2::new(2.0, 2.0),
            Vec2::new(0.0, 2.0),
        ];
        assert!(matches!(ConvexPolygon::new(bad), Err(PolygonError::NotConvex(_))));
        let flat = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(2.0, 0.0)];
        assert_eq!(ConvexPolygon::new(flat), Err(PolygonError::Degenerate));
        assert_eq!(ConvexPolygon::new(vec![]), Err(PolygonError::TooFewVertices(0)));
    }

    #[test]
    fn pose_round_trips_points() {
        let pose = Pose::new(2330.0, 1210.0, 89f64.to_radians());
        let p = Vec2::new(300.0, -20.0);
        let back = pose.inverse_transform_point(&pose.transform_point(&p));
        assert!((back - p).norm() < 1e-9);
    }

    #[test]
    fn signed_distance_inside_and_outside() {
        let r = ConvexPolygon::rectangle(2.0, 2.0).unwrap();
        assert!((r.signed_distance(&Vec2::new(0.0, 0.0)) + 1.0).abs() < 1e-12);
        assert!((r.signed_distance(&Vec2::new(3.0, 0.0)) - 2.0).abs() < 1e-12);
        assert!((r.signed_distance(&Vec2::new(4.0, 5.0)) - 5.0).abs() < 1e-12);
    }
}
