//! Wall presses (issue 21's uncertainty-removing moves): a peg pressed against a fixture wall
//! leaves square to it, whatever its turn before; the screening keeps a press only when it
//! beats the plan without it on the same worlds.

use mesopush_plan::UncertainWorld;
use mesopush_plan::wall_press::{WallPressSettings, add_wall_presses, wall_press_variants};
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};

/// The paper's peg lying in the wide channel, turned `theta_deg`, its centre 250 µm below
/// where a level peg would touch the upper wall (y = 300), pushed 300 µm along −x at its
/// right end.
fn pushed_near_the_top_wall(theta_deg: f64) -> Plan {
    let start = PegStart { x_um: 2500.0, y_um: 300.0 + 492.5 + 250.0, theta_deg };
    Plan {
        name: "one push".into(),
        speed_um_s: 140.0,
        peg_start: start,
        probe_start_um: [3400.0, start.y_um],
        moves_um: vec![[-(3400.0 - 2500.0 - 807.5 - 12.5) - 300.0, 0.0]],
    }
}

#[test]
fn a_press_against_the_upper_wall_squares_the_peg_whatever_its_turn() {
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let world = UncertainWorld::nominal(&model, &fixture, &settings);
    let mut sim = Simulator::new(model.clone(), fixture.clone(), settings.clone()).unwrap();
    let part_um = 1615.0;
    for theta_deg in [-6.0, 0.0, 5.0] {
        let plan = pushed_near_the_top_wall(theta_deg);
        let variants = wall_press_variants(&plan, &world, &WallPressSettings::default()).unwrap();
        let up = variants
            .iter()
            .find(|v| v.direction == "-y" && v.after_move == Some(0))
            .unwrap_or_else(|| panic!("{theta_deg}°: no press towards the upper wall"));
        assert_eq!(up.after_move, Some(0));
        let end = replay(&mut sim, &up.plan, None).unwrap();
        assert!(end.overload.is_none(), "{theta_deg}°: {:?}", end.overload);
        let top = model.part.polygon().transformed(&end.final_pose).bounds().0.y;
        assert!(
            (top - 300.0).abs() < 0.01 * part_um,
            "{theta_deg}°: top edge at {top} µm, the wall at 300"
        );
        assert!(
            end.final_pose.theta_rad.to_degrees().abs() < 0.5,
            "{theta_deg}°: left turned {:.2}° after the press",
            end.final_pose.theta_rad.to_degrees()
        );
        // Without the press the turn stays (the regression this test guards: a press that
        // does not reach the wall would leave it too).
        if theta_deg != 0.0 {
            let plain = replay(&mut sim, &plan, None).unwrap();
            assert!(plain.final_pose.theta_rad.to_degrees().abs() > 2.0, "{theta_deg}°");
        }
    }
}

#[test]
fn presses_are_added_only_while_they_beat_the_plan_on_the_screening_worlds() {
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let world = UncertainWorld::nominal(&model, &fixture, &settings);
    let plan = Plan::table2();
    let ws = WallPressSettings { screen_samples: 16, ..Default::default() };
    let (out, rounds) = add_wall_presses(&plan, plan.peg_start, &world, &ws, 3).unwrap();
    assert!(!rounds.is_empty() && rounds.len() <= ws.max_presses);
    // Every round but the last added its press; the last added one only if it was the
    // round limit.
    let added = rounds.iter().filter(|r| r.improves()).count();
    assert!(rounds[..rounds.len() - 1].iter().all(|r| r.improves()));
    assert_eq!(out == plan, added == 0);
    for r in &rounds {
        if let Some((_, n)) = &r.best {
            assert!(*n <= r.samples && r.without <= r.samples);
        }
    }
    // Deterministic for the seed.
    assert_eq!(add_wall_presses(&plan, plan.peg_start, &world, &ws, 3).unwrap().0, out);
}

#[test]
fn a_press_before_the_first_move_squares_the_peg_where_it_starts_against_the_nearest_wall() {
    // Table II's start: the peg upright (89°) in the wide channel, its top edge about 94 µm
    // below the upper wall (y = 300). A press before any push acts on the start's own
    // uncertainty. The plan: one step of the probe away from the peg (+x), so its variant is
    // the press and that step.
    let (model, fixture, settings) = (Model::default(), Fixture::paper(), SimSettings::default());
    let world = UncertainWorld::nominal(&model, &fixture, &settings);
    let mut sim = Simulator::new(model.clone(), fixture.clone(), settings.clone()).unwrap();
    let plan = Plan { moves_um: vec![[10.0, 0.0]], ..Plan::table2() };
    let ws = WallPressSettings { at_start_only: true, ..Default::default() };
    let variants = wall_press_variants(&plan, &world, &ws).unwrap();
    assert!(variants.iter().all(|v| v.after_move.is_none()), "only presses at the start");
    let up = variants.iter().find(|v| v.direction == "-y").expect("a press towards the upper wall");
    let outline = model.part.polygon().transformed(&plan.peg_start_pose());
    let gap = outline.bounds().0.y - 300.0;
    assert!((up.gap_um - gap).abs() < 1e-6 * 1615.0, "gap {} µm, geometry {gap} µm", up.gap_um);
    let end = replay(&mut sim, &up.plan, None).unwrap();
    assert!(end.overload.is_none(), "{:?}", end.overload);
    let top = model.part.polygon().transformed(&end.final_pose).bounds().0.y;
    assert!((top - 300.0).abs() < 0.01 * 1615.0, "top edge at {top} µm, the wall at 300");
    let turn = end.final_pose.theta_rad.to_degrees();
    assert!((turn - 90.0).abs() < 0.5, "left at {turn:.2}° (started at 89°): not squared");
    // The press returns the probe where it started, so the plan's own moves follow unchanged.
    let sum = up.plan.moves_um.iter().fold([0.0, 0.0], |a, m| [a[0] + m[0], a[1] + m[1]]);
    assert!((sum[0] - 10.0).abs() < 1e-9 && sum[1].abs() < 1e-9, "{sum:?}");
}
