//! The paper's planner (section II-B, III-B): an RRT over peg poses whose edges are simulated
//! probe pushes along x or y from discretised pushing locations on the reachable boundary.
//!
//! Each iteration samples a target pose (the goal with probability `goal_bias`), takes the
//! nearest node, simulates `inputs_per_iteration` random pushes from it (random location,
//! axis and length) and keeps the outcome closest to the target, as in RRTs for systems
//! that can only be steered through their inputs. Every new node also tries the direct
//! connection to the goal: a push through the centre of mass that centres the peg on the
//! channel, then one along −x that slides it in. A push that bends the needle beyond the
//! model's limit is never an edge. A branch counts as found only when the whole plan,
//! replayed from the start, inserts the peg (within the needle's limit) and keeps the probe
//! out of the walls.

use crate::Error;
use crate::pushes::boundary_locations;
use crate::rrt_settings::RrtSettings;
use crate::shortcut::shortcut;
use crate::steer::{Extension, Steer};
use crate::tree::{Tree, pose_distance};
use mesopush_core::geom::Pose;
use mesopush_sim::fixture::FIELD_UM;
use mesopush_sim::{Plan, Simulator};
use rand::{RngExt, SeedableRng};
use std::time::Instant;

/// What the search did.
#[derive(Debug, Clone, PartialEq)]
pub struct RrtResult {
    /// The plan, when one was found.
    pub plan: Option<Plan>,
    /// Iterations run.
    pub iterations: usize,
    /// Nodes in the tree.
    pub tree_size: usize,
    /// Pushes (tree edges) in the plan after shortcutting; 0 when none was found.
    pub pushes: usize,
    /// Pushes of the branch the search found, before shortcutting; 0 when none was found.
    pub pushes_before_shortcut: usize,
    /// Push drops the shortcut pass tried.
    pub shortcut_attempts: usize,
    /// Push simulations run.
    pub simulated_pushes: usize,
    /// Candidate plans that reached the goal in the tree but failed the whole-plan replay.
    pub rejected_at_verification: usize,
    /// Simulated pushes (tree edges) rejected because they bent the needle beyond the
    /// model's `probe_deflection_limit_um` (search and shortcut pass).
    pub overloaded_pushes: usize,
}

/// Progress report for a caller's bar; return `false` from the callback to stop early.
#[derive(Debug, Clone, Copy)]
pub struct RrtProgress {
    /// Iterations so far.
    pub iteration: usize,
    /// Nodes so far.
    pub tree_size: usize,
}

/// Plans from the peg pose `start` to the goal of `sim`'s fixture.
pub fn plan_rrt(
    sim: &mut Simulator,
    start: Pose,
    settings: &RrtSettings,
    rng: &mut impl rand::Rng,
    progress: &mut dyn FnMut(RrtProgress) -> bool,
) -> Result<RrtResult, Error> {
    let locations = boundary_locations(sim.model().part.polygon(), settings.pushes.n_locations);
    let mut steer = Steer::new(sim, &locations, settings);
    let mut tree = Tree::new(start);
    let mut out = RrtResult {
        plan: None,
        iterations: 0,
        tree_size: 1,
        pushes: 0,
        pushes_before_shortcut: 0,
        shortcut_attempts: 0,
        simulated_pushes: 0,
        rejected_at_verification: 0,
        overloaded_pushes: 0,
    };
    let goal = steer.goal();
    if let Some(leaf) = try_connect(&mut steer, &mut tree, 0, settings, &mut out)? {
        return finish(&mut steer, &tree, leaf, settings, out);
    }
    for it in 0..settings.max_iterations {
        out.iterations = it + 1;
        let target = if rng.random_bool(settings.goal_bias) { goal } else { random_pose(rng) };
        let near = tree.nearest(&target);
        let mut best: Option<Extension> = None;
        for _ in 0..settings.inputs_per_iteration {
            out.simulated_pushes += 1;
            let Some(ext) = steer.random_push(&tree.nodes[near], rng)? else { continue };
            let better = best.as_ref().is_none_or(|b| {
                pose_distance(&ext.node.pose, &target) < pose_distance(&b.node.pose, &target)
            });
            if better {
                best = Some(ext);
            }
        }
        if let Some(ext) = best {
            let id = steer.add(&mut tree, near, ext);
            if let Some(leaf) = try_connect(&mut steer, &mut tree, id, settings, &mut out)? {
                return finish(&mut steer, &tree, leaf, settings, out);
            }
        }
        out.tree_size = tree.nodes.len();
        if !progress(RrtProgress { iteration: it + 1, tree_size: tree.nodes.len() }) {
            break;
        }
    }
    out.tree_size = tree.nodes.len();
    out.overloaded_pushes = steer.overloaded_pushes();
    Ok(out)
}

/// Tries the goal connection from node `id`; returns the inserted leaf whose whole plan
/// verifies.
fn try_connect(
    steer: &mut Steer<'_>,
    tree: &mut Tree,
    id: usize,
    settings: &RrtSettings,
    out: &mut RrtResult,
) -> Result<Option<usize>, Error> {
    let (leaf, inserted, sims) = steer.connect(tree, id)?;
    out.simulated_pushes += sims;
    let Some(leaf) = leaf else { return Ok(None) };
    if !inserted {
        return Ok(None);
    }
    let plan = tree.plan_to(leaf, "RRT plan", settings.speed_um_s);
    if steer.verify(&plan)? {
        return Ok(Some(leaf));
    }
    out.rejected_at_verification += 1;
    Ok(None)
}

/// The plan to the found `leaf`, shortcut.
fn finish(
    steer: &mut Steer<'_>,
    tree: &Tree,
    leaf: usize,
    s: &RrtSettings,
    mut out: RrtResult,
) -> Result<RrtResult, Error> {
    out.tree_size = tree.nodes.len();
    out.pushes_before_shortcut = tree.branch(leaf).len() - 1;
    let short = shortcut(steer, tree, leaf, s)?;
    out.shortcut_attempts = short.attempts;
    out.pushes = short.tree.branch(short.leaf).len() - 1;
    out.overloaded_pushes = steer.overloaded_pushes();
    let name = format!("RRT plan ({} pushes, {} iterations)", out.pushes, out.iterations);
    out.plan = Some(short.tree.plan_to(short.leaf, &name, s.speed_um_s));
    Ok(out)
}

/// A uniformly random peg pose over the camera field.
fn random_pose(rng: &mut impl rand::Rng) -> Pose {
    Pose::new(
        rng.random_range(0.0..FIELD_UM[0]),
        rng.random_range(0.0..FIELD_UM[1]),
        rng.random_range(-std::f64::consts::FRAC_PI_2..std::f64::consts::FRAC_PI_2),
    )
}

/// A search as `mesopush plan rrt` runs it: seeded, under a wall-clock budget.
#[derive(Debug, Clone, PartialEq)]
pub struct RrtRun {
    /// What the search did (`plan: None` when it found nothing within the budget).
    pub result: RrtResult,
    /// Wall-clock time of the search and the shortcut pass, ms.
    pub planning_ms: f64,
}

/// [`plan_rrt`] from the ChaCha8 stream of `seed`, stopped after the first iteration that ends
/// past `time_limit_s`; `progress` sees every iteration (for a progress display).
pub fn plan_rrt_within(
    sim: &mut Simulator,
    start: Pose,
    settings: &RrtSettings,
    seed: u64,
    time_limit_s: f64,
    progress: &mut dyn FnMut(RrtProgress),
) -> Result<RrtRun, Error> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let t0 = Instant::now();
    let mut on_progress = |p: RrtProgress| {
        progress(p);
        t0.elapsed().as_secs_f64() < time_limit_s
    };
    let result = plan_rrt(sim, start, settings, &mut rng, &mut on_progress)?;
    Ok(RrtRun { result, planning_ms: t0.elapsed().as_secs_f64() * 1e3 })
}
