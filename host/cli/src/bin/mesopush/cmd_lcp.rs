//! `mesopush lcp solve FILE`: solve an (M)LCP from a dense Siconos `.dat` file with our solver
//! and print the verified answer (or the named failure), optionally timing repeated solves.

use mesopush_core::check::Allowed;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use mesopush_core::stats::percentile;
use mesopush_lcp::{LcpSettings, LcpSolver, siconos};
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
    /// then fallbacks; every answer is verified). Exit status: 0 solved, 1 no verified
    /// solution (status names why), 2 invalid input.
    Solve(SolveArgs),
    /// Benchmark the solver on seeded random simulator step problems (paper Eq. 7–8; with the
    /// probe alone, 3 free and 31 complementarity variables): per-problem median solve time,
    /// then the median over problems; counts solved and failed problems.
    Steps(StepsArgs),
}

#[derive(Debug, Args)]
struct StepsArgs {
    /// Number of random step problems.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    count: u64,
    /// Seed of the first problem (problem k uses seed + k).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Fixture contacts besides the probe (each adds 4 complementarity variables).
    #[arg(long, default_value_t = 0, value_parser = crate::ranges::count(0, 64))]
    fixtures: usize,
    /// Timed solves per problem.
    #[arg(long, default_value_t = 200, value_parser = crate::ranges::at_least_one())]
    runs: usize,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
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
    #[arg(long, value_name = "N", value_parser = crate::ranges::at_least_one())]
    bench: Option<usize>,
    /// Lemke pivot limit per attempt.
    #[arg(long, default_value_t = LcpSettings::default().max_pivots, value_parser = crate::ranges::at_least_one())]
    max_pivots: usize,
    /// Acceptance tolerance on the scaled residuals.
    #[arg(long, default_value_t = LcpSettings::default().tol, value_parser = crate::ranges::real(Allowed::positive_to(1.0, "")))]
    tol: f64,
    /// Largest n for the enumeration fallback (0 disables it).
    #[arg(long, default_value_t = LcpSettings::default().enumerate_max_n, value_parser = crate::ranges::count(0, 30))]
    enumerate_max_n: usize,
}

pub(crate) fn run(args: LcpArgs) -> anyhow::Result<()> {
    match args.command {
        LcpCommand::Solve(a) => solve(a),
        LcpCommand::Steps(a) => steps(a),
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
        return Err(crate::verdict::Negative("no verified solution".into()).into());
    }
    Ok(())
}

fn steps(a: StepsArgs) -> anyhow::Result<()> {
    use mesopush_lcp::{MlcpProblem, generate};
    use rand::SeedableRng;
    anyhow::ensure!(a.count > 0 && a.runs > 0, "--count and --runs must be at least 1");
    let mut solver = LcpSolver::new(64, LcpSettings::default());
    let (mut medians, mut failed, mut pivots) = (Vec::new(), 0, Vec::new());
    for k in 0..a.count {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(a.seed + k);
        let step = generate::random_step(&mut rng, a.fixtures);
        let p = MlcpProblem { n_free: step.n_free, n: step.n, m: &step.m, q: &step.q };
        match solver.solve(&p) {
            Ok(sol) => pivots.push(sol.pivots as f64),
            Err(_) => failed += 1,
        }
        let lcp = siconos::SiconosMlcp { n_free: step.n_free, n: step.n, m: step.m, q: step.q };
        medians.push(time_solves(&mut solver, &lcp, a.runs));
    }
    let median = percentile(&mut medians, 0.5);
    let (p90, max) = (percentile(&mut medians, 0.9), percentile(&mut medians, 1.0));
    let summary = json!({
        "problems": a.count, "seed": a.seed, "fixtures": a.fixtures, "runs": a.runs,
        "solved": a.count as usize - failed, "failed": failed,
        "mean_pivots": pivots.iter().sum::<f64>() / pivots.len().max(1) as f64,
        "solve_us_median": median,
        "solve_us_p90": p90,
        "solve_us_max": max,
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary).context("encoding JSON")?);
    } else {
        println!(
            "{} step problems ({} fixtures): {} solved, {} failed; median {:.2} µs per solve \
             (p90 {:.2} µs, slowest problem {:.2} µs), {:.1} pivots on average",
            a.count,
            a.fixtures,
            summary["solved"],
            failed,
            summary["solve_us_median"].as_f64().unwrap_or(f64::NAN),
            summary["solve_us_p90"].as_f64().unwrap_or(f64::NAN),
            summary["solve_us_max"].as_f64().unwrap_or(f64::NAN),
            summary["mean_pivots"].as_f64().unwrap_or(f64::NAN)
        );
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
    // The upper median (a measured time); no runs: NaN, printed as null.
    percentile(&mut times, 0.5).unwrap_or(f64::NAN)
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
