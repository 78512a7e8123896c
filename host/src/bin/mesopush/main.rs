//! `mesopush`: the host command line. Thin over `mesopush_host`: each subcommand module parses
//! its flags, calls the library and prints.

mod cmd_lcp;

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
    /// Complementarity problems: solve LCP files with our solver.
    Lcp(cmd_lcp::LcpArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Lcp(args) => cmd_lcp::run(args),
    }
}
