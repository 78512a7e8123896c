//! What the microscope looks at: a plain description of the fixture walls, the peg and the
//! probe, plus a plausible fixture for tests and demos until the simulator provides the paper's.

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};

/// The paper's peg, µm (length × width).
pub const PEG_SIZE_UM: (f64, f64) = (1615.0, 985.0);

/// One scene to render. All coordinates in the fixture frame, µm, except the peg, which is
/// given in its body frame (centre of mass at the origin) and placed by `peg_pose`.
#[derive(Debug, Clone, Copy)]
pub struct Scene<'a> {
    /// Fixture material (acrylic walls), fixture frame.
    pub walls: &'a [ConvexPolygon],
    /// The peg's outline in its body frame, centre of mass at the origin. `None`: no peg.
    pub peg: Option<&'a ConvexPolygon>,
    /// Where the peg is.
    pub peg_pose: Pose,
    /// Centre of the probe's rounded tip, fixture frame. `None`: probe out of view.
    pub probe_tip: Option<Vec2>,
}

/// The paper's peg (1615 × 985 µm rectangle) in its body frame.
pub fn paper_peg() -> ConvexPolygon {
    ConvexPolygon::rectangle(PEG_SIZE_UM.0, PEG_SIZE_UM.1).expect("the paper's peg is valid")
}

/// Channel geometry of the demo fixture, µm (fixture frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DemoFixture {
    /// Wide channel: y of its top and bottom walls.
    pub wide_y_um: (f64, f64),
    /// Narrow channel: y of its top and bottom walls.
    pub narrow_y_um: (f64, f64),
    /// x where the wide channel ends and the narrow one begins.
    pub step_x_um: f64,
    /// The field, µm.
    pub field_um: (f64, f64),
}

impl Default for DemoFixture {
    /// A 2015 µm wide channel on the left narrowing to a 1090 µm channel on the right, both
    /// centred on y = 1260 in a 3370 × 2520 µm field (approximating the paper's Fig. 4).
    fn default() -> Self {
        let c = 1260.0;
        Self {
            wide_y_um: (c - 1007.5, c + 1007.5),
            narrow_y_um: (c - 545.0, c + 545.0),
            step_x_um: 2250.0,
            field_um: (3370.0, 2520.0),
        }
    }
}

impl DemoFixture {
    /// The walls as rectangles reaching 200 µm past the field so their outer edges never show.
    pub fn walls(&self) -> Result<Vec<ConvexPolygon>, Error> {
        let (w, h) = self.field_um;
        let m = 200.0;
        let rects = [
            // top and bottom walls of the wide channel, full width
            (-m, -m, w + m, self.wide_y_um.0),
            (-m, self.wide_y_um.1, w + m, h + m),
            // the step into the narrow channel (overlapping the walls above and below so no
            // seam shows where they meet)
            (self.step_x_um, -m, w + m, self.narrow_y_um.0),
            (self.step_x_um, self.narrow_y_um.1, w + m, h + m),
        ];
        rects.iter().map(|&(x0, y0, x1, y1)| rect(x0, y0, x1, y1)).collect()
    }
}

/// An axis-aligned rectangle from its corners, fixture frame.
pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Result<ConvexPolygon, Error> {
    let r = ConvexPolygon::rectangle(x1 - x0, y1 - y0)?;
    Ok(r.translated(&Vec2::new(0.5 * (x0 + x1), 0.5 * (y0 + y1))))
}

/// Whether two convex polygons overlap by more than `margin_um` (separating axis test; a
/// positive margin also counts near-misses closer than it as overlapping).
pub fn polygons_overlap(a: &ConvexPolygon, b: &ConvexPolygon, margin_um: f64) -> bool {
    let separated_by = |p: &ConvexPolygon, q: &ConvexPolygon| {
        (0..p.len()).any(|i| {
            let n = p.edge_normal(i);
            let a0 = p.edge(i).0;
            q.vertices().iter().all(|v| n.dot(&(v - a0)) > margin_um)
        })
    };
    !(separated_by(a, b) || separated_by(b, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demo_walls_leave_the_channels_open() {
        let f = DemoFixture::default();
        let walls = f.walls().unwrap();
        let in_wide = Vec2::new(1000.0, 1260.0);
        let in_narrow = Vec2::new(3000.0, 1260.0);
        let in_wall = Vec2::new(3000.0, 500.0);
        assert!(walls.iter().all(|w| !w.contains(&in_wide, 0.0)));
        assert!(walls.iter().all(|w| !w.contains(&in_narrow, 0.0)));
        assert!(walls.iter().any(|w| w.contains(&in_wall, 0.0)));
        assert!((f.narrow_y_um.1 - f.narrow_y_um.0 - 1090.0).abs() < 1e-9);
        assert!((f.wide_y_um.1 - f.wide_y_um.0 - 2015.0).abs() < 1e-9);
    }

    #[test]
    fn overlap_test_separates_and_detects() {
        let a = rect(0.0, 0.0, 10.0, 10.0).unwrap();
        let b = rect(12.0, 0.0, 20.0, 10.0).unwrap();
        assert!(!polygons_overlap(&a, &b, 0.0));
        assert!(polygons_overlap(&a, &b, 5.0));
        let c = rect(9.0, 9.0, 20.0, 20.0).unwrap();
        assert!(polygons_overlap(&a, &c, 0.0));
    }
}
