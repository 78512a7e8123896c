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

use crate::Error;
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
    /// The probe tip's true position (stage), fixture frame µm.
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

    /// Stage nm → fixture µm.
    pub fn stage_to_fixture(&self, probe_nm: (i32, i32)) -> Vec2 {
        Vec2::new(f64::from(probe_nm.0) / 1000.0, f64::from(probe_nm.1) / 1000.0) - self.offset_um
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
            self.move_probe_to(pe);
            self.truth.push(TruthSample { t_us: te, peg: self.st.peg, probe_um: pe });
            self.next_exposure_us += self.period_us;
        }
        if (target - self.st.probe_um).norm() >= self.sim.settings().step_um {
            self.move_probe_to(target);
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
