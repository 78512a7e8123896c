//! Where the default robust search starts its press: on the top edge of the peg as the
//! skeleton's own rotation leaves it in the nominal world, a quarter of the edge's length in
//! from its right end.
//!
//! Why: the press is the one move of the skeleton whose useful region is small. Pressing to
//! the height of the nominal peg's edge leaves the nominal peg where it is and lowers only
//! the draws that the rotation left higher; over the right end it also meets the draws whose
//! turn stalled. Searches that started the press at Table II's numbers (the middle of the
//! rotated peg, at the height that centres a level peg) found this region in about half of
//! their rounds and otherwise settled where the press touches no draw (docs/planning.md).
//! The point is computed from the nominal replay, not stored: another model, fixture or
//! start pose moves it.

use crate::Error;
use crate::skeleton::Skeleton;
use crate::world::UncertainWorld;
use mesopush_core::geom::Vec2;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Simulator, replay};

/// Where along the upward-facing edge the press goes, as a fraction of the edge's length
/// from its left end.
pub const ALONG_TOP_EDGE: f64 = 0.75;

/// `s` with its press moved onto the nominally rotated peg (see the module header); the
/// other numbers are unchanged. Errors if the nominal replay fails.
pub fn press_on_rotated_peg(
    s: Skeleton,
    world: &UncertainWorld<'_>,
    start: PegStart,
) -> Result<Skeleton, Error> {
    let mut sim =
        Simulator::new(world.model.clone(), world.fixture.clone(), world.settings.clone())?;
    let rotated = replay(&mut sim, &s.rotation_plan(start), None)?.final_pose;
    let outline = world.model.part.polygon().transformed(&rotated);
    let [px, py] = point_along_top_edge(outline.vertices(), ALONG_TOP_EDGE);
    let mut out = s;
    out.params[2] = px;
    out.params[3] = py;
    Ok(out.clamped())
}

/// The point at `fraction` of the way (from its left end) along the edge of the convex
/// polygon `v` whose outward normal points most nearly up (−y; y is down).
fn point_along_top_edge(v: &[Vec2], fraction: f64) -> [f64; 2] {
    let n = v.len();
    debug_assert!(n >= 3, "a part outline has at least three vertices");
    // Counter-clockwise in (x, y): the outward normal of edge (a, b) is (b − a) turned right.
    // The outward normal's −y component is then the edge direction's x component.
    let upness = |i: usize| (v[(i + 1) % n] - v[i]).normalize().x;
    let i = (0..n).max_by(|&a, &b| upness(a).total_cmp(&upness(b))).unwrap_or(0);
    let (a, b) = (v[i], v[(i + 1) % n]);
    let (left, right) = if a.x <= b.x { (a, b) } else { (b, a) };
    let p = left + (right - left) * fraction;
    [p.x, p.y]
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_sim::{Fixture, Model, Plan, SimSettings};

    #[test]
    fn the_top_edge_of_a_turned_rectangle_is_its_upward_long_edge() {
        // A 200 × 100 rectangle turned by +20° (y down: its right end lower).
        let th = 20f64.to_radians();
        let (c, s) = (th.cos(), th.sin());
        let corner = |x: f64, y: f64| Vec2::new(c * x - s * y, s * x + c * y);
        let v = [
            corner(-100.0, -50.0),
            corner(100.0, -50.0),
            corner(100.0, 50.0),
            corner(-100.0, 50.0),
        ];
        let [x, y] = point_along_top_edge(&v, 0.75);
        let want = corner(-100.0, -50.0) + (corner(100.0, -50.0) - corner(-100.0, -50.0)) * 0.75;
        assert!((x - want.x).abs() < 1e-9 && (y - want.y).abs() < 1e-9, "{x}, {y} vs {want:?}");
    }

    #[test]
    fn the_press_starts_on_the_nominally_rotated_peg_over_its_right_end() {
        let (model, fixture, settings) =
            (Model::default(), Fixture::paper(), SimSettings::default());
        let world = UncertainWorld::nominal(&model, &fixture, &settings);
        let start = Plan::table2().peg_start;
        let t2 = Skeleton::table2_like();
        let s = press_on_rotated_peg(t2, &world, start).unwrap();
        // Only the press moved.
        for k in [0, 1, 4, 5] {
            assert_eq!(s.params[k], t2.params[k], "parameter {k}");
        }
        // On the rotated nominal peg's outline, right of its centre of mass.
        let mut sim = Simulator::new(model.clone(), fixture.clone(), settings.clone()).unwrap();
        let pose = replay(&mut sim, &t2.rotation_plan(start), None).unwrap().final_pose;
        let outline = model.part.polygon().transformed(&pose);
        let p = Vec2::new(s.params[2], s.params[3]);
        assert!(outline.signed_distance(&p).abs() < 1e-6, "{p:?} is off the outline of {pose:?}");
        assert!(p.x > pose.x_um + 300.0 && p.y < pose.y_um, "{p:?} vs {pose:?}");
    }
}
