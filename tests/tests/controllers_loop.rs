//! Table II through the whole loop on each emulated commercial controller (issue 20): plan →
//! flash → executor core → point-to-point adapter (one move per plan step) → the
//! controller's own wire protocol over a real pseudo-terminal (or loopback UDP for the
//! Sensapex) → the firmware simulator's emulator of that controller, written from the
//! vendor's public documentation independently of the adapter → stage → world → camera →
//! tracking → verdict, in simulated time. Each run exercises its controller's quirks on the
//! way: the MPC-200's pause inside `S` (without it the emulator crashes) and its silent
//! end-of-move CR, the MP-285's position read only when needed (its knob hang), the
//! Scientifica's "finished" 30 ms before the stage stops, the Sensapex's notifications.

use mesopush_rig::drive::spec::ControllerKind;
use mesopush_rig::{ClockMode, TrialReport, TrialSpec, WorldFile, run_trial};
use mesopush_sim::{Fixture, Model, Plan, SimSettings, Simulator, replay};
use mesopush_trial::{Trial, TrialState};

/// The default world filming at 4 Hz (the renderer and tracker run on every frame), no
/// injected faults.
fn world() -> WorldFile {
    let text = "name = \"controllers\"\n[camera]\nperiod_us = 250000\n";
    WorldFile::from_toml(text, None).expect("test world")
}

fn run(controller: ControllerKind, seed: u64) -> (TrialReport, Trial) {
    let spec = TrialSpec {
        trial_id: format!("{}-{seed}", controller.name()),
        plan: Plan::table2(),
        world: world(),
        seed,
        clock: ClockMode::Simulated,
        peg_start: None,
        controller,
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("trial");
    let r = run_trial(&spec, &out, &mut |_| {})
        .unwrap_or_else(|e| panic!("{} seed {seed}: {e}", controller.name()));
    let trial = Trial::load(&out).unwrap();
    (r, trial)
}

fn inserts(controller: ControllerKind) {
    let seed = 5;
    let name = controller.name();
    let (r, trial) = run(controller, seed);
    assert_eq!(r.state, TrialState::Done, "{name} seed {seed}: {r:?}");
    assert_eq!(r.inserted, Some(true), "{name} seed {seed}: {r:?}");
    // One move per plan step, each checked at its target by the adapter.
    let steps = Plan::table2().moves_um.len() as u64;
    assert_eq!(r.segments_expected, steps, "{name}");
    assert_eq!(r.segments_applied, steps, "{name}: moves completed at their targets");
    assert_eq!(r.faults_detected, 0, "{name}: {:?}", r.reason);
    assert_eq!(r.jams, 0, "{name}: the needle jammed (peak {} µm)", r.max_deflection_um);
    // The peg ends where the host's model says (the world runs the same model; the
    // controllers move at their own quantised speeds, which a quasi-static push ignores).
    let mut sim =
        Simulator::new(Model::default(), Fixture::paper(), SimSettings::default()).unwrap();
    let predicted = replay(&mut sim, &Plan::table2(), None).unwrap().final_pose;
    let f = r.true_final_pose.unwrap();
    let d = ((f.x_um - predicted.x_um).powi(2) + (f.y_um - predicted.y_um).powi(2)).sqrt();
    assert!(d < 15.0, "{name}: true final {f:?} vs predicted {predicted:?}");
    // Frames were stamped with the adapter's positions (measured or estimated), and the
    // tracker followed the peg.
    assert!(r.frames_compared >= 150, "{name}: {} frames compared", r.frames_compared);
    assert!(r.track_error_um_max < 10.0, "{name}: {} µm", r.track_error_um_max);
    assert!(trial.probe.iter().filter(|p| p.rep_x_um.is_some()).count() > 1000, "{name}");
}

#[test]
fn table2_inserts_on_an_emulated_sutter_mpc200() {
    inserts(ControllerKind::Mpc200);
}

#[test]
fn table2_inserts_on_an_emulated_sutter_mp285() {
    inserts(ControllerKind::Mp285);
}

#[test]
fn table2_inserts_on_an_emulated_scientifica_v3_card() {
    inserts(ControllerKind::Scientifica);
}

#[test]
fn table2_inserts_on_an_emulated_sensapex_ump_over_udp() {
    inserts(ControllerKind::Sensapex);
}
