//! `mesopush calibrate` through the three processes of a rig (`mesopush-fwsim`,
//! `mesopush-executor`, `mesopush`), on a world whose optics are 2 % finer than the nominal
//! pixel size the tip is tracked with (`worlds/scale.toml`): the calibration written must be
//! the world's true one — its renderer's pixel size and origin, read here from the world file
//! (which the calibrate code never reads), and rotation 0 (the world's camera is aligned with
//! its stage) — not the nominal it started from. The file it writes is read by `mesopush
//! track --calibration`. A calibration whose x move takes the tip out of view is refused
//! (exit 2) naming the position, and writes nothing.
//!
//! Tolerances, from the tip tracker's accuracy: a free tip is located within 0.25 px of a
//! constant bias (`host/vision/tests/vision_tip_free.rs`: measured 0.18 px; bias (−0.17,
//! 0.35) px), and so is the median over a rest's frames. Moves of 1000 µm (194 px) along x
//! then y: over 200 000 draws of such errors at the three positions the fit's scale was off
//! by at most 0.27 %, its rotation by 0.126° and its origin by 2.25 px (the scale error
//! times the positions' 400–550 px from the origin); the bias adds up to 0.4 px to the
//! origin and cancels in the rest. Asserted: 0.3 %, 0.15°, 3 px — an order of magnitude
//! below the 2 % the nominal is off.
//!
//! `mesopush-executor` is another package's binary: `cargo test --workspace` builds it;
//! alone, `cargo build -p mesopush-executor --profile test` first.

mod hil_common;

use hil_common::{MESOPUSH, run_cmd, start_rig_in};
use mesopush_rig::WorldFile;
use mesopush_trial::CalibrationFile;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// Places the peg (θ = 90°) in the wide channel's left half and the probe at (2000, 2000) µm,
/// clear of it: the calibration's three positions, (2020, 1980), (3020, 1980) and
/// (3020, 980) µm after the 20 µm backlash take-up, lie on free plate with the needle's
/// shaft running up and right away from the peg. (Its move is never run.)
const PLAN: &str = r#"
name = "calibration start"
speed_um_s = 200.0
probe_start_um = [2000.0, 2000.0]
moves_um = [[-100.0, 0.0]]

[peg_start]
x_um = 1100.0
y_um = 1300.0
theta_deg = 90.0
"#;

const SCALE_TOL: f64 = 3e-3;
const ROTATION_TOL_DEG: f64 = 0.15;
const ORIGIN_TOL_PX: f64 = 3.0;

fn text(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn calibrate(rig: &hil_common::RigProcs, out: &Path, move_um: &str) -> std::process::Output {
    let b = &rig.banner;
    run_cmd(
        Command::new(MESOPUSH)
            .args(["calibrate", "--port", &rig.host, "--record-dir"])
            .arg(&rig.rec)
            .args(["--background", &b[2], "--fixture-origin-um", &b[4]])
            .args(["--move-um", move_um, "--speed-um-s", "200", "--out"])
            .arg(out),
        Duration::from_secs(180),
    )
}

#[test]
fn calibrate_measures_the_worlds_true_pixel_size_and_refuses_a_tip_out_of_view() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let plan = d.join("start.toml");
    std::fs::write(&plan, PLAN).unwrap();
    let world = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/scale.toml");
    let rig = start_rig_in(d, &plan, Some(&world));

    let out = d.join("calibration.toml");
    let run = calibrate(&rig, &out, "1000,-1000");
    assert_eq!(run.status.code(), Some(0), "{}", text(&run));
    println!("{}", text(&run));
    println!("{}", std::fs::read_to_string(&out).unwrap());
    let file = CalibrationFile::load(&out).unwrap();
    let fit = file.fit.unwrap();
    let truth = WorldFile::load(&world).unwrap().render_calibration().unwrap();
    let told = WorldFile::load(&world).unwrap().spec.camera.calibration().unwrap();
    let c = file.checked_calibration().unwrap();
    let (ex, ey) =
        (c.sx_um_per_px / truth.sx_um_per_px - 1.0, c.sy_um_per_px / truth.sy_um_per_px - 1.0);
    let origin_err = (c.origin_px - truth.origin_px).norm();
    println!(
        "calibrate: {:.5} × {:.5} µm/px (true {:.5} × {:.5}: {:+.3} %, {:+.3} %; nominal {} × {}), \
         rotation {:.4}°, origin ({:.2}, {:.2}) px ({:.2} px from the true), residual {:.3} µm \
         RMS, tip spreads {:?} px",
        c.sx_um_per_px,
        c.sy_um_per_px,
        truth.sx_um_per_px,
        truth.sy_um_per_px,
        100.0 * ex,
        100.0 * ey,
        told.sx_um_per_px,
        told.sy_um_per_px,
        fit.rotation_rad.to_degrees(),
        c.origin_px.x,
        c.origin_px.y,
        origin_err,
        fit.residual_um_rms,
        file.positions.iter().map(|p| p.spread_px).collect::<Vec<_>>()
    );
    assert!(ex.abs() < SCALE_TOL && ey.abs() < SCALE_TOL, "{}", text(&run));
    assert!(fit.rotation_rad.to_degrees().abs() < ROTATION_TOL_DEG, "{}", text(&run));
    assert!(origin_err < ORIGIN_TOL_PX, "{}", text(&run));
    assert!((c.sx_um_per_px / told.sx_um_per_px - 1.0).abs() > 0.015, "measured, not the nominal");
    assert_eq!(file.positions.len(), 3);
    assert!(file.positions.iter().all(|p| p.frames >= 5), "{file:?}");

    // `track` reads the file: the calibration moves' own recording, tracked with it.
    let trial_dir = rig.rec.read_dir().unwrap().next().unwrap().unwrap().path();
    let track = run_cmd(
        Command::new(MESOPUSH)
            .arg("track")
            .arg(&trial_dir)
            .args(["--background", &rig.banner[2], "--calibration"])
            .arg(&out)
            .arg("--out")
            .arg(d.join("pose.csv"))
            .arg("--json"),
        Duration::from_secs(120),
    );
    assert!(track.status.success(), "{}", text(&track));

    // From (3020, 980) µm, 1000 µm further along x leaves the field (it ends at 3319 µm):
    // refused at the second position, naming it, and nothing written.
    let refused_out = d.join("refused.toml");
    let refused = calibrate(&rig, &refused_out, "1000,1000");
    let t = text(&refused);
    println!("{t}");
    assert_eq!(refused.status.code(), Some(2), "{t}");
    assert!(t.contains("probe tip not found at rest position 2 (after the x move"), "{t}");
    assert!(t.contains("no needle seen in") && t.contains("--move-um"), "{t}");
    assert!(!refused_out.exists());
}
