//! Plain-data settings of the simulated controller and of the fault injector.
//!
//! Units in the field names; defaults documented on each field and collected in
//! [`CtrlConfig::DEFAULT`] and [`FaultConfig::NONE`]. Rates are probabilities per event
//! (per frame on a line, per camera frame) or per second of simulated time (stage faults).

use crate::error::SimError;

/// The simulated motion controller and its stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CtrlConfig {
    /// Segments the queue holds. Default 32.
    pub queue_capacity: u16,
    /// Servo period: the stage and the segment interpolator advance in these steps, µs.
    /// Default 250 µs (4 kHz).
    pub servo_period_us: u64,
    /// Position report period, µs (controller clock). Default 10 ms.
    pub report_period_us: u64,
    /// Status (queue occupancy) period, µs. Default 10 ms.
    pub status_period_us: u64,
    /// Heartbeat period, µs. Default 50 ms.
    pub heartbeat_period_us: u64,
    /// Stage speed limit, nm/s. Default 2 mm/s.
    pub max_speed_nm_s: f64,
    /// Stage acceleration limit, nm/s². Default 500 mm/s².
    pub max_accel_nm_s2: f64,
    /// Position gain of the stage's tracking loop, 1/s. Default 200.
    pub tracking_gain_per_s: f64,
    /// Encoder resolution: reported positions are multiples of this, nm. Default 100
    /// (0.1 µm).
    pub resolution_nm: i32,
    /// Following error (commanded − actual) that counts as a stall, nm. Default 20 µm.
    pub stall_error_nm: f64,
    /// Travel limits (limit switches), nm, inclusive: `[min_x, max_x, min_y, max_y]`.
    /// Default 0..=12 mm on both axes.
    pub travel_nm: [i32; 4],
    /// A segment dequeued this long after its start time is late, µs. Default 2 ms.
    pub late_tolerance_us: u64,
    /// No message from the executor this long while moving → `ExecutorSilent`, µs.
    /// Default 250 ms.
    pub executor_silence_us: u64,
    /// Needle deflection above which the controller faults `NeedleOverload`, nm, when the
    /// world reports the needle's deflection ([`crate::World::needle_deflection_nm`]).
    /// Default `None` (no check): the limit is the needle's, so it comes from the world's
    /// model (`probe_deflection_limit_um`, 50 µm by default), which the host's rig sets here;
    /// this crate states no second default.
    pub needle_deflection_limit_nm: Option<i32>,
}

impl CtrlConfig {
    /// The documented defaults.
    pub const DEFAULT: Self = Self {
        queue_capacity: 32,
        servo_period_us: 250,
        report_period_us: 10_000,
        status_period_us: 10_000,
        heartbeat_period_us: 50_000,
        max_speed_nm_s: 2_000_000.0,
        max_accel_nm_s2: 500_000_000.0,
        tracking_gain_per_s: 200.0,
        resolution_nm: 100,
        stall_error_nm: 20_000.0,
        travel_nm: [0, 12_000_000, 0, 12_000_000],
        late_tolerance_us: 2_000,
        executor_silence_us: 250_000,
        needle_deflection_limit_nm: None,
    };

    /// Checks the settings; names the first bad field.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field| Err(SimError::BadConfig { field });
        if self.queue_capacity == 0 {
            return bad("queue_capacity");
        }
        if self.servo_period_us == 0 {
            return bad("servo_period_us");
        }
        if !(self.max_speed_nm_s > 0.0 && self.max_accel_nm_s2 > 0.0) {
            return bad("max_speed_nm_s/max_accel_nm_s2");
        }
        if self.resolution_nm <= 0 {
            return bad("resolution_nm");
        }
        let t = self.travel_nm;
        if t[0] > t[1] || t[2] > t[3] {
            return bad("travel_nm");
        }
        if self.needle_deflection_limit_nm.is_some_and(|l| l <= 0) {
            return bad("needle_deflection_limit_nm");
        }
        Ok(())
    }
}

impl Default for CtrlConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Faults to inject, drawn from the run's seed. Deserialisable (a world file's `[faults]`
/// table): every field defaults to [`FaultConfig::NONE`]'s, unknown fields are refused;
/// check the values with [`FaultConfig::validate`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FaultConfig {
    /// Probability that a frame on a line is lost.
    pub link_drop: f64,
    /// Probability that a frame has one bit flipped.
    pub link_corrupt: f64,
    /// Probability that a frame is delivered twice.
    pub link_duplicate: f64,
    /// Probability that a frame is held back by an extra `link_delay_us` (so it may arrive
    /// after later frames).
    pub link_delay: f64,
    /// Base one-way latency of a line, µs. Default 200.
    pub link_latency_us: u64,
    /// Uniform extra latency 0..=this, µs. Default 100.
    pub link_jitter_us: u64,
    /// Extra latency of a delayed frame, µs. Default 5 ms.
    pub link_delay_us: u64,
    /// Stage stalls (stops following) per second of motion.
    pub stall_per_s: f64,
    /// Spurious limit-switch trips per second of motion.
    pub limit_switch_per_s: f64,
    /// Controller reboots per second.
    pub reboot_per_s: f64,
    /// Probability that a camera frame is dropped.
    pub frame_drop: f64,
    /// Probability that a camera frame is black.
    pub frame_black: f64,
}

impl FaultConfig {
    /// No faults; 200 µs ± 100 µs latency.
    pub const NONE: Self = Self {
        link_drop: 0.0,
        link_corrupt: 0.0,
        link_duplicate: 0.0,
        link_delay: 0.0,
        link_latency_us: 200,
        link_jitter_us: 100,
        link_delay_us: 5_000,
        stall_per_s: 0.0,
        limit_switch_per_s: 0.0,
        reboot_per_s: 0.0,
        frame_drop: 0.0,
        frame_black: 0.0,
    };

    /// Checks every probability is within `[0, 1]` and rates are non-negative.
    pub fn validate(&self) -> Result<(), SimError> {
        let probabilities = [
            ("link_drop", self.link_drop),
            ("link_corrupt", self.link_corrupt),
            ("link_duplicate", self.link_duplicate),
            ("link_delay", self.link_delay),
            ("frame_drop", self.frame_drop),
            ("frame_black", self.frame_black),
        ];
        for (field, p) in probabilities {
            if !(0.0..=1.0).contains(&p) {
                return Err(SimError::BadConfig { field });
            }
        }
        let rates = [
            ("stall_per_s", self.stall_per_s),
            ("limit_switch_per_s", self.limit_switch_per_s),
            ("reboot_per_s", self.reboot_per_s),
        ];
        for (field, r) in rates {
            if !(r >= 0.0 && r.is_finite()) {
                return Err(SimError::BadConfig { field });
            }
        }
        Ok(())
    }
}

impl Default for FaultConfig {
    fn default() -> Self {
        Self::NONE
    }
}
