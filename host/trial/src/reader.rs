//! Loading a trial directory. Only `trial.json` and `probe.csv` are required, plus
//! `pose.csv` for anything that compares with measurement: trials tracked elsewhere carry no
//! frames. Every problem is reported with the file and, for CSV, the row, line, column and
//! value; pose rows left out because their time stepped back are counted in the result.

use super::files;
use super::meta::TrialMeta;
use super::records::{EventRow, FrameRow, PoseRow, ProbeRow};
use crate::Error;
use crate::csv_read::read_csv;
use crate::pusher_path::check_theta_column;
use crate::time_order::{DroppedRow, check_ordered, drop_steps_back};
use mesopush_core::geom::{Pose, Vec2};
use mesopush_sim::ProbePoint;
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
    /// `pose.csv`, when tracked, without the rows in [`Trial::pose_rows_dropped`].
    pub pose: Option<Vec<PoseRow>>,
    /// pose.csv rows left out because their time stepped back (within
    /// [`crate::time_order::POSE_STEP_BACK_TOLERANCE_US`]); callers report them.
    pub pose_rows_dropped: Vec<DroppedRow>,
}

/// Parses `trial.json`, naming the field of a refused value by its path.
fn parse_meta(path: &Path, text: &str) -> Result<TrialMeta, Error> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = e.path().to_string();
        if field == "." {
            Error::parse(path, e.inner())
        } else {
            Error::parse(path, format!("field {field}: {}", e.inner()))
        }
    })
}

fn rows_only<T>(rows: Option<Vec<(u64, T)>>) -> Vec<T> {
    rows.unwrap_or_default().into_iter().map(|(_, r)| r).collect()
}

impl Trial {
    /// Loads `dir`.
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let meta_path = dir.join(files::META);
        let text =
            std::fs::read_to_string(&meta_path).map_err(|cause| Error::io(&meta_path, cause))?;
        let meta = parse_meta(&meta_path, &text)?;
        let probe_path = dir.join(files::PROBE);
        let probe = read_csv::<ProbeRow>(&probe_path, true)?.unwrap_or_default();
        let times: Vec<(u64, i64)> = probe.iter().map(|(l, r)| (*l, r.t_us)).collect();
        check_ordered(&probe_path, &times)?;
        check_theta_column(&probe_path, &probe)?;
        let pose_path = dir.join(files::POSE);
        let (pose, pose_rows_dropped) = match read_csv::<PoseRow>(&pose_path, false)? {
            Some(rows) => {
                let (kept, dropped) = drop_steps_back(&pose_path, rows, |r| r.t_us)?;
                (Some(kept), dropped)
            }
            None => (None, Vec::new()),
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            meta,
            probe: rows_only(Some(probe)),
            frames: rows_only(read_csv(&dir.join(files::FRAMES), false)?),
            events: rows_only(read_csv(&dir.join(files::EVENTS), false)?),
            pose,
            pose_rows_dropped,
        })
    }

    /// What loading left out, for a caller to print (`None` when nothing was).
    pub fn load_note(&self) -> Option<String> {
        let d = &self.pose_rows_dropped;
        let first = d.first()?;
        Some(format!(
            "{}: {} pose.csv row(s) dropped because their time stepped back (first: line {}, \
             t_us {} after {})",
            self.dir.display(),
            d.len(),
            first.line,
            first.t_us,
            first.after_t_us
        ))
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

    /// The commanded pusher path as simulator waypoints: the reference point and the angle
    /// (`cmd_theta_rad`, 0 when probe.csv has no such column) per probe.csv row.
    pub fn commanded_path(&self) -> Vec<ProbePoint> {
        self.probe
            .iter()
            .map(|r| ProbePoint {
                t_s: r.t_us as f64 * 1e-6,
                probe_um: Vec2::new(r.cmd_x_um, r.cmd_y_um),
                probe_theta_rad: r.cmd_theta_rad.unwrap_or(0.0),
            })
            .collect()
    }

    /// The first tracked pose (the simulation's start).
    pub fn first_pose(&self) -> Result<Pose, Error> {
        let p = self.poses()?[0];
        Ok(Pose::new(p.x_um, p.y_um, p.theta_rad))
    }
}
