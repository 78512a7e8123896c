//! The generator's world: a convex part on point supports with stated normal loads, the
//! support and pusher friction, and the disc pusher. Chosen here, not taken from the
//! project: the supports are not the project's default triangle, μ are not its defaults, and
//! a world may have more than three supports (statically indeterminate: the loads are
//! stated, then projected onto static balance).

use super::Error;
use crate::coulomb::{self, V2};
use serde_json::{Value, json};
use std::ops::{Add, Sub};

/// A support point of the part (body frame, origin at the centre of mass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Where, µm (body frame).
    pub at_um: [f64; 2],
    /// Normal load, part weights (the loads sum to 1).
    pub load: f64,
}

/// The world of one batch.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// A name for the record (`peg`, `square`, `pentagon`).
    pub name: String,
    /// Convex outline, counter-clockwise, body frame (its area centroid, the COM, at 0).
    pub outline_um: Vec<[f64; 2]>,
    /// Support points and their loads (balanced about the COM).
    pub supports: Vec<Support>,
    /// Part–plate friction coefficient (every support).
    pub mu_support: f64,
    /// Part–pusher friction coefficient.
    pub mu_pusher: f64,
    /// Disc pusher radius, µm (the paper's needle: 12.5).
    pub pusher_radius_um: f64,
}

/// The worlds this generator knows.
pub const WORLD_NAMES: [&str; 3] = ["peg", "square", "pentagon"];

fn rectangle(l: f64, w: f64) -> Vec<[f64; 2]> {
    let (a, b) = (l / 2.0, w / 2.0);
    vec![[-a, -b], [a, -b], [a, b], [-a, b]]
}

fn regular(n: usize, circumradius: f64) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::FRAC_PI_2 + std::f64::consts::TAU * k as f64 / n as f64;
            [circumradius * a.cos(), circumradius * a.sin()]
        })
        .collect()
}

impl World {
    /// A named world: `peg` (1600 × 1000 µm, three supports), `square` (1200 × 1200 µm,
    /// four supports, unequal stated loads), `pentagon` (circumradius 720 µm, three
    /// supports). μ support 0.35, μ pusher 0.5, the 25 µm needle.
    pub fn named(name: &str) -> Result<Self, Error> {
        let (outline, points, hint): (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<f64>) = match name {
            "peg" => (
                rectangle(1600.0, 1000.0),
                vec![[-560.0, -310.0], [-430.0, 340.0], [590.0, 40.0]],
                vec![1.0; 3],
            ),
            "square" => (
                rectangle(1200.0, 1200.0),
                vec![[-470.0, -430.0], [450.0, -460.0], [480.0, 420.0], [-440.0, 470.0]],
                vec![0.3, 0.2, 0.3, 0.2],
            ),
            "pentagon" => (
                regular(5, 720.0),
                vec![[-330.0, -300.0], [-250.0, 380.0], [450.0, -20.0]],
                vec![1.0; 3],
            ),
            other => {
                return Err(Error::invalid(
                    "world",
                    format!("{other:?} is not a world; known: {}", WORLD_NAMES.join(", ")),
                ));
            }
        };
        let loads = balanced_loads(&points, &hint)?;
        let supports =
            points.iter().zip(loads).map(|(&at_um, load)| Support { at_um, load }).collect();
        let w = Self {
            name: name.into(),
            outline_um: outline,
            supports,
            mu_support: 0.35,
            mu_pusher: 0.5,
            pusher_radius_um: 12.5,
        };
        w.validate()?;
        Ok(w)
    }

    /// Checks the outline (convex, counter-clockwise, COM at its centroid), the supports
    /// (inside, positive balanced loads), μ and the radius.
    pub fn validate(&self) -> Result<(), Error> {
        let o = &self.outline_um;
        let n = o.len();
        let convex = n >= 3
            && (0..n).all(|i| {
                let (a, b, c) = (v(o[i]), v(o[(i + 1) % n]), v(o[(i + 2) % n]));
                b.sub(a).cross(c.sub(b)) > 0.0
            });
        if !convex {
            return Err(Error::invalid("outline_um", "must be convex and counter-clockwise"));
        }
        for (i, s) in self.supports.iter().enumerate() {
            if s.load <= 0.0 || s.load.is_nan() || !inside(o, v(s.at_um)) {
                return Err(Error::invalid(
                    "supports",
                    format!(
                        "support {i} at {:?} load {}: must be inside, load > 0",
                        s.at_um, s.load
                    ),
                ));
            }
        }
        let (sum, moment) = self
            .supports
            .iter()
            .fold((0.0, V2::default()), |(s, m), p| (s + p.load, m.add(v(p.at_um).scale(p.load))));
        if (sum - 1.0).abs() > 1e-9 || moment.len() > 1e-6 {
            return Err(Error::invalid(
                "supports",
                format!("loads sum to {sum} with moment {moment:?} µm; need 1 and 0 (balance)"),
            ));
        }
        for (name, mu) in [("mu_support", self.mu_support), ("mu_pusher", self.mu_pusher)] {
            if !(0.0..=2.0).contains(&mu) {
                return Err(Error::invalid(name, format!("{mu} must be in [0, 2]")));
            }
        }
        if !(self.pusher_radius_um >= 0.0 && self.pusher_radius_um.is_finite()) {
            return Err(Error::invalid("pusher_radius_um", "must be finite and ≥ 0"));
        }
        Ok(())
    }

    /// The reference pusher's part (loads as stated, μ at every support).
    pub fn part(&self) -> coulomb::Part {
        coulomb::Part {
            outline: self.outline_um.iter().map(|&p| v(p)).collect(),
            supports: self.supports.iter().map(|s| v(s.at_um)).collect(),
            normal: self.supports.iter().map(|s| s.load).collect(),
            mu: vec![self.mu_support; self.supports.len()],
            speed_gain_per_um: 0.0,
        }
    }

    /// The disc pusher.
    pub fn pusher(&self) -> coulomb::Pusher {
        coulomb::Pusher { radius: self.pusher_radius_um, mu: self.mu_pusher }
    }

    /// Largest vertex radius, µm.
    pub fn reach_um(&self) -> f64 {
        self.outline_um.iter().map(|&p| v(p).len()).fold(0.0, f64::max)
    }

    /// The same world with every support moved by `d_um` (body frame), loads re-balanced.
    pub fn with_supports_moved(&self, d_um: [f64; 2]) -> Result<Self, Error> {
        let points: Vec<[f64; 2]> =
            self.supports.iter().map(|s| [s.at_um[0] + d_um[0], s.at_um[1] + d_um[1]]).collect();
        let hint: Vec<f64> = self.supports.iter().map(|s| s.load).collect();
        let loads = balanced_loads(&points, &hint)?;
        let mut w = self.clone();
        w.supports =
            points.iter().zip(loads).map(|(&at_um, load)| Support { at_um, load }).collect();
        w.validate()?;
        Ok(w)
    }

    /// The description written verbatim into trial.json's `world`.
    pub fn to_json(&self) -> Value {
        json!({
            "name": self.name,
            "outline_um": self.outline_um,
            "supports": self.supports.iter().map(|s| json!({"at_um": s.at_um, "load_weight": s.load})).collect::<Vec<_>>(),
            "mu_support": self.mu_support,
            "mu_pusher": self.mu_pusher,
            "pusher_radius_um": self.pusher_radius_um,
            "friction": "exact Coulomb at point supports (mesopush_tests::coulomb)",
        })
    }
}

fn v(p: [f64; 2]) -> V2 {
    V2::new(p[0], p[1])
}

fn inside(o: &[[f64; 2]], p: V2) -> bool {
    (0..o.len()).all(|i| v(o[(i + 1) % o.len()]).sub(v(o[i])).cross(p.sub(v(o[i]))) > 0.0)
}

/// The loads closest to `hint` (least squares) that sum to 1 with no moment about the COM
/// (`Σ Nᵢ = 1`, `Σ Nᵢ rᵢ = 0`); refused when any is not positive (the COM outside the
/// supports' hull, or a hint too far from balance).
pub fn balanced_loads(points: &[[f64; 2]], hint: &[f64]) -> Result<Vec<f64>, Error> {
    if points.len() < 3 || hint.len() != points.len() {
        return Err(Error::invalid("supports", "need ≥ 3 points, one load hint each"));
    }
    // Rows of A: [1], [x], [y]; N = h − Aᵀ (A Aᵀ)⁻¹ (A h − b), b = (1, 0, 0).
    let rows: [Vec<f64>; 3] = [
        vec![1.0; points.len()],
        points.iter().map(|p| p[0]).collect(),
        points.iter().map(|p| p[1]).collect(),
    ];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let g: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| dot(&rows[i], &rows[j])));
    let r = [dot(&rows[0], hint) - 1.0, dot(&rows[1], hint), dot(&rows[2], hint)];
    let lambda = solve3(g, r).ok_or_else(|| Error::invalid("supports", "points are collinear"))?;
    let loads: Vec<f64> = (0..points.len())
        .map(|k| hint[k] - (0..3).map(|i| rows[i][k] * lambda[i]).sum::<f64>())
        .collect();
    if let Some((i, n)) = loads.iter().enumerate().find(|(_, n)| **n <= 0.0) {
        return Err(Error::invalid(
            "supports",
            format!("support {i} would carry {n} weights; the COM must lie inside the supports"),
        ));
    }
    Ok(loads)
}

fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    if d.abs() < 1e-12 * m[1][1].max(1.0) * m[2][2].max(1.0) {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = b[i];
        }
        det(&mk) / d
    }))
}
