//! The plant assembled from a world file, a plan and the seed: the world and how its camera
//! sees it. The in-process trial (the drive module) and the firmware simulator's own process
//! (`Fwsim`) assemble their plant here, so the same world file and seed give the
//! same peg start, camera timing and noise in both (seed streams: camera noise
//! `12 + noise_stream`, start perturbation 13).

use super::world::{RigWorld, WorldSetup};
use super::world_file::WorldFile;
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_firmware_sim::SimRng;
use mesopush_sim::Plan;
use mesopush_vision::RenderSettings;
use rand::SeedableRng;

/// Seed stream of the start perturbation.
const PERTURB_STREAM: u64 = 13;
/// Base of the camera noise streams (`+ noise_stream`).
const NOISE_STREAM_BASE: u64 = 12;

/// The camera's exposure timing.
#[derive(Debug, Clone, Copy)]
pub struct CameraTiming {
    /// Frame period, µs.
    pub period_us: u64,
    /// Readout, µs.
    pub readout_us: u64,
    /// First exposure, µs.
    pub start_us: u64,
}

/// The world and how it is seen.
pub(crate) struct Assembled {
    /// The world, the probe at the plan's start.
    pub world: RigWorld,
    /// The camera's exposure timing.
    pub camera: CameraTiming,
    /// The true optics the frames are rendered with (they differ from the camera's
    /// declared calibration by the world's scale error, if any).
    pub render: RenderSettings,
    /// Fixture origin in stage coordinates, µm.
    pub offset_um: Vec2,
}

/// The peg's start: `over` if given, else the world file's start, else the plan's; then
/// the world file's perturbation (uniform within ± its bounds, µm and degrees) if it has one.
pub(crate) fn peg_start(world: &WorldFile, plan: &Plan, over: Option<Pose>, rng: &SimRng) -> Pose {
    let w = &world.spec.peg;
    let nominal = over.unwrap_or_else(|| {
        w.start.map_or_else(
            || plan.peg_start_pose(),
            |s| Pose::new(s.x_um, s.y_um, s.theta_deg.to_radians()),
        )
    });
    let Some([dx, dy, dth]) = w.perturb else { return nominal };
    let mut r = rng.fork(PERTURB_STREAM);
    let mut u = |a: f64| (2.0 * r.unit() - 1.0) * a;
    Pose::new(nominal.x_um + u(dx), nominal.y_um + u(dy), nominal.theta_rad + u(dth).to_radians())
}

/// Assembles the world of `world` for `plan` under the seed's `rng`.
pub(crate) fn assemble(
    world: &WorldFile,
    plan: &Plan,
    peg_start_over: Option<Pose>,
    rng: &SimRng,
) -> Result<Assembled, Error> {
    let ws = &world.spec;
    let offset_um = Vec2::new(ws.stage.offset_um[0], ws.stage.offset_um[1]);
    let render = RenderSettings {
        width_px: ws.camera.size_px[0],
        height_px: ws.camera.size_px[1],
        calibration: world.render_calibration()?,
        ..RenderSettings::default()
    };
    let camera = CameraTiming {
        period_us: ws.camera.period_us,
        readout_us: ws.camera.readout_us,
        start_us: ws.camera.period_us,
    };
    let setup = WorldSetup {
        model: world.model.clone(),
        peg_start: peg_start(world, plan, peg_start_over, rng),
        stage_offset_um: offset_um,
        render: render.clone(),
        camera_start_us: camera.start_us,
        camera_period_us: camera.period_us,
        effects: ws.effects.clone(),
    };
    let noise_seed = rng.fork(NOISE_STREAM_BASE + ws.camera.noise_stream).next_u64();
    let noise = rand_chacha::ChaCha8Rng::seed_from_u64(noise_seed);
    let world = RigWorld::new(setup, plan.probe_start(), noise)?;
    Ok(Assembled { world, camera, render, offset_um })
}
