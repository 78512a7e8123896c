//! Identification on simulated trials with known truth: the truth scores at the tracking
//! noise floor, the sweep and the joint optimiser recover μ, the consistent set holds the
//! truth's neighbourhood, another part at another scale is identified the same way, and bad
//! input gets a clear error. Budgets are small (tests run at opt-level 1); the full-size
//! figures are in docs/identification.md.

use mesopush_host::ident::score::score;
use mesopush_host::ident::synth::{SynthSpec, demo_truth, hexagon, write_trials};
use mesopush_host::ident::{
    Candidate, IdentTrial, IdentifySettings, NO_TICKS, OptimizeSettings, ScoreSettings,
    SweepSettings, identify,
};
use mesopush_host::sim::Model;
use rand::SeedableRng;
use std::path::Path;

const SEED: u64 = 20240611;

fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// Writes the first `n` paper-like pushes of `travel_um` with `truth` and loads them.
fn trials(dir: &Path, truth: &Model, travel_um: f64, n: usize) -> Vec<IdentTrial> {
    let mut spec = SynthSpec::paper_like(truth.clone(), travel_um);
    spec.pushes.truncate(n);
    let dirs = write_trials(&spec, dir, &mut rng(SEED)).unwrap();
    dirs.iter().map(|d| IdentTrial::load(d).unwrap()).collect()
}

fn truth_candidate(m: &Model) -> Candidate {
    Candidate { mu_probe: m.mu_probe, support: m.support.clone() }
}

/// Noise floor of the synthetic trials: 2σ² on X,Y (µm²), σ² on θ (deg²).
fn floor(spec: &SynthSpec) -> (f64, f64) {
    (2.0 * spec.noise_xy_um.powi(2), spec.noise_theta_rad.to_degrees().powi(2))
}

#[test]
fn the_true_parameters_score_at_the_noise_floor() {
    let dir = tempfile::tempdir().unwrap();
    let truth = demo_truth();
    let ts = trials(dir.path(), &truth, 400.0, 6);
    let (xy_floor, th_floor) = floor(&SynthSpec::paper_like(truth.clone(), 400.0));
    let s = ScoreSettings::default();
    let (mut xy, mut th, mut n) = (0.0, 0.0, 0usize);
    for t in &ts {
        let sc = score(t, &truth_candidate(&truth), &s);
        assert!(sc.ok(), "seed {SEED}: {} failed", t.id);
        xy += sc.xy_mse_um2 * sc.n_poses as f64;
        th += sc.theta_mse_deg2() * sc.n_poses as f64;
        n += sc.n_poses;
    }
    let (xy, th) = (xy / n as f64, th / n as f64);
    eprintln!(
        "truth: X,Y MSE {xy:.4} µm² (floor {xy_floor}), θ MSE {th:.6} deg² (floor {th_floor:.6})"
    );
    assert!(xy > 0.6 * xy_floor && xy < 1.5 * xy_floor, "seed {SEED}: X,Y MSE {xy}");
    assert!(th > 0.6 * th_floor && th < 1.5 * th_floor, "seed {SEED}: θ MSE {th}");
}
