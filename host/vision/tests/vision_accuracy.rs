//! Accuracy of the tracker on rendered frames with noise (issue 4's targets): over 240 random
//! frames, the unflagged poses must be within 2 µm / 0.3° RMS and none off by more than 10 µm
//! or 2°. Run with `-- --nocapture` to see the figures.

mod vision_support;

use mesopush_vision::{TrackSettings, Tracker};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vision_support::{Generator, Placement, ProbeUse, Stats, errors};

/// The default seed; `VISION_ACCURACY_SEED=<n>` runs another set of frames.
const DEFAULT_SEED: u64 = 20_261_121;
const FRAMES: usize = 240;

#[test]
fn unflagged_poses_meet_the_accuracy_targets() {
    let seed_env = std::env::var("VISION_ACCURACY_SEED").ok();
    let seed_value = seed_env.and_then(|s| s.parse().ok()).unwrap_or(DEFAULT_SEED);
    #[allow(non_snake_case)]
    let SEED = seed_value;
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let mut generator = Generator::new(&mut rng);
    let mut tracker = Tracker::new(&generator.background, TrackSettings::default()).unwrap();
    let (mut all, mut clean) = (Stats::default(), Stats::default());
    let mut tip_errors: Vec<f64> = Vec::new();
    let mut tips_missed = 0usize;
    for i in 0..FRAMES {
        let case = generator.case(&mut rng);
        let m = tracker.measure(&case.frame.image).unwrap();
        let truth = case.frame.truth.peg_pose.unwrap();
        if let Some((d, a)) = errors(&m, &truth)
            && !m.is_flagged()
            && (d > 10.0 || a.to_degrees() > 2.0)
        {
            panic!(
                "seed {SEED} frame {i} ({:?}, {:?}): unflagged error {d:.2} µm {:.3}°, {m:?}",
                case.placement,
                case.probe,
                a.to_degrees()
            );
        }
        all.add(&m, &truth);
        if case.frame.truth.peg_in_field
            && case.placement == Placement::Wide
            && case.probe != ProbeUse::Over
        {
            clean.add(&m, &truth);
        }
        if case.probe == ProbeUse::Touching && !m.is_flagged() {
            let t = case.frame.truth.probe_tip_um.unwrap();
            match m.probe_tip_um {
                Some(tm) => tip_errors.push((t - tm).norm()),
                None => tips_missed += 1,
            }
        }
    }
    tip_errors.sort_by(f64::total_cmp);
    let tips = tip_errors.len();
    let tip_rms = (tip_errors.iter().map(|e| e * e).sum::<f64>() / tips.max(1) as f64).sqrt();
    let tip_p90 = tip_errors.get(tips * 9 / 10).copied().unwrap_or(f64::NAN);
    println!(
        "vision accuracy (seed {SEED}, {} frames): RMS position {:.3} µm, RMS orientation {:.4}°, \
         flagged {:.1} % ({} of {}), max unflagged error {:.3} µm / {:.4}°; probe tip RMS {:.2} µm, \
         90th percentile {:.2} µm over {} touching frames ({} not found); clean frames flagged {} of {}",
        all.frames,
        all.rms_um(),
        all.rms_deg(),
        100.0 * all.share_flagged(),
        all.flagged,
        all.frames,
        all.max_d,
        all.max_a.to_degrees(),
        tip_rms,
        tip_p90,
        tips,
        tips_missed,
        clean.flagged,
        clean.frames
    );
    assert!(all.frames >= 200);
    assert!(tips >= 30 && tip_p90 <= 5.0, "probe tip: 90th percentile {tip_p90} µm over {tips}");
    assert!(tips_missed * 10 <= tips, "probe tip not found in {tips_missed} touching frames");
    assert!(all.rms_um() <= 2.0, "RMS position {} µm (seed {SEED})", all.rms_um());
    assert!(all.rms_deg() <= 0.3, "RMS orientation {}° (seed {SEED})", all.rms_deg());
    // flagging everything would pass the bounds above: the clean frames must mostly count
    assert!(
        clean.frames >= 60 && clean.share_flagged() < 0.05,
        "clean frames flagged: {} of {}",
        clean.flagged,
        clean.frames
    );
}
