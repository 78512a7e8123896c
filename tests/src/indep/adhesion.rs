//! Adhesion between the needle and the part as an elastic bond: once the needle has pushed
//! the part, a bond forms; while the needle moves away its force is
//! `pull_off · gap / range`, and it breaks when the gap exceeds `range`. Quasi-statically
//! the part stays while the bond's force is below what dragging it needs, and is dragged at
//! the gap where the two are equal; a drag that needs more than the pull-off force never
//! happens (the bond stretches and breaks).

use crate::coulomb::{self, Part, Pose, Pusher, Settings, V2};
use std::ops::Add;

/// The bond's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bond {
    /// Force at break, part weights.
    pub pull_off_weight: f64,
    /// Gap at break, µm.
    pub range_um: f64,
}

/// One increment `dp` of a bonded needle at `p` leaving the part: the part's pose after it
/// and whether the bond still holds.
pub fn bonded_increment(
    part: &Part,
    pusher: &Pusher,
    pose: Pose,
    p: V2,
    dp: V2,
    bond: &Bond,
    s: &Settings,
) -> (Pose, bool) {
    let (gap_now, ..) = coulomb::contact(part, &pose, p, pusher.radius);
    let (gap_still, ..) = coulomb::contact(part, &pose, p.add(dp), pusher.radius);
    if gap_still <= gap_now {
        // Not leaving (sideways or back in): the bond carries no load this increment.
        return (pose, gap_still <= bond.range_um);
    }
    let hold = gap_now.max(0.0);
    let Some(held) = coulomb::drag(part, pusher, pose, p, dp, hold, s) else {
        return (pose, gap_still <= bond.range_um);
    };
    let needed = held.f_n.hypot(held.f_t);
    let gap_eq = bond.range_um * needed / bond.pull_off_weight;
    if held.f_n >= 0.0 || gap_eq > bond.range_um || gap_still < gap_eq {
        // A drag that would push, or needs more than the bond gives: the part stays.
        return (pose, gap_still <= bond.range_um);
    }
    match coulomb::drag(part, pusher, pose, p, dp, gap_eq, s) {
        Some(d) => (d.pose, true),
        None => (held.pose, true),
    }
}
