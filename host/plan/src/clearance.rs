//! Where the probe may be: clearance of probe positions and straight probe moves from the
//! fixture walls, the peg and the executor's workspace box. The simulator ignores probe–wall
//! contact (the needle is above the plate between the walls), so the planner must keep every
//! commanded probe path out of the walls itself.

use mesopush_core::geom::{ConvexPolygon, Vec2, cross, point_segment_distance};
use mesopush_executor::ExecutorConfig;
use mesopush_protocol::units::{nm_s_to_um_s, nm_to_um};

/// Clearance the probe disc keeps from the fixture walls, µm (beyond its radius).
pub const WALL_CLEARANCE_UM: f64 = 5.0;

/// The executor's default workspace box in µm: (min, max) corners.
pub fn workspace_um() -> (Vec2, Vec2) {
    let w = ExecutorConfig::DEFAULT.workspace;
    (
        Vec2::new(nm_to_um(w.min_x_nm), nm_to_um(w.min_y_nm)),
        Vec2::new(nm_to_um(w.max_x_nm), nm_to_um(w.max_y_nm)),
    )
}

/// The executor's default speed limit, µm/s.
pub fn max_speed_um_s() -> f64 {
    nm_s_to_um_s(ExecutorConfig::DEFAULT.max_speed_nm_s)
}

/// Whether `p` lies inside the executor's workspace box.
pub fn in_workspace(p: &Vec2) -> bool {
    let (lo, hi) = workspace_um();
    p.x >= lo.x && p.y >= lo.y && p.x <= hi.x && p.y <= hi.y
}

/// Whether segments `a`–`b` and `c`–`d` cross or touch.
fn segments_intersect(a: &Vec2, b: &Vec2, c: &Vec2, d: &Vec2) -> bool {
    let o1 = cross(&(b - a), &(c - a));
    let o2 = cross(&(b - a), &(d - a));
    let o3 = cross(&(d - c), &(a - c));
    let o4 = cross(&(d - c), &(b - c));
    o1 * o2 <= 0.0 && o3 * o4 <= 0.0 && (o1 != 0.0 || o2 != 0.0 || o3 != 0.0 || o4 != 0.0)
}

/// Distance between the segment `a`–`b` and a convex polygon, µm (0 when they overlap).
pub fn segment_polygon_distance(a: &Vec2, b: &Vec2, poly: &ConvexPolygon) -> f64 {
    let (da, db) = (poly.signed_distance(a), poly.signed_distance(b));
    if da <= 0.0 || db <= 0.0 {
        return 0.0;
    }
    let mut best = da.min(db);
    for i in 0..poly.len() {
        let (p, q) = poly.edge(i);
        if segments_intersect(a, b, &p, &q) {
            return 0.0;
        }
        best = best.min(point_segment_distance(&p, a, b));
    }
    best
}

/// The obstacles a probe path is checked against.
#[derive(Debug, Clone, Copy)]
pub struct Obstacles<'a> {
    /// Fixture walls.
    pub walls: &'a [ConvexPolygon],
    /// The peg outline at its current pose (None: ignore the peg).
    pub peg: Option<&'a ConvexPolygon>,
    /// Probe tip radius, µm.
    pub probe_radius_um: f64,
    /// Clearance kept from the peg beyond the probe radius, µm.
    pub peg_clearance_um: f64,
}

impl Obstacles<'_> {
    /// Whether the probe disc at `p` is clear of walls and peg and inside the workspace.
    pub fn point_free(&self, p: &Vec2) -> bool {
        self.segment_free(p, p)
    }

    /// Whether the probe disc swept from `a` to `b` stays clear of walls and peg and inside
    /// the workspace box (a box is convex, so checking the ends suffices for it).
    pub fn segment_free(&self, a: &Vec2, b: &Vec2) -> bool {
        if !(in_workspace(a) && in_workspace(b)) {
            return false;
        }
        let wall_min = self.probe_radius_um + WALL_CLEARANCE_UM;
        if self.walls.iter().any(|w| segment_polygon_distance(a, b, w) < wall_min) {
            return false;
        }
        let peg_min = self.probe_radius_um + self.peg_clearance_um;
        self.peg.is_none_or(|peg| segment_polygon_distance(a, b, peg) >= peg_min)
    }
}

/// First probe move (index) of a path that enters a wall or leaves the workspace, if any.
/// The path starts at `start` and follows `moves`.
pub fn first_wall_violation(
    start: Vec2,
    moves: &[[f64; 2]],
    walls: &[ConvexPolygon],
    probe_radius_um: f64,
) -> Option<usize> {
    let obstacles = Obstacles { walls, peg: None, probe_radius_um, peg_clearance_um: 0.0 };
    let mut p = start;
    for (i, m) in moves.iter().enumerate() {
        let q = p + Vec2::new(m[0], m[1]);
        if !obstacles.segment_free(&p, &q) {
            return Some(i);
        }
        p = q;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distance_sees_crossing_touching_and_clear_segments() {
        let sq = ConvexPolygon::rectangle(100.0, 100.0).unwrap();
        let d = |a: (f64, f64), b: (f64, f64)| {
            segment_polygon_distance(&Vec2::new(a.0, a.1), &Vec2::new(b.0, b.1), &sq)
        };
        assert_eq!(d((-200.0, 0.0), (200.0, 0.0)), 0.0, "crosses through");
        assert!((d((-200.0, 80.0), (200.0, 80.0)) - 30.0).abs() < 1e-9, "passes above");
        assert!((d((100.0, -200.0), (100.0, 200.0)) - 50.0).abs() < 1e-9, "passes beside");
        assert!((d((60.0, 60.0), (90.0, 90.0)) - 200f64.sqrt()).abs() < 1e-9, "corner");
    }
}
