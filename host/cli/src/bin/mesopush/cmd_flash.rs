//! `mesopush flash PLAN --port P`: uploads a plan to a running `mesopush-executor` over its
//! host line (`unix:PATH` or a serial device). Thin over `mesopush_rig::client::hil::flash`.

use anyhow::Context;
use clap::Args;
use mesopush_rig::client::hil;
use mesopush_sim::Plan;
use std::path::PathBuf;

/// Upload a plan to a running executor.
#[derive(Debug, Args)]
pub(crate) struct FlashArgs {
    /// Plan TOML.
    plan: PathBuf,
    /// The executor's host line: `unix:PATH` (its `--host-port unix:PATH`) or a serial device.
    #[arg(long)]
    port: String,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &FlashArgs) -> anyhow::Result<()> {
    let plan = Plan::load(&args.plan)?;
    let steps = hil::flash(&args.port, &plan)
        .with_context(|| format!("flashing {} to {}", args.plan.display(), args.port))?;
    if args.json {
        println!("{}", serde_json::json!({ "accepted": true, "step_count": steps }));
    } else {
        println!("plan {} accepted: {steps} steps", args.plan.display());
    }
    Ok(())
}
