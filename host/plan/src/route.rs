//! Probe repositioning between pushes: a shortest axis-aligned path from where the last push
//! left the probe to where the next one starts, clear of the peg and the walls.
//!
//! The executor streams one connected probe path, so a plan must carry these moves. Candidate
//! corners lie on a sparse grid of x and y levels (the two ends, the peg's bounding box and
//! the wall vertices, each pushed out by a clearance); Dijkstra over (corner, axis) states
//! with a penalty per turn finds a short path with few moves.

use super::clearance::Obstacles;
use mesopush_core::geom::Vec2;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Cost of one extra move (a turn), in µm of travel.
const TURN_PENALTY_UM: f64 = 200.0;
/// How far candidate levels sit outside the peg's box and the wall corners, µm.
const LEVEL_OFFSET_UM: f64 = 70.0;

#[derive(Debug, PartialEq)]
struct Entry {
    cost: f64,
    state: usize,
}
impl Eq for Entry {}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.cost.total_cmp(&self.cost).then(other.state.cmp(&self.state))
    }
}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

fn levels(ends: [f64; 2], extra: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = ends.into_iter().chain(extra).collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() < 1.0);
    v
}

/// The axis-aligned moves (µm) that take the probe from `from` to `to` without touching
/// `obstacles`, or `None` when the grid holds no such path. Collinear moves are merged.
pub fn route(from: Vec2, to: Vec2, obstacles: &Obstacles<'_>) -> Option<Vec<[f64; 2]>> {
    if (from - to).norm() < 1e-9 {
        return Some(Vec::new());
    }
    if !(obstacles.point_free(&from) && obstacles.point_free(&to)) {
        return None;
    }
    let off = LEVEL_OFFSET_UM + obstacles.probe_radius_um;
    let mut corners: Vec<Vec2> =
        obstacles.walls.iter().flat_map(|w| w.vertices().to_vec()).collect();
    if let Some(peg) = obstacles.peg {
        let (lo, hi) = peg.bounds();
        corners.extend([lo, hi]);
    }
    let xs = levels([from.x, to.x], corners.iter().flat_map(|c| [c.x - off, c.x + off]));
    let ys = levels([from.y, to.y], corners.iter().flat_map(|c| [c.y - off, c.y + off]));
    let (nx, ny) = (xs.len(), ys.len());
    let node = |i: usize, j: usize| i * ny + j;
    let pos = |n: usize| Vec2::new(xs[n / ny], ys[n % ny]);
    let free: Vec<bool> = (0..nx * ny).map(|n| obstacles.point_free(&pos(n))).collect();
    let find = |p: Vec2| {
        let i = xs.iter().position(|x| (x - p.x).abs() < 1.0)?;
        let j = ys.iter().position(|y| (y - p.y).abs() < 1.0)?;
        Some(node(i, j))
    };
    let (start, goal) = (find(from)?, find(to)?);
    // State = node * 2 + axis of the move that reached it (0: x, 1: y).
    let mut dist = vec![f64::INFINITY; nx * ny * 2];
    let mut prev = vec![usize::MAX; nx * ny * 2];
    let mut heap = BinaryHeap::new();
    for axis in 0..2 {
        dist[start * 2 + axis] = 0.0;
        heap.push(Entry { cost: 0.0, state: start * 2 + axis });
    }
    while let Some(Entry { cost, state }) = heap.pop() {
        if cost > dist[state] {
            continue;
        }
        let (n, axis) = (state / 2, state % 2);
        if n == goal {
            return Some(unwind(state, &prev, start, pos));
        }
        let (i, j) = (n / ny, n % ny);
        let mut neighbours = Vec::with_capacity(4);
        if i > 0 {
            neighbours.push((node(i - 1, j), 0));
        }
        if i + 1 < nx {
            neighbours.push((node(i + 1, j), 0));
        }
        if j > 0 {
            neighbours.push((node(i, j - 1), 1));
        }
        if j + 1 < ny {
            neighbours.push((node(i, j + 1), 1));
        }
        for (m, a) in neighbours {
            if !free[m] || !obstacles.segment_free(&pos(n), &pos(m)) {
                continue;
            }
            let turn = if a == axis || n == start { 0.0 } else { TURN_PENALTY_UM };
            let c = cost + (pos(m) - pos(n)).norm() + turn;
            if c < dist[m * 2 + a] {
                dist[m * 2 + a] = c;
                prev[m * 2 + a] = state;
                heap.push(Entry { cost: c, state: m * 2 + a });
            }
        }
    }
    None
}

fn unwind(goal: usize, prev: &[usize], start: usize, pos: impl Fn(usize) -> Vec2) -> Vec<[f64; 2]> {
    let mut pts = vec![pos(goal / 2)];
    let mut s = goal;
    while s / 2 != start {
        s = prev[s];
        pts.push(pos(s / 2));
    }
    pts.reverse();
    merge_moves(pts.windows(2).map(|w| [w[1].x - w[0].x, w[1].y - w[0].y]))
}

/// Joins consecutive moves along the same axis and direction and drops zero moves.
pub fn merge_moves(moves: impl IntoIterator<Item = [f64; 2]>) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::new();
    for m in moves {
        if m[0].abs() < 1e-9 && m[1].abs() < 1e-9 {
            continue;
        }
        if let Some(last) = out.last_mut() {
            let same_x = last[1] == 0.0 && m[1] == 0.0 && last[0] * m[0] > 0.0;
            let same_y = last[0] == 0.0 && m[0] == 0.0 && last[1] * m[1] > 0.0;
            if same_x || same_y {
                last[0] += m[0];
                last[1] += m[1];
                continue;
            }
        }
        out.push(m);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::ConvexPolygon;

    #[test]
    fn route_goes_around_a_block_and_ends_where_asked() {
        let block =
            ConvexPolygon::rectangle(400.0, 400.0).unwrap().translated(&Vec2::new(1000.0, 1000.0));
        let obstacles = Obstacles {
            walls: &[],
            peg: Some(&block),
            probe_radius_um: 12.5,
            peg_clearance_um: 40.0,
        };
        let (a, b) = (Vec2::new(500.0, 1000.0), Vec2::new(1500.0, 1000.0));
        let moves = route(a, b, &obstacles).expect("a way around");
        assert!(moves.len() >= 3, "{moves:?}");
        let mut p = a;
        for m in &moves {
            let q = p + Vec2::new(m[0], m[1]);
            assert!(obstacles.segment_free(&p, &q));
            p = q;
        }
        assert!((p - b).norm() < 1e-9);
    }
}
