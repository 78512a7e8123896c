//! Table II of the paper replayed on the reconstructed fixture with the nominal model: the peg
//! must end in the narrow channel, never penetrate a wall beyond the stated tolerance, be
//! insensitive to the discretisation within stated bounds, and replay bit-identically.

use mesopush_sim::{Fixture, Model, Plan, Replay, SimSettings, Simulator, replay};

fn run(settings: SimSettings) -> Replay {
    let mut sim = Simulator::new(Model::default(), Fixture::paper(), settings).unwrap();
    replay(&mut sim, &Plan::table2(), None).unwrap()
}

#[test]
fn table2_inserts_the_peg_without_penetrating_a_wall() {
    let settings = SimSettings::default();
    let r = run(settings.clone());
    let p = r.final_pose;
    eprintln!(
        "Table II: inserted {}, final ({:.1} µm, {:.1} µm, {:.2}°), {} steps, max wall \
         penetration {:.4} µm, max needle deflection {:.3} µm",
        r.inserted,
        p.x_um,
        p.y_um,
        p.theta_rad.to_degrees(),
        r.steps,
        r.max_penetration_um,
        r.max_probe_deflection_um
    );
    assert!(r.events.is_empty(), "events: {:?}", r.events);
    assert!(r.inserted, "peg not in the narrow channel: {p:?}");
    assert!(
        r.max_penetration_um <= settings.penetration_tol_um,
        "penetration {} µm beyond the {} µm tolerance",
        r.max_penetration_um,
        settings.penetration_tol_um
    );
}

/// Bounds on how much the final pose may move when the discretisation is refined.
const BOUND_UM: f64 = 25.0;
const BOUND_DEG: f64 = 2.0;

fn pose_change(a: &Replay, b: &Replay) -> (f64, f64) {
    let (a, b) = (a.final_pose, b.final_pose);
    ((a.position() - b.position()).norm(), (a.theta_rad - b.theta_rad).to_degrees().abs())
}

#[test]
fn halving_the_step_barely_moves_the_final_pose() {
    let base = run(SimSettings::default());
    let half =
        run(SimSettings { step_um: SimSettings::default().step_um / 2.0, ..Default::default() });
    let (d_um, d_deg) = pose_change(&base, &half);
    eprintln!("half step: final pose moves {d_um:.3} µm, {d_deg:.4}°; inserted {}", half.inserted);
    assert!(half.inserted, "half step: not inserted");
    assert!(d_um <= BOUND_UM && d_deg <= BOUND_DEG, "half step: {d_um} µm, {d_deg}°");
}

/// The paper's polygonal cone converges to the exact circular one as it gets more directions
/// (body frame): 64 directions end Table II near the exact cone's pose, and the exact cone
/// inserts. The paper's 8 directions are reported, not bounded: they are the coarse model the
/// exact cone replaces. Caught the square-cornered entrance of the first fixture
/// reconstruction, where finer cones jammed Table II at the step (docs/fixture.md,
/// "Entrance chamfer").
#[test]
fn friction_cone_refinement_converges() {
    use mesopush_sim::SupportFriction;
    let poly = |n| {
        run(SimSettings {
            n_directions: n,
            support_friction: SupportFriction::Polygon,
            ..Default::default()
        })
    };
    let (exact, p8, p64) = (run(SimSettings::default()), poly(8), poly(64));
    let (d_um, d_deg) = pose_change(&p64, &exact);
    let (e_um, e_deg) = pose_change(&p8, &exact);
    eprintln!(
        "exact cone vs polygon n_d 64: {d_um:.2} µm, {d_deg:.3}°; vs n_d 8: {e_um:.1} µm, \
         {e_deg:.2}° (inserted: exact {}, 64 {}, 8 {})",
        exact.inserted, p64.inserted, p8.inserted
    );
    assert!(d_um <= BOUND_UM && d_deg <= BOUND_DEG, "n_d 64 vs exact: {d_um} µm, {d_deg}°");
    assert!(exact.inserted && p64.inserted);
}

#[test]
fn same_inputs_give_bit_identical_trajectories() {
    let a = run(SimSettings::default());
    let b = run(SimSettings::default());
    assert_eq!(a.samples.len(), b.samples.len());
    for (x, y) in a.samples.iter().zip(&b.samples) {
        let bits = |s: &mesopush_sim::replay::Sample| {
            [
                s.t_s,
                s.probe_um[0],
                s.probe_um[1],
                s.peg.x_um,
                s.peg.y_um,
                s.peg.theta_rad,
                s.probe_force,
            ]
            .map(f64::to_bits)
        };
        assert_eq!(bits(x), bits(y));
        assert_eq!(x.contacts, y.contacts);
    }
}
