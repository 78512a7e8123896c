//! What diagnosis needs from a trial directory: the commanded probe path, the measured peg
//! poses (stamped times), the probe tip as imaged when the tracker wrote it (the optional
//! `probe_tip_x_um, probe_tip_y_um` columns of pose.csv, as `mesopush track` writes them),
//! and the part, probe and fixture the metadata declares. Frames are never needed, so
//! trials tracked elsewhere (metadata + probe.csv + pose.csv) load the same way.

use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_sim::fixture::rect;
use mesopush_sim::{Fixture, Part, ProbePoint, Pusher};
use mesopush_trial::{Trial, files};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// One measured frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The frame's stamp, s since the trial's start.
    pub t_s: f64,
    /// Tracked peg pose.
    pub pose: Pose,
    /// Probe tip as imaged, µm, when tracked.
    pub tip_um: Option<Vec2>,
}

/// A trial ready for diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialData {
    /// `trial_id`.
    pub id: String,
    /// Position in the batch (0-based, in the order given), for drift over a batch.
    pub index: usize,
    /// The pushed part.
    pub part: Part,
    /// Probe tip radius, µm (the imaged tip's; the largest disc of a several-disc pusher).
    pub probe_radius_um: f64,
    /// The pusher (its discs).
    pub pusher: Pusher,
    /// How deep the recorded pusher may start inside the part (trial.json
    /// `registration_tol_um`), µm; `None`: the simulator's default.
    pub registration_tol_um: Option<f64>,
    /// pose.csv rows the loader dropped (stamped slightly before the row above: recording
    /// jitter, docs/trial-log.md), counted so nothing is lost silently.
    pub pose_rows_dropped: usize,
    /// Times of the `log_gap` events, s: the pusher's path before each is not recorded, so a
    /// replay restarts there from the measured pose.
    pub log_gaps_s: Vec<f64>,
    /// The fixture (an open plate when the trial declares none).
    pub fixture: Fixture,
    /// Commanded probe path.
    pub cmd: Vec<ProbePoint>,
    /// Measured frames, in time order.
    pub frames: Vec<Measured>,
    /// Derived, not recorded: how the replay's strokes depend on their measured start poses,
    /// attached to training trials so the fits' loss is profiled over the starts
    /// ([`crate::start_pose`]); `None` as loaded.
    pub start_sensitivity: Option<std::sync::Arc<crate::start_pose::StartSensitivity>>,
}

#[derive(Debug, Deserialize)]
struct TipRow {
    #[serde(default)]
    probe_tip_x_um: Option<f64>,
    #[serde(default)]
    probe_tip_y_um: Option<f64>,
}

/// An open plate: no walls (the goal is a token square far away).
pub fn open_plate() -> Fixture {
    let goal = rect(-20_000.0, -20_000.0, -19_000.0, -19_000.0).expect("constant square");
    Fixture { walls: vec![], goal, insert_depth_um: 100.0, goal_whole_part: false }
}

fn read_tips(dir: &Path, n: usize) -> Result<Vec<Option<Vec2>>, Error> {
    let path = dir.join(files::POSE);
    let mut r = csv::Reader::from_path(&path)
        .map_err(|e| Error::Parse { path: path.clone(), message: e.to_string() })?;
    let mut out = Vec::with_capacity(n);
    for (i, row) in r.deserialize::<TipRow>().enumerate() {
        let row = row.map_err(|e| Error::Parse {
            path: path.clone(),
            message: format!("row {} (line {}): {e}", i + 1, i + 2),
        })?;
        out.push(match (row.probe_tip_x_um, row.probe_tip_y_um) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some(Vec2::new(x, y)),
            _ => None,
        });
    }
    out.resize(n, None);
    Ok(out)
}

impl TrialData {
    /// Loads a trial directory; `index` is its place in the batch.
    pub fn load(dir: &Path, index: usize) -> Result<Self, Error> {
        let trial = Trial::load(dir)?;
        let poses = trial.poses()?;
        let tips = read_tips(dir, poses.len())?;
        let frames: Vec<Measured> = poses
            .iter()
            .zip(tips)
            .filter(|(p, _)| p.x_um.is_finite() && p.y_um.is_finite() && p.theta_rad.is_finite())
            .map(|(p, tip_um)| Measured {
                t_s: p.t_us as f64 * 1e-6,
                pose: Pose::new(p.x_um, p.y_um, p.theta_rad),
                tip_um,
            })
            .collect();
        let cmd = trial.commanded_path();
        if cmd.len() < 2 {
            return Err(Error::invalid(
                "trial",
                format!("{}: probe.csv needs at least two rows", dir.display()),
            ));
        }
        if frames.len() < 8 {
            return Err(Error::invalid(
                "trial",
                format!("{}: pose.csv has {} usable poses (need ≥ 8)", dir.display(), frames.len()),
            ));
        }
        Ok(Self {
            id: trial.meta.trial_id.clone(),
            index,
            part: trial.meta.part.clone(),
            probe_radius_um: trial.meta.pusher().max_radius_um(),
            pusher: trial.meta.pusher(),
            registration_tol_um: trial.meta.registration_tol_um,
            pose_rows_dropped: trial.pose_rows_dropped.len(),
            log_gaps_s: trial
                .events
                .iter()
                .filter(|e| e.kind == "log_gap")
                .map(|e| e.t_us as f64 * 1e-6)
                .collect(),
            fixture: trial.meta.fixture.clone().unwrap_or_else(open_plate),
            cmd,
            frames,
            start_sensitivity: None,
        })
    }

    /// Whether any frame carries an imaged probe tip.
    pub fn has_tips(&self) -> bool {
        self.frames.iter().any(|f| f.tip_um.is_some())
    }
}

/// Loads the trials of `dirs` (each indexed by its place in the list) and splits them: even
/// places train, odd ones are held out. At least two are needed.
pub fn load_split(dirs: &[PathBuf]) -> Result<(Vec<TrialData>, Vec<TrialData>), Error> {
    if dirs.len() < 2 {
        return Err(Error::invalid(
            "trials",
            format!(
                "{} given; diagnosis needs at least two (one to train on, one held out)",
                dirs.len()
            ),
        ));
    }
    let trials: Vec<TrialData> =
        dirs.iter().enumerate().map(|(i, d)| TrialData::load(d, i)).collect::<Result<_, _>>()?;
    Ok(trials.into_iter().partition(|t| t.index % 2 == 0))
}
