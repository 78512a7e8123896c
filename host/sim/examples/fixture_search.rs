//! Reproduces the fixture reconstruction of `docs/fixture.md`. The paper gives the two channel
//! widths (2015 µm and 1090 µm) and Table II, but neither the rest of the fixture's dimensions
//! nor its nominal support distribution. This searches both jointly: every fixture of the
//! two-channel family on a grid, under random three-point supports (seeded), keeping those where
//! Table II inserts the peg from its nominal start, ranked by how many of the starts perturbed
//! as in the paper's trials (±26 µm, ±74 µm, ±3°) also insert.
//! Run: `cargo run --release -p mesopush-sim --example fixture_search`.

use mesopush_core::geom::Pose;
use mesopush_sim::fixture::PaperFixtureParams;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, SupportDistribution, replay};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

fn inserts(sim: &mut Simulator, plan: &Plan, start: Option<Pose>) -> bool {
    replay(sim, plan, start).is_ok_and(|r| r.inserted && r.events.is_empty())
}

fn fixtures() -> Vec<PaperFixtureParams> {
    let mut out = Vec::new();
    for xs in (0..=10).map(|i| 300.0 + 150.0 * f64::from(i)) {
        for wt in (0..=4).map(|i| 100.0 * f64::from(i)) {
            for nt in (0..=12).map(|i| wt + 75.0 * f64::from(i)) {
                out.push(PaperFixtureParams {
                    x_step_um: xs,
                    wide_top_um: wt,
                    narrow_top_um: nt,
                    chamfer_um: 0.0,
                });
            }
        }
    }
    out
}

fn main() {
    let plan = Plan::table2();
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let starts = plan.perturbed_starts(&mut rng, 12, (26.0, 74.0, 3.0));
    let mut models = vec![Model::default()];
    while models.len() < 40 {
        let pts: [[f64; 2]; 3] = std::array::from_fn(|_| {
            [rng.random_range(-800.0..800.0), rng.random_range(-485.0..485.0)]
        });
        let m = Model {
            support: SupportDistribution { points_um: pts, mu_surface: [0.3; 3] },
            ..Model::default()
        };
        if m.validate().is_ok() {
            models.push(m);
        }
    }
    let fx = fixtures();
    let mut rows: Vec<(usize, usize, PaperFixtureParams)> = models
        .par_iter()
        .enumerate()
        .flat_map_iter(|(mi, model)| {
            let mut found = Vec::new();
            for p in &fx {
                let Ok(fixture) = Fixture::paper_with(p) else { continue };
                let mut sim =
                    Simulator::new(model.clone(), fixture, SimSettings::default()).unwrap();
                if inserts(&mut sim, &plan, None) {
                    let k = starts.iter().filter(|s| inserts(&mut sim, &plan, Some(**s))).count();
                    found.push((k, mi, *p));
                }
            }
            found
        })
        .collect();
    rows.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    println!(
        "{} fixtures x {} supports; {} pairs insert from the nominal start",
        fx.len(),
        models.len(),
        rows.len()
    );
    for (k, mi, p) in rows.iter().take(30) {
        println!(
            "{k:>2}/{} perturbed: support {mi:>2} {:?} {p:?}",
            starts.len(),
            models[*mi].support.points_um
        );
    }
}
