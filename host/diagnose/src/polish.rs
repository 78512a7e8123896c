//! The nominal fit redone at a finer simulator step when it is already near the floor.
//!
//! The replays step the probe `step_um` at a time (5 µm for the paper's peg). That error is
//! small against a missing effect, but not against the measurement floor: the independent
//! generator's own truth, replayed by the simulator, predicts held-out clean trials at
//! 1.12–1.78 × the floor with 5 µm steps and 1.03–1.42 × with 1 µm steps (docs/diagnose.md,
//! "A finer step near the floor"). When the nominal fit is already within the floor band,
//! the whole nominal fit ([`crate::nominal::nominal_base`]) is done again at
//! [`crate::Options::polish_step_um`] and kept when it predicts the held-out trials better
//! (the rule that keeps a support family). Batches far above the floor — an effect to find —
//! keep the coarse step: there the step's error is a small part of the residual, and a finer
//! step costs two to three times the time.

use super::data::TrialData;
use super::fit::Fit;
use super::nominal::{Held, SupportFit, nominal_base};
use super::options::Options;
use mesopush_sim::{Model, SimSettings};

/// What the refit did (in the diagnosis's JSON and report).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Polish {
    /// The finer step, µm (scaled to the part as `step_um` is).
    pub step_um: f64,
    /// The support family the refit kept.
    pub family: &'static str,
    /// Held-out error of the refit at that step, noise units.
    pub heldout_norm: f64,
    /// Whether it replaced the coarse fit (its held-out error is lower).
    pub kept: bool,
    /// Objective evaluations its free-support fits used.
    pub evals: usize,
}

/// The refitted nominal: the fit, the training trials (their start-pose sensitivity at it),
/// the finer settings, and what was done.
#[derive(Debug)]
pub struct Polished {
    /// The refitted nominal.
    pub fit: Fit,
    /// The training trials as the effects would be fitted on them.
    pub train: Vec<TrialData>,
    /// The finer settings.
    pub settings: SimSettings,
    /// The summary.
    pub polish: Polish,
}

/// The finer settings for `coarse` (already scaled to the part), or None when
/// `opts.polish_step_um` is off (zero) or not finer than the coarse step.
pub fn fine_settings(coarse: &SimSettings, opts: &Options) -> Option<SimSettings> {
    let scale = coarse.step_um / opts.settings.step_um;
    let step_um = opts.polish_step_um * scale;
    (step_um > 0.0 && step_um < coarse.step_um).then(|| SimSettings { step_um, ..coarse.clone() })
}

/// The nominal fit from `prior` on the plain training trials `train` at `fine`, judged on
/// `held`'s trials at the same settings (`band`: the floor band, as for the coarse fit).
pub fn polish(
    prior: &Model,
    train: &[TrialData],
    held: &Held<'_>,
    band: f64,
    fine: &SimSettings,
    opts: &Options,
) -> Polished {
    let held_fine = Held { settings: fine, ..*held };
    let (fit, _, sf, train) = nominal_base(prior, train, &held_fine, band, opts);
    let polish = Polish {
        step_um: fine.step_um,
        family: sf.family,
        heldout_norm: sf.kept_heldout_norm(),
        kept: false,
        evals: sf.evals,
    };
    Polished { fit, train, settings: fine.clone(), polish }
}

/// What a refit near the floor works from.
#[derive(Debug, Clone, Copy)]
pub struct NearFloor<'a> {
    /// The model the nominal fit started from.
    pub prior: &'a Model,
    /// The plain training trials.
    pub train: &'a [TrialData],
    /// The held-out trials at the coarse settings.
    pub held: &'a Held<'a>,
    /// The floor band, noise units.
    pub band: f64,
    /// The diagnosis's options.
    pub opts: &'a Options,
}

impl NearFloor<'_> {
    /// The coarse nominal fit (`kept`, its support fit, its training trials), refitted at the
    /// finer step when it is inside the floor band and the option is on; the refit replaces
    /// it when its held-out error is lower. Returns the nominal, the support fit (with the
    /// refit's summary), the training trials and the settings the rest of the diagnosis uses.
    pub fn refit(
        &self,
        kept: Fit,
        mut support_fit: SupportFit,
        train: Vec<TrialData>,
        progress: &(dyn Fn(&str) + Sync),
    ) -> (Fit, SupportFit, Vec<TrialData>, SimSettings) {
        let coarse = self.held.settings.clone();
        let at_floor = support_fit.kept_heldout_norm() <= self.band;
        let Some(fine) = fine_settings(&coarse, self.opts).filter(|_| at_floor) else {
            return (kept, support_fit, train, coarse);
        };
        progress("refit at the finer step");
        let mut p = polish(self.prior, self.train, self.held, self.band, &fine, self.opts);
        p.polish.kept = p.polish.heldout_norm < support_fit.kept_heldout_norm();
        let kept_refit = p.polish.kept;
        support_fit.polish = Some(p.polish);
        if kept_refit {
            (p.fit, support_fit, p.train, p.settings)
        } else {
            (kept, support_fit, train, coarse)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_finer_step_scales_with_the_part_and_is_off_at_zero_or_when_not_finer() {
        let opts = Options::default();
        let peg = opts.settings.clone();
        assert_eq!(fine_settings(&peg, &opts).map(|s| s.step_um), Some(1.0));
        // A part of 0.76 × the peg's size steps 3.8 µm; its finer step is 0.76 µm.
        let small = SimSettings { step_um: 3.8, ..peg.clone() };
        let f = fine_settings(&small, &opts).unwrap();
        assert!((f.step_um - 0.76).abs() < 1e-12);
        assert_eq!(SimSettings { step_um: 3.8, ..f }, small);
        let off = Options { polish_step_um: 0.0, ..opts.clone() };
        assert_eq!(fine_settings(&peg, &off), None);
        let coarser = Options { polish_step_um: 5.0, ..opts };
        assert_eq!(fine_settings(&peg, &coarser), None);
    }
}
