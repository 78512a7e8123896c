//! A rotated and translated world gives a rotated and translated answer: the same push of the
//! same part on the same supports against the same wall, drawn at a random angle and offset,
//! must follow the same trajectory (to 0.1 % of the part's size and 0.1°). The paper's
//! world-fixed friction directions broke this by up to 12.8° (issue 17); the exact cone keeps
//! it (the body-frame polygon only up to rounding at stick–slip transitions: not asserted).

use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::fixture::rect;
use mesopush_sim::{
    Fixture, Model, SimSettings, SimState, Simulator, SupportDistribution, SupportFriction,
};
use proptest::prelude::*;

/// A rigid motion of the plane: rotation by `phi` about the origin, then a shift.
#[derive(Debug, Clone, Copy)]
struct Motion {
    phi: f64,
    shift: Vec2,
}

impl Motion {
    fn point(&self, p: Vec2) -> Vec2 {
        let (s, c) = self.phi.sin_cos();
        Vec2::new(c * p.x - s * p.y, s * p.x + c * p.y) + self.shift
    }
    fn pose(&self, p: &Pose) -> Pose {
        let q = self.point(p.position());
        Pose::new(q.x, q.y, p.theta_rad + self.phi)
    }
    fn vector(&self, v: Vec2) -> Vec2 {
        self.point(v) - self.point(Vec2::zeros())
    }
    fn polygon(&self, p: &ConvexPolygon) -> ConvexPolygon {
        ConvexPolygon::new(p.vertices().iter().map(|v| self.point(*v)).collect()).unwrap()
    }
}

/// A push scene: supports (body frame), the peg's start, a wall ahead of it whose face is
/// oblique to the push, and the probe's path: one push from behind, off-centre, that carries
/// the peg into the wall, where it turns and slides along the face (or jams).
#[derive(Debug, Clone)]
struct Scene {
    supports: [[f64; 2]; 3],
    peg: Pose,
    wall: ConvexPolygon,
    probe_start: Vec2,
    moves: Vec<Vec2>,
}

/// The peg's poses after each step, or `None` when the push jams: a step fails, or the needle
/// bends more than 5 µm (forces of ten part weights: the peg is wedged, not pushed).
fn simulate(scene: &Scene, m: &Motion, friction: SupportFriction) -> Option<Vec<Pose>> {
    let model = Model {
        support: SupportDistribution { points_um: scene.supports, mu_surface: [0.35; 3] },
        mu_probe: 0.3,
        mu_wall: 0.1,
        ..Model::default()
    };
    let goal = m.polygon(&rect(50_000.0, 50_000.0, 51_000.0, 51_000.0).unwrap());
    let fixture = Fixture {
        walls: vec![m.polygon(&scene.wall)],
        goal,
        insert_depth_um: 1.0,
        goal_whole_part: false,
    };
    let settings = SimSettings { support_friction: friction, ..SimSettings::default() };
    let mut sim = Simulator::new(model, fixture, settings).expect("a valid scene");
    let mut st = SimState::new(m.pose(&scene.peg), m.point(scene.probe_start));
    let mut out = vec![];
    for mv in &scene.moves {
        let n = (mv.norm() / 5.0).ceil() as usize;
        for _ in 0..n {
            let info = sim.step(&mut st, m.vector(*mv / n as f64)).ok()?;
            if info.probe_deflection_um > 5.0 {
                return None;
            }

            out.push(st.peg);
        }
    }
    Some(out)
}

fn scene() -> impl Strategy<Value = Scene> {
    // Supports: one in each third of the circle around the COM (±0.5 rad about its middle),
    // so no gap between neighbours reaches π and they span the COM.
    let support = |k: f64| {
        (-0.5..0.5f64, 0.3..0.95f64)
            .prop_map(move |(a, r)| (k * std::f64::consts::TAU / 3.0 + a, r))
    };
    (support(0.0), support(1.0), support(2.0), -300.0..300.0f64, -0.3..0.3f64, 300.0..900.0f64)
        .prop_map(|(s0, s1, s2, offset, theta, push)| {
            let (hl, hw) = (807.5, 492.5);
            let pt = |(a, r): (f64, f64)| [r * hl * a.cos(), r * hw * a.sin()];
            let peg = Pose::new(0.0, 0.0, theta);
            let back = peg.transform_point(&Vec2::new(-hl - 14.0, offset));
            // The wall: a 400 µm slab whose face, 55° off square to the push, passes 1850 µm
            // ahead (clear of the start, within reach of the turning peg's lower corner).
            let n = Vec2::new(0.9599f64.cos(), -(0.9599f64.sin()));
            let along = Vec2::new(-n.y, n.x);
            let p = Vec2::new(1850.0, 0.0);
            let wall = ConvexPolygon::new(vec![
                p - along * 5000.0,
                p - along * 5000.0 + n * 400.0,
                p + along * 5000.0 + n * 400.0,
                p + along * 5000.0,
            ])
            .unwrap();
            Scene {
                supports: [pt(s0), pt(s1), pt(s2)],
                peg,
                wall,
                probe_start: back,
                moves: vec![Vec2::new(theta.cos(), theta.sin()) * push],
            }
        })
}

fn motion() -> impl Strategy<Value = Motion> {
    (0.0..std::f64::consts::TAU, -5000.0..5000.0f64, -5000.0..5000.0f64)
        .prop_map(|(phi, x, y)| Motion { phi, shift: Vec2::new(x, y) })
}

proptest! {
    // A fixed seed: the same 64 scenes on every machine and run (determinism).
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x17_f1c7),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn a_moved_world_gives_the_moved_trajectory(s in scene(), m in motion()) {
        let size_um = 1615.0;
        // The exact cone only: the body-frame polygon is invariant in exact arithmetic, but
        // a CI run found a random scene where rounding at a stick–slip transition moved its
        // answer by 0.12° (docs/simulation.md); it is not claimed to this bound.
        for friction in [SupportFriction::Coulomb] {
            let here = simulate(&s, &Motion { phi: 0.0, shift: Vec2::zeros() }, friction);
            // A jam is a bifurcation (wedge or slip) that no simulator resolves alike under
            // rounding: such scenes are no test of invariance.
            prop_assume!(here.is_some());
            let (here, there) = (here.unwrap(), simulate(&s, &m, friction));
            prop_assert!(there.is_some(), "{friction:?}: the moved world jams, the other not");
            let there = there.unwrap();
            prop_assert_eq!(here.len(), there.len());
            for (a, b) in here.iter().zip(&there) {
                let want = m.pose(a);
                let d = (want.position() - b.position()).norm();
                let dth = (want.theta_rad - b.theta_rad).to_degrees();
                prop_assert!(d <= 1e-3 * size_um, "{friction:?}: {d} µm apart ({m:?})");
                prop_assert!(dth.abs() <= 0.1, "{friction:?}: {dth}° apart ({m:?})");
            }
        }
    }
}
