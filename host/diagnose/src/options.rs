//! The knobs of a diagnosis, in one plain-data struct with documented defaults (sized for a
//! real batch; tests shrink the budgets).

use super::candidates::Effect;
use mesopush_sim::{Model, SimSettings};

/// Newton's stopping tolerance for diagnosis's replays, as a fraction of the step (0.5 pm on
/// the paper's 5 µm step; the simulator's own default is 1e-9): Newton's method stops an
/// iteration earlier where the answer has settled that far. With the second pass skipped
/// under a free-tip verdict ([`crate::attribute`]), the seed-1 and seed-12 independent sets
/// took 15 % and 14 % less time with the same verdicts (docs/diagnose.md, "Fewer
/// replays"). At 1e-6 the own-world seed-11 speed-friction batch flipped to `none`:
/// its held-out replay sits on a knife edge (2.9 -> 26.9 noise units with the same fitted
/// parameters), so the tolerance is kept a decade tighter than the one that flips it.
pub const DIAGNOSIS_NEWTON_TOL: f64 = 1e-7;

/// Knobs of a diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Evaluations for the nominal fit about the fitted support. Default 120.
    pub nominal_evals: usize,
    /// Evaluations for the nominal support fit ([`crate::nominal`]: both friction
    /// coefficients and all three support points free), per family tried. Default 400.
    pub support_evals: usize,
    /// The model the nominal fit starts from (`diagnose --model`, e.g. what `identify`
    /// wrote); None: the part's default ([`crate::candidates::base_model`]).
    pub start_model: Option<Model>,
    /// Evaluations (start grid included) for each effect fit. Default 80.
    pub effect_evals: usize,
    /// Candidates to try. Default every effect of [`Effect::EFFECTS`].
    pub candidates: Vec<Effect>,
    /// Simulator settings. Default [`SimSettings::default`] with Newton's tolerance at
    /// [`DIAGNOSIS_NEWTON_TOL`].
    pub settings: SimSettings,
    /// Smallest relative drop of the held-out error that counts (0.3 = 30 %). Default 0.3.
    pub min_gain: f64,
    /// The nominal residual counts as at the floor below this many times the floor.
    /// Default 5.
    pub floor_factor: f64,
    /// Smallest BIC improvement on the training trials that counts. Default 10.
    pub min_delta_bic: f64,
    /// Ambiguity: when the winner's held-out error stays above the floor band and another
    /// effect's is within this factor of it (1.15 = 15 % worse), two explanations fit the
    /// held-out trials about as well and neither explains them; the verdict is then
    /// `unexplained` (naming both in the diagnosis's `ambiguity`), never a guess between them. Default 1.15.
    pub ambiguity_ratio: f64,
    /// Whether the training loss is profiled over the replay's measured start poses
    /// ([`crate::start_pose`]): their tracker noise then cannot bend the fitted support.
    /// Default true (false: the loss of every fit is the plain prediction error).
    pub profile_start_poses: bool,
    /// Simulator step, µm for the paper's peg (scaled to the part as `settings.step_um` is),
    /// at which a nominal fit already within the floor band is polished ([`crate::polish`]);
    /// 0 or not finer than `settings.step_um`: off. Default 1.
    pub polish_step_um: f64,
    /// Whether the effect leading on the training trials is refitted with the three support
    /// points free as well ([`crate::free_support`]). Default true.
    pub refit_lead_support: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            nominal_evals: 120,
            support_evals: 400,
            start_model: None,
            effect_evals: 80,
            candidates: Effect::EFFECTS.to_vec(),
            settings: SimSettings { newton_tol: DIAGNOSIS_NEWTON_TOL, ..SimSettings::default() },
            min_gain: 0.3,
            floor_factor: 5.0,
            min_delta_bic: 10.0,
            ambiguity_ratio: 1.15,
            profile_start_poses: true,
            polish_step_um: 1.0,
            refit_lead_support: true,
        }
    }
}
