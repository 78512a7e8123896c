//! One quasi-static time step: find the contacts, build the mixed LCP, solve it and move the
//! peg. The probe is position-controlled; the peg moves only through its contacts.

mod solve;

use super::cone::SupportCones;
use super::contact::{Contact, ContactKind, probe_contact, wall_contacts};
use super::fixture::Fixture;
use super::formulate::{Layout, N_SUPPORTS, StepProblem};
use super::model::Model;
use super::settings::SimSettings;
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_lcp::{LcpSettings, LcpSolver};

/// The simulated world's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimState {
    /// Peg pose.
    pub peg: Pose,
    /// Probe tip centre, µm.
    pub probe_um: Vec2,
}

/// What one step found (for trajectories and diagnostics).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepInfo {
    /// Whether an LCP was solved (false: the probe was clear of the peg).
    pub solved_lcp: bool,
    /// Contacts carrying force after the step, with their mode, e.g. `probe:stick`.
    pub active: Vec<(ContactKind, Mode)>,
    /// Normal force at the probe, in units of the part's weight.
    pub probe_force: f64,
    /// Tangential (friction) force at the probe along t = (−n_y, n_x), part weights.
    pub probe_friction: f64,
    /// Whether the probe contact slides (its σ > 0).
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
        let support_forces = model.validate()?;
        let cones = SupportCones::new(settings.n_directions);
        let char_len_um = model.part.char_length_um();
        let capacity = Layout { n_contacts: 16, n_directions: settings.n_directions }.n();
        Ok(Self {
            model,
            fixture,
            settings,
            support_forces,
            cones,
            newton_carry: None,
            z: Vec::with_capacity(capacity),
            char_len_um,
            problem: StepProblem::default(),
            solver: LcpSolver::new(capacity, LcpSettings::default()),
            contacts: Vec::with_capacity(16),
            scratch: Vec::with_capacity(16),
            warm: [WarmStart::new(capacity), WarmStart::new(capacity)],
            probe_speed_um_s: 0.0,
            support_slip_um_s: [0.0; N_SUPPORTS],
        })
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
    /// The fixture.
    pub fn fixture(&self) -> &Fixture {
        &self.fixture
    }
    /// The settings.
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }

    /// Gap between the probe disc and the peg, µm (negative: penetration).
    pub fn probe_gap_um(&self, state: &SimState) -> f64 {
        let peg = self.model.part.polygon().transformed(&state.peg);
        peg.signed_distance(&state.probe_um) - self.model.probe_radius_um
    }

    /// Advances the probe by `delta_um` and moves the peg quasi-statically. A step whose peg
    /// motion would carry a vertex further than the contact margin, or end with the peg in a
    /// wall beyond the penetration tolerance, is split in halves (at most 2^8 pieces), so fast
    /// rotations near a pivot cannot tunnel. On failure the state is left unchanged.
    pub fn step(&mut self, state: &mut SimState, delta_um: Vec2) -> Result<StepInfo, Error> {
        let start = *state;
        let mut info = StepInfo::default();
        match self.step_split(state, delta_um, 0, &mut info) {
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
        delta_um: Vec2,
        depth: u32,
        acc: &mut StepInfo,
    ) -> Result<(), Error> {
        const MAX_DEPTH: u32 = 8;
        let before = *state;
        let info = self.solve_step(state, delta_um)?;
        let moved = self.max_vertex_motion_um(&before.peg, &state.peg);
        let pen = self.wall_penetration_um(&state.peg);
        let bad = moved > self.settings.contact_margin_um || pen > self.settings.penetration_tol_um;
        if bad {
            *state = before;
            if depth == MAX_DEPTH {
                return Err(Error::Stuck(format!(
                    "even a {:.4} µm probe step moves a peg vertex {moved:.1} µm (wall \
                     penetration {pen:.1} µm): the peg is wedged and cannot follow the probe",
                    delta_um.norm()
                )));
            }
            self.step_split(state, delta_um / 2.0, depth + 1, acc)?;
            return self.step_split(state, delta_um / 2.0, depth + 1, acc);
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
        let poly = self.model.part.polygon();
        poly.vertices()
            .iter()
            .map(|v| (a.transform_point(v) - b.transform_point(v)).norm())
            .fold(0.0, f64::max)
    }

    /// Deepest penetration of the peg (at `pose`) into any wall, µm (0 when clear).
    pub fn wall_penetration_um(&mut self, pose: &Pose) -> f64 {
        let peg = self.model.part.polygon().transformed(pose);
        self.scratch.clear();
        wall_contacts(&peg, &self.fixture.walls, 0.0, &mut self.scratch);
        self.scratch.iter().map(|c| -c.gap_um).fold(0.0, f64::max)
    }

    /// One step without splitting. With adhesion on, a probe retracting from a peg it
    /// touches first tries to drag the peg (the contact mirrored, pulling); the drag holds
    /// when it needs no more than the pull-off force.
    fn solve_step(&mut self, state: &mut SimState, delta_um: Vec2) -> Result<StepInfo, Error> {
        let peg = self.model.part.polygon().transformed(&state.peg);
        let margin = self.settings.contact_margin_um + delta_um.norm();
        let r = self.model.probe_radius_um;
        let Some(probe) = probe_contact(&peg, &state.probe_um, r, margin) else {
            self.support_slip_um_s = [0.0; N_SUPPORTS];
            state.probe_um += delta_um;
            return Ok(StepInfo::default());
        };
        if let Some(a) = self.model.effects.adhesion
            && probe.gap_um <= a.range_um
            && probe.normal.dot(&delta_um) < 0.0
        {
            let before = *state;
            let pull = Contact { normal: -probe.normal, gap_um: 0.0, ..probe };
            match self.solve_contacts(state, &peg, pull, delta_um, margin) {
                Ok(info) if info.probe_force <= a.pull_off_weight => return Ok(info),
                _ => *state = before,
            }
        }
        self.solve_contacts(state, &peg, probe, delta_um, margin)
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

    /// Solves one step with the probe contact `probe` and the walls near `peg`.
    fn solve_contacts(
        &mut self,
        state: &mut SimState,
        peg: &mesopush_core::geom::ConvexPolygon,
        probe: Contact,
        delta_um: Vec2,
        margin: f64,
    ) -> Result<StepInfo, Error> {
        let mut info = StepInfo::default();
        self.contacts.clear();
        self.contacts.push((probe, self.model.mu_probe));
        self.scratch.clear();
        wall_contacts(peg, &self.fixture.walls, margin, &mut self.scratch);
        self.contacts.extend(self.scratch.iter().map(|c| (*c, self.model.mu_wall)));
        let supports = self.model.support.points().map(|p| state.peg.rotate(&p));
        let lay = self.solve_aligned(state, &supports, delta_um, &mut info)?;
        let z = &self.z;
        info.solved_lcp = true;
        info.probe_force = z[lay.normal(0)];
        info.probe_friction = z[lay.planar_friction(0, 0)] - z[lay.planar_friction(0, 1)];
        info.probe_sliding = z[lay.planar_sigma(0)] > ACTIVE_EPS;
        for (i, (c, _)) in self.contacts.iter().enumerate() {
            if z[lay.normal(i)] > ACTIVE_EPS {
                let mode =
                    if z[lay.planar_sigma(i)] > ACTIVE_EPS { Mode::Slide } else { Mode::Stick };
                info.active.push((c.kind, mode));
            }
        }
        let dz = [z[0], z[1], z[2] / self.char_len_um];
        if self.model.effects.speed_friction.is_some() {
            self.track_support_slip(&supports, dz, delta_um.norm());
        }
        state.peg.x_um += dz[0];
        state.peg.y_um += dz[1];
        state.peg.theta_rad += dz[2];
        state.probe_um += delta_um;
        Ok(info)
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
        ContactKind::Probe => "probe".into(),
        ContactKind::Wall { wall, peg_vertex: true } => format!("wall{wall}v"),
        ContactKind::Wall { wall, peg_vertex: false } => format!("wall{wall}e"),
    }
}
