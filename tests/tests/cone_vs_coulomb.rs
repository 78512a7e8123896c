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

/// One push: the part (a rectangle), its supports and frictions, its start angle, and the
/// pusher's straight path (fixture frame, the part's COM at the origin).
struct Push {
    length: f64,
    width: f64,
    supports: [[f64; 2]; 3],
    mu_support: f64,
    mu_probe: f64,
    radius: f64,
    theta_rad: f64,
    from: [f64; 2],
    to: [f64; 2],
}

const LENGTH: f64 = 1200.0;

/// The off-centre pushes of the first test: a part and supports the project never uses.
fn off_centre(offset: f64, travel: f64) -> Push {
    let (l, radius) = (LENGTH / 2.0, 20.0);
    Push {
        length: LENGTH,
        width: 700.0,
        supports: [[-420.0, -230.0], [-150.0, 260.0], [380.0, -40.0]],
        mu_support: 0.45,
        mu_probe: 0.25,
        radius,
        theta_rad: 0.0,
        from: [-l - radius - 1.0, offset],
        to: [-l - radius - 1.0 + travel, offset],
    }
}

fn reference(c: &Push) -> coulomb::Pose {
    let (l, w) = (c.length / 2.0, c.width / 2.0);
    let outline = vec![V2::new(-l, -w), V2::new(l, -w), V2::new(l, w), V2::new(-l, w)];
    let part =
        coulomb::Part::three_point(outline, c.supports.map(|p| V2::new(p[0], p[1])), c.mu_support);
    let pusher = coulomb::Pusher { radius: c.radius, mu: c.mu_probe };
    let s = coulomb::Settings { step: 0.5, slip_eps: 1e-7 };
    let start = coulomb::Pose { x: 0.0, y: 0.0, theta: c.theta_rad };
    let (from, to) = (V2::new(c.from[0], c.from[1]), V2::new(c.to[0], c.to[1]));
    *coulomb::push(&part, &pusher, start, from, to, &s).last().unwrap()
}

/// Our simulator on push `c`, 5 µm steps; also whether any step fell back to the polygon.
fn ours(c: &Push, friction: SupportFriction, n_directions: usize) -> (Pose, bool) {
    let model = Model {
        part: Part::from_polygon(&ConvexPolygon::rectangle(c.length, c.width).unwrap()),
        support: SupportDistribution { points_um: c.supports, mu_surface: [c.mu_support; 3] },
        mu_probe: c.mu_probe,
        probe_radius_um: c.radius,
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
    let mut st = SimState::new(Pose::new(0.0, 0.0, c.theta_rad), Vec2::new(c.from[0], c.from[1]));
    let travel = Vec2::new(c.to[0] - c.from[0], c.to[1] - c.from[1]);
    let n = (travel.norm() / 5.0).ceil() as usize;
    let mut fallback = false;
    for _ in 0..n {
        fallback |= sim.step(&mut st, travel / n as f64).unwrap().newton_fallback;
    }
    (st.peg, fallback)
}

fn error(p: &Pose, r: &coulomb::Pose) -> (f64, f64) {
    ((p.x_um - r.x).hypot(p.y_um - r.y), (p.theta_rad - r.theta).to_degrees().abs())
}

#[test]
fn the_exact_cone_follows_an_independent_coulomb_pusher() {
    for (offset, travel) in [(0.0, 800.0), (120.0, 800.0), (240.0, 1200.0), (-300.0, 1200.0)] {
        let c = off_centre(offset, travel);
        let r = reference(&c);
        let (d, a) = error(&ours(&c, SupportFriction::Coulomb, 8).0, &r);
        let (d8, a8) = error(&ours(&c, SupportFriction::Polygon, 8).0, &r);
        let (d64, a64) = error(&ours(&c, SupportFriction::Polygon, 64).0, &r);
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

/// The independent generator's clean batch 6409012635243707006 (trial 5): the paper's peg
/// turned −15.9°, pushed along −y near a corner of its long edge with the probe sliding on
/// the edge of its friction cone. Newton's method alternated between two answers on every
/// step and the polygonal fallback slid the peg along x three times as fast as the
/// reference, 40 µm off within the stroke (the diagnosis's held-out error of that batch was
/// 96 × the floor with the generator's true parameters). The exact solve must converge
/// (averaged iterations after Newton) and end within 0.2 % of the part's size and 0.15°.
#[test]
fn a_push_whose_newton_steps_alternate_still_follows_the_reference() {
    let c = Push {
        length: 1600.0,
        width: 1000.0,
        supports: [[-560.0, -310.0], [-430.0, 340.0], [590.0, 40.0]],
        mu_support: 0.35,
        mu_probe: 0.5,
        radius: 12.5,
        theta_rad: (-15.927f64).to_radians(),
        from: [-202.2, 606.5],
        to: [-202.2, 306.5],
    };
    let r = reference(&c);
    let (p, fallback) = ours(&c, SupportFriction::Coulomb, 8);
    let (d, a) = error(&p, &r);
    println!(
        "reference ({:.1}, {:.1}) µm, {:.2}°; exact cone {d:.2} µm {a:.3}° off",
        r.x,
        r.y,
        r.theta.to_degrees()
    );
    assert!(!fallback, "a step fell back to the polygonal cones");
    assert!(d <= 2e-3 * c.length && a <= 0.15, "{d} µm, {a}° off");
}
