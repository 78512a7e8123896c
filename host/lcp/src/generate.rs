//! Seeded generator of the simulator's step problems (paper Eq. 7–8), for tests and benches.
//!
//! A rectangular peg (1615 × 985 µm, COM at its centre) rests on three random support points
//! that span the COM (normal forces from statics, all positive, weight normalised to 1); a probe
//! touches a random boundary point and moves inward by a random step; optional fixture contacts
//! touch other boundary points. The layout is the simulator's:
//! `z = [Δq (dx µm, dy µm, L·dθ µm) | λ_n | λ_f | σ]`, `L` = the peg's half-diagonal, so all
//! entries of `M` are O(1); forces are in units of the peg's weight.

use rand::{Rng, RngExt};

use super::MlcpProblem;

/// Peg size (µm).
pub const PEG_W_UM: f64 = 1615.0;
/// Peg height (µm).
pub const PEG_H_UM: f64 = 985.0;

/// A planar contact (probe or fixture) on the peg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarContact {
    /// Contact point relative to the COM (µm).
    pub point_um: [f64; 2],
    /// Unit normal pointing into the peg (direction of the force on the peg).
    pub normal: [f64; 2],
    /// Friction coefficient.
    pub mu: f64,
    /// `ψ + hψ̇` (µm): the gap at the end of the step if the peg does not move.
    pub gap_um: f64,
    /// Tangential displacement of the other body along `t = (−n_y, n_x)` during the step (µm).
    pub drive_um: f64,
}

/// A support point with its known normal force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Point relative to the COM (µm).
    pub point_um: [f64; 2],
    /// Normal force (units of the peg's weight), `> 0`.
    pub normal_force: f64,
    /// Surface friction coefficient.
    pub mu: f64,
}

/// An assembled step problem, owning its data.
#[derive(Debug, Clone, PartialEq)]
pub struct StepLcp {
    /// Free variables (always 3).
    pub n_free: usize,
    /// Total size.
    pub n: usize,
    /// `M`, row-major.
    pub m: Vec<f64>,
    /// `q`.
    pub q: Vec<f64>,
}

impl StepLcp {
    /// The solver's view.
    pub fn problem(&self) -> MlcpProblem<'_> {
        MlcpProblem { n_free: self.n_free, n: self.n, m: &self.m, q: &self.q }
    }
}

/// The wrench `(f_x, f_y, (r × f)/L)` of a unit force `f` at `r`.
fn wrench(r: [f64; 2], f: [f64; 2], length_um: f64) -> [f64; 3] {
    [f[0], f[1], (r[0] * f[1] - r[1] * f[0]) / length_um]
}

/// Assembles Eq. 7–8 for the given contacts (`n_dirs` friction directions per support).
pub fn assemble(contacts: &[PlanarContact], supports: &[Support], n_dirs: usize) -> StepLcp {
    let length_um = 0.5 * PEG_W_UM.hypot(PEG_H_UM);
    let (nc, ns) = (contacts.len(), supports.len());
    let nf_dirs = 2 * nc + n_dirs * ns;
    let (o_n, o_f) = (3, 3 + nc);
    let o_s = o_f + nf_dirs;
    let n = o_s + nc + ns;
    let mut m = vec![0.0; n * n];
    let mut q = vec![0.0; n];
    // Couples column `col` (a force with wrench `wr`) to the equalities, symmetrically.
    let couple = |m: &mut [f64], col: usize, wr: [f64; 3]| {
        for (k, v) in wr.iter().enumerate() {
            m[k * n + col] = *v;
            m[col * n + k] = *v;
        }
    };
    for (c, ct) in contacts.iter().enumerate() {
        let t = [-ct.normal[1], ct.normal[0]];
        couple(&mut m, o_n + c, wrench(ct.point_um, ct.normal, length_um));
        q[o_n + c] = ct.gap_um;
        for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
            let col = o_f + 2 * c + k;
            couple(&mut m, col, wrench(ct.point_um, [sign * t[0], sign * t[1]], length_um));
            m[col * n + o_s + c] = 1.0;
            m[(o_s + c) * n + col] = -1.0;
            q[col] = -sign * ct.drive_um;
        }
        m[(o_s + c) * n + o_n + c] = ct.mu;
    }
    for (k, sp) in supports.iter().enumerate() {
        let sigma = o_s + nc + k;
        for d in 0..n_dirs {
            let a = std::f64::consts::TAU * d as f64 / n_dirs as f64;
            let col = o_f + 2 * nc + k * n_dirs + d;
            couple(&mut m, col, wrench(sp.point_um, [a.cos(), a.sin()], length_um));
            m[col * n + sigma] = 1.0;
            m[sigma * n + col] = -1.0;
        }
        q[sigma] = sp.mu * sp.normal_force;
    }
    StepLcp { n_free: 3, n, m, q }
}

/// Three support points inside the peg spanning the COM, with their static normal forces
/// (each at least 2 % of the weight).
pub fn random_supports(rng: &mut impl Rng) -> [Support; 3] {
    let (a, b) = (PEG_W_UM / 2.0, PEG_H_UM / 2.0);
    for _ in 0..10_000 {
        let p: [[f64; 2]; 3] =
            std::array::from_fn(|_| [rng.random_range(-a..a), rng.random_range(-b..b)]);
        // Barycentric coordinates of the COM (origin) = normal forces (weight 1).
        let det =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if det.abs() < 1e3 {
            continue;
        }
        let f1 = ((-p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (-p[0][1])) / det;
        let f2 = ((p[1][0] - p[0][0]) * (-p[0][1]) - (-p[0][0]) * (p[1][1] - p[0][1])) / det;
        let f = [1.0 - f1 - f2, f1, f2];
        if f.iter().all(|&v| v >= 0.02) {
            let mu = rng.random_range(0.1..0.5);
            return std::array::from_fn(|k| Support { point_um: p[k], normal_force: f[k], mu });
        }
    }
    // Unreachable in practice (a random triangle spans the centre about a quarter of the time);
    // a fixed valid triangle keeps the generator total.
    let p = [[-a / 2.0, -b / 2.0], [a / 2.0, -b / 2.0], [0.0, b / 2.0]];
    let f = [0.25, 0.25, 0.5];
    std::array::from_fn(|k| Support { point_um: p[k], normal_force: f[k], mu: 0.3 })
}

/// A random boundary point of the peg and the inward normal there.
fn boundary_point(rng: &mut impl Rng) -> ([f64; 2], [f64; 2]) {
    let (a, b) = (PEG_W_UM / 2.0, PEG_H_UM / 2.0);
    match rng.random_range(0..4u8) {
        0 => ([-a, rng.random_range(-b..b)], [1.0, 0.0]),
        1 => ([a, rng.random_range(-b..b)], [-1.0, 0.0]),
        2 => ([rng.random_range(-a..a), -b], [0.0, 1.0]),
        _ => ([rng.random_range(-a..a), b], [0.0, -1.0]),
    }
}

/// A random step: the probe pushes inward (step 0.2–2 µm, up to ±70° from the normal),
/// `fixtures` static contacts with gaps from slightly closed to open, 8 directions per support.
pub fn random_step(rng: &mut impl Rng, fixtures: usize) -> StepLcp {
    let supports = random_supports(rng);
    let mut contacts = Vec::with_capacity(1 + fixtures);
    let (point_um, normal) = boundary_point(rng);
    let step = rng.random_range(0.2..2.0);
    let phi: f64 = rng.random_range(-1.2..1.2);
    contacts.push(PlanarContact {
        point_um,
        normal,
        mu: rng.random_range(0.0..1.0),
        gap_um: rng.random_range(-0.05..0.05) - step * phi.cos(),
        drive_um: step * phi.sin(),
    });
    for _ in 0..fixtures {
        let (point_um, normal) = boundary_point(rng);
        contacts.push(PlanarContact {
            point_um,
            normal,
            mu: rng.random_range(0.0..1.0),
            gap_um: rng.random_range(-0.02..2.0),
            drive_um: 0.0,
        });
    }
    assemble(&contacts, &supports, 8)
}
