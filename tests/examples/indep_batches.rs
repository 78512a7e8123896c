//! Writes batches of trial logs from the independent generator (`mesopush_tests::indep`):
//!
//! ```text
//! cargo run --release -p mesopush-tests --example indep_batches -- --out DIR --seed N \
//!     [--effect clean|backlash|latency|scale|stripe|adhesion|speed_friction|drift|leadscrew|all]
//!     [--batches K] [--world peg|square|pentagon|mixed] [--pusher-radius-um R]
//! ```
//!
//! K batches per effect under `DIR/<effect>-<b>/trial-NNN`, and `DIR/manifest.json` with each
//! batch's true effect and parameters. Exit code 2 on invalid arguments.

use mesopush_tests::indep::batch::{Request, write_batches};
use std::path::PathBuf;
use std::process::ExitCode;

fn parse(args: &[String]) -> Result<Request, String> {
    let mut req = Request {
        out: PathBuf::new(),
        seed: 1,
        effects: vec!["all".into()],
        batches: 1,
        world: "peg".into(),
        pusher_radius_um: None,
    };
    let mut out = None;
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = |what: &str| format!("{flag} = {value:?}: not {what}");
        match flag.as_str() {
            "--out" => out = Some(PathBuf::from(value)),
            "--seed" => req.seed = value.parse().map_err(|_| num("a u64"))?,
            "--effect" => req.effects = value.split(',').map(str::to_owned).collect(),
            "--batches" => req.batches = value.parse().map_err(|_| num("a count"))?,
            "--world" => req.world = value.clone(),
            "--pusher-radius-um" => {
                req.pusher_radius_um = Some(value.parse().map_err(|_| num("a number"))?)
            }
            _ => return Err(format!("unknown argument {flag:?}")),
        }
    }
    req.out = out.ok_or("--out DIR is required")?;
    Ok(req)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let req = match parse(&args) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("indep_batches: {e}");
            return ExitCode::from(2);
        }
    };
    match write_batches(&req) {
        Ok(m) => {
            let n = m["batches"].as_array().map_or(0, Vec::len);
            println!("wrote {n} batches and manifest.json under {}", req.out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("indep_batches: {e}");
            ExitCode::from(2)
        }
    }
}
