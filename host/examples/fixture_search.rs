//! Reproduces the fixture reconstruction of `docs/fixture.md`: the paper gives only the two
//! channel widths, so the remaining dimensions (where the step between the channels is and how
//! high each channel sits) are searched on a grid for the set under which Table II's plan
//! inserts the peg from its nominal start *and* from starts perturbed as in the paper's trials
//! (±26 µm, ±74 µm, ±3°). Run: `cargo run --release -p mesopush-host --example fixture_search`.

use mesopush_host::geom::Pose;
use mesopush_host::sim::fixture::PaperFixtureParams;
use mesopush_host::sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How far the final peg lies outside the goal, µm (≤ 0: inserted), or None on a jam.
fn miss_um(sim: &mut Simulator, plan: &Plan, start: Option<Pose>) -> Option<f64> {
    let r = replay(sim, plan, start).ok()?;
    if !r.events.is_empty() {
        return None;
    }
    let peg = sim.model().part.polygon().transformed(&r.final_pose);
    let goal = &sim.fixture().goal;
    Some(peg.vertices().iter().map(|v| goal.signed_distance(v)).fold(f64::MIN, f64::max))
}

fn main() {
    let plan = Plan::table2();
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let s0 = plan.peg_start_pose();
    let starts: Vec<Pose> = (0..24)
        .map(|_| {
            Pose::new(
                s0.x_um + rng.random_range(-26.0..=26.0),
                s0.y_um + rng.random_range(-74.0..=74.0),
                s0.theta_rad + rng.random_range(-3.0f64..=3.0).to_radians(),
            )
        })
        .collect();
    let mut rows: Vec<(f64, usize, PaperFixtureParams)> = Vec::new();
    let (mut tried, mut jams) = (0, 0);
    for xs in (0..=19).map(|i| 100.0 + 90.0 * f64::from(i)) {
        for wt in (0..=8).map(|i| 50.0 * f64::from(i)) {
            for nt in (0..=12).map(|i| wt + 75.0 * f64::from(i)) {
                let p = PaperFixtureParams { x_step_um: xs, wide_top_um: wt, narrow_top_um: nt };
                let Ok(fixture) = Fixture::paper_with(&p) else { continue };
                tried += 1;
                let mut sim =
                    Simulator::new(Model::default(), fixture, SimSettings::default()).unwrap();
                let Some(miss) = miss_um(&mut sim, &plan, None) else {
                    jams += 1;
                    continue;
                };
                let ok = if miss <= 0.0 {
                    starts
                        .iter()
                        .filter(|s| miss_um(&mut sim, &plan, Some(**s)).is_some_and(|m| m <= 0.0))
                        .count()
                } else {
                    0
                };
                rows.push((miss, ok, p));
            }
        }
    }
    rows.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.total_cmp(&b.0)));
    println!("tried {tried} fixtures, {jams} jammed from the nominal start");
    for (miss, ok, p) in rows.iter().take(25) {
        println!("miss {miss:>8.1} µm, {ok:>2}/{} perturbed inserted: {p:?}", starts.len());
    }
}
