//! Draws the dimensioned figure of the reconstructed fixture for `docs/fixture.md`:
//! `cargo run --release -p mesopush-plot --example fixture_figure -- docs/img/fixture.png`.

use mesopush_plot::draw_fixture;
use mesopush_sim::fixture::PaperFixtureParams;
use mesopush_sim::{Fixture, Model, Plan};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map_or_else(|| PathBuf::from("fixture.png"), PathBuf::from);
    let p = PaperFixtureParams::default();
    let fixture = Fixture::paper_with(&p)?;
    let model = Model::default();
    draw_fixture(&p, &fixture.walls, model.part.polygon(), &Plan::table2().peg_start_pose(), &out)?;
    Ok(())
}
