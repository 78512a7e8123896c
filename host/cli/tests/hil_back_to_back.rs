//! Hardware-in-the-loop trials back to back through the separate processes, as an operator
//! runs them: `mesopush-fwsim` and `mesopush-executor` stay up; per trial `mesopush rig goto
//! --plan` (the probe back to the plan's start) and `mesopush run`. Between them the
//! safety refusals: a run with the probe where the last trial left it is refused (exit 2,
//! both positions named, nothing moves), a plan starting outside the workspace is refused,
//! `rig status` reports the absolute position and `rig stop` answers in any state.
//!
//! Trials: `MESOPUSH_HIL_TRIALS` (default 20; each a 0.5 s push, ≈ 3 s with its goto and
//! recording on the 2-core machine). See docs/hil.md for the count run by hand.

mod hil_common;

use hil_common::{MESOPUSH, start_rig};
use std::process::Command;
use std::time::Duration;

/// A 0.5 s push of 100 µm from Table II's probe start (the peg is 70 µm to its left).
const PLAN: &str = r#"
name = "half-second push"
speed_um_s = 200.0
probe_start_um = [2900.0, 1000.0]
moves_um = [[-100.0, 0.0]]

[peg_start]
x_um = 2330.0
y_um = 1210.0
theta_deg = 89.0
"#;

/// The issue's plan: its start (−50 000, −50 000) µm is 5 cm off the fixture.
const FAR_PLAN: &str = r#"
name = "far away"
speed_um_s = 200.0
probe_start_um = [-50000.0, -50000.0]
moves_um = [[-100.0, 0.0]]

[peg_start]
x_um = 2330.0
y_um = 1210.0
theta_deg = 89.0
"#;

/// A start the plan loader accepts (inside ±20 mm) but 15 mm left of the fixture: outside
/// the executor's 0..10 mm stage workspace, so run and goto are refused by the rig.
const OUTSIDE_PLAN: &str = r#"
name = "outside the workspace"
speed_um_s = 200.0
probe_start_um = [-15000.0, 1000.0]
moves_um = [[-100.0, 0.0]]

[peg_start]
x_um = 2330.0
y_um = 1210.0
theta_deg = 89.0
"#;

fn text(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn status_json(rig: &hil_common::RigProcs) -> serde_json::Value {
    let o = rig.rig(&["status", "--json"]);
    assert!(o.status.success(), "status: {}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn hil_trials_back_to_back_with_goto_start_between() {
    let trials: usize =
        std::env::var("MESOPUSH_HIL_TRIALS").ok().and_then(|v| v.parse().ok()).unwrap_or(20);
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let plan = d.join("push.toml");
    std::fs::write(&plan, PLAN).unwrap();
    let rig = start_rig(d, &plan);
    rig.flash(&plan);
    let s = status_json(&rig);
    assert_eq!(s["probe_fixture_um"], serde_json::json!([2900.0, 1000.0]), "{s}");

    for i in 0..trials {
        let goto = rig.rig(&["goto", "--plan", plan.to_str().unwrap()]);
        assert!(goto.status.success(), "trial {i}: goto: {}", text(&goto));
        assert!(text(&goto).contains("arrived: fixture ("), "{}", text(&goto));
        // On the start to the encoder's 0.1 µm (the report may trail the settling stage by
        // a count).
        let s = status_json(&rig);
        let p = &s["probe_fixture_um"];
        let off = (p[0].as_f64().unwrap() - 2900.0).hypot(p[1].as_f64().unwrap() - 1000.0);
        assert!(off < 0.5, "trial {i}: goto ended {off} µm off the start: {s}");
        let out = d.join(format!("trial-{i}"));
        let run = rig.run(&plan, &out, Duration::from_secs(120));
        let code = run.status.code();
        // A 100 µm push does not insert: exit 1 with a done trial (a fault would be 1 too,
        // and is caught by the state below).
        assert_eq!(code, Some(1), "trial {i}: {}", text(&run));
        let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
        assert_eq!(v["state"], "done", "trial {i}: {v}");
        // Every frame of the 0.5 s push at 30 Hz is accounted for, recorded or marked
        // dropped (on a loaded machine the live recorder drops frames — CI saw 4 kept and
        // 17 dropped with five builds beside it; frame delivery is the executor bench's
        // subject, not this test's), and at least one was recorded.
        let (kept, dropped) =
            (v["frames"].as_u64().unwrap(), v["dropped_frames"].as_u64().unwrap());
        assert!(kept >= 1 && kept + dropped >= 15, "trial {i}: {v}");
        // The probe ends 100 µm left of the start.
        let s = status_json(&rig);
        let x = s["probe_fixture_um"][0].as_f64().unwrap();
        assert!((x - 2800.0).abs() < 1.0, "trial {i}: probe at {s}");

        if i == 0 {
            // Where the last trial left it: `run` is refused, naming both positions and
            // what to do, and nothing moves.
            let refused = rig.run(&plan, &d.join("refused"), Duration::from_secs(60));
            let t = text(&refused);
            assert_eq!(refused.status.code(), Some(2), "{t}");
            assert!(t.contains("(3800.0, 2000.0) µm") && t.contains("(3900.0, 2000.0) µm"), "{t}");
            assert!(t.contains("5.0 µm") && t.contains("rig goto --plan"), "{t}");
            assert_eq!(status_json(&rig)["probe_fixture_um"], s["probe_fixture_um"]);
            // The issue's plan (a start of −50 000 µm): refused by the plan loader at flash,
            // run and goto alike (outside the ±20 mm a plan may state), naming the field; the
            // probe stays.
            let far = d.join("far.toml");
            std::fs::write(&far, FAR_PLAN).unwrap();
            let flash = Command::new(MESOPUSH)
                .arg("flash")
                .arg(&far)
                .args(["--port", &rig.host, "--json"])
                .output()
                .unwrap();
            let run = rig.run(&far, &d.join("far"), Duration::from_secs(60));
            let goto = rig.rig(&["goto", "--plan", far.to_str().unwrap()]);
            for o in [&flash, &run, &goto] {
                assert_eq!(o.status.code(), Some(2), "{}", text(o));
                assert!(text(o).contains("probe_start_um"), "{}", text(o));
            }
            assert_eq!(status_json(&rig)["probe_fixture_um"], s["probe_fixture_um"]);
            // A start the loader accepts but the rig's workspace does not: flashed, then
            // refused at run and at goto by the executor; the probe stays.
            let out = d.join("outside.toml");
            std::fs::write(&out, OUTSIDE_PLAN).unwrap();
            rig.flash(&out);
            let run = rig.run(&out, &d.join("outside"), Duration::from_secs(60));
            assert_eq!(run.status.code(), Some(2), "{}", text(&run));
            assert!(text(&run).contains("outside the rig's workspace"), "{}", text(&run));
            assert!(text(&run).contains("(-15000.0, 1000.0) µm"), "{}", text(&run));
            let goto = rig.rig(&["goto", "--plan", out.to_str().unwrap()]);
            assert_eq!(goto.status.code(), Some(2), "{}", text(&goto));
            assert!(text(&goto).contains("outside the workspace"), "{}", text(&goto));
            assert_eq!(status_json(&rig)["probe_fixture_um"], s["probe_fixture_um"]);
            // Stop when nothing moves: answered, state kept.
            let stop = rig.rig(&["stop"]);
            assert!(stop.status.success(), "{}", text(&stop));
            rig.flash(&plan);
        }
    }
    let recorded = std::fs::read_dir(&rig.rec).unwrap().count();
    assert_eq!(recorded, trials, "one recording per trial");
    let o = Command::new(MESOPUSH).args(["rig", "--help"]).output().unwrap();
    assert!(text(&o).contains("goto") && text(&o).contains("stop"));
}
