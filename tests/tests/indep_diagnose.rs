//! Diagnosis on batches the project did not make: the independent exact-Coulomb generator
//! (`mesopush_tests::indep`, its own supports, friction, plans, noise and effect code) writes
//! clean six-trial batches; `diagnose` must fit them to the measurement floor (held-out X,Y
//! MSE ≤ 1.5 × the floor 2σ², σ the tracker noise it estimates itself) and say `none`.
//! Caught: the nominal fit freed only a shift of the project's default support triangle and
//! stayed at 720–1 800 µm² held-out on such batches (verdict `unexplained`).
//! Seeds chosen before the first run; numbers: `cargo test --release -p mesopush-tests --test
//! indep_diagnose -- --ignored --nocapture`.
//!
//! NOT MET YET (issue 18 point 1 stays open): the first run (2026-11-26) gave peg seed 101
//! 66.5 µm² held-out (34× the floor, `unexplained`), pentagon seed 202 6.39 µm² (3.2×, `none`),
//! the four-support square seed 303 2 742 µm² (1 324×, `unexplained`). The tests are kept,
//! ignored, with their bounds unchanged, so they are run by hand until the fit meets them.
//! After the multi-start descent and the averaged restart poses (2026-11-26): peg 34.2 µm²
//! (17.5×, `none`), pentagon 7.25 µm² (3.6×, `none`), square 1 545 µm² (746×,
//! `unexplained`). What is left on the peg is partly the simulator's step: at the
//! generator's true parameters a clean peg batch can sit at 4.9× the floor at the 5 µm
//! step and 1.1× at 0.5 µm (`tests/tests/indep_truth.rs`). With the training loss profiled
//! over the restart poses (`diagnose::start_pose`, 2026-11-27): peg 11.6 µm² (5.9×, `none`),
//! pentagon 10.2 µm² (5.1×, `none`), square 2 836 µm² (1 369×, `unexplained`; four supports
//! are outside the three-point family). With the nominal fit redone at a 1 µm step when it is
//! inside the floor band (`diagnose::polish`, 2026-11-27): peg 10.7 µm² (5.47×, `none`),
//! pentagon 3.16 µm² (1.57×, `none`), square unchanged (not inside the band).

use mesopush_diagnose::data::load_split;
use mesopush_diagnose::residual::{Mse, Noise};
use mesopush_diagnose::{Options, TrialData, Verdict, diagnose};
use mesopush_tests::indep::batch::{BatchSpec, write_batch};
use mesopush_tests::indep::world::World;

fn clean_batch_reaches_the_floor(world: &str, seed: u64) {
    let tmp = tempfile::tempdir().unwrap();
    let spec = BatchSpec::standard(World::named(world).unwrap(), "clean", seed).unwrap();
    let dirs = write_batch(tmp.path(), &spec).unwrap();
    let (train, test) = load_split(&dirs).unwrap();
    let all: Vec<TrialData> = train.iter().chain(&test).cloned().collect();
    let noise = Noise::estimate(&all);
    let d = diagnose(&train, &test, &Options::default(), &|_| {}).unwrap();
    let mse = Mse::of(&d.residuals.0);
    let floor = 2.0 * noise.xy_um * noise.xy_um;
    eprintln!(
        "{world} seed {seed}: {:?}, family {} {:?}, held-out X,Y MSE {:.2} µm² (floor {floor:.2}, \
         ratio {:.2}), θ MSE {:.2e} rad²",
        d.verdict,
        d.support_fit.family,
        d.support_fit.heldout_norm,
        mse.xy_um2,
        mse.xy_um2 / floor,
        mse.theta_rad2
    );
    assert_eq!(d.verdict, Verdict::None, "{world} seed {seed}");
    assert!(mse.xy_um2 <= 1.5 * floor, "{world} seed {seed}: {} > 1.5 × {floor}", mse.xy_um2);
}

#[test]
#[ignore = "peg seed 101: 2.5x the floor (issue 18 point 1 open)"]
fn a_clean_peg_batch_from_another_simulator_is_fitted_to_the_floor() {
    clean_batch_reaches_the_floor("peg", 101);
}

#[test]
#[ignore = "pentagon seed 202: 1.57x the floor (issue 18 point 1 open)"]
fn a_clean_pentagon_batch_from_another_simulator_is_fitted_to_the_floor() {
    clean_batch_reaches_the_floor("pentagon", 202);
}

#[test]
#[ignore = "four supports: 1369x the floor (issue 18 point 1 open)"]
fn a_clean_square_on_four_supports_from_another_simulator_is_fitted_to_the_floor() {
    clean_batch_reaches_the_floor("square", 303);
}

/// The refit at the finer step ([`mesopush_diagnose::polish`]): a clean peg batch of the
/// independent generator (`indep_batches --seed 8 --world peg`, its second batch) whose
/// nominal fit at the 5 µm step predicts the held-out trials at 4.1 × the floor is refitted at
/// 1 µm, kept, and within 1.5 × (1.44 × when measured). Fails if the refit is not run, not
/// kept, or not finer.
#[test]
fn a_clean_batch_near_the_floor_is_refitted_at_the_finer_step() {
    let tmp = tempfile::tempdir().unwrap();
    let seed = 12_846_116_240_401_813_752;
    let spec = BatchSpec::standard(World::named("peg").unwrap(), "clean", seed).unwrap();
    let dirs = write_batch(tmp.path(), &spec).unwrap();
    let (train, test) = load_split(&dirs).unwrap();
    let all: Vec<TrialData> = train.iter().chain(&test).cloned().collect();
    let noise = Noise::estimate(&all);
    let floor = 2.0 * noise.xy_um * noise.xy_um;
    let d = diagnose(&train, &test, &Options::default(), &|_| {}).unwrap();
    let mse = Mse::of(&d.residuals.0);
    let p = d.support_fit.polish.clone().expect("a fit within the floor band is refitted");
    eprintln!(
        "peg seed {seed}: {:?}, coarse {:?}, refit {p:?}, held-out X,Y MSE {:.2} µm² ({:.2} × \
         the floor)",
        d.verdict,
        d.support_fit.heldout_norm,
        mse.xy_um2,
        mse.xy_um2 / floor
    );
    assert_eq!(d.verdict, Verdict::None);
    assert!(p.kept && p.step_um < 1.01, "{p:?}");
    assert!(mse.xy_um2 <= 1.5 * floor, "{} > 1.5 × {floor}", mse.xy_um2);
}
