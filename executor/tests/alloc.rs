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
