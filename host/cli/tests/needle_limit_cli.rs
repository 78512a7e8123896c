//! The needle's limit on the command line (issue 19, "Needle safety"): `sim` reports a plan's
//! peak deflection and force and calls a plan that bends the needle beyond the model's
//! `probe_deflection_limit_um` overloaded (exit 1, never "inserted"); `robustness` counts such
//! trials as failures with their own count; `plan robust` refuses a design whose nominal
//! replay overloads the needle, and `plan rrt` keeps no push that does.

use mesopush_sim::fixture::rect;
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Fixture, Model, Plan, SupportDistribution};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const HALF_LEN_UM: f64 = 807.5;
const WALL_X_UM: f64 = 900.0;

/// Runs `mesopush` with `args` (strings and paths alike).
fn mesopush<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).output().unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A model (symmetric supports), a fixture with a wall at x = 900 µm (and a far one on the
/// left) and a goal holding the peg stopped against it, and a push `past_stop_um` beyond where the wall stops the peg.
fn wall_files(dir: &Path, past_stop_um: f64) -> (PathBuf, PathBuf, PathBuf) {
    let model = Model {
        support: SupportDistribution {
            points_um: [[-300.0, -200.0], [-300.0, 200.0], [300.0, 0.0]],
            mu_surface: [0.3; 3],
        },
        ..Model::default()
    };
    let fixture = Fixture {
        // A far wall on the left too, so the start lies within the fixture (`sim` checks).
        walls: vec![
            rect(WALL_X_UM, -2000.0, WALL_X_UM + 1000.0, 2000.0).unwrap(),
            rect(-3000.0, -2000.0, -2500.0, 2000.0).unwrap(),
        ],
        goal: rect(50.0, -100.0, 150.0, 100.0).unwrap(),
        insert_depth_um: 1.0,
        goal_whole_part: false,
    };
    let plan = Plan {
        name: "into the wall".into(),
        speed_um_s: 140.0,
        peg_start: PegStart { x_um: 0.0, y_um: 0.0, theta_deg: 0.0 },
        probe_start_um: [-HALF_LEN_UM - 12.5 - 40.0, 0.0],
        moves_um: vec![[40.0 + WALL_X_UM - HALF_LEN_UM + past_stop_um, 0.0]],
    };
    (
        write(dir, "model.toml", &toml::to_string_pretty(&model).unwrap()),
        write(dir, "fixture.toml", &toml::to_string_pretty(&fixture).unwrap()),
        write(dir, "plan.toml", &plan.to_toml()),
    )
}

#[test]
fn sim_calls_a_plan_that_drives_the_peg_into_a_wall_overloaded_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let (model, fixture, plan) = wall_files(dir.path(), 150.0);
    let (json_out, text_out) = (dir.path().join("sim-json"), dir.path().join("sim-text"));
    let (p, m, f) = (plan.as_os_str(), model.as_os_str(), fixture.as_os_str());
    let sim = |out: &Path, json: bool| {
        let mut args = vec![OsStr::new("sim"), OsStr::new("--plan"), p, OsStr::new("--model"), m];
        args.extend([OsStr::new("--fixture"), f, OsStr::new("--out"), out.as_os_str()]);
        if json {
            args.push(OsStr::new("--json"));
        }
        mesopush(&args)
    };
    let (o, o2) = (sim(&json_out, true), sim(&text_out, false));
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        (&v["inserted"], &v["peg_in_goal"], &v["overloaded"]),
        (&false.into(), &true.into(), &true.into()),
        "{v}"
    );
    let peak = v["max_probe_deflection_um"].as_f64().unwrap();
    assert!((peak - 150.0).abs() < 2.0, "150 µm past the stop: {v}");
    assert_eq!(v["probe_deflection_limit_um"], 50.0);
    assert_eq!(v["probe_force_limit_weights"], 100.0);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("needle overload at move 1: 150 µm > 50 µm"), "{err}");
    // The text form says why it is not inserted, and the outputs are still written.
    assert_eq!(o2.status.code(), Some(1));
    let text = String::from_utf8_lossy(&o2.stdout);
    assert!(
        text.contains("inserted: NO (the peg ends in the goal, but the needle is overloaded)"),
        "{text}"
    );
    assert!(text.contains("OVERLOADED"), "{text}");
    assert!(text_out.join("trajectory.csv").exists() && json_out.join("fig6.png").exists());
}

#[test]
fn sim_of_the_same_push_within_the_limit_inserts_and_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let (model, fixture, plan) = wall_files(dir.path(), 20.0);
    let out = dir.path().join("sim");
    let o = mesopush(&[
        OsStr::new("sim"),
        OsStr::new("--json"),
        OsStr::new("--plan"),
        plan.as_os_str(),
        OsStr::new("--model"),
        model.as_os_str(),
        OsStr::new("--fixture"),
        fixture.as_os_str(),
        OsStr::new("--out"),
        out.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((&v["inserted"], &v["overloaded"]), (&true.into(), &false.into()), "{v}");
}

/// The words of a command line followed by paths, as one argument list.
fn line(words: &str, paths: &[&Path]) -> Vec<std::ffi::OsString> {
    let mut v: Vec<std::ffi::OsString> = words.split_whitespace().map(Into::into).collect();
    v.extend(paths.iter().map(|p| p.as_os_str().to_owned()));
    v
}

#[test]
fn robustness_counts_overloaded_trials_as_failures() {
    let dir = tempfile::tempdir().unwrap();
    let (model, fixture, plan) = wall_files(dir.path(), 150.0);
    let out = dir.path().join("rob");
    let args = line(
        "robustness run --samples 6 --dx-um 0 --dy-um 0 --dtheta-deg 0 --json --out",
        &[&out, Path::new("--model"), &model, Path::new("--fixture"), &fixture, &plan],
    );
    let o = mesopush(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((&v["successes"], &v["overloaded"]), (&0.into(), &6.into()), "{v}");
}

/// A needle that may bend only 0.1 µm: every push that moves the peg overloads it (Table
/// II's pushes bend it 0.8 µm).
fn stiff_model(dir: &Path) -> PathBuf {
    let m = Model { probe_deflection_limit_um: 0.1, ..Model::default() };
    write(dir, "stiff.toml", &toml::to_string_pretty(&m).unwrap())
}

#[test]
fn plan_robust_refuses_a_design_whose_nominal_replay_overloads_the_needle() {
    let dir = tempfile::tempdir().unwrap();
    let model = stiff_model(dir.path());
    let out = dir.path().join("robust.toml");
    let o = mesopush(&line(
        "plan robust --json --generations 1 --train-samples 2 --population 2 --elite 1 \
         --finalists 1 --validation-samples 2 --confirm-samples 0 --rounds 1 \
         --check-samples 2 --model",
        &[&model, Path::new("--out"), &out],
    ));
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.exists(), "a refused plan is not written");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((&v["found"], &v["plan"]), (&false.into(), &serde_json::Value::Null), "{v}");
    assert!(v["nominal_overload"]["peak_deflection_um"].as_f64().unwrap() > 0.1, "{v}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("refused and was not written") && err.contains("needle overload"),
        "{err}"
    );
}

#[test]
fn plan_rrt_keeps_no_push_that_overloads_the_needle() {
    let dir = tempfile::tempdir().unwrap();
    let model = stiff_model(dir.path());
    let out = dir.path().join("rrt.toml");
    let o = mesopush(&line(
        "plan rrt --seed 2 --max-iterations 20 --json --model",
        &[&model, Path::new("--out"), &out],
    ));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["found"], false, "{v}");
    assert!(v["overloaded_pushes"].as_u64().unwrap() > 0, "{v}");
    assert!(!out.exists());
}
