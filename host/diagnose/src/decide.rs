//! The verdict from the candidates' scores: `none` at the floor; an effect when one candidate
//! wins on the training BIC *and* on the held-out error, clearly; `unexplained` otherwise —
//! with the two effects the evidence is split between when there are two.

use super::candidates::Effect;
use super::fit::Fit;
use super::options::Options;
use super::residual::Mse;
use serde::Serialize;

/// What a diagnosis concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A library effect explains the residual.
    Effect,
    /// The residual is above the floor and no candidate explains it.
    Unexplained,
    /// The residual is at the measurement floor: no missing effect.
    None,
}

/// One candidate's fit and held-out score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectScore {
    /// The candidate.
    pub candidate: Effect,
    /// Fitted parameters: name, value, 1σ (NaN when not estimated).
    pub params: Vec<(String, f64, f64)>,
    /// BIC on the training trials.
    pub bic: f64,
    /// Held-out errors.
    pub heldout: Mse,
    /// Held-out error in noise units.
    pub heldout_norm: f64,
    /// Held-out error of each held-out trial alone, noise units, in the held-out order
    /// (infinite for a trial the model cannot simulate).
    pub heldout_per_trial_norm: Vec<f64>,
    /// Held-out error of the imaged probe tip alone, noise units (1 at the floor; NaN when
    /// the trials image no tip).
    pub heldout_tip_norm: f64,
}

/// Why two effects were in the running and neither was named.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ambiguity {
    /// Both fit the held-out trials about as well, above the floor band (best first).
    Tie(Effect, Effect),
    /// One fits the held-out trials best, another fits the training trials far better: an
    /// effect that explains the training trials but does not carry over to held-out ones, or
    /// one that carries over only by chance. Either way the evidence does not agree.
    TrainVsHeldout {
        /// The held-out winner.
        heldout: Effect,
        /// The training (BIC) winner.
        train: Effect,
    },
}

impl Ambiguity {
    /// The two effects (the held-out one first).
    pub fn pair(&self) -> (Effect, Effect) {
        match *self {
            Self::Tie(a, b) => (a, b),
            Self::TrainVsHeldout { heldout, train } => (heldout, train),
        }
    }
}

/// The effect that fits the training trials best, when it beats the nominal BIC by
/// `min_delta_bic` (reported as a lead even when the verdict is `unexplained`).
pub fn training_lead(scores: &[EffectScore], opts: &Options) -> Option<Effect> {
    let bic0 = scores.first()?.bic;
    scores[1..]
        .iter()
        .filter(|s| s.bic < bic0 - opts.min_delta_bic)
        .min_by(|a, b| a.bic.total_cmp(&b.bic))
        .map(|s| s.candidate)
}

/// The verdict from the scores (nominal first, then one per fit in `fits`' order) and the
/// nominal held-out error `e0` against the `floor` (noise units): `none` at the floor; the
/// effect that wins on BIC and on held-out error by `min_gain` (an effect that moves the free
/// tip, [`Effect::shows_in_free_tip`], on the tip's held-out error too), unless another
/// qualifying effect ties with it well above the floor (`ambiguity_ratio`) or the training
/// trials favour another effect by more than `min_delta_bic`; else `unexplained`.
pub fn decide<'f>(
    scores: &[EffectScore],
    fits: &'f [Fit],
    e0: f64,
    floor: f64,
    opts: &Options,
) -> (Verdict, Option<&'f Fit>, Option<Ambiguity>) {
    if e0 <= opts.floor_factor * floor {
        return (Verdict::None, None, None);
    }
    if let Some(w) = tip_winner(scores, fits, opts) {
        return (Verdict::Effect, Some(w), None);
    }
    let bic0 = scores[0].bic;
    let mut ok: Vec<(&EffectScore, &Fit)> = scores[1..]
        .iter()
        .zip(fits)
        .filter(|(sc, _)| sc.bic < bic0 - opts.min_delta_bic)
        .filter(|(sc, _)| sc.heldout_norm <= (1.0 - opts.min_gain) * e0)
        .filter(|(sc, _)| tip_agrees(sc, scores[0].heldout_tip_norm, opts))
        .collect();
    ok.sort_by(|a, b| a.0.heldout_norm.total_cmp(&b.0.heldout_norm));
    let lead = training_lead(scores, opts).and_then(|c| scores.iter().find(|s| s.candidate == c));
    match ok.as_slice() {
        [] => (Verdict::Unexplained, None, None),
        [(w, _), (r, _), ..]
            if w.heldout_norm > opts.floor_factor * floor
                && r.heldout_norm <= opts.ambiguity_ratio * w.heldout_norm =>
        {
            (Verdict::Unexplained, None, Some(Ambiguity::Tie(w.candidate, r.candidate)))
        }
        [(w, _), ..]
            if lead.is_some_and(|l| {
                l.candidate != w.candidate && w.bic - l.bic > opts.min_delta_bic
            }) =>
        {
            let train = lead.map_or(w.candidate, |l| l.candidate);
            let amb = Ambiguity::TrainVsHeldout { heldout: w.candidate, train };
            (Verdict::Unexplained, None, Some(amb))
        }
        [(_, f), ..] => (Verdict::Effect, Some(*f), None),
    }
}

/// Whether the imaged tip agrees with naming `sc`'s effect: an effect that moves the free tip
/// ([`Effect::shows_in_free_tip`]) must bring the held-out tip error (`t0` the nominal's,
/// noise units) down by `min_gain` when the trials image the tip — the tip shows such an
/// effect whatever the part's physics, so a gain in the poses alone is the nominal model's
/// misfit bent by it (the independent generator's lead screw, seed 13: a 0.09 % "scale" took
/// the held-out pose error 431 → 207 noise units while the tip's went 25.3 → 27.3 µm²). Any
/// other effect, and trials without an imaged tip, pass.
fn tip_agrees(sc: &EffectScore, t0: f64, opts: &Options) -> bool {
    if !sc.candidate.shows_in_free_tip() || t0.is_nan() || sc.heldout_tip_norm.is_nan() {
        return true;
    }
    sc.heldout_tip_norm <= (1.0 - opts.min_gain) * t0
}

/// The effect the imaged probe tip names on its own: an effect acting between the command
/// and the image (the stage's lost motion, the camera's clock or scale, a needle that bends)
/// shows in the tip whatever the part's physics, so a support model that cannot yet predict
/// the held-out poses (another simulator's part, a real plate) does not drown it there. Named
/// when the nominal model's held-out tip is above its floor band (`floor_factor` × the floor),
/// and exactly one candidate that beats the nominal training BIC by `min_delta_bic` brings it
/// into the band, by at least `min_gain`. Effects of the part's physics leave the tip as it
/// was and are never named here.
pub fn tip_winner<'f>(scores: &[EffectScore], fits: &'f [Fit], opts: &Options) -> Option<&'f Fit> {
    let (nominal, band) = (scores.first()?, opts.floor_factor);
    let t0 = nominal.heldout_tip_norm;
    if t0.is_nan() || t0 <= band {
        return None;
    }
    let mut at_floor = scores[1..]
        .iter()
        .zip(fits)
        .filter(|(sc, _)| sc.bic < nominal.bic - opts.min_delta_bic)
        .filter(|(sc, _)| sc.heldout_tip_norm <= band.min((1.0 - opts.min_gain) * t0));
    let (_, w) = at_floor.next()?;
    at_floor.next().is_none().then_some(w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::candidates::base_model;
    use mesopush_sim::Part;

    fn fit_of(c: Effect) -> Fit {
        let model = base_model(&Part::default_peg());
        Fit {
            candidate: c,
            values: vec![],
            base: model.clone(),
            model,
            loss: 1.0,
            n: 100,
            evals: 0,
        }
    }

    fn score_of(c: Effect, bic: f64, heldout_norm: f64) -> EffectScore {
        let heldout = Mse { xy_um2: 0.0, theta_rad2: 0.0, tip_um2: 0.0 };
        EffectScore {
            candidate: c,
            params: vec![],
            bic,
            heldout,
            heldout_norm,
            heldout_per_trial_norm: vec![],
            heldout_tip_norm: f64::NAN,
        }
    }

    /// Patch seed 11 of the confusion run: drift and patch tied far above the floor and the
    /// old rule named drift, a wrong effect.
    #[test]
    fn two_effects_tied_far_above_the_floor_are_unexplained_not_a_guess() {
        let opts = Options::default();
        let fits = [fit_of(Effect::SupportDrift), fit_of(Effect::FrictionPatch)];
        let scores = [
            score_of(Effect::Nominal, 0.0, 40_000.0),
            score_of(Effect::SupportDrift, -500.0, 24_083.0),
            score_of(Effect::FrictionPatch, -400.0, 25_627.0),
        ];
        let (v, best, amb) = decide(&scores, &fits, 40_000.0, 2.0, &opts);
        assert_eq!(v, Verdict::Unexplained);
        assert!(best.is_none());
        assert_eq!(amb, Some(Ambiguity::Tie(Effect::SupportDrift, Effect::FrictionPatch)));
    }

    #[test]
    fn a_clear_winner_or_one_at_the_floor_is_named_despite_a_runner_up() {
        let opts = Options::default();
        let fits = [fit_of(Effect::Backlash), fit_of(Effect::Adhesion)];
        // Far above the floor but the runner-up is 2x worse: named.
        let scores = [
            score_of(Effect::Nominal, 0.0, 600.0),
            score_of(Effect::Backlash, -500.0, 50.0),
            score_of(Effect::Adhesion, -400.0, 100.0),
        ];
        let (v, best, _) = decide(&scores, &fits, 600.0, 2.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Backlash)));
        // Tied, but the winner reaches the floor band: named.
        let scores = [
            score_of(Effect::Nominal, 0.0, 600.0),
            score_of(Effect::Backlash, -500.0, 5.0),
            score_of(Effect::Adhesion, -400.0, 5.2),
        ];
        let (v, best, _) = decide(&scores, &fits, 600.0, 2.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Backlash)));
        // A runner-up that fails the BIC test does not make it ambiguous.
        let scores = [
            score_of(Effect::Nominal, 0.0, 600.0),
            score_of(Effect::Backlash, -500.0, 50.0),
            score_of(Effect::Adhesion, 5.0, 51.0),
        ];
        let (v, _, amb) = decide(&scores, &fits, 600.0, 2.0, &opts);
        assert_eq!((v, amb), (Verdict::Effect, None));
    }

    #[test]
    fn at_the_floor_is_none_and_no_gain_is_unexplained() {
        let opts = Options::default();
        let fits = [fit_of(Effect::Backlash)];
        let scores = [score_of(Effect::Nominal, 0.0, 8.0), score_of(Effect::Backlash, -50.0, 7.0)];
        assert_eq!(decide(&scores, &fits, 8.0, 2.0, &opts).0, Verdict::None);
        let scores =
            [score_of(Effect::Nominal, 0.0, 90.0), score_of(Effect::Backlash, -50.0, 80.0)];
        assert_eq!(decide(&scores, &fits, 90.0, 2.0, &opts).0, Verdict::Unexplained);
    }

    /// Patch seed 5 of the four-trial full-loop sweep: the friction patch fitted the training
    /// trials far better than anything (BIC 1014 against 5653) but did not carry over; support
    /// drift scraped past the held-out rule and was named, a wrong effect.
    #[test]
    fn a_held_out_winner_the_training_trials_disfavour_is_not_named() {
        let opts = Options::default();
        let fits = [fit_of(Effect::FrictionPatch), fit_of(Effect::SupportDrift)];
        let scores = [
            score_of(Effect::Nominal, 5653.0, 70_903.0),
            score_of(Effect::FrictionPatch, 1014.0, 136_471.0),
            score_of(Effect::SupportDrift, 5583.0, 47_705.0),
        ];
        let (v, best, amb) = decide(&scores, &fits, 70_903.0, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Unexplained, None));
        let split = Ambiguity::TrainVsHeldout {
            heldout: Effect::SupportDrift,
            train: Effect::FrictionPatch,
        };
        assert_eq!(amb, Some(split));
        assert_eq!(training_lead(&scores, &opts), Some(Effect::FrictionPatch));
    }

    fn tip_score(c: Effect, bic: f64, heldout_norm: f64, tip: f64) -> EffectScore {
        EffectScore { heldout_tip_norm: tip, ..score_of(c, bic, heldout_norm) }
    }

    /// The same scores from trials that image no tip.
    fn without_tips(scores: &[EffectScore]) -> Vec<EffectScore> {
        scores.iter().map(|s| EffectScore { heldout_tip_norm: f64::NAN, ..s.clone() }).collect()
    }

    /// Latency batch 0 of the independent generator (seed 1): the free-support nominal model
    /// predicts the held-out poses at 430 noise units, so the pose channel ranked compliance
    /// (145) above latency (214) and the training trials favoured latency: `unexplained`. The
    /// imaged tip alone names latency (0.66 against 27 and more for every other candidate).
    #[test]
    fn the_imaged_tip_names_a_camera_effect_the_pose_channel_drowns() {
        let opts = Options::default();
        let fits = [fit_of(Effect::Backlash), fit_of(Effect::Latency), fit_of(Effect::Compliance)];
        let scores = [
            tip_score(Effect::Nominal, 58_773.0, 429.5, 58.97),
            tip_score(Effect::Backlash, 47_817.0, 1356.7, 26.67),
            tip_score(Effect::Latency, -1258.0, 213.7, 0.66),
            tip_score(Effect::Compliance, 54_745.0, 144.8, 45.88),
        ];
        let (v, best, _) = decide(&scores, &fits, 429.5, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Latency)));
        // Two candidates that both bring the tip to its floor: the tip does not decide (the
        // general rule then sees compliance best held out and latency best in training).
        let mut two = scores.clone();
        two[1] = tip_score(Effect::Backlash, 47_817.0, 1356.7, 2.0);
        let (v, _, amb) = decide(&two, &fits, 429.5, 3.0, &opts);
        assert_eq!(v, Verdict::Unexplained);
        assert!(amb.is_some());
        // The tip at its floor already (a physical effect leaves it there): not decided by it.
        let mut calm = scores.clone();
        calm[0].heldout_tip_norm = 1.2;
        assert_eq!(tip_winner(&calm, &fits, &opts).map(|f| f.candidate), None);
        // Without imaged tips (NaN): never.
        let none = without_tips(&scores);
        assert_eq!(tip_winner(&none, &fits, &opts).map(|f| f.candidate), None);
    }

    /// Lead-screw batch 1 of the independent generator (seed 13; a periodic stage error, not
    /// in the library): a 0.09 % scale error won on the poses (held-out 431 → 207 noise
    /// units, BIC 709 lower) while the imaged tip got worse (25.3 → 27.3); `scale_error` was
    /// named, a wrong effect.
    #[test]
    fn a_stage_or_camera_effect_the_imaged_tip_does_not_confirm_is_not_named() {
        let opts = Options::default();
        let fits = [fit_of(Effect::Backlash), fit_of(Effect::Scale), fit_of(Effect::Adhesion)];
        let scores = [
            tip_score(Effect::Nominal, 25_104.0, 431.3, 12.4),
            tip_score(Effect::Backlash, 24_935.0, 296.9, 12.1),
            tip_score(Effect::Scale, 24_395.0, 207.0, 13.4),
            tip_score(Effect::Adhesion, 25_132.0, 431.2, 12.4),
        ];
        let (v, best, _) = decide(&scores, &fits, 431.3, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Unexplained, None));
        // The same poses with the tip confirming the scale (12.4 → 1.1): named.
        let mut confirmed = scores.clone();
        confirmed[2].heldout_tip_norm = 1.1;
        let (v, best, _) = decide(&confirmed, &fits, 431.3, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Scale)));
        // Without imaged tips the poses decide, as before.
        let blind = without_tips(&scores);
        let (v, best, _) = decide(&blind, &fits, 431.3, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Scale)));
        // An effect that moves the part, not the tip, is not asked to move the tip.
        let mut physical = scores.clone();
        physical[2] = tip_score(Effect::Scale, 25_100.0, 431.0, 13.4);
        physical[3] = tip_score(Effect::Adhesion, 24_395.0, 207.0, 12.4);
        let (v, best, _) = decide(&physical, &fits, 431.3, 3.0, &opts);
        assert_eq!((v, best.map(|f| f.candidate)), (Verdict::Effect, Some(Effect::Adhesion)));
    }
}
