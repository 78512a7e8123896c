//! Loading a trial directory. Only `trial.json` and `probe.csv` are required, plus
//! `pose.csv` for anything that compares with measurement: trials tracked elsewhere carry no
//! frames. Every problem is reported with the file and, for CSV, the line.

use super::files;
use super::meta::TrialMeta;
use super::records::{EventRow, FrameRow, PoseRow, ProbeRow};
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_sim::ProbePoint;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// A loaded trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Its directory.
    pub dir: PathBuf,
    /// `trial.json`.
    pub meta: TrialMeta,
    /// `probe.csv`.
    pub probe: Vec<ProbeRow>,
    /// `frames.csv` (empty when absent).
    pub frames: Vec<FrameRow>,
    /// `events.csv` (empty when absent).
    pub events: Vec<EventRow>,
    /// `pose.csv`, when tracked.
    pub pose: Option<Vec<PoseRow>>,
}

fn read_csv<T: DeserializeOwned>(path: &Path, required: bool) -> Result<Option<Vec<T>>, Error> {
    if !path.exists() {
        return if required {
            Err(Error::Io { path: path.to_path_buf(), cause: std::io::ErrorKind::NotFound.into() })
        } else {
            Ok(None)
        };
    }
    let mut r = csv::Reader::from_path(path)
        .map_err(|e| Error::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    let mut rows = Vec::new();
    for (i, row) in r.deserialize().enumerate() {
        let row = row.map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            message: format!("row {} (line {}): {e}", i + 1, i + 2),
        })?;
        rows.push(row);
    }
    Ok(Some(rows))
}

fn check_times(path: &Path, times: impl Iterator<Item = i64>) -> Result<(), Error> {
    let mut last = i64::MIN;
    for (i, t) in times.enumerate() {
        if t < last {
            return Err(Error::Parse {
                path: path.to_path_buf(),
                message: format!(
                    "row {} (line {}): t_us {t} goes backwards (after {last})",
                    i + 1,
                    i + 2
                ),
            });
        }
        last = t;
    }
    Ok(())
}

impl Trial {
    /// Loads `dir`.
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let meta_path = dir.join(files::META);
        let text = std::fs::read_to_string(&meta_path)
            .map_err(|cause| Error::Io { path: meta_path.clone(), cause })?;
        let meta: TrialMeta = serde_json::from_str(&text)
            .map_err(|e| Error::Parse { path: meta_path.clone(), message: e.to_string() })?;
        meta.check()
            .map_err(|e| Error::Parse { path: meta_path.clone(), message: e.to_string() })?;
        let probe: Vec<ProbeRow> = read_csv(&dir.join(files::PROBE), true)?.unwrap_or_default();
        check_times(&dir.join(files::PROBE), probe.iter().map(|r| r.t_us))?;
        let pose: Option<Vec<PoseRow>> = read_csv(&dir.join(files::POSE), false)?;
        if let Some(p) = &pose {
            check_times(&dir.join(files::POSE), p.iter().map(|r| r.t_us))?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            meta,
            probe,
            frames: read_csv(&dir.join(files::FRAMES), false)?.unwrap_or_default(),
            events: read_csv(&dir.join(files::EVENTS), false)?.unwrap_or_default(),
            pose,
        })
    }

    /// The tracked poses, or an error naming the trial when it was never tracked.
    pub fn poses(&self) -> Result<&[PoseRow], Error> {
        match &self.pose {
            Some(p) if !p.is_empty() => Ok(p),
            _ => Err(Error::invalid(
                "trial",
                format!(
                    "{} has no tracked poses (pose.csv); run `mesopush track` first",
                    self.dir.display()
                ),
            )),
        }
    }

    /// The commanded probe path as simulator waypoints.
    pub fn commanded_path(&self) -> Vec<ProbePoint> {
        self.probe
            .iter()
            .map(|r| ProbePoint {
                t_s: r.t_us as f64 * 1e-6,
                probe_um: Vec2::new(r.cmd_x_um, r.cmd_y_um),
                probe_theta_rad: 0.0,
            })
            .collect()
    }

    /// The first tracked pose (the simulation's start).
    pub fn first_pose(&self) -> Result<Pose, Error> {
        let p = self.poses()?[0];
        Ok(Pose::new(p.x_um, p.y_um, p.theta_rad))
    }
}
