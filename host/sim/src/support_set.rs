//! A set of plausible (probe friction, support) pairs: what identification writes (`identify
//! --consistent-out`: its bootstrap refits and the candidates that fit equally well) and what
//! robustness samples (`robustness --supports`). A pair is drawn whole, so the probe friction
//! and the support that fitted together stay together (a support far from the COM with a low
//! μ can explain the same pushes as a central one with a high μ; mixing them would not).
//!
//! File: TOML `[[support]]` tables (or JSON: an array, or `{"support": [...]}`), each
//! `points_um = [[x, y]; 3]` (µm, body frame, relative to the COM), `mu_surface = [μ1, μ2,
//! μ3]` and optionally `mu_probe` (absent: the model's, perturbed as the caller's uncertainty
//! says). Comment lines (`#`) carry how the set was made.

use crate::{Error, Part, SupportDistribution};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One plausible pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportSample {
    /// Probe–part friction fitted with this support (None: not given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu_probe: Option<f64>,
    /// Support points relative to the COM, body frame, µm.
    pub points_um: [[f64; 2]; 3],
    /// Surface friction at each support.
    pub mu_surface: [f64; 3],
}

impl SupportSample {
    /// A sample of `support` with probe friction `mu_probe`.
    pub fn new(mu_probe: Option<f64>, support: &SupportDistribution) -> Self {
        Self { mu_probe, points_um: support.points_um, mu_surface: support.mu_surface }
    }

    /// The support distribution.
    pub fn support(&self) -> SupportDistribution {
        SupportDistribution { points_um: self.points_um, mu_surface: self.mu_surface }
    }
}

/// A list of [`SupportSample`]s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportSet {
    /// The samples.
    pub support: Vec<SupportSample>,
}

impl SupportSet {
    /// Loads a set (`.json` as JSON, anything else as TOML) and validates every sample on
    /// `part`: the points inside it and spanning its COM, the frictions in [0, 2].
    pub fn load(path: &Path, part: &Part) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let parse = |m: String| Error::Parse { path: path.into(), message: m };
        let set: SupportSet = if path.extension().is_some_and(|e| e == "json") {
            serde_json::from_str::<Vec<SupportSample>>(&text)
                .map(|support| SupportSet { support })
                .or_else(|_| serde_json::from_str(&text))
                .map_err(|e| parse(e.to_string()))?
        } else {
            toml::from_str(&text).map_err(|e| parse(e.to_string()))?
        };
        if set.support.is_empty() {
            return Err(parse("the support set is empty (no [[support]] table)".into()));
        }
        for (i, s) in set.support.iter().enumerate() {
            s.check(part).map_err(|e| parse(format!("support {}: {e}", i + 1)))?;
        }
        Ok(set)
    }

    /// Writes the set as TOML after `header` (each of its lines written as a `#` comment).
    pub fn save(&self, path: &Path, header: &str) -> Result<(), Error> {
        let body = toml::to_string(self)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        let comments: String = header.lines().map(|l| format!("# {l}\n")).collect();
        std::fs::write(path, comments + &body).map_err(|e| Error::io(path, e))
    }
}

impl SupportSample {
    fn check(&self, part: &Part) -> Result<(), Error> {
        let in_range = |name: &'static str, v: f64| {
            if v.is_finite() && (0.0..=2.0).contains(&v) {
                Ok(())
            } else {
                Err(Error::invalid(name, format!("{v} is outside [0, 2]")))
            }
        };
        if let Some(mu) = self.mu_probe {
            in_range("mu_probe", mu)?;
        }
        for mu in self.mu_surface {
            in_range("mu_surface", mu)?;
        }
        self.support().validate(part.polygon()).map(|_| ())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_round_trips_and_a_bad_sample_is_named() {
        let part = Part::default_peg();
        let model = crate::Model::default();
        let set = SupportSet {
            support: vec![
                SupportSample::new(Some(0.7), &model.support),
                SupportSample::new(None, &model.support),
            ],
        };
        let dir = std::env::temp_dir().join(format!("mesopush-support-set-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("set.toml");
        set.save(&p, "made by a test\nsecond line").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("# made by a test\n# second line\n[[support]]"), "{text}");
        assert_eq!(SupportSet::load(&p, &part).unwrap(), set);
        let bad = text.replace("mu_probe = 0.7", "mu_probe = 7.0");
        std::fs::write(&p, bad).unwrap();
        let e = SupportSet::load(&p, &part).unwrap_err().to_string();
        assert!(e.contains("support 1") && e.contains("mu_probe") && e.contains("[0, 2]"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
