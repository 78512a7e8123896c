//! The paper's linearised support friction cone: `n_d` force directions per support, in the
//! part's body frame (so a rotated scene gives a rotated answer). Kept for reproducing the
//! paper (`support_friction = "polygon"`); the default is the exact circular cone
//! ([`crate::coulomb`]), which the polygon approaches only as `n_d` grows (measured in
//! `docs/effects.md` → "Friction cones").

use super::formulate::{N_SUPPORTS, cone_directions};
use mesopush_core::geom::Vec2;

/// The three supports' direction sets.
#[derive(Debug, Clone)]
pub struct SupportCones {
    base: Vec<Vec2>,
    dirs: Vec<Vec2>,
}

impl SupportCones {
    /// `n` directions per support.
    pub fn new(n: usize) -> Self {
        let base = cone_directions(n);
        Self { dirs: vec![Vec2::zeros(); N_SUPPORTS * n], base }
    }

    /// The directions for a part at orientation `theta_rad`: every support's set turned with
    /// the part, support after support (`n` each), unit vectors in the fixture frame.
    pub fn in_body_frame(&mut self, theta_rad: f64) -> &[Vec2] {
        self.turned([theta_rad; N_SUPPORTS])
    }

    /// The directions with each support's set turned so its first direction points against
    /// that support's slip (the exact Coulomb force direction), or in the body frame where a
    /// support does not slip.
    pub fn against_slips(&mut self, theta_rad: f64, slips: &[Vec2; N_SUPPORTS]) -> &[Vec2] {
        let eps = 1e-12;
        let angles = slips.map(|v| if v.norm() > eps { (-v.y).atan2(-v.x) } else { theta_rad });
        self.turned(angles)
    }

    fn turned(&mut self, angles_rad: [f64; N_SUPPORTS]) -> &[Vec2] {
        let n = self.base.len();
        for (s, a) in angles_rad.iter().enumerate() {
            let (sin, cos) = a.sin_cos();
            for (d, b) in self.dirs[s * n..(s + 1) * n].iter_mut().zip(&self.base) {
                *d = Vec2::new(cos * b.x - sin * b.y, sin * b.x + cos * b.y);
            }
        }
        &self.dirs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_set_turns_with_the_part() {
        let mut c = SupportCones::new(8);
        let d = c.in_body_frame(0.3);
        assert_eq!(d.len(), 24);
        for s in 0..3 {
            for j in 0..8 {
                let want = 0.3 + std::f64::consts::TAU * j as f64 / 8.0;
                let a = d[s * 8 + j].y.atan2(d[s * 8 + j].x);
                let diff = (a - want).rem_euclid(std::f64::consts::TAU);
                assert!(!(1e-12..=std::f64::consts::TAU - 1e-12).contains(&diff), "{a} vs {want}");
            }
        }
    }
}
