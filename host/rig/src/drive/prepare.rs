//! The start both clock modes share: [`prepare`] assembles the plant from the world file and
//! the seed, creates the trial directory with its trial.json, and sets up the recorder with
//! the setpoint schedule of the flashed plan; [`Limits`] says how long the loop may run and
//! [`TAIL_US`] how long it goes on after the trial's end.

use super::recorder::Recorder;
use super::spec::TrialSpec;
use crate::Error;
use crate::client::schedule::Schedule;
use crate::client::session::plan_steps;
use crate::plant::assemble::{Assembled, CameraTiming, assemble};
use crate::plant::world::RigWorld;
use mesopush_executor::ExecutorConfig;
use mesopush_firmware_sim::SimRng;
use mesopush_protocol::units::{s_to_us, um_to_nm};
use mesopush_sim::Fixture;
use mesopush_trial::{CalibrationRecord, TrialMeta};
use mesopush_vision::TrackSettings;
use std::path::Path;

/// Time the loop keeps running after the trial's end (frames of the peg at rest), µs.
pub(crate) const TAIL_US: u64 = 300_000;

/// The tail for a camera: [`TAIL_US`], or long enough for two more frames to be exposed and
/// delivered after the end (a slow camera's last frame must show the peg at rest: the
/// verdict is judged on it).
pub(crate) fn tail_us(camera: &CameraTiming) -> u64 {
    TAIL_US.max(2 * camera.period_us + camera.readout_us)
}

/// How long a loop may run.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Limits {
    /// The trial's expected length for the progress bar, s.
    pub total_s: f64,
    /// Give up at this clock time, µs.
    pub max_us: u64,
}

impl Limits {
    /// The limits of a plan that takes `plan_duration_s`: 2 s more expected, 30 s more
    /// allowed.
    fn of(plan_duration_s: f64) -> Result<Self, Error> {
        let total_s = plan_duration_s + 2.0;
        Ok(Self { total_s, max_us: whole_us("trial time limit", plan_duration_s + 30.0)? })
    }
}

/// `s` seconds as whole µs, truncated as the limit always was (so the same seed still ends a
/// run that never finishes on the same step), through the checked conversion: `s_to_us`
/// rounds, so one µs comes off when it rounded up.
fn whole_us(quantity: &'static str, s: f64) -> Result<u64, Error> {
    let rounded = s_to_us(quantity, s)?;
    let us = s * 1e6; // the product `s_to_us` rounded, for the direction it rounded in
    Ok(rounded - u64::from(us - us.floor() >= 0.5))
}

/// Parts shared by both clock modes.
pub(crate) struct Prepared {
    pub rng: SimRng,
    pub world: RigWorld,
    pub recorder: Recorder,
    /// The stage's start, stage nm.
    pub probe_start_nm: (i32, i32),
    pub camera: CameraTiming,
    pub config: ExecutorConfig,
    pub limits: Limits,
    pub segments_expected: u64,
}

fn meta(spec: &TrialSpec, cal: &mesopush_vision::Calibration) -> TrialMeta {
    let mut m = TrialMeta::new(&spec.trial_id, "fwsim", spec.world.model.part.clone());
    m.pusher = mesopush_sim::Pusher::single(spec.world.model.probe_radius_um);
    m.fixture = Some(Fixture::paper());
    m.plan = Some(spec.plan.clone());
    m.calibration = Some(CalibrationRecord::from(cal));
    m.frame_period_us = Some(spec.world.spec.camera.period_us as f64);
    m.seeds.insert("seed".into(), spec.seed);
    m.world = Some(spec.world.description());
    m
}

/// Assembles the plant for `spec`, creates the trial directory `out_dir` and the recorder.
pub(crate) fn prepare(spec: &TrialSpec, out_dir: &Path) -> Result<Prepared, Error> {
    spec.plan.validate()?;
    let rng = SimRng::new(spec.seed);
    let ws = &spec.world.spec;
    let cal = ws.camera.calibration()?;
    let Assembled { mut world, camera, offset_um: offset, .. } =
        assemble(&spec.world, &spec.plan, spec.peg_start, &rng)?;
    let config = ExecutorConfig::DEFAULT;
    let p = spec.plan.probe_start() + offset;
    let probe_start_nm = (um_to_nm("probe start x", p.x)?, um_to_nm("probe start y", p.y)?);
    let schedule = Schedule {
        steps: plan_steps(&spec.plan)?,
        start_nm: (i64::from(probe_start_nm.0), i64::from(probe_start_nm.1)),
        offset_um: offset,
        period_us: config.setpoint_period_us(),
        lead_us: config.start_lead_us,
    };
    let limits = Limits::of(spec.plan.travel_um() / spec.plan.speed_um_s)?;
    let background = world.background();
    let writer = mesopush_trial::TrialWriter::create(out_dir, meta(spec, &cal))?;
    let track = TrackSettings {
        calibration: cal,
        theta_hint_rad: spec.plan.peg_start_pose().theta_rad,
        ..TrackSettings::default()
    };
    // A point-to-point controller gets one move per plan step.
    let segments_expected = if spec.controller.point_to_point() {
        u64::try_from(schedule.steps.len()).unwrap_or(u64::MAX)
    } else {
        schedule.total_us().div_ceil(schedule.period())
    };
    let recorder = Recorder::new(writer, &background, track, schedule)?;
    Ok(Prepared { rng, world, recorder, probe_start_nm, camera, config, limits, segments_expected })
}
