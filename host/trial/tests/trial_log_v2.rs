//! Trial-log format version 2: the documented example loads as documented; version 1 still
//! reads (as a one-disc pusher); a two-disc pusher, the pusher angle and a fractional frame
//! period survive writer → reader; every refusal names the field and the value; pose rows
//! whose time steps back a little are dropped and counted, a larger step is refused.

use mesopush_sim::{Disc, Part, Pusher};
use mesopush_trial::{Outcome, PoseRow, ProbeRow, Trial, TrialMeta, TrialState, TrialWriter};
use std::path::{Path, PathBuf};

fn docs_trial_log() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/trial-log.md")
}

/// The fenced blocks of `markdown` whose info string says `example:NAME`, as (NAME, text).
fn example_blocks(markdown: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut lines = markdown.lines();
    while let Some(line) = lines.next() {
        let Some(name) = line
            .strip_prefix("```")
            .and_then(|info| info.split_whitespace().find_map(|w| w.strip_prefix("example:")))
        else {
            continue;
        };
        let body: Vec<&str> = lines.by_ref().take_while(|l| !l.starts_with("```")).collect();
        out.push((name.to_string(), body.join("\n") + "\n"));
    }
    out
}

#[test]
fn the_documented_example_loads() {
    let doc = std::fs::read_to_string(docs_trial_log()).unwrap();
    let blocks = example_blocks(&doc);
    let names: Vec<&str> = blocks.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["trial.json", "probe.csv", "pose.csv"], "the doc's example blocks");
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in &blocks {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let t = Trial::load(dir.path()).unwrap();
    assert_eq!(t.meta.format_version, 2);
    assert_eq!(t.meta.pusher(), Pusher::two_finger(2500.0, 24_000.0));
    assert_eq!(t.meta.fixture, None);
    assert_eq!(t.meta.part.polygon().len(), 4);
    let path = t.commanded_path();
    let theta: Vec<f64> = path.iter().map(|p| p.probe_theta_rad).collect();
    assert_eq!(theta, [0.0, 0.0, 0.02]);
    assert_eq!((path[2].t_s, path[2].probe_um.x, path[2].probe_theta_rad), (1.0, -22_500.0, 0.02));
    assert_eq!(t.poses().unwrap().len(), 3);
    assert!(t.pose_rows_dropped.is_empty() && t.load_note().is_none());
}

fn write(dir: &Path, meta: &str, probe: &str, pose: &str) {
    std::fs::write(dir.join("trial.json"), meta).unwrap();
    std::fs::write(dir.join("probe.csv"), probe).unwrap();
    std::fs::write(dir.join("pose.csv"), pose).unwrap();
}

const SQUARE: &str = r#""part": {"vertices_um": [[0,0],[1000,0],[1000,1000],[0,1000]]}"#;
const PROBE: &str = "t_us,cmd_x_um,cmd_y_um\n0,-100,500\n1000,-50,500\n";
const POSE: &str = "t_us,x_um,y_um,theta_rad\n0,500,500,0\n";

fn v1(extra: &str) -> String {
    format!(
        r#"{{"format": "mesopush-trial", "format_version": 1, "trial_id": "v1", "source": "x",
            {SQUARE}, {extra} "outcome": {{"state": "done"}}}}"#
    )
}

fn v2(extra: &str) -> String {
    format!(
        r#"{{"format": "mesopush-trial", "format_version": 2, "trial_id": "v2", "source": "x",
            {SQUARE}, {extra} "outcome": {{"state": "done"}}}}"#
    )
}

const ONE_DISC: &str = r#""pusher": {"discs": [{"center_um": [0, 0], "radius_um": 12.5}]},"#;

#[test]
fn version_1_reads_as_a_one_disc_pusher() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), &v1(r#""probe_radius_um": 4.7, "frame_period_us": 33333,"#), PROBE, POSE);
    let t = Trial::load(dir.path()).unwrap();
    assert_eq!(t.meta.pusher(), Pusher::single(4.7));
    assert_eq!(t.meta.pusher(), Pusher::single(4.7));
    assert_eq!(t.meta.frame_period_us, Some(33_333.0));
    assert_eq!(t.meta.format_version, 2, "a version-1 file loads as its version-2 equivalent");
    assert!(t.commanded_path().iter().all(|p| p.probe_theta_rad == 0.0));
    write(dir.path(), &v1(""), PROBE, POSE);
    assert_eq!(Trial::load(dir.path()).unwrap().meta.pusher(), Pusher::single(12.5));
    // Version 2 with the project writer's explicit nulls.
    let nulls = r#""fixture": null, "plan": null, "calibration": null, "frame_period_us": null,
        "world": null, "import": null,"#;
    write(dir.path(), &v2(&format!("{ONE_DISC} {nulls}")), PROBE, POSE);
    let t = Trial::load(dir.path()).unwrap();
    assert_eq!((t.meta.fixture, t.meta.frame_period_us), (None, None));
}

fn two_finger_meta() -> TrialMeta {
    let mut m = TrialMeta::new("rt-1", "test", Part::default_peg());
    m.pusher = Pusher {
        discs: vec![
            Disc { center_um: [-300.0, -900.0], radius_um: 250.0 },
            Disc { center_um: [-300.0, 900.0], radius_um: 100.0 },
        ],
    };
    m.frame_period_us = Some(33_333.3);
    m.import = Some(serde_json::json!({"note": "round trip"}));
    m
}

fn angled(i: i64) -> ProbeRow {
    ProbeRow {
        t_us: i * 20_000,
        cmd_x_um: -2000.0 + 10.0 * i as f64,
        cmd_y_um: 0.5 * i as f64,
        rep_x_um: None,
        rep_y_um: None,
        cmd_theta_rad: Some(0.001 * i as f64 - 0.05),
    }
}

#[test]
fn version_2_round_trips_a_two_disc_pusher_and_the_angle() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rt");
    let meta = two_finger_meta();
    let mut w = TrialWriter::create(&path, meta.clone()).unwrap();
    for i in 0..50 {
        w.probe(&angled(i)).unwrap();
    }
    let out = Outcome { state: TrialState::Done, reason: None, inserted: None };
    w.finish(out.clone()).unwrap();
    let json = std::fs::read_to_string(path.join("trial.json")).unwrap();
    assert!(json.contains("\"format_version\": 2") && json.contains("\"pusher\""), "{json}");
    assert!(!json.contains("probe_radius_um"), "{json}");
    let header = std::fs::read_to_string(path.join("probe.csv")).unwrap();
    assert!(header.starts_with("t_us,cmd_x_um,cmd_y_um,rep_x_um,rep_y_um,cmd_theta_rad\n"));

    let t = Trial::load(&path).unwrap();
    assert_eq!(t.meta, TrialMeta { outcome: out, ..meta });
    assert_eq!(t.probe, (0..50).map(angled).collect::<Vec<_>>());
    let p = t.commanded_path();
    assert_eq!(p[49].probe_theta_rad, angled(49).cmd_theta_rad.unwrap());
    assert_eq!((p[10].probe_um.x, p[10].probe_um.y), (-1900.0, 5.0));
    assert_eq!(t.meta.pusher().discs.len(), 2);
}

#[test]
fn the_writer_refuses_a_row_that_disagrees_on_the_angle_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = TrialWriter::create(&dir.path().join("w"), two_finger_meta()).unwrap();
    w.probe(&angled(0)).unwrap();
    let e = w.probe(&ProbeRow { cmd_theta_rad: None, ..angled(1) }).unwrap_err().to_string();
    assert!(e.contains("cmd_theta_rad") && e.contains("row 2"), "{e}");
    let mut bad = two_finger_meta();
    bad.pusher.discs[1].center_um = [-300.0, -800.0];
    let e = TrialWriter::create(&dir.path().join("b"), bad).unwrap_err().to_string();
    assert!(e.contains("overlap"), "{e}");
}

/// Loads (meta, probe, pose) and returns the error message.
fn refusal(meta: &str, probe: &str, pose: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), meta, probe, pose);
    match Trial::load(dir.path()) {
        Ok(_) => panic!("loaded, but should be refused:\n{meta}\n{probe}\n{pose}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn trial_json_refusals_name_the_field_and_the_value() {
    let cases: Vec<(String, &str, &str, Vec<&str>)> = vec![
        (v2(""), PROBE, POSE, vec!["trial.json", "format_version 2 requires `pusher`"]),
        (
            v2(&format!(r#"{ONE_DISC} "probe_radius_um": 3,"#)),
            PROBE,
            POSE,
            vec!["probe_radius_um = 3", "version-1 field"],
        ),
        (v1(ONE_DISC), PROBE, POSE, vec!["`pusher` is a version-2 field"]),
        (v1(r#""probe_radius_um": -1,"#), PROBE, POSE, vec!["probe_radius_um = -1", "≥ 0"]),
        (
            v2(r#""pusher": {"discs": [{"center_um": [0, 0], "radius_um": 5},
                                       {"center_um": [0, 6], "radius_um": 5}]},"#),
            PROBE,
            POSE,
            vec!["pusher", "discs[0] and discs[1] overlap"],
        ),
        (
            v2(r#""pusher": {"discs": [{"center_um": [0, 0], "radius": 5}]},"#),
            PROBE,
            POSE,
            vec!["field pusher.discs[0]", "radius"],
        ),
        (
            v2(&format!(r#"{ONE_DISC} "frame_period_us": 0,"#)),
            PROBE,
            POSE,
            vec!["frame_period_us = 0", "> 0"],
        ),
        (
            v2(&format!(r#"{ONE_DISC} "frame_period_us": "fast","#)),
            PROBE,
            POSE,
            vec!["field frame_period_us", "\"fast\""],
        ),
        (
            v2(&format!(
                r#"{ONE_DISC} "units": {{"length": "mm", "angle": "rad", "time": "us"}},"#
            )),
            PROBE,
            POSE,
            vec!["units", "mm"],
        ),
        (v2(ONE_DISC).replace("mesopush-trial", "other"), PROBE, POSE, vec!["format = \"other\""]),
    ];
    for (meta, probe, pose, wanted) in cases {
        let e = refusal(&meta, probe, pose);
        eprintln!("{e}");
        for w in wanted {
            assert!(e.contains(w), "{w:?} not in {e:?}");
        }
    }
}

#[test]
fn csv_refusals_name_the_row_column_and_value() {
    let cases: Vec<(String, &str, &str, Vec<&str>)> = vec![
        (
            v2(ONE_DISC),
            "t_us,cmd_x_um,cmd_y_um\n0,1,2\n5,x,2\n",
            POSE,
            vec!["probe.csv", "line 3", "column cmd_x_um = \"x\""],
        ),
        (
            v2(ONE_DISC),
            "t_us,cmd_x_um,cmd_y_um\n0,1,NaN\n",
            POSE,
            vec!["probe.csv", "line 2", "column cmd_y_um = NaN", "finite"],
        ),
        (
            v2(ONE_DISC),
            "t_us,cmd_x_um,cmd_y_um,cmd_theta_rad\n0,1,2,0.5\n5,1,2,\n",
            POSE,
            vec!["probe.csv", "line 3", "cmd_theta_rad is empty", "0.5"],
        ),
        (
            v2(ONE_DISC),
            "t_us,cmd_x_um,cmd_y_um\n9,1,2\n5,1,2\n",
            POSE,
            vec!["probe.csv", "line 3", "t_us = 5 goes backwards"],
        ),
        (v2(ONE_DISC), "t_us,cmd_x_um\n0,1\n", POSE, vec!["probe.csv", "line 2", "cmd_y_um"]),
        (
            v2(ONE_DISC),
            PROBE,
            "t_us,x_um,y_um,theta_rad\n0,1,2,3\n1,1,2\n",
            vec!["pose.csv", "line 3", "3 fields", "header has 4"],
        ),
        (
            v2(ONE_DISC),
            PROBE,
            "t_us,x_um,y_um,theta_rad\n0,1,2,inf\n",
            vec!["pose.csv", "column theta_rad = inf"],
        ),
    ];
    for (meta, probe, pose, wanted) in cases {
        let e = refusal(&meta, probe, pose);
        eprintln!("{e}");
        for w in wanted {
            assert!(e.contains(w), "{w:?} not in {e:?}");
        }
    }
}

fn pose_csv(times: &[i64]) -> String {
    let mut s = String::from("t_us,x_um,y_um,theta_rad\n");
    for (i, t) in times.iter().enumerate() {
        s += &format!("{t},{},0,0\n", 500 + i);
    }
    s
}

#[test]
fn pose_rows_stepping_back_up_to_20_ms_are_dropped_and_counted_beyond_refused() {
    let dir = tempfile::tempdir().unwrap();
    let times = [0, 33_333, 66_666, 50_000, 46_666, 100_000, 100_000, 120_000];
    write(dir.path(), &v2(ONE_DISC), PROBE, &pose_csv(&times));
    let t = Trial::load(dir.path()).unwrap();
    let kept: Vec<i64> = t.poses().unwrap().iter().map(|p| p.t_us).collect();
    assert_eq!(kept, [0, 33_333, 66_666, 100_000, 100_000, 120_000], "equal times are kept");
    let lines: Vec<(u64, i64, i64)> =
        t.pose_rows_dropped.iter().map(|d| (d.line, d.t_us, d.after_t_us)).collect();
    assert_eq!(lines, [(5, 50_000, 66_666), (6, 46_666, 66_666)], "20 000 µs back is dropped");
    let note = t.load_note().unwrap();
    assert!(note.contains("2 pose.csv row(s) dropped") && note.contains("line 5"), "{note}");
    assert_eq!(
        t.poses().unwrap()[3],
        PoseRow { t_us: 100_000, x_um: 505.0, ..t.poses().unwrap()[3] }
    );

    let e = refusal(&v2(ONE_DISC), PROBE, &pose_csv(&[0, 33_333, 66_666, 46_665]));
    assert!(
        e.contains("pose.csv") && e.contains("line 5") && e.contains("goes back 20001 µs"),
        "{e}"
    );
}
