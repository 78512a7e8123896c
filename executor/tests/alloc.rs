//! No allocation after start-up: a whole trial — hello, flash in chunks, arm, start, every
//! setpoint streamed against a scripted controller, done, plus camera frames — runs through
//! the executor core under a counting global allocator, which must count zero.
#![allow(unsafe_code)] // the counting allocator is a GlobalAlloc impl

mod common;

use common::{CAP, Exec, OUT, ScriptedCtrl, image, square_plan};
use mesopush_executor::{CameraFrame, ExecutorConfig, Input, MemStore, Output, Outputs};
use mesopush_protocol::flash::{FlashHeader, image_chunks};
use mesopush_protocol::host::{
    ExecState, ExecToHost, Hello, HostToExec, MotionEventKind, StagePoint, TrialEventKind,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    // Per thread, so tests running in parallel do not count each other's allocations.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
    }
}

fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Host-side tally of what the executor said (no storage, so no allocation).
#[derive(Default)]
struct Tally {
    accepted: bool,
    armed: bool,
    done: bool,
    frames: u32,
    moves: u32,
    arrived: bool,
}

fn deliver(out: &mut Outputs<OUT>, now_us: u64, ctrl: &mut ScriptedCtrl, tally: &mut Tally) {
    for o in out.iter() {
        match o {
            Output::Ctrl(m) => {
                tally.moves += u32::from(matches!(m, mesopush_protocol::ExecToCtrl::Move(_)));
                ctrl.on_msg(now_us, m);
            }
            Output::Host(ExecToHost::FlashAccepted { .. }) => tally.accepted = true,
            Output::Host(ExecToHost::Status(s)) if s.state == ExecState::Armed => {
                tally.armed = true
            }
            Output::Host(ExecToHost::Trial(t)) if t.kind == TrialEventKind::Done => {
                tally.done = true
            }
            Output::Host(ExecToHost::Frame(_)) => tally.frames += 1,
            Output::Host(ExecToHost::Motion(m)) => {
                tally.arrived |= matches!(m.kind, MotionEventKind::Arrived { .. })
            }
            Output::Host(_) | Output::Log(_) => {}
        }
    }
    out.clear();
}

fn run_trial(exec: &mut Exec, ctrl: &mut ScriptedCtrl, header: FlashHeader, img: &[u8]) -> Tally {
    let mut tally = Tally::default();
    let mut out = Outputs::<OUT>::new();
    let mut now_us = 1_000;
    let mut host =
        |exec: &mut Exec, ctrl: &mut ScriptedCtrl, t: &mut Tally, now: u64, msg: HostToExec| {
            exec.handle(now, Input::Host(&msg), &mut out).expect("room");
            deliver(&mut out, now, ctrl, t);
        };
    host(exec, ctrl, &mut tally, now_us, HostToExec::Hello(Hello::CURRENT));
    host(exec, ctrl, &mut tally, now_us, HostToExec::FlashBegin(header));
    for chunk in image_chunks(header.plan_id, img) {
        host(exec, ctrl, &mut tally, now_us, HostToExec::FlashChunk(chunk));
    }
    host(exec, ctrl, &mut tally, now_us, HostToExec::FlashCommit { plan_id: header.plan_id });
    let mut out = Outputs::<OUT>::new();
    let mut frame_seq = 0;
    for i in 0..4_000u64 {
        now_us += 1_000;
        ctrl.tick(now_us);
        while let Some(m) = ctrl.pop() {
            exec.handle(now_us, Input::Ctrl(&m), &mut out).expect("room");
            deliver(&mut out, now_us, ctrl, &mut tally);
        }
        if i % 33 == 0 {
            let frame = CameraFrame { frame_seq, driver_stamp_us: None, black: false };
            frame_seq += 1;
            exec.handle(now_us, Input::Frame(frame), &mut out).expect("room");
        }
        if i % 100 == 0 {
            let beat = HostToExec::Heartbeat { host_time_us: now_us };
            exec.handle(now_us, Input::Host(&beat), &mut out).expect("room");
        }
        let cmd = match i {
            200 => Some(HostToExec::Arm { plan_id: header.plan_id, start: common::START }),
            210 => Some(HostToExec::Start { plan_id: header.plan_id }),
            // Between trials: a goto 100 µm away, then a stop.
            2_800 => {
                Some(HostToExec::Goto { target: StagePoint { x_nm: 1_100_000, y_nm: 1_000_000 } })
            }
            3_600 => Some(HostToExec::Stop),
            _ => None,
        };
        if let Some(cmd) = cmd {
            exec.handle(now_us, Input::Host(&cmd), &mut out).expect("room");
        }
        exec.handle(now_us, Input::Tick, &mut out).expect("room");
        deliver(&mut out, now_us, ctrl, &mut tally);
    }
    tally
}

#[test]
fn a_full_trial_and_a_goto_allocate_nothing_after_start_up() {
    // Start-up (may allocate): plan image, executor, controller.
    let steps = square_plan(16);
    let img = image(&steps);
    let header = FlashHeader::for_image(5, &img).unwrap();
    let mut exec = Exec::new(ExecutorConfig::DEFAULT, MemStore::<CAP>::new()).unwrap();
    let mut ctrl = Box::new(ScriptedCtrl::new(3_000_000, (1_000_000, 1_000_000)));

    COUNTING.with(|c| c.set(true));
    let tally = run_trial(&mut exec, &mut ctrl, header, &img);
    COUNTING.with(|c| c.set(false));
    let allocations = allocations();

    assert!(tally.accepted && tally.armed && tally.done, "trial incomplete");
    assert!(tally.arrived, "goto incomplete");
    // 16 steps × 20 µm at 140 µm/s = 2.2857 s → 229 setpoints at 100 Hz; the goto's 100 µm
    // at 200 µm/s → 50 more.
    assert_eq!(tally.moves, 229 + 50);
    assert_eq!(ctrl.received.len(), 229 + 50);
    assert!(tally.frames >= 100);
    assert_eq!(exec.state(), ExecState::PlanFlashed);
    println!(
        "allocations during the trial: {allocations} (moves {}, frames {})",
        tally.moves, tally.frames
    );
    assert_eq!(allocations, 0, "the executor core allocated after start-up");
}

/// The counter works: an allocation inside the window is seen (so zero above means zero).
#[test]
fn the_counter_sees_allocations() {
    let before = allocations();
    COUNTING.with(|c| c.set(true));
    let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
    COUNTING.with(|c| c.set(false));
    assert_eq!(v.len(), 3);
    assert_eq!(allocations(), before + 1);
}

/// A Sutter MPC-200 as its documentation describes it, without allocating: `C` answered at
/// once with drive, x, y, z and `0D`; `S V x y z` moves at 81.25·(V + 1) µm/s along the
/// fastest axis and answers `0D` at the end; `03` answers `0D`.
struct FakeMpc200 {
    pos: [i32; 3],
    rx: heapless::Vec<u8, 16>,
    reply: heapless::Vec<u8, 16>,
    reply_at_us: u64,
}

impl FakeMpc200 {
    fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        for &b in bytes {
            let _ = self.rx.push(b);
            let word = |k: usize| {
                let r = &self.rx[2 + 4 * k..6 + 4 * k];
                i32::from_le_bytes([r[0], r[1], r[2], r[3]])
            };
            match self.rx[0] {
                b'C' => {
                    self.reply.clear();
                    let _ = self.reply.push(1);
                    for v in self.pos {
                        let _ = self.reply.extend_from_slice(&v.to_le_bytes());
                    }
                    let _ = self.reply.push(0x0D);
                    self.reply_at_us = now_us;
                    self.rx.clear();
                }
                0x03 => {
                    self.reply.clear();
                    let _ = self.reply.push(0x0D);
                    self.reply_at_us = now_us;
                    self.rx.clear();
                }
                b'S' if self.rx.len() == 14 => {
                    let target = [word(0), word(1), word(2)];
                    let longest = (0..3).map(|k| (target[k] - self.pos[k]).unsigned_abs()).max();
                    let axis_usteps_s = 1_300 * (u64::from(self.rx[1]) + 1); // 81.25 µm/s × 16
                    let dur_us = u64::from(longest.unwrap_or(0)) * 1_000_000 / axis_usteps_s;
                    self.pos = target;
                    self.reply.clear();
                    let _ = self.reply.push(0x0D);
                    self.reply_at_us = now_us + dur_us;
                    self.rx.clear();
                }
                _ => {}
            }
        }
    }

    fn transmit(&mut self, now_us: u64) -> Option<heapless::Vec<u8, 16>> {
        if self.reply.is_empty() || now_us < self.reply_at_us {
            return None;
        }
        Some(core::mem::take(&mut self.reply))
    }
}

#[test]
fn a_trial_through_the_point_to_point_adapter_allocates_nothing_after_start_up() {
    use mesopush_executor::Segmenting;
    use mesopush_executor::adapter::p2p::driver::{P2pSettings, PointToPointAdapter};
    use mesopush_executor::adapter::p2p::mpc200::Mpc200;
    use mesopush_executor::adapter::{AdapterEvent, ControllerAdapter};
    let steps = square_plan(16);
    let img = image(&steps);
    let header = FlashHeader::for_image(6, &img).unwrap();
    let config = ExecutorConfig { segmenting: Segmenting::PlanSteps, ..ExecutorConfig::DEFAULT };
    let mut exec = Exec::new(config, MemStore::<CAP>::new()).unwrap();
    let mut adapter: Box<PointToPointAdapter<Mpc200, 32>> =
        Box::new(PointToPointAdapter::new(Mpc200::new(), P2pSettings::DEFAULT));
    // The stage at the plan's start, (1000, 1000) µm.
    let mut device = FakeMpc200 {
        pos: [16_000, 16_000, 0],
        rx: heapless::Vec::new(),
        reply: heapless::Vec::new(),
        reply_at_us: 0,
    };
    let mut out = Outputs::<OUT>::new();
    let mut tally = Tally::default();
    let mut buf = [0u8; 64];

    COUNTING.with(|c| c.set(true));
    let host = |exec: &mut Exec, out: &mut Outputs<OUT>, now: u64, msg: HostToExec| {
        exec.handle(now, Input::Host(&msg), out).expect("room");
    };
    host(&mut exec, &mut out, 1_000, HostToExec::Hello(Hello::CURRENT));
    host(&mut exec, &mut out, 1_000, HostToExec::FlashBegin(header));
    for chunk in image_chunks(header.plan_id, &img) {
        host(&mut exec, &mut out, 1_000, HostToExec::FlashChunk(chunk));
    }
    host(&mut exec, &mut out, 1_000, HostToExec::FlashCommit { plan_id: header.plan_id });
    for i in 0..5_000u64 {
        let now_us = 1_000 + i * 1_000;
        let cmd = match i {
            300 => Some(HostToExec::Arm { plan_id: header.plan_id, start: common::START }),
            310 => Some(HostToExec::Start { plan_id: header.plan_id }),
            _ if i % 100 == 0 => Some(HostToExec::Heartbeat { host_time_us: now_us }),
            _ => None,
        };
        if let Some(cmd) = cmd {
            exec.handle(now_us, Input::Host(&cmd), &mut out).expect("room");
        }
        exec.handle(now_us, Input::Tick, &mut out).expect("room");
        for o in out.iter() {
            match o {
                Output::Ctrl(m) => {
                    tally.moves += u32::from(matches!(m, mesopush_protocol::ExecToCtrl::Move(_)));
                    adapter.command(now_us, m);
                }
                Output::Host(ExecToHost::FlashAccepted { .. }) => tally.accepted = true,
                Output::Host(ExecToHost::Trial(t)) if t.kind == TrialEventKind::Done => {
                    tally.done = true
                }
                _ => {}
            }
        }
        out.clear();
        adapter.poll(now_us);
        while let Some(bytes) = adapter.transmit(now_us, &mut buf) {
            device.receive(now_us, bytes);
        }
        if let Some(reply) = device.transmit(now_us) {
            adapter.receive(now_us, &reply);
        }
        while let Some(event) = adapter.next_event() {
            if let AdapterEvent::Ctrl(m) = event {
                exec.handle(now_us, Input::Ctrl(&m), &mut out).expect("room");
            }
        }
    }
    COUNTING.with(|c| c.set(false));
    let allocations = allocations();
    assert!(tally.accepted && tally.done, "trial incomplete: {:?}", exec.status(0));
    assert_eq!(tally.moves, 16, "one segment per plan step");
    assert_eq!(device.pos, [16_000, 16_000, 0], "the square closes on its start");
    assert_eq!(allocations, 0, "the point-to-point adapter allocated after start-up");
}
