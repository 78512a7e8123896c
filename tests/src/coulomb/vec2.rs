//! The reference's own plane vector (no mesopush geometry), so the pusher shares no types
//! with the project.

/// A plane vector.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct V2 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
}

impl V2 {
    /// (x, y).
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }
    /// Scaled by `k`.
    pub fn scale(self, k: f64) -> V2 {
        V2::new(self.x * k, self.y * k)
    }
    /// Dot product.
    pub fn dot(self, o: V2) -> f64 {
        self.x * o.x + self.y * o.y
    }
    /// z of the cross product.
    pub fn cross(self, o: V2) -> f64 {
        self.x * o.y - self.y * o.x
    }
    /// Length.
    pub fn len(self) -> f64 {
        self.x.hypot(self.y)
    }
    /// Rotated by `a` rad.
    pub fn rot(self, a: f64) -> V2 {
        let (s, c) = a.sin_cos();
        V2::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl std::ops::Add for V2 {
    type Output = V2;
    fn add(self, o: V2) -> V2 {
        V2::new(self.x + o.x, self.y + o.y)
    }
}

impl std::ops::Sub for V2 {
    type Output = V2;
    fn sub(self, o: V2) -> V2 {
        V2::new(self.x - o.x, self.y - o.y)
    }
}
