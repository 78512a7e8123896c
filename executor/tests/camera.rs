//! Camera stamping during a trial: time base, probe position at exposure, drop detection.

mod common;

use common::{Rig, square_plan};
use mesopush_executor::camera::{PositionSource, SeqCheck, StampSource};
use mesopush_executor::{CameraFrame, ExecutorConfig, Input, LogEvent, StampedFrame};
use mesopush_protocol::host::{ExecState, HostToExec};

fn stamped(rig: &Rig) -> Vec<StampedFrame> {
    rig.logs
        .iter()
        .filter_map(|e| match e {
            LogEvent::Frame(f) => Some(*f),
            _ => None,
        })
        .collect()
}

#[test]
fn frames_carry_the_probe_position_at_exposure() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    // One step: 100 µm along +x at 140 µm/s.
    let step = mesopush_protocol::flash::PlanStep { dx_nm: 100_000, dy_nm: 0, speed_nm_s: 140_000 };
    rig.flash_steps(7, &[step]);
    rig.run_for(200_000);
    rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    rig.host(HostToExec::Start { plan_id: 7 });
    let mut seq = 0;
    while rig.exec.state() == ExecState::Running {
        rig.run_for(33_000);
        seq += if seq == 5 { 2 } else { 1 }; // frame 6 is dropped
        // Exposure 20 ms before arrival, stamped by the driver (executor clock).
        let frame = CameraFrame {
            frame_seq: seq,
            driver_stamp_us: Some(rig.now_us - 20_000),
            black: false,
        };
        rig.input(Input::Frame(frame));
    }
    let frames = stamped(&rig);
    assert!(frames.len() > 15);
    assert!(frames.iter().all(|f| f.source == StampSource::Driver));
    assert_eq!(frames.iter().filter(|f| f.seq == SeqCheck::Gap { dropped: 1 }).count(), 1);
    assert_eq!(rig.exec.frames().dropped, 1);
    // While moving, the probe is at x = x0 + 140 nm/ms × (t − t_start); reports come every
    // 10 ms and the position is interpolated between them: within 1 µm of the truth.
    let start_exec_us = rig.logs.iter().find_map(|e| match e {
        LogEvent::Trial(t) => Some(t.exec_time_us),
        _ => None,
    });
    let t0 = start_exec_us.unwrap() + ExecutorConfig::DEFAULT.start_lead_us;
    let mut checked = 0;
    for f in &frames {
        let t = f.stamp.frame_stamp_us;
        if f.position != PositionSource::Interpolated || t < t0 + 20_000 || t > t0 + 690_000 {
            continue;
        }
        let expect_x = 1_000_000 + ((t - t0) as f64 * 0.14) as i32;
        assert!(
            (f.stamp.probe_x_nm - expect_x).abs() <= 1_500,
            "t {t}: {} vs {expect_x}",
            f.stamp.probe_x_nm
        );
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} frames checked");
}

#[test]
fn frames_without_a_driver_stamp_use_arrival_time() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.run_for(50_000);
    rig.input(Input::Frame(CameraFrame { frame_seq: 4, driver_stamp_us: None, black: true }));
    let f = stamped(&rig)[0];
    assert_eq!(
        (f.source, f.stamp.frame_stamp_us, f.black),
        (StampSource::Arrival, rig.now_us, true)
    );
    assert_eq!(f.position, PositionSource::LatestReport);
    assert_eq!((f.stamp.probe_x_nm, f.stamp.probe_y_nm), (1_000_000, 1_000_000));
}

#[test]
fn a_plan_of_square_moves_is_unaffected_by_frames() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    rig.flash_steps(7, &square_plan(4));
    rig.run_for(200_000);
    rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    rig.host(HostToExec::Start { plan_id: 7 });
    for seq in 0..40 {
        rig.run_for(33_333);
        rig.input(Input::Frame(CameraFrame {
            frame_seq: seq,
            driver_stamp_us: None,
            black: false,
        }));
    }
    assert_eq!(rig.exec.state(), ExecState::Done);
    assert_eq!(rig.ctrl.pos, (1_000_000, 1_000_000));
}
