//! Flashing: a corrupt, truncated, disordered, unsafe or unstorable upload is refused with a
//! reason and the previous plan stays intact and runnable.

mod common;

use common::{CAP, Rig, image, square_plan};
use mesopush_executor::{ExecutorConfig, LogEvent, MemStore, Refusal, SafetyViolation};
use mesopush_protocol::flash::{
    FlashChunk, FlashHeader, FlashRejectReason, PlanStep, SafetyLimit, image_chunks,
};
use mesopush_protocol::host::{CommandRejectReason, ExecState, ExecToHost, HostToExec};

/// Plan 7 (two steps) accepted; clock synced.
fn with_plan() -> Rig {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    rig.flash_steps(7, &square_plan(2));
    rig.run_for(200_000);
    rig
}

fn rejected(plan_id: u32, reason: FlashRejectReason) -> ExecToHost {
    ExecToHost::FlashRejected { plan_id, reason }
}

/// The old plan is still stored, in `PlanFlashed`, and arms.
fn assert_old_plan_intact(rig: &mut Rig) {
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    let plan = rig.exec.plan().expect("plan kept");
    assert_eq!((plan.plan_id(), plan.step_count()), (7, 2));
    assert_eq!(plan.image(), &image(&square_plan(2))[..]);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    assert!(
        matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
        "{reply:?}"
    );
}

#[test]
fn corrupt_image_is_rejected_and_the_old_plan_stays() {
    let mut rig = with_plan();
    let good = image(&square_plan(20));
    let header = FlashHeader::for_image(8, &good).unwrap();
    let mut bad = good.clone();
    bad[100] ^= 0x10;
    let reply = rig.flash(header, &bad);
    let ExecToHost::FlashRejected {
        plan_id: 8,
        reason: FlashRejectReason::CrcMismatch { expected_crc32, .. },
    } = reply
    else {
        panic!("expected a CRC mismatch, got {reply:?}");
    };
    assert_eq!(expected_crc32, header.image_crc32);
    assert_old_plan_intact(&mut rig);
}

#[test]
fn truncated_image_is_rejected_and_the_old_plan_stays() {
    let mut rig = with_plan();
    let good = image(&square_plan(40));
    let header = FlashHeader::for_image(8, &good).unwrap();
    let reply = rig.flash(header, &good[..good.len() - 192]);
    let reason =
        FlashRejectReason::LengthMismatch { expected_len_bytes: 480, received_len_bytes: 288 };
    assert_eq!(reply, rejected(8, reason));
    assert_old_plan_intact(&mut rig);
}

#[test]
fn out_of_order_and_foreign_chunks_are_rejected() {
    let mut rig = with_plan();
    let good = image(&square_plan(40));
    let header = FlashHeader::for_image(8, &good).unwrap();
    let chunks: Vec<FlashChunk> = image_chunks(8, &good).collect();
    rig.host(HostToExec::FlashBegin(header));
    rig.host(HostToExec::FlashChunk(chunks[0].clone()));
    let reply = rig.host(HostToExec::FlashChunk(chunks[2].clone()));
    let reason =
        FlashRejectReason::OutOfOrderChunk { expected_offset_bytes: 192, got_offset_bytes: 384 };
    assert_eq!(reply, vec![rejected(8, reason)]);
    assert_old_plan_intact(&mut rig);

    let mut rig = with_plan();
    rig.host(HostToExec::FlashBegin(header));
    let mut foreign = chunks[0].clone();
    foreign.plan_id = 9;
    let reason = FlashRejectReason::PlanIdMismatch { expected_plan_id: 8, got_plan_id: 9 };
    assert_eq!(rig.host(HostToExec::FlashChunk(foreign)), vec![rejected(9, reason)]);
    assert_eq!(
        rig.host(HostToExec::FlashCommit { plan_id: 8 }),
        vec![rejected(8, FlashRejectReason::NoFlashInProgress)]
    );
    assert_old_plan_intact(&mut rig);
}

#[test]
fn bad_headers_are_rejected() {
    let mut rig = with_plan();
    let good = image(&square_plan(2));
    let mut header = FlashHeader::for_image(8, &good).unwrap();
    header.format_version = 99;
    let reply = rig.host(HostToExec::FlashBegin(header));
    assert_eq!(reply, vec![rejected(8, FlashRejectReason::UnsupportedFormatVersion { got: 99 })]);
    let huge = FlashHeader {
        step_count: 1_000,
        image_len_bytes: 12_000,
        ..FlashHeader::for_image(8, &good).unwrap()
    };
    let reply = rig.host(HostToExec::FlashBegin(huge));
    let reason =
        FlashRejectReason::TooLarge { image_len_bytes: 12_000, capacity_bytes: CAP as u32 };
    assert_eq!(reply, vec![rejected(8, reason)]);
    assert_old_plan_intact(&mut rig);
}

fn refusal(rig: &Rig) -> Option<Refusal> {
    rig.logs.iter().rev().find_map(|e| match e {
        LogEvent::PlanRefused { refusal, .. } => Some(*refusal),
        _ => None,
    })
}

#[test]
fn plans_breaking_speed_or_acceleration_limits_are_refused() {
    let mut rig = with_plan();
    let fast = [PlanStep { dx_nm: 10_000, dy_nm: 0, speed_nm_s: 1_000_001 }];
    let reply = rig.flash_steps(8, &fast);
    assert_eq!(
        reply,
        rejected(8, FlashRejectReason::Unsafe { step_index: 0, limit: SafetyLimit::Speed })
    );
    let v = SafetyViolation::SpeedTooHigh {
        step_index: 0,
        speed_nm_s: 1_000_001,
        limit_nm_s: 1_000_000,
    };
    assert_eq!(refusal(&rig), Some(Refusal::Safety(v)));

    // 600 µm/s then −600 µm/s under a 100 mm/s² limit, over a 10 ms setpoint period: the
    // start from rest needs 60 mm/s² (fine), the reversal 120 mm/s² (refused).
    let config = ExecutorConfig { max_accel_nm_s2: 100_000_000, ..ExecutorConfig::DEFAULT };
    let mut rig = Rig::new(config);
    rig.hello();
    rig.flash_steps(7, &square_plan(2));
    rig.run_for(200_000);
    let zigzag = [
        PlanStep { dx_nm: 10_000, dy_nm: 0, speed_nm_s: 600_000 },
        PlanStep { dx_nm: -10_000, dy_nm: 0, speed_nm_s: 600_000 },
    ];
    let reply = rig.flash_steps(8, &zigzag);
    assert_eq!(
        reply,
        rejected(8, FlashRejectReason::Unsafe { step_index: 1, limit: SafetyLimit::Acceleration })
    );
    let v = SafetyViolation::AccelTooHigh {
        step_index: 1,
        accel_nm_s2: 120_000_000,
        limit_nm_s2: 100_000_000,
    };
    assert_eq!(refusal(&rig), Some(Refusal::Safety(v)));
    assert_old_plan_intact(&mut rig);
}

#[test]
fn plans_wider_than_the_workspace_or_leaving_it_are_refused() {
    let mut rig = with_plan();
    let wide = [PlanStep { dx_nm: 10_000_001, dy_nm: 0, speed_nm_s: 1_000_000 }];
    let reply = rig.flash_steps(8, &wide);
    // A violation of the plan as a whole is reported at step_index = step_count.
    assert_eq!(
        reply,
        rejected(8, FlashRejectReason::Unsafe { step_index: 1, limit: SafetyLimit::Workspace })
    );
    assert_old_plan_intact(&mut rig);

    // Fits the box, but not from where the probe is (1 mm, 1 mm): 2 mm to the left.
    let mut rig = with_plan();
    let left = [PlanStep { dx_nm: -1_000_000, dy_nm: 0, speed_nm_s: 500_000 }; 2];
    assert_eq!(rig.flash_steps(8, &left), ExecToHost::FlashAccepted { plan_id: 8, step_count: 2 });
    let reply = rig.host(HostToExec::Arm { plan_id: 8, start: common::START });
    let reason = CommandRejectReason::Unsafe { step_index: Some(1), limit: SafetyLimit::Workspace };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(reason)]);
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    let logged = rig.logs.iter().any(|e| {
        matches!(
            e,
            LogEvent::ArmRefused {
                plan_id: 8,
                violation: SafetyViolation::LeavesWorkspace {
                    step_index: Some(1),
                    x_nm: -1_000_000,
                    y_nm: 1_000_000
                }
            }
        )
    });
    assert!(logged, "{:?}", rig.logs);
}

#[test]
fn a_failed_store_refuses_the_plan_and_keeps_the_old_one() {
    let mut store = MemStore::<CAP>::new();
    store.fail_next_save = true;
    let mut failing = Rig::with_store(ExecutorConfig::DEFAULT, store);
    failing.hello();
    let reply = failing.flash_steps(8, &square_plan(2));
    assert_eq!(reply, rejected(8, FlashRejectReason::NotStored));
    assert_eq!(failing.exec.state(), ExecState::Idle);
    assert!(failing.exec.plan().is_none());
    // With a plan already stored, a failed save leaves it, in memory and in the store.
    let mut rig = with_plan();
    rig.exec.store_mut().fail_next_save = true;
    assert_eq!(rig.flash_steps(9, &square_plan(3)), rejected(9, FlashRejectReason::NotStored));
    assert_eq!(refusal(&rig), Some(Refusal::Store(mesopush_executor::StoreError::WriteFailed)));
    let mut buf = [0u8; CAP];
    let stored = mesopush_executor::PlanStore::load(rig.exec.store_mut(), &mut buf).unwrap();
    assert_eq!(stored.map(|(h, _)| h.plan_id), Some(7));
    assert_old_plan_intact(&mut rig);
}

#[test]
fn a_stored_plan_survives_a_restart() {
    let mut store = MemStore::<CAP>::new();
    let steps = square_plan(5);
    let img = image(&steps);
    let header = FlashHeader::for_image(11, &img).unwrap();
    mesopush_executor::PlanStore::save(&mut store, &header, &img).unwrap();
    let rig = Rig::with_store(ExecutorConfig::DEFAULT, store);
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    assert_eq!(rig.exec.plan().map(|p| (p.plan_id(), p.step_count())), Some((11, 5)));
}

#[test]
fn a_stored_plan_that_became_unsafe_is_not_loaded_and_says_why() {
    let mut store = MemStore::<CAP>::new();
    let fast = [PlanStep { dx_nm: 10_000, dy_nm: 0, speed_nm_s: 900_000 }];
    let img = image(&fast);
    let header = FlashHeader::for_image(11, &img).unwrap();
    mesopush_executor::PlanStore::save(&mut store, &header, &img).unwrap();
    let config = ExecutorConfig { max_speed_nm_s: 500_000, ..ExecutorConfig::DEFAULT };
    let rig = Rig::with_store(config, store);
    assert_eq!(rig.exec.state(), ExecState::Idle);
    assert!(rig.exec.plan().is_none());
    let v =
        SafetyViolation::SpeedTooHigh { step_index: 0, speed_nm_s: 900_000, limit_nm_s: 500_000 };
    assert_eq!(rig.exec.startup_issue(), Some(Refusal::Safety(v)));
}
