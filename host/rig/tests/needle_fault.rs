//! The needle's limit through the whole loop (issue 19, "Needle safety"): the world's model
//! sets the controller's limit, the world reports the needle's deflection, and a push that
//! holds the peg against a wall while the stage goes on faults the trial `NeedleOverload`
//! with a reason an operator acts on; within the limit the same push runs to its end.
//!
//! Geometry (expected values): the peg lies level 100 µm below the wide channel's upper wall
//! (y = 300 µm); the probe starts 40 µm below it and moves 290 µm up, so the stage goes 150
//! µm past the point where the wall stops the peg — 150 µm of needle deflection.

use mesopush_rig::{ClockMode, TrialSpec, WorldFile, run_trial};
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Model, Plan, SupportDistribution};
use mesopush_trial::{Trial, TrialState};
use std::path::Path;

const PEG_Y_UM: f64 = 300.0 + 492.5 + 100.0;

fn world(dir: &Path, limit_um: f64) -> WorldFile {
    // Supports symmetric about the push's line: the peg translates straight up.
    let model = Model {
        support: SupportDistribution {
            points_um: [[-300.0, -200.0], [300.0, -200.0], [0.0, 300.0]],
            mu_surface: [0.3; 3],
        },
        probe_deflection_limit_um: limit_um,
        ..Model::default()
    };
    std::fs::write(dir.join("model.toml"), toml::to_string_pretty(&model).unwrap()).unwrap();
    let text = format!(
        "name = \"needle\"\n[model]\npath = \"model.toml\"\n[peg]\nstart = {{ x_um = 2330.0, \
         y_um = {PEG_Y_UM}, theta_deg = 0.0 }}\n[camera]\nperiod_us = 250000\n"
    );
    WorldFile::from_toml(&text, Some(&dir.join("world.toml"))).unwrap()
}

fn push_into_the_wall() -> Plan {
    Plan {
        name: "into the upper wall".into(),
        speed_um_s: 140.0,
        peg_start: PegStart { x_um: 2330.0, y_um: PEG_Y_UM, theta_deg: 0.0 },
        probe_start_um: [2330.0, PEG_Y_UM + 492.5 + 12.5 + 40.0],
        moves_um: vec![[0.0, -290.0]],
    }
}

fn run(limit_um: f64, seed: u64) -> (mesopush_rig::TrialReport, Trial, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let spec = TrialSpec {
        trial_id: format!("needle-{limit_um}"),
        plan: push_into_the_wall(),
        world: world(dir.path(), limit_um),
        seed,
        clock: ClockMode::Simulated,
        peg_start: None,
        controller: mesopush_rig::drive::spec::ControllerKind::Native,
    };
    let out = dir.path().join("trial");
    let r = run_trial(&spec, &out, &mut |_| {}).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
    let t = Trial::load(&r.dir).unwrap();
    (r, t, dir)
}

#[test]
fn a_push_that_bends_the_needle_past_the_worlds_limit_faults_the_trial() {
    let seed = 3;
    let (r, t, _dir) = run(50.0, seed);
    assert_eq!(r.state, TrialState::Faulted, "seed {seed}: {r:?}");
    let reason = r.reason.clone().unwrap_or_default();
    assert!(reason.contains("the needle bent beyond its limit"), "seed {seed}: {reason}");
    assert_eq!(r.deflection_limit_um, 50.0);
    let ctrl_fault = t.events.iter().find(|e| e.kind == "ctrl_fault");
    let detail = &ctrl_fault.unwrap_or_else(|| panic!("seed {seed}: {:?}", t.events)).detail;
    assert!(detail.contains("needle bent beyond its limit"), "{detail}");
    // The controller stopped the stage just past the limit, far short of 150 µm of bend.
    assert!(
        r.max_deflection_um > 50.0 && r.max_deflection_um < 60.0,
        "seed {seed}: {} µm",
        r.max_deflection_um
    );
}

#[test]
fn the_same_push_within_the_worlds_limit_runs_to_its_end() {
    let seed = 3;
    let (r, _t, _dir) = run(200.0, seed);
    assert_eq!(r.state, TrialState::Done, "seed {seed}: {r:?}");
    assert!((r.max_deflection_um - 150.0).abs() < 6.0, "seed {seed}: {}", r.max_deflection_um);
    assert_eq!(r.jams, 0, "150 µm is within a 200 µm limit");
}
