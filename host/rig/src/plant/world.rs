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
//!
//! The needle: the simulator's probe point is the needle's undeflected position (its
//! compliance lets it press into a peg that resists); the tip itself rests against the peg,
//! so the world puts it there — on the edge it met, the probe point moved out along that
//! edge's normal until it touches ([`super::needle::resting_tip`]) — and the camera renders
//! it there, never over the peg.
//! Jams: when the simulator finds the peg wedged (no quasi-static solution), the probe point
//! stops where it is while the stage goes on; the 25 µm needle bends.
//! Each later move re-attempts from the tip's actual position towards the new commanded
//! position (once the command has moved a simulator step since the failed attempt), so the
//! tip follows again as soon as the command pulls away. The needle's deflection (commanded
//! tip − resting tip) is recorded at every exposure and its jam episodes logged
//! ([`super::truth::JamLog`], beyond the world model's `probe_deflection_limit_um`); the
//! controller senses it too ([`World::needle_deflection_nm`]) and faults beyond the same
//! limit. The camera renders the tip where it actually is.
//!
//! Rendering off the controller's loop (on a renderer thread) is the painter module's; the
//! world itself knows nothing of threads.

use super::needle::{contact_edge, resting_tip};
use super::truth::{JamEvent, JamLog, TruthSample};
use crate::Error;
use image::GrayImage;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2, point_segment_distance};
use mesopush_firmware_sim::{PegPose, World};
use mesopush_protocol::units::{nm_to_um, um_to_nm};
use mesopush_sim::advance::{SegmentEnd, advance};
use mesopush_sim::effects::{Backlash, Effects, stamp_with_latency_us};
use mesopush_sim::{Fixture, SimSettings, SimState, Simulator};
use mesopush_vision::{RenderSettings, Renderer, Scene};
use rand_chacha::ChaCha8Rng;

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
    pub model: mesopush_sim::Model,
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
    jams: JamLog,
    /// The commanded tip of the last attempt the peg blocked (re-attempted once the command
    /// has moved a simulator step from it).
    blocked_at: Option<Vec2>,
    /// Commanded tip of the last move (after backlash).
    commanded_um: Vec2,
    backlash: Backlash,
    latency_us: f64,
    /// Time and stage position of the last physics advance (for the probe speed).
    last_advance: Option<(u64, Vec2)>,
    probe_radius_um: f64,
    /// The peg edge the probe met, while in contact (the tip rests on it).
    contact_edge: Option<usize>,
}

/// Step budget per physics advance (a bounded loop).
const ADVANCE_BUDGET: usize = 100_000;

/// How far the simulated probe path may cut a corner of the stage's path, µm (the stage
/// reports positions in whole nm, so a straight move wanders by about that much).
const CORNER_TOLERANCE_UM: f64 = 0.01;

impl RigWorld {
    /// A world with the probe at `probe_start_um` (fixture frame); the renderer's noise from
    /// `rng`.
    pub fn new(setup: WorldSetup, probe_start_um: Vec2, rng: ChaCha8Rng) -> Result<Self, Error> {
        let fixture = Fixture::paper();
        let renderer = Renderer::new(setup.render.clone(), &fixture.walls)?;
        let peg_body = setup.model.part.polygon().clone();
        let probe_radius_um = setup.model.probe_radius_um;
        let jams = JamLog::new(setup.model.probe_deflection_limit_um);
        let sim = Simulator::new(setup.model, fixture, SimSettings::default())?;
        let st = SimState::new(setup.peg_start, probe_start_um);
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
            jams,
            blocked_at: None,
            commanded_um: probe_start_um,
            backlash: Backlash::new(setup.effects.backlash_um),
            latency_us: setup.effects.camera_latency_us,
            last_advance: None,
            probe_radius_um,
            contact_edge: None,
        })
    }

    /// Ground truth at every exposure so far, in time order.
    pub fn truth(&self) -> &[TruthSample] {
        &self.truth
    }

    /// Jam episodes so far (needle deflection beyond [`RigWorld::deflection_limit_um`]).
    pub fn jam_events(&self) -> &[JamEvent] {
        self.jams.events()
    }

    /// Largest needle deflection so far, µm.
    pub fn max_deflection_um(&self) -> f64 {
        self.jams.max_deflection_um()
    }

    /// The needle's deflection limit, µm: the world model's `probe_deflection_limit_um`.
    pub fn deflection_limit_um(&self) -> f64 {
        self.jams.limit_um()
    }

    /// Where the needle's tip is: resting against the peg (see [`super::needle::resting_tip`]).
    fn tip_um(&self) -> Vec2 {
        let peg = self.peg_body.transformed(&self.st.peg);
        resting_tip(&peg, self.st.probe_um, self.probe_radius_um, self.contact_edge)
    }

    /// The needle's current deflection (commanded tip − resting tip), µm.
    fn deflection_um(&self) -> f64 {
        (self.commanded_um - self.tip_um()).norm()
    }

    /// The renderer (true optics; the static part of the picture cached).
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The peg's outline in its body frame.
    pub fn peg_body(&self) -> &ConvexPolygon {
        &self.peg_body
    }

    /// The next draw of the world's sensor-noise stream: the seed of a renderer's own
    /// stream (the painter's, which draws frames off the controller's loop).
    pub fn next_noise_seed(&mut self) -> u64 {
        rand::Rng::next_u64(&mut self.rng)
    }

    /// The world's state now, stamped `t_us` (what a frame exposed now would show).
    pub fn truth_now(&self, t_us: u64) -> TruthSample {
        TruthSample {
            t_us,
            peg: self.st.peg,
            probe_um: self.tip_um(),
            deflection_um: self.deflection_um(),
            jams: self.jams.count(),
        }
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
        let exposure_us = i64::try_from(exposure_us).unwrap_or(i64::MAX);
        u64::try_from(stamp_with_latency_us(exposure_us, self.latency_us)).unwrap_or(0)
    }

    /// The world's camera latency, µs (rounded; 0 when none).
    pub fn camera_latency_us(&self) -> i64 {
        self.latency_us.round() as i64
    }

    /// Stage nm → fixture µm.
    pub fn stage_to_fixture(&self, probe_nm: (i32, i32)) -> Vec2 {
        Vec2::new(nm_to_um(probe_nm.0), nm_to_um(probe_nm.1)) - self.offset_um
    }

    /// Moves the stage to `stage_um` at `t_us`: the tip follows through the backlash and
    /// the physics advances to it (or as far as the peg lets it).
    fn move_stage_to(&mut self, t_us: u64, stage_um: Vec2) {
        let tip = self.backlash.update(stage_um);
        self.flush_corner(tip);
        if let Some((t0, p0)) = self.last_advance
            && t_us > t0
        {
            // µs → s by multiplication, as always: `units::us_to_s` divides, which differs
            // in the last bit for some times, and the speed-friction physics depends on it.
            let speed = (stage_um - p0).norm() / ((t_us - t0) as f64 * 1e-6);
            self.sim.set_probe_speed_um_s(speed);
        }
        self.last_advance = Some((t_us, stage_um));
        self.move_probe_to(tip);
        self.note_deflection(t_us);
    }

    /// Brings the physics to the pending tip (the last one not yet simulated, because it was
    /// less than a step away) when going straight on to `next_um` would cut the corner there:
    /// at a reversal the deepest point of a push would otherwise be skipped, and the peg would
    /// stop up to a simulator step short of where the probe pushed it (lost motion a clean
    /// world must not have; it read as backlash to `diagnose`).
    fn flush_corner(&mut self, next_um: Vec2) {
        let pending = self.commanded_um;
        if self.blocked_at.is_some() || (pending - self.st.probe_um).norm() < 1e-9 {
            return;
        }
        if point_segment_distance(&pending, &self.st.probe_um, &next_um) > CORNER_TOLERANCE_UM {
            self.move_probe_to(pending);
        }
    }

    /// Advances the physics with the commanded tip at `target_um`. When the peg wedged, the
    /// tip stays where it stopped (the needle bends, the stage goes on); the same attempt is
    /// not repeated until the command has moved a step from the blocked one.
    fn move_probe_to(&mut self, target_um: Vec2) {
        self.commanded_um = target_um;
        let delta = target_um - self.st.probe_um;
        if delta.norm() < 1e-9 {
            self.blocked_at = None;
            return;
        }
        let step_um = self.sim.settings().step_um;
        if self.blocked_at.is_some_and(|b| (target_um - b).norm() < step_um) {
            return;
        }
        let mut budget = ADVANCE_BUDGET;
        match advance(&mut self.sim, &mut self.st, delta, &mut budget, |_, _, _| {}) {
            Ok(SegmentEnd::Reached) => self.blocked_at = None,
            Ok(SegmentEnd::Jammed { .. }) | Err(_) => self.blocked_at = Some(target_um),
        }
        // the edge the tip met stays its edge until the probe leaves the peg
        let peg = self.peg_body.transformed(&self.st.peg);
        match contact_edge(&peg, self.st.probe_um, self.probe_radius_um) {
            None => self.contact_edge = None,
            Some(e) => {
                self.contact_edge.get_or_insert(e);
            }
        }
    }

    /// Tracks the needle's deflection and the jam episodes.
    fn note_deflection(&mut self, t_us: u64) {
        let d = self.deflection_um();
        self.jams.note(t_us, d, self.st.peg);
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
            self.move_stage_to(te, pe);
            let sample = self.truth_now(te);
            self.truth.push(sample);
            self.next_exposure_us += self.period_us;
        }
        // The backlash sees every stage position (a reversal inside a chord counts).
        let tip = self.backlash.update(target);
        self.flush_corner(tip);
        if (tip - self.st.probe_um).norm() >= self.sim.settings().step_um {
            self.move_stage_to(sim_time_us, target);
        } else {
            self.commanded_um = tip;
        }
        self.last = Some((sim_time_us, target));
        let p = self.st.peg;
        PegPose { x_um: p.x_um, y_um: p.y_um, theta_rad: p.theta_rad }
    }

    /// The needle's deflection after the last step, nm (beyond the wire's range: the
    /// largest, which any limit exceeds).
    fn needle_deflection_nm(&self) -> Option<i32> {
        Some(um_to_nm("needle deflection", self.deflection_um()).unwrap_or(i32::MAX))
    }

    fn render(&mut self, sim_time_us: u64) -> WorldFrame {
        let i = self.truth.partition_point(|s| s.t_us < sim_time_us);
        let truth = self.truth.get(i).or(self.truth.last()).copied();
        let truth = truth.unwrap_or_else(|| self.truth_now(sim_time_us));
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
