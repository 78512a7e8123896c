//! Where the needle's tip rests. The world's simulator treats the needle as compliant: a peg
//! that resists lets the probe point press into it, and a wedged peg stops it while the stage
//! goes on. The tip itself cannot be inside the peg: it stays where it met the outline and
//! the needle bends. [`resting_tip`] finds that point (used for the truth and the camera).

use crate::geom::{ConvexPolygon, Vec2};

/// Where a needle whose undeflected centre is `p` rests against `peg` (a convex outline):
/// `p` itself when its tip (radius `r_um`) clears the outline, else `p` drawn back along
/// `back` (a unit vector: against the push) until the tip touches it — the point where it
/// met the peg. Without a direction (`back` zero), `p` is pushed out along the nearest
/// edge's normal.
pub fn resting_tip(peg: &ConvexPolygon, p: Vec2, r_um: f64, back: Vec2) -> Vec2 {
    if peg.signed_distance(&p) >= r_um {
        return p;
    }
    if back.norm() < 0.5 {
        return pushed_out(peg, p, r_um);
    }
    // {x : distance(x) < r} is convex: along the ray it is one interval from p; bisect its end
    let span = peg.vertices().iter().map(|v| (v - p).norm()).fold(0.0, f64::max) + r_um;
    let (mut lo, mut hi) = (0.0, span);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if peg.signed_distance(&(p + back * mid)) >= r_um {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    p + back * hi
}

/// `p` pushed out of `peg` until its distance is `r_um`: along the nearest edge's normal
/// from inside, away from the nearest boundary point from outside.
fn pushed_out(peg: &ConvexPolygon, p: Vec2, r_um: f64) -> Vec2 {
    let n = peg.len();
    let Some((i, depth)) = (0..n)
        .map(|i| (i, peg.edge_normal(i).dot(&(p - peg.edge(i).0))))
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return p;
    };
    if depth <= 0.0 {
        return p + peg.edge_normal(i) * (r_um - depth);
    }
    let nearest = (0..n)
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
    fn a_needle_pressed_into_the_peg_rests_where_it_met_the_outline() {
        let peg = square();
        let none = Vec2::new(0.0, 0.0);
        // clear of the peg: unchanged
        let p = Vec2::new(20.0, 0.0);
        assert_eq!(resting_tip(&peg, p, 5.0, Vec2::new(1.0, 0.0)), p);
        // pushed leftwards deep into the peg near its top: back along the push to the right
        // edge it came through, not out of the nearer top edge
        let t = resting_tip(&peg, Vec2::new(2.0, 8.0), 5.0, Vec2::new(1.0, 0.0));
        assert!((t - Vec2::new(15.0, 8.0)).norm() < 1e-9, "{t:?}");
        // no direction known: out along the nearest edge's normal
        let t = resting_tip(&peg, Vec2::new(6.0, 3.0), 5.0, none);
        assert!((t - Vec2::new(15.0, 3.0)).norm() < 1e-12, "{t:?}");
        let t = resting_tip(&peg, Vec2::new(11.0, 11.0), 5.0, none);
        assert!((peg.signed_distance(&t) - 5.0).abs() < 1e-9, "{t:?}");
    }
}
