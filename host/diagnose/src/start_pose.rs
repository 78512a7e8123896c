//! The restart poses' own measurement error, taken out of the training loss. A replay
//! restarts every stroke from the measured resting pose ([`crate::predict`]): the mean of
//! up to 30 frames, so it carries the tracker's noise divided by √n, and that error stays in
//! the whole stroke. Where a stroke is sensitive — a push whose turn depends on µm where
//! the probe meets the part — a start error far inside the noise moves the stroke's end by
//! many noise units, and a fit then bends the support to explain what was only the start's
//! noise. On clean batches of the independent generator this was the largest pull on the
//! support: at the true parameters the rest after one stroke sat 0.9 µm and 0.5 mrad off
//! (271 frames; 0.06 µm standard error), the same stroke replayed from the generator's
//! exact start pose 0.1 µm off; the fitted support moved a point 26 µm to absorb it, and a
//! held-out trial that turns on that point was missed by 10 µm.
//!
//! So each training stroke's start pose is a nuisance parameter with the prior its frames
//! give (mean of the measured rest, σ/√n per axis) and the training loss is minimised over
//! it, linearised: with `r` the stroke's noise-weighted residuals, `J` their derivative by
//! the start pose (a secant over one prior σ, so a stroke whose outcome bends within the
//! start's uncertainty shows it), and `P` the prior's inverse covariance, the start's best
//! correction is `δ = (JᵀJ + P)⁻¹ Jᵀr` and the loss `|r − Jδ|² + δᵀPδ` — the marginal
//! likelihood of the stroke with its start unknown to the measured precision (Woodbury).
//! The correction is held to the start's measured precision, so it cannot explain an
//! effect; what it discounts is exactly what the start's noise could have caused.
//!
//! `J` depends on the model only through which way the strokes go: it is computed once at
//! a reference model ([`attach`]) and held while a fit runs. Held-out errors are never
//! profiled: they are the plain prediction from the measured start.

use super::data::TrialData;
use super::predict::{predict, predict_shifted, segments};
use super::residual::{Noise, Residual};
use mesopush_ident::optim::lm::solve;
use mesopush_sim::{Model, SimSettings};
use rayon::prelude::*;
use std::sync::Arc;

/// How one stroke's predicted peg poses move with its start pose.
#[derive(Debug, Clone, PartialEq)]
struct Stroke {
    /// First frame the stroke predicts.
    first: usize,
    /// Per frame, ∂(peg x, y, θ)/∂(start x, y, θ), each column per the start's 1σ (so the
    /// prior on the scaled start is the identity).
    jac: Vec<[[f64; 3]; 3]>,
}

/// A training trial's start-pose sensitivity, per stroke.
#[derive(Debug, Clone, PartialEq)]
pub struct StartSensitivity {
    strokes: Vec<Stroke>,
}

/// The sensitivity of `data`'s strokes to their start poses under `model`: each stroke's
/// start moved by one prior σ per axis (σ the floor's per-frame noise over √n, n the frames
/// its rest pose averages) and the trial predicted again. `None` when the trial cannot be
/// predicted; a start move that cannot be (the part jams) leaves that column zero.
pub fn sensitivity(
    data: &TrialData,
    model: &Model,
    settings: &SimSettings,
    noise: &Noise,
) -> Option<StartSensitivity> {
    let base = predict(data, model, settings).ok()?;
    let per_frame = [noise.xy_um, noise.xy_um, noise.theta_rad];
    let strokes = segments(data, model)
        .into_iter()
        .enumerate()
        .map(|(i, seg)| {
            let root_n = (seg.rest_frames as f64).sqrt();
            let sigma = per_frame.map(|s| s / root_n);
            let mut jac = vec![[[0.0; 3]; 3]; seg.frames.len()];
            for axis in 0..3 {
                let mut offset = [0.0; 3];
                offset[axis] = sigma[axis];
                let Ok(moved) = predict_shifted(data, model, settings, i, offset) else {
                    continue;
                };
                for (row, f) in jac.iter_mut().zip(seg.frames.clone()) {
                    let (a, b) = (&moved.poses[f], &base.poses[f]);
                    row[0][axis] = (a.x_um - b.x_um) / per_frame[0];
                    row[1][axis] = (a.y_um - b.y_um) / per_frame[1];
                    row[2][axis] = (a.theta_rad - b.theta_rad) / per_frame[2];
                }
            }
            Stroke { first: seg.frames.start, jac }
        })
        .collect();
    Some(StartSensitivity { strokes })
}

/// `trials` with their start-pose sensitivity under `model` attached (in parallel, in
/// order): the training loss of every fit on them is then profiled over the start poses
/// ([`StartSensitivity::profile`]).
pub fn attach(
    trials: &[TrialData],
    model: &Model,
    settings: &SimSettings,
    noise: &Noise,
) -> Vec<TrialData> {
    trials
        .par_iter()
        .map(|t| {
            let mut t = TrialData { start_sensitivity: None, ..t.clone() };
            t.start_sensitivity = sensitivity(&t, model, settings, noise).map(Arc::new);
            t
        })
        .collect()
}

impl StartSensitivity {
    /// Profiles `r` over the start poses: each stroke's peg residuals corrected by its best
    /// start `δ` (in prior σ), returned per stroke so the caller adds `|δ|²` to the loss.
    /// A residual whose frames do not match (another trial) is left as it is.
    pub fn profile(&self, r: &mut Residual, noise: &Noise) -> Vec<[f64; 3]> {
        let w = [noise.xy_um, noise.xy_um, noise.theta_rad];
        let mut deltas = Vec::with_capacity(self.strokes.len());
        for s in &self.strokes {
            let Some(frames) = r.frames.get_mut(s.first..s.first + s.jac.len()) else {
                return deltas;
            };
            let mut a = [[0.0; 3]; 3];
            let mut b = [0.0; 3];
            for (i, row) in a.iter_mut().enumerate() {
                row[i] = 1.0;
            }
            for (f, j) in frames.iter().zip(&s.jac) {
                let e = [f.peg[0] / w[0], f.peg[1] / w[1], f.peg[2] / w[2]];
                for o in 0..3 {
                    for p in 0..3 {
                        b[p] += j[o][p] * e[o];
                        for q in 0..3 {
                            a[p][q] += j[o][p] * j[o][q];
                        }
                    }
                }
            }
            // JᵀJ + I is positive definite; a non-finite residual leaves the start as measured.
            let d = solve(a.map(Vec::from).into(), b.into())
                .filter(|d| d.iter().all(|v| v.is_finite()))
                .map_or([0.0; 3], |d| [d[0], d[1], d[2]]);
            for (f, j) in frames.iter_mut().zip(&s.jac) {
                for o in 0..3 {
                    f.peg[o] -= w[o] * (j[o][0] * d[0] + j[o][1] * d[1] + j[o][2] * d[2]);
                }
            }
            deltas.push(d);
        }
        deltas
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(peg: [f64; 3]) -> crate::residual::FrameResidual {
        crate::residual::FrameResidual {
            t_s: 0.0,
            peg,
            tip: None,
            cmd_vel_um_s: mesopush_core::geom::Vec2::zeros(),
            pos_um: mesopush_core::geom::Vec2::zeros(),
            force: 0.0,
            since_reversal_s: f64::INFINITY,
        }
    }

    /// The profiled loss is the stroke's marginal χ² with the start unknown to its prior:
    /// |r − Jδ|² + |δ|² = rᵀ(I + JJᵀ)⁻¹r (Woodbury), for any J and r; and a stroke whose
    /// residual is exactly what a start error within the prior causes is nearly explained.
    #[test]
    fn profiling_gives_the_marginal_chi_square_of_the_unknown_start() {
        let noise = Noise { xy_um: 0.8, theta_rad: 0.003, tip_um: 1.0 };
        let w = [0.8, 0.8, 0.003];
        // Deterministic "random" numbers.
        let mut seed = 0x9e37_79b9_u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let n = 5;
        let jac: Vec<[[f64; 3]; 3]> =
            (0..n).map(|_| [[0; 3]; 3].map(|row| row.map(|_: i32| 3.0 * next()))).collect();
        let e: Vec<f64> = (0..3 * n).map(|_| next()).collect();
        let stroke = Stroke { first: 1, jac: jac.clone() };
        let sens = StartSensitivity { strokes: vec![stroke] };
        let mut r = Residual {
            frames: std::iter::once(frame([9.0, 9.0, 9.0]))
                .chain((0..n).map(|k| frame([0, 1, 2].map(|o| e[3 * k + o] * w[o]))))
                .collect(),
        };
        let deltas = sens.profile(&mut r, &noise);
        assert_eq!(deltas.len(), 1);
        assert_eq!(r.frames[0].peg, [9.0, 9.0, 9.0], "a frame before the stroke is left alone");
        let profiled: f64 = r.frames[1..]
            .iter()
            .flat_map(|f| (0..3).map(move |o| (f.peg[o] / w[o]).powi(2)))
            .sum::<f64>()
            + deltas[0].iter().map(|d| d * d).sum::<f64>();
        // Reference: rᵀ (I + J Jᵀ)⁻¹ r with J the 3n × 3 stack.
        let jrow = |i: usize| jac[i / 3][i % 3];
        let m: Vec<Vec<f64>> = (0..3 * n)
            .map(|i| {
                (0..3 * n)
                    .map(|k| {
                        let jj: f64 = (0..3).map(|p| jrow(i)[p] * jrow(k)[p]).sum();
                        jj + if i == k { 1.0 } else { 0.0 }
                    })
                    .collect()
            })
            .collect();
        let x = solve(m, e.clone()).unwrap();
        let marginal: f64 = e.iter().zip(&x).map(|(a, b)| a * b).sum();
        let plain: f64 = e.iter().map(|v| v * v).sum();
        assert!((profiled - marginal).abs() < 1e-9 * marginal, "{profiled} vs {marginal}");
        assert!(profiled < plain);

        // A residual that is J times a start error of one prior σ: mostly absorbed.
        let d_true = [1.0, -0.5, 0.8];
        let mut r = Residual {
            frames: std::iter::once(frame([0.0; 3]))
                .chain(
                    jac.iter()
                        .map(|j| {
                            [0, 1, 2]
                                .map(|o| w[o] * (0..3).map(|p| j[o][p] * d_true[p]).sum::<f64>())
                        })
                        .map(frame),
                )
                .collect(),
        };
        let before: f64 =
            r.frames.iter().flat_map(|f| (0..3).map(move |o| (f.peg[o] / w[o]).powi(2))).sum();
        let d = sens.profile(&mut r, &noise)[0];
        let after: f64 = r
            .frames
            .iter()
            .flat_map(|f| (0..3).map(move |o| (f.peg[o] / w[o]).powi(2)))
            .sum::<f64>()
            + d.iter().map(|v| v * v).sum::<f64>();
        assert!(after < 0.2 * before, "{after} of {before}");
        for (got, want) in d.iter().zip(d_true) {
            assert!((got - want).abs() < 0.25, "{d:?} against {d_true:?}");
        }
    }
}
