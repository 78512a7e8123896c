//! Draws of the uncertainty a plan must survive (the paper's section V): the peg's start pose
//! within the measured positioning error, the support distribution (from an identified
//! candidate set, or perturbed around the model's), and the friction coefficients.

use crate::Error;
use mesopush_core::geom::Pose;
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Model, Plan, SupportDistribution};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// The uncertainty box (half-widths of uniform distributions; plain data).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Uncertainty {
    /// Start x error, µm. Paper: 26.
    pub dx_um: f64,
    /// Start y error, µm. Paper: 74.
    pub dy_um: f64,
    /// Start orientation error, degrees. Paper: 3.
    pub dtheta_deg: f64,
    /// Friction error added to μ_probe, μ_wall and each support's μ, independently. 0.1.
    pub dmu: f64,
    /// Support point error, µm per coordinate, when supports are perturbed around the
    /// model's (no candidate set). Default 100 (about a tenth of the peg's width).
    pub support_um: f64,
}

impl Default for Uncertainty {
    /// The paper's trials: ±26 µm, ±74 µm, ±3°; μ ± 0.1; supports ± 100 µm.
    fn default() -> Self {
        Self { dx_um: 26.0, dy_um: 74.0, dtheta_deg: 3.0, dmu: 0.1, support_um: 100.0 }
    }
}

impl Uncertainty {
    /// Checks that every half-width is finite and ≥ 0; the error names the first that is not.
    pub fn validate(&self) -> Result<(), Error> {
        let fields = [
            ("dx_um", self.dx_um),
            ("dy_um", self.dy_um),
            ("dtheta_deg", self.dtheta_deg),
            ("dmu", self.dmu),
            ("support_um", self.support_um),
        ];
        match fields.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            Some((name, v)) => Err(Error::invalid(
                "uncertainty",
                format!("{name} = {v}: a half-width must be finite and ≥ 0"),
            )),
            None => Ok(()),
        }
    }

    /// Every half-width multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            dx_um: self.dx_um * k,
            dy_um: self.dy_um * k,
            dtheta_deg: self.dtheta_deg * k,
            dmu: self.dmu * k,
            support_um: self.support_um * k,
        }
    }
}

/// One draw: the world a single Monte Carlo trial runs in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Draw {
    /// Start pose offset from the plan's nominal start: (µm, µm, degrees).
    pub offset: [f64; 3],
    /// Index of the candidate support used (`None`: perturbed around the model's).
    pub support_index: Option<usize>,
    /// The model of this trial.
    pub model: Model,
}

impl Draw {
    /// The peg's start pose for `plan`.
    pub fn start(&self, plan: &Plan) -> Pose {
        let s = plan.peg_start_pose();
        Pose::new(
            s.x_um + self.offset[0],
            s.y_um + self.offset[1],
            s.theta_rad + self.offset[2].to_radians(),
        )
    }
}

/// Smallest normal force (part weights) a perturbed support must carry at every point: keeps
/// the centre of mass well inside the support triangle.
const MIN_SUPPORT_FORCE: f64 = 0.05;
/// Attempts at a valid perturbed support before falling back to the model's.
const SUPPORT_TRIES: usize = 200;

fn sym(rng: &mut impl rand::Rng, half: f64) -> f64 {
    if half > 0.0 { rng.random_range(-half..=half) } else { 0.0 }
}

fn perturbed_support(
    model: &Model,
    spread_um: f64,
    rng: &mut impl rand::Rng,
) -> SupportDistribution {
    for _ in 0..SUPPORT_TRIES {
        let mut s = model.support.clone();
        for p in &mut s.points_um {
            p[0] += sym(rng, spread_um);
            p[1] += sym(rng, spread_um);
        }
        let ok = s
            .validate(model.part.polygon())
            .is_ok_and(|f| f.iter().all(|l| *l >= MIN_SUPPORT_FORCE));
        if ok {
            return s;
        }
    }
    model.support.clone()
}

/// Draws one trial's world: start offset, support (a random candidate when `candidates` is
/// not empty, else perturbed around `model`'s), friction. A candidate that carries its probe
/// friction is drawn as a pair: its μ_probe and surface frictions are used as they are (they
/// were fitted together with its points); only the wall friction is perturbed.
pub fn draw(
    model: &Model,
    unc: &Uncertainty,
    candidates: &[SupportSample],
    rng: &mut impl rand::Rng,
) -> Draw {
    let offset = [sym(rng, unc.dx_um), sym(rng, unc.dy_um), sym(rng, unc.dtheta_deg)];
    let (support, support_index, paired_mu) = if candidates.is_empty() {
        (perturbed_support(model, unc.support_um, rng), None, None)
    } else {
        let i = rng.random_range(0..candidates.len());
        (candidates[i].support(), Some(i), candidates[i].mu_probe)
    };
    let mut m = Model { support, ..model.clone() };
    let mu_probe_drawn = (m.mu_probe + sym(rng, unc.dmu)).clamp(0.0, 2.0);
    m.mu_wall = (m.mu_wall + sym(rng, unc.dmu)).clamp(0.0, 2.0);
    let surface_drawn = m.support.mu_surface.map(|mu| (mu + sym(rng, unc.dmu)).clamp(0.0, 2.0));
    // The draws above are made in every case, so a pair's trial keeps the random stream of
    // the trials around it.
    match paired_mu {
        Some(mu) => m.mu_probe = mu,
        None => (m.mu_probe, m.support.mu_surface) = (mu_probe_drawn, surface_drawn),
    }
    Draw { offset, support_index, model: m }
}
