//! Properties the paper's quasi-static model must have, each checked on the simulator:
//! symmetric pushes translate, off-centre pushes rotate as Mason's voting theorem predicts,
//! no push means no motion, and the probe sticks or slides exactly as its friction cone says.

use mesopush_core::geom::{Pose, Vec2, cross};
use mesopush_sim::fixture::rect;
use mesopush_sim::stepper::StepInfo;
use mesopush_sim::{Fixture, Model, SimSettings, SimState, Simulator, SupportDistribution};

const HALF_LEN: f64 = 807.5;

fn open_plate() -> Fixture {
    Fixture {
        walls: vec![],
        goal: rect(-1.0, -1.0, 1.0, 1.0).unwrap(),
        insert_depth_um: 100.0,
        goal_whole_part: false,
    }
}

fn model(mu_probe: f64) -> Model {
    Model {
        support: SupportDistribution {
            points_um: [[-300.0, -200.0], [-300.0, 200.0], [300.0, 0.0]],
            mu_surface: [0.3; 3],
        },
        mu_probe,
        ..Model::default()
    }
}

fn sim(mu_probe: f64) -> Simulator {
    Simulator::new(model(mu_probe), open_plate(), SimSettings::default()).unwrap()
}

/// Pushes the peg (at the origin, θ = `theta`) with the probe starting at `probe` moving by
/// `delta` in 5 µm steps; returns the final state and the last step's info.
fn push(sim: &mut Simulator, theta: f64, probe: Vec2, delta: Vec2) -> (SimState, StepInfo) {
    let mut st = SimState::new(Pose::new(0.0, 0.0, theta), probe);
    let n = (delta.norm() / 5.0).ceil() as usize;
    let mut last = StepInfo::default();
    for _ in 0..n {
        last = sim.step(&mut st, delta / n as f64).expect("step solves");
    }
    (st, last)
}

#[test]
fn push_through_com_with_symmetric_support_is_pure_translation() {
    let mut s = sim(0.8);
    let (st, info) = push(&mut s, 0.0, Vec2::new(-HALF_LEN - 13.5, 0.0), Vec2::new(100.0, 0.0));
    assert!(info.probe_force > 0.0, "probe must be pushing: {info:?}");
    // 1 µm gap closed, the rest carried, less the needle's deflection under the push.
    let expected = 99.0 - info.probe_deflection_um;
    assert!((st.peg.x_um - expected).abs() < 1e-6, "x moved {} not {expected}", st.peg.x_um);
    assert!(st.peg.y_um.abs() < 1e-9, "y drifted {}", st.peg.y_um);
    assert!(st.peg.theta_rad.abs() < 1e-12, "rotated {}", st.peg.theta_rad);
}

/// Mason's voting theorem: the rotation sense is the majority sense of the moments about the
/// COM of the pushing direction and of the two friction-cone edges, all through the contact.
fn votes(contact: Vec2, normal: Vec2, push_dir: Vec2, mu: f64) -> f64 {
    let half = mu.atan();
    let rot =
        |v: Vec2, a: f64| Vec2::new(v.x * a.cos() - v.y * a.sin(), v.x * a.sin() + v.y * a.cos());
    let lines = [push_dir, rot(normal, half), rot(normal, -half)];
    lines.iter().map(|d| cross(&contact, d).signum()).sum()
}

#[test]
fn off_centre_pushes_rotate_as_the_voting_theorem_predicts() {
    for mu in [0.0, 0.3, 0.8] {
        let mut s = sim(mu);
        for offset in [-400.0, -250.0, -120.0, 120.0, 250.0, 400.0] {
            let probe = Vec2::new(-HALF_LEN - 13.0, offset);
            let (st, _) = push(&mut s, 0.0, probe, Vec2::new(30.0, 0.0));
            let x = Vec2::new(1.0, 0.0);
            let vote = votes(Vec2::new(-HALF_LEN, offset), x, x, mu);
            assert!(vote.abs() >= 1.0, "votes must not tie");
            assert!(
                st.peg.theta_rad.abs() > 1e-6 && st.peg.theta_rad.signum() == vote.signum(),
                "mu {mu}, offset {offset}: dθ = {}, votes {vote}",
                st.peg.theta_rad
            );
        }
    }
}

#[test]
fn no_push_means_no_motion() {
    let mut s = sim(0.8);
    // Probe touching but still, and probe retreating from or sliding off the contact.
    for delta in [Vec2::zeros(), Vec2::new(-20.0, 0.0), Vec2::new(-5.0, 15.0)] {
        let probe = Vec2::new(-HALF_LEN - 12.5, 100.0);
        let mut st = SimState::new(Pose::new(0.0, 0.0, 0.0), probe);
        s.step(&mut st, delta).unwrap();
        let p = st.peg;
        let moved = p.x_um.abs().max(p.y_um.abs()).max(p.theta_rad.abs() * HALF_LEN);
        assert!(moved < 1e-9, "delta {delta:?} moved the peg by {moved} µm: {p:?}");
    }
}

#[test]
fn probe_sticks_or_slides_exactly_as_its_friction_cone_says() {
    // The peg is turned 25°, so a push along +x meets its face 25° off the face normal.
    let theta = 25f64.to_radians();
    let face_normal = Vec2::new(theta.cos(), theta.sin());
    let probe = -face_normal * (HALF_LEN + 13.0);
    let mut modes = Vec::new();
    for mu in [0.0, 0.1, 0.2, 0.3, 0.5, 0.8, 1.0] {
        let mut s = sim(mu);
        let (before, _) = push(&mut s, theta, probe, Vec2::new(20.0, 0.0));
        let mut after = before;
        let delta = Vec2::new(5.0, 0.0);
        let info = s.step(&mut after, delta).unwrap();
        let (fnorm, ft) = (info.probe_force, info.probe_friction);
        assert!(fnorm > 0.0, "mu {mu}: no contact force");
        // Slip of the peg's contact point relative to the probe, along t = (−n_y, n_x).
        let n = face_normal;
        let t = Vec2::new(-n.y, n.x);
        let c_before = before.peg.transform_point(&Vec2::new(-HALF_LEN, 0.0));
        let c_after = after.peg.transform_point(&Vec2::new(-HALF_LEN, 0.0));
        let slip = (c_after - c_before - delta).dot(&t);
        if info.probe_sliding {
            // On the cone's edge, opposing the slip.
            let edge = (ft.abs() - mu * fnorm).abs();
            assert!(edge <= 1e-7 * fnorm.max(1.0), "mu {mu}: |ft| {ft} != mu fn {fnorm}");
            assert!(slip.abs() > 1e-4 && ft * slip <= 0.0, "mu {mu}: slip {slip}, ft {ft}");
        } else {
            // Inside the cone, no slip.
            assert!(ft.abs() <= mu * fnorm + 1e-9, "mu {mu}: sticking force outside the cone");
            assert!(slip.abs() < 1e-4, "mu {mu}: sticking contact slipped {slip} µm");
        }
        modes.push((mu, info.probe_sliding));
    }
    // Frictionless probe always slides here; μ = 0.8 holds the peg.
    assert_eq!(modes.first(), Some(&(0.0, true)), "{modes:?}");
    assert_eq!(modes.iter().find(|m| m.0 == 0.8), Some(&(0.8, false)), "{modes:?}");
    // Once the cone is wide enough to stick, wider cones stick too.
    let first_stick = modes.iter().position(|m| !m.1).expect("some μ sticks");
    assert!(modes[first_stick..].iter().all(|m| !m.1), "{modes:?}");
    eprintln!("probe modes (mu, sliding): {modes:?}");
}
