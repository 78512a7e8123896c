//! The physical world behind the controller: probe position in, peg pose and camera frame
//! out.
//!
//! The host implements [`World`] with its quasi-static simulator and renderer; the firmware
//! simulator only moves the probe and asks for poses and frames, so no package cycle
//! appears. Units follow the host's physics convention for the pose (µm, rad) and the
//! wire's for the probe and the needle's deflection the controller senses (nm).

/// Peg pose in the fixture frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PegPose {
    /// Centre x, µm.
    pub x_um: f64,
    /// Centre y, µm.
    pub y_um: f64,
    /// Orientation, rad.
    pub theta_rad: f64,
}

/// The simulated physical world.
pub trait World {
    /// A rendered camera image.
    type Frame;

    /// Advances the world to `sim_time_us` with the probe at `probe_nm` (true stage
    /// position, nm); returns the peg's pose.
    fn step(&mut self, sim_time_us: u64, probe_nm: (i32, i32)) -> PegPose;

    /// Renders what the camera sees at `sim_time_us`.
    fn render(&mut self, sim_time_us: u64) -> Self::Frame;

    /// The needle's deflection now (commanded tip − actual tip), nm, when the world knows it
    /// (a strain gauge on a real needle; the host's simulated world); the controller faults
    /// `NeedleOverload` when it exceeds its limit. Default: not reported.
    fn needle_deflection_nm(&self) -> Option<i32> {
        None
    }
}
