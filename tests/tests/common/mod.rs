//! What the tests that hold the project against the independent generator share: the
//! generator's world as the project's model, for checks (never for making data).

use mesopush_core::geom::ConvexPolygon;
use mesopush_sim::{Model, Part, SupportDistribution};
use mesopush_tests::indep::world::World;

/// The generator's world (three supports: the peg and the pentagon) as the project's model:
/// its outline, true supports, frictions and needle radius.
pub(crate) fn project_model(world: &World) -> Model {
    let poly = ConvexPolygon::try_from(world.outline_um.clone()).unwrap();
    let p = |k: usize| world.supports[k].at_um;
    Model {
        part: Part::from_polygon(&poly),
        support: SupportDistribution {
            points_um: [p(0), p(1), p(2)],
            mu_surface: [world.mu_support; 3],
        },
        mu_probe: world.mu_pusher,
        probe_radius_um: world.pusher_radius_um,
        ..Model::default()
    }
}
