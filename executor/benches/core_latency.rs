//! Latency of the executor core: every `Executor::handle` call of whole trials (hello,
//! flash, arm, start, stream every setpoint, done, with camera frames) at 100 Hz and 1 kHz
//! setpoints against the scripted controller of the tests, timed one by one. Prints mean,
//! percentiles and maximum per call, and the time per streamed segment. Not a test: figures
//! for the real-time budget (a 1 kHz stream leaves 1 ms per segment).

#[path = "../tests/common/mod.rs"]
mod common;

use common::{CAP, Exec, OUT, ScriptedCtrl, image, square_plan};
use mesopush_executor::{CameraFrame, ExecutorConfig, Input, MemStore, Output, Outputs};
use mesopush_protocol::flash::{FlashHeader, image_chunks};
use mesopush_protocol::host::{ExecState, Hello, HostToExec};
use std::time::Instant;

struct Timed<'a> {
    exec: &'a mut Exec,
    ctrl: &'a mut ScriptedCtrl,
    out: Outputs<OUT>,
    samples_ns: Vec<u64>,
}

impl Timed<'_> {
    fn call(&mut self, now_us: u64, input: Input<'_>) {
        let t = Instant::now();
        self.exec.handle(now_us, input, &mut self.out).expect("room");
        self.samples_ns.push(t.elapsed().as_nanos() as u64);
        for o in self.out.iter() {
            if let Output::Ctrl(m) = o {
                self.ctrl.on_msg(now_us, m);
            }
        }
        self.out.clear();
    }
}

fn trial(rate_hz: u32, steps: usize) -> (Vec<u64>, u32, f64) {
    let config = ExecutorConfig { setpoint_rate_hz: rate_hz, ..ExecutorConfig::DEFAULT };
    let img = image(&square_plan(steps));
    let header = FlashHeader::for_image(5, &img).unwrap();
    let mut exec = Exec::new(config, MemStore::<CAP>::new()).unwrap();
    let mut ctrl = Box::new(ScriptedCtrl::new(3_000_000, (1_000_000, 1_000_000)));
    ctrl.report_us = 1_000_000 / u64::from(rate_hz);
    let mut t = Timed {
        exec: &mut exec,
        ctrl: &mut ctrl,
        out: Outputs::new(),
        samples_ns: Vec::with_capacity(1 << 20),
    };
    let mut now_us = 1_000;
    t.call(now_us, Input::Host(&HostToExec::Hello(Hello::CURRENT)));
    t.call(now_us, Input::Host(&HostToExec::FlashBegin(header)));
    for chunk in image_chunks(5, &img) {
        t.call(now_us, Input::Host(&HostToExec::FlashChunk(chunk)));
    }
    t.call(now_us, Input::Host(&HostToExec::FlashCommit { plan_id: 5 }));
    let step_us = 250;
    let wall = Instant::now();
    for i in 0u64.. {
        now_us += step_us;
        t.ctrl.tick(now_us);
        while let Some(m) = t.ctrl.pop() {
            t.call(now_us, Input::Ctrl(&m));
        }
        if i % 133 == 0 {
            t.call(
                now_us,
                Input::Frame(CameraFrame {
                    frame_seq: (i / 133) as u32,
                    driver_stamp_us: None,
                    black: false,
                }),
            );
        }
        if i % 400 == 0 {
            t.call(now_us, Input::Host(&HostToExec::Heartbeat { host_time_us: now_us }));
        }
        match i {
            800 => {
                t.call(now_us, Input::Host(&HostToExec::Arm { plan_id: 5, start: common::START }))
            }
            840 => t.call(now_us, Input::Host(&HostToExec::Start { plan_id: 5 })),
            _ => {}
        }
        t.call(now_us, Input::Tick);
        if t.exec.state() == ExecState::Done || i > 10_000_000 {
            break;
        }
    }
    let wall_s = wall.elapsed().as_secs_f64();
    assert_eq!(t.exec.state(), ExecState::Done);
    let segments = t.ctrl.received.len() as u32;
    (t.samples_ns, segments, wall_s)
}

fn main() {
    for (rate_hz, steps) in [(100, 64), (1000, 16)] {
        let (mut ns, segments, wall_s) = trial(rate_hz, steps);
        let calls = ns.len();
        let total: u64 = ns.iter().sum();
        ns.sort_unstable();
        let pct = |p: f64| ns[((calls as f64 - 1.0) * p) as usize];
        println!(
            "executor core @ {rate_hz} Hz: {calls} handle calls, {segments} segments; per call \
             mean {:.0} ns, p50 {} ns, p99 {} ns, p99.9 {} ns, max {} ns; core time per \
             segment {:.1} µs; loop wall time {:.3} s",
            total as f64 / calls as f64,
            pct(0.5),
            pct(0.99),
            pct(0.999),
            ns[calls - 1],
            total as f64 / 1e3 / f64::from(segments),
            wall_s,
        );
    }
}
