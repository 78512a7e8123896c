//! The peer suite's mixed problems (`../shared/lcp-suite/mlcp/*_mlcp.dat`, circuit simulation
//! MLCPs from Siconos): every square one is solved with a verified residual by the mixed
//! solver; the rectangular one is refused by name.

mod lcp_common;

use std::path::PathBuf;

use mesopush_lcp::{LcpSettings, LcpSolver, siconos};

#[test]
fn every_square_mlcp_file_is_solved_and_verified() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/lcp-suite/mlcp");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "dat"))
        .collect();
    files.sort();
    assert!(files.len() >= 11, "suite incomplete: {} files", files.len());
    let mut solver = LcpSolver::new(8, LcpSettings::default());
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let problem = match siconos::read_mlcp(path) {
            Ok(p) => p,
            Err(e) => {
                assert_eq!(name, "Rectangular_mlcp.dat", "{e}");
                assert!(e.to_string().contains("must be square"), "{e}");
                continue;
            }
        };
        let sol = solver.solve(&problem.problem()).unwrap_or_else(|e| panic!("{name}: {e}"));
        let r = lcp_common::residual(problem.n_free, &problem.m, &problem.q, sol.z);
        println!(
            "{name}: n_free {} n {}: {:?}, {} pivots, residual {:.1e} (independent {r:.1e})",
            problem.n_free,
            problem.n,
            sol.method,
            sol.pivots,
            sol.residuals.max()
        );
        assert!(r < 1e-9, "{name}: independent residual {r:e}");
    }
}
