//! Trial logs: written rows come back; a trial that never finished says so; bad files are
//! refused with the file and line; a trial tracked elsewhere (no frames) loads.

use mesopush_sim::{Part, Plan};
use mesopush_trial::{
    EventRow, FrameRow, Outcome, PoseRow, ProbeRow, Trial, TrialMeta, TrialState, TrialWriter,
};

fn page_meta(index: u64, t_us: i64) -> mesopush_framestore::PageMeta {
    mesopush_framestore::PageMeta { index, t_capture_us: Some(t_us) }
}

fn meta() -> TrialMeta {
    let mut m = TrialMeta::new("trial-0001", "test", Part::default_peg());
    m.plan = Some(Plan::table2());
    m.seeds.insert("world".into(), 7);
    m
}

fn probe(i: i64) -> ProbeRow {
    let x = 100.0 + i as f64;
    ProbeRow {
        t_us: i * 10_000,
        cmd_x_um: x,
        cmd_y_um: 5.0,
        rep_x_um: Some(x - 0.1),
        rep_y_um: None,
        cmd_theta_rad: None,
    }
}

#[test]
fn rows_written_come_back_and_the_outcome_is_final() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t1");
    let mut w = TrialWriter::create(&path, meta()).unwrap();
    for i in 0..200 {
        w.probe(&probe(i)).unwrap();
    }
    let frame = FrameRow {
        index: 0,
        frame_seq: 5,
        t_capture_us: Some(1_000),
        t_arrival_us: Some(16_000),
        stamp_source: "driver".into(),
        dropped: false,
        black: false,
        probe_x_um: Some(101.0),
        probe_y_um: Some(5.0),
        file: Some(w.frame_image(page_meta(0, 1_000), 4, 2, &[9, 8, 7, 6, 5, 4, 3, 2]).unwrap()),
    };
    w.frame(&frame).unwrap();
    w.event(&EventRow { t_us: 0, kind: "started".into(), detail: String::new() }).unwrap();
    let pose = PoseRow {
        t_us: 1_000,
        x_um: 1.0,
        y_um: 2.0,
        theta_rad: 0.5,
        frame_index: Some(0),
        residual_px: Some(0.1),
        probe_tip_x_um: None,
        probe_tip_y_um: None,
    };
    w.pose(&pose).unwrap();
    let out = Outcome { state: TrialState::Done, reason: None, inserted: Some(true) };
    w.finish(out.clone()).unwrap();

    let t = Trial::load(&path).unwrap();
    assert_eq!(t.meta.outcome, out);
    assert_eq!(t.meta.plan, Some(Plan::table2()));
    assert_eq!(t.probe, (0..200).map(probe).collect::<Vec<_>>());
    assert_eq!(t.frames, vec![frame]);
    assert_eq!(t.pose.as_deref(), Some(&[pose][..]));
    assert_eq!(t.events.len(), 1);
    assert_eq!(t.commanded_path().len(), 200);
    assert_eq!(t.frames[0].file.as_deref(), Some("frames.tif#0"));
    let mut store = mesopush_framestore::FrameStore::open(&path.join("frames.tif")).unwrap();
    assert_eq!(store.read(0).unwrap().pixels, [9, 8, 7, 6, 5, 4, 3, 2]);
    let header = std::fs::read_to_string(path.join("probe.csv")).unwrap();
    assert!(header.starts_with("t_us,cmd_x_um,cmd_y_um,rep_x_um,rep_y_um\n"), "{header}");
}

#[test]
fn an_unfinished_trial_keeps_its_rows_and_says_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t2");
    let mut w = TrialWriter::create(&path, meta()).unwrap();
    for i in 0..100 {
        w.probe(&probe(i)).unwrap();
    }
    w.flush().unwrap();
    std::mem::forget(w); // as if the process died: no finish, no drop
    let t = Trial::load(&path).unwrap();
    assert_eq!(t.meta.outcome.state, TrialState::Incomplete);
    assert_eq!(t.probe.len(), 100);
    assert!(t.poses().unwrap_err().to_string().contains("no tracked poses"));
    // A second writer refuses to overwrite it.
    assert!(TrialWriter::create(&path, meta()).unwrap_err().to_string().contains("refusing"));
}

#[test]
fn bad_files_are_refused_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t3");
    TrialWriter::create(&path, meta()).unwrap().finish(Outcome::incomplete()).unwrap();
    std::fs::write(
        path.join("probe.csv"),
        "t_us,cmd_x_um,cmd_y_um,rep_x_um,rep_y_um\n0,1,2,,\n5,x,2,,\n",
    )
    .unwrap();
    let e = Trial::load(&path).unwrap_err().to_string();
    assert!(e.contains("probe.csv") && e.contains("line 3"), "{e}");
    std::fs::write(
        path.join("probe.csv"),
        "t_us,cmd_x_um,cmd_y_um,rep_x_um,rep_y_um\n9,1,2,,\n5,1,2,,\n",
    )
    .unwrap();
    let e = Trial::load(&path).unwrap_err().to_string();
    assert!(e.contains("backwards"), "{e}");
    let text = std::fs::read_to_string(path.join("trial.json")).unwrap();
    std::fs::write(
        path.join("trial.json"),
        text.replace("\"format_version\": 2", "\"format_version\": 9"),
    )
    .unwrap();
    let e = Trial::load(&path).unwrap_err().to_string();
    assert!(e.contains("format_version 9"), "{e}");
    assert!(
        Trial::load(&dir.path().join("nowhere")).unwrap_err().to_string().contains("trial.json")
    );
}

#[test]
fn a_trial_tracked_elsewhere_of_another_part_loads() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("trial.json"),
        r#"{"format": "mesopush-trial", "format_version": 1, "trial_id": "ext-1",
            "source": "other-lab", "part": {"vertices_um": [[0,0],[400,0],[600,346],[400,693],[0,693],[-200,346]]},
            "outcome": {"state": "done"}}"#,
    )
    .unwrap();
    std::fs::write(
        dir.path().join("probe.csv"),
        "t_us,cmd_x_um,cmd_y_um,rep_x_um,rep_y_um\n0,-500,346,,\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("pose.csv"),
        "t_us,x_um,y_um,theta_rad,frame_index,residual_px\n0,200,346,0,,\n",
    )
    .unwrap();
    let t = Trial::load(dir.path()).unwrap();
    assert_eq!(t.meta.part.polygon().len(), 6);
    assert_eq!(t.meta.pusher(), mesopush_sim::Pusher::single(12.5));
    assert!(t.frames.is_empty());
    assert_eq!(t.first_pose().unwrap().x_um, 200.0);
}
