//! The head of a trial's printed summary (state, verdict, reason, final pose), shared by
//! `mesopush demo` (in-process loop) and `mesopush run` (a rig or `mesopush-fwsim`), so both
//! say the same thing the same way.

use mesopush_core::geom::Pose;
use mesopush_trial::TrialState;

/// Prints `trial <state>[ (seed S)]: <verdict>`, the reason and the final tracked pose.
pub(crate) fn print_head(
    state: TrialState,
    seed: Option<u64>,
    inserted: Option<bool>,
    reason: Option<&str>,
    final_pose: Option<Pose>,
) {
    let verdict = match inserted {
        Some(true) => "INSERTED",
        Some(false) => "NOT inserted",
        None => "not judged (no tracked pose)",
    };
    let seed = seed.map(|s| format!(" (seed {s})")).unwrap_or_default();
    println!("trial {state:?}{seed}: {verdict}");
    if let Some(reason) = reason {
        println!("  reason: {reason}");
    }
    if let Some(p) = final_pose {
        let deg = p.theta_rad.to_degrees();
        println!("  final tracked pose: x {:.1} µm, y {:.1} µm, θ {deg:.2}°", p.x_um, p.y_um);
    }
}
