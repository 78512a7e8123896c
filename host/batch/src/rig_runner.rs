//! The `rig` runner: the whole loop (`host::rig::run_trial` in simulated time) — the plan
//! flashed into the executor, streamed over a pseudo-terminal to the firmware simulator's
//! controller, the simulated stage pushing the peg in the world file's world, the camera
//! filmed, frames stamped, recorded and tracked, the verdict judged from the tracked poses.
//! The world file's faults (link drop / corrupt / duplicate / delay, stall, limit switch,
//! reboot mid-move, dropped and black frames) are injected from the attempt's seed.
//!
//! Before the trial, a pre-trial frame of the world (same renderer, tracker and camera
//! calibration as the world's camera; the batch's `[camera]` faults) gives the start pose
//! the plan is chosen and shifted for (see [`mesopush_rig::plant::start_camera`], [`super::policy`]). The peg start comes from
//! the batch (the world file's own `perturb` is ignored so the start is perturbed once).
//! The batch's `camera.film_period_us`, when set, replaces the world camera's frame period.
//! After the verdict the batch's frame retention (`frames`) is applied to the trial
//! directory (`mesopush_trial::retention`). Cancellation: the loop's progress callback checks the cancel flag every 0.1 s of
//! simulated time and unwinds out of the loop (without the panic hook) when raised.

use super::policy::{adapt, nearest_plan};
use super::runner::{Cancel, TrialJob, TrialResult, TrialRunner, TrialVerdict};
use super::sim_runner::no_start_pose;
use super::spec::StartCameraSpec;
use crate::Error;
use mesopush_rig::plant::start_camera::Camera;
use mesopush_rig::{ClockMode, FaultCount, TrialReport, TrialSpec, WorldFile, run_trial};
use mesopush_sim::Fixture;
use mesopush_trial::{FrameRetention, TrialMeta, TrialState};
use mesopush_vision::RenderSettings;
use rand::SeedableRng;
use std::panic::AssertUnwindSafe;
use std::path::Path;

/// The full-loop runner.
#[derive(Debug)]
pub struct RigRunner {
    world: WorldFile,
    camera: Option<Camera>,
    frames: FrameRetention,
}

/// The unwinding payload that carries a cancellation out of the loop.
#[derive(Debug)]
struct Cancelled;

impl RigRunner {
    /// A runner over `world` (its `peg.perturb` cleared); `theta_hint_rad` orients the
    /// pre-trial tracker.
    pub fn new(
        mut world: WorldFile,
        camera: &StartCameraSpec,
        theta_hint_rad: f64,
    ) -> Result<Self, Error> {
        world.spec.peg.perturb = None;
        if let Some(period_us) = camera.film_period_us {
            world.spec.camera.period_us = period_us;
        }
        let camera = if camera.estimate_start {
            let ws = &world.spec.camera;
            let settings = RenderSettings {
                width_px: ws.size_px[0],
                height_px: ws.size_px[1],
                calibration: ws.calibration()?,
                ..RenderSettings::default()
            };
            let peg = world.model.part.polygon().clone();
            Some(Camera::new(
                settings,
                &Fixture::paper().walls,
                &peg,
                theta_hint_rad,
                camera.frame_faults(),
            )?)
        } else {
            None
        };
        Ok(Self { world, camera, frames: FrameRetention::All })
    }

    /// The runner keeping `frames` of each trial (default all).
    pub fn keeping(mut self, frames: FrameRetention) -> Self {
        self.frames = frames;
        self
    }
}

/// TrialVerdict and reason from the loop's report. A miss after a world jam (the peg wedged, the
/// needle bent beyond its limit) says so: `missed, jammed: …`.
fn verdict(r: &TrialReport) -> (TrialVerdict, String) {
    let why = r.reason.clone().unwrap_or_default();
    let jam = (r.jams > 0).then(|| {
        format!(
            "peg wedged, needle deflected up to {:.0} µm (limit {:.0} µm) in {} jam(s)",
            r.max_deflection_um, r.deflection_limit_um, r.jams
        )
    });
    match (r.state, jam) {
        (TrialState::Done, _) if r.inserted == Some(true) => {
            (TrialVerdict::Inserted, "inserted: last tracked pose inside the channel".into())
        }
        (TrialState::Done, None) if r.inserted.is_none() => {
            (TrialVerdict::Missed, "missed, no tracked final pose: cannot judge".into())
        }
        (TrialState::Done, Some(j)) if r.inserted.is_none() => (
            TrialVerdict::Missed,
            format!("missed, jammed: {j}; no tracked final pose: cannot judge"),
        ),
        (TrialState::Done, None) => {
            (TrialVerdict::Missed, "missed: last tracked pose outside the channel".into())
        }
        (TrialState::Done, Some(j)) => (
            TrialVerdict::Missed,
            format!("missed, jammed: {j}; last tracked pose outside the channel"),
        ),
        (TrialState::Faulted, _) => (TrialVerdict::Faulted, format!("executor fault: {why}")),
        (TrialState::Aborted, _) => (TrialVerdict::Faulted, format!("aborted: {why}")),
        (TrialState::Incomplete, _) => (TrialVerdict::Error, format!("loop did not end: {why}")),
    }
}

impl TrialRunner for RigRunner {
    fn name(&self) -> &'static str {
        "rig"
    }

    fn run(&mut self, job: &TrialJob, dir: &Path, cancel: &Cancel) -> Result<TrialResult, Error> {
        let mut out = super::supervise::engine_verdict(TrialVerdict::Error, String::new());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(job.attempt_seed ^ 0xca3e);
        let nominal = &job.plans[0];
        let mut plan = nominal.clone();
        if let Some(cam) = self.camera.as_mut() {
            let e = cam.estimate(job.peg_start, nominal.probe_start(), &mut rng);
            out.faults_injected += e.injected;
            out.faults_detected += e.detected;
            out.faults.camera = FaultCount { injected: e.injected, detected: e.detected };
            out.dropped_frames += e.injected;
            let Some(p) = e.pose else {
                let mut meta =
                    TrialMeta::new(job.trial_id.clone(), "rig", self.world.model.part.clone());
                meta.fixture = Some(Fixture::paper());
                meta.plan = Some(nominal.clone());
                meta.world = Some(self.world.description());
                return no_start_pose(dir, meta, &e, out);
            };
            let char_len = self.world.model.part.char_length_um();
            plan = adapt(&job.plans[nearest_plan(&job.plans, &p, char_len)], &p);
            out.estimated_start = Some(p);
        }
        let spec = TrialSpec {
            trial_id: job.trial_id.clone(),
            plan: plan.clone(),
            world: self.world.clone(),
            seed: job.attempt_seed,
            clock: ClockMode::Simulated,
            peg_start: Some(job.peg_start),
            controller: mesopush_rig::drive::spec::ControllerKind::Native,
        };
        let mut progress = |_p: mesopush_rig::TrialProgress| {
            if cancel.is_cancelled() {
                std::panic::resume_unwind(Box::new(Cancelled));
            }
        };
        let r = match std::panic::catch_unwind(AssertUnwindSafe(|| {
            run_trial(&spec, dir, &mut progress)
        })) {
            Ok(r) => r?,
            Err(p) if p.is::<Cancelled>() => return cancel.check().map(|()| out),
            Err(p) => std::panic::resume_unwind(p),
        };
        let (v, why) = verdict(&r);
        // poses are tracked, the verdict judged: only images go (counts in trial.json)
        mesopush_trial::retention::apply(&r.dir, self.frames, v == TrialVerdict::Inserted)?;
        out.verdict = v;
        out.reason = why;
        out.plan_name = plan.name;
        out.final_pose = r.final_pose;
        out.frames = r.frames;
        out.dropped_frames += r.dropped_frames;
        // every class's detections: camera, controller and executor-controller link
        out.faults.add(&r.faults);
        out.faults_injected += r.faults_injected;
        out.faults_detected += r.faults.total().detected;
        out.records_lost += r.records_lost;
        out.track_error_um_max = out.track_error_um_max.max(r.track_error_um_max);
        out.sim_time_s = r.sim_time_s;
        Ok(out)
    }
}
