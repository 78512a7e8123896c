//! The effects the generator can put into a batch, in its own parametrisation (stated in
//! docs/independent-generator.md), at fixed standard sizes; the random parts (a sign, a
//! phase) are drawn from the batch's seed. Where each acts: [`super::stage`] (backlash, lead
//! screw), [`super::physics`] (stripe, adhesion, speed friction, drift), [`super::camera`]
//! (latency, scale).

use super::Error;
use super::rng::Rng;
use serde_json::{Value, json};

/// One effect and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Effect {
    /// Nothing beyond exact Coulomb friction and camera noise.
    Clean,
    /// Lost motion of the stage, a play of full width `deadband_um` per axis.
    Backlash {
        /// Full width per axis, µm.
        deadband_um: [f64; 2],
    },
    /// Each frame shows the world `delay_s` before its stamp.
    Latency {
        /// s.
        delay_s: f64,
    },
    /// The image is stretched about `origin_um` by `1 + gain` per axis (peg and tip).
    Scale {
        /// Relative error per axis.
        gain: [f64; 2],
        /// Fixed point of the stretch, µm.
        origin_um: [f64; 2],
    },
    /// Supports whose world x lies in `[x_from_um, x_to_um]` have `factor ×` the friction.
    Stripe {
        /// Band start, µm.
        x_from_um: f64,
        /// Band end, µm.
        x_to_um: f64,
        /// Friction multiplier inside.
        factor: f64,
    },
    /// An elastic bond between the needle and a part it touched: force
    /// `pull_off_weight · gap / range_um`, broken beyond `range_um`.
    Adhesion {
        /// Bond force at break, part weights.
        pull_off_weight: f64,
        /// Gap at break, µm.
        range_um: f64,
    },
    /// Every support's μ(v) = μ (1 + gain · v), v its own sliding speed.
    SpeedFriction {
        /// Per µm/s.
        gain_per_um_s: f64,
    },
    /// Trial k's supports are moved by `k · per_trial_um` (body frame), loads re-balanced.
    Drift {
        /// µm per trial.
        per_trial_um: [f64; 2],
    },
    /// The stage's x is off by `amplitude_um · sin(2π x_cmd / pitch_um + phase_rad)`.
    LeadScrew {
        /// Screw pitch, µm.
        pitch_um: f64,
        /// Error amplitude, µm.
        amplitude_um: f64,
        /// Phase, rad.
        phase_rad: f64,
    },
}

/// Every effect name, `clean` first.
pub const EFFECT_NAMES: [&str; 9] = [
    "clean",
    "backlash",
    "latency",
    "scale",
    "stripe",
    "adhesion",
    "speed_friction",
    "drift",
    "leadscrew",
];

impl Effect {
    /// The effect `name` at its standard size; signs and phases drawn from `rng`.
    pub fn standard(name: &str, rng: &mut Rng) -> Result<Self, Error> {
        Ok(match name {
            "clean" => Effect::Clean,
            "backlash" => Effect::Backlash { deadband_um: [12.0, 12.0] },
            "latency" => Effect::Latency { delay_s: 0.070 },
            "scale" => Effect::Scale { gain: [0.02, 0.0], origin_um: [0.0, 0.0] },
            "stripe" => Effect::Stripe { x_from_um: 3150.0, x_to_um: 4350.0, factor: 2.5 },
            "adhesion" => Effect::Adhesion { pull_off_weight: 0.3, range_um: 5.0 },
            "speed_friction" => Effect::SpeedFriction { gain_per_um_s: 0.002 },
            "drift" => Effect::Drift { per_trial_um: [rng.sign() * 15.0, 0.0] },
            "leadscrew" => Effect::LeadScrew {
                pitch_um: 1000.0,
                amplitude_um: 8.0,
                phase_rad: rng.range(0.0, std::f64::consts::TAU),
            },
            other => {
                return Err(Error::invalid(
                    "effect",
                    format!("{other:?} is not an effect; known: {}", EFFECT_NAMES.join(", ")),
                ));
            }
        })
    }

    /// The effect's name (one of [`EFFECT_NAMES`]).
    pub fn name(&self) -> &'static str {
        match self {
            Effect::Clean => "clean",
            Effect::Backlash { .. } => "backlash",
            Effect::Latency { .. } => "latency",
            Effect::Scale { .. } => "scale",
            Effect::Stripe { .. } => "stripe",
            Effect::Adhesion { .. } => "adhesion",
            Effect::SpeedFriction { .. } => "speed_friction",
            Effect::Drift { .. } => "drift",
            Effect::LeadScrew { .. } => "leadscrew",
        }
    }

    /// Whether the project's effect library has a counterpart (the lead screw has none).
    pub fn in_project_library(&self) -> bool {
        !matches!(self, Effect::LeadScrew { .. } | Effect::Clean)
    }

    /// The parameters as JSON (for trial.json's `world` and the manifest).
    pub fn to_json(&self) -> Value {
        let params = match *self {
            Effect::Clean => json!({}),
            Effect::Backlash { deadband_um } => json!({ "deadband_um": deadband_um }),
            Effect::Latency { delay_s } => json!({ "delay_s": delay_s }),
            Effect::Scale { gain, origin_um } => json!({ "gain": gain, "origin_um": origin_um }),
            Effect::Stripe { x_from_um, x_to_um, factor } => {
                json!({ "x_from_um": x_from_um, "x_to_um": x_to_um, "factor": factor })
            }
            Effect::Adhesion { pull_off_weight, range_um } => {
                json!({ "pull_off_weight": pull_off_weight, "range_um": range_um })
            }
            Effect::SpeedFriction { gain_per_um_s } => json!({ "gain_per_um_s": gain_per_um_s }),
            Effect::Drift { per_trial_um } => json!({ "per_trial_um": per_trial_um }),
            Effect::LeadScrew { pitch_um, amplitude_um, phase_rad } => json!({
                "pitch_um": pitch_um, "amplitude_um": amplitude_um, "phase_rad": phase_rad
            }),
        };
        json!({ "name": self.name(), "params": params, "in_project_library": self.in_project_library() })
    }
}
