//! Stage 3 of the fixture reconstruction (docs/fixture.md): a 45° chamfer on the narrow
//! channel's entrance corners against the friction cone's resolution n_d — does Table II
//! insert from the nominal start, where does it end, and from how many of 24 seeded starts
//! perturbed as in the paper's trials (±26 µm, ±74 µm, ±3°) does it insert.
//! Run: `cargo run --release -p mesopush-sim --example fixture_chamfer`.
use mesopush_sim::fixture::PaperFixtureParams;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use rayon::prelude::*;

fn main() {
    let plan = Plan::table2();
    let mut jobs = Vec::new();
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2027);
    let starts = plan.perturbed_starts(&mut rng, 24, (26.0, 74.0, 3.0));
    for c in [0.0, 150.0, 175.0, 200.0, 225.0, 250.0] {
        for nd in [8, 32, 64] {
            jobs.push((c, nd));
        }
    }
    let out: Vec<_> = jobs
        .par_iter()
        .map(|&(c, nd)| {
            let p = PaperFixtureParams { chamfer_um: c, ..Default::default() };
            let s = SimSettings { n_directions: nd, ..SimSettings::default() };
            let mut sim =
                Simulator::new(Model::default(), Fixture::paper_with(&p).unwrap(), s).unwrap();
            let r = replay(&mut sim, &plan, None).unwrap();
            let ok = starts
                .iter()
                .filter(|s| replay(&mut sim, &plan, Some(**s)).is_ok_and(|r| r.inserted))
                .count();
            (c, nd, r.inserted, r.final_pose, ok)
        })
        .collect();
    for (c, nd, ins, f, ev) in out {
        println!(
            "c={c:5} nd={nd:2} ins={ins} ({:.1},{:.1},{:.2}°) ev={ev}",
            f.x_um,
            f.y_um,
            f.theta_rad.to_degrees()
        );
    }
}
