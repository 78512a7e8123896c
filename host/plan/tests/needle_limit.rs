//! The needle's limit in planning and robustness (issue 19, "Needle safety"; issue 21: a plan
//! counts as inserting only without exceeding the limit): the RRT keeps no push that bends
//! the needle beyond the model's `probe_deflection_limit_um`, and Monte Carlo robustness
//! counts an overloaded trial as a failure, with its own count, even with the peg in the goal.

use mesopush_plan::robustness::RobustnessRun;
use mesopush_plan::{RrtSettings, Uncertainty, plan_is_feasible, plan_rrt};
use mesopush_sim::fixture::rect;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, SupportDistribution, replay};
use rand::SeedableRng;

/// A needle limit that nothing reaches: the planner as it was before the limit existed.
const NO_LIMIT_UM: f64 = 1e5;

fn paper_sim(limit_um: f64) -> Simulator {
    let model = Model { probe_deflection_limit_um: limit_um, ..Model::default() };
    Simulator::new(model, Fixture::paper(), SimSettings::default()).unwrap()
}

fn rrt(sim: &mut Simulator, seed: u64) -> mesopush_plan::RrtResult {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let start = Plan::table2().peg_start_pose();
    plan_rrt(sim, start, &RrtSettings::default(), &mut rng, &mut |_| true).unwrap()
}

/// What issue 19 reported of seed 3 (a plan called inserted while bending the needle 296 µm)
/// happens today with seed 4: searched without a limit, its plan bends the needle about
/// 194 µm (387 part weights) in its nominal replay. Under the default 50 µm limit that plan
/// is overloaded and not inserted, and the same seed's search, which now rejects such pushes
/// as edges, returns a plan that stays within the limit.
#[test]
fn rrt_seed_4_plan_that_bent_the_needle_194_um_is_refused_and_the_search_stays_within_50_um() {
    let seed = 4;
    let unlimited = rrt(&mut paper_sim(NO_LIMIT_UM), seed);
    let old = unlimited.plan.expect("seed 4 finds a plan without a limit");
    let mut judged = paper_sim(50.0);
    let r = replay(&mut judged, &old, None).unwrap();
    let o = r.overload.unwrap_or_else(|| panic!("seed {seed}: peak {}", r.max_probe_deflection_um));
    assert!(o.peak_deflection_um > 150.0, "seed {seed}: {o:?}");
    assert!(!r.inserted, "seed {seed}: an overloaded plan is not inserted");
    assert!(!plan_is_feasible(&mut judged, &old).unwrap(), "seed {seed}: nor feasible");

    let mut limited = paper_sim(50.0);
    let found = rrt(&mut limited, seed);
    let plan = found.plan.expect("seed 4 finds a plan within the limit");
    assert!(found.overloaded_pushes > 0, "seed {seed}: the search met overloading pushes");
    let r = replay(&mut limited, &plan, None).unwrap();
    assert!(r.inserted && r.overload.is_none(), "seed {seed}: {:?}", r.overload);
    assert!(r.max_probe_deflection_um <= 50.0, "seed {seed}: {}", r.max_probe_deflection_um);
}

const HALF_LEN_UM: f64 = 807.5;
const WALL_X_UM: f64 = 900.0;

/// A peg at the origin pushed along +x through its COM against a wall at x = 900 µm; the
/// goal holds the stopped peg's COM (92.5, 0).
fn wall_world() -> (Model, Fixture) {
    let model = Model {
        support: SupportDistribution {
            points_um: [[-300.0, -200.0], [-300.0, 200.0], [300.0, 0.0]],
            mu_surface: [0.3; 3],
        },
        ..Model::default()
    };
    let fixture = Fixture {
        walls: vec![rect(WALL_X_UM, -2000.0, WALL_X_UM + 1000.0, 2000.0).unwrap()],
        goal: rect(50.0, -100.0, 150.0, 100.0).unwrap(),
        insert_depth_um: 1.0,
        goal_whole_part: false,
    };
    (model, fixture)
}

/// The push, going `past_stop_um` beyond where the wall stops the peg: that much needle
/// deflection once the peg rests on the wall.
fn into_the_wall(past_stop_um: f64) -> Plan {
    let approach = 40.0;
    Plan {
        name: format!("{past_stop_um} µm past the wall"),
        speed_um_s: 140.0,
        peg_start: PegStart { x_um: 0.0, y_um: 0.0, theta_deg: 0.0 },
        probe_start_um: [-HALF_LEN_UM - 12.5 - approach, 0.0],
        moves_um: vec![[approach + WALL_X_UM - HALF_LEN_UM + past_stop_um, 0.0]],
    }
}

#[test]
fn robustness_counts_trials_that_overload_the_needle_as_failures_with_their_own_count() {
    let (model, fixture) = wall_world();
    let dir = tempfile::tempdir().unwrap();
    let (over, within) = (dir.path().join("over.toml"), dir.path().join("within.toml"));
    std::fs::write(&over, into_the_wall(150.0).to_toml()).unwrap();
    std::fs::write(&within, into_the_wall(20.0).to_toml()).unwrap();
    // Start pose exact (so the wall always stops the peg in the goal); supports and μ vary.
    let uncertainty =
        Uncertainty { dx_um: 0.0, dy_um: 0.0, dtheta_deg: 0.0, dmu: 0.05, support_um: 20.0 };
    let run = RobustnessRun {
        model: &model,
        fixture: &fixture,
        supports: &[],
        uncertainty,
        samples: 12,
        seed: 5,
        sweep: false,
        out: &dir.path().join("out"),
    };
    let report = run.run(&[over, within], &|| ()).unwrap();
    let (o, w) = (&report.rows[0], &report.rows[1]);
    // (A trial may also jam against the wall: the probe stops, the stage goes on and the
    // needle bends by the travel left, which is overloaded all the same.)
    assert_eq!((o.successes, o.overloaded, o.sim_errors), (0, 12, 0), "{o:?}");
    assert_eq!((w.successes, w.overloaded), (12, 0), "{w:?}");
    // The overloaded trials ended with the peg in the goal: before the limit they passed.
    let csv = std::fs::read_to_string(dir.path().join("out/trials_over.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ins, ovl, defl) = (col("inserted"), col("overloaded"), col("max_deflection_um"));
    let (fx, fy) = (col("final_x_um"), col("final_y_um"));
    for row in csv.lines().skip(1) {
        let v: Vec<&str> = row.split(',').collect();
        assert_eq!((v[ins], v[ovl]), ("false", "true"), "{row}");
        let d: f64 = v[defl].parse().unwrap();
        assert!((d - 150.0).abs() < 3.0, "150 µm past the stop bends the needle 150 µm: {row}");
        let com = mesopush_core::geom::Vec2::new(v[fx].parse().unwrap(), v[fy].parse().unwrap());
        assert!(fixture.inserted(&com), "the peg rests in the goal: {row}");
    }
}
