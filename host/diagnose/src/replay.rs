//! `mesopush replay`: a model's open-loop prediction of recorded trials. Each trial's
//! recorded pusher path is replayed from its first measured pose with the model's physics
//! (its `[effects]` included, as diagnosis predicts) on the trial's own part, pusher and
//! fixture, and the prediction is compared with every measured pose. Where the recording
//! says the pusher's path is unknown (a `log_gap` event), the replay starts again from the
//! first measured pose after the gap (docs/trial-log.md).
//!
//! Errors: `final_error_um` is the distance between the predicted and the measured centre of
//! mass at the last measured pose, `final_error_deg` the signed angle difference (predicted
//! − measured, wrapped to ±180°); `rms_um` and `rms_deg` are the root mean squares of the
//! same over every measured pose.

use crate::Error;
use crate::data::TrialData;
use crate::predict::predict_open_loop;
use mesopush_core::geom::Pose;
use mesopush_ident::figure::TrackPanel;
use mesopush_sim::{Model, SimSettings};
use serde::Serialize;

/// One trial's replay errors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialReplay {
    /// The trial's id.
    pub trial: String,
    /// Distance of the predicted from the measured COM at the last measured pose, µm.
    pub final_error_um: f64,
    /// Predicted − measured angle at the last measured pose, degrees (wrapped to ±180).
    pub final_error_deg: f64,
    /// RMS of the COM distance over the measured poses, µm.
    pub rms_um: f64,
    /// RMS of the angle difference over the measured poses, degrees.
    pub rms_deg: f64,
    /// Measured poses compared.
    pub n_poses: usize,
    /// Path segments on which the simulated part wedged.
    pub jams: usize,
    /// pose.csv rows the loader dropped for recording jitter (not compared).
    pub pose_rows_dropped: usize,
    /// Predicted poses at the measured times (for the figure; not in the JSON).
    #[serde(skip)]
    pub predicted: Vec<(f64, Pose)>,
}

/// The angle `a − b` wrapped to (−π, π].
pub fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI { d - std::f64::consts::TAU } else { d }
}

/// How trials are replayed.
#[derive(Debug, Clone, Default)]
pub struct ReplayOptions {
    /// The simulator's settings for the paper's peg (scaled to each trial's part).
    pub base: SimSettings,
    /// The registration tolerance as a fraction of the part's size, overriding the trials'
    /// `registration_tol_um` and the simulator's default.
    pub registration_tol: Option<f64>,
}

/// The simulator settings for a trial: the base settings with their lengths scaled to the
/// trial's part ([`SimSettings::scaled_to`]; the paper's peg keeps them), and the
/// registration tolerance given, else the trial's own, else the simulator's default.
pub fn settings_for(options: &ReplayOptions, data: &TrialData) -> SimSettings {
    let mut s = options.base.clone().scaled_to(&data.part);
    match (options.registration_tol, data.registration_tol_um) {
        (Some(f), _) => s.registration_tol = f,
        (None, Some(r)) => s.registration_tol = r / data.part.char_length_um(),
        (None, None) => {}
    }
    s
}

/// Replays `data` under `model`; the simulator's error names the trial.
pub fn replay_trial(
    model: &Model,
    data: &TrialData,
    settings: &SimSettings,
) -> Result<TrialReplay, Error> {
    let pred = predict_open_loop(data, model, settings)
        .map_err(|e| Error::invalid("trial", format!("trial {}: {e}", data.id)))?;
    let (mut sq_um, mut sq_deg, mut last) = (0.0, 0.0, (0.0, 0.0));
    for (m, p) in data.frames.iter().zip(&pred.poses) {
        let d_um = (p.position() - m.pose.position()).norm();
        let d_deg = angle_diff(p.theta_rad, m.pose.theta_rad).to_degrees();
        (sq_um, sq_deg, last) = (sq_um + d_um * d_um, sq_deg + d_deg * d_deg, (d_um, d_deg));
    }
    let n = data.frames.len().min(pred.poses.len()).max(1);
    Ok(TrialReplay {
        trial: data.id.clone(),
        final_error_um: last.0,
        final_error_deg: last.1,
        rms_um: (sq_um / n as f64).sqrt(),
        rms_deg: (sq_deg / n as f64).sqrt(),
        n_poses: n,
        jams: pred.jams,
        pose_rows_dropped: data.pose_rows_dropped,
        predicted: data.frames.iter().zip(&pred.poses).map(|(m, p)| (m.t_s, *p)).collect(),
    })
}

/// A trial the replay refused or could not simulate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayFailure {
    /// The trial directory.
    pub trial: String,
    /// Why, in words.
    pub reason: String,
}

/// Replays of a set of trials.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayReport {
    /// One entry per trial replayed, in the order given.
    pub trials: Vec<TrialReplay>,
    /// Trials that could not be loaded or replayed.
    pub failures: Vec<ReplayFailure>,
    /// Median of `final_error_um` over the replayed trials (null when none).
    pub median_final_error_um: Option<f64>,
    /// Median of `|final_error_deg|`.
    pub median_abs_final_error_deg: Option<f64>,
    /// Median of `rms_um`.
    pub median_rms_um: Option<f64>,
    /// Median of `rms_deg`.
    pub median_rms_deg: Option<f64>,
}

/// Loads and replays every trial directory in `dirs` under `model` ([`settings_for`] each); `on_trial` is called after each. A trial that fails is reported
/// in `failures` and the rest go on.
pub fn replay_dirs(
    model: &Model,
    dirs: &[std::path::PathBuf],
    options: &ReplayOptions,
    mut on_trial: impl FnMut(&std::path::Path, Option<&TrialReplay>, &TrialData),
) -> ReplayReport {
    let (mut trials, mut failures) = (Vec::new(), Vec::new());
    for (i, dir) in dirs.iter().enumerate() {
        let result = TrialData::load(dir, i).and_then(|data| {
            let r = replay_trial(model, &data, &settings_for(options, &data))?;
            Ok((r, data))
        });
        match result {
            Ok((r, data)) => {
                on_trial(dir, Some(&r), &data);
                trials.push(r);
            }
            Err(e) => failures
                .push(ReplayFailure { trial: dir.display().to_string(), reason: e.to_string() }),
        }
    }
    let med = |f: &dyn Fn(&TrialReplay) -> f64| {
        let mut v: Vec<f64> = trials.iter().map(f).collect();
        mesopush_core::stats::median(&mut v)
    };
    ReplayReport {
        median_final_error_um: med(&|t| t.final_error_um),
        median_abs_final_error_deg: med(&|t| t.final_error_deg.abs()),
        median_rms_um: med(&|t| t.rms_um),
        median_rms_deg: med(&|t| t.rms_deg),
        trials,
        failures,
    }
}

impl TrialReplay {
    /// This replay as a panel of [`mesopush_ident::figure::draw_tracks`].
    pub fn panel<'a>(&self, data: &'a TrialData) -> TrackPanel<'a> {
        TrackPanel {
            part: &data.part,
            path: &data.cmd,
            measured: data.frames.iter().map(|m| (m.t_s, m.pose)).collect(),
            sim: Some(self.predicted.clone()),
            title: format!(
                "{}: final error {:.1} µm, {:.2}°; RMS {:.1} µm, {:.2}°",
                self.trial, self.final_error_um, self.final_error_deg, self.rms_um, self.rms_deg
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_differences_wrap_to_the_short_way_round() {
        assert!((angle_diff(3.1, -3.1) - (6.2 - std::f64::consts::TAU)).abs() < 1e-12);
        assert!((angle_diff(0.1, 0.3) + 0.2).abs() < 1e-12);
        assert!((angle_diff(-3.1, 3.1) - (std::f64::consts::TAU - 6.2)).abs() < 1e-12);
    }
}
