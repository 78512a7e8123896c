//! The firmware simulator's physical world, implemented by the host: the quasi-static
//! simulator (with the *world's* model, which may differ from the host's nominal one) moves
//! the peg as the stage moves the probe, and the synthetic microscope renders what the camera
//! sees at each exposure.
//!
//! Time: `sim_time_us` is the simulation's clock (the executor's clock in simulated-time
//! runs). The world knows the camera's exposure schedule; when a step crosses an exposure it
//! advances the physics exactly to the probe position at the exposure (interpolated between
//! steps) and keeps a snapshot, so the frame the camera delivers `readout_us` later shows the
//! scene at its exposure, not at its delivery. Between exposures the physics advances in
//! chords of the simulator's step length (the stage path is piecewise straight, so nothing
//! is lost). Snapshots are the ground truth (`truth()`), never shown to the host's tracker.
//!
//! Undeclared kinematic effects (the world file's `[effects]`): stage backlash sits between
//! the stage (what the controller reports) and the probe tip that touches the peg (a
//! stateful [`Backlash`] fed every stage position, chords included); camera latency makes
//! the driver's stamp late ([`RigWorld::driver_stamp_us`]: stamp = exposure + latency). The
//! scale error lives in the renderer's calibration (`WorldFile::render_calibration`), the
//! physical effects in the world's model. The probe speed the speed-friction effect needs is
//! the stage's speed over each physics chord.

use crate::Error;
use crate::effects::{Backlash, Effects, stamp_with_latency_us};
use crate::geom::{ConvexPolygon, Pose, Vec2};
use crate::sim::advance::{SegmentEnd, advance};
use crate::sim::{Fixture, SimSettings, SimState, Simulator};
use crate::vision::{RenderSettings, Renderer, Scene};
use image::GrayImage;
use mesopush_firmware_sim::{PegPose, World};
use rand_chacha::ChaCha8Rng;

/// The world at one camera exposure (ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Exposure time, µs (simulation clock).
    pub t_us: u64,
    /// The peg's true pose.
    pub peg: Pose,
    /// The probe tip's true position (after backlash), fixture frame µm.
    pub probe_um: Vec2,
}

/// A rendered frame.
#[derive(Debug, Clone)]
pub struct WorldFrame {
    /// The image.
    pub image: GrayImage,
    /// What it shows.
    pub truth: TruthSample,
}

/// How the world is set up.
#[derive(Debug, Clone)]
pub struct WorldSetup {
    /// The world's physics.
    pub model: crate::sim::Model,
    /// The peg's start pose.
    pub peg_start: Pose,
    /// Fixture origin in stage coordinates, µm.
    pub stage_offset_um: Vec2,
    /// The renderer's settings (true optics).
    pub render: RenderSettings,
    /// First exposure and frame period, µs.
    pub camera_start_us: u64,
    /// Frame period, µs.
    pub camera_period_us: u64,
    /// The world's effects; here only backlash and camera latency are used (the renderer's
    /// calibration carries the scale error, the model the physical effects).
    pub effects: Effects,
}

/// The host's world for the firmware simulator.
#[derive(Debug)]
pub struct RigWorld {
    sim: Simulator,
    renderer: Renderer,
    rng: ChaCha8Rng,
    peg_body: ConvexPolygon,
    st: SimState,
    offset_um: Vec2,
    last: Option<(u64, Vec2)>,
    next_exposure_us: u64,
    period_us: u64,
    truth: Vec<TruthSample>,
    jams: u64,
    backlash: Backlash,
    latency_us: f64,
    /// Time and stage position of the last physics advance (for the probe speed).
    last_advance: Option<(u64, Vec2)>,
}

/// Step budget per physics advance (a bounded loop).
const ADVANCE_BUDGET: usize = 100_000;

impl RigWorld {
    /// A world with the probe at `probe_start_um` (fixture frame); the renderer's noise from
    /// `rng`.
    pub fn new(setup: WorldSetup, probe_start_um: Vec2, rng: ChaCha8Rng) -> Result<Self, Error> {
        let fixture = Fixture::paper();
        let renderer = Renderer::new(setup.render.clone(), &fixture.walls)?;
        let peg_body = setup.model.part.polygon().clone();
        let sim = Simulator::new(setup.model, fixture, SimSettings::default())?;
        let st = SimState { peg: setup.peg_start, probe_um: probe_start_um };
        if sim.probe_gap_um(&st) < 0.0 {
            return Err(Error::invalid("world", "the probe starts inside the peg"));
        }
        Ok(Self {
            sim,
            renderer,
            rng,
            peg_body,
            st,
            offset_um: setup.stage_offset_um,
            last: None,
            next_exposure_us: setup.camera_start_us,
            period_us: setup.camera_period_us.max(1),
            truth: Vec::new(),
            jams: 0,
            backlash: Backlash::new(setup.effects.backlash_um),
            latency_us: setup.effects.camera_latency_us,
            last_advance: None,
        })
    }

    /// Ground truth at every exposure so far, in time order.
    pub fn truth(&self) -> &[TruthSample] {
        &self.truth
    }

    /// Times the peg wedged (the probe could not advance the physics).
    pub fn jams(&self) -> u64 {
        self.jams
    }

    /// The peg's current pose.
    pub fn peg(&self) -> Pose {
        self.st.peg
    }

    /// The fixture the world runs in.
    pub fn fixture(&self) -> &Fixture {
        self.sim.fixture()
    }

    /// Renders the empty fixture (no peg, no probe) as a user records a background: the mean
    /// of 16 frames.
    pub fn background(&mut self) -> GrayImage {
        let walls = self.sim.fixture().walls.clone();
        let scene = Scene { walls: &walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
        self.renderer.render_averaged(&scene, 16, &mut self.rng).image
    }

    /// The camera driver's stamp of a frame exposed at `exposure_us`: late by the world's
    /// camera latency (never before time 0).
    pub fn driver_stamp_us(&self, exposure_us: u64) -> u64 {
        stamp_with_latency_us(exposure_us as i64, self.latency_us).max(0) as u64
    }

    /// The world's camera latency, µs (rounded; 0 when none).
    pub fn camera_latency_us(&self) -> i64 {
        self.latency_us.round() as i64
    }

    /// Stage nm → fixture µm.
    pub fn stage_to_fixture(&self, probe_nm: (i32, i32)) -> Vec2 {
        Vec2::new(f64::from(probe_nm.0) / 1000.0, f64::from(probe_nm.1) / 1000.0) - self.offset_um
    }

    /// Moves the stage to `stage_um` at `t_us`: the tip follows through the backlash and
    /// the physics advances to it.
    fn move_stage_to(&mut self, t_us: u64, stage_um: Vec2) -> Vec2 {
        let tip = self.backlash.update(stage_um);
        if let Some((t0, p0)) = self.last_advance
            && t_us > t0
        {
            let speed = (stage_um - p0).norm() / ((t_us - t0) as f64 * 1e-6);
            self.sim.set_probe_speed_um_s(speed);
        }
        self.last_advance = Some((t_us, stage_um));
        self.move_probe_to(tip);
        tip
    }

    fn move_probe_to(&mut self, target_um: Vec2) {
        let delta = target_um - self.st.probe_um;
        if delta.norm() < 1e-9 {
            return;
        }
        let mut budget = ADVANCE_BUDGET;
        match advance(&mut self.sim, &mut self.st, delta, &mut budget, |_, _, _| {}) {
            Ok(SegmentEnd::Reached) => {}
            // The probe stops where the peg wedged; the next move starts from there (the
            // needle bends, the stage goes on).
            Ok(SegmentEnd::Jammed { .. }) | Err(_) => self.jams += 1,
        }
    }
}

impl World for RigWorld {
    type Frame = WorldFrame;

    fn step(&mut self, sim_time_us: u64, probe_nm: (i32, i32)) -> PegPose {
        let target = self.stage_to_fixture(probe_nm);
        let (t0, p0) = self.last.unwrap_or((sim_time_us, target));
        while self.next_exposure_us <= sim_time_us {
            let te = self.next_exposure_us;
            let f = if sim_time_us > t0 && te > t0 {
                (te - t0) as f64 / (sim_time_us - t0) as f64
            } else {
                1.0
            };
            let pe = p0 + (target - p0) * f;
            let tip = self.move_stage_to(te, pe);
            self.truth.push(TruthSample { t_us: te, peg: self.st.peg, probe_um: tip });
            self.next_exposure_us += self.period_us;
        }
        // The backlash sees every stage position (a reversal inside a chord counts).
        let tip = self.backlash.update(target);
        if (tip - self.st.probe_um).norm() >= self.sim.settings().step_um {
            self.move_stage_to(sim_time_us, target);
        }
        self.last = Some((sim_time_us, target));
        let p = self.st.peg;
        PegPose { x_um: p.x_um, y_um: p.y_um, theta_rad: p.theta_rad }
    }

    fn render(&mut self, sim_time_us: u64) -> WorldFrame {
        let i = self.truth.partition_point(|s| s.t_us < sim_time_us);
        let truth = self.truth.get(i).or(self.truth.last()).copied().unwrap_or(TruthSample {
            t_us: sim_time_us,
            peg: self.st.peg,
            probe_um: self.st.probe_um,
        });
        let walls = &self.sim.fixture().walls;
        let scene = Scene {
            walls,
            peg: Some(&self.peg_body),
            peg_pose: truth.peg,
            probe_tip: Some(truth.probe_um),
        };
        let image = self.renderer.render(&scene, &mut self.rng).image;
        WorldFrame { image, truth }
    }
}
