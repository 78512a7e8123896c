//! The simulator's physical effects: off changes nothing, adhesion drags a peg the probe
//! retracts from (sideways too when the bond sticks), a high-friction patch under the peg
//! changes how it moves.

use mesopush_core::geom::{Pose, Vec2};
use mesopush_diagnose::data::open_plate;
use mesopush_sim::effects::{Adhesion, FrictionPatch};
use mesopush_sim::{Model, ProbePoint, SimSettings, Simulator, follow_path};

/// The peg at rest at (2000, 1200) µm, level; the probe from `pts[0]` through each of `pts` in
/// 100 steps of 10 ms: the peg after the first leg and at the end.
fn follow(model: Model, pts: &[[f64; 2]]) -> (Pose, Pose) {
    let start = Pose::new(2000.0, 1200.0, 0.0);
    let mut path = vec![];
    let mut t = 0.0;
    for w in pts.windows(2) {
        for k in 0..=100 {
            let f = k as f64 / 100.0;
            let p = Vec2::new(w[0][0] + (w[1][0] - w[0][0]) * f, w[0][1] + (w[1][1] - w[0][1]) * f);
            path.push(ProbePoint::new(t, p));
            t += 0.01;
        }
    }
    let mut sim = Simulator::new(model, open_plate(), SimSettings::default()).unwrap();
    let rep = follow_path(&mut sim, start, &path).unwrap();
    (rep.samples[100].peg, rep.samples.last().unwrap().peg)
}

/// The probe's start, 50 µm clear of the peg's short side.
const X0_UM: f64 = 2000.0 - 807.5 - 12.5 - 50.0;

/// Push the peg's short side by 200 µm along +x, then retract 200 µm.
fn push_and_retract(model: Model) -> (Pose, Pose) {
    follow(model, &[[X0_UM, 1300.0], [X0_UM + 250.0, 1300.0], [X0_UM + 50.0, 1300.0]])
}

#[test]
fn effects_off_is_the_nominal_model() {
    let a = push_and_retract(Model::default());
    let mut m = Model::default();
    m.effects.adhesion = Some(Adhesion { pull_off_weight: 0.0, range_um: 2.0, mu_bond: None });
    let b = push_and_retract(m);
    assert_eq!(a.1, push_and_retract(Model::default()).1);
    assert!((a.1.x_um - b.1.x_um).abs() < 1e-6, "zero pull-off drags nothing");
    let (pushed, end) = a;
    assert_eq!(pushed, end, "without adhesion a retracting probe leaves the peg");
}

#[test]
fn adhesion_drags_the_peg_back_on_retract() {
    let mut m = Model::default();
    m.effects.adhesion = Some(Adhesion { pull_off_weight: 1.5, range_um: 2.0, mu_bond: None });
    let (pushed, end) = push_and_retract(m);
    assert!(pushed.x_um - end.x_um > 10.0, "pushed {pushed:?}, after retract {end:?}");
}

#[test]
fn a_sticky_patch_under_the_peg_changes_its_motion() {
    let mut m = Model::default();
    let (a, _) = push_and_retract(m.clone());
    m.effects.friction_patch =
        Some(FrictionPatch { min_um: [1900.0, 0.0], max_um: [5000.0, 5000.0], mu_surface: 1.2 });
    let (b, _) = push_and_retract(m);
    let d = (a.x_um - b.x_um).hypot(a.y_um - b.y_um) + 800.0 * (a.theta_rad - b.theta_rad).abs();
    assert!(d > 1.0, "patch made no difference: {a:?} vs {b:?}");
}

/// Push along +x by 250 µm, then retract 200 µm back along −x while moving 100 µm sideways
/// (+y): the peg after the push and at the end.
fn push_and_retract_sideways(model: Model) -> (Pose, Pose) {
    follow(model, &[[X0_UM, 1300.0], [X0_UM + 250.0, 1300.0], [X0_UM + 50.0, 1400.0]])
}

/// The bond's own friction: a bond that sticks carries the peg sideways with a probe that
/// leaves obliquely; a frictionless one only pulls along the contact normal, and the probe
/// slides along the edge.
#[test]
fn a_sticking_bond_drags_the_peg_sideways_a_sliding_one_does_not() {
    let bond = |mu_bond| {
        let mut m = Model::default();
        m.effects.adhesion = Some(Adhesion { pull_off_weight: 1.5, range_um: 2.0, mu_bond });
        push_and_retract_sideways(m)
    };
    let (p0, e0) = bond(Some(0.0));
    let (p1, e1) = bond(Some(10.0));
    eprintln!("frictionless {p0:?} -> {e0:?}\nsticking {p1:?} -> {e1:?}");
    assert_eq!(p0, p1, "the push is the same whatever the bond");
    // Measured: the sticking bond carries the peg 5.3 µm along +y, the frictionless one
    // lets it fall back 4.6 µm; an ignored `mu_bond` would make them equal.
    let (side0, side1) = (e0.y_um - p0.y_um, e1.y_um - p1.y_um);
    assert!(side1 > side0 + 5.0, "sideways: sticking {side1:.2} µm, frictionless {side0:.2} µm");
    assert!(side1 > 0.0, "a sticking bond drags the peg the probe's way, got {side1:.2} µm");
}
