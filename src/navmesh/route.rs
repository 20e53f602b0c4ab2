//! Point-to-point routes for users and later stages: snap both points, find the shortest
//! path, and report it between the points themselves (not the span centres).
//!
//! [`route`] answers one query; [`route_in`] and [`route_many`] answer many on one grid with
//! the query structures ([`Geodesic`]: line-of-sight index, sparse graph, search records)
//! built once and shared. Every function gives the same answer for the same pair.

use glam::Vec3;
use rayon::prelude::*;

use super::geodesic::Geodesic;
use super::grid::NavGrid;
use super::path::{shortest_path, shortest_path_in, PathResult};
use crate::scene::RoomClass;

/// A route between two world points.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// Both points lie on one island.
    pub reachable: bool,
    /// Length of the path (m), `None` when unreachable.
    pub geodesic: Option<f32>,
    /// Rooms passed, in order (indices into `grid.rooms`).
    pub rooms: Vec<u32>,
    /// Doors passed, in order (indices into `grid.objects`).
    pub doors: Vec<u32>,
    /// The polyline from `from` to `to` (empty when unreachable).
    pub points: Vec<Vec3>,
}

impl Route {
    /// `(id, class name)` of the rooms the route passes, in order, as `minos nav query` and
    /// the bindings' path finder name them (`other` for a class minos does not know).
    pub fn room_names(&self, grid: &NavGrid) -> Vec<(String, String)> {
        self.rooms
            .iter()
            .filter_map(|&i| grid.rooms.get(i as usize))
            .map(|room| {
                let class = RoomClass::ALL
                    .get(room.class as usize)
                    .map_or("other", |c| c.name());
                (room.id.clone(), class.to_string())
            })
            .collect()
    }

    /// Ids of the doors the route passes, in order.
    pub fn door_ids(&self, grid: &NavGrid) -> Vec<String> {
        self.doors
            .iter()
            .filter_map(|&i| grid.objects.get(i as usize))
            .map(|door| door.id.clone())
            .collect()
    }
}

/// A route endpoint that is not near walkable floor.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{which} point ({:.2}, {:.2}, {:.2}) is not within 2 m of walkable floor", point.x, point.y, point.z)]
pub struct NotWalkable {
    /// `start` or `goal`.
    pub which: &'static str,
    /// The point.
    pub point: Vec3,
}

/// The shortest route from `from` to `to` (y = floor height under the agent). Builds the
/// query structures for this one query; see [`route_in`] for many.
pub fn route(grid: &NavGrid, from: Vec3, to: Vec3) -> Result<Route, NotWalkable> {
    let (a, b) = snap_both(grid, from, to)?;
    Ok(finish(grid, from, to, a, b, shortest_path(grid, a, b)))
}

/// [`route`] with the query structures of `geo`'s grid built beforehand.
pub fn route_in(geo: &Geodesic<'_>, from: Vec3, to: Vec3) -> Result<Route, NotWalkable> {
    let grid = geo.grid();
    let (a, b) = snap_both(grid, from, to)?;
    Ok(finish(grid, from, to, a, b, shortest_path_in(geo, a, b)))
}

/// [`route_in`] for every `(from, to)` pair, in parallel on the current rayon pool; the
/// answers are in the pairs' order whatever the thread count.
pub fn route_many(geo: &Geodesic<'_>, pairs: &[(Vec3, Vec3)]) -> Vec<Result<Route, NotWalkable>> {
    pairs
        .par_iter()
        .map(|&(from, to)| route_in(geo, from, to))
        .collect()
}

/// Both endpoints snapped to walkable spans.
fn snap_both(grid: &NavGrid, from: Vec3, to: Vec3) -> Result<(u32, u32), NotWalkable> {
    let a = grid.snap(from).ok_or(NotWalkable {
        which: "start",
        point: from,
    })?;
    let b = grid.snap(to).ok_or(NotWalkable {
        which: "goal",
        point: to,
    })?;
    Ok((a, b))
}

/// The route of a path search between spans `a` (snapped from `from`) and `b` (from `to`).
fn finish(grid: &NavGrid, from: Vec3, to: Vec3, a: u32, b: u32, result: PathResult) -> Route {
    match result {
        PathResult::Unreachable => Route {
            reachable: false,
            geodesic: None,
            rooms: vec![],
            doors: vec![],
            points: vec![],
        },
        PathResult::Found(p) => {
            let mut points = p.points.clone();
            // Start and end at the points themselves, on the floor of their spans.
            let ya = grid.spans[a as usize].y;
            let yb = grid.spans[b as usize].y;
            if let Some(first) = points.first_mut() {
                *first = Vec3::new(from.x, ya, from.z);
            }
            if points.len() == 1 {
                points.push(Vec3::new(to.x, yb, to.z));
            } else if let Some(last) = points.last_mut() {
                *last = Vec3::new(to.x, yb, to.z);
            }
            let length = points.windows(2).map(|w| w[0].distance(w[1])).sum();
            Route {
                reachable: true,
                geodesic: Some(length),
                rooms: p.rooms,
                doors: p.doors,
                points,
            }
        }
    }
}
