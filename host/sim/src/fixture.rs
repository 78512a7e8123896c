//! The fixture: wall polygons the peg can touch, and the goal region (the narrow channel).
//!
//! [`Fixture::paper`] reconstructs the paper's test-bed (a 2015 µm wide channel opening into a
//! 1090 µm narrow channel, origin at the fixture's top-left corner in the image, x right,
//! y down); `docs/fixture.md` documents the reconstruction with a dimensioned figure.

use crate::Error;
use mesopush_core::check::{Allowed, all_finite_in, finite_in, int_in};
use mesopush_core::geom::{ConvexPolygon, Vec2};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Width of the paper's wide channel, µm.
pub const WIDE_CHANNEL_UM: f64 = 2015.0;
/// Width of the paper's narrow channel, µm.
pub const NARROW_CHANNEL_UM: f64 = 1090.0;
/// The camera's field of view, µm (3.37 × 2.52 mm).
pub const FIELD_UM: [f64; 2] = [3370.0, 2520.0];

/// Walls and goal. Walls are convex polygons in the fixture frame, µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fixture {
    /// Wall polygons (fixture material).
    pub walls: Vec<ConvexPolygon>,
    /// The goal region (the narrow channel). The peg counts as inserted when its centre of
    /// mass lies at least `insert_depth_um` inside it — which a 985 µm peg in a 1090 µm
    /// channel can only do when aligned with the channel.
    pub goal: ConvexPolygon,
    /// How deep inside the goal the centre of mass must be, µm. Default 100.
    #[serde(default = "default_depth")]
    pub insert_depth_um: f64,
    /// Whether the part's whole outline must also lie inside the goal (for parts that can
    /// put their centre of mass deep into the goal while wedged across its mouth, as a
    /// triangle can). Default false: the centre-of-mass rule alone (the paper's).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub goal_whole_part: bool,
}

fn default_depth() -> f64 {
    100.0
}

/// Dimensions of the reconstructed paper fixture (all µm, fixture frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperFixtureParams {
    /// x of the step where the wide channel (to the right) meets the narrow one (to the left).
    pub x_step_um: f64,
    /// y of the wide channel's upper wall.
    pub wide_top_um: f64,
    /// y of the narrow channel's upper wall.
    pub narrow_top_um: f64,
    /// 45° chamfer cut off both entrance corners of the narrow channel (leg length), µm.
    #[serde(default)]
    pub chamfer_um: f64,
}

impl Default for PaperFixtureParams {
    /// The reconstruction chosen in `docs/fixture.md` (searched jointly with the nominal
    /// support distribution by `host/examples/fixture_search.rs`).
    fn default() -> Self {
        Self { x_step_um: 525.0, wide_top_um: 300.0, narrow_top_um: 950.0, chamfer_um: 225.0 }
    }
}

/// How far a vertex may lie outside the goal under `goal_whole_part`, as a fraction of the
/// part's diameter: 1e-3, 1.9 µm for the paper's peg (the simulator lets a part sink 1 µm
/// into a wall).
pub const WHOLE_PART_TOLERANCE: f64 = 1e-3;

/// Most walls a fixture may have.
pub const MAX_WALLS: usize = 256;
/// Where fixture vertices may lie, µm (±1 km about the origin: far beyond any fixture, yet
/// clear of the magnitudes whose squares overflow).
pub const COORDINATE_UM: Allowed = Allowed::closed(-1e9, 1e9, "µm");

/// How far the walls run beyond the camera field, µm (the narrow channel continues to the
/// left out of view).
const OUTSIDE_UM: f64 = 3000.0;

impl Fixture {
    /// The paper's fixture with the default reconstruction.
    pub fn paper() -> Self {
        Self::paper_with(&PaperFixtureParams::default()).expect("default fixture is valid")
    }

    /// The paper's fixture with given dimensions.
    pub fn paper_with(p: &PaperFixtureParams) -> Result<Self, Error> {
        let wide_bottom = p.wide_top_um + WIDE_CHANNEL_UM;
        let narrow_bottom = p.narrow_top_um + NARROW_CHANNEL_UM;
        let (xl, xr) = (-OUTSIDE_UM, FIELD_UM[0] + OUTSIDE_UM);
        let yb = FIELD_UM[1] + OUTSIDE_UM;
        let ok = p.x_step_um > 0.0
            && p.x_step_um < FIELD_UM[0]
            && p.wide_top_um >= 0.0
            && (0.0..=300.0).contains(&p.chamfer_um)
            && p.narrow_top_um >= p.wide_top_um
            && narrow_bottom <= wide_bottom
            && wide_bottom < yb;
        if !ok {
            return Err(Error::invalid(
                "fixture",
                format!(
                    "paper fixture dimensions out of range: x_step_um = {}, wide_top_um = {}, \
                     narrow_top_um = {}, chamfer_um = {}; allowed: x_step_um inside the camera \
                     field, wide_top_um ≥ 0, chamfer_um 0..=300, the narrow channel inside the \
                     wide one",
                    p.x_step_um, p.wide_top_um, p.narrow_top_um, p.chamfer_um
                ),
            ));
        }
        let mut walls = Vec::new();
        let mut push_rect = |x0: f64, y0: f64, x1: f64, y1: f64| -> Result<(), Error> {
            if y1 - y0 > 1.0 && x1 - x0 > 1.0 {
                walls.push(rect(x0, y0, x1, y1)?);
            }
            Ok(())
        };
        push_rect(p.x_step_um, 0.0, xr, p.wide_top_um)?;
        push_rect(p.x_step_um, wide_bottom, xr, yb)?;
        let c = p.chamfer_um;
        if c > 0.0 {
            let (xs, nt, nb) = (p.x_step_um, p.narrow_top_um, narrow_bottom);
            let v = |pts: &[[f64; 2]]| pts.iter().map(|&[x, y]| Vec2::new(x, y)).collect();
            walls.push(ConvexPolygon::new(v(&[
                [xl, 0.0],
                [xs, 0.0],
                [xs, nt - c],
                [xs - c, nt],
                [xl, nt],
            ]))?);
            walls.push(ConvexPolygon::new(v(&[
                [xl, nb],
                [xs - c, nb],
                [xs, nb + c],
                [xs, yb],
                [xl, yb],
            ]))?);
        } else {
            push_rect(xl, 0.0, p.x_step_um, p.narrow_top_um)?;
            push_rect(xl, narrow_bottom, p.x_step_um, yb)?;
        }
        let goal = rect(xl, p.narrow_top_um, p.x_step_um, narrow_bottom)?;
        Ok(Fixture { walls, goal, insert_depth_um: default_depth(), goal_whole_part: false })
    }

    /// Loads and validates a fixture TOML (`walls = [[[x, y], ...], ...]`,
    /// `goal = [[x, y], ...]`).
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let fixture: Fixture = toml::from_str(&text)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        fixture
            .validate()
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        Ok(fixture)
    }

    /// Checks every field, naming the field, the value and the allowed range: at most
    /// [`MAX_WALLS`] walls, every vertex within [`COORDINATE_UM`], `insert_depth_um` in
    /// [0, 10 000] µm. (Each polygon is already convex and finite by construction.)
    pub fn validate(&self) -> Result<(), Error> {
        int_in("fixture walls (number of walls)", self.walls.len(), 0, MAX_WALLS, "")?;
        let polygons = self.walls.iter().enumerate().map(|(i, w)| (format!("walls[{i}]"), w));
        for (name, poly) in polygons.chain(std::iter::once(("goal".to_string(), &self.goal))) {
            for (k, v) in poly.vertices().iter().enumerate() {
                all_finite_in(&format!("fixture {name} vertex {k}"), &[v.x, v.y], COORDINATE_UM)?;
            }
        }
        let depth = Allowed::closed(0.0, 10_000.0, "µm");
        finite_in("fixture insert_depth_um", self.insert_depth_um, depth)?;
        Ok(())
    }

    /// Whether a peg whose centre of mass is at `com` counts as inserted by the
    /// centre-of-mass rule (all a fixture asks unless `goal_whole_part`; see
    /// [`Fixture::part_inserted`]).
    pub fn inserted(&self, com: &Vec2) -> bool {
        self.goal.signed_distance(com) <= -self.insert_depth_um
    }

    /// Whether a part whose outline (at its pose) is `outline` and whose centre of mass is
    /// `com` counts as inserted: the centre-of-mass rule, and with `goal_whole_part` every
    /// vertex of the outline inside the goal too, to within [`WHOLE_PART_TOLERANCE`] of the
    /// outline's diameter (a part resting against the channel's wall sinks into it by the
    /// simulator's penetration).
    pub fn part_inserted(&self, outline: &ConvexPolygon, com: &Vec2) -> bool {
        let tol_um = WHOLE_PART_TOLERANCE * outline.diameter();
        self.inserted(com)
            && (!self.goal_whole_part
                || outline.vertices().iter().all(|v| self.goal.contains(v, tol_um)))
    }
}

/// Axis-aligned rectangle from two corners.
pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Result<ConvexPolygon, Error> {
    Ok(ConvexPolygon::new(vec![
        Vec2::new(x0, y0),
        Vec2::new(x1, y0),
        Vec2::new(x1, y1),
        Vec2::new(x0, y1),
    ])?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::Pose;

    #[test]
    fn the_entrance_chamfer_widens_only_the_mouth() {
        let f = Fixture::paper();
        let p = PaperFixtureParams::default();
        let nt = p.narrow_top_um;
        // Inside the chamfer, at the step: free space; a chamfer length into the channel: wall.
        let free = |x: f64, y: f64| f.walls.iter().all(|w| !w.contains(&Vec2::new(x, y), 0.0));
        assert!(free(p.x_step_um - 1.0, nt - p.chamfer_um / 2.0));
        assert!(!free(p.x_step_um - p.chamfer_um - 1.0, nt - 1.0));
        let square = Fixture::paper_with(&PaperFixtureParams { chamfer_um: 0.0, ..p }).unwrap();
        assert_eq!(square.walls.len(), f.walls.len());
        assert!(Fixture::paper_with(&PaperFixtureParams { chamfer_um: -1.0, ..p }).is_err());
    }

    #[test]
    fn the_whole_part_rule_refuses_a_part_wedged_across_the_mouth_that_the_com_rule_passes() {
        let mut f = Fixture::paper();
        // A 300 µm square whose centre is 200 µm inside the channel, on its mid-line: in.
        let sq = ConvexPolygon::rectangle(300.0, 300.0).unwrap();
        let com = Vec2::new(325.0, 1495.0);
        let inside = sq.translated(&com);
        // The same centre with a long arm reaching back out of the mouth (a triangle wedged
        // corner-first): the centre-of-mass rule passes it, the whole-part rule does not.
        let wedged = ConvexPolygon::new(vec![
            Vec2::new(-200.0, 1400.0),
            Vec2::new(1200.0, 1450.0),
            Vec2::new(-200.0, 1600.0),
        ])
        .unwrap();
        assert!(f.part_inserted(&inside, &com) && f.part_inserted(&wedged, &com));
        f.goal_whole_part = true;
        assert!(f.part_inserted(&inside, &com));
        assert!(!f.part_inserted(&wedged, &com));
        assert!(!f.part_inserted(&inside, &Vec2::new(500.0, 1495.0)), "the depth rule still holds");
    }

    /// The tolerance was declared (1e-3 of the part's diameter) but not applied: a part
    /// resting against the channel's wall, sunk into it by the simulator's 1 µm, failed the
    /// whole-part rule.
    #[test]
    fn a_part_resting_against_the_channel_wall_is_inside_and_one_reaching_out_is_not() {
        let f = Fixture { goal_whole_part: true, ..Fixture::paper() };
        let top = PaperFixtureParams::default().narrow_top_um;
        // The paper's peg (diameter 1889 µm: 1.9 µm of tolerance) lying in the channel.
        let peg = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        let d = peg.diameter();
        let at = |dy: f64| {
            let com = Vec2::new(-1000.0, top + 492.5 + dy);
            (peg.translated(&com), com)
        };
        let (sunk, com) = at(-1.0);
        assert!(f.part_inserted(&sunk, &com), "sunk 1 µm into the wall it rests on");
        let (out, com) = at(-2.0 * WHOLE_PART_TOLERANCE * d);
        assert!(!f.part_inserted(&out, &com), "twice the tolerance outside");
    }

    #[test]
    fn channels_have_the_paper_widths() {
        let p = PaperFixtureParams::default();
        let f = Fixture::paper();
        // A vertical probe line through the wide channel meets walls exactly 2015 µm apart.
        let x = p.x_step_um + 500.0;
        let free = |y: f64| f.walls.iter().all(|w| !w.contains(&Vec2::new(x, y), -1e-9));
        assert!(free(p.wide_top_um + 1.0) && free(p.wide_top_um + WIDE_CHANNEL_UM - 1.0));
        assert!(!free(p.wide_top_um - 1.0) && !free(p.wide_top_um + WIDE_CHANNEL_UM + 1.0));
        let x = p.x_step_um - 500.0;
        let free = |y: f64| f.walls.iter().all(|w| !w.contains(&Vec2::new(x, y), -1e-9));
        assert!(free(p.narrow_top_um + 1.0) && free(p.narrow_top_um + NARROW_CHANNEL_UM - 1.0));
        assert!(!free(p.narrow_top_um - 1.0));
    }

    #[test]
    fn table2_start_is_free_and_not_inserted() {
        let f = Fixture::paper();
        let peg = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        let pose = Pose::new(2330.0, 1210.0, 89f64.to_radians());
        let start = peg.transformed(&pose);
        assert!(!f.inserted(&pose.position()));
        for v in start.vertices() {
            assert!(f.walls.iter().all(|w| w.signed_distance(v) > 0.0), "vertex {v:?} in a wall");
        }
    }

    #[test]
    fn impossible_dimensions_are_refused() {
        let p = PaperFixtureParams { narrow_top_um: 2000.0, ..Default::default() };
        assert!(Fixture::paper_with(&p).is_err());
    }
}
