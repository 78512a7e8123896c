//! Demo material for the synthetic microscope: where a probe tip touches a peg, and a short
//! pushing sequence (peg sliding and turning in the wide channel with the probe on it) used by
//! `mesopush render`, the tests and the benchmark.

use crate::needle::NeedleSettings;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};

/// Tip centre for a probe touching edge `edge` of the peg (at `along` ∈ [0, 1] of the edge),
/// tip surface on the edge. Edge indices follow the body polygon's vertex order.
pub fn probe_touching(
    peg: &ConvexPolygon,
    pose: &Pose,
    needle: &NeedleSettings,
    edge: usize,
    along: f64,
) -> Vec2 {
    let world = peg.transformed(pose);
    let i = edge % world.len();
    let (a, b) = world.edge(i);
    a + (b - a) * along.clamp(0.0, 1.0) + world.edge_normal(i) * (0.5 * needle.tip_diameter_um)
}

/// The edge whose outward normal points most along the needle's shaft: the side a needle
/// coming from that direction can push without its shaft crossing the peg.
pub fn edge_facing_needle(peg: &ConvexPolygon, pose: &Pose, needle: &NeedleSettings) -> usize {
    let world = peg.transformed(pose);
    let u = needle.shaft_dir();
    (0..world.len())
        .max_by(|&i, &j| world.edge_normal(i).dot(&u).total_cmp(&world.edge_normal(j).dot(&u)))
        .unwrap_or(0)
}

/// Frame `k` of an `n`-frame pushing sequence in the demo fixture's wide channel: the peg
/// slides right by 300 µm and turns from 0.5 rad to 0.05 rad while the probe touches the edge
/// facing the needle, a little off its middle.
pub fn demo_sequence_frame(
    peg: &ConvexPolygon,
    needle: &NeedleSettings,
    k: usize,
    n: usize,
) -> (Pose, Vec2) {
    let f = if n > 1 { k as f64 / (n - 1) as f64 } else { 0.0 };
    let pose = Pose::new(1000.0 + 300.0 * f, 1300.0 - 40.0 * f, 0.5 - 0.45 * f);
    let edge = edge_facing_needle(peg, &pose, needle);
    (pose, probe_touching(peg, &pose, needle, edge, 0.35))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::paper_peg;

    #[test]
    fn touching_tip_sits_one_radius_outside_the_edge() {
        let peg = paper_peg();
        let pose = Pose::new(1000.0, 1200.0, 0.4);
        let needle = NeedleSettings::default();
        let e = edge_facing_needle(&peg, &pose, &needle);
        let tip = probe_touching(&peg, &pose, &needle, e, 0.5);
        let d = peg.transformed(&pose).signed_distance(&tip);
        assert!((d - 12.5).abs() < 1e-9, "distance {d}");
        // the shaft leaves the peg: its normal points along the shaft
        assert!(peg.transformed(&pose).edge_normal(e).dot(&needle.shaft_dir()) > 0.0);
    }
}
