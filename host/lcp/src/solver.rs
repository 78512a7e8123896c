//! [`LcpSolver`]: the reusable solver that runs Lemke, its fallbacks and the verification, in
//! workspaces sized once.

use super::dense::SetSolve;
use super::enumerate::enumerate;
use super::lemke::{Cover, LemkeEnd, Tableau, all_finite};
use super::newton::FbNewton;
use super::scale::Equilibration;
use super::verify::{self, Residuals};
use super::{Error, LcpSettings, MlcpProblem};

/// Which method produced a solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SolveMethod {
    /// Lemke with the covering vector of ones.
    Lemke,
    /// One of Lemke's retries with another covering vector.
    LemkeRetry,
    /// Enumeration of complementary bases.
    Enumeration,
    /// The caller's guess of the active set ([`LcpSolver::solve_warm`]), verified.
    WarmStart,
    /// The Fischer–Burmeister Newton fallback's active set, solved exactly and verified.
    Newton,
}

/// A verified answer, borrowed from the solver's buffers (valid until its next solve).
#[derive(Debug, Clone, Copy)]
pub struct LcpSolution<'a> {
    /// `z` (length `n`): free part first, then the complementarity part (all `≥ 0`).
    pub z: &'a [f64],
    /// `w = M z + q` recomputed from the original data (free part ≈ 0).
    pub w: &'a [f64],
    /// The answer's complementary basis: `true` where `z_i` is basic (so `w_i = 0`; always
    /// for free variables). Pass it to [`LcpSolver::solve_warm`] for the next, similar problem.
    pub active: &'a [bool],
    /// Pivots spent, all attempts included (block pivot of the free variables too).
    pub pivots: usize,
    /// The verified scaled residuals (each `≤ settings.tol`).
    pub residuals: Residuals,
    /// What produced it.
    pub method: SolveMethod,
    /// Whether the tableau's answer needed the active-set polish to pass.
    pub polished: bool,
}

/// A complementarity solver with reusable workspaces: construct once, call
/// [`solve`](LcpSolver::solve) many times. A solve allocates only when `n` exceeds every
/// size seen before (the buffers then grow once).
#[derive(Debug)]
pub struct LcpSolver {
    settings: LcpSettings,
    tab: Tableau,
    set: SetSolve,
    z: Vec<f64>,
    w: Vec<f64>,
    in_set: Vec<bool>,
    equilibration: Equilibration,
    newton: FbNewton,
}

/// How one Lemke attempt ended, for the failure report.
#[derive(Debug, Clone, Copy)]
enum Attempt {
    Verified(Residuals, bool),
    Unverified(f64),
    Ended(LemkeEnd),
}

impl LcpSolver {
    /// A solver with workspaces for problems of up to `capacity_n` variables.
    pub fn new(capacity_n: usize, settings: LcpSettings) -> Self {
        let mut s = LcpSolver {
            settings,
            tab: Tableau::with_capacity(capacity_n),
            set: SetSolve::default(),
            z: Vec::new(),
            w: Vec::new(),
            in_set: Vec::new(),
            equilibration: Equilibration::default(),
            newton: FbNewton::default(),
        };
        s.reserve(capacity_n);
        s
    }

    /// The settings in use.
    pub fn settings(&self) -> &LcpSettings {
        &self.settings
    }

    /// Replaces the settings.
    pub fn set_settings(&mut self, settings: LcpSettings) {
        self.settings = settings;
    }

    fn reserve(&mut self, n: usize) {
        if self.z.len() < n {
            self.tab.reserve(n);
            self.set.reserve(n);
            self.z.resize(n, 0.0);
            self.w.resize(n, 0.0);
            self.in_set.resize(n, false);
        }
    }

    /// Solves the mixed LCP `p`, returning a verified answer or the reason there is none.
    pub fn solve(&mut self, p: &MlcpProblem<'_>) -> Result<LcpSolution<'_>, Error> {
        p.validate_sizes()?;
        self.settings.validate()?;
        self.reserve(p.n);
        let mut pivots = 0;
        let mut worst = Attempt::Ended(LemkeEnd::Ray);
        for k in 0..=self.settings.retries {
            // Attempt 0 as given; then the equilibrated problem, first with the classic
            // covering vector, then with spread ones.
            let (cover, method) = match k {
                0 => (Cover::Ones, SolveMethod::Lemke),
                1 => (Cover::Ones, SolveMethod::LemkeRetry),
                _ => (Cover::Spread(k - 1), SolveMethod::LemkeRetry),
            };
            if k == 1 {
                self.equilibration.compute(p);
            }
            let attempt = self.attempt(p, k > 0, cover, &mut pivots)?;
            match attempt {
                Attempt::Verified(residuals, polished) => {
                    return Ok(self.answer(p, pivots, residuals, method, polished));
                }
                Attempt::Unverified(_) => worst = attempt,
                Attempt::Ended(_) if matches!(worst, Attempt::Ended(_)) => worst = attempt,
                Attempt::Ended(_) => {}
            }
        }
        if p.n_comp() <= self.settings.enumerate_max_n {
            let n = p.n;
            let e = enumerate(
                p,
                self.settings.tol,
                &mut self.set,
                &mut self.in_set[..n],
                &mut self.z[..n],
                &mut self.w[..n],
            );
            return match e.found {
                Some(r) => Ok(self.answer(p, pivots, r, SolveMethod::Enumeration, false)),
                None => Err(Error::NoSolutionFound { pivots, bases: e.bases }),
            };
        }
        if let Some(r) = self.newton_fallback(p) {
            return Ok(self.answer(p, pivots, r, SolveMethod::Newton, true));
        }
        let n = p.n_comp();
        Err(match worst {
            Attempt::Unverified(residual) => {
                Error::VerificationFailed { residual, tol: self.settings.tol }
            }
            Attempt::Ended(LemkeEnd::Limit) => Error::PivotLimit { pivots, n },
            _ => Error::SecondaryRay { pivots, n },
        })
    }

    /// Like [`solve`](Self::solve), but first tries the active set `guess` (length `n`; e.g.
    /// the previous step's [`LcpSolution::active`]): one linear solve on it, accepted only if
    /// the answer verifies; otherwise the full solve runs. Consecutive simulator steps
    /// usually keep their active set, which makes this several times cheaper than Lemke.
    pub fn solve_warm(
        &mut self,
        p: &MlcpProblem<'_>,
        guess: &[bool],
    ) -> Result<LcpSolution<'_>, Error> {
        p.validate_sizes()?;
        self.settings.validate()?;
        if guess.len() != p.n {
            return Err(Error::BadInput(format!(
                "active-set guess has {} entries, expected n = {}",
                guess.len(),
                p.n
            )));
        }
        if !(all_finite(p.m) && all_finite(p.q)) {
            p.validate()?;
        }
        self.reserve(p.n);
        let n = p.n;
        self.in_set[..n].copy_from_slice(guess);
        self.in_set[..p.n_free].fill(true);
        if self.set.solve(p, &self.in_set[..n], &mut self.z[..n]) {
            let r = self.verified(p);
            if r.max() <= self.settings.tol {
                return Ok(self.answer(p, 0, r, SolveMethod::WarmStart, false));
            }
        }
        self.solve(p)
    }

    fn answer(
        &self,
        p: &MlcpProblem<'_>,
        pivots: usize,
        residuals: Residuals,
        method: SolveMethod,
        polished: bool,
    ) -> LcpSolution<'_> {
        LcpSolution {
            z: &self.z[..p.n],
            w: &self.w[..p.n],
            active: &self.in_set[..p.n],
            pivots,
            residuals,
            method,
            polished,
        }
    }

    /// The Newton fallback from two starts (`z = 0`; `z = 1` on the complementarity part);
    /// its active set is solved exactly and verified. `z`, `w`, `in_set` hold the answer.
    fn newton_fallback(&mut self, p: &MlcpProblem<'_>) -> Option<Residuals> {
        let (n, iterations) = (p.n, self.settings.newton_iterations);
        if iterations == 0 {
            return None;
        }
        for start in [0.0, 1.0] {
            self.z[..p.n_free].fill(0.0);
            self.z[p.n_free..n].fill(start);
            let found = self.newton.run(
                p,
                &mut self.z[..n],
                &mut self.in_set[..n],
                iterations,
                self.settings.tol,
            );
            if found && self.set.solve(p, &self.in_set[..n], &mut self.z[..n]) {
                let r = self.verified(p);
                if r.max() <= self.settings.tol {
                    return Some(r);
                }
            }
        }
        None
    }

    /// One Lemke run with covering vector `cover`, on the equilibrated problem if `scaled`;
    /// on success `z`, `w` hold the answer (verified against `p` itself).
    fn attempt(
        &mut self,
        p: &MlcpProblem<'_>,
        scaled: bool,
        cover: Cover,
        pivots: &mut usize,
    ) -> Result<Attempt, Error> {
        let eq = std::mem::take(&mut self.equilibration);
        let result = self.attempt_on(p, if scaled { Some(&eq) } else { None }, cover, pivots);
        self.equilibration = eq;
        result
    }

    fn attempt_on(
        &mut self,
        p: &MlcpProblem<'_>,
        eq: Option<&Equilibration>,
        cover: Cover,
        pivots: &mut usize,
    ) -> Result<Attempt, Error> {
        let sp = eq.map_or(*p, |e| e.problem(p));
        if !self.tab.load(&sp, self.settings.pivot_tol) {
            // Names the non-finite entry.
            p.validate()?;
        }
        let block =
            self.tab.make_free_basic(sp.m).ok_or(Error::SingularEqualities { n_free: p.n_free })?;
        let (end, spent) = self.tab.lemke(sp.m, self.settings.max_pivots, cover);
        *pivots += block + spent;
        if end != LemkeEnd::Solved {
            return Ok(Attempt::Ended(end));
        }
        let n = p.n;
        self.tab.extract_z(&mut self.z[..n]);
        self.tab.active_set(&mut self.in_set[..n]);
        unscale(eq, &mut self.z[..n]);
        let first = self.verified(p);
        if first.max() <= self.settings.tol {
            return Ok(Attempt::Verified(first, false));
        }
        // Polish: solve directly on the active set Lemke identified.
        if self.set.solve(&sp, &self.in_set[..n], &mut self.z[..n]) {
            unscale(eq, &mut self.z[..n]);
            let second = self.verified(p);
            if second.max() <= self.settings.tol {
                return Ok(Attempt::Verified(second, true));
            }
            return Ok(Attempt::Unverified(first.max().min(second.max())));
        }
        Ok(Attempt::Unverified(first.max()))
    }

    /// Clamps the complementarity part of `z` at zero, recomputes `w` and checks.
    fn verified(&mut self, p: &MlcpProblem<'_>) -> Residuals {
        let n = p.n;
        for zi in &mut self.z[p.n_free..n] {
            *zi = zi.max(0.0);
        }
        verify::check_finite(p, &self.z[..n], &mut self.w[..n])
    }
}

/// `z = C z̃` when the attempt ran on the equilibrated problem.
fn unscale(eq: Option<&Equilibration>, z: &mut [f64]) {
    if let Some(e) = eq {
        for (zi, c) in z.iter_mut().zip(&e.col) {
            *zi *= c;
        }
    }
}
