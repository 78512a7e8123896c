//! The batch's plan policy after the start camera ([`mesopush_rig::plant::start_camera`]): among the
//! batch's plans choose the one whose nominal start is nearest the estimate (position distance
//! plus the part's characteristic length × angle difference), then shift its probe start by
//! the estimate's offset from that nominal start, so the probe meets the peg where the plan
//! expects. Orientation errors are not compensated (the moves stay axis-aligned); the plan's
//! own robustness has to cover them.

use mesopush_core::geom::Pose;
use mesopush_sim::Plan;

/// Index of the plan whose nominal start is nearest `pose` (`char_len_um` weighs angles).
pub fn nearest_plan(plans: &[Plan], pose: &Pose, char_len_um: f64) -> usize {
    let cost = |p: &Plan| {
        let s = p.peg_start_pose();
        let d = (s.position() - pose.position()).norm();
        let a = (s.theta_rad - pose.theta_rad).sin().abs();
        d + char_len_um * a
    };
    (0..plans.len()).min_by(|a, b| cost(&plans[*a]).total_cmp(&cost(&plans[*b]))).unwrap_or(0)
}

/// `plan` shifted so it starts from `pose`: probe start moved by the position offset, the
/// nominal start replaced by the estimate (moves unchanged).
pub fn adapt(plan: &Plan, pose: &Pose) -> Plan {
    let s = plan.peg_start_pose();
    let (dx, dy) = (pose.x_um - s.x_um, pose.y_um - s.y_um);
    let mut out = plan.clone();
    out.probe_start_um = [plan.probe_start_um[0] + dx, plan.probe_start_um[1] + dy];
    out.peg_start.x_um = pose.x_um;
    out.peg_start.y_um = pose.y_um;
    out.name = format!("{} (shifted by {dx:+.1}, {dy:+.1} µm)", plan.name);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adapt_moves_probe_start_with_the_peg() {
        let plan = Plan::table2();
        let s = plan.peg_start_pose();
        let a = adapt(&plan, &Pose::new(s.x_um + 10.0, s.y_um - 20.0, s.theta_rad));
        assert_eq!(a.probe_start_um, [3060.0, 1220.0]);
        assert_eq!(a.moves_um, plan.moves_um);
    }

    #[test]
    fn nearest_plan_picks_the_closer_start() {
        let a = Plan::table2();
        let mut b = a.clone();
        b.peg_start.x_um += 500.0;
        let near_b =
            Pose::new(b.peg_start.x_um - 10.0, b.peg_start.y_um, a.peg_start_pose().theta_rad);
        assert_eq!(nearest_plan(&[a.clone(), b.clone()], &near_b, 900.0), 1);
        assert_eq!(nearest_plan(&[a.clone(), b], &a.peg_start_pose(), 900.0), 0);
    }
}
