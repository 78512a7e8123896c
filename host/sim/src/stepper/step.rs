//! One step without splitting: gather the pusher's and the walls' contacts, solve, and move
//! the peg and the pusher.

use super::{ACTIVE_EPS, Mode, SimState, Simulator, StepInfo};
use crate::Error;
use crate::contact::{Contact, ContactKind, probe_contact, wall_contacts};
use crate::formulate::{N_SUPPORTS, PusherMotion};
use mesopush_core::geom::{ConvexPolygon, Vec2};
use nalgebra::Rotation2;

impl Simulator {
    /// One step without splitting: the pusher moves by `delta.0` and turns by `delta.1`.
    /// With adhesion on, a one-disc probe retracting from a peg it touches first tries to
    /// drag the peg (the contact mirrored, pulling, sliding along the edge against the
    /// bond's μ); the drag holds when it needs no more
    /// than the pull-off force.
    pub(super) fn solve_step(
        &mut self,
        state: &mut SimState,
        delta: (Vec2, f64),
    ) -> Result<StepInfo, Error> {
        let (delta_um, d_theta_rad) = delta;
        let peg = self.model.part.polygon().transformed(&state.peg);
        let margin = self.settings.contact_margin_um + self.pusher_travel_um(delta_um, d_theta_rad);
        let mut probes = [None; crate::pusher::MAX_DISCS];
        let mut touching = 0;
        for (k, (centre, r)) in self.pusher.discs_at(&state.pusher_pose()).enumerate() {
            probes[k] = probe_contact(&peg, k, &centre, r, margin);
            touching += usize::from(probes[k].is_some());
        }
        let motion = PusherMotion { origin_um: state.probe_um, d_um: delta_um, d_theta_rad };
        if touching == 0 {
            self.support_slip_um_s = [0.0; N_SUPPORTS];
            state.probe_um += delta_um;
            state.probe_theta_rad += d_theta_rad;
            return Ok(StepInfo::default());
        }
        if let (Some(a), [Some(probe)]) = (self.model.effects.adhesion, &probes[..1])
            && self.pusher.discs.len() == 1
            && probe.gap_um <= a.range_um
            && probe.normal.dot(&delta_um) < 0.0
        {
            let before = *state;
            let pull = Contact { normal: -probe.normal, gap_um: 0.0, ..*probe };
            let mu = a.mu_bond.unwrap_or(self.model.mu_probe);
            match self.solve_contacts(state, &peg, &[Some(pull)], mu, motion, margin) {
                Ok(info) if info.probe_force <= a.pull_off_weight => return Ok(info),
                _ => *state = before,
            }
        }
        self.solve_contacts(state, &peg, &probes, self.model.mu_probe, motion, margin)
    }

    /// Solves one step with the pusher contacts `probes` (friction coefficient `mu_probe`)
    /// and the walls near `peg`.
    fn solve_contacts(
        &mut self,
        state: &mut SimState,
        peg: &ConvexPolygon,
        probes: &[Option<Contact>],
        mu_probe: f64,
        motion: PusherMotion,
        margin: f64,
    ) -> Result<StepInfo, Error> {
        let mut info = StepInfo::default();
        self.contacts.clear();
        self.contacts.extend(probes.iter().flatten().map(|c| (*c, mu_probe)));
        let n_probes = self.contacts.len();
        self.scratch.clear();
        wall_contacts(peg, &self.fixture.walls, margin, &mut self.scratch);
        self.contacts.extend(self.scratch.iter().map(|c| (*c, self.model.mu_wall)));
        // `Pose::rotate`'s arithmetic, the rotation built once for the three supports.
        let rot = Rotation2::new(state.peg.theta_rad);
        let supports = self.model.support.points().map(|p| rot * p);
        let travel_um = self.pusher_travel_um(motion.d_um, motion.d_theta_rad);
        let lay = self.solve_aligned(state, &supports, motion, travel_um, &mut info)?;
        let z = &self.z;
        info.solved_lcp = true;
        for i in 0..n_probes {
            info.probe_force += z[lay.normal(i)];
            info.probe_friction += z[lay.planar_friction(i, 0)] - z[lay.planar_friction(i, 1)];
            info.probe_sliding |= z[lay.planar_sigma(i)] > ACTIVE_EPS;
        }
        for (i, (c, _)) in self.contacts.iter().enumerate() {
            if z[lay.normal(i)] > ACTIVE_EPS {
                let mode =
                    if z[lay.planar_sigma(i)] > ACTIVE_EPS { Mode::Slide } else { Mode::Stick };
                info.active.push((c.kind, mode));
            }
        }
        debug_assert!(
            self.contacts[..n_probes].iter().all(|(c, _)| matches!(c.kind, ContactKind::Probe(_)))
        );
        let dz = [z[0], z[1], z[2] / self.char_len_um];
        if self.model.effects.speed_friction.is_some() {
            self.track_support_slip(&supports, dz, travel_um);
        }
        state.peg.x_um += dz[0];
        state.peg.y_um += dz[1];
        state.peg.theta_rad += dz[2];
        state.probe_um += motion.d_um;
        state.probe_theta_rad += motion.d_theta_rad;
        Ok(info)
    }
}
