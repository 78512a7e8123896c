//! One trial through the whole loop: [`run_trial`] assembles the plant from the world file
//! and the seed, runs the loop (simulated or real time), lets the recorder write and track,
//! and judges the verdict from the tracked poses. Simulated time is deterministic: the same
//! seed gives a byte-identical trial directory.

use super::finish::{Finished, finish};
use super::prepare::{Limits, prepare, tail_us};
use super::realtime::run_realtime;
use super::simloop::{STEP_US, SimLoop};
use super::spec::{ClockMode, TrialProgress, TrialReport, TrialSpec};
use crate::Error;
use crate::client::session::{HostSession, SessionGoal};
use crate::plant::world_file::validated_faults;
use mesopush_protocol::host::StagePoint;
use mesopush_protocol::units::us_to_s;
use std::path::Path;

/// Runs one trial into `out_dir` (created; must not hold a trial). `progress` is called
/// now and then.
pub fn run_trial(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(TrialProgress),
) -> Result<TrialReport, Error> {
    let wall = std::time::Instant::now();
    if spec.clock == ClockMode::Realtime && spec.controller.point_to_point() {
        return Err(Error::invalid(
            "controller",
            "the in-process real-time loop drives the native controller only; run a \
             point-to-point controller in simulated time, or in real time through the \
             three-process flow (mesopush-fwsim --controller, mesopush-executor --controller)",
        ));
    }
    let mut report = match spec.clock {
        ClockMode::Simulated => run_simulated(spec, out_dir, progress)?,
        ClockMode::Realtime => run_realtime(spec, out_dir, progress)?,
    };
    report.wall_time_s = wall.elapsed().as_secs_f64();
    Ok(report)
}

fn run_simulated(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(TrialProgress),
) -> Result<TrialReport, Error> {
    let prep = prepare(spec, out_dir)?;
    let faults = validated_faults(&spec.world.spec.faults)?;
    let session_id = 7_000 + prep.rng.fork(11).below(1000) as u16;
    let start = StagePoint { x_nm: prep.probe_start_nm.0, y_nm: prep.probe_start_nm.1 };
    let host = HostSession::new(&spec.plan, SessionGoal::FlashAndRun, start, session_id)?;
    let (tx, rx) = crossbeam_channel::bounded(256);
    let recorder = prep.recorder;
    let rec = std::thread::spawn(move || recorder.run(rx));
    let tail = tail_us(&prep.camera);
    let mut lp = SimLoop::new(
        &prep.rng,
        spec.controller,
        prep.config,
        faults,
        prep.probe_start_nm,
        host,
        prep.world,
        prep.camera,
        tx,
    )?;
    let result = run_loop(&mut lp, prep.limits, tail, progress);
    let end = lp.host.end().cloned();
    let faults_injected = lp.faults_injected();
    let mut classes = lp.fault_classes();
    let applied = lp.applied();
    // µs → s by multiplication, as always (the report's time must stay bit-identical;
    // `units::us_to_s` divides, which differs in the last bit for some times).
    let sim_time_s = lp.now_us as f64 * 1e-6;
    let world = lp.into_world(); // flushes, then closes the recorder's channel
    let recorded =
        rec.join().map_err(|_| Error::invalid("recorder", "the recorder panicked"))??;
    result?;
    let world = world?;
    let segments_expected = prep.segments_expected;
    let done = Finished {
        end,
        applied,
        segments_expected,
        faults_injected,
        records_lost: 0,
        sim_time_s,
        camera_latency_us: world.camera_latency_us(),
        deflection_limit_um: world.deflection_limit_um(),
    };
    let mut report =
        finish(out_dir, recorded, world.truth(), (world.fixture(), world.peg_body()), done)?;
    classes.controller.detected = report.faults_detected;
    report.faults = classes;
    Ok(report)
}

/// Steps `lp` until `tail` µs after the session's end, or the limit; a failed step ends it.
fn run_loop(
    lp: &mut SimLoop,
    limits: Limits,
    tail: u64,
    progress: &mut dyn FnMut(TrialProgress),
) -> Result<(), Error> {
    let mut ended_at = None;
    while lp.now_us < limits.max_us {
        lp.step()?;
        if lp.now_us % 100_000 < STEP_US {
            progress(TrialProgress { t_s: us_to_s(lp.now_us), total_s: limits.total_s });
        }
        if lp.host.end().is_some() && ended_at.is_none() {
            ended_at = Some(lp.now_us);
        }
        if ended_at.is_some_and(|t| lp.now_us >= t + tail) {
            break;
        }
    }
    Ok(())
}
