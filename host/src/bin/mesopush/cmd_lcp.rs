//! `mesopush lcp solve FILE`: solve an (M)LCP from a dense Siconos `.dat` file with our solver
//! and print the verified answer (or the named failure), optionally timing repeated solves.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use mesopush_host::lcp::{LcpSettings, LcpSolver, siconos};
use serde_json::json;

/// Complementarity problems.
#[derive(Debug, Args)]
pub(crate) struct LcpArgs {
    #[command(subcommand)]
    command: LcpCommand,
}

#[derive(Debug, Subcommand)]
enum LcpCommand {
    /// Solve the LCP (or, with --mlcp, the mixed LCP) in a dense Siconos `.dat` file (Lemke,
    /// then fallbacks; every answer is verified). Exit status: 0 solved, 2 no verified
    /// solution (status names why), 1 error.
    Solve(SolveArgs),
}

#[derive(Debug, Args)]
struct SolveArgs {
    /// The problem file (Siconos dense format: n, 0, n n n n, M column-major, q).
    file: PathBuf,
    /// The file is a Siconos MLCP (`*_mlcp.dat`: equality rows first, then complementarity).
    #[arg(long)]
    mlcp: bool,
    /// Print a JSON summary (status, z, pivots, residuals) instead of text.
    #[arg(long)]
    json: bool,
    /// Solve the problem N times in this process and report the median time per solve.
    #[arg(long, value_name = "N")]
    bench: Option<usize>,
    /// Lemke pivot limit per attempt.
    #[arg(long, default_value_t = LcpSettings::default().max_pivots)]
    max_pivots: usize,
    /// Acceptance tolerance on the scaled residuals.
    #[arg(long, default_value_t = LcpSettings::default().tol)]
    tol: f64,
    /// Largest n for the enumeration fallback (0 disables it).
    #[arg(long, default_value_t = LcpSettings::default().enumerate_max_n)]
    enumerate_max_n: usize,
}

pub(crate) fn run(args: LcpArgs) -> anyhow::Result<()> {
    match args.command {
        LcpCommand::Solve(a) => solve(a),
    }
}

fn solve(a: SolveArgs) -> anyhow::Result<()> {
    let lcp = if a.mlcp {
        siconos::read_mlcp(&a.file)?
    } else {
        let l = siconos::read(&a.file)?;
        siconos::SiconosMlcp { n_free: 0, n: l.n, m: l.m, q: l.q }
    };
    let settings = LcpSettings {
        max_pivots: a.max_pivots,
        tol: a.tol,
        enumerate_max_n: a.enumerate_max_n,
        ..LcpSettings::default()
    };
    let mut solver = LcpSolver::new(lcp.n, settings);
    let timing = match a.bench {
        Some(0) => anyhow::bail!("--bench must be at least 1"),
        Some(runs) => Some(time_solves(&mut solver, &lcp, runs)),
        None => None,
    };
    let file = a.file.display().to_string();
    let outcome = solver.solve(&lcp.problem());
    let solved = outcome.is_ok();
    let mut summary = match &outcome {
        Ok(sol) => json!({
            "file": file, "n": lcp.n, "n_free": lcp.n_free, "status": "solved", "method": sol.method,
            "z": sol.z, "pivots": sol.pivots, "polished": sol.polished,
            "residual": sol.residuals.max(), "residuals": sol.residuals,
        }),
        Err(f) => json!({
            "file": file, "n": lcp.n, "status": f.status_name(), "message": f.to_string(),
            "z": null, "pivots": f.pivots(), "residual": f.residual(),
        }),
    };
    if let Some(median_us) = timing {
        summary["solve_us_median"] = json!(median_us);
        summary["bench_runs"] = json!(a.bench);
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary).context("encoding JSON")?);
    } else {
        print_text(&summary, &outcome.as_ref().map(|s| s.z.to_vec()).map_err(|f| f.to_string()));
    }
    if !solved {
        use std::io::Write;
        std::io::stdout().flush().ok();
        std::process::exit(2);
    }
    Ok(())
}

/// Solves `runs` times and returns the median wall time per solve in µs.
fn time_solves(solver: &mut LcpSolver, lcp: &siconos::SiconosMlcp, runs: usize) -> f64 {
    let p = lcp.problem();
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            let ok = solver.solve(&p).is_ok();
            let dt = t0.elapsed().as_secs_f64() * 1e6;
            std::hint::black_box(ok);
            dt
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn print_text(summary: &serde_json::Value, outcome: &Result<Vec<f64>, String>) {
    let file = summary["file"].as_str().unwrap_or("?");
    match outcome {
        Ok(z) => {
            println!(
                "{file}: solved by {} in {} pivots, residual {:.2e} (n = {})",
                summary["method"].as_str().unwrap_or("?"),
                summary["pivots"],
                summary["residual"].as_f64().unwrap_or(f64::NAN),
                summary["n"]
            );
            println!("z = {z:?}");
        }
        Err(message) => {
            println!("{file}: {} — {message}", summary["status"].as_str().unwrap_or("?"))
        }
    }
    if let Some(us) = summary["solve_us_median"].as_f64() {
        println!("median solve time: {us:.2} µs over {} runs", summary["bench_runs"]);
    }
}
