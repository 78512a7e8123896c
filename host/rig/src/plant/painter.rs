//! Rendering off the controller's loop: rendering a frame takes milliseconds, and a
//! controller loop that renders answers clock-sync requests late (the executor then drops
//! the sync and, after a second without one, faults the trial). [`Deferred`] is the world as
//! the loop sees it — physics only; its `render` hands back the ground truth at the exposure
//! — and a [`Painter`] on another thread draws it. Used by the `mesopush-fwsim` process and by
//! the in-process real-time loop.

use super::truth::TruthSample;
use super::world::RigWorld;
use image::GrayImage;
use mesopush_core::geom::ConvexPolygon;
use mesopush_firmware_sim::{PegPose, World};
use mesopush_vision::{Renderer, Scene};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The world as the controller loop sees it: physics only; `render` returns the ground truth
/// at the exposure (what to draw) and the renderer thread draws it.
#[derive(Debug)]
pub struct Deferred<'a> {
    /// The world stepped by the loop.
    pub world: &'a mut RigWorld,
}

impl World for Deferred<'_> {
    type Frame = TruthSample;

    fn step(&mut self, sim_time_us: u64, probe_nm: (i32, i32)) -> PegPose {
        self.world.step(sim_time_us, probe_nm)
    }

    fn needle_deflection_nm(&self) -> Option<i32> {
        self.world.needle_deflection_nm()
    }

    fn render(&mut self, sim_time_us: u64) -> TruthSample {
        // As `RigWorld::render`: the snapshot at the exposure (taken when a step crossed it).
        let truth = self.world.truth();
        let i = truth.partition_point(|s| s.t_us < sim_time_us);
        let now = || self.world.truth_now(sim_time_us);
        truth.get(i).or(truth.last()).copied().unwrap_or_else(now)
    }
}

/// What the renderer thread draws with (see [`Painter::for_world`]).
#[derive(Debug)]
pub struct Painter {
    /// The renderer (static part of the picture cached).
    pub renderer: Renderer,
    /// Fixture walls, fixture frame µm.
    pub walls: Vec<ConvexPolygon>,
    /// The peg's outline in its body frame.
    pub peg: ConvexPolygon,
    /// Sensor noise stream.
    pub rng: ChaCha8Rng,
}

impl Painter {
    /// What a renderer thread needs to draw `world`'s frames: a copy of its renderer, and a
    /// noise stream of its own seeded from the world's, so frames can be drawn off the
    /// controller's loop.
    pub fn for_world(world: &mut RigWorld) -> Self {
        Self {
            renderer: world.renderer().clone(),
            walls: world.fixture().walls.clone(),
            peg: world.peg_body().clone(),
            rng: ChaCha8Rng::seed_from_u64(world.next_noise_seed()),
        }
    }

    /// Draws `t` as an image.
    pub fn paint_image(&mut self, t: &TruthSample) -> GrayImage {
        let scene = Scene {
            walls: &self.walls,
            peg: Some(&self.peg),
            peg_pose: t.peg,
            probe_tip: Some(t.probe_um),
        };
        self.renderer.render(&scene, &mut self.rng).image
    }

    /// Draws `t` as raw 8-bit pixels, row-major.
    pub fn paint(&mut self, t: &TruthSample) -> Vec<u8> {
        self.paint_image(t).into_raw()
    }
}
