//! Plain-data settings of the quasi-static simulator, with documented defaults and units.

use serde::{Deserialize, Serialize};

/// How the simulator discretises and tolerates (see each field for its unit and default).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimSettings {
    /// Probe travel per time step while the probe is near the peg, µm. Default 5.
    pub step_um: f64,
    /// Number of directions of the linearised friction cone at each support (the paper's
    /// n_d). Default 8.
    pub n_directions: usize,
    /// Friction at the supports: `coulomb` (default), the circular cone solved exactly by
    /// Newton's method (`coulomb` module); or `polygon`, the paper's `n_directions` force
    /// directions in the part's body frame (`cone` module).
    pub support_friction: SupportFriction,
    /// Slip speed regularisation of the exact friction, as a fraction of `step_um`: a
    /// support creeps at most this far per step where Coulomb says it sticks. Default 1e-3.
    pub slip_regularisation: f64,
    /// Newton's method stops when the part's motion changes by less than this fraction of
    /// `step_um` (µm, and µm at the characteristic length for rotation). Default 1e-9.
    pub newton_tol: f64,
    /// Newton iterations allowed per step before the step fails. Default 50.
    pub newton_iterations: usize,
    /// Contacts whose gap is below this enter the step's problem ahead of touching, µm
    /// (Stewart–Trinkle style, so fast approach never tunnels). Default 30.
    pub contact_margin_um: f64,
    /// Penetration that counts as a violation when checked after each step, µm. Default 1.
    pub penetration_tol_um: f64,
    /// How far a recorded pusher may start inside the part, as a fraction of the part's size
    /// (its largest vertex distance from the COM): a replay moves the part clear first
    /// (registration error of the recording); deeper is refused. Default 0.02 (19 µm for
    /// the paper's peg, 0.6 mm for a 50 × 35 mm block).
    pub registration_tol: f64,
    /// Upper bound on time steps for one plan replay (a bounded loop). Default 200 000.
    pub max_steps: usize,
    /// Viscous regularisation of the support friction: drag, in part weights, of a support
    /// point moving as fast as the probe. Makes the quasi-static motion unique under the
    /// linearised friction cone (see `formulate`); small against μ. Default 0.005 (1.7 % of
    /// a μ = 0.3 surface friction). Scaled per step by 1/`step_um`, so halving the step does
    /// not change it.
    pub support_viscosity: f64,
    /// Compliance of the probe needle along the contact normal, µm of tip deflection per part
    /// weight of force. A real needle bends a little; with a perfectly rigid probe a peg
    /// wedged between probe and wall has no quasi-static solution. Default 0.5.
    pub probe_compliance_um: f64,
}

/// How the supports' friction cone is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SupportFriction {
    /// The circular Coulomb cone, exact (Newton's method on the step).
    Coulomb,
    /// The paper's polygonal cone with `n_directions` directions in the body frame.
    Polygon,
}

impl Default for SimSettings {
    fn default() -> Self {
        Self {
            step_um: 5.0,
            n_directions: 8,
            support_friction: SupportFriction::Coulomb,
            slip_regularisation: 1e-3,
            newton_tol: 1e-9,
            newton_iterations: 50,
            contact_margin_um: 30.0,
            penetration_tol_um: 1.0,
            registration_tol: 0.02,
            max_steps: 200_000,
            support_viscosity: 0.005,
            probe_compliance_um: 0.5,
        }
    }
}

impl SimSettings {
    /// These settings for a part of `part`'s size: the lengths (`step_um`,
    /// `contact_margin_um`, `penetration_tol_um`, `probe_compliance_um`) multiplied by the
    /// part's characteristic length over the paper's peg's (945.8 µm), so the defaults,
    /// chosen for the peg, keep their meaning relative to any part (a 50 mm block steps
    /// 0.16 mm). The peg gets exactly these settings back.
    pub fn scaled_to(mut self, part: &crate::Part) -> Self {
        let k = part.char_length_um() / crate::Part::default_peg().char_length_um();
        if k != 1.0 {
            self.step_um *= k;
            self.contact_margin_um *= k;
            self.penetration_tol_um *= k;
            self.probe_compliance_um *= k;
        }
        self
    }

    /// Checks every field; the error names the field and the rule.
    pub fn validate(&self) -> Result<(), crate::Error> {
        use crate::Error;
        if !(self.step_um.is_finite() && self.step_um > 0.0) {
            return Err(Error::invalid("step_um", format!("{} must be > 0 µm", self.step_um)));
        }
        if !(3..=64).contains(&self.n_directions) {
            return Err(Error::invalid("n_directions", "must be between 3 and 64"));
        }
        let e = self.slip_regularisation;
        if !(e.is_finite() && e > 0.0 && e <= 0.1) {
            return Err(Error::invalid("slip_regularisation", format!("{e} must be in (0, 0.1]")));
        }
        let t = self.newton_tol;
        if !(t.is_finite() && t > 0.0 && t <= 1e-3) {
            return Err(Error::invalid("newton_tol", format!("{t} must be in (0, 1e-3]")));
        }
        if !(1..=1000).contains(&self.newton_iterations) {
            return Err(Error::invalid("newton_iterations", "must be in 1..=1000"));
        }
        if !(self.contact_margin_um.is_finite() && self.contact_margin_um > 0.0) {
            return Err(Error::invalid("contact_margin_um", "must be > 0"));
        }
        if !(self.penetration_tol_um.is_finite() && self.penetration_tol_um > 0.0) {
            return Err(Error::invalid("penetration_tol_um", "must be > 0"));
        }
        let g = self.registration_tol;
        if !(g.is_finite() && (0.0..=0.5).contains(&g)) {
            return Err(Error::invalid("registration_tol", format!("{g} must be in [0, 0.5]")));
        }
        let v = self.support_viscosity;
        if !(v.is_finite() && (0.0..=0.1).contains(&v)) {
            return Err(Error::invalid("support_viscosity", "must be in [0, 0.1]"));
        }
        let c = self.probe_compliance_um;
        if !(c.is_finite() && c >= 0.0) {
            return Err(Error::invalid("probe_compliance_um", format!("{c} must be ≥ 0")));
        }
        if self.max_steps == 0 {
            return Err(Error::invalid("max_steps", "must be > 0"));
        }
        Ok(())
    }
}
