//! Contact detection between the peg, the probe and the fixture walls.
//!
//! Vertex–edge both ways (peg vertices against wall polygons, wall vertices against the peg)
//! and the probe disc against the peg. Every pair closer than the contact margin becomes a
//! [`Contact`] with its gap ψ (negative when penetrating), so contacts enter the step's
//! problem ahead of touching and a fast approach cannot tunnel.

use mesopush_core::geom::{ConvexPolygon, Vec2, point_segment_distance};

/// What the peg touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactKind {
    /// Disc `k` of the pusher (the probe tip is disc 0 of a one-disc pusher).
    Probe(usize),
    /// Fixture wall `wall`; `peg_vertex` says whether the peg's vertex touches the wall's
    /// edge (true) or a wall vertex touches the peg's edge (false).
    Wall {
        /// Index of the wall polygon.
        wall: usize,
        /// Peg vertex on wall edge (true) or wall vertex on peg edge (false).
        peg_vertex: bool,
    },
}

/// One (possible) contact on the peg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// What the peg touches.
    pub kind: ContactKind,
    /// Contact point on the peg, fixture frame, µm.
    pub point: Vec2,
    /// Unit normal along which the contact can push the peg.
    pub normal: Vec2,
    /// Gap ψ along the normal, µm (negative: penetration).
    pub gap_um: f64,
}

/// Closest boundary point of a convex polygon to `p`: (signed distance, closest point, unit
/// outward normal of the polygon there pointing towards `p` when `p` is outside).
pub fn closest_on_polygon(poly: &ConvexPolygon, p: &Vec2) -> (f64, Vec2, Vec2) {
    let n = poly.len();
    let mut best_sep = f64::NEG_INFINITY;
    let mut best_edge = 0;
    for i in 0..n {
        let s = poly.edge_normal(i).dot(&(p - poly.edge(i).0));
        if s > best_sep {
            best_sep = s;
            best_edge = i;
        }
    }
    if best_sep <= 0.0 {
        let normal = poly.edge_normal(best_edge);
        return (best_sep, p - normal * best_sep, normal);
    }
    let mut best = (f64::INFINITY, Vec2::zeros());
    for i in 0..n {
        let (a, b) = poly.edge(i);
        let d = point_segment_distance(p, &a, &b);
        if d < best.0 {
            let ab = b - a;
            let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            best = (d, a + ab * t);
        }
    }
    let (d, c) = best;
    let normal = if d > 0.0 { (p - c) / d } else { poly.edge_normal(best_edge) };
    (d, c, normal)
}

/// Pusher disc `disc` (centre `tip`, radius `radius_um`) against the peg, if within
/// `margin_um`.
pub fn probe_contact(
    peg: &ConvexPolygon,
    disc: usize,
    tip: &Vec2,
    radius_um: f64,
    margin_um: f64,
) -> Option<Contact> {
    let (d, c, n_out) = closest_on_polygon(peg, tip);
    let gap = d - radius_um;
    (gap <= margin_um).then_some(Contact {
        kind: ContactKind::Probe(disc),
        point: c,
        normal: -n_out,
        gap_um: gap,
    })
}

/// Appends the peg–wall contacts within `margin_um` to `out` (vertex–edge both ways,
/// near-duplicates merged).
pub fn wall_contacts(
    peg: &ConvexPolygon,
    walls: &[ConvexPolygon],
    margin_um: f64,
    out: &mut Vec<Contact>,
) {
    let (plo, phi) = peg.bounds();
    let centre = peg.centroid();
    let size_um = peg.vertices().iter().map(|v| (v - centre).norm()).fold(0.0, f64::max);
    let merge_um = MERGE_FRACTION * size_um;
    for (wi, wall) in walls.iter().enumerate() {
        let (wlo, whi) = wall.bounds();
        let apart = plo.x > whi.x + margin_um
            || plo.y > whi.y + margin_um
            || wlo.x > phi.x + margin_um
            || wlo.y > phi.y + margin_um;
        if apart {
            continue;
        }
        for v in peg.vertices() {
            let (d, _, n_out) = closest_on_polygon(wall, v);
            if d <= margin_um {
                let kind = ContactKind::Wall { wall: wi, peg_vertex: true };
                push_unique(out, Contact { kind, point: *v, normal: n_out, gap_um: d }, merge_um);
            }
        }
        for w in wall.vertices() {
            let (d, c, n_out) = closest_on_polygon(peg, w);
            if d <= margin_um {
                let kind = ContactKind::Wall { wall: wi, peg_vertex: false };
                push_unique(out, Contact { kind, point: c, normal: -n_out, gap_um: d }, merge_um);
            }
        }
    }
}

/// Two contacts closer than this fraction of the peg's size (its largest vertex distance
/// from its centroid) with nearly the same normal are the same contact (a corner meeting a
/// corner is found from both sides): 0.47 µm for the paper's peg.
pub const MERGE_FRACTION: f64 = 5e-4;

fn push_unique(out: &mut Vec<Contact>, c: Contact, merge_um: f64) {
    let dup = out
        .iter()
        .any(|o| (o.point - c.point).norm() < merge_um && o.normal.dot(&c.normal) > 0.995);
    if !dup {
        out.push(c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::Pose;

    fn peg_at(x: f64, y: f64, th: f64) -> ConvexPolygon {
        ConvexPolygon::rectangle(1000.0, 500.0).unwrap().transformed(&Pose::new(x, y, th))
    }

    #[test]
    fn probe_left_of_peg_pushes_right() {
        let peg = peg_at(0.0, 0.0, 0.0);
        let c = probe_contact(&peg, 0, &Vec2::new(-520.0, 10.0), 12.5, 30.0).unwrap();
        assert!((c.gap_um - 7.5).abs() < 1e-9);
        assert!((c.normal - Vec2::new(1.0, 0.0)).norm() < 1e-12);
        assert!((c.point - Vec2::new(-500.0, 10.0)).norm() < 1e-9);
        assert!(probe_contact(&peg, 0, &Vec2::new(-600.0, 0.0), 12.5, 30.0).is_none());
    }

    #[test]
    fn peg_resting_flat_on_a_floor_gives_two_contacts() {
        let floor = crate::fixture::rect(-2000.0, 260.0, 2000.0, 900.0).unwrap();
        let mut out = Vec::new();
        wall_contacts(&peg_at(0.0, 0.0, 0.0), &[floor], 30.0, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        for c in &out {
            assert!((c.gap_um - 10.0).abs() < 1e-9);
            assert!((c.normal - Vec2::new(0.0, -1.0)).norm() < 1e-12);
        }
    }

    #[test]
    fn wall_corner_against_peg_edge_pushes_into_the_peg() {
        // A wall whose corner pokes at the peg's left edge from the left.
        let wall = crate::fixture::rect(-900.0, -50.0, -505.0, 50.0).unwrap();
        let mut out = Vec::new();
        wall_contacts(&peg_at(0.0, 0.0, 0.0), &[wall], 30.0, &mut out);
        assert!(!out.is_empty());
        for c in &out {
            assert!((c.normal - Vec2::new(1.0, 0.0)).norm() < 1e-9, "{c:?}");
            assert!((c.gap_um - 5.0).abs() < 1e-9);
        }
    }

    #[test]
    fn penetration_is_reported_as_negative_gap() {
        let peg = peg_at(0.0, 0.0, 0.0);
        let c = probe_contact(&peg, 0, &Vec2::new(-495.0, 0.0), 12.5, 30.0).unwrap();
        assert!((c.gap_um + 17.5).abs() < 1e-9, "{c:?}");
        assert!((c.normal - Vec2::new(1.0, 0.0)).norm() < 1e-12);
    }
}
