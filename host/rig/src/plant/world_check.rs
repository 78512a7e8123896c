//! Range checks of a world file's values, apart from its parsing ([`super::world_file`]
//! calls them on load) so that a NaN or an absurd number is refused at the boundary with the
//! field, the value and the allowed range — not met later as a panic in the world's physics
//! or as a controller that faults on a stage position it cannot reach.
//!
//! The stage: the world's controller has the firmware simulator's default travel
//! ([`CtrlConfig::DEFAULT`], 0..=12 mm per axis), so the fixture's camera field must lie
//! inside it once moved by the stage offset, and so must every probe position of a plan.

use crate::Error;
use mesopush_core::check::{Allowed, all_finite_in, finite_in, int_in};
use mesopush_core::geom::Vec2;
use mesopush_firmware_sim::CtrlConfig;
use mesopush_protocol::units::nm_to_um;
use mesopush_sim::Plan;
use mesopush_sim::fixture::FIELD_UM;
use mesopush_sim::plan::{POSITION_UM, PegStart};

/// The controller's travel per axis, stage µm: `[min_x, max_x, min_y, max_y]`.
fn travel_um() -> [f64; 4] {
    CtrlConfig::DEFAULT.travel_nm.map(nm_to_um)
}

/// The stage offset (fixture origin in stage coordinates, µm): finite, and the camera field
/// `[0, FIELD_UM]` inside the controller's travel once offset.
pub fn check_stage_offset(offset_um: [f64; 2]) -> Result<(), Error> {
    let t = travel_um();
    for (k, lo, hi) in [(0, t[0], t[1]), (1, t[2], t[3])] {
        let allowed = Allowed::closed(
            lo,
            hi - FIELD_UM[k],
            "µm (the fixture's camera field inside the controller's travel)",
        );
        finite_in(&format!("world stage.offset_um[{k}]"), offset_um[k], allowed)?;
    }
    Ok(())
}

/// The peg's start (if given) and its perturbation bounds.
pub fn check_peg(start: Option<&PegStart>, perturb: Option<[f64; 3]>) -> Result<(), Error> {
    if let Some(s) = start {
        finite_in("world peg.start.x_um", s.x_um, POSITION_UM)?;
        finite_in("world peg.start.y_um", s.y_um, POSITION_UM)?;
        let angle = Allowed::closed(-720.0, 720.0, "°");
        finite_in("world peg.start.theta_deg", s.theta_deg, angle)?;
    }
    if let Some([dx, dy, dth]) = perturb {
        let shift = Allowed::closed(0.0, 1000.0, "µm");
        finite_in("world peg.perturb[0] (x)", dx, shift)?;
        finite_in("world peg.perturb[1] (y)", dy, shift)?;
        finite_in("world peg.perturb[2] (θ)", dth, Allowed::closed(0.0, 180.0, "°"))?;
    }
    Ok(())
}

/// The camera's timing and image size, and the world's camera latency.
pub fn check_camera(
    period_us: u64,
    readout_us: u64,
    size_px: [u32; 2],
    latency_us: f64,
) -> Result<(), Error> {
    int_in("world camera.period_us", period_us, 1_000, 10_000_000, "µs")?;
    int_in("world camera.readout_us", readout_us, 0, 10_000_000, "µs")?;
    int_in("world camera.size_px[0]", size_px[0], 16, 4096, "px")?;
    int_in("world camera.size_px[1]", size_px[1], 16, 4096, "px")?;
    let late = Allowed::closed(0.0, 1e6, "µs (a driver stamps frames late, never early)");
    finite_in("world effects.camera_latency_us", latency_us, late)?;
    Ok(())
}

/// The calibration the host is told: scale in (0, 1000] µm/px, origin within ±100 000 px.
pub fn check_optics(um_per_px: [f64; 2], origin_px: [f64; 2]) -> Result<(), Error> {
    all_finite_in("world camera.um_per_px", &um_per_px, Allowed::positive_to(1000.0, "µm/px"))?;
    all_finite_in("world camera.origin_px", &origin_px, Allowed::closed(-1e5, 1e5, "px"))?;
    Ok(())
}

/// The plan's probe start and every waypoint, moved to the stage by `offset_um`, inside the
/// controller's travel (a stage that cannot get there faults the controller).
pub fn check_plan_on_stage(plan: &Plan, offset_um: [f64; 2]) -> Result<(), Error> {
    let t = travel_um();
    let offset = Vec2::new(offset_um[0], offset_um[1]);
    let mut at = plan.probe_start();
    let waypoints = std::iter::once(Vec2::new(0.0, 0.0))
        .chain(plan.moves_um.iter().map(|&[x, y]| Vec2::new(x, y)));
    for (i, d) in waypoints.enumerate() {
        at += d;
        let s = at + offset;
        let name = if i == 0 {
            "plan probe start".to_string()
        } else {
            format!("plan probe after move {i}")
        };
        let (ax, ay) = (Allowed::closed(t[0], t[1], "µm"), Allowed::closed(t[2], t[3], "µm"));
        finite_in(&format!("{name}, stage x (fixture x + offset)"), s.x, ax)?;
        finite_in(&format!("{name}, stage y (fixture y + offset)"), s.y, ay)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_and_far_offsets_are_named_with_their_range() {
        let e = check_stage_offset([f64::NAN, 1000.0]).unwrap_err().to_string();
        assert!(e.contains("stage.offset_um[0] = NaN") && e.contains("[0, 8630]"), "{e}");
        let e = check_stage_offset([1000.0, 1e15]).unwrap_err().to_string();
        assert!(e.contains("stage.offset_um[1] = 1e15"), "{e}");
        check_stage_offset([1000.0, 1000.0]).unwrap();
    }

    #[test]
    fn a_plan_the_stage_cannot_reach_is_named_at_its_first_bad_waypoint() {
        let mut plan = Plan::table2();
        check_plan_on_stage(&plan, [1000.0, 1000.0]).unwrap();
        plan.probe_start_um = [-15_000.0, 1240.0];
        let e = check_plan_on_stage(&plan, [1000.0, 1000.0]).unwrap_err().to_string();
        assert!(e.contains("plan probe start, stage x") && e.contains("-14000"), "{e}");
    }

    #[test]
    fn nan_peg_start_and_early_stamps_are_refused() {
        let s = PegStart { x_um: f64::NAN, y_um: 1000.0, theta_deg: 0.0 };
        let e = check_peg(Some(&s), None).unwrap_err().to_string();
        assert!(e.contains("peg.start.x_um = NaN"), "{e}");
        let e = check_camera(33_333, 15_000, [928, 480], -1.0).unwrap_err().to_string();
        assert!(e.contains("camera_latency_us = -1"), "{e}");
    }
}
