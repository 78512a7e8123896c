//! Identification on simulated trials with known truth: the truth scores at the tracking
//! noise floor, the sweep and the joint optimiser recover μ and the optimiser ends at that
//! floor, the consistent set holds the truth's neighbourhood, another part at another scale
//! is identified the same way, and bad input gets a clear error. Budgets are small; the
//! full-size figures are in docs/identification.md.

use mesopush_ident::score::score;
use mesopush_ident::synth::{SynthSpec, demo_truth, hexagon, write_trials};
use mesopush_ident::{
    Candidate, IdentTrial, IdentifySettings, NO_TICKS, OptimizeSettings, ScoreSettings,
    SweepSettings, identify,
};
use mesopush_sim::Model;
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

fn small_settings(optimize: bool, n_supports: usize) -> IdentifySettings {
    IdentifySettings {
        sweep: SweepSettings { mu_step: 0.1, n_supports, ..SweepSettings::default() },
        optimize: optimize.then(|| OptimizeSettings { max_evals: 192, ..Default::default() }),
        score: ScoreSettings::default(),
        bootstrap: Default::default(),
    }
}

#[test]
fn sweep_and_optimiser_recover_mu_within_0_05() {
    let dir = tempfile::tempdir().unwrap();
    let truth = demo_truth();
    let ts = trials(dir.path(), &truth, 400.0, 6);
    let report = identify(&ts, &small_settings(true, 30), &mut rng(SEED), &NO_TICKS).unwrap();
    let opt = report.optimized.as_ref().unwrap();
    let xy = |s: &mesopush_ident::report::Scored| {
        s.per_trial.iter().map(|p| p.xy_mse_um2).sum::<f64>() / s.per_trial.len() as f64
    };
    eprintln!(
        "seed {SEED}: true μ {}, sweep μ {:.3} (X,Y MSE {:.3} µm²), optimiser μ {:.3} (X,Y MSE {:.3} µm²), floor {:.3} µm²",
        truth.mu_probe,
        report.nominal.candidate.mu_probe,
        xy(&report.nominal),
        opt.candidate.mu_probe,
        xy(opt),
        floor(&SynthSpec::paper_like(truth.clone(), 400.0)).0
    );
    assert!((report.nominal.candidate.mu_probe - truth.mu_probe).abs() <= 0.05 + 1e-9);
    assert!((opt.candidate.mu_probe - truth.mu_probe).abs() <= 0.05, "seed {SEED}");
    assert!(opt.total_sse_um2 < report.nominal.total_sse_um2, "the optimiser must improve");
    // Even this small budget (192 evaluations) ends at the tracking noise floor.
    let xy_floor = floor(&SynthSpec::paper_like(truth.clone(), 400.0)).0;
    assert!(xy(opt) < 1.2 * xy_floor, "seed {SEED}: X,Y MSE {} vs floor {xy_floor}", xy(opt));
    assert_eq!(report.chosen_from, "optimizer");
    // Table I has one row per trial with every simulation counted.
    assert_eq!(report.table.len(), 6);
    assert!(report.table.iter().all(|r| r.simulations == 11 * 30));
    // The cross matrix's diagonal is each trial's own best.
    for (i, row) in report.table.iter().enumerate() {
        assert_eq!(report.cross_xy_mse_um2[i][i], row.xy_mse_um2);
    }
}

#[test]
fn the_consistent_set_is_written_as_a_supports_list_of_valid_supports() {
    let dir = tempfile::tempdir().unwrap();
    let truth = demo_truth();
    let ts = trials(dir.path(), &truth, 300.0, 2);
    let report = identify(&ts, &small_settings(false, 12), &mut rng(SEED), &NO_TICKS).unwrap();
    let set = &report.consistent;
    assert!(!set.members.is_empty() && set.members.len() < set.examined);
    assert!(set.members.windows(2).all(|w| w[0].1 <= w[1].1));
    assert!(set.members.iter().all(|m| m.1 <= set.threshold_um2));
    let path = dir.path().join("supports.toml");
    set.save(&path).unwrap();
    // Read back as `robustness --supports` reads it: every member with its probe friction.
    let file = mesopush_sim::support_set::SupportSet::load(&path, &truth.part).unwrap();
    assert_eq!(file.support.len(), set.members.len());
    for (s, m) in file.support.iter().zip(&set.members) {
        assert_eq!(s.mu_probe, Some(m.0.mu_probe));
        assert_eq!(s.support(), m.0.support);
    }
}

#[test]
fn a_hexagon_at_another_scale_and_speed_is_identified_the_same_way_and_deterministically() {
    let dir = tempfile::tempdir().unwrap();
    let mut truth = demo_truth();
    truth.part = hexagon(400.0);
    truth.support.points_um = [[-200.0, 150.0], [-90.0, -220.0], [250.0, 40.0]];
    truth.mu_probe = 0.3;
    let mut spec = SynthSpec::paper_like(truth.clone(), 250.0);
    spec.speed_um_s = 60.0;
    spec.setpoint_period_us = 20_000;
    spec.pushes.truncate(2);
    let dirs = write_trials(&spec, dir.path(), &mut rng(SEED)).unwrap();
    let ts: Vec<IdentTrial> = dirs.iter().map(|d| IdentTrial::load(d).unwrap()).collect();
    let run = || identify(&ts, &small_settings(false, 12), &mut rng(SEED), &NO_TICKS).unwrap();
    let (a, b) = (run(), run());
    assert_eq!(a.sweep.scores, b.sweep.scores, "same seed, same numbers");
    let all: Vec<f64> = (0..a.sweep.n_candidates()).map(|k| a.sweep.total_sse_um2(k)).collect();
    let mut sorted = all.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    eprintln!(
        "hexagon: true μ 0.3, nominal μ {:.2}, SSE {:.1} (median {median:.1})",
        a.nominal.candidate.mu_probe, a.nominal.total_sse_um2
    );
    assert!(a.nominal.total_sse_um2 < median);
    assert!((a.nominal.candidate.mu_probe - truth.mu_probe).abs() <= 0.1 + 1e-9, "seed {SEED}");
}

#[test]
fn a_trial_without_poses_is_named_and_told_to_track_first() {
    let dir = tempfile::tempdir().unwrap();
    let truth = demo_truth();
    let mut spec = SynthSpec::paper_like(truth, 200.0);
    spec.pushes.truncate(1);
    let dirs = write_trials(&spec, dir.path(), &mut rng(SEED)).unwrap();
    std::fs::remove_file(dirs[0].join("pose.csv")).unwrap();
    let e = IdentTrial::load(&dirs[0]).unwrap_err().to_string();
    assert!(e.contains("synth-00") && e.contains("track"), "{e}");
}

#[test]
fn the_optimiser_descends_to_the_noise_floor_from_the_true_basin() {
    use mesopush_ident::optimize;
    let dir = tempfile::tempdir().unwrap();
    let truth = demo_truth();
    let ts = trials(dir.path(), &truth, 400.0, 6);
    let (xy_floor, th_floor) = floor(&SynthSpec::paper_like(truth.clone(), 400.0));
    // A start in the true basin but well off the truth: μ + 0.08, every point moved 40 µm.
    let mut start = truth_candidate(&truth);
    start.mu_probe += 0.08;
    for (i, p) in start.support.points_um.iter_mut().enumerate() {
        p[0] += if i % 2 == 0 { 40.0 } else { -40.0 };
        p[1] += 40.0;
    }
    let settings = OptimizeSettings { max_evals: 200, starts: 1, ..Default::default() };
    let s = ScoreSettings::default();
    let o = optimize(&ts, &[start], &settings, &s, &mut rng(SEED), &|| ());
    let (mut xy, mut th, mut n) = (0.0, 0.0, 0usize);
    for t in &ts {
        let sc = score(t, &o.best, &s);
        xy += sc.xy_mse_um2 * sc.n_poses as f64;
        th += sc.theta_mse_deg2() * sc.n_poses as f64;
        n += sc.n_poses;
    }
    let (xy, th) = (xy / n as f64, th / n as f64);
    eprintln!(
        "seed {SEED}: start SSE {:.1} → {:.1} µm² in {} evaluations; μ {:.4}; X,Y MSE {xy:.4} µm² \
         (floor {xy_floor}), θ MSE {th:.6} deg² (floor {th_floor:.6})",
        o.start_sse_um2, o.total_sse_um2, o.evals, o.best.mu_probe
    );
    assert!(o.evals <= settings.max_evals + 8, "{} evaluations", o.evals);
    assert!((o.best.mu_probe - truth.mu_probe).abs() <= 0.01, "seed {SEED}: μ {}", o.best.mu_probe);
    assert!(xy < 1.2 * xy_floor, "seed {SEED}: X,Y MSE {xy} vs floor {xy_floor}");
    assert!(th < 1.2 * th_floor, "seed {SEED}: θ MSE {th} vs floor {th_floor}");
}
