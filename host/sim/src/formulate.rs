//! Builds one time step's mixed LCP: the paper's Eq. 7–8 with the known support normal
//! forces moved into `b`.
//!
//! Unknowns, in order: Δq = (dx, dy, L·dθ) (3 free; L the part's characteristic length so all
//! columns have the same scale) | λ_n (one per planar contact) | λ_f (±tangent per planar
//! contact, then `n_d` directions per support) | σ (one per planar contact, then one per
//! support). Rows: force/moment balance (3 equalities), then the complementarity rows
//! ρ_n = Wₙᵀ Δq + ψ − n·δu ⊥ λ_n, ρ_f = W_fᵀ Δq + Eσ − t·δu ⊥ λ_f and
//! s = U λ_n − Eᵀ λ_f (+ μ_k λ_nk for supports) ⊥ σ. Forces are in units of the part's
//! weight; lengths in µm.
//!
//! One addition to the paper: with a linearised (polygonal) friction cone the quasi-static
//! motion is not unique whenever support forces sit at cone vertices (a symmetric push through
//! the COM admits a whole family of rotations about the probe, and a pivoting solver returns
//! an arbitrary extreme one). A small viscous term εCΔq in the balance rows (ε ≪ μ per µm)
//! makes the motion unique and symmetric problems give symmetric answers.

use super::contact::{Contact, ContactKind};
use super::coulomb::Linearised;
use mesopush_core::geom::{Vec2, cross};

/// Index layout of a step problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Planar contacts (probe and walls).
    pub n_contacts: usize,
    /// Friction directions per support.
    pub n_directions: usize,
}

/// Number of support points (three-point support).
pub const N_SUPPORTS: usize = 3;
/// Number of free variables (planar rigid body).
pub const N_FREE: usize = 3;

impl Layout {
    /// Total number of unknowns. With `n_directions = 0` the supports have no
    /// complementarity variables (their friction is in the balance rows, [`crate::coulomb`]).
    pub const fn n(&self) -> usize {
        let supports = if self.n_directions > 0 { N_SUPPORTS * (self.n_directions + 1) } else { 0 };
        N_FREE + 4 * self.n_contacts + supports
    }
    /// Index of contact `i`'s normal force.
    pub const fn normal(&self, i: usize) -> usize {
        N_FREE + i
    }
    /// Index of contact `i`'s friction force along +t (`k = 0`) or −t (`k = 1`).
    pub const fn planar_friction(&self, i: usize, k: usize) -> usize {
        N_FREE + self.n_contacts + 2 * i + k
    }
    /// Index of support `s`'s friction force along direction `j`.
    pub const fn support_friction(&self, s: usize, j: usize) -> usize {
        N_FREE + 3 * self.n_contacts + s * self.n_directions + j
    }
    /// Index of contact `i`'s sliding multiplier σ.
    pub const fn planar_sigma(&self, i: usize) -> usize {
        N_FREE + 3 * self.n_contacts + N_SUPPORTS * self.n_directions + i
    }
    /// Index of support `s`'s sliding multiplier σ.
    pub const fn support_sigma(&self, s: usize) -> usize {
        self.planar_sigma(self.n_contacts) + s
    }
}

/// Everything a step needs besides the contacts.
#[derive(Debug, Clone, Copy)]
pub struct StepInputs<'a> {
    /// Planar contacts with their friction coefficients.
    pub contacts: &'a [(Contact, f64)],
    /// Centre of mass, fixture frame, µm.
    pub com: Vec2,
    /// Characteristic length L scaling rotations, µm.
    pub char_len_um: f64,
    /// The pusher's rigid motion over the step.
    pub pusher: PusherMotion,
    /// Support points relative to the COM, rotated into the fixture frame, µm.
    pub supports: [Vec2; N_SUPPORTS],
    /// Known support normal forces (weights).
    pub support_forces: [f64; N_SUPPORTS],
    /// Surface friction coefficient at each support.
    pub mu_surface: [f64; N_SUPPORTS],
    /// Unit friction directions of the linearised cones, support after support (the same
    /// number for each; see [`crate::cone`]).
    pub directions: &'a [Vec2],
    /// Viscous regularisation of the support friction, part weights per µm of support
    /// displacement (see [`crate::SimSettings::support_viscosity`]).
    pub viscosity: f64,
    /// Probe compliance along its contact normal, µm per part weight.
    pub probe_compliance_um: f64,
    /// The supports' exact Coulomb friction linearised at a guess of the motion; when given,
    /// `directions` is empty and the supports get no complementarity rows.
    pub coulomb: Option<Linearised>,
}

/// A pusher's rigid motion over one step: its reference point `origin_um` moves by `d_um`
/// and the pusher turns by `d_theta_rad` about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PusherMotion {
    /// The reference point at the step's start, fixture frame, µm.
    pub origin_um: Vec2,
    /// Its displacement, µm.
    pub d_um: Vec2,
    /// The turn, rad.
    pub d_theta_rad: f64,
}

impl PusherMotion {
    /// A translation by `d_um` (the paper's probe).
    pub fn translation(d_um: Vec2) -> Self {
        Self { origin_um: Vec2::zeros(), d_um, d_theta_rad: 0.0 }
    }

    /// Displacement of the pusher's material point at `p` (first order in the turn), µm.
    pub fn at(&self, p: &Vec2) -> Vec2 {
        if self.d_theta_rad == 0.0 {
            return self.d_um;
        }
        let r = p - self.origin_um;
        self.d_um + Vec2::new(-r.y, r.x) * self.d_theta_rad
    }
}

/// Wrench (fx, fy, τ/L) of a unit force `f` applied at `r` from the COM.
fn wrench(r: &Vec2, f: &Vec2, char_len: f64) -> [f64; 3] {
    [f.x, f.y, cross(r, f) / char_len]
}

/// Reusable dense buffers for the step problem (row-major `m`, `q`).
#[derive(Debug, Clone, Default)]
pub struct StepProblem {
    /// Layout of the last built problem.
    pub layout: Option<Layout>,
    /// Row-major n × n matrix.
    pub m: Vec<f64>,
    /// Constant vector.
    pub q: Vec<f64>,
}

impl StepProblem {
    /// Fills the buffers for `inp`; reuses their capacity.
    pub fn build(&mut self, inp: &StepInputs<'_>) -> Layout {
        debug_assert!(inp.directions.len().is_multiple_of(N_SUPPORTS), "one set per support");
        let n_directions = inp.directions.len() / N_SUPPORTS;
        let lay = Layout { n_contacts: inp.contacts.len(), n_directions };
        let n = lay.n();
        self.m.clear();
        self.m.resize(n * n, 0.0);
        self.q.clear();
        self.q.resize(n, 0.0);
        let m = &mut self.m;
        // Row `col` gets the wrenchᵀ (contact displacement); the equality rows, written as
        // 0 = εCΔq − Σ W λ, get −wrench in column `col` (monotone structure for the solver).
        let couple = |m: &mut Vec<f64>, col: usize, w: [f64; 3]| {
            for (k, wk) in w.iter().enumerate() {
                m[k * n + col] = -*wk;
                m[col * n + k] = *wk;
            }
        };
        // εC = ε Σ_k λ_nk J_kᵀ J_k, J_k maps Δq to support k's displacement.
        for s in 0..N_SUPPORTS {
            let r = inp.supports[s];
            let l = inp.char_len_um;
            let jac = [[1.0, 0.0, -r.y / l], [0.0, 1.0, r.x / l]];
            for a in 0..N_FREE {
                for b in 0..N_FREE {
                    let jtj = jac[0][a] * jac[0][b] + jac[1][a] * jac[1][b];
                    m[a * n + b] += inp.viscosity * inp.support_forces[s] * jtj;
                }
            }
        }
        if let Some(l) = &inp.coulomb {
            for a in 0..N_FREE {
                for b in 0..N_FREE {
                    m[a * n + b] += l.h[a][b];
                }
                self.q[a] = -l.rhs[a];
            }
        }
        for (i, (c, mu)) in inp.contacts.iter().enumerate() {
            let r = c.point - inp.com;
            let t = Vec2::new(-c.normal.y, c.normal.x);
            let is_probe = matches!(c.kind, ContactKind::Probe(_));
            let du = if is_probe { inp.pusher.at(&c.point) } else { Vec2::zeros() };
            couple(m, lay.normal(i), wrench(&r, &c.normal, inp.char_len_um));
            self.q[lay.normal(i)] = c.gap_um - c.normal.dot(&du);
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                let row = lay.planar_friction(i, k);
                couple(m, row, wrench(&r, &(t * sign), inp.char_len_um));
                m[row * n + lay.planar_sigma(i)] = 1.0;
                m[lay.planar_sigma(i) * n + row] = -1.0;
                self.q[row] = -sign * t.dot(&du);
            }
            m[lay.planar_sigma(i) * n + lay.normal(i)] = *mu;
            if is_probe {
                m[lay.normal(i) * n + lay.normal(i)] = inp.probe_compliance_um;
            }
        }
        for s in (0..N_SUPPORTS).filter(|_| n_directions > 0) {
            let set = &inp.directions[s * n_directions..(s + 1) * n_directions];
            for (j, d) in set.iter().enumerate() {
                let row = lay.support_friction(s, j);
                couple(m, row, wrench(&inp.supports[s], d, inp.char_len_um));
                m[row * n + lay.support_sigma(s)] = 1.0;
                m[lay.support_sigma(s) * n + row] = -1.0;
            }
            self.q[lay.support_sigma(s)] = inp.mu_surface[s] * inp.support_forces[s];
        }
        self.layout = Some(lay);
        lay
    }
}

/// `n` unit directions evenly spaced on the circle (the linearised friction cone).
pub fn cone_directions(n: usize) -> Vec<Vec2> {
    (0..n)
        .map(|j| {
            let a = std::f64::consts::TAU * j as f64 / n as f64;
            Vec2::new(a.cos(), a.sin())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_matches_the_papers_31_variable_problem() {
        let lay = Layout { n_contacts: 1, n_directions: 8 };
        assert_eq!(lay.n(), 3 + 31);
        assert_eq!(lay.support_sigma(2), lay.n() - 1);
        assert_eq!(lay.planar_sigma(0), 3 + 1 + 2 + 24);
    }

    #[test]
    fn equality_block_is_the_transpose_of_the_gap_rows() {
        let contact = Contact {
            kind: ContactKind::Probe(0),
            point: Vec2::new(-500.0, 100.0),
            normal: Vec2::new(1.0, 0.0),
            gap_um: 2.0,
        };
        let dirs: Vec<Vec2> = (0..N_SUPPORTS).flat_map(|_| cone_directions(8)).collect();
        let inp = StepInputs {
            contacts: &[(contact, 0.8)],
            com: Vec2::zeros(),
            char_len_um: 1000.0,
            pusher: PusherMotion::translation(Vec2::new(5.0, 0.0)),
            supports: [Vec2::new(-100.0, -100.0), Vec2::new(-100.0, 100.0), Vec2::new(200.0, 0.0)],
            support_forces: [0.25, 0.25, 0.5],
            mu_surface: [0.3; 3],
            directions: &dirs,
            viscosity: 0.0,
            probe_compliance_um: 0.0,
            coulomb: None,
        };
        let mut p = StepProblem::default();
        let lay = p.build(&inp);
        let n = lay.n();
        for col in N_FREE..n {
            for k in 0..N_FREE {
                assert_eq!(-p.m[k * n + col], p.m[col * n + k]);
            }
        }
        // Probe moving +x into a +x normal closes the 2 µm gap by 5 µm.
        assert!((p.q[lay.normal(0)] - (2.0 - 5.0)).abs() < 1e-12);
        // Torque of a +x push at y = 100 about the COM: r × f = -100 (scaled by 1/L).
        assert!((p.m[lay.normal(0) * n + 2] - (-0.1)).abs() < 1e-12);
        assert!((p.q[lay.support_sigma(2)] - 0.15).abs() < 1e-12);
    }
}
