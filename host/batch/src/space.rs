//! Free disk space for a batch: an estimate of what one trial writes, a refusal before a
//! batch starts when the trials left will not fit, and a clean stop before a trial when the
//! disk is nearly full (the journal is consistent between trials, so the same command
//! resumes once space is freed). The free-space figure comes from a [`FreeSpace`] source
//! (`statvfs` on the output filesystem; tests inject a small disk, never fill a real one).

use super::spec::BatchSpec;
use crate::Error;
use mesopush_rig::WorldFile;
use mesopush_sim::Plan;
use mesopush_trial::FrameRetention;
use std::path::Path;
use std::sync::Arc;

/// Bytes every trial writes besides frame images (trial.json, CSVs, figures); measured
/// trials write 0.2–0.6 MB, so this is an upper bound.
pub const TRIAL_OVERHEAD_BYTES: u64 = 2 << 20;
/// Free space kept untouched by default, bytes: a batch stops before a trial that would
/// leave less (the trial's own estimate comes on top).
pub const DEFAULT_MARGIN_BYTES: u64 = 100_000_000;

/// Where the free-space figure comes from.
pub trait FreeSpace: std::fmt::Debug + Send + Sync {
    /// Bytes an unprivileged writer may still use on the filesystem holding `dir`.
    fn free_bytes(&self, dir: &Path) -> Result<u64, Error>;
}

/// The real figure: `statvfs` (available blocks × fragment size).
#[derive(Debug, Clone, Copy, Default)]
pub struct DiskFree;

impl FreeSpace for DiskFree {
    fn free_bytes(&self, dir: &Path) -> Result<u64, Error> {
        let s = rustix::fs::statvfs(dir).map_err(|e| Error::io(dir, e.into()))?;
        Ok(s.f_bavail.saturating_mul(s.f_frsize))
    }
}

/// The free-space policy of a run.
#[derive(Debug, Clone)]
pub struct SpaceCheck {
    /// What one trial is expected to write, bytes (see [`estimate_trial_bytes`]).
    pub trial_bytes: u64,
    /// Free space never used, bytes.
    pub margin_bytes: u64,
    /// Start even when the trials left do not fit (`--ignore-free-space`); the stop before
    /// a trial that would eat into the margin still applies.
    pub ignore_at_start: bool,
    /// The free-space source.
    pub free: Arc<dyn FreeSpace>,
}

impl Default for SpaceCheck {
    fn default() -> Self {
        Self {
            trial_bytes: TRIAL_OVERHEAD_BYTES,
            margin_bytes: DEFAULT_MARGIN_BYTES,
            ignore_at_start: false,
            free: Arc::new(DiskFree),
        }
    }
}

fn mb(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

impl SpaceCheck {
    /// Refuses (naming the need and the free space) when `trials` more trials and the
    /// margin do not fit on the filesystem of `dir`, unless told to ignore it.
    pub fn before_start(&self, dir: &Path, trials: u64) -> Result<(), Error> {
        let free = self.free.free_bytes(dir)?;
        let need = self.trial_bytes.saturating_mul(trials).saturating_add(self.margin_bytes);
        if free >= need || self.ignore_at_start || trials == 0 {
            return Ok(());
        }
        Err(Error::invalid(
            "free space",
            format!(
                "{} trials × {} each + {} margin = {} needed on the filesystem of {}, {} free; \
                 free space, keep fewer frames (frames = \"failed\", \"every N\" or \"none\"), \
                 run fewer trials (--max-trials), or start anyway with --ignore-free-space",
                trials,
                mb(self.trial_bytes),
                mb(self.margin_bytes),
                mb(need),
                dir.display(),
                mb(free)
            ),
        ))
    }

    /// `Some(why)` when the next trial would leave less than the margin free.
    pub fn before_trial(&self, dir: &Path) -> Result<Option<String>, Error> {
        let free = self.free.free_bytes(dir)?;
        let need = self.trial_bytes.saturating_add(self.margin_bytes);
        Ok((free < need).then(|| {
            format!(
                "{} free on the filesystem of {}, a trial needs {} plus the {} margin; free \
                 space and run the same command again to resume",
                mb(free),
                dir.display(),
                mb(self.trial_bytes),
                mb(self.margin_bytes)
            )
        }))
    }
}

/// An upper bound of what one trial of `spec` writes: for the `rig` runner, every frame of
/// the longest plan (its travel at its speed, plus 2 s of lead and tail) at the camera's
/// size and period, uncompressed (the store compresses; measured ratios in docs/batch.md),
/// scaled by the share of frames `spec.frames` keeps (`failed` counts as all: any trial may
/// fail); plus [`TRIAL_OVERHEAD_BYTES`]. The `sim` runner stores no frames.
pub fn estimate_trial_bytes(spec: &BatchSpec, base: &Path, plans: &[Plan]) -> Result<u64, Error> {
    if spec.runner != "rig" {
        return Ok(TRIAL_OVERHEAD_BYTES);
    }
    let world = match &spec.world.file {
        Some(p) => WorldFile::load(&base.join(p))?,
        None => WorldFile::default_world(),
    };
    let cam = &world.spec.camera;
    let period_us = spec.camera.film_period_us.unwrap_or(cam.period_us).max(1);
    let longest_s = plans.iter().map(|p| p.travel_um() / p.speed_um_s).fold(0.0, f64::max) + 2.0;
    let frames = (longest_s * 1e6 / period_us as f64).ceil() as u64;
    let kept = match spec.frames {
        FrameRetention::All | FrameRetention::Failed => frames,
        FrameRetention::Every(n) => frames.div_ceil(u64::from(n)),
        FrameRetention::None => 0,
    };
    let frame_bytes = u64::from(cam.size_px[0]) * u64::from(cam.size_px[1]);
    Ok(kept.saturating_mul(frame_bytes).saturating_add(TRIAL_OVERHEAD_BYTES))
}
