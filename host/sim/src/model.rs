//! The physical model the simulator runs: the part's shape, its support distribution and the
//! friction coefficients. Loaded from and saved to a model TOML (identification writes one,
//! `sim`, `plan` and `robustness` read one).

use super::support::SupportDistribution;
use crate::Error;
use crate::effects::Effects;
use crate::pusher::Pusher;
use mesopush_core::check::{Allowed, all_finite_in, finite_in};
use mesopush_core::geom::{ConvexPolygon, Vec2};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Length of the default peg, µm (the paper's typical 1615 × 985 µm peg).
pub const PEG_LENGTH_UM: f64 = 1615.0;
/// Width of the default peg, µm.
pub const PEG_WIDTH_UM: f64 = 985.0;

/// Default needle deflection limit, µm ([`Model::probe_deflection_limit_um`]; why 50 is
/// explained there). The one statement of the default: the model's serde default, the
/// simulator's overload verdict and the rig's jam log and controller all read it through
/// the model.
pub const DEFAULT_PROBE_DEFLECTION_LIMIT_UM: f64 = 50.0;

/// Largest needle deflection limit a model may set, µm (the part vertices' range).
pub const MAX_PROBE_DEFLECTION_LIMIT_UM: f64 = 1e5;

/// A rigid planar part: a convex polygon in its body frame with the centre of mass at the
/// origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PartSpec", into = "PartSpec")]
pub struct Part {
    polygon: ConvexPolygon,
}

/// On-disk form of a part: vertices in any frame, and optionally where the COM is (default:
/// the area centroid, i.e. a uniform plate).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartSpec {
    vertices_um: Vec<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    com_um: Option<[f64; 2]>,
}

impl TryFrom<PartSpec> for Part {
    type Error = Error;
    fn try_from(spec: PartSpec) -> Result<Self, Error> {
        let poly = ConvexPolygon::try_from(spec.vertices_um)?;
        let com = spec.com_um.map_or_else(|| poly.centroid(), |[x, y]| Vec2::new(x, y));
        if !poly.contains(&com, 0.0) {
            return Err(Error::invalid("part", "com_um lies outside the part"));
        }
        Ok(Part { polygon: poly.translated(&-com) })
    }
}

impl From<Part> for PartSpec {
    fn from(p: Part) -> Self {
        PartSpec { vertices_um: p.polygon.into(), com_um: None }
    }
}

impl Part {
    /// A part whose COM is the polygon's area centroid.
    pub fn from_polygon(polygon: &ConvexPolygon) -> Self {
        Part { polygon: polygon.translated(&-polygon.centroid()) }
    }

    /// The paper's default peg, 1615 × 985 µm, long axis along body x.
    pub fn default_peg() -> Self {
        Part::from_polygon(
            &ConvexPolygon::rectangle(PEG_LENGTH_UM, PEG_WIDTH_UM).expect("constant rectangle"),
        )
    }

    /// The outline in the body frame (COM at the origin).
    pub fn polygon(&self) -> &ConvexPolygon {
        &self.polygon
    }

    /// A characteristic length (the largest vertex radius), µm; scales rotations to lengths.
    pub fn char_length_um(&self) -> f64 {
        self.polygon.vertices().iter().map(|v| v.norm()).fold(0.0, f64::max)
    }
}

/// Everything the simulator needs to know about the physics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// The pushed part.
    pub part: Part,
    /// Three-point support distribution and surface friction.
    pub support: SupportDistribution,
    /// Probe–part friction coefficient. Default 0.8 (the paper's choice).
    pub mu_probe: f64,
    /// Part–fixture friction coefficient. Default 0.25.
    pub mu_wall: f64,
    /// Probe tip radius, µm (0 allowed). Default 12.5 (a 25 µm tip). The pusher is one
    /// disc of this radius unless `pusher` is given.
    pub probe_radius_um: f64,
    /// The pusher's discs (`[[pusher.discs]]`; [`crate::pusher`]), when it is not the
    /// single disc of `probe_radius_um` (a two-finger hand, say). Absent: one disc.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pusher: Option<Pusher>,
    /// How far the needle may bend, µm: the largest probe deflection (the simulator's
    /// compliance × contact force, `probe_compliance_um` in [`crate::SimSettings`] or the
    /// `probe_compliance_um_per_weight` effect) a plan may cause. A replay that exceeds it
    /// is *overloaded* ([`crate::needle`]): never inserted, refused by `plan`, a failure in
    /// `robustness`; the rig's world logs a jam beyond it and its controller faults
    /// (`NeedleOverload`). As a force: limit / compliance part weights (100 at the default
    /// 0.5 µm per weight); a rigid probe (compliance 0) never bends, so nothing binds.
    /// Allowed (0, 1e5] µm. Default [`DEFAULT_PROBE_DEFLECTION_LIMIT_UM`] = 50.
    ///
    /// Why 50 µm for the paper's 25 µm tungsten needle: the acrylic peg (1615 × 985 µm,
    /// half the 3.175 mm fixture's thickness, 1.19 g/cm³) weighs 3.0 mg, 29.5 µN, and the
    /// simulator's 0.5 µm of deflection per part weight is the compliance L³/(3EI) of a
    /// 25 µm tungsten cylinder (E = 411 GPa) 0.74 mm long — the slender end of an etched
    /// probe. Such a tip reaches the yield stress of drawn tungsten wire (≈ 1.5 GPa; its
    /// tensile strength is 2–4 GPa) at a tip deflection of (2/3)(σ/E)L²/d ≈ 53 µm, under
    /// F = σπd³/(32L) ≈ 3.1 mN ≈ 105 part weights. Beyond that the needle bends for good
    /// (and a plan that counts on hundreds of part weights pushes through a bent tip); 50
    /// µm keeps it elastic. A stiffer or longer probe: set it from its own beam numbers.
    #[serde(default = "default_probe_deflection_limit_um")]
    pub probe_deflection_limit_um: f64,
    /// Effects beyond the nominal model (`[effects]` table; see [`crate::effects`]). Absent
    /// from a TOML = all off, and then results are bit-identical to the nominal model's.
    #[serde(default, skip_serializing_if = "Effects::is_none")]
    pub effects: Effects,
}

fn default_probe_deflection_limit_um() -> f64 {
    DEFAULT_PROBE_DEFLECTION_LIMIT_UM
}

impl Default for Model {
    fn default() -> Self {
        Self {
            part: Part::default_peg(),
            // The nominal support found with the fixture reconstruction (docs/fixture.md).
            support: SupportDistribution {
                points_um: [[-250.0, 440.0], [50.0, -330.0], [250.0, 60.0]],
                mu_surface: [0.3; 3],
            },
            mu_probe: 0.8,
            mu_wall: 0.25,
            probe_radius_um: 12.5,
            pusher: None,
            probe_deflection_limit_um: DEFAULT_PROBE_DEFLECTION_LIMIT_UM,
            effects: Effects::default(),
        }
    }
}

impl Model {
    /// Checks every field; returns the support normal forces (weights) on success.
    pub fn validate(&self) -> Result<[f64; 3], Error> {
        for (name, v) in [("mu_probe", self.mu_probe), ("mu_wall", self.mu_wall)] {
            if !(v.is_finite() && (0.0..=2.0).contains(&v)) {
                return Err(Error::invalid("model", format!("{name} = {v} must be within [0, 2]")));
            }
        }
        let r = self.probe_radius_um;
        if !(r.is_finite() && r >= 0.0) {
            return Err(Error::invalid(
                "model",
                format!("probe_radius_um = {r} must be finite and ≥ 0"),
            ));
        }
        for (k, v) in self.part.polygon().vertices().iter().enumerate() {
            let field = format!("model part vertex {k} (about the COM)");
            all_finite_in(&field, &[v.x, v.y], Allowed::closed(-1e5, 1e5, "µm"))?;
        }
        finite_in("model probe_radius_um", r, Allowed::closed(0.0, 1e4, "µm"))?;
        finite_in(
            "model probe_deflection_limit_um",
            self.probe_deflection_limit_um,
            Allowed::positive_to(MAX_PROBE_DEFLECTION_LIMIT_UM, "µm"),
        )?;
        if let Some(p) = &self.pusher {
            p.validate()?;
        }
        self.effects.validate()?;
        self.support.validate(self.part.polygon())
    }

    /// The pusher the simulator moves: `pusher`, else one disc of `probe_radius_um`.
    pub fn pusher(&self) -> Pusher {
        self.pusher.clone().unwrap_or_else(|| Pusher::single(self.probe_radius_um))
    }

    /// Loads and validates a model TOML.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let model: Model = toml::from_str(&text)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        model.validate().map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        Ok(model)
    }

    /// Writes the model as TOML.
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        let text = toml::to_string_pretty(self)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        std::fs::write(path, text).map_err(|e| Error::io(path, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_model_is_valid_and_round_trips_through_toml() {
        let m = Model::default();
        m.validate().unwrap();
        let text = toml::to_string_pretty(&m).unwrap();
        let back: Model = toml::from_str(&text).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn part_is_recentred_on_its_centroid() {
        let spec = "vertices_um = [[0,0],[200,0],[300,100],[200,200],[0,200]]";
        let part: Part = toml::from_str(spec).unwrap();
        assert!(part.polygon().centroid().norm() < 1e-9);
    }

    /// A needle limit of zero, below zero or not a number would make every push (or none)
    /// an overload: validation refuses it, naming the field, the value and the range.
    #[test]
    fn a_needle_limit_outside_its_range_is_refused_by_name_value_and_range() {
        for (v, shown) in [(0.0, "= 0:"), (-5.0, "= -5:"), (f64::NAN, "= NaN:"), (2e5, "= 200000:")]
        {
            let m = Model { probe_deflection_limit_um: v, ..Model::default() };
            let e = m.validate().unwrap_err().to_string();
            assert!(e.contains("probe_deflection_limit_um"), "{v}: the field is named: {e}");
            assert!(e.contains(shown), "{v}: the value is named: {e}");
            assert!(e.contains("(0, 100000] µm"), "{v}: the range is named: {e}");
        }
        Model { probe_deflection_limit_um: 120.0, ..Model::default() }.validate().unwrap();
    }

    #[test]
    fn a_model_file_without_a_needle_limit_gets_fifty_micrometres() {
        let text = toml::to_string_pretty(&Model::default()).unwrap();
        assert!(text.contains("probe_deflection_limit_um = 50.0"), "written out: {text}");
        let without: String = text
            .lines()
            .filter(|l| !l.starts_with("probe_deflection_limit_um"))
            .map(|l| format!("{l}\n"))
            .collect();
        let m: Model = toml::from_str(&without).unwrap();
        assert_eq!(m.probe_deflection_limit_um, 50.0);
    }

    #[test]
    fn bad_friction_is_named() {
        let m = Model { mu_probe: -0.1, ..Model::default() };
        assert!(m.validate().unwrap_err().to_string().contains("mu_probe"));
    }
}
