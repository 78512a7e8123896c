//! `mesopush sim`: replay a plan in the quasi-static simulator, write the trajectory CSV and
//! the Fig. 6-style figure, print the verdict (or `--json`), or time it (`--bench`). A plan
//! that bends the needle beyond the model's `probe_deflection_limit_um` is a negative
//! verdict (exit 1, after the outputs are written): it must not run on a rig.

use anyhow::{Context, Result};
use clap::Args;
use mesopush_core::geom::Vec2;
use mesopush_core::stats::percentile;
use mesopush_sim::start::check_start;
use mesopush_sim::{
    Fixture, Model, Plan, Replay, SimSettings, SimState, Simulator, SupportFriction, replay,
    trajectory,
};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Replay a pushing plan in the quasi-static simulator.
#[derive(Debug, Args)]
pub(crate) struct SimArgs {
    /// Plan TOML (start pose, probe start, moves Δu_i, speed), e.g. plans/table2.toml.
    #[arg(long)]
    plan: PathBuf,
    /// Model TOML (part, supports, friction); default: the nominal model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fixture TOML (walls, goal); default: the reconstructed paper fixture.
    #[arg(long)]
    fixture: Option<PathBuf>,
    /// Output directory for trajectory.csv, fig6.png and fig6.svg.
    #[arg(long, default_value = "runs/sim")]
    out: PathBuf,
    /// Probe travel per step, µm.
    #[arg(long, default_value_t = SimSettings::default().step_um, value_parser = crate::ranges::step_um())]
    step_um: f64,
    /// Friction directions per support (the polygonal cone).
    #[arg(long, default_value_t = SimSettings::default().n_directions, value_parser = crate::ranges::count(3, 64))]
    n_directions: usize,
    /// Support friction: `coulomb`, the circular cone solved exactly (default), or
    /// `polygon`, the paper's `--n-directions` directions in the part's body frame
    /// (docs/simulation.md).
    #[arg(long, default_value = "coulomb", value_parser = ["coulomb", "polygon"])]
    support_friction: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Time the replay and its steps over this many runs instead of writing outputs.
    #[arg(long, value_name = "RUNS", num_args = 0..=1, default_missing_value = "30", value_parser = crate::ranges::count(1, 100_000))]
    bench: Option<usize>,
}

pub(crate) fn run(args: &SimArgs) -> Result<()> {
    let plan = Plan::load(&args.plan)?;
    let model = match &args.model {
        Some(p) => Model::load(p)?,
        None => Model::default(),
    };
    let fixture = match &args.fixture {
        Some(p) => Fixture::load(p)?,
        None => Fixture::paper(),
    };
    let settings = SimSettings {
        step_um: args.step_um,
        n_directions: args.n_directions,
        support_friction: if args.support_friction == "polygon" {
            SupportFriction::Polygon
        } else {
            SupportFriction::Coulomb
        },
        ..Default::default()
    };
    let mut sim = Simulator::new(model, fixture, settings)?;
    let what = format!("{}: peg_start", args.plan.display());
    check_start(&mut sim, &what, plan.peg_start_pose(), Some(plan.probe_start()))?;
    if let Some(runs) = args.bench {
        return bench(&mut sim, &plan, runs.max(1), args.json);
    }
    let result = replay(&mut sim, &plan, None)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let csv = args.out.join("trajectory.csv");
    trajectory::save_csv(&result, &csv)?;
    let figs = [args.out.join("fig6.png"), args.out.join("fig6.svg")];
    for f in &figs {
        figure(&sim, &plan, &result, f)?;
    }
    print_result(&result, sim.probe_force_limit_weights(), &csv, &figs, args.json);
    match &result.overload {
        Some(o) => Err(crate::verdict::Negative(o.to_string()).into()),
        None => Ok(()),
    }
}

fn figure(sim: &Simulator, plan: &Plan, r: &Replay, path: &std::path::Path) -> Result<()> {
    Ok(mesopush_plan::figures::draw_replay(sim, plan, r, path)?)
}

fn print_result(
    r: &Replay,
    force_limit_weights: f64,
    csv: &std::path::Path,
    figs: &[PathBuf],
    as_json: bool,
) {
    let p = r.final_pose;
    if as_json {
        let v = json!({
            "inserted": r.inserted,
            "peg_in_goal": r.peg_in_goal,
            "overloaded": r.overload.is_some(),
            "overload": r.overload,
            "final_pose": {"x_um": p.x_um, "y_um": p.y_um, "theta_rad": p.theta_rad},
            "steps": r.steps,
            "lcp_solves": r.lcp_solves,
            "max_penetration_um": r.max_penetration_um,
            "max_probe_deflection_um": r.max_probe_deflection_um,
            "max_probe_force_weights": r.max_probe_force_weights,
            "probe_deflection_limit_um": r.probe_deflection_limit_um,
            "probe_force_limit_weights": force_limit_weights,
            "events": r.events,
            "trajectory_csv": csv,
            "figures": figs,
        });
        println!("{v}");
        return;
    }
    let verdict = match (&r.overload, r.peg_in_goal) {
        (None, true) => "yes",
        (None, false) => "NO",
        (Some(_), true) => "NO (the peg ends in the goal, but the needle is overloaded)",
        (Some(_), false) => "NO (and the needle is overloaded)",
    };
    println!("inserted: {verdict}");
    println!(
        "final pose: x = {:.1} µm, y = {:.1} µm, θ = {:.2}°",
        p.x_um,
        p.y_um,
        p.theta_rad.to_degrees()
    );
    println!(
        "steps: {} ({} LCP solves), max wall penetration {:.3} µm",
        r.steps, r.lcp_solves, r.max_penetration_um
    );
    println!(
        "needle: peak deflection {:.2} µm, peak probe force {:.1} part weights (limit {:.0} µm \
         = {:.0} part weights): {}",
        r.max_probe_deflection_um,
        r.max_probe_force_weights,
        r.probe_deflection_limit_um,
        force_limit_weights,
        if r.overload.is_some() { "OVERLOADED" } else { "within the limit" }
    );
    if let Some(o) = &r.overload {
        println!("{o}");
    }
    for e in &r.events {
        println!("event at t = {:.2} s (move {}): {}", e.t_s, e.move_index + 1, e.what);
    }
    println!("trajectory: {}", csv.display());
    for f in figs {
        println!("figure: {}", f.display());
    }
}

fn bench(sim: &mut Simulator, plan: &Plan, runs: usize, as_json: bool) -> Result<()> {
    let mut replay_ms = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let t0 = Instant::now();
        let r = replay(sim, plan, None)?;
        replay_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        last = Some(r);
    }
    let r = last.context("no run")?;
    // Re-time every LCP step of the replay from its recorded start state.
    let mut step_us = Vec::new();
    for w in r.samples.windows(2) {
        if !w[1].solved_lcp {
            continue;
        }
        let start = SimState::new(w[0].peg, Vec2::from(w[0].probe_um));
        let delta = Vec2::from(w[1].probe_um) - start.probe_um;
        let reps = 20;
        let t0 = Instant::now();
        for _ in 0..reps {
            let mut s = start;
            sim.step(&mut s, delta)?;
        }
        step_us.push(t0.elapsed().as_secs_f64() * 1e6 / reps as f64);
    }
    // Upper medians (measured values); the step median is absent when the plan never
    // touches the peg (no LCP step to time).
    let rm = percentile(&mut replay_ms, 0.5).context("no run")?;
    let (sm, s90) = (percentile(&mut step_us, 0.5), percentile(&mut step_us, 0.9));
    if as_json {
        let v = json!({"replay_ms_median": rm, "step_us_median": sm, "step_us_p90": s90,
                        "runs": runs, "lcp_steps": step_us.len(), "steps": r.steps,
                        "step_us_mean_in_replay": rm * 1e3 / r.steps.max(1) as f64});
        println!("{v}");
    } else {
        println!("replay: {rm:.3} ms median over {runs} runs ({} steps)", r.steps);
        match (sm, s90) {
            (Some(sm), Some(s90)) => println!(
                "step:   {sm:.2} µs median (p90 {s90:.2}) over {} LCP steps re-timed in place \
                 (warm start); {:.2} µs per step on average inside a replay",
                step_us.len(),
                rm * 1e3 / r.steps.max(1) as f64
            ),
            _ => println!("step:   no LCP step to time (the plan never touches the peg)"),
        }
    }
    Ok(())
}
