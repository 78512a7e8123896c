//! Solving one step's mixed LCP: with the paper's polygonal support cones (one solve), or
//! with exact Coulomb friction at the supports by a damped Newton's method whose iterations
//! are LCPs with the support friction linearised ([`crate::coulomb`]).

use super::{SimState, Simulator, StepInfo};
use crate::Error;
use crate::coulomb::{Linearised, Supports};
use crate::formulate::{Layout, N_SUPPORTS, PusherMotion, StepInputs};
use crate::settings::SupportFriction;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_lcp::MlcpProblem;

/// How the supports' friction enters one LCP.
#[derive(Debug, Clone, Copy)]
enum SupportTerm {
    /// The polygonal cones in the part's body frame.
    BodyFrame,
    /// The polygonal cones turned against the given slips.
    AgainstSlips([Vec2; N_SUPPORTS]),
    /// The exact friction, linearised.
    Exact(Linearised),
}

/// Averaged iterations allowed after Newton's method fails (each halves the distance to
/// the answer, about: 60 take an error of a whole step far below [`AVERAGED_TOL`]).
const AVERAGED_ITERATIONS: usize = 60;

/// The averaged iterations stop when the motion changes by less than this fraction of the
/// step (0.5 nm per 5 µm step): far below the tracker's noise, and looser than Newton's
/// `newton_tol`, which a linear rate would reach only slowly.
const AVERAGED_TOL: f64 = 1e-4;

/// Largest component difference of two motions.
fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max)
}

impl Simulator {
    /// Solves the step's mixed LCP into `self.z`: with the paper's polygonal cones in the
    /// part's body frame ([`crate::cone`]), or with exact Coulomb friction at the supports
    /// ([`crate::coulomb`], the default) by Newton's method.
    pub(super) fn solve_aligned(
        &mut self,
        state: &SimState,
        supports: &[Vec2; N_SUPPORTS],
        motion: PusherMotion,
        travel_um: f64,
        info: &mut StepInfo,
    ) -> Result<Layout, Error> {
        let mu = self.surface_friction(&state.peg);
        let ctx = StepCtx { state, supports, motion, travel_um, mu };
        if self.settings.support_friction == SupportFriction::Polygon {
            return self.solve_with(&ctx, SupportTerm::BodyFrame, info);
        }
        let exact = Supports {
            r_um: *supports,
            normal: self.support_forces,
            mu,
            char_len_um: self.char_len_um,
            eps_um: self.settings.slip_regularisation * self.settings.step_um,
        };
        // Start from the last step's motion when this step continues it (scaled to this
        // step's probe travel), else from the paper's polygonal cones (robust where nothing
        // slides, which a tangent of |v| taken at a slip cannot see); if Newton's method from
        // the carried motion fails, it starts again from the polygon, and where that fails
        // too, averaged iterations follow from the polygon's motion (so every step Newton's
        // method solved before they existed is solved as it was).
        let carried = self.newton_carry.filter(|(p, _, _)| *p == state.peg);
        if let Some((_, u, travel)) = carried.filter(|c| c.2 > 0.0) {
            let u = u.map(|x| x * travel_um / travel);
            if let Some(lay) = self.newton(&ctx, &exact, u, info) {
                return Ok(lay);
            }
        }
        self.solve_with(&ctx, SupportTerm::BodyFrame, info)?;
        let u = [self.z[0], self.z[1], self.z[2]];
        if let Some(lay) = self.newton(&ctx, &exact, u, info) {
            return Ok(lay);
        }
        if let Some(lay) = self.averaged(&ctx, &exact, u, info) {
            return Ok(lay);
        }
        // Neither converged: fall back to the polygonal cones turned against the
        // polygon's slips (an LCP, always solvable), and say so.
        info.newton_fallback = true;
        self.newton_carry = None;
        let slips = [0, 1, 2].map(|s| exact.slip(s, &u));
        self.solve_with(&ctx, SupportTerm::AgainstSlips(slips), info)
    }

    /// Newton's method on the exact support friction from `u`: the layout of the last LCP,
    /// with the answer in `self.z`, or `None` when it does not converge within the budget
    /// (or an LCP of it has no solution).
    fn newton(
        &mut self,
        ctx: &StepCtx<'_>,
        exact: &Supports,
        mut u: [f64; 3],
        info: &mut StepInfo,
    ) -> Option<Layout> {
        let tol = self.settings.newton_tol * self.settings.step_um;
        let budget = info.newton_iterations + self.settings.newton_iterations;
        // Newton's step from `u` is `full(u) − u` (the answer of the LCP linearised at `u`);
        // its size is the merit (zero exactly at the answer). A step that does not shrink it
        // is retried with a proximal term ρ(u' − u) in the linearisation (Levenberg–
        // Marquardt): the contacts stay consistent with the shorter step, which a scaled
        // Newton step would not guarantee. ρ grows ×8 per refusal and shrinks ÷8 per success.
        let (mut lay, mut full) = self.newton_map(ctx, exact, &u, 0.0, info).ok()?;
        let mut size = distance(&full, &u);
        let rho0 = self.support_forces.iter().sum::<f64>() / self.settings.step_um;
        let mut rho = 0.0f64;
        while size > tol {
            if info.newton_iterations >= budget || rho > 1e3 * rho0 {
                return None;
            }
            let trial =
                if rho == 0.0 { full } else { self.newton_map(ctx, exact, &u, rho, info).ok()?.1 };
            let (l2, f2) = self.newton_map(ctx, exact, &trial, 0.0, info).ok()?;
            let s2 = distance(&f2, &trial);
            if s2 < size {
                (u, lay, full, size) = (trial, l2, f2, s2);
                rho = if rho / 8.0 < 1e-3 * rho0 { 0.0 } else { rho / 8.0 };
            } else {
                rho = (8.0 * rho).max(rho0);
            }
        }
        self.carry(ctx, full);
        Some(lay)
    }

    /// Averaged iterations of the same map, `u ← u + ½ (full(u) − u)` (Krasnosel'skii–Mann),
    /// from `u`, when Newton's method fails: a contact on the edge of its friction cone can
    /// make the linearised answer jump between two sides of the answer so that no Newton step
    /// shrinks (the independent generator's clean batch 6409012635243707006: every step of a
    /// sliding push alternated, and the polygonal fallback turned the peg along another
    /// branch, 40 µm off within a stroke). Averaging converges linearly to the same fixed
    /// point — the exact answer — within [`AVERAGED_ITERATIONS`] to [`AVERAGED_TOL`] of the
    /// step; `None` when it does not.
    fn averaged(
        &mut self,
        ctx: &StepCtx<'_>,
        exact: &Supports,
        mut u: [f64; 3],
        info: &mut StepInfo,
    ) -> Option<Layout> {
        let tol = AVERAGED_TOL.max(self.settings.newton_tol) * self.settings.step_um;
        for _ in 0..AVERAGED_ITERATIONS {
            let (lay, full) = self.newton_map(ctx, exact, &u, 0.0, info).ok()?;
            if distance(&full, &u) <= tol {
                self.carry(ctx, full);
                return Some(lay);
            }
            for (x, f) in u.iter_mut().zip(full) {
                *x += 0.5 * (f - *x);
            }
        }
        None
    }

    /// Keeps the step's answer `full` to start the next step's Newton's method from.
    fn carry(&mut self, ctx: &StepCtx<'_>, full: [f64; 3]) {
        let p = &ctx.state.peg;
        let end =
            Pose::new(p.x_um + full[0], p.y_um + full[1], p.theta_rad + full[2] / self.char_len_um);
        self.newton_carry = Some((end, full, ctx.travel_um));
    }

    /// One Newton iteration: the step's LCP with the support friction linearised at `u`,
    /// plus a proximal term `rho (u' − u)`; returns the motion it finds.
    fn newton_map(
        &mut self,
        ctx: &StepCtx<'_>,
        exact: &Supports,
        u: &[f64; 3],
        rho: f64,
        info: &mut StepInfo,
    ) -> Result<(Layout, [f64; 3]), Error> {
        let mut lin = exact.linearise(u);
        for (k, x) in u.iter().enumerate() {
            lin.h[k][k] += rho;
            lin.rhs[k] += rho * x;
        }
        let lay = self.solve_with(ctx, SupportTerm::Exact(lin), info)?;
        Ok((lay, [self.z[0], self.z[1], self.z[2]]))
    }

    /// Builds the step's problem with the supports' friction as `term` and solves it into
    /// `self.z`.
    fn solve_with(
        &mut self,
        ctx: &StepCtx<'_>,
        term: SupportTerm,
        info: &mut StepInfo,
    ) -> Result<Layout, Error> {
        let theta = ctx.state.peg.theta_rad;
        let (directions, coulomb): (&[Vec2], _) = match term {
            SupportTerm::BodyFrame => (self.cones.in_body_frame(theta), None),
            SupportTerm::AgainstSlips(slips) => (self.cones.against_slips(theta, &slips), None),
            SupportTerm::Exact(lin) => (&[], Some(lin)),
        };
        // The viscous regularisation makes the polygonal cone's motion unique; the circular
        // cone's is unique without it.
        let viscosity = if coulomb.is_none() {
            self.settings.support_viscosity / self.settings.step_um
        } else {
            0.0
        };
        let inputs = StepInputs {
            contacts: &self.contacts,
            com: ctx.state.peg.position(),
            char_len_um: self.char_len_um,
            pusher: ctx.motion,
            supports: *ctx.supports,
            support_forces: self.support_forces,
            mu_surface: ctx.mu,
            directions,
            viscosity,
            probe_compliance_um: self.settings.probe_compliance_um,
            coulomb,
        };
        let lay = self.problem.build(&inputs);
        self.solve_problem(&lay, info)?;
        info.newton_iterations += 1;
        Ok(lay)
    }

    /// Solves the built problem into `self.z`, warm-started from the last active set of the
    /// same problem shape when the contacts are the same ones (same count and kinds, in
    /// order); the solver verifies the guess and falls back to Lemke when it does not hold.
    fn solve_problem(&mut self, lay: &Layout, info: &mut StepInfo) -> Result<(), Error> {
        let problem = MlcpProblem { n_free: 3, n: lay.n(), m: &self.problem.m, q: &self.problem.q };
        let warm = &mut self.warm[usize::from(lay.n_directions == 0)];
        let same = warm.active.len() == lay.n()
            && warm.kinds.len() == self.contacts.len()
            && warm.kinds.iter().zip(&self.contacts).all(|(k, (c, _))| *k == c.kind);
        let sol = if same {
            self.solver.solve_warm(&problem, &warm.active)
        } else {
            self.solver.solve(&problem)
        }
        .map_err(Error::Lcp)?;
        warm.active.clear();
        warm.active.extend_from_slice(sol.active);
        warm.kinds.clear();
        warm.kinds.extend(self.contacts.iter().map(|(c, _)| c.kind));
        self.z.clear();
        self.z.extend_from_slice(sol.z);
        info.pivots += sol.pivots;
        Ok(())
    }
}

/// What every LCP of one step shares.
struct StepCtx<'a> {
    state: &'a SimState,
    supports: &'a [Vec2; N_SUPPORTS],
    motion: PusherMotion,
    travel_um: f64,
    mu: [f64; N_SUPPORTS],
}
