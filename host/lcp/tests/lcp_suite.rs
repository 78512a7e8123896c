//! The peer test suite (`../shared/lcp-suite/lcp/*.dat`, Siconos's LCP test data): every dense
//! file is answered correctly — solved with a verified residual where a solution exists, an
//! honest failure on the one without (`lcp_Pang_isolated_sol_perturbed.dat`) — and the
//! sparse-block files are refused by name.

mod lcp_common;

use std::path::PathBuf;

use mesopush_lcp::{Error, LcpSettings, LcpSolver, siconos};

fn suite_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/lcp-suite/lcp")
}

#[test]
fn every_dense_file_is_answered_correctly() {
    let dir = suite_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "dat"))
        .collect();
    files.sort();
    assert!(files.len() >= 20, "suite incomplete: {} files", files.len());
    let mut solver = LcpSolver::new(8, LcpSettings::default());
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with("_block.dat") {
            let err = siconos::read(path).unwrap_err().to_string();
            assert!(err.contains("sparse-block") && err.contains(&name), "{name}: {err}");
            continue;
        }
        let lcp = siconos::read(path).unwrap_or_else(|e| panic!("{e}"));
        match solver.solve(&lcp.problem()) {
            Ok(sol) => {
                let indep = lcp_common::residual(0, &lcp.m, &lcp.q, sol.z);
                println!(
                    "{name}: solved by {:?}, {} pivots, residual {:.2e} (independent {:.2e})",
                    sol.method,
                    sol.pivots,
                    sol.residuals.max(),
                    indep
                );
                assert!(indep <= 1e-8, "{name}: independent residual {indep:e}");
                assert!(
                    name != "lcp_Pang_isolated_sol_perturbed.dat",
                    "{name}: claimed a solution where none exists"
                );
            }
            Err(f) => {
                println!("{name}: {f}");
                assert_eq!(name, "lcp_Pang_isolated_sol_perturbed.dat", "{name}: {f}");
                assert!(matches!(f, Error::NoSolutionFound { .. }), "{name}: {f}");
            }
        }
    }
}

/// Regression: rounding noise in exactly-zero `B⁻¹` entries decided lexicographic ties, and
/// plain Lemke cycled on this highly degenerate bimatrix problem past 10⁶ pivots. Exact
/// rational lexicographic Lemke (a throwaway Python check) takes 127 pivots; so must we.
#[test]
fn tobenna_lexicographic_ties_ignore_rounding_noise() {
    let lcp = siconos::read(&suite_dir().join("lcp_tobenna.dat")).unwrap();
    let settings = LcpSettings { retries: 0, enumerate_max_n: 0, ..Default::default() };
    let mut solver = LcpSolver::new(40, settings);
    let sol = solver.solve(&lcp.problem()).unwrap();
    assert_eq!(sol.pivots, 127);
    assert!(lcp_common::residual(0, &lcp.m, &lcp.q, sol.z) < 1e-12);
}

/// Without enumeration, the Newton fallback must still rescue the bimatrix game on which
/// Lemke ends on a secondary ray, and must not invent an answer for the one without.
#[test]
fn newton_fallback_solves_cps_3_and_refuses_pang_perturbed() {
    let settings = LcpSettings { enumerate_max_n: 0, ..Default::default() };
    let mut solver = LcpSolver::new(4, settings);
    let lcp = siconos::read(&suite_dir().join("lcp_CPS_3.dat")).unwrap();
    let sol = solver.solve(&lcp.problem()).unwrap();
    assert_eq!(sol.method, mesopush_lcp::SolveMethod::Newton);
    assert!(lcp_common::residual(0, &lcp.m, &lcp.q, sol.z) < 1e-12);
    let lcp = siconos::read(&suite_dir().join("lcp_Pang_isolated_sol_perturbed.dat")).unwrap();
    assert!(matches!(solver.solve(&lcp.problem()), Err(Error::SecondaryRay { .. })));
}
