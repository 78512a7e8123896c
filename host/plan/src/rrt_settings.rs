//! The RRT's settings (plain data with documented defaults), shared by the search loop
//! (`rrt`), the steering that grows its tree (`steer`) and the shortcut pass after it
//! (`shortcut`): they sit below all three, so none of them depends on another for them.

use crate::pushes::PushSettings;

/// RRT settings (plain data, documented defaults).
#[derive(Debug, Clone, PartialEq)]
pub struct RrtSettings {
    /// Iterations before giving up. Default 2000.
    pub max_iterations: usize,
    /// Random pushes simulated per iteration. Default 6.
    pub inputs_per_iteration: usize,
    /// Probability of steering towards the goal. Default 0.2.
    pub goal_bias: f64,
    /// Push discretisation.
    pub pushes: PushSettings,
    /// Probe speed written into the plan, µm/s. Default 140 (the paper's).
    pub speed_um_s: f64,
    /// Goal pose tolerance for trying the direct connection: |Δθ| (mod π), degrees.
    /// Default 8.
    pub connect_theta_deg: f64,
    /// Most push drops the shortcut pass tries on the found branch (`plan::shortcut`);
    /// 0 keeps the branch as found. Default 60.
    pub shortcut_attempts: usize,
    /// Orientation window of the goal connection during shortcutting, degrees (wider than
    /// `connect_theta_deg`: the channel's chamfers square a peg that comes in turned, and the
    /// pass keeps only plans whose whole replay inserts). Default 20.
    pub shortcut_connect_theta_deg: f64,
}

impl Default for RrtSettings {
    fn default() -> Self {
        Self {
            max_iterations: 2000,
            inputs_per_iteration: 6,
            goal_bias: 0.2,
            pushes: PushSettings::default(),
            speed_um_s: 140.0,
            connect_theta_deg: 8.0,
            shortcut_attempts: 60,
            shortcut_connect_theta_deg: 20.0,
        }
    }
}
