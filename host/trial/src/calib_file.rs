//! The camera calibration file (TOML) that `mesopush calibrate` writes and `mesopush track
//! --calibration` and `mesopush run --calibration` read: the `[calibration]` table is the
//! record trial.json's `calibration` holds (µm per pixel along image columns and rows, the
//! fixture origin in the image); `[fit]` and `[[positions]]` say how it was measured (the
//! camera's rotation relative to the stage axes, the residual, the tip seen at each rest
//! position). Readers use `[calibration]` and warn about a rotation the tracker does not
//! model ([`CalibrationFile::rotation_warning`]).

use crate::Error;
use crate::meta::CalibrationRecord;
use mesopush_vision::Calibration;
use mesopush_vision::calib_fit::CalibrationFit;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A camera rotation above this (rad; 0.057°: 3 µm at 3 mm from the fixture origin, under a
/// pixel of the paper's optics) is worth a warning: the tracker takes image and stage axes
/// to be parallel.
pub const ROTATION_WARNING_RAD: f64 = 1e-3;

/// One rest position of a calibration: where the tip was and where it was seen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationPosition {
    /// Commanded tip position in the fixture frame, µm (stage − registration).
    pub fixture_um: [f64; 2],
    /// The tip's median location in the frames at rest there, px.
    pub tip_px: [f64; 2],
    /// Frames at rest in which the tip was located.
    pub frames: usize,
    /// Root-mean-square distance of those frames' tips from the median, px.
    pub spread_px: f64,
}

/// A calibration file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    /// What the tracker uses (trial.json's `calibration` record).
    pub calibration: CalibrationRecord,
    /// How it was fitted (absent in a file written by hand).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<CalibrationFit>,
    /// The positions it was fitted to.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<CalibrationPosition>,
}

impl CalibrationFile {
    /// Reads and checks a calibration file; errors name the file and the field.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let file: Self = toml::from_str(&text)
            .map_err(|e| Error::Parse { path: path.to_path_buf(), message: e.to_string() })?;
        file.checked_calibration()
            .map_err(|e| Error::Parse { path: path.to_path_buf(), message: e.to_string() })?;
        Ok(file)
    }

    /// The calibration, checked (scales finite and positive, origin finite).
    pub fn checked_calibration(&self) -> Result<Calibration, Error> {
        let c = &self.calibration;
        let [ox, oy] = c.origin_px;
        let origin = mesopush_core::geom::Vec2::new(ox, oy);
        Ok(Calibration::new(c.sx_um_per_px, c.sy_um_per_px, origin)?)
    }

    /// The file's text: a header comment, then the tables.
    pub fn to_toml(&self) -> Result<String, Error> {
        let body = toml::to_string_pretty(self)
            .map_err(|e| Error::invalid("calibration file", e.to_string()))?;
        Ok(format!(
            "# Camera calibration (docs/vision.md, \"Calibrating pixel size on a rig\").\n\
             # [calibration] is what the tracker uses (µm per pixel along image columns and\n\
             # rows, the fixture origin in the image, px); [fit] and [[positions]] say how\n\
             # `mesopush calibrate` measured it (rotation in rad, residuals in µm).\n\n{body}"
        ))
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        Ok(mesopush_core::fsx::write_atomic(path, self.to_toml()?.as_bytes())?)
    }

    /// A warning when the fitted rotation exceeds [`ROTATION_WARNING_RAD`], saying what it
    /// costs and what to do.
    pub fn rotation_warning(&self) -> Option<String> {
        let r = self.fit?.rotation_rad;
        (r.abs() > ROTATION_WARNING_RAD).then(|| {
            format!(
                "the camera is turned {:.3}° relative to the stage axes; the tracker takes them \
                 to be parallel, so positions 3 mm from the fixture origin are off by {:.1} µm: \
                 turn the camera (or the stage) and calibrate again",
                r.to_degrees(),
                3000.0 * r.abs()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(rotation_rad: f64) -> CalibrationFile {
        CalibrationFile {
            calibration: CalibrationRecord {
                sx_um_per_px: 5.16,
                sy_um_per_px: 5.15,
                origin_px: [290.5, 4.0],
            },
            fit: Some(CalibrationFit {
                sx_um_per_px: 5.16,
                sy_um_per_px: 5.15,
                rotation_rad,
                origin_px: [290.5, 4.0],
                residual_um_rms: 0.2,
                residual_um_max: 0.3,
                positions: 3,
            }),
            positions: vec![CalibrationPosition {
                fixture_um: [2000.0, 2000.0],
                tip_px: [677.0, 390.0],
                frames: 40,
                spread_px: 0.05,
            }],
        }
    }

    #[test]
    fn a_written_file_reads_back_and_a_hand_written_one_needs_only_the_calibration() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("calibration.toml");
        let f = file(2e-4);
        f.write(&path).unwrap();
        assert_eq!(CalibrationFile::load(&path).unwrap(), f);
        assert!(f.rotation_warning().is_none());
        let hand =
            "[calibration]\nsx_um_per_px = 5.0\nsy_um_per_px = 5.0\norigin_px = [0.0, 0.0]\n";
        std::fs::write(&path, hand).unwrap();
        let h = CalibrationFile::load(&path).unwrap();
        assert_eq!(h.checked_calibration().unwrap().sx_um_per_px, 5.0);
    }

    #[test]
    fn bad_files_are_refused_naming_the_file_and_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        let neg =
            "[calibration]\nsx_um_per_px = -5.0\nsy_um_per_px = 5.0\norigin_px = [0.0, 0.0]\n";
        std::fs::write(&path, neg).unwrap();
        let e = CalibrationFile::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("µm per pixel along x"), "{e}");
        std::fs::write(&path, "[calibration]\nsx_um_per_px = 5.0\n").unwrap();
        let e = CalibrationFile::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("sy_um_per_px"), "{e}");
    }

    #[test]
    fn a_turned_camera_is_warned_about() {
        let w = file(0.01).rotation_warning().unwrap();
        assert!(w.contains("0.573°") && w.contains("30.0 µm"), "{w}");
    }
}
