//! The `sim` runner: the host simulator stands in for the rig. Per trial: the synthetic
//! camera estimates the start (see [`mesopush_rig::plant::start_camera`], [`super::policy`]), the plan is chosen and shifted for
//! it, the quasi-static simulator replays that plan from the world's true (perturbed) start,
//! and a real trial log is written with `TrialWriter`: probe.csv from the plan's path,
//! pose.csv from the replay's samples (simulator truth), frames.csv from the camera phase,
//! events.csv. No executor, no firmware, no link: its faults are the camera's only. Fast —
//! for Monte-Carlo-style batches.

use super::policy::{adapt, nearest_plan};
use super::runner::{Cancel, TrialJob, TrialResult, TrialRunner, TrialVerdict};
use super::spec::StartCameraSpec;
use crate::Error;
use mesopush_core::geom::Pose;
use mesopush_rig::FaultCount;
use mesopush_rig::plant::start_camera::{Camera, FRAME_PERIOD_US, StartEstimate};
use mesopush_sim::{Fixture, Model, Replay, SimSettings, Simulator, replay};
use mesopush_trial::{EventRow, Outcome, PoseRow, ProbeRow, TrialMeta, TrialState, TrialWriter};
use mesopush_vision::{Calibration, RenderSettings};
use rand::SeedableRng;
use std::path::Path;

/// The simulator-backed runner.
#[derive(Debug)]
pub struct SimRunner {
    /// Built afresh for every trial (`Simulator::new`, validated once here): a simulator
    /// carries warm-start state from one replay to the next, and a trial must not depend on
    /// the ones before it (shards and resumed runs see other predecessors).
    model: Model,
    fixture: Fixture,
    camera: Option<Camera>,
    world: serde_json::Value,
}

impl SimRunner {
    /// A runner over `model` in `fixture`; `theta_hint_rad` orients the tracker; `world` is
    /// recorded verbatim in every trial.json.
    pub fn new(
        model: Model,
        fixture: Fixture,
        camera: &StartCameraSpec,
        theta_hint_rad: f64,
        world: serde_json::Value,
    ) -> Result<Self, Error> {
        let camera = if camera.estimate_start {
            let peg = model.part.polygon().clone();
            Some(Camera::new(
                RenderSettings::default(),
                &fixture.walls,
                &peg,
                theta_hint_rad,
                camera.frame_faults(),
            )?)
        } else {
            None
        };
        Simulator::new(model.clone(), fixture.clone(), SimSettings::default())?;
        Ok(Self { model, fixture, camera, world })
    }
}

fn us(t_s: f64) -> i64 {
    (t_s * 1e6).round() as i64
}

fn event(t_us: i64, kind: &str, detail: impl Into<String>) -> EventRow {
    EventRow { t_us, kind: kind.into(), detail: detail.into() }
}

fn base_result(plan_name: String) -> TrialResult {
    super::supervise::engine_verdict(TrialVerdict::Error, String::new()).with_plan(plan_name)
}

impl TrialResult {
    fn with_plan(mut self, plan_name: String) -> Self {
        self.plan_name = plan_name;
        self
    }
}

impl SimRunner {
    fn meta(&self, job: &TrialJob) -> TrialMeta {
        let mut meta = TrialMeta::new(job.trial_id.clone(), "sim", self.model.part.clone());
        meta.pusher = mesopush_sim::Pusher::single(self.model.probe_radius_um);
        meta.fixture = Some(self.fixture.clone());
        meta.seeds.insert("trial".into(), job.trial_seed);
        meta.seeds.insert("attempt".into(), job.attempt_seed);
        let mut world = self.world.clone();
        if let Some(o) = world.as_object_mut() {
            o.insert("peg_start_truth".into(), serde_json::json!(job.peg_start));
        }
        meta.world = Some(world);
        if self.camera.is_some() {
            meta.calibration = Some((&Calibration::default()).into());
            meta.frame_period_us = Some(FRAME_PERIOD_US as f64);
        }
        meta
    }

    fn write_replay(w: &mut TrialWriter, r: &Replay) -> Result<(), Error> {
        for s in &r.samples {
            let t_us = us(s.t_s);
            let [x, y] = s.probe_um;
            w.probe(&ProbeRow {
                t_us,
                cmd_x_um: x,
                cmd_y_um: y,
                rep_x_um: None,
                rep_y_um: None,
                cmd_theta_rad: None,
            })?;
            let p = s.peg;
            w.pose(&PoseRow {
                t_us,
                x_um: p.x_um,
                y_um: p.y_um,
                theta_rad: p.theta_rad,
                frame_index: None,
                residual_px: None,
                probe_tip_x_um: None,
                probe_tip_y_um: None,
            })?;
        }
        for e in &r.events {
            w.event(&event(us(e.t_s), "jam", format!("move {}: {}", e.move_index + 1, e.what)))?;
        }
        Ok(())
    }
}

impl TrialRunner for SimRunner {
    fn name(&self) -> &'static str {
        "sim"
    }

    fn run(&mut self, job: &TrialJob, dir: &Path, cancel: &Cancel) -> Result<TrialResult, Error> {
        cancel.check()?;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(job.attempt_seed);
        let mut out = base_result(String::new());
        let mut meta = self.meta(job);
        let nominal = &job.plans[0];
        let est = self
            .camera
            .as_mut()
            .map(|c| c.estimate(job.peg_start, nominal.probe_start(), &mut rng));
        let plan = match est.as_ref().map(|e| e.pose) {
            None => nominal.clone(),
            Some(None) => {
                meta.plan = Some(nominal.clone());
                let e = est.as_ref().expect("camera ran");
                return no_start_pose(dir, meta, e, out);
            }
            Some(Some(p)) => {
                let char_len = self.model.part.char_length_um();
                adapt(&job.plans[nearest_plan(&job.plans, &p, char_len)], &p)
            }
        };
        cancel.check()?;
        meta.plan = Some(plan.clone());
        let mut w = TrialWriter::create(dir, meta)?;
        if let Some(e) = &est {
            e.frames.iter().try_for_each(|f| w.frame(f))?;
            out.frames = e.frames.len() as u64;
            out.dropped_frames = e.injected;
            out.faults_injected = e.injected;
            out.faults_detected = e.detected;
            out.faults.camera = FaultCount { injected: e.injected, detected: e.detected };
            out.estimated_start = e.pose;
            out.track_error_um_max = e.pose.map_or(0.0, |p| err_um(&p, &job.peg_start));
        }
        w.event(&event(0, "started", format!("plan {:?}", plan.name)))?;
        out.plan_name = plan.name.clone();
        let mut sim =
            Simulator::new(self.model.clone(), self.fixture.clone(), SimSettings::default())?;
        let r = match replay(&mut sim, &plan, Some(job.peg_start)) {
            Ok(r) => r,
            Err(e) => {
                let why = format!("simulator: {e}");
                w.event(&event(0, "aborted", why.clone()))?;
                w.finish(Outcome {
                    state: TrialState::Aborted,
                    reason: Some(why.clone()),
                    inserted: None,
                })?;
                out.reason = why;
                return Ok(out);
            }
        };
        cancel.check()?;
        Self::write_replay(&mut w, &r)?;
        let t_end = r.samples.last().map_or(0.0, |s| s.t_s);
        let (verdict, why) = judge(&r, &self.fixture);
        w.event(&event(us(t_end), "verdict", why.clone()))?;
        w.finish(Outcome {
            state: TrialState::Done,
            reason: Some(why.clone()),
            inserted: Some(r.inserted),
        })?;
        out.verdict = verdict;
        out.reason = why;
        out.final_pose = Some(r.final_pose);
        out.sim_time_s = t_end;
        Ok(out)
    }
}

/// The camera phase gave no start pose: a detected fault; the probe never moved.
pub(super) fn no_start_pose(
    dir: &Path,
    meta: TrialMeta,
    e: &StartEstimate,
    mut out: TrialResult,
) -> Result<TrialResult, Error> {
    let mut w = TrialWriter::create(dir, meta)?;
    e.frames.iter().try_for_each(|f| w.frame(f))?;
    let why = format!(
        "no start pose: {} frames, {} dropped/black, {} untracked; probe not moved",
        e.frames.len(),
        e.injected,
        e.untracked
    );
    w.event(&event(0, "fault", why.clone()))?;
    let outcome = Outcome { state: TrialState::Faulted, reason: Some(why.clone()), inserted: None };
    w.finish(outcome)?;
    out.verdict = TrialVerdict::Faulted;
    out.reason = why;
    out.frames = e.frames.len() as u64;
    out.dropped_frames = e.injected;
    out.faults_injected = e.injected;
    out.faults_detected = e.detected;
    out.faults.camera = FaultCount { injected: e.injected, detected: e.detected };
    Ok(out)
}

fn err_um(a: &Pose, b: &Pose) -> f64 {
    (a.position() - b.position()).norm()
}

/// Inserted or missed; the reason's class (before the `:`) says how it missed.
fn judge(r: &Replay, fixture: &Fixture) -> (TrialVerdict, String) {
    let d = fixture.goal.signed_distance(&r.final_pose.position());
    let jams = r.events.len();
    if r.inserted {
        return (TrialVerdict::Inserted, format!("inserted: COM {:.0} µm inside the channel", -d));
    }
    let how = if jams > 0 { "missed after a jam" } else { "missed" };
    if r.peg_in_goal {
        // In the goal by the fixture's rule, but the needle was bent beyond its limit.
        return (
            TrialVerdict::Missed,
            format!(
                "{how}, the needle overloaded: the peg ended in the goal, the verdict does not count it"
            ),
        );
    }
    if d <= -fixture.insert_depth_um {
        // Deep enough by the centre-of-mass rule: the fixture asks for the whole part inside.
        let why = "part not wholly inside the channel (the fixture's goal_whole_part)";
        return (TrialVerdict::Missed, format!("{how}, {why}: COM {:.0} µm deep", -d));
    }
    if d < 0.0 {
        (TrialVerdict::Missed, format!("{how}, COM in the channel mouth: only {:.0} µm deep", -d))
    } else {
        (
            TrialVerdict::Missed,
            format!("{how}, COM short of the channel: {d:.0} µm outside; {jams} jam(s)"),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_sim::Plan;

    fn judged(model: Model, fixture: Fixture) -> (TrialVerdict, String) {
        let mut sim = Simulator::new(model, fixture.clone(), SimSettings::default()).unwrap();
        let r = replay(&mut sim, &Plan::table2(), None).unwrap();
        judge(&r, &fixture)
    }

    /// The miss text spoke only of the centre of mass: a peg in the goal with the needle
    /// overloaded, or deep enough by its centre but not wholly inside a `goal_whole_part`
    /// channel, was reported "only N µm deep" with N beyond the insert depth.
    #[test]
    fn a_miss_says_whether_the_needle_or_the_whole_part_rule_refused_it() {
        let (v, why) = judged(Model::default(), Fixture::paper());
        assert_eq!(v, TrialVerdict::Inserted, "{why}");
        let weak = Model { probe_deflection_limit_um: 1e-3, ..Model::default() };
        let (v, why) = judged(weak, Fixture::paper());
        assert_eq!(v, TrialVerdict::Missed, "{why}");
        assert!(why.contains("needle overloaded"), "{why}");
        // Table II's peg ends at y ≈ 1508 µm, 985 µm wide: a goal 600 µm tall around it holds
        // its centre 300 µm deep but not its outline.
        let narrow = mesopush_sim::fixture::rect(-3000.0, 1200.0, 525.0, 1800.0).unwrap();
        let whole = Fixture { goal: narrow, goal_whole_part: true, ..Fixture::paper() };
        let (v, why) = judged(Model::default(), whole);
        assert_eq!(v, TrialVerdict::Missed, "{why}");
        assert!(why.contains("not wholly inside"), "{why}");
    }
}
