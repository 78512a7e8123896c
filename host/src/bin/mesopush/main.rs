//! `mesopush`: the host command line. Thin over `mesopush_host`: each subcommand module parses
//! its flags, calls the library and prints.

mod cmd_lcp;
mod cmd_sim;

use clap::{Parser, Subcommand};

/// Design, execute and verify open-loop pushing plans for meso-scale assembly.
#[derive(Debug, Parser)]
#[command(name = "mesopush", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Replay a plan in the quasi-static simulator (trajectory CSV, figure, verdict).
    Sim(cmd_sim::SimArgs),
    /// Complementarity problems: solve LCP files with our solver.
    Lcp(cmd_lcp::LcpArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Sim(args) => cmd_sim::run(&args),
        Command::Lcp(args) => cmd_lcp::run(args),
    }
}
