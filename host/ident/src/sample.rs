//! Random three-point supports as the paper draws them: three points inside the part whose
//! triangle spans the centre of mass. Points are uniform over the part (rejection from its
//! bounding box); a triangle is kept when every support carries at least `min_weight` of the
//! part's weight, which keeps away from degenerate triangles the statics cannot resolve.

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Vec2};
use mesopush_sim::SupportDistribution;
use rand::{Rng, RngExt};

/// Smallest share of the weight a sampled support may carry. Default for [`sample_supports`].
pub const MIN_WEIGHT: f64 = 0.02;

/// A point uniform over `poly` (rejection from its bounding box; bounded attempts).
fn point_in(poly: &ConvexPolygon, rng: &mut impl Rng) -> Option<Vec2> {
    let (lo, hi) = poly.bounds();
    for _ in 0..1000 {
        let p = Vec2::new(rng.random_range(lo.x..=hi.x), rng.random_range(lo.y..=hi.y));
        if poly.contains(&p, 0.0) {
            return Some(p);
        }
    }
    None
}

/// Whether `s` is a support the sampler would accept on `part`.
pub fn acceptable(s: &SupportDistribution, part: &ConvexPolygon, min_weight: f64) -> bool {
    s.validate(part).is_ok_and(|f| f.iter().all(|w| *w >= min_weight))
}

/// `n` random supports inside `part` (body frame, COM at the origin) spanning the COM, each
/// with surface friction `mu_surface` at all three points.
pub fn sample_supports(
    part: &ConvexPolygon,
    n: usize,
    mu_surface: f64,
    rng: &mut impl Rng,
) -> Result<Vec<SupportDistribution>, Error> {
    let mut out = Vec::with_capacity(n);
    let mut tries = 0usize;
    while out.len() < n {
        tries += 1;
        if tries > 1000 * (n + 10) {
            return Err(Error::invalid(
                "support sampling",
                format!("found only {} of {n} supports spanning the COM", out.len()),
            ));
        }
        let mut pts = [[0.0; 2]; 3];
        for p in &mut pts {
            let v = point_in(part, rng)
                .ok_or_else(|| Error::invalid("support sampling", "the part has no area"))?;
            *p = [v.x, v.y];
        }
        let s = SupportDistribution { points_um: pts, mu_surface: [mu_surface; 3] };
        if acceptable(&s, part, MIN_WEIGHT) {
            out.push(s);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn samples_lie_inside_span_the_com_and_follow_the_seed() {
        let part = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        let part = part.translated(&-part.centroid());
        let draw = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            sample_supports(&part, 50, 0.3, &mut rng).unwrap()
        };
        let a = draw(3);
        assert_eq!(a.len(), 50);
        assert_eq!(a, draw(3));
        assert_ne!(a, draw(4));
        for s in &a {
            let f = s.validate(&part).unwrap();
            assert!(f.iter().all(|w| *w >= MIN_WEIGHT), "{f:?}");
        }
    }
}
