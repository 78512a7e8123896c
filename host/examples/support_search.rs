//! Stage 1 of the fixture reconstruction (docs/fixture.md): on an open plate, which support
//! distributions make Table II end with the peg horizontal and pushed all the way left?
use mesopush_host::geom::Vec2;
use mesopush_host::sim::fixture::rect;
use mesopush_host::sim::{
    Fixture, Model, Plan, SimSettings, Simulator, SupportDistribution, replay,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let plan = Plan::table2();
    let open = Fixture { walls: vec![], goal: rect(-1.0, -1.0, 1.0, 1.0).unwrap() };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut rows = Vec::new();
    let mut tried = 0;
    while tried < 3000 {
        let pts: [[f64; 2]; 3] = std::array::from_fn(|_| {
            [rng.random_range(-800.0..800.0), rng.random_range(-485.0..485.0)]
        });
        let support = SupportDistribution { points_um: pts, mu_surface: [0.3; 3] };
        let model = Model { support, ..Model::default() };
        if model.validate().is_err() {
            continue;
        }
        tried += 1;
        let mut sim = Simulator::new(model.clone(), open.clone(), SimSettings::default()).unwrap();
        let Ok(r) = replay(&mut sim, &plan, None) else { continue };
        if !r.events.is_empty() {
            continue;
        }
        let p = r.final_pose;
        let th = (p.theta_rad.to_degrees() + 90.0).rem_euclid(180.0) - 90.0;
        // y-extent of the peg during the last move (entry), and where the 6th move ended.
        let last: Vec<_> = r.samples.iter().filter(|s| s.move_index == 6).collect();
        let peg = model.part.polygon();
        let ys = last.iter().flat_map(|s| {
            peg.transformed(&s.peg).vertices().iter().map(|v| v.y).collect::<Vec<_>>()
        });
        let (ylo, yhi) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        let right_end = peg.transformed(&p).vertices().iter().map(|v| v.x).fold(f64::MIN, f64::max);
        let _ = Vec2::zeros();
        if right_end < 700.0 {
            rows.push((th.abs(), p, right_end, yhi - ylo, pts));
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    println!("tried {tried}, {} ran", rows.len());
    for (th, p, re, span, pts) in rows.iter().take(20) {
        println!(
            "|θ| {th:5.2}° final ({:7.1},{:7.1}) right end {re:7.1} entry y-span {span:6.1} support {pts:?}",
            p.x_um, p.y_um
        );
    }
}
