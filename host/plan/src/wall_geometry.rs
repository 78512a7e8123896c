//! The geometry of a press against a wall: how far a part can slide along a direction
//! before it meets a wall ([`gap_along`]), whether it overlaps one, and the part squared to
//! a direction (the face whose normal is nearest it turned to face it exactly).

use mesopush_core::geom::{ConvexPolygon, Vec2, cross};

/// Distance along `d` from `p` to the boundary of convex `poly`, if the ray meets it (the
/// nearest crossing beyond `tol`).
pub(crate) fn ray_distance(p: Vec2, d: Vec2, poly: &ConvexPolygon, tol: f64) -> Option<f64> {
    let v = poly.vertices();
    (0..v.len())
        .filter_map(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let e = b - a;
            let den = cross(&d, &e);
            if den.abs() < 1e-12 {
                return None;
            }
            let t = cross(&(a - p), &e) / den;
            let s = cross(&(a - p), &d) / den;
            (t > tol && (0.0..=1.0).contains(&s)).then_some(t)
        })
        .min_by(f64::total_cmp)
}

/// How far `part` can translate along `d` before it touches one of `walls`: the shortest ray
/// from a vertex of one, outside the other by more than `tol`, to the other (points already
/// touching or inside — a part resting on a wall sinks into it by the simulator's
/// tolerance — cast no ray, so a part on the floor is not stopped by the floor it rests on).
pub fn gap_along(part: &ConvexPolygon, d: Vec2, walls: &[ConvexPolygon], tol: f64) -> Option<f64> {
    let outside = |p: &ConvexPolygon, v: &Vec2| p.signed_distance(v) > tol;
    let from_part = walls.iter().flat_map(|w| {
        part.vertices()
            .iter()
            .filter(|v| outside(w, v))
            .filter_map(move |v| ray_distance(*v, d, w, tol))
    });
    let from_walls = walls.iter().flat_map(|w| {
        w.vertices()
            .iter()
            .filter(|u| outside(part, u))
            .filter_map(|u| ray_distance(*u, -d, part, tol))
    });
    from_part.chain(from_walls).min_by(f64::total_cmp)
}

/// Whether `part` and one of `walls` overlap by more than `tol`.
pub(crate) fn overlaps(part: &ConvexPolygon, walls: &[ConvexPolygon], tol: f64) -> bool {
    walls.iter().any(|w| {
        part.vertices().iter().any(|v| w.signed_distance(v) < -tol)
            || w.vertices().iter().any(|v| part.signed_distance(v) < -tol)
    })
}

/// The largest extent of `v` from `c` along `d`.
pub(crate) fn support(v: &[Vec2], c: Vec2, d: Vec2) -> f64 {
    v.iter().map(|p| (*p - c).dot(&d)).fold(f64::NEG_INFINITY, f64::max)
}

/// How close counts as touching, as a fraction of the part's diameter: 1e-3 (1.9 µm for the
/// paper's peg; the simulator lets a part sink 1 µm into a wall).
pub(crate) const TOUCH_FRACTION: f64 = 1e-3;

/// The vertices of `outline` turned about its centroid so that the edge whose outward normal
/// is nearest `d` faces along `d` exactly.
pub(crate) fn squared(outline: &ConvexPolygon, d: Vec2) -> Vec<Vec2> {
    let v = outline.vertices();
    let c = outline.centroid();
    let best = (0..v.len())
        .max_by(|&a, &b| outline.edge_normal(a).dot(&d).total_cmp(&outline.edge_normal(b).dot(&d)))
        .unwrap_or(0);
    let n = outline.edge_normal(best);
    let turn = cross(&n, &d).atan2(n.dot(&d));
    let (sn, cs) = turn.sin_cos();
    v.iter()
        .map(|p| {
            let q = *p - c;
            c + Vec2::new(cs * q.x - sn * q.y, sn * q.x + cs * q.y)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gap_to_a_wall_is_the_translation_that_makes_them_touch() {
        let part = ConvexPolygon::rectangle(200.0, 100.0).unwrap();
        let wall = mesopush_sim::fixture::rect(-1000.0, -400.0, 1000.0, -300.0).unwrap();
        // The part's top edge at y = −50, the wall's bottom at y = −300: 250 along −y.
        let g = gap_along(&part, Vec2::new(0.0, -1.0), std::slice::from_ref(&wall), 1e-6).unwrap();
        assert!((g - 250.0).abs() < 1e-9, "{g}");
        // Nothing that way along +y.
        assert_eq!(gap_along(&part, Vec2::new(0.0, 1.0), std::slice::from_ref(&wall), 1e-6), None);
        // A wall corner poking down at x = 0 meets the part's top edge (vertex of the wall).
        let spike = ConvexPolygon::new(vec![
            Vec2::new(-10.0, -500.0),
            Vec2::new(10.0, -500.0),
            Vec2::new(0.0, -120.0),
        ])
        .unwrap();
        let g = gap_along(&part, Vec2::new(0.0, -1.0), &[spike], 1e-6).unwrap();
        assert!((g - 70.0).abs() < 1e-9, "{g}");
        // Resting on the wall (sunk 0.5 µm into it) the part is not stopped by it when pushed
        // away, nor along it: the wall it rests on casts no ray.
        let resting = part.translated(&Vec2::new(0.0, -249.5));
        assert_eq!(
            gap_along(&resting, Vec2::new(0.0, 1.0), std::slice::from_ref(&wall), 1.0),
            None
        );
        assert_eq!(gap_along(&resting, Vec2::new(1.0, 0.0), &[wall], 1.0), None);
    }
}
