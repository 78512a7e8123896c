//! Path shortcutting after the RRT search. A random tree's branch carries detours (the paper's
//! plans have 7–10 pushes, a raw branch here a median of 13), so the found branch is
//! shortened greedily and deterministically (no random choice, so the plan stays fixed by the
//! seed):
//!
//! - first connect earlier nodes of the branch straight to the goal (the earliest that works);
//! - drop one push of the branch (then, when no single drop helps, two consecutive ones), keep
//!   the pushes before it as they are and replay the ones after it, each re-aimed at the
//!   peg's new pose from the same boundary location, along the same axis and for the same
//!   length (the goal connection's pushes too);
//! - after every replayed push, also try the direct goal connection (centre on the channel,
//!   push in) aimed at the new pose, which may end the plan early;
//! - the goal connection here accepts poses within
//!   [`RrtSettings::shortcut_connect_theta_deg`] of the channel's axis, wider than the
//!   search's window (the chamfers square a turned peg; every kept plan is verified);
//! - keep the change only when it has fewer pushes and the **whole plan, replayed from the
//!   start**, inserts the peg and keeps the probe out of the walls ([`Steer::verify`], the
//!   same check the search uses); start again from the shorter branch until no single drop
//!   helps or the attempt cap is reached.

use crate::Error;
use crate::rrt_settings::RrtSettings;
use crate::steer::Steer;
use crate::tree::Tree;

/// One push of a branch: (boundary location, direction, length after touching in µm).
pub type Push = (usize, usize, f64);

/// The pushes of `tree`'s branch from the root to `leaf`, in order.
pub fn branch_pushes(tree: &Tree, leaf: usize) -> Vec<Push> {
    tree.branch(leaf)
        .iter()
        .skip(1)
        .map(|&i| {
            let n = &tree.nodes[i];
            (n.location, n.direction, n.length_um)
        })
        .collect()
}

/// A tree holding only the branch from the root to `leaf` (node `k` at depth `k`); returns it
/// and its leaf.
pub fn branch_tree(tree: &Tree, leaf: usize) -> (Tree, usize) {
    let branch = tree.branch(leaf);
    let nodes = branch
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            let mut n = tree.nodes[i].clone();
            n.parent = k.checked_sub(1);
            n
        })
        .collect();
    (Tree { nodes }, branch.len() - 1)
}

/// What the shortcut pass did.
#[derive(Debug, Clone)]
pub struct Shortcut {
    /// The tree holding the shortened branch.
    pub tree: Tree,
    /// Its inserted leaf.
    pub leaf: usize,
    /// Drops tried.
    pub attempts: usize,
}

/// Shortens the branch from the root of `tree` to its inserted, verified `leaf`, trying at
/// most [`RrtSettings::shortcut_attempts`] changes; never returns more pushes than the branch
/// had.
pub fn shortcut(
    steer: &mut Steer<'_>,
    tree: &Tree,
    leaf: usize,
    settings: &RrtSettings,
) -> Result<Shortcut, Error> {
    let (max_attempts, speed_um_s) = (settings.shortcut_attempts, settings.speed_um_s);
    let theta = settings.shortcut_connect_theta_deg;
    let (mut best, mut best_leaf) = branch_tree(tree, leaf);
    let mut attempts = 0;
    // Earlier nodes straight to the goal connection, earliest first (the fewest pushes).
    for i in 0..best_leaf.saturating_sub(1) {
        if attempts >= max_attempts {
            break;
        }
        attempts += 1;
        let (mut t, n) = branch_tree(&best, best_leaf);
        if let Some(l) = connect_verified(steer, &mut t, i, n, theta, speed_um_s)? {
            (best, best_leaf) = branch_tree(&t, l);
            break;
        }
    }
    'shorter: loop {
        let chain = branch_pushes(&best, best_leaf);
        let n = chain.len();
        // Drop pushes k..k + w (node k is the pose before push k, node 0 the root).
        for (w, k) in (1..=2).flat_map(|w| (0..(n + 1).saturating_sub(w)).map(move |k| (w, k))) {
            if attempts >= max_attempts {
                break 'shorter;
            }
            attempts += 1;
            let (mut t, _) = branch_tree(&best, best_leaf);
            if let Some(l) = realise(steer, &mut t, k, &chain[k + w..], n, theta, speed_um_s)? {
                (best, best_leaf) = branch_tree(&t, l);
                continue 'shorter;
            }
        }
        break;
    }
    Ok(Shortcut { tree: best, leaf: best_leaf, attempts })
}

/// Replays `rest` from node `from` of `tree`, trying the goal connection (window `theta_deg`)
/// after each push; returns the first inserted leaf with fewer than `limit` pushes whose whole
/// plan verifies.
fn realise(
    steer: &mut Steer<'_>,
    tree: &mut Tree,
    from: usize,
    rest: &[Push],
    limit: usize,
    theta_deg: f64,
    speed_um_s: f64,
) -> Result<Option<usize>, Error> {
    let mut at = from;
    for &(location, direction, length_um) in rest {
        // A connection adds at least one push: from depth limit − 1 on nothing can be shorter.
        if tree.nodes[at].depth + 1 >= limit {
            return Ok(None);
        }
        let node = tree.nodes[at].clone();
        let Some(ext) = steer.push_from(&node, location, direction, length_um)? else {
            return Ok(None);
        };
        let inserted = ext.inserted;
        at = steer.add(tree, at, ext);
        if inserted {
            return verified(steer, tree, at, speed_um_s);
        }
        if let Some(l) = connect_verified(steer, tree, at, limit, theta_deg, speed_um_s)? {
            return Ok(Some(l));
        }
    }
    Ok(None)
}

/// The goal connection from node `at` (window `theta_deg`) when it inserts with fewer than
/// `limit` pushes and the whole plan verifies.
fn connect_verified(
    steer: &mut Steer<'_>,
    tree: &mut Tree,
    at: usize,
    limit: usize,
    theta_deg: f64,
    speed_um_s: f64,
) -> Result<Option<usize>, Error> {
    let (leaf, inserted, _) = steer.connect_within(tree, at, theta_deg)?;
    match (leaf, inserted) {
        (Some(leaf), true) if tree.nodes[leaf].depth < limit => {
            verified(steer, tree, leaf, speed_um_s)
        }
        _ => Ok(None),
    }
}

/// `leaf` when the plan to it verifies.
fn verified(
    steer: &mut Steer<'_>,
    tree: &Tree,
    leaf: usize,
    speed_um_s: f64,
) -> Result<Option<usize>, Error> {
    let plan = tree.plan_to(leaf, "shortcut", speed_um_s);
    Ok(steer.verify(&plan)?.then_some(leaf))
}
