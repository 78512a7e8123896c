//! Stage and camera effects fitted on the free imaged tip alone. Where the tip is clear of
//! the peg, the image shows it where the stage put it (the commanded path through the stage's
//! lost motion), seen at the frame's stamp less the camera's latency, through the image's
//! scale error: nothing of the part's physics enters. So the effects between the command and
//! the image ([`Effect::shows_in_free_tip`]) can be fitted on those frames without replaying
//! the part at all: a kinematic fit, cheap, and blind to how well the support model predicts
//! the poses — on data from another simulator or a real plate the joint fit of an effect and
//! the nominal parameters can bend the effect to absorb the part model's error (an
//! independent generator's 2 % image scale fitted as 1.4 %, held-out tip 661 → 54 noise units:
//! not named), while the free tip alone sees it whole.
//!
//! Each trial's free residual is registered by its median, as in [`crate::tip`]: a constant
//! offset between stage and image is a calibration, and a scale about an unknown origin is
//! such an offset plus a scale about the library's origin, so the origin need not be fitted.

use super::candidates::Effect;
use super::data::TrialData;
use super::predict::{probe_at, tip_path};
use super::residual::Noise;
use super::tip::{MIN_REGISTRATION_FRAMES, free_tip_frames, median};
use mesopush_core::geom::Vec2;
use mesopush_sim::Model;
use mesopush_sim::effects::apply_scale_error;
use serde::Serialize;

/// Grid points per parameter of the coordinate search (its bounds' span in equal steps).
const GRID_POINTS: usize = 21;
/// Golden-section steps refining each coordinate between the grid points beside its best.
const GOLDEN_STEPS: usize = 30;
/// Coordinate-search sweeps over an effect's parameters.
const SWEEPS: usize = 2;

/// One stage or camera effect fitted on the free imaged tip of the training trials.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FreeTipFit {
    /// The effect.
    pub candidate: Effect,
    /// Its own parameters (as [`Effect::effect_params`] lays them out), fitted.
    pub values: Vec<f64>,
    /// Free-tip error on the training trials, noise units (1 at the floor).
    pub train_norm: f64,
    /// Free-tip error on the held-out trials, noise units.
    pub heldout_norm: f64,
}

/// The free imaged tip's errors under the nominal model and each stage/camera effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FreeTip {
    /// The nominal model's free-tip error on the training trials, noise units.
    pub nominal_train_norm: f64,
    /// The nominal model's free-tip error on the held-out trials, noise units.
    pub nominal_heldout_norm: f64,
    /// Free frames counted (training, held-out).
    pub frames: (usize, usize),
    /// One fit per stage/camera candidate, in the candidates' order.
    pub fits: Vec<FreeTipFit>,
}

/// Fits every candidate of `candidates` that shows in the free tip on the training trials'
/// free tip frames and scores it on the held-out ones. `base` and `nominal` (the nominal
/// fit's model and parameters) only carry the parameter layout: the nominal parameters do
/// not move a free tip. `None` when either side has no trial with enough free tip frames to
/// register.
pub fn fit_free_tip(
    candidates: &[Effect],
    base: &Model,
    nominal: &[f64],
    train: &[TrialData],
    heldout: &[TrialData],
    noise: &Noise,
) -> Option<FreeTip> {
    let norm = |c: Effect, e: &[f64], trials: &[TrialData]| {
        let model = c.apply(base, &[nominal, e].concat());
        let (ss, n) =
            trials.iter().map(|t| sum_sq(&model, t)).fold((0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        (n > 0).then(|| ss / (2.0 * noise.tip_um.powi(2) * n as f64))
    };
    let nominal_train_norm = norm(Effect::Nominal, &[], train)?;
    let nominal_heldout_norm = norm(Effect::Nominal, &[], heldout)?;
    let count = |ts: &[TrialData]| ts.iter().map(|t| registered(t).len()).sum::<usize>();
    let fits = candidates
        .iter()
        .filter(|c| c.shows_in_free_tip())
        .map(|&c| {
            let f = |e: &[f64]| norm(c, e, train).unwrap_or(f64::INFINITY);
            let values = coordinate_search(c, &f);
            let heldout_norm = norm(c, &values, heldout).unwrap_or(f64::INFINITY);
            FreeTipFit { candidate: c, train_norm: f(&values), heldout_norm, values }
        })
        .collect();
    Some(FreeTip {
        nominal_train_norm,
        nominal_heldout_norm,
        frames: (count(train), count(heldout)),
        fits,
    })
}

impl FreeTip {
    /// The effect the free tip names: the nominal model's held-out free-tip error is above
    /// the floor band (`floor_factor`) and exactly one effect brings it into the band, by at
    /// least `min_gain`, having lowered the training trials' free-tip error by `min_gain`
    /// too (the same two knobs as every other verdict: nothing tuned for this rule).
    pub fn winner(&self, floor_factor: f64, min_gain: f64) -> Option<Effect> {
        let t0 = self.nominal_heldout_norm;
        if t0.is_nan() || t0 <= floor_factor {
            return None;
        }
        let mut at_floor = self.fits.iter().filter(|f| {
            f.heldout_norm <= floor_factor.min((1.0 - min_gain) * t0)
                && f.train_norm <= (1.0 - min_gain) * self.nominal_train_norm
        });
        let w = at_floor.next()?;
        at_floor.next().is_none().then_some(w.candidate)
    }

    /// The fit of `c`, when it was fitted.
    pub fn fit_of(&self, c: Effect) -> Option<&FreeTipFit> {
        self.fits.iter().find(|f| f.candidate == c)
    }
}

/// The free frames of `t` with enough of them to register the trial (empty otherwise).
fn registered(t: &TrialData) -> Vec<usize> {
    let k = free_tip_frames(t);
    if k.len() >= MIN_REGISTRATION_FRAMES { k } else { Vec::new() }
}

/// The sum of squared registered free-tip residuals of trial `t` under `model`'s stage and
/// camera effects, and how many frames it sums.
fn sum_sq(model: &Model, t: &TrialData) -> (f64, usize) {
    let frames = registered(t);
    if frames.is_empty() || t.cmd.is_empty() {
        return (0.0, 0);
    }
    let fx = &model.effects;
    let path = tip_path(fx, &t.cmd);
    let latency_s = fx.camera_latency_us * 1e-6;
    let d: Vec<Vec2> = frames
        .iter()
        .filter_map(|&k| {
            let m = &t.frames[k];
            let at = probe_at(&path, m.t_s - latency_s);
            Some(m.tip_um? - apply_scale_error(at, fx.scale_error, fx.scale_origin_um))
        })
        .collect();
    let (Some(ox), Some(oy)) =
        (median(d.iter().map(|v| v.x).collect()), median(d.iter().map(|v| v.y).collect()))
    else {
        return (0.0, 0);
    };
    let ss = d.iter().map(|v| (v.x - ox).powi(2) + (v.y - oy).powi(2)).sum();
    (ss, d.len())
}

/// Minimises `f` over `c`'s own parameters within their bounds: per coordinate a grid over
/// the bounds, then golden section between the grid points beside the best, [`SWEEPS`]
/// sweeps from every parameter off. Bounded work (no tolerance loop), deterministic.
fn coordinate_search(c: Effect, f: &dyn Fn(&[f64]) -> f64) -> Vec<f64> {
    let params = c.effect_params();
    let mut x: Vec<f64> = params.iter().map(|p| 0.0f64.clamp(p.lo, p.hi)).collect();
    for _ in 0..SWEEPS {
        for (i, p) in params.iter().enumerate() {
            let at = |v: f64| {
                let mut y = x.clone();
                y[i] = v;
                f(&y)
            };
            let step = (p.hi - p.lo) / (GRID_POINTS - 1) as f64;
            let grid: Vec<f64> = (0..GRID_POINTS).map(|k| p.lo + step * k as f64).collect();
            let vals: Vec<f64> = grid.iter().map(|&v| at(v)).collect();
            let best = (0..GRID_POINTS).min_by(|&a, &b| vals[a].total_cmp(&vals[b])).unwrap_or(0);
            let (a, b) = (grid[best.saturating_sub(1)], grid[(best + 1).min(GRID_POINTS - 1)]);
            let v = golden(&at, a, b);
            // Keep the grid's best if the refinement did not beat it (a kink at a bound).
            x[i] = if at(v) <= vals[best] { v } else { grid[best] };
        }
    }
    x
}

/// Golden-section minimum of `f` on `[a, b]` in [`GOLDEN_STEPS`] steps.
fn golden(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..GOLDEN_STEPS {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}

#[cfg(test)]
mod tests {
    //! Trials whose imaged tips the tests make with their own kinematics (not the library's
    //! effect code): a stage with play, a late stamp, an image scale about an origin the
    //! library does not assume, a lead screw the library does not know.
    use super::*;
    use crate::candidates::base_model;
    use crate::data::{Measured, open_plate};
    use mesopush_core::geom::Pose;
    use mesopush_sim::{ProbePoint, Pusher};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// What happens between the command and the image, as the tests' own world has it.
    #[derive(Clone, Copy)]
    enum World {
        Clean,
        /// Full play per axis, µm.
        Play(f64),
        /// Exposure this long before the stamp, s.
        Late(f64),
        /// Image scale error about an origin, µm.
        Scale(f64, [f64; 2]),
        /// A lead screw's periodic error along x: amplitude and pitch, µm.
        Screw(f64, f64),
    }

    /// A command zigzagging over the plate (reversals on both axes), 50 Hz set-points at
    /// 300 µm/s, different for each seed.
    fn command(rng: &mut ChaCha8Rng) -> Vec<ProbePoint> {
        let mut at = Vec2::new(2000.0, 1500.0);
        let mut out = vec![ProbePoint { t_s: 0.0, probe_um: at, probe_theta_rad: 0.0 }];
        for _ in 0..12 {
            let to = Vec2::new(rng.random_range(1000.0..4000.0), rng.random_range(800.0..3000.0));
            let n = ((to - at).norm() / 6.0).ceil().max(1.0) as usize;
            for k in 1..=n {
                let t_s = out.last().map_or(0.0, |p| p.t_s) + 0.02;
                let probe_um = at + (to - at) * (k as f64 / n as f64);
                out.push(ProbePoint { t_s, probe_um, probe_theta_rad: 0.0 });
            }
            at = to;
        }
        out
    }

    /// The commanded position at `t_s`, linear between set-points (the test's own).
    fn commanded(cmd: &[ProbePoint], t_s: f64) -> Vec2 {
        let i = cmd.iter().position(|p| p.t_s > t_s).unwrap_or(cmd.len());
        match i {
            0 => cmd[0].probe_um,
            i if i == cmd.len() => cmd[i - 1].probe_um,
            i => {
                let (a, b) = (&cmd[i - 1], &cmd[i]);
                a.probe_um + (b.probe_um - a.probe_um) * ((t_s - a.t_s) / (b.t_s - a.t_s))
            }
        }
    }

    /// One trial: the peg far off (every frame free), 30 Hz frames, the tip imaged through
    /// `world` with 1 µm of white noise per axis.
    fn trial(world: World, seed: u64) -> TrialData {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cmd = command(&mut rng);
        let end = cmd.last().map_or(0.0, |p| p.t_s);
        // The stage with play: the tip stays until the command is half the play away.
        let tips: Vec<Vec2> = match world {
            World::Play(w) => {
                let mut tip = cmd[0].probe_um;
                cmd.iter()
                    .map(|p| {
                        let d = p.probe_um - tip;
                        tip.x += (d.x.abs() - w / 2.0).max(0.0) * d.x.signum();
                        tip.y += (d.y.abs() - w / 2.0).max(0.0) * d.y.signum();
                        tip
                    })
                    .collect()
            }
            _ => cmd.iter().map(|p| p.probe_um).collect(),
        };
        let stage: Vec<ProbePoint> =
            cmd.iter().zip(&tips).map(|(p, t)| ProbePoint { probe_um: *t, ..*p }).collect();
        let mut gauss = || {
            let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random_range(0.0..1.0));
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let frames = (0..)
            .map(|k| k as f64 / 30.0)
            .take_while(|t| *t <= end)
            .map(|t_s| {
                let exposed = match world {
                    World::Late(d) => t_s - d,
                    _ => t_s,
                };
                let mut p = commanded(&stage, exposed);
                match world {
                    World::Scale(e, o) => p.x = o[0] + (p.x - o[0]) * (1.0 + e),
                    World::Screw(a, pitch) => {
                        p.x += a * (std::f64::consts::TAU * p.x / pitch).sin()
                    }
                    _ => {}
                }
                let tip = p + Vec2::new(gauss(), gauss());
                Measured { t_s, pose: Pose::new(20_000.0, 20_000.0, 0.0), tip_um: Some(tip) }
            })
            .collect();
        TrialData {
            id: format!("t{seed}"),
            index: seed as usize,
            part: mesopush_sim::Model::default().part,
            probe_radius_um: 12.5,
            pusher: Pusher::single(12.5),
            registration_tol_um: None,
            pose_rows_dropped: 0,
            log_gaps_s: Vec::new(),
            fixture: open_plate(),
            cmd,
            frames,
            start_sensitivity: None,
        }
    }

    fn free_tip_of(world: World) -> FreeTip {
        let train: Vec<TrialData> = (1..=3).map(|s| trial(world, s)).collect();
        let heldout: Vec<TrialData> = (4..=6).map(|s| trial(world, s)).collect();
        let noise = Noise { xy_um: 1.0, theta_rad: 0.002, tip_um: 1.0 };
        let base = base_model(&train[0].part);
        let nominal = [0.8, 0.3, 0.0, 0.0];
        fit_free_tip(&Effect::EFFECTS, &base, &nominal, &train, &heldout, &noise).expect("free")
    }

    /// The defaults' knobs (floor factor 5, gain 30 %).
    fn winner(f: &FreeTip) -> Option<Effect> {
        f.winner(5.0, 0.3)
    }

    #[test]
    fn an_image_scale_about_another_origin_is_fitted_whole_on_the_free_tip() {
        let f = free_tip_of(World::Scale(0.02, [700.0, -400.0]));
        assert_eq!(winner(&f), Some(Effect::Scale), "{f:?}");
        let s = &f.fit_of(Effect::Scale).expect("scale").values;
        assert!((s[0] - 0.02).abs() < 5e-4 && s[1].abs() < 5e-4, "{s:?}");
        assert!(f.fit_of(Effect::Scale).expect("scale").heldout_norm < 1.5, "{f:?}");
    }

    #[test]
    fn a_late_stamp_and_a_stage_with_play_are_told_apart() {
        let late = free_tip_of(World::Late(0.070));
        assert_eq!(winner(&late), Some(Effect::Latency), "{late:?}");
        let l = late.fit_of(Effect::Latency).expect("latency").values[0];
        assert!((l - 70e3).abs() < 3e3, "latency {l} µs");
        let play = free_tip_of(World::Play(12.0));
        assert_eq!(winner(&play), Some(Effect::Backlash), "{play:?}");
        let b = &play.fit_of(Effect::Backlash).expect("backlash").values;
        assert!(b.iter().all(|w| (w - 12.0).abs() < 1.0), "play {b:?}");
    }

    #[test]
    fn a_clean_stage_and_a_lead_screw_name_nothing() {
        let clean = free_tip_of(World::Clean);
        assert!(clean.nominal_heldout_norm < 1.5, "{clean:?}");
        assert_eq!(winner(&clean), None);
        // 6 µm over a 500 µm pitch: above the floor band, and no library effect fits it.
        let screw = free_tip_of(World::Screw(6.0, 500.0));
        assert!(screw.nominal_heldout_norm > 5.0, "{screw:?}");
        assert_eq!(winner(&screw), None, "{screw:?}");
    }
}
