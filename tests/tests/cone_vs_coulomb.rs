//! The simulator's support friction against an independent exact-Coulomb pusher
//! ([`mesopush_tests::coulomb`], no mesopush code): a part and supports the project never
//! uses by default, pushed off-centre far enough to turn it by tens of degrees. The default
//! model (the exact circular cone, Newton's method) must end within 0.2 % of the part's size
//! and 0.15° of the reference; the paper's polygonal cone (body frame) is printed beside it,
//! at 8 and 64 directions, for the record (`cargo test -p mesopush-tests --test
//! cone_vs_coulomb -- --nocapture`).

use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::fixture::rect;
use mesopush_sim::{
    Fixture, Model, Part, SimSettings, SimState, Simulator, SupportDistribution, SupportFriction,
};
use mesopush_tests::coulomb::{self, V2};

const LENGTH: f64 = 1200.0;
const WIDTH: f64 = 700.0;
const SUPPORTS: [[f64; 2]; 3] = [[-420.0, -230.0], [-150.0, 260.0], [380.0, -40.0]];
const MU_SUPPORT: f64 = 0.45;
const MU_PROBE: f64 = 0.25;
const RADIUS: f64 = 20.0;

fn reference(offset: f64, travel: f64) -> coulomb::Pose {
    let (l, w) = (LENGTH / 2.0, WIDTH / 2.0);
    let outline = vec![V2::new(-l, -w), V2::new(l, -w), V2::new(l, w), V2::new(-l, w)];
    let part =
        coulomb::Part::three_point(outline, SUPPORTS.map(|p| V2::new(p[0], p[1])), MU_SUPPORT);
    let pusher = coulomb::Pusher { radius: RADIUS, mu: MU_PROBE };
    let s = coulomb::Settings { step: 0.5, slip_eps: 1e-7 };
    let from = V2::new(-l - RADIUS - 1.0, offset);
    let to = V2::new(-l - RADIUS - 1.0 + travel, offset);
    *coulomb::push(&part, &pusher, coulomb::Pose::default(), from, to, &s).last().unwrap()
}

fn ours(offset: f64, travel: f64, friction: SupportFriction, n_directions: usize) -> Pose {
    let model = Model {
        part: Part::from_polygon(&ConvexPolygon::rectangle(LENGTH, WIDTH).unwrap()),
        support: SupportDistribution { points_um: SUPPORTS, mu_surface: [MU_SUPPORT; 3] },
        mu_probe: MU_PROBE,
        probe_radius_um: RADIUS,
        ..Model::default()
    };
    let goal = rect(50_000.0, 50_000.0, 51_000.0, 51_000.0).unwrap();
    let fixture = Fixture { walls: vec![], goal, insert_depth_um: 1.0, goal_whole_part: false };
    // A rigid probe, as the reference's.
    let settings = SimSettings {
        support_friction: friction,
        n_directions,
        probe_compliance_um: 0.0,
        ..SimSettings::default()
    };
    let mut sim = Simulator::new(model, fixture, settings).unwrap();
    let l = LENGTH / 2.0;
    let mut st = SimState::new(Pose::new(0.0, 0.0, 0.0), Vec2::new(-l - RADIUS - 1.0, offset));
    let n = (travel / 5.0).ceil() as usize;
    for _ in 0..n {
        sim.step(&mut st, Vec2::new(travel / n as f64, 0.0)).unwrap();
    }
    st.peg
}

fn error(p: &Pose, r: &coulomb::Pose) -> (f64, f64) {
    ((p.x_um - r.x).hypot(p.y_um - r.y), (p.theta_rad - r.theta).to_degrees().abs())
}

#[test]
fn the_exact_cone_follows_an_independent_coulomb_pusher() {
    for (offset, travel) in [(0.0, 800.0), (120.0, 800.0), (240.0, 1200.0), (-300.0, 1200.0)] {
        let r = reference(offset, travel);
        let (d, a) = error(&ours(offset, travel, SupportFriction::Coulomb, 8), &r);
        let (d8, a8) = error(&ours(offset, travel, SupportFriction::Polygon, 8), &r);
        let (d64, a64) = error(&ours(offset, travel, SupportFriction::Polygon, 64), &r);
        println!(
            "push at {offset:+.0} µm for {travel:.0} µm: reference ({:.1}, {:.1}) µm, {:.2}°; \
             exact cone {d:.2} µm {a:.3}° off; polygon n_d 8 {d8:.1} µm {a8:.2}°, n_d 64 \
             {d64:.2} µm {a64:.3}°",
            r.x,
            r.y,
            r.theta.to_degrees()
        );
        assert!(d <= 2e-3 * LENGTH && a <= 0.15, "offset {offset}: {d} µm, {a}° off");
    }
}
