//! A plain 2-D point/vector for the independent microscope (its own type: no geometry code of
//! the project is used to make the frames the tracker is tested on).

use std::ops::{Add, Mul, Sub};

/// A point or vector, µm or px as the caller says.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pt {
    /// x (right).
    pub x: f64,
    /// y (down).
    pub y: f64,
}

impl Pt {
    /// `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Dot product.
    pub fn dot(self, o: Pt) -> f64 {
        self.x * o.x + self.y * o.y
    }

    /// Length.
    pub fn norm(self) -> f64 {
        self.dot(self).sqrt()
    }

    /// Turned a quarter turn (x towards y).
    pub fn perp(self) -> Pt {
        Pt::new(-self.y, self.x)
    }

    /// Turned by `a` rad (x towards y).
    pub fn rotated(self, a: f64) -> Pt {
        let (s, c) = a.sin_cos();
        Pt::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl Add for Pt {
    type Output = Pt;
    fn add(self, o: Pt) -> Pt {
        Pt::new(self.x + o.x, self.y + o.y)
    }
}

impl Sub for Pt {
    type Output = Pt;
    fn sub(self, o: Pt) -> Pt {
        Pt::new(self.x - o.x, self.y - o.y)
    }
}

impl Mul<f64> for Pt {
    type Output = Pt;
    fn mul(self, k: f64) -> Pt {
        Pt::new(self.x * k, self.y * k)
    }
}
