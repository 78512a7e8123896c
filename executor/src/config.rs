//! Plain-data executor settings: workspace, motion limits, streaming rate, watchdog bounds.
//!
//! Everything the safety check, the streamer and the watchdog need, with units in the field
//! names and documented defaults ([`ExecutorConfig::DEFAULT`]). Positions are in the
//! controller's absolute frame (nm), times in µs.

/// Axis-aligned box the probe must stay in, nm, bounds inclusive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Workspace {
    /// Smallest allowed x, nm.
    pub min_x_nm: i32,
    /// Largest allowed x, nm.
    pub max_x_nm: i32,
    /// Smallest allowed y, nm.
    pub min_y_nm: i32,
    /// Largest allowed y, nm.
    pub max_y_nm: i32,
}

impl Workspace {
    /// Whether `(x_nm, y_nm)` lies inside (bounds included).
    pub fn contains(&self, x_nm: i64, y_nm: i64) -> bool {
        (i64::from(self.min_x_nm)..=i64::from(self.max_x_nm)).contains(&x_nm)
            && (i64::from(self.min_y_nm)..=i64::from(self.max_y_nm)).contains(&y_nm)
    }
}

/// How a plan is cut into the segments the controller receives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segmenting {
    /// One segment per setpoint period (`setpoint_rate_hz`): the project's streaming
    /// controller, which queues short timed moves and blends them (the default).
    Setpoints,
    /// One segment per plan step, at the step's speed: point-to-point controllers, which run
    /// one "move to" at a time with their own acceleration ([`crate::adapter`]).
    PlanSteps,
}

/// Executor settings. All fields are plain data; see [`ExecutorConfig::DEFAULT`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExecutorConfig {
    /// Box the probe must stay in. Default: 0..=10 mm on both axes (the micromanipulator's
    /// travel over the fixture).
    pub workspace: Workspace,
    /// Largest plan step speed, nm/s. Default 1 mm/s (the paper's plans push at 140 µm/s).
    pub max_speed_nm_s: u32,
    /// Largest acceleration a plan may demand, nm/s². A plan changes velocity at step
    /// boundaries (and starts and stops from rest); the streamer realises each change across
    /// one setpoint period, so the demanded acceleration is `|Δv| × setpoint_rate_hz`.
    /// Default 200 mm/s² (so a 140 µm/s start from rest passes even at 1 kHz).
    pub max_accel_nm_s2: u64,
    /// Setpoint rate, Hz: one controller segment per period. Default 100, allowed 1..=1000.
    /// With [`Segmenting::PlanSteps`] it sets only the look-ahead horizon's unit.
    pub setpoint_rate_hz: u32,
    /// How plans are cut into segments. Default [`Segmenting::Setpoints`].
    pub segmenting: Segmenting,
    /// How far ahead of the controller's clock the first segment of a trial starts, µs.
    /// Default 50 ms.
    pub start_lead_us: u64,
    /// A segment still unsent this close to its start time (controller clock) means the
    /// controller's queue is about to run dry: the trial faults with `StreamUnderrun`, µs.
    /// Default 2 ms.
    pub underrun_margin_us: u64,
    /// Look-ahead horizon in setpoint periods: each segment is due to go out exactly this
    /// many periods before its start (the send schedule), so about this many plus one are
    /// in flight (sent, not reported done); the in-flight count is capped by the look-ahead
    /// queue's capacity `LA` and the controller's queue capacity. Default 16 (160 ms at
    /// 100 Hz, 16 ms at 1 kHz): in the seeded full-loop simulation with 2 % of frames
    /// dropped, 2 % corrupted, 2 % duplicated and 2 % delayed on every line, 8 let the stream
    /// run dry (a safe `StreamUnderrun` stop) in 2 of 40 runs, while go-back-N recovered a
    /// lost window; 16 in none.
    pub lookahead_segments: u16,
    /// Controller silent (no valid message) this long while armed or running → stop, µs.
    /// Default 100 ms.
    pub ctrl_silence_us: u64,
    /// Host silent this long while running → stop, µs. Default 1 s.
    pub host_silence_us: u64,
    /// Period of executor → controller heartbeats, µs. Default 20 ms.
    pub heartbeat_interval_us: u64,
    /// Period of clock-sync queries, µs. Default 100 ms.
    pub sync_interval_us: u64,
    /// Round trips longer than this are not used for clock sync, µs. Default 5 ms.
    pub sync_max_rtt_us: u64,
    /// Good clock-sync samples needed before arming. Default 4.
    pub sync_samples_to_arm: u8,
    /// Clock sync older than this (no good sample since) is lost, µs. Default 1 s.
    pub sync_max_age_us: u64,
    /// Arming is refused when the probe's reported position is farther than this from the
    /// plan's stated start (the host's plan start in stage coordinates), nm. Default 5 µm:
    /// a goto ends on its target to the encoder's resolution (0.1 µm), while a probe left
    /// where the last trial ended is typically millimetres away.
    pub start_tolerance_nm: u32,
    /// Speed of a goto or home move, nm/s. Default 200 µm/s (a 10 mm move takes 50 s): slow
    /// enough that the start from rest, realised over one setpoint period, stays within
    /// `max_accel_nm_s2` at every rate up to 1 kHz; must not exceed `max_speed_nm_s`.
    pub goto_speed_nm_s: u32,
    /// Where `home` moves the probe, stage nm: a park position, not an encoder-referencing
    /// run (the stage's encoders are absolute; referencing them is the controller's job).
    /// Default the workspace's centre (5 mm, 5 mm).
    pub home_nm: (i32, i32),
}

impl ExecutorConfig {
    /// The documented defaults.
    pub const DEFAULT: Self = Self {
        workspace: Workspace {
            min_x_nm: 0,
            max_x_nm: 10_000_000,
            min_y_nm: 0,
            max_y_nm: 10_000_000,
        },
        max_speed_nm_s: 1_000_000,
        max_accel_nm_s2: 200_000_000,
        setpoint_rate_hz: 100,
        segmenting: Segmenting::Setpoints,
        start_lead_us: 50_000,
        underrun_margin_us: 2_000,
        lookahead_segments: 16,
        ctrl_silence_us: 100_000,
        host_silence_us: 1_000_000,
        heartbeat_interval_us: 20_000,
        sync_interval_us: 100_000,
        sync_max_rtt_us: 5_000,
        sync_samples_to_arm: 4,
        sync_max_age_us: 1_000_000,
        start_tolerance_nm: 5_000,
        goto_speed_nm_s: 200_000,
        home_nm: (5_000_000, 5_000_000),
    };

    /// Setpoint period, µs (the rate clamped to 1..=1000 Hz).
    pub fn setpoint_period_us(&self) -> u64 {
        1_000_000 / u64::from(self.setpoint_rate_hz.clamp(1, 1000))
    }

    /// Checks the settings are usable; names the first bad field.
    pub fn validate(&self) -> Result<(), crate::ExecError> {
        let bad = |field| Err(crate::ExecError::BadConfig { field });
        let w = &self.workspace;
        if w.min_x_nm > w.max_x_nm || w.min_y_nm > w.max_y_nm {
            return bad("workspace");
        }
        if !(1..=1000).contains(&self.setpoint_rate_hz) {
            return bad("setpoint_rate_hz");
        }
        if self.max_speed_nm_s == 0 {
            return bad("max_speed_nm_s");
        }
        if self.lookahead_segments == 0 {
            return bad("lookahead_segments");
        }
        if self.start_lead_us <= self.underrun_margin_us {
            return bad("start_lead_us");
        }
        if self.sync_samples_to_arm == 0 {
            return bad("sync_samples_to_arm");
        }
        let goto_accel = u64::from(self.goto_speed_nm_s) * u64::from(self.setpoint_rate_hz);
        if self.goto_speed_nm_s == 0
            || self.goto_speed_nm_s > self.max_speed_nm_s
            || goto_accel > self.max_accel_nm_s2
        {
            return bad("goto_speed_nm_s");
        }
        if !w.contains(i64::from(self.home_nm.0), i64::from(self.home_nm.1)) {
            return bad("home_nm");
        }
        Ok(())
    }
}

impl Default for ExecutorConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
