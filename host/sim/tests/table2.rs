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

/// The linearised friction cone converges: 8 directions (the paper's choice and our default),
/// 32 and 64 all insert and give nearly the same final pose. Caught the square-cornered
/// entrance of the first fixture reconstruction, where n_d ≥ 12 jammed Table II at the step
/// (docs/fixture.md, "Entrance chamfer").
#[test]
fn friction_cone_refinement_converges() {
    let r = |n| run(SimSettings { n_directions: n, ..Default::default() });
    let (r8, r32, r64) = (r(8), r(32), r(64));
    let (d_um, d_deg) = pose_change(&r32, &r64);
    let (e_um, e_deg) = pose_change(&r8, &r32);
    eprintln!(
        "n_d 32 vs 64: {d_um:.2} µm, {d_deg:.3}°; n_d 8 vs 32: {e_um:.1} µm, {e_deg:.2}° \
               (inserted: 8 {}, 32 {}, 64 {})",
        r8.inserted, r32.inserted, r64.inserted
    );
    assert!(d_um <= BOUND_UM && d_deg <= BOUND_DEG, "n_d 32 vs 64: {d_um} µm, {d_deg}°");
    assert!(e_um <= BOUND_UM && e_deg <= BOUND_DEG, "n_d 8 vs 32: {e_um} µm, {e_deg}°");
    assert!(r8.inserted && r32.inserted && r64.inserted);
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
