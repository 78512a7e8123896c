//! Whether a plan's start is one the simulator can honestly begin from: the peg's centre of
//! mass inside the fixture (the box its walls and goal span), the peg not sunk into a wall,
//! the probe inside the fixture's box and not inside the peg. Without this check a start far
//! outside the fixture only shows up as "no plan found", and a peg 300 µm inside a wall is
//! replayed as if nothing were wrong.

use crate::Error;
use crate::stepper::{SimState, Simulator};
use mesopush_core::check::{Allowed, finite_in};
use mesopush_core::geom::{Pose, Vec2};

/// How far the starting peg may overlap a wall, or the probe the peg, µm (a plan written
/// from a measurement touches to within tracking noise).
pub const START_OVERLAP_TOL_UM: f64 = 1.0;

/// The box the fixture's walls and goal span, `[min_x, max_x, min_y, max_y]`, µm.
pub fn fixture_box_um(sim: &Simulator) -> [f64; 4] {
    let f = sim.fixture();
    let mut b = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    for v in f.walls.iter().chain(std::iter::once(&f.goal)).flat_map(|p| p.vertices()) {
        b = [b[0].min(v.x), b[1].max(v.x), b[2].min(v.y), b[3].max(v.y)];
    }
    b
}

/// Checks a start (`what` names it in errors: "plan peg_start", "--start"): see the module
/// header. Errors name the value and the allowed range.
pub fn check_start(
    sim: &mut Simulator,
    what: &str,
    peg: Pose,
    probe_um: Option<Vec2>,
) -> Result<(), Error> {
    let b = fixture_box_um(sim);
    let (ax, ay) = (inside("µm (the fixture)", b[0], b[1]), inside("µm (the fixture)", b[2], b[3]));
    finite_in(&format!("{what} x_um"), peg.x_um, ax)?;
    finite_in(&format!("{what} y_um"), peg.y_um, ay)?;
    let sunk = sim.wall_penetration_um(&peg);
    if sunk > START_OVERLAP_TOL_UM {
        return Err(Error::invalid(
            "start",
            format!(
                "{what} ({:.1}, {:.1}) µm, {:.2}°: the peg lies {sunk:.1} µm inside a wall \
                 (allowed: at most {START_OVERLAP_TOL_UM} µm)",
                peg.x_um,
                peg.y_um,
                peg.theta_rad.to_degrees()
            ),
        ));
    }
    let Some(p) = probe_um else { return Ok(()) };
    finite_in("probe start x_um", p.x, ax)?;
    finite_in("probe start y_um", p.y, ay)?;
    let gap = sim.probe_gap_um(&SimState::new(peg, p));
    if gap < -START_OVERLAP_TOL_UM {
        return Err(Error::invalid(
            "start",
            format!(
                "the probe at ({:.1}, {:.1}) µm starts {:.1} µm inside the peg (allowed: at \
                 most {START_OVERLAP_TOL_UM} µm)",
                p.x, p.y, -gap
            ),
        ));
    }
    Ok(())
}

fn inside(unit: &'static str, lo: f64, hi: f64) -> Allowed {
    Allowed::closed(lo, hi, unit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Fixture, Model, Plan, SimSettings};

    fn sim() -> Simulator {
        Simulator::new(Model::default(), Fixture::paper(), SimSettings::default()).unwrap()
    }

    #[test]
    fn table2_starts_clear_and_far_or_sunk_starts_are_named() {
        let mut s = sim();
        let plan = Plan::table2();
        check_start(&mut s, "plan peg_start", plan.peg_start_pose(), Some(plan.probe_start()))
            .unwrap();
        let far = Pose::new(1e9, 1e9, 0.0);
        let e = check_start(&mut s, "--start", far, None).unwrap_err().to_string();
        assert!(e.contains("--start x_um = 1e9") && e.contains("[-3000, 6370]"), "{e}");
        // 300 µm into the wide channel's lower wall (its upper edge at y = 2315).
        let sunk = Pose::new(2330.0, 2315.0 + 300.0 - 492.5, 0.0);
        let e = check_start(&mut s, "plan peg_start", sunk, None).unwrap_err().to_string();
        assert!(e.contains("300.0 µm inside a wall"), "{e}");
        let e = check_start(&mut s, "p", plan.peg_start_pose(), Some(Vec2::new(2330.0, 1210.0)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("inside the peg"), "{e}");
    }
}
