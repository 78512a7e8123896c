//! Growing the RRT: turning a chosen push into a connected probe path (retract, go around
//! the peg, approach, push), simulating it, and the direct connection to the goal.

use crate::Error;
use crate::clearance::{Obstacles, first_wall_violation};
use crate::feasible::plan_is_feasible;
use crate::pushes::{DIRECTIONS, Location, PushStart, push_start, simulate};
use crate::route::route;
use crate::rrt_settings::RrtSettings;
use crate::tree::{Node, Tree, angle_diff_mod_pi, pose_distance};
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::{Plan, Simulator};
use rand::RngExt;

/// Retract distances tried after a push, µm (the first that clears the peg is used).
const RETRACTS_UM: [f64; 4] = [60.0, 120.0, 240.0, 480.0];
/// Random (location, direction) draws tried before giving up on one random push.
const DRAWS: usize = 24;
/// How far past the channel mouth the direct connection aims the centre of mass, µm.
const INSERT_EXTRA_UM: f64 = 150.0;

/// A simulated push ready to join the tree (its `parent` is set by [`Steer::add`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Extension {
    /// The node it would add.
    pub node: Node,
    /// Whether the peg ended inserted.
    pub inserted: bool,
}

/// Everything the RRT needs to extend its tree.
#[derive(Debug)]
pub struct Steer<'a> {
    sim: &'a mut Simulator,
    locations: &'a [Location],
    settings: &'a RrtSettings,
    part: ConvexPolygon,
    walls: Vec<ConvexPolygon>,
    goal: Pose,
    overloaded: usize,
}

impl<'a> Steer<'a> {
    /// Steering over `sim`'s model and fixture.
    pub fn new(
        sim: &'a mut Simulator,
        locations: &'a [Location],
        settings: &'a RrtSettings,
    ) -> Self {
        let part = sim.model().part.polygon().clone();
        let walls = sim.fixture().walls.clone();
        let goal = goal_pose(sim);
        Self { sim, locations, settings, part, walls, goal, overloaded: 0 }
    }

    /// Pushes rejected so far because they bent the needle beyond the model's limit.
    pub fn overloaded_pushes(&self) -> usize {
        self.overloaded
    }

    /// The goal pose the planner steers to: centred on the channel, aligned with it,
    /// `INSERT_EXTRA_UM` beyond the insertion depth.
    pub fn goal(&self) -> Pose {
        self.goal
    }

    fn obstacles<'b>(&'b self, peg: Option<&'b ConvexPolygon>) -> Obstacles<'b> {
        Obstacles {
            walls: &self.walls,
            peg,
            probe_radius_um: self.sim.model().probe_radius_um,
            peg_clearance_um: self.settings.pushes.peg_clearance_um,
        }
    }

    /// The probe path from `node`'s probe end to the push `ps` of `length_um`, and where it
    /// starts; `None` when the probe cannot get there or the push would enter a wall.
    fn moves_for(
        &self,
        node: &Node,
        ps: &PushStart,
        length_um: f64,
    ) -> Option<(Vec2, Vec<[f64; 2]>)> {
        let push = ps.movement(length_um);
        let r = self.sim.model().probe_radius_um;
        if first_wall_violation(ps.start_um, &[push], &self.walls, r).is_some() {
            return None;
        }
        let Some(from) = node.probe_um else { return Some((ps.start_um, vec![push])) };
        let peg = self.part.transformed(&node.pose);
        let obstacles = self.obstacles(Some(&peg));
        let walls_only = self.obstacles(None);
        let d = Vec2::new(DIRECTIONS[node.direction][0], DIRECTIONS[node.direction][1]);
        let back = RETRACTS_UM
            .iter()
            .map(|k| from - d * *k)
            .find(|q| walls_only.segment_free(&from, q) && obstacles.point_free(q))?;
        let mut moves = vec![[back.x - from.x, back.y - from.y]];
        moves.extend(route(back, ps.start_um, &obstacles)?);
        moves.push(push);
        Some((from, moves))
    }

    /// Simulates push `ps` of `length_um` from `node`; `None` when it is unusable (no probe
    /// path, jammed, the needle overloaded, or the peg hardly moved).
    fn extend(
        &mut self,
        node: &Node,
        ps: &PushStart,
        length_um: f64,
    ) -> Result<Option<Extension>, Error> {
        let Some((from, moves)) = self.moves_for(node, ps, length_um) else { return Ok(None) };
        let (o, _) = simulate(self.sim, node.pose, from, &moves)?;
        self.overloaded += usize::from(o.overloaded);
        if o.jammed || o.overloaded || pose_distance(&o.pose, &node.pose) < 2.0 {
            return Ok(None);
        }
        let new = Node {
            pose: o.pose,
            parent: None,
            moves,
            probe_from_um: from,
            probe_um: Some(o.probe_um),
            direction: ps.direction,
            location: ps.location,
            length_um,
            depth: node.depth + 1,
        };
        Ok(Some(Extension { node: new, inserted: o.inserted }))
    }

    /// One random push from `node`: random location and axis among the usable ones, length
    /// log-uniform in the settings' range.
    pub fn random_push(
        &mut self,
        node: &Node,
        rng: &mut impl rand::Rng,
    ) -> Result<Option<Extension>, Error> {
        let peg = self.part.transformed(&node.pose);
        let (lo, hi) = self.settings.pushes.length_range_um;
        for _ in 0..DRAWS {
            let li = rng.random_range(0..self.locations.len());
            let di = rng.random_range(0..DIRECTIONS.len());
            let obstacles = self.obstacles(Some(&peg));
            let ps =
                push_start(self.locations, li, di, &node.pose, &obstacles, &self.settings.pushes);
            let Some(ps) = ps else { continue };
            let length = (lo.ln() + rng.random_range(0.0..1.0) * (hi / lo).ln()).exp();
            return self.extend(node, &ps, length);
        }
        Ok(None)
    }

    /// The push from `location` along `direction` of `length_um` from `node`, re-aimed at
    /// `node`'s pose (what the shortcut pass replays); `None` when it is unusable there.
    pub fn push_from(
        &mut self,
        node: &Node,
        location: usize,
        direction: usize,
        length_um: f64,
    ) -> Result<Option<Extension>, Error> {
        let peg = self.part.transformed(&node.pose);
        let obstacles = self.obstacles(Some(&peg));
        let ps = push_start(
            self.locations,
            location,
            direction,
            &node.pose,
            &obstacles,
            &self.settings.pushes,
        );
        match ps {
            Some(ps) => self.extend(node, &ps, length_um),
            None => Ok(None),
        }
    }

    /// Adds `ext` under `parent`; returns its index.
    pub fn add(&self, tree: &mut Tree, parent: usize, mut ext: Extension) -> usize {
        ext.node.parent = Some(parent);
        tree.nodes.push(ext.node);
        tree.nodes.len() - 1
    }

    /// The usable push along `di` whose contact point is nearest the line through `through`
    /// along the push (a push through the centre of mass when `through` is the COM).
    fn push_through(&self, pose: &Pose, di: usize, through: Vec2) -> Option<PushStart> {
        let peg = self.part.transformed(pose);
        let obstacles = self.obstacles(Some(&peg));
        let d = Vec2::new(DIRECTIONS[di][0], DIRECTIONS[di][1]);
        let off = |li: usize| {
            let p = pose.transform_point(&self.locations[li].point_um) - through;
            (p - d * p.dot(&d)).norm()
        };
        (0..self.locations.len())
            .filter_map(|li| {
                push_start(self.locations, li, di, pose, &obstacles, &self.settings.pushes)
            })
            .min_by(|a, b| off(a.location).total_cmp(&off(b.location)))
    }

    /// Direct connection from node `id`: when the peg is aligned with the channel and outside
    /// it, centre it on the channel with a push through its COM, then push it in along −x.
    /// Returns (the last node added, whether it is inserted, pushes simulated).
    pub fn connect(
        &mut self,
        tree: &mut Tree,
        id: usize,
    ) -> Result<(Option<usize>, bool, usize), Error> {
        self.connect_within(tree, id, self.settings.connect_theta_deg)
    }

    /// [`Steer::connect`] from poses within `theta_deg` of the channel's axis (the shortcut
    /// pass tries a wider window than the search: it verifies every plan it keeps).
    pub fn connect_within(
        &mut self,
        tree: &mut Tree,
        id: usize,
        theta_deg: f64,
    ) -> Result<(Option<usize>, bool, usize), Error> {
        let pose = tree.nodes[id].pose;
        let aligned =
            angle_diff_mod_pi(pose.theta_rad, self.goal.theta_rad).abs() <= theta_deg.to_radians();
        let mouth_x = self.sim.fixture().goal.bounds().1.x;
        if !aligned || pose.x_um <= mouth_x {
            return Ok((None, false, 0));
        }
        let (mut at, mut sims) = (id, 0);
        // The goal for the part turned as it is (0 or π from the goal's orientation): a part
        // whose centre of mass is off its outline's middle (a triangle) sits off-centre.
        let goal = goal_pose_turned(self.sim, pose.theta_rad);
        let dy = goal.y_um - pose.y_um;
        if dy.abs() > 5.0 {
            let di = if dy > 0.0 { 2 } else { 3 };
            let Some(ps) = self.push_through(&pose, di, pose.position()) else {
                return Ok((None, false, 0));
            };
            sims += 1;
            let node = tree.nodes[at].clone();
            let Some(ext) = self.extend(&node, &ps, dy.abs())? else {
                return Ok((None, false, sims));
            };
            at = self.add(tree, at, ext);
        }
        let pose = tree.nodes[at].pose;
        let Some(ps) = self.push_through(&pose, 1, pose.position()) else {
            return Ok((None, false, sims));
        };
        sims += 1;
        let node = tree.nodes[at].clone();
        let Some(ext) = self.extend(&node, &ps, pose.x_um - goal.x_um)? else {
            return Ok((None, false, sims));
        };
        let inserted = ext.inserted;
        Ok((Some(self.add(tree, at, ext)), inserted, sims))
    }

    /// Whether the whole `plan` works when replayed from its start.
    pub fn verify(&mut self, plan: &Plan) -> Result<bool, Error> {
        plan_is_feasible(self.sim, plan)
    }
}

/// The goal pose for `sim`'s fixture: aligned with x, the part's outline centred on the goal
/// region's mid-line, its centre of mass `INSERT_EXTRA_UM` deeper than the insertion depth
/// from the mouth (the goal's largest x) — with `goal_whole_part`, its outline's right end
/// that deep.
pub fn goal_pose(sim: &Simulator) -> Pose {
    goal_pose_turned(sim, 0.0)
}

/// [`goal_pose`] for the part turned by the multiple of π nearest `theta_rad` (a part
/// aligned with the channel either way round).
pub fn goal_pose_turned(sim: &Simulator, theta_rad: f64) -> Pose {
    let f = sim.fixture();
    let (lo, hi) = f.goal.bounds();
    let turn = (theta_rad / std::f64::consts::PI).round() * std::f64::consts::PI;
    let outline = sim.model().part.polygon().transformed(&Pose::new(0.0, 0.0, turn));
    let (plo, phi) = outline.bounds();
    let right = if f.goal_whole_part { phi.x } else { 0.0 };
    let x = hi.x - f.insert_depth_um - INSERT_EXTRA_UM - right;
    Pose::new(x, (lo.y + hi.y) / 2.0 - (plo.y + phi.y) / 2.0, turn)
}
