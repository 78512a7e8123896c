//! Adhesion fitted in the diagnosis's own form (pull-off force, capture range and the bond's
//! friction along the edge all free). Caught: the candidate freed the pull-off alone, with
//! the range fixed at our own generator's 2 µm and the pull sliding at the probe's μ; on the
//! independent generator's adhesion (an elastic bond, 5 µm reach, stuck along the edge;
//! `indep_batches --seed 12`, adhesion-01) its best fit predicted the held-out trials worse
//! than no adhesion at all (939 → 2 190 noise units) and the verdict was `unexplained`.
//! With the bond's range and friction free: held-out 939 → 127, `adhesion` named (CLI
//! budgets, docs/diagnose.md). This test runs the library's default budgets: held-out
//! 1 493 → 98.6 noise units (range 7.6 µm, bond μ 2.6); with the range held at 2 µm and the
//! pull at the probe's μ the same budgets still name adhesion but predict the held-out
//! trials at 415 (0.28 of the nominal's), which the bound below refuses.

use mesopush_diagnose::data::load_split;
use mesopush_diagnose::{Effect, Options, Verdict, diagnose};
use mesopush_tests::indep::batch::{BatchSpec, write_batch};
use mesopush_tests::indep::world::World;

#[test]
fn an_adhesive_bond_that_sticks_and_reaches_further_than_ours_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let spec =
        BatchSpec::standard(World::named("peg").unwrap(), "adhesion", 5_187_768_732_132_219_331)
            .unwrap();
    let dirs = write_batch(tmp.path(), &spec).unwrap();
    let (train, test) = load_split(&dirs).unwrap();
    let d = diagnose(&train, &test, &Options::default(), &|_| {}).unwrap();
    let adhesion = d.scores.iter().find(|s| s.candidate == Effect::Adhesion).unwrap();
    let param = |name: &str| adhesion.params.iter().find(|p| p.0 == name).map(|p| p.1).unwrap();
    let (nominal, after) = (d.scores[0].heldout_norm, adhesion.heldout_norm);
    eprintln!(
        "adhesion-01: {:?} {:?}, held-out {nominal:.1} → {after:.1} noise units, pull-off \
         {:.3} weights, range {:.2} µm, bond μ {:.2}",
        d.verdict,
        d.effect,
        param("pull_off_weight"),
        param("range_um"),
        param("mu_bond"),
    );
    assert_eq!((d.verdict, d.effect), (Verdict::Effect, Some(Effect::Adhesion)));
    // The fit must carry over to the held-out trials: 0.07 of the nominal's error with the
    // bond's reach and grip free, 0.28 with our generator's (see above).
    assert!(after < 0.15 * nominal, "held-out {nominal:.1} → {after:.1} noise units");
}
