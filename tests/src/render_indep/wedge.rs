//! The probe needle as a wedge: two straight flanks tangent to a round tip, opening by the
//! taper half-angle towards where the needle enters the field. Its inside test works with a
//! bound on the distance (exact for the tip disc, a lower bound outside the flanks), which the
//! rasteriser uses to skip pixels far from the outline, and which finds the contact with the
//! peg by bisection.

use super::pt::Pt;

/// The needle's shape and where its tip is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wedge {
    /// Centre of the round tip, µm.
    pub tip: Pt,
    /// Unit vector from the tip along the shaft (towards where the needle enters).
    pub shaft: Pt,
    /// Radius of the round tip, µm.
    pub tip_radius_um: f64,
    /// Half-angle between the flanks, rad.
    pub half_angle_rad: f64,
}

impl Wedge {
    /// A bound on the signed distance from `p` to the needle, µm: negative inside, and when
    /// positive at most the true distance (so `> m` means "further than `m`").
    pub fn distance_bound(&self, p: Pt) -> f64 {
        let d = p - self.tip;
        let r = self.tip_radius_um;
        let disc = d.norm() - r;
        let (sin, cos) = self.half_angle_rad.sin_cos();
        let lat = self.shaft.perp();
        // outward normals of the flanks, tangent to the disc where along = −r sin
        let n_left = lat * cos - self.shaft * sin;
        let n_right = lat * (-cos) - self.shaft * sin;
        let flanks =
            (d.dot(n_left) - r).max(d.dot(n_right) - r).max(-(d.dot(self.shaft) + r * sin));
        disc.min(flanks)
    }

    /// Whether `p` is inside the needle.
    pub fn contains(&self, p: Pt) -> bool {
        self.distance_bound(p) < 0.0
    }

    /// The same needle with its tip moved by `t` µm along the shaft (positive: withdrawn).
    pub fn withdrawn(&self, t: f64) -> Wedge {
        Wedge { tip: self.tip + self.shaft * t, ..*self }
    }
}

/// The tip position along `shaft` from `start` at which the needle, withdrawn from deep
/// contact, just touches the closed `outline` (world µm): `start + shaft · t` for the least `t`
/// in `[t_in, t_out]` with no outline point inside the needle. `t_out` must be free of contact.
pub fn touching_at(needle: &Wedge, outline: &[Pt], t_in: f64, t_out: f64) -> f64 {
    let reach = needle.tip_radius_um + t_out.abs() + t_in.abs() + 300.0;
    let near: Vec<Pt> =
        outline.iter().copied().filter(|p| (*p - needle.tip).norm() < reach).collect();
    let hits = |t: f64| {
        let w = needle.withdrawn(t);
        near.iter().any(|&p| w.contains(p))
    };
    let (mut lo, mut hi) = (t_in, t_out);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if hits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tip_disc_and_the_flanks() {
        let w = Wedge {
            tip: Pt::new(0.0, 0.0),
            shaft: Pt::new(1.0, 0.0),
            tip_radius_um: 10.0,
            half_angle_rad: 0.05,
        };
        assert!(w.contains(Pt::new(-9.9, 0.0)) && !w.contains(Pt::new(-10.1, 0.0)));
        // 1000 µm up the shaft the half-width is about 10 + 1000 tan(0.05)
        let half = 10.0 / 0.05f64.cos() + 1000.0 * 0.05f64.tan();
        assert!(w.contains(Pt::new(1000.0, half - 0.1)));
        assert!(!w.contains(Pt::new(1000.0, half + 0.1)));
        assert!((w.distance_bound(Pt::new(0.0, 30.0)) - 20.0).abs() < 0.5);
    }

    #[test]
    fn contact_with_a_straight_edge_head_on() {
        // edge x = 0 (points from y = −100 to 100), needle coming from +x along −x
        let outline: Vec<Pt> = (-100..=100).map(|y| Pt::new(0.0, f64::from(y))).collect();
        let w = Wedge {
            tip: Pt::new(0.0, 0.0),
            shaft: Pt::new(1.0, 0.0),
            tip_radius_um: 10.0,
            half_angle_rad: 0.03,
        };
        let t = touching_at(&w, &outline, -5.0, 40.0);
        assert!((t - 10.0).abs() < 1e-6, "{t}");
    }
}
