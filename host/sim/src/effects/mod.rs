//! The effect library: documented, parametric extensions of the nominal model, each one a
//! physical effect a real rig (or the firmware simulator's world) can carry and the host's
//! nominal model does not. Every effect is off by default; an [`Effects`] value with every
//! field at its default is the nominal model, bit for bit.
//!
//! Two kinds:
//! - *kinematic / measurement* effects act between the commanded and the true probe, or
//!   between the true scene and the measurement: stage backlash ([`Backlash`]), camera
//!   timestamp latency ([`stamp_with_latency_us`]), image scale and aspect error
//!   ([`apply_scale_error`]), probe compliance (tip deflection ∝ contact force);
//! - *physical* effects change the mechanics and live inside the simulator through
//!   [`crate::Model`]'s `effects` field: probe–peg adhesion, a friction patch on the
//!   plate, speed-dependent friction, and drift of the support distribution over a batch.
//!
//! Sizes and signatures are in `docs/effects.md`. Units are in every field's name.

pub mod primitives;

pub use primitives::{
    Backlash, BacklashAxis, apply_scale_error, remove_scale_error, scale_pose,
    stamp_with_latency_us,
};

use crate::Error;
use serde::{Deserialize, Serialize};

/// All library effects. Serialized as the `[effects]` table of a model TOML or a world file;
/// every field is optional and defaults to "off".
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Effects {
    /// Stage backlash (lost motion) per axis [x, y], µm: the full width of the deadband the
    /// stage drive must cross after a direction reversal before the tip moves again.
    /// `[0, 0]` = none. Realistic: 5–20 µm.
    pub backlash_um: [f64; 2],
    /// Camera timestamp latency, µs: a frame stamped at `t` was exposed at `t − latency`
    /// (stamp = capture + latency). 0 = none. Realistic: 30 000–100 000 µs.
    pub camera_latency_us: f64,
    /// Image scale error per axis [x, y] (dimensionless): a measured position is
    /// `origin + (true − origin)·(1 + err)`, for the peg and the imaged probe tip alike.
    /// Different x and y errors are an aspect error. `[0, 0]` = none. Realistic: 0.01–0.03.
    pub scale_error: [f64; 2],
    /// The point the scale error is about (the image origin), fixture frame, µm.
    /// Default `[0, 0]` (the fixture origin at the image's top-left corner).
    pub scale_origin_um: [f64; 2],
    /// Probe compliance, µm of tip deflection per part weight of contact force; when set it
    /// replaces the simulator's `probe_compliance_um` setting. `None` = the setting's value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probe_compliance_um_per_weight: Option<f64>,
    /// Probe–peg adhesion.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adhesion: Option<Adhesion>,
    /// A patch of the plate with another surface friction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub friction_patch: Option<FrictionPatch>,
    /// Speed-dependent surface friction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_friction: Option<SpeedFriction>,
    /// Drift of the support distribution over a batch of trials.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub support_drift: Option<SupportDrift>,
}

/// Probe–peg adhesion: while the probe touches the peg (gap below `range_um`) and retracts,
/// the contact can pull with up to `pull_off_weight`; if dragging the peg needs less than
/// that, the peg follows the probe, else the contact lets go.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adhesion {
    /// Largest pull the contact sustains, in part weights (comparable to the support
    /// friction μ ≈ 0.3 when it matters).
    pub pull_off_weight: f64,
    /// Gap below which the probe counts as stuck to the peg, µm. Default 2.
    #[serde(default = "default_adhesion_range")]
    pub range_um: f64,
    /// Friction coefficient of the pulling contact along the peg's edge: how hard the bond
    /// resists sliding while it drags (large: the bond sticks). Absent: the probe's μ
    /// (`mu_probe`), a pull that slides like a push.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu_bond: Option<f64>,
}

fn default_adhesion_range() -> f64 {
    2.0
}

/// A rectangle of the plate (fixture frame) where the peg–plate friction is `mu_surface`
/// instead of the model's: a support point inside it uses this coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionPatch {
    /// Lower corner [x, y], µm.
    pub min_um: [f64; 2],
    /// Upper corner [x, y], µm.
    pub max_um: [f64; 2],
    /// Surface friction coefficient inside.
    pub mu_surface: f64,
}

impl FrictionPatch {
    /// Whether a plate point lies in the patch.
    pub fn contains(&self, p_um: [f64; 2]) -> bool {
        (0..2).all(|k| p_um[k] >= self.min_um[k] && p_um[k] <= self.max_um[k])
    }
}

/// Speed-dependent surface friction: each support's μ(v) = μ·(1 + `gain_per_mm_s`·v/(1 mm/s)),
/// with v that support's own sliding speed on the plate (its slip per µm of probe travel in
/// the previous steps times the probe speed). A friction that changed alike at every support
/// would scale every support force by one factor and leave the quasi-static motion as it
/// was; friction that follows each contact's own slip is what changes it: a peg turning
/// about a point near one support drags its far supports faster, and they grip harder.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedFriction {
    /// Relative friction change per mm/s of probe speed (negative: velocity weakening).
    pub gain_per_mm_s: f64,
}

impl SpeedFriction {
    /// The factor multiplying μ at probe speed `speed_um_s` (never below 0.05).
    pub fn factor(&self, speed_um_s: f64) -> f64 {
        (1.0 + self.gain_per_mm_s * speed_um_s * 1e-3).max(0.05)
    }
}

/// Drift of the support distribution over a batch: trial `k` (0-based, in batch order) sees
/// its support points moved by `k · points_um_per_trial` and its surface friction changed by
/// `k · mu_surface_per_trial`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SupportDrift {
    /// Shift of every support point per trial, body frame, µm.
    pub points_um_per_trial: [f64; 2],
    /// Change of every support's surface friction per trial.
    pub mu_surface_per_trial: f64,
}

impl Effects {
    /// Whether every effect is off.
    pub fn is_none(&self) -> bool {
        *self == Effects::default()
    }

    /// Checks sizes and signs; the error names the field and the rule.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |what: &str, rule: &str| Err(Error::invalid("effects", format!("{what} {rule}")));
        if !self.backlash_um.iter().all(|b| b.is_finite() && (0.0..=1000.0).contains(b)) {
            return bad("backlash_um", "must be in [0, 1000] µm per axis");
        }
        if !(self.camera_latency_us.is_finite() && self.camera_latency_us.abs() <= 1e6) {
            return bad("camera_latency_us", "must be within ±1 s");
        }
        if !self.scale_error.iter().all(|s| s.is_finite() && s.abs() < 0.5) {
            return bad("scale_error", "must be within ±0.5 per axis");
        }
        if !self.scale_origin_um.iter().all(|s| s.is_finite()) {
            return bad("scale_origin_um", "must be finite");
        }
        if let Some(c) = self.probe_compliance_um_per_weight
            && !(c.is_finite() && (0.0..=1000.0).contains(&c))
        {
            return bad("probe_compliance_um_per_weight", "must be in [0, 1000]");
        }
        if let Some(a) = &self.adhesion
            && !(a.pull_off_weight.is_finite()
                && (0.0..=10.0).contains(&a.pull_off_weight)
                && a.range_um.is_finite()
                && (0.0..=100.0).contains(&a.range_um)
                && a.mu_bond.is_none_or(|m| m.is_finite() && (0.0..=100.0).contains(&m)))
        {
            return bad(
                "adhesion",
                "needs pull_off_weight in [0, 10], range_um in [0, 100] and mu_bond in [0, 100]",
            );
        }
        if let Some(p) = &self.friction_patch {
            let ok = (0..2).all(|k| p.min_um[k].is_finite() && p.max_um[k].is_finite())
                && (0..2).all(|k| p.min_um[k] <= p.max_um[k])
                && p.mu_surface.is_finite()
                && (0.0..=2.0).contains(&p.mu_surface);
            if !ok {
                return bad("friction_patch", "needs min_um ≤ max_um and mu_surface in [0, 2]");
            }
        }
        if let Some(s) = &self.speed_friction
            && !(s.gain_per_mm_s.is_finite() && s.gain_per_mm_s.abs() <= 100.0)
        {
            return bad("speed_friction", "gain_per_mm_s must be within ±100");
        }
        if let Some(d) = &self.support_drift {
            let ok = d.points_um_per_trial.iter().all(|v| v.is_finite())
                && d.mu_surface_per_trial.is_finite();
            if !ok {
                return bad("support_drift", "must be finite");
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_table_is_no_effect_and_round_trips() {
        let e: Effects = toml::from_str("").unwrap();
        assert!(e.is_none());
        let full = Effects {
            backlash_um: [10.0, 5.0],
            camera_latency_us: 50_000.0,
            scale_error: [0.02, -0.01],
            adhesion: Some(Adhesion { pull_off_weight: 0.3, range_um: 2.0, mu_bond: None }),
            friction_patch: Some(FrictionPatch {
                min_um: [0.0, 0.0],
                max_um: [1000.0, 800.0],
                mu_surface: 0.6,
            }),
            speed_friction: Some(SpeedFriction { gain_per_mm_s: 0.5 }),
            support_drift: Some(SupportDrift::default()),
            ..Effects::default()
        };
        full.validate().unwrap();
        let back: Effects = toml::from_str(&toml::to_string(&full).unwrap()).unwrap();
        assert_eq!(back, full);
    }

    #[test]
    fn bad_sizes_are_named() {
        let e = Effects { backlash_um: [-1.0, 0.0], ..Effects::default() };
        assert!(e.validate().unwrap_err().to_string().contains("backlash_um"));
        let e = Effects {
            adhesion: Some(Adhesion { pull_off_weight: f64::NAN, range_um: 1.0, mu_bond: None }),
            ..Effects::default()
        };
        assert!(e.validate().unwrap_err().to_string().contains("adhesion"));
    }
}
