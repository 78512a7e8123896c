//! Stage 2 of the fixture reconstruction (docs/fixture.md): around the best pair found by
//! `fixture_search`, try supports on a 10 µm lattice and nearby fixture dimensions, keep those
//! where Table II inserts with both the 8- and a 32-direction friction cone (so the result is
//! not an artefact of the linearisation), ranked by how many of 24 perturbed starts (±26 µm,
//! ±74 µm, ±3°) insert, so the shipped nominal is not on a knife edge either. Run: `cargo run --release -p mesopush-sim --example fixture_refine`.

use mesopush_core::geom::Pose;
use mesopush_sim::fixture::PaperFixtureParams;
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, SupportDistribution, replay};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

fn inserts(sim: &mut Simulator, plan: &Plan, start: Option<Pose>) -> bool {
    replay(sim, plan, start).is_ok_and(|r| r.inserted && r.events.is_empty())
}

/// Inserts from the nominal start with both the default and a 32-direction friction cone.
fn inserts_both(model: &Model, p: &PaperFixtureParams, plan: &Plan) -> Option<Simulator> {
    let fine = SimSettings { n_directions: 32, ..SimSettings::default() };
    let fixture = Fixture::paper_with(p).ok()?;
    let mut sim32 = Simulator::new(model.clone(), fixture.clone(), fine).ok()?;
    let mut sim = Simulator::new(model.clone(), fixture, SimSettings::default()).ok()?;
    (inserts(&mut sim, plan, None) && inserts(&mut sim32, plan, None)).then_some(sim)
}

fn main() {
    let plan = Plan::table2();
    let mut rng = ChaCha8Rng::seed_from_u64(2027);
    let starts = plan.perturbed_starts(&mut rng, 24, (26.0, 74.0, 3.0));
    let centre = [[-250.0, 440.0], [50.0, -330.0], [250.0, 60.0]];
    let wide = std::env::args().any(|a| a == "--wide");
    let mut supports = Vec::new();
    while supports.len() < if wide { 160 } else { 64 } {
        let pts: [[f64; 2]; 3] = std::array::from_fn(|i| {
            if wide {
                let x = (rng.random_range(-800.0f64..800.0) / 10.0).round() * 10.0;
                let y = (rng.random_range(-485.0f64..485.0) / 10.0).round() * 10.0;
                return [x, y];
            }
            let mut j =
                |c: f64| ((c / 10.0).round() + f64::from(rng.random_range(-5i32..=5))) * 10.0;
            [j(centre[i][0]), j(centre[i][1])]
        });
        let m = Model {
            support: SupportDistribution { points_um: pts, mu_surface: [0.3; 3] },
            ..Model::default()
        };
        if m.validate().is_ok() {
            supports.push(m);
        }
    }
    let mut fx = Vec::new();
    for xs in [375.0, 450.0, 525.0, 600.0, 675.0] {
        for wt in [200.0, 300.0, 400.0] {
            for nt in (0..=8).map(|i| 850.0 + 25.0 * f64::from(i)) {
                fx.push(PaperFixtureParams {
                    x_step_um: xs,
                    wide_top_um: wt,
                    narrow_top_um: nt,
                    chamfer_um: 0.0,
                });
            }
        }
    }
    let mut rows: Vec<(usize, usize, PaperFixtureParams)> = supports
        .par_iter()
        .enumerate()
        .flat_map_iter(|(mi, model)| {
            let mut found = Vec::new();
            for p in &fx {
                if let Some(mut sim) = inserts_both(model, p, &plan) {
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
        supports.len(),
        rows.len()
    );
    for (k, mi, p) in rows.iter().take(20) {
        println!("{k:>2}/{}: support {:?} {p:?}", starts.len(), supports[*mi].support.points_um);
    }
}
