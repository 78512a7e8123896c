//! Exact Coulomb friction at the supports: the circular cone, solved by Newton's method.
//!
//! A support sliding with velocity `v` feels `F = −μN·v/|v|`, whatever direction `v` has.
//! The paper linearises the circle by `n_d` force directions, one complementarity pair each;
//! fixed in the world frame that makes the motion depend on how the world is drawn, and
//! turning the directions after the slip is not a cure: the slip of a support near the
//! part's centre of rotation swings faster than its force direction (measured slopes above
//! 2), so turning the cone after it diverges, within a step or from one step to the next
//! (`docs/effects.md` → "Friction cones").
//!
//! Instead the support forces stay nonlinear and the step is solved by Newton's method on
//! them: at the current guess `u` of the part's motion (dx, dy, L·dθ) the supports'
//! generalised force `g(u) = Σ Jᵢᵀ Fᵢ(Jᵢ u)` is replaced by its tangent
//! `g(u) + ∂g/∂u (u' − u)`, which enters the step's mixed LCP as a linear (damping-like) term
//! in the balance rows; only the planar contacts (probe, walls) keep complementarity rows.
//! The LCP's answer is the next guess, until the motion stops changing. The slip speed is
//! regularised, `|v| → √(|v|² + ε²)`, with ε a tiny fraction of the step, so a support that
//! barely moves (a pivot) creeps at most ε per step instead of making the tangent infinite.
//! The cone is the circle: nothing depends on the orientation of the world.

use super::formulate::N_SUPPORTS;
use mesopush_core::geom::Vec2;

/// The supports' generalised friction force, linearised at a guess of the motion: the
/// balance rows get `h · u'` and `−rhs` (see `formulate`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Linearised {
    /// `−∂g/∂u`, symmetric positive semi-definite, part weights per µm.
    pub h: [[f64; 3]; 3],
    /// `g(u) + h·u`, part weights.
    pub rhs: [f64; 3],
}

/// The supports, as one step sees them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Supports {
    /// Support points relative to the centre of mass, fixture frame, µm.
    pub r_um: [Vec2; N_SUPPORTS],
    /// Normal force at each support, part weights.
    pub normal: [f64; N_SUPPORTS],
    /// Friction coefficient at each support.
    pub mu: [f64; N_SUPPORTS],
    /// The part's characteristic length L (scales the rotation column), µm.
    pub char_len_um: f64,
    /// Slip regularisation ε, µm per step.
    pub eps_um: f64,
}

impl Supports {
    /// Support `s`'s displacement for the motion `u = (dx, dy, L·dθ)`.
    pub fn slip(&self, s: usize, u: &[f64; 3]) -> Vec2 {
        let r = self.r_um[s] / self.char_len_um;
        Vec2::new(u[0] - r.y * u[2], u[1] + r.x * u[2])
    }

    /// The generalised friction force at `u` and its tangent.
    pub fn linearise(&self, u: &[f64; 3]) -> Linearised {
        let mut out = Linearised::default();
        let mut g = [0.0; 3];
        for s in 0..N_SUPPORTS {
            let r = self.r_um[s] / self.char_len_um;
            let jac = [[1.0, 0.0, -r.y], [0.0, 1.0, r.x]];
            let v = self.slip(s, u);
            let speed = (v.norm_squared() + self.eps_um * self.eps_um).sqrt();
            let k = self.mu[s] * self.normal[s] / speed;
            let f = -v * k;
            // −∂F/∂v = k (I − v vᵀ / speed²): positive semi-definite.
            let vv = [v.x, v.y];
            let d = |a: usize, b: usize| {
                k * (f64::from(u8::from(a == b)) - vv[a] * vv[b] / (speed * speed))
            };
            for a in 0..3 {
                g[a] += jac[0][a] * f.x + jac[1][a] * f.y;
                for b in 0..3 {
                    let mut h = 0.0;
                    for i in 0..2 {
                        for j in 0..2 {
                            h += jac[i][a] * d(i, j) * jac[j][b];
                        }
                    }
                    out.h[a][b] += h;
                }
            }
        }
        for (a, (rhs, row)) in out.rhs.iter_mut().zip(&out.h).enumerate() {
            *rhs = g[a] + row.iter().zip(u).map(|(h, x)| h * x).sum::<f64>();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn supports() -> Supports {
        Supports {
            r_um: [Vec2::new(-300.0, -200.0), Vec2::new(-300.0, 200.0), Vec2::new(300.0, 0.0)],
            normal: [0.25, 0.25, 0.5],
            mu: [0.3; 3],
            char_len_um: 900.0,
            eps_um: 1e-6,
        }
    }

    /// The generalised force g(u) = rhs − h·u.
    fn force(s: &Supports, u: &[f64; 3]) -> [f64; 3] {
        let l = s.linearise(u);
        std::array::from_fn(|a| l.rhs[a] - l.h[a].iter().zip(u).map(|(h, x)| h * x).sum::<f64>())
    }

    #[test]
    fn a_translation_is_resisted_by_mu_times_the_weight_against_it() {
        let s = supports();
        let l = s.linearise(&[3.0, 4.0, 0.0]);
        let g: Vec<f64> = (0..3)
            .map(|a| l.rhs[a] - (0..3).map(|b| l.h[a][b] * [3.0, 4.0, 0.0][b]).sum::<f64>())
            .collect();
        assert!((g[0] + 0.3 * 0.6).abs() < 1e-9 && (g[1] + 0.3 * 0.8).abs() < 1e-9, "{g:?}");
        assert!(g[2].abs() < 1e-9, "no moment about the COM: {g:?}");
    }

    #[test]
    fn the_tangent_matches_finite_differences() {
        let s = supports();
        let u = [1.0, -2.0, 0.7];
        let l = s.linearise(&u);
        let g = |u: &[f64; 3]| force(&s, u);
        for b in 0..3 {
            let mut up = u;
            up[b] += 1e-6;
            let (g1, g0) = (g(&up), g(&u));
            for a in 0..3 {
                let fd = -(g1[a] - g0[a]) / 1e-6;
                assert!((fd - l.h[a][b]).abs() < 1e-5, "h[{a}][{b}] {} vs {fd}", l.h[a][b]);
            }
        }
    }
}
