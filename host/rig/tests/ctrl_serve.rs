//! The controller served on a pseudo-terminal keeps running when the executor stops
//! reading: frames wait in a bounded send buffer (the excess dropped and counted, the
//! reliable link resends), and once the executor reads again the frames come through.
//! Regression (issue 19): a write that did not complete within the master's 1 ms timeout
//! ended `mesopush-fwsim` with `Operation timed out`, and the executor then saw a silent
//! controller.

use mesopush_firmware_sim::camera::SimCamera;
use mesopush_firmware_sim::world::{PegPose, World};
use mesopush_firmware_sim::{FaultConfig, SimRng};
use mesopush_rig::plant::controller::controller;
use mesopush_rig::plant::ctrl_serve::{LineState, ServedController, ServedLine, TX_QUEUE_FRAMES};
use mesopush_rig::plant::vendor::Plant;
use serialport::{SerialPort, TTYPort};
use std::io::Read;
use std::time::Duration;

struct Still;

impl World for Still {
    type Frame = ();
    fn step(&mut self, _: u64, _: (i32, i32)) -> PegPose {
        PegPose { x_um: 0.0, y_um: 0.0, theta_rad: 0.0 }
    }
    fn render(&mut self, _: u64) {}
}

#[test]
fn an_executor_that_stops_reading_does_not_stop_the_controller() {
    let (master, mut slave) = TTYPort::pair().expect("a pty");
    let rng = SimRng::new(4);
    let limit_um = mesopush_sim::Model::default().probe_deflection_limit_um;
    let node = controller(FaultConfig::NONE, rng.fork(1), 0, (1_000_000, 1_000_000), limit_um)
        .expect("a valid limit");
    let camera = SimCamera::new(1_000_000_000, 0, 1_000_000_000, rng.fork(6), FaultConfig::NONE);
    let mut ctrl =
        ServedController::new(ServedLine::Pty(master), Plant::Native(Box::new(node)), camera)
            .expect("served");
    // 30 s of controller time without the executor reading a byte.
    let mut now_us = 0;
    for _ in 0..3_000 {
        now_us += 10_000;
        let (line, _) = ctrl.step(now_us, &mut Still).expect("the controller keeps running");
        assert_eq!(line, LineState::Connected);
        assert!(ctrl.tx_queued_frames() <= TX_QUEUE_FRAMES);
    }
    assert!(ctrl.tx_dropped_frames() > 0, "the line filled up (else this test proves nothing)");
    // The executor reads again: the line drains and fresh frames follow.
    slave.set_timeout(Duration::from_millis(1)).unwrap();
    let mut buf = [0u8; 4096];
    let mut read = 0;
    for _ in 0..2_000 {
        now_us += 10_000;
        ctrl.step(now_us, &mut Still).expect("the controller keeps running");
        while let Ok(n @ 1..) = slave.read(&mut buf) {
            read += n;
        }
        if ctrl.tx_queued_frames() == 0 && read > 64 * 1024 {
            break;
        }
    }
    assert_eq!(ctrl.tx_queued_frames(), 0, "the send queue drained");
    assert!(read > 64 * 1024, "{read} bytes read: the backlog and fresh frames");
}
