//! The pusher: one or more round discs rigidly attached to the stage. The paper's probe is
//! one 12.5 µm disc at the stage's reference point; a two-finger hand is two discs either
//! side of it. The discs are given in the pusher's own frame (µm), whose origin is the
//! reference point a recorded or planned path moves and whose x axis turns with the pusher's
//! angle θ (rad, from the world's x axis towards +y).

use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use serde::{Deserialize, Serialize};

/// Most discs a pusher may have (each is one contact of every step's LCP).
pub const MAX_DISCS: usize = 8;

/// One round disc of a pusher.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disc {
    /// Centre in the pusher's frame, µm.
    pub center_um: [f64; 2],
    /// Radius, µm (0 allowed: a point).
    pub radius_um: f64,
}

/// A rigid set of discs (see the module header for the frame).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pusher {
    /// The discs, in the pusher's frame; 1 to [`MAX_DISCS`].
    pub discs: Vec<Disc>,
}

impl Pusher {
    /// The paper's probe: one disc of `radius_um` at the reference point.
    pub fn single(radius_um: f64) -> Self {
        Self { discs: vec![Disc { center_um: [0.0, 0.0], radius_um }] }
    }

    /// Two discs of `radius_um` at ±`spacing_um`/2 along the pusher's y axis (a two-finger
    /// hand whose reference point is midway between the fingers and which pushes along +x).
    pub fn two_finger(radius_um: f64, spacing_um: f64) -> Self {
        let h = spacing_um / 2.0;
        Self {
            discs: vec![
                Disc { center_um: [0.0, -h], radius_um },
                Disc { center_um: [0.0, h], radius_um },
            ],
        }
    }

    /// Checks the disc count, that every number is finite and every radius ≥ 0, and that no
    /// two discs overlap (one contact per disc must stay a contact of one body).
    pub fn validate(&self) -> Result<(), Error> {
        let n = self.discs.len();
        if !(1..=MAX_DISCS).contains(&n) {
            return Err(Error::invalid(
                "pusher",
                format!("discs has {n} entries; a pusher has 1 to {MAX_DISCS} discs"),
            ));
        }
        for (i, d) in self.discs.iter().enumerate() {
            let [x, y] = d.center_um;
            if !(x.is_finite() && y.is_finite()) {
                return Err(Error::invalid(
                    "pusher",
                    format!("discs[{i}].center_um = [{x}, {y}] must be finite"),
                ));
            }
            let r = d.radius_um;
            if !(r.is_finite() && r >= 0.0) {
                return Err(Error::invalid(
                    "pusher",
                    format!("discs[{i}].radius_um = {r} must be finite and ≥ 0"),
                ));
            }
        }
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (&self.discs[i], &self.discs[j]);
                let dist =
                    (Vec2::new(a.center_um[0] - b.center_um[0], a.center_um[1] - b.center_um[1]))
                        .norm();
                if dist < a.radius_um + b.radius_um {
                    return Err(Error::invalid(
                        "pusher",
                        format!(
                            "discs[{i}] and discs[{j}] overlap (centres {dist} µm apart, radii \
                             {} + {} µm); give non-overlapping discs",
                            a.radius_um, b.radius_um
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Each disc's centre in the world when the pusher's reference point is at `pose`
    /// (position µm, angle rad), with its radius.
    pub fn discs_at(&self, pose: &Pose) -> impl Iterator<Item = (Vec2, f64)> + '_ {
        let pose = *pose;
        self.discs.iter().map(move |d| {
            (pose.transform_point(&Vec2::new(d.center_um[0], d.center_um[1])), d.radius_um)
        })
    }

    /// The largest disc radius, µm.
    pub fn max_radius_um(&self) -> f64 {
        self.discs.iter().map(|d| d.radius_um).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_fingers_turn_with_the_pusher() {
        let p = Pusher::two_finger(2500.0, 18_000.0);
        p.validate().unwrap();
        let at: Vec<_> = p.discs_at(&Pose::new(100.0, 0.0, std::f64::consts::FRAC_PI_2)).collect();
        assert!((at[0].0 - Vec2::new(9100.0, 0.0)).norm() < 1e-9, "{:?}", at[0]);
        assert!((at[1].0 - Vec2::new(-8900.0, 0.0)).norm() < 1e-9, "{:?}", at[1]);
    }

    #[test]
    fn bad_pushers_are_named() {
        let none = Pusher { discs: vec![] };
        assert!(none.validate().unwrap_err().to_string().contains("1 to 8 discs"));
        let neg = Pusher::single(-1.0);
        assert!(neg.validate().unwrap_err().to_string().contains("discs[0].radius_um = -1"));
        let overlap = Pusher::two_finger(2500.0, 4000.0);
        assert!(overlap.validate().unwrap_err().to_string().contains("overlap"));
    }
}
