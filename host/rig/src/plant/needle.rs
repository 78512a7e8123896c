//! Where the needle's tip rests. The world's simulator treats the needle as compliant: a peg
//! that resists lets the probe point press into it, and a wedged peg stops it while the stage
//! goes on. The tip itself cannot be inside the peg: it stays on the outline — on the edge it
//! met — and the needle bends. [`resting_tip`] finds that point (for the truth and the
//! camera); [`contact_edge`] names the edge when the probe first touches.

use mesopush_core::geom::{ConvexPolygon, Vec2};

/// The edge the probe point `p` touches or presses through (the one it is least deep
/// behind), when its tip (radius `r_um`) does not clear `peg`.
pub fn contact_edge(peg: &ConvexPolygon, p: Vec2, r_um: f64) -> Option<usize> {
    if peg.signed_distance(&p) >= r_um {
        return None;
    }
    (0..peg.len())
        .map(|i| (i, peg.edge_normal(i).dot(&(p - peg.edge(i).0))))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Where a needle whose undeflected centre is `p` rests against `peg` (a convex outline):
/// `p` itself when its tip (radius `r_um`) clears the outline, else `p` moved along `edge`'s
/// outward normal until the tip touches that edge's line — the edge it met, however deep the
/// compliant probe point has pressed since. Just outside near a corner, away from the
/// nearest boundary point.
pub fn resting_tip(peg: &ConvexPolygon, p: Vec2, r_um: f64, edge: Option<usize>) -> Vec2 {
    if peg.signed_distance(&p) >= r_um {
        return p;
    }
    let e = match edge {
        Some(e) if e < peg.len() => e,
        _ => match contact_edge(peg, p, r_um) {
            Some(e) => e,
            None => return p,
        },
    };
    let n = peg.edge_normal(e);
    let d = n.dot(&(p - peg.edge(e).0));
    if d < r_um {
        let t = p + n * (r_um - d);
        if peg.signed_distance(&t) >= r_um - 1e-9 {
            return t;
        }
    }
    off_corner(peg, p, r_um)
}

/// `p` (outside `peg`, closer than `r_um`) moved away from the nearest boundary point to
/// distance `r_um`.
fn off_corner(peg: &ConvexPolygon, p: Vec2, r_um: f64) -> Vec2 {
    let nearest = (0..peg.len())
        .map(|i| {
            let (a, b) = peg.edge(i);
            let ab = b - a;
            let t = ((p - a).dot(&ab) / ab.dot(&ab).max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
            a + ab * t
        })
        .min_by(|a, b| (p - a).norm().total_cmp(&(p - b).norm()));
    match nearest {
        Some(q) if (p - q).norm() > 0.0 => q + (p - q) * (r_um / (p - q).norm()),
        _ => p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> ConvexPolygon {
        let v = [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)];
        ConvexPolygon::new(v.iter().map(|&(x, y)| Vec2::new(x, y)).collect()).unwrap()
    }

    #[test]
    fn a_needle_pressed_into_the_peg_rests_on_the_edge_it_met() {
        let peg = square();
        // clear of the peg: unchanged
        let p = Vec2::new(20.0, 0.0);
        assert_eq!(contact_edge(&peg, p, 5.0), None);
        assert_eq!(resting_tip(&peg, p, 5.0, None), p);
        // touching the right edge, then pressed deep into the peg near its top: it rests on
        // the right edge it met, not on the nearer top edge
        let right = contact_edge(&peg, Vec2::new(14.0, 8.0), 5.0);
        let t = resting_tip(&peg, Vec2::new(2.0, 8.0), 5.0, right);
        assert!((t - Vec2::new(15.0, 8.0)).norm() < 1e-9, "{t:?}");
        // no edge known: the nearest one
        let t = resting_tip(&peg, Vec2::new(6.0, 3.0), 5.0, None);
        assert!((t - Vec2::new(15.0, 3.0)).norm() < 1e-12, "{t:?}");
        // near a corner: clear of the peg, moved less than a radius
        let p = Vec2::new(11.0, 11.0);
        let t = resting_tip(&peg, p, 5.0, None);
        assert!(peg.signed_distance(&t) >= 5.0 - 1e-9 && (t - p).norm() < 5.0, "{t:?}");
    }
}
