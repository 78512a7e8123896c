//! The residual's structure: whiteness (autocorrelation, Ljung–Box), correlation with the
//! inputs (commanded probe velocity, speed, contact force), and conditioning on events and
//! places (after direction reversals, in contact or not, by workspace region). These are the
//! physical signatures the report quotes for an effect, and the description it gives when
//! nothing in the library explains the residual.

use super::residual::{FrameResidual, Noise, Residual};
use mesopush_core::stats::percentile;
use serde::Serialize;

/// Summary numbers of a set of residuals (pooled over trials).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Structure {
    /// Lag-1..5 autocorrelation of the peg position residual (x and y pooled).
    pub autocorr_xy: Vec<f64>,
    /// Ljung–Box Q over 10 lags (x and y pooled) and its p-value against white noise.
    pub ljung_box_q: f64,
    /// p-value of `ljung_box_q` (χ² with 10 dof, Wilson–Hilferty).
    pub ljung_box_p: f64,
    /// Correlation of the position residual with the commanded probe velocity (per axis,
    /// pooled): latency and backlash show here.
    pub corr_velocity: f64,
    /// Correlation of the imaged-tip residual with the commanded velocity (NaN: no tip).
    pub corr_tip_velocity: f64,
    /// Correlation of |tip residual| with the contact force (compliance).
    pub corr_tip_force: f64,
    /// RMS position residual within 0.5 s after a reversal, and elsewhere, µm.
    pub rms_after_reversal_um: [f64; 2],
    /// RMS position residual in contact (force > 0) and out of contact, µm.
    pub rms_contact_um: [f64; 2],
    /// RMS position residual by workspace quadrant (about the median position), µm.
    pub rms_by_quadrant_um: [f64; 4],
    /// RMS position residual at slow and fast commanded speeds (below / above the median).
    pub rms_by_speed_um: [f64; 2],
    /// Mean position residual per trial in batch order (drift shows as a trend), µm.
    pub mean_by_trial_um: Vec<[f64; 2]>,
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    if n < 3.0 {
        return f64::NAN;
    }
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 { f64::NAN } else { (s / n as f64).sqrt() }
}

fn autocorr(series: &[Vec<f64>], lag: usize) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for v in series {
        let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
        for i in 0..v.len() {
            den += (v[i] - m).powi(2);
            if i >= lag {
                num += (v[i] - m) * (v[i - lag] - m);
            }
        }
    }
    num / den.max(1e-300)
}

/// Upper tail of χ² with `k` dof (Wilson–Hilferty normal approximation).
fn chi2_sf(q: f64, k: f64) -> f64 {
    let z = ((q / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    0.5 * libm_erfc(z / std::f64::consts::SQRT_2)
}

/// erfc by Abramowitz–Stegun 7.1.26 (|error| < 1.5e-7).
fn libm_erfc(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let e = y * (-x * x).exp();
    if x >= 0.0 { e } else { 2.0 - e }
}

impl Structure {
    /// Analyses `residuals` (one per trial, in batch order).
    pub fn of(residuals: &[Residual]) -> Self {
        let frames: Vec<&FrameResidual> = residuals.iter().flat_map(|r| &r.frames).collect();
        let series: Vec<Vec<f64>> = residuals
            .iter()
            .flat_map(|r| [0, 1].map(|a| r.frames.iter().map(|f| f.peg[a]).collect()))
            .collect();
        let n: usize = series.iter().map(Vec::len).sum::<usize>() / 2;
        let acf: Vec<f64> = (1..=10).map(|l| autocorr(&series, l)).collect();
        let q = n as f64
            * (n as f64 + 2.0)
            * acf
                .iter()
                .enumerate()
                .map(|(i, r)| r * r / (n as f64 - i as f64 - 1.0).max(1.0))
                .sum::<f64>();
        let pegv: Vec<f64> = frames.iter().flat_map(|f| f.peg[..2].to_vec()).collect();
        let vel: Vec<f64> =
            frames.iter().flat_map(|f| [f.cmd_vel_um_s.x, f.cmd_vel_um_s.y]).collect();
        let tips: Vec<&FrameResidual> =
            frames.iter().copied().filter(|f| f.tip.is_some()).collect();
        let tipv: Vec<f64> = tips.iter().flat_map(|f| f.tip.unwrap_or([0.0; 2])).collect();
        let tvel: Vec<f64> =
            tips.iter().flat_map(|f| [f.cmd_vel_um_s.x, f.cmd_vel_um_s.y]).collect();
        let tmag: Vec<f64> = tips.iter().map(|f| f.tip.map_or(0.0, |t| t[0].hypot(t[1]))).collect();
        let tforce: Vec<f64> = tips.iter().map(|f| f.force).collect();
        let mag = |f: &&FrameResidual| f.peg[0].hypot(f.peg[1]);
        let split2 = |pred: &dyn Fn(&&FrameResidual) -> bool| {
            [
                rms(frames.iter().filter(|f| pred(f)).map(mag)),
                rms(frames.iter().filter(|f| !pred(f)).map(mag)),
            ]
        };
        // The sample at rank n/2 (the upper median of an even count), 0 when empty.
        let median = |mut v: Vec<f64>| percentile(&mut v, 0.5).unwrap_or(0.0);
        let mx = median(frames.iter().map(|f| f.pos_um.x).collect());
        let my = median(frames.iter().map(|f| f.pos_um.y).collect());
        let ms = median(frames.iter().map(|f| f.cmd_vel_um_s.norm()).collect());
        let quad = |q: usize| {
            rms(frames
                .iter()
                .filter(|f| usize::from(f.pos_um.x > mx) + 2 * usize::from(f.pos_um.y > my) == q)
                .map(mag))
        };
        Structure {
            autocorr_xy: acf[..5].to_vec(),
            ljung_box_q: q,
            ljung_box_p: chi2_sf(q, 10.0),
            corr_velocity: corr(&pegv, &vel),
            corr_tip_velocity: corr(&tipv, &tvel),
            corr_tip_force: corr(&tmag, &tforce),
            rms_after_reversal_um: split2(&|f| f.since_reversal_s < 0.5),
            rms_contact_um: split2(&|f| f.force > 0.0),
            rms_by_quadrant_um: [quad(0), quad(1), quad(2), quad(3)],
            rms_by_speed_um: split2(&|f| f.cmd_vel_um_s.norm() <= ms),
            mean_by_trial_um: residuals
                .iter()
                .map(|r| {
                    let k = r.frames.len().max(1) as f64;
                    [0, 1].map(|a| r.frames.iter().map(|f| f.peg[a]).sum::<f64>() / k)
                })
                .collect(),
        }
    }

    /// A plain-language description (for `unexplained` verdicts and the report).
    pub fn describe(&self, noise: &Noise) -> String {
        let white = if self.ljung_box_p > 0.01 { "white" } else { "correlated in time" };
        format!(
            "residual is {white} (Ljung–Box Q = {:.0}, p = {:.3}; lag-1 autocorrelation {:.2}); \
             correlation with commanded velocity {:.2} (imaged tip: {:.2}); RMS after reversals \
             {:.2} µm vs {:.2} µm elsewhere; in contact {:.2} µm vs {:.2} µm free; by quadrant \
             {:.2}/{:.2}/{:.2}/{:.2} µm; slow {:.2} µm vs fast {:.2} µm; floor {:.2} µm",
            self.ljung_box_q,
            self.ljung_box_p,
            self.autocorr_xy[0],
            self.corr_velocity,
            self.corr_tip_velocity,
            self.rms_after_reversal_um[0],
            self.rms_after_reversal_um[1],
            self.rms_contact_um[0],
            self.rms_contact_um[1],
            self.rms_by_quadrant_um[0],
            self.rms_by_quadrant_um[1],
            self.rms_by_quadrant_um[2],
            self.rms_by_quadrant_um[3],
            self.rms_by_speed_um[0],
            self.rms_by_speed_um[1],
            noise.xy_um,
        )
    }
}
