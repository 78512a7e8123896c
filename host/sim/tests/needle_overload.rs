//! The needle limit in a replay (issue 19, "Needle safety"): a plan that drives the peg into
//! a wall and keeps pushing bends the needle by the probe's travel past the peg's stop, and a
//! replay that bends it beyond the model's `probe_deflection_limit_um` is overloaded — not
//! inserted, even with the peg in the goal.
//!
//! Expected values come from the geometry, not from the simulator: the peg (1615 µm long,
//! through its COM, symmetric supports) is pushed along +x against a wall at x = 900 µm;
//! once its right face rests on the wall the peg stops, and every further µm of probe
//! travel is a µm of needle deflection (the probe point presses into the held peg).

use mesopush_sim::fixture::rect;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, SupportDistribution, replay};

const HALF_LEN_UM: f64 = 807.5;
const WALL_X_UM: f64 = 900.0;
const PROBE_RADIUS_UM: f64 = 12.5;
/// Gap between the probe's rim and the peg at the start, µm.
const APPROACH_UM: f64 = 40.0;

fn sim(limit_um: f64) -> Simulator {
    let model = Model {
        support: SupportDistribution {
            points_um: [[-300.0, -200.0], [-300.0, 200.0], [300.0, 0.0]],
            mu_surface: [0.3; 3],
        },
        probe_deflection_limit_um: limit_um,
        ..Model::default()
    };
    let fixture = Fixture {
        walls: vec![rect(WALL_X_UM, -2000.0, WALL_X_UM + 1000.0, 2000.0).unwrap()],
        // The peg's COM ends at x = 92.5 µm, y = 0: inside, 57.5 µm from the goal's edge.
        goal: rect(50.0, -100.0, 150.0, 100.0).unwrap(),
        insert_depth_um: 1.0,
        goal_whole_part: false,
    };
    Simulator::new(model, fixture, SimSettings::default()).unwrap()
}

/// The peg at the origin, the probe `APPROACH_UM` left of it, one push along +x that goes
/// `past_stop_um` beyond the point where the wall stops the peg.
fn push_into_wall(past_stop_um: f64) -> Plan {
    let travel_to_wall = WALL_X_UM - HALF_LEN_UM;
    Plan {
        name: "into the wall".into(),
        speed_um_s: 140.0,
        peg_start: PegStart { x_um: 0.0, y_um: 0.0, theta_deg: 0.0 },
        probe_start_um: [-HALF_LEN_UM - PROBE_RADIUS_UM - APPROACH_UM, 0.0],
        moves_um: vec![[APPROACH_UM + travel_to_wall + past_stop_um, 0.0]],
    }
}

#[test]
fn a_plan_that_drives_the_peg_into_a_wall_overloads_the_needle_and_is_not_inserted() {
    let mut s = sim(50.0);
    let r = replay(&mut s, &push_into_wall(150.0), None).unwrap();
    let p = r.final_pose;
    assert!((p.x_um - (WALL_X_UM - HALF_LEN_UM)).abs() < 1.0, "the wall stops the peg: {p:?}");
    assert!(r.peg_in_goal, "the peg ends in the goal region: {p:?}");
    assert!(!r.inserted, "an overloaded plan is never inserted");
    let o = r.overload.expect("150 µm of deflection is beyond the 50 µm limit");
    assert!((o.peak_deflection_um - 150.0).abs() < 2.0, "{o:?}");
    // 150 µm at the default compliance of 0.5 µm per part weight.
    assert!((r.max_probe_force_weights - 300.0).abs() < 4.0, "{}", r.max_probe_force_weights);
    assert_eq!((o.limit_um, o.first_move_index, o.peak_move_index), (50.0, 0, 0));
    // The limit is first exceeded 50 µm of travel past the stop (t = travel / speed).
    let t_expected = (APPROACH_UM + WALL_X_UM - HALF_LEN_UM + 50.0) / 140.0;
    assert!((o.first_t_s - t_expected).abs() < 0.1, "{} s, not {t_expected} s", o.first_t_s);
    assert!(r.events.is_empty(), "a held peg is no jam: {:?}", r.events);
    let text = o.to_string();
    assert!(text.starts_with("needle overload at move 1: 150 µm > 50 µm"), "{text}");
}

#[test]
fn the_same_push_stopping_within_the_limit_inserts() {
    let mut s = sim(50.0);
    let r = replay(&mut s, &push_into_wall(30.0), None).unwrap();
    assert!(r.peg_in_goal && r.inserted, "{:?}", r.final_pose);
    assert_eq!(r.overload, None);
    assert!((r.max_probe_deflection_um - 30.0).abs() < 2.0, "{}", r.max_probe_deflection_um);
    assert_eq!(r.probe_deflection_limit_um, 50.0);
}

#[test]
fn the_limit_is_the_models_a_stiffer_allowance_accepts_the_same_push() {
    let plan = push_into_wall(150.0);
    let r = replay(&mut sim(200.0), &plan, None).unwrap();
    assert!(r.inserted && r.overload.is_none(), "a 200 µm limit holds 150 µm");
    let r = replay(&mut sim(100.0), &plan, None).unwrap();
    assert!(!r.inserted && r.overload.is_some(), "a 100 µm limit does not");
    // The force the limit stands for: limit / compliance.
    assert_eq!(sim(50.0).probe_force_limit_weights(), 100.0);
}
