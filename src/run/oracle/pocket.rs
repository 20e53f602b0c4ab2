//! Pockets: floor the body reaches but the goal's distance field does not. The grid is eroded
//! and rasterised more coarsely than the body is shaped, so a body squeezes through gaps the
//! grid closes (a cabinet beside an open door's leaf, furniture in a corner); when another
//! driver (a learner in DAgger, a person) has led the agent into such a pocket, both planners
//! start with a search for the way out, guided by [`way_out`]: a walk over a fine lattice of
//! the positions where the body fits (within a skin as thin as the lattice is fine), to the
//! first the field reaches. When that search fails,
//! or momentum carries the body on into a pocket whatever it does, the continuous planner
//! searches on to a *steady* state (one some action keeps on the field), its heuristic
//! counting the turns to head along the walk as well.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::BuildHasherDefault;

use glam::Vec3;

use crate::sim::Simulator;

use super::KeyHasher;

/// Spacing (m) of the lattice [`way_out`] walks: fine enough that a gap the body passes
/// with a few centimetres to spare has a lattice line through it.
const POCKET_CELL: f32 = 0.02;
/// How deep (m) a lattice point may overlap the scene: the body slides along what it touches,
/// so it passes gaps with no room to spare that a lattice, however fine, may have no point
/// in; half a lattice step of overlap puts one in every gap the body passes.
const POCKET_SKIN: f32 = 0.5 * POCKET_CELL;
/// How far (m) from the agent [`way_out`] looks.
const POCKET_REACH: f32 = 2.0;

/// The way out of a pocket: lattice points from the agent to the first the goal's field
/// reaches, with the length of the walk left from each.
#[derive(Debug)]
pub(super) struct WayOut {
    points: Vec<Vec3>,
    left: Vec<f32>,
}

impl WayOut {
    /// The length (m) of a way from `p` out of the pocket: to a point of the walk, then
    /// along it.
    pub(super) fn from(&self, p: Vec3) -> f32 {
        self.joined(p).1
    }

    /// Where to head from `p`: the first point of the walk at least `reach` away after the
    /// one [`WayOut::from`] joins it at, else the walk's end.
    pub(super) fn ahead(&self, p: Vec3, reach: f32) -> Vec3 {
        let (i, _) = self.joined(p);
        let rest = self.points.get(i..).unwrap_or_default();
        rest.iter()
            .find(|q| flat(**q, p) >= reach)
            .or(rest.last())
            .copied()
            .unwrap_or(p)
    }

    /// The index of the point where the way from `p` joins the walk, and the way's length.
    fn joined(&self, p: Vec3) -> (usize, f32) {
        self.points
            .iter()
            .zip(&self.left)
            .map(|(q, l)| flat(*q, p) + l)
            .enumerate()
            .fold((0, f32::INFINITY), |best, (i, len)| {
                if len < best.1 {
                    (i, len)
                } else {
                    best
                }
            })
    }
}

/// Horizontal distance (m) between `a` and `b`.
fn flat(a: Vec3, b: Vec3) -> f32 {
    Vec3::new(a.x - b.x, 0.0, a.z - b.z).length()
}

/// The body's own way out of a pocket of floor the goal's field does not reach (the grid is
/// eroded and rasterised more coarsely than the body is shaped, so the body squeezes through
/// gaps the grid closes): a shortest 8-connected walk over a [`POCKET_CELL`] lattice around
/// `from`, through positions where the body overlaps nothing deeper than [`POCKET_SKIN`], to
/// the first position the field reaches; `None` when there is none within [`POCKET_REACH`].
pub(super) fn way_out(sim: &Simulator, from: Vec3) -> Option<WayOut> {
    let collision = &sim.assets().collision;
    let r = (POCKET_REACH / POCKET_CELL) as i32;
    let at = |c: (i32, i32)| {
        Vec3::new(
            from.x + c.0 as f32 * POCKET_CELL,
            from.y,
            from.z + c.1 as f32 * POCKET_CELL,
        )
    };
    // Each cell's cost in hundredths of a cell (100 straight, 141 diagonal) and the cell
    // it was reached from.
    type Cell = (i32, i32);
    let mut cost: HashMap<Cell, (u32, Cell), BuildHasherDefault<KeyHasher>> = HashMap::default();
    let mut open = BinaryHeap::new();
    cost.insert((0, 0), (0, (0, 0)));
    open.push(Reverse((0u32, (0i32, 0i32))));
    while let Some(Reverse((c, cell))) = open.pop() {
        if cost.get(&cell).is_some_and(|&(b, _)| b < c) {
            continue;
        }
        if sim.goal_field_distance(at(cell)).is_some() {
            let mut points = vec![at(cell)];
            let mut cur = cell;
            while cur != (0, 0) {
                cur = cost[&cur].1;
                points.push(at(cur));
            }
            points.reverse();
            let mut left = vec![0.0; points.len()];
            for i in (0..points.len().saturating_sub(1)).rev() {
                left[i] = left[i + 1] + points[i].distance(points[i + 1]);
            }
            return Some(WayOut { points, left });
        }
        for (dx, dz) in [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ] {
            let next = (cell.0 + dx, cell.1 + dz);
            if next.0.abs() > r || next.1.abs() > r {
                continue;
            }
            let nc = c + if dx != 0 && dz != 0 { 141 } else { 100 };
            if cost.get(&next).is_some_and(|&(b, _)| b <= nc)
                || collision.blocked_beyond(at(next), POCKET_SKIN)
            {
                continue;
            }
            cost.insert(next, (nc, cell));
            open.push(Reverse((nc, next)));
        }
    }
    None
}
