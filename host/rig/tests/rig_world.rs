//! The firmware simulator's world (`rig::plant::world`) against the simulator it wraps: the
//! peg must go where the stage's path, replayed by the simulator alone, puts it.

use mesopush_core::geom::{Pose, Vec2};
use mesopush_firmware_sim::World;
use mesopush_rig::plant::world::{RigWorld, WorldSetup};
use mesopush_sim::advance::advance;
use mesopush_sim::effects::Effects;
use mesopush_sim::{Fixture, Model, SimSettings, SimState, Simulator};
use mesopush_vision::RenderSettings;
use rand::SeedableRng;

const OFFSET_UM: [f64; 2] = [1000.0, 1000.0];

fn world(peg: Pose, probe_um: Vec2) -> RigWorld {
    world_with(Model::default(), peg, probe_um)
}

fn world_with(model: Model, peg: Pose, probe_um: Vec2) -> RigWorld {
    let setup = WorldSetup {
        model,
        peg_start: peg,
        stage_offset_um: Vec2::new(OFFSET_UM[0], OFFSET_UM[1]),
        render: RenderSettings::default(),
        // No exposure during the test: each would bring the physics to the stage exactly.
        camera_start_us: 1_000_000_000,
        camera_period_us: 33_333,
        effects: Effects::default(),
    };
    RigWorld::new(setup, probe_um, rand_chacha::ChaCha8Rng::seed_from_u64(1)).expect("world")
}

fn stage_nm(p: Vec2) -> (i32, i32) {
    (((p.x + OFFSET_UM[0]) * 1000.0).round() as i32, ((p.y + OFFSET_UM[1]) * 1000.0).round() as i32)
}

/// Drives the world's stage from `from` to `to` in ticks of 1 ms at 300 µm/s.
fn drive(w: &mut RigWorld, t_us: &mut u64, from: Vec2, to: Vec2) {
    let n = ((to - from).norm() / 0.3).ceil() as usize;
    for k in 1..=n {
        *t_us += 1000;
        w.step(*t_us, stage_nm(from + (to - from) * (k as f64 / n as f64)));
    }
}

/// Clean world, a push that reverses between camera exposures: the world simulated the
/// probe only in chords of a simulator step, so at the reversal the last partial chord (up
/// to 5 µm) was never simulated and the peg stopped short of where the probe pushed it —
/// lost motion in a world without backlash, which `diagnose` read as an effect.
#[test]
fn a_push_that_reverses_between_exposures_moves_the_peg_all_the_way() {
    let peg = Pose::new(2330.0, 1210.0, 89f64.to_radians());
    let start = Vec2::new(2900.0, 1151.5);
    for push_um in [200.0, 202.0, 203.5, 204.4] {
        let turn = start - Vec2::new(push_um, 0.0);
        let mut w = world(peg, start);
        let mut t_us = 0;
        drive(&mut w, &mut t_us, start, turn);
        drive(&mut w, &mut t_us, turn, turn + Vec2::new(50.0, 0.0));
        let mut sim =
            Simulator::new(Model::default(), Fixture::paper(), SimSettings::default()).unwrap();
        let mut st = SimState::new(peg, start);
        let mut budget = 100_000;
        advance(&mut sim, &mut st, turn - start, &mut budget, |_, _, _| {}).unwrap();
        let (got, want) = (w.peg(), st.peg);
        let d = (got.position() - want.position()).norm();
        assert!(
            d < 0.3 && (got.theta_rad - want.theta_rad).abs() < 1e-3,
            "push {push_um} µm: world peg {got:?}, simulator {want:?} ({d:.2} µm apart)"
        );
    }
}

/// The world's needle limit is its model's `probe_deflection_limit_um` (issue 19: one limit,
/// not a second constant): a peg pushed against the wide channel's upper wall (y = 300 µm)
/// and the stage going on 150 µm past the stop bends the needle 150 µm (geometry: the tip
/// rests on the held peg's edge), which the world reports to the controller in nm, and logs
/// as a jam beyond a 50 µm limit but not within a 200 µm one.
#[test]
fn the_world_reports_the_needles_deflection_and_logs_jams_against_its_models_limit() {
    // Supports symmetric about the push's line: the peg translates straight up.
    let support = mesopush_sim::SupportDistribution {
        points_um: [[-300.0, -200.0], [300.0, -200.0], [0.0, 300.0]],
        mu_surface: [0.3; 3],
    };
    let peg = Pose::new(2330.0, 300.0 + 492.5 + 100.0, 0.0);
    let start = Vec2::new(2330.0, peg.y_um + 492.5 + 12.5 + 40.0);
    let end = start - Vec2::new(0.0, 40.0 + 100.0 + 150.0);
    for (limit_um, jams) in [(50.0, 1), (200.0, 0)] {
        let model = Model {
            support: support.clone(),
            probe_deflection_limit_um: limit_um,
            ..Model::default()
        };
        let mut w = world_with(model, peg, start);
        let mut t_us = 0;
        drive(&mut w, &mut t_us, start, end);
        assert_eq!(w.deflection_limit_um(), limit_um);
        let p = w.peg();
        assert!((p.y_um - (300.0 + 492.5)).abs() < 1.0, "the wall holds the peg: {p:?}");
        let d_nm = w.needle_deflection_nm().expect("the world reports its needle");
        assert!((d_nm - 150_000).abs() < 1_000, "limit {limit_um}: {d_nm} nm");
        // The jam log notes the deflection at every physics chord (a simulator step, 5 µm).
        let max = w.max_deflection_um();
        assert!((144.0..=151.0).contains(&max), "limit {limit_um}: max {max} µm");
        assert_eq!(w.jam_events().len(), jams, "limit {limit_um} µm");
    }
}
