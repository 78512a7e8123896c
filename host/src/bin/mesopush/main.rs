//! `mesopush`: the host command line. Thin over `mesopush_host`: each subcommand module parses
//! its flags, calls the library and prints.

mod cmd_render;
mod cmd_track;

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
    /// Render a synthetic microscope sequence (PNG frames, frames.csv, truth.csv, bg.png).
    Render(cmd_render::RenderArgs),
    /// Track the peg and the probe tip in a folder of PNG frames; writes pose.csv.
    Track(cmd_track::TrackArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Render(args) => cmd_render::run(&args),
        Command::Track(args) => cmd_track::run(&args),
    }
}
