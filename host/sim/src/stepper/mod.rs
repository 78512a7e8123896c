//! One quasi-static time step: find the contacts, build the mixed LCP, solve it and move the
//! peg. The pusher (one or more discs, [`crate::pusher`]) is position-controlled in x, y and
//! θ; the peg moves only through its contacts.

mod solve;
mod step;

use super::cone::SupportCones;
use super::contact::{Contact, ContactKind, wall_contacts};
use super::fixture::Fixture;
use super::formulate::{Layout, N_SUPPORTS, StepProblem};
use super::model::Model;
use super::pusher::Pusher;
use super::settings::SimSettings;
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_lcp::{LcpSettings, LcpSolver};
use nalgebra::Rotation2;

/// The simulated world's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimState {
    /// Peg pose.
    pub peg: Pose,
    /// The pusher's reference point (the probe tip centre of a one-disc pusher), µm.
    pub probe_um: Vec2,
    /// The pusher's angle, rad (0 for the paper's probe, which never turns).
    pub probe_theta_rad: f64,
}

impl SimState {
    /// The peg at `peg` and the pusher at `probe_um`, not turned.
    pub fn new(peg: Pose, probe_um: Vec2) -> Self {
        Self { peg, probe_um, probe_theta_rad: 0.0 }
    }

    /// The pusher's pose (reference point and angle).
    pub fn pusher_pose(&self) -> Pose {
        Pose::new(self.probe_um.x, self.probe_um.y, self.probe_theta_rad)
    }
}

/// What one step found (for trajectories and diagnostics).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepInfo {
    /// Whether an LCP was solved (false: the probe was clear of the peg).
    pub solved_lcp: bool,
    /// Contacts carrying force after the step, with their mode, e.g. `probe:stick`.
    pub active: Vec<(ContactKind, Mode)>,
    /// Normal force at the pusher (summed over its discs), in units of the part's weight.
    pub probe_force: f64,
    /// Tangential (friction) force at the pusher along each contact's t = (−n_y, n_x),
    /// summed over its discs, part weights.
    pub probe_friction: f64,
    /// Whether a pusher contact slides (its σ > 0).
    pub probe_sliding: bool,
    /// Largest penetration of the peg into a wall after the step, µm (≥ 0).
    pub penetration_um: f64,
    /// Probe needle deflection (compliance × force) at the end of the step, µm.
    pub probe_deflection_um: f64,
    /// Sub-steps the step was split into (1 when the whole step was accepted).
    pub substeps: usize,
    /// LCP pivots used.
    pub pivots: usize,
    /// LCP solves of the step (Newton iterations of the exact support friction; 1 with the
    /// polygonal cone).
    pub newton_iterations: usize,
    /// Newton's method stalled and the step was solved with polygonal cones turned against
    /// the best iterate's slips (see `solve_aligned`).
    pub newton_fallback: bool,
}

/// The active set of the last solve of one problem shape, with the contacts it was for.
#[derive(Debug, Clone, Default)]
struct WarmStart {
    active: Vec<bool>,
    kinds: Vec<ContactKind>,
}

impl WarmStart {
    fn new(capacity: usize) -> Self {
        Self { active: Vec::with_capacity(capacity), kinds: Vec::with_capacity(16) }
    }
}

/// Contact mode after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Force, no relative sliding.
    Stick,
    /// Force and sliding.
    Slide,
}

/// Force or sliding speed below this counts as zero when reporting modes.
const ACTIVE_EPS: f64 = 1e-9;

/// The simulator: model, fixture, settings and reusable buffers.
#[derive(Debug)]
pub struct Simulator {
    model: Model,
    pusher: Pusher,
    /// Largest distance of a disc's rim from the pusher's reference point, µm: how far a
    /// turn of 1 rad moves a contact on the pusher.
    pusher_reach_um: f64,
    fixture: Fixture,
    settings: SimSettings,
    support_forces: [f64; N_SUPPORTS],
    cones: SupportCones,
    /// The last step's motion, the peg pose it ended at and the probe travel it took:
    /// Newton's first guess for a step that starts there (a replay's steps chain; any other
    /// step starts from the probe's displacement). Only the starting point: the answer is
    /// the same to `newton_tol`.
    newton_carry: Option<(Pose, [f64; 3], f64)>,
    z: Vec<f64>,
    char_len_um: f64,
    problem: StepProblem,
    solver: LcpSolver,
    contacts: Vec<(Contact, f64)>,
    scratch: Vec<Contact>,
    /// The last active sets, one per problem shape (polygonal cones, exact friction).
    warm: [WarmStart; 2],
    probe_speed_um_s: f64,
    /// Each support's sliding speed over the last steps, µm/s (speed-dependent friction).
    support_slip_um_s: [f64; N_SUPPORTS],
}

impl Simulator {
    /// Validates everything and sizes the buffers.
    pub fn new(model: Model, fixture: Fixture, settings: SimSettings) -> Result<Self, Error> {
        let mut settings = settings;
        if let Some(c) = model.effects.probe_compliance_um_per_weight {
            settings.probe_compliance_um = c;
        }
        settings.validate()?;
        fixture.validate()?;
        let support_forces = model.validate()?;
        let cones = SupportCones::new(settings.n_directions);
        let char_len_um = model.part.char_length_um();
        let pusher = model.pusher();
        // Sized for the pusher's discs and two walls; the buffers grow once if a step needs
        // more (sizing for the largest step up front cost a replay's setup a quarter MB of
        // zeroed pages, and a diagnosis sets up thousands).
        let n_contacts = pusher.discs.len() + 2;
        let capacity = Layout { n_contacts, n_directions: settings.n_directions }.n();
        let pusher_reach_um = pusher
            .discs
            .iter()
            .map(|d| d.center_um[0].hypot(d.center_um[1]) + d.radius_um)
            .fold(0.0, f64::max);
        Ok(Self {
            model,
            pusher,
            pusher_reach_um,
            fixture,
            settings,
            support_forces,
            cones,
            newton_carry: None,
            z: Vec::with_capacity(capacity),
            char_len_um,
            problem: StepProblem::default(),
            solver: LcpSolver::new(capacity, LcpSettings::default()),
            contacts: Vec::with_capacity(n_contacts),
            scratch: Vec::with_capacity(n_contacts),
            warm: [WarmStart::new(capacity), WarmStart::new(capacity)],
            probe_speed_um_s: 0.0,
            support_slip_um_s: [0.0; N_SUPPORTS],
        })
    }

    /// Forgets everything a replay carries from step to step (Newton's carried motion, the
    /// warm-start active sets, the supports' sliding speeds, the probe speed): the simulator
    /// then steps exactly as a new one with the same model, fixture and settings would, bit
    /// for bit, without validating and sizing everything again.
    pub fn reset(&mut self) {
        self.newton_carry = None;
        self.z.clear();
        for w in &mut self.warm {
            w.active.clear();
            w.kinds.clear();
        }
        self.probe_speed_um_s = 0.0;
        self.support_slip_um_s = [0.0; N_SUPPORTS];
    }

    /// Tells the simulator how fast the probe moves now, µm/s (used only by the
    /// speed-dependent friction effect, which turns each support's slip per µm of probe
    /// travel into a sliding speed; [`super::follow_path`] sets it per segment).
    pub fn set_probe_speed_um_s(&mut self, speed_um_s: f64) {
        self.probe_speed_um_s = speed_um_s;
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }
    /// The pusher.
    pub fn pusher(&self) -> &Pusher {
        &self.pusher
    }
    /// Largest distance of a disc's rim from the pusher's reference point, µm.
    pub fn pusher_reach_um(&self) -> f64 {
        self.pusher_reach_um
    }
    /// The fixture.
    pub fn fixture(&self) -> &Fixture {
        &self.fixture
    }
    /// The settings.
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }
    /// The needle's limit as a force, part weights: the model's deflection limit over the
    /// probe's compliance (infinite for a rigid probe, which never bends).
    pub fn probe_force_limit_weights(&self) -> f64 {
        self.model.probe_deflection_limit_um / self.settings.probe_compliance_um
    }

    /// Smallest gap between a pusher disc and the peg, µm (negative: penetration).
    pub fn probe_gap_um(&self, state: &SimState) -> f64 {
        let peg = self.model.part.polygon().transformed(&state.peg);
        self.pusher
            .discs_at(&state.pusher_pose())
            .map(|(c, r)| peg.signed_distance(&c) - r)
            .fold(f64::INFINITY, f64::min)
    }

    /// How far a pusher point can move when the pusher moves by `delta_um` and turns by
    /// `d_theta_rad`, µm (the travel that steps and margins are measured in).
    pub fn pusher_travel_um(&self, delta_um: Vec2, d_theta_rad: f64) -> f64 {
        delta_um.norm() + d_theta_rad.abs() * self.pusher_reach_um
    }

    /// Advances the probe by `delta_um` and moves the peg quasi-statically. A step whose peg
    /// motion would carry a vertex further than the contact margin, or end with the peg in a
    /// wall beyond the penetration tolerance, is split in halves (at most 2^8 pieces), so fast
    /// rotations near a pivot cannot tunnel. On failure the state is left unchanged.
    pub fn step(&mut self, state: &mut SimState, delta_um: Vec2) -> Result<StepInfo, Error> {
        self.step_turning(state, delta_um, 0.0)
    }

    /// As [`Simulator::step`], with the pusher also turning by `d_theta_rad` about its
    /// reference point.
    pub fn step_turning(
        &mut self,
        state: &mut SimState,
        delta_um: Vec2,
        d_theta_rad: f64,
    ) -> Result<StepInfo, Error> {
        let start = *state;
        let mut info = StepInfo::default();
        match self.step_split(state, (delta_um, d_theta_rad), 0, &mut info) {
            Ok(()) => Ok(info),
            Err(e) => {
                *state = start;
                Err(e)
            }
        }
    }

    fn step_split(
        &mut self,
        state: &mut SimState,
        delta: (Vec2, f64),
        depth: u32,
        acc: &mut StepInfo,
    ) -> Result<(), Error> {
        const MAX_DEPTH: u32 = 8;
        let before = *state;
        let info = self.solve_step(state, delta)?;
        let moved = self.max_vertex_motion_um(&before.peg, &state.peg);
        let pen = self.wall_penetration_um(&state.peg);
        let bad = moved > self.settings.contact_margin_um || pen > self.settings.penetration_tol_um;
        if bad {
            *state = before;
            if depth == MAX_DEPTH {
                return Err(Error::Stuck(format!(
                    "even a {:.4} µm probe step moves a peg vertex {moved:.1} µm (wall \
                     penetration {pen:.1} µm): the peg is wedged and cannot follow the probe",
                    self.pusher_travel_um(delta.0, delta.1)
                )));
            }
            let half = (delta.0 / 2.0, delta.1 / 2.0);
            self.step_split(state, half, depth + 1, acc)?;
            return self.step_split(state, half, depth + 1, acc);
        }
        acc.solved_lcp |= info.solved_lcp;
        acc.pivots += info.pivots;
        acc.newton_iterations += info.newton_iterations;
        acc.newton_fallback |= info.newton_fallback;
        acc.substeps += 1;
        acc.penetration_um = acc.penetration_um.max(pen);
        acc.active = info.active;
        acc.probe_force = info.probe_force;
        acc.probe_friction = info.probe_friction;
        acc.probe_sliding = info.probe_sliding;
        acc.probe_deflection_um = info.probe_force * self.settings.probe_compliance_um;
        Ok(())
    }

    /// Largest displacement of a peg vertex between two poses, µm.
    fn max_vertex_motion_um(&self, a: &Pose, b: &Pose) -> f64 {
        // `Pose::transform_point`'s arithmetic, each rotation built once instead of per vertex.
        let (ra, rb) = (Rotation2::new(a.theta_rad), Rotation2::new(b.theta_rad));
        let (pa, pb) = (a.position(), b.position());
        let poly = self.model.part.polygon();
        poly.vertices().iter().map(|v| ((ra * v + pa) - (rb * v + pb)).norm()).fold(0.0, f64::max)
    }

    /// Deepest penetration of the peg (at `pose`) into any wall, µm (0 when clear).
    pub fn wall_penetration_um(&mut self, pose: &Pose) -> f64 {
        if self.fixture.walls.is_empty() {
            // An open plate (what diagnosis replays on): no wall to place the peg against.
            return 0.0;
        }
        let peg = self.model.part.polygon().transformed(pose);
        self.scratch.clear();
        wall_contacts(&peg, &self.fixture.walls, 0.0, &mut self.scratch);
        self.scratch.iter().map(|c| -c.gap_um).fold(0.0, f64::max)
    }

    /// Surface friction at each support now (the model's, changed by the friction patch
    /// and speed-dependent friction effects when they are on; speed friction uses each
    /// support's own sliding speed, from the steps before).
    fn surface_friction(&self, peg: &mesopush_core::geom::Pose) -> [f64; 3] {
        let mut mu = self.model.support.mu_surface;
        let fx = &self.model.effects;
        if let Some(patch) = &fx.friction_patch {
            for (m, p) in mu.iter_mut().zip(self.model.support.points()) {
                let w = peg.transform_point(&p);
                if patch.contains([w.x, w.y]) {
                    *m = patch.mu_surface;
                }
            }
        }
        if let Some(sf) = &fx.speed_friction {
            for (m, v) in mu.iter_mut().zip(self.support_slip_um_s) {
                *m *= sf.factor(v);
            }
        }
        mu
    }
}

impl Simulator {
    /// Updates each support's sliding speed from the step's peg motion `[dx, dy, dθ]`
    /// (supports at `supports` from the COM) over `travel_um` of probe travel at the probe's
    /// speed; half the old value is kept, so the friction it sets cannot flip step to step.
    fn track_support_slip(&mut self, supports: &[Vec2; N_SUPPORTS], d: [f64; 3], travel_um: f64) {
        if travel_um <= 0.0 {
            return;
        }
        for (v, r) in self.support_slip_um_s.iter_mut().zip(supports) {
            let slip = Vec2::new(d[0] - d[2] * r.y, d[1] + d[2] * r.x).norm();
            *v = 0.5 * *v + 0.5 * slip / travel_um * self.probe_speed_um_s;
        }
    }
}

/// Short label of a contact for CSV columns, e.g. `probe`, `wall2v` (peg vertex on wall 2).
pub fn contact_label(kind: ContactKind) -> String {
    match kind {
        ContactKind::Probe(0) => "probe".into(),
        ContactKind::Probe(k) => format!("probe{k}"),
        ContactKind::Wall { wall, peg_vertex: true } => format!("wall{wall}v"),
        ContactKind::Wall { wall, peg_vertex: false } => format!("wall{wall}e"),
    }
}
