//! Test-only navigation grids built from ASCII maps, and exact geometric references.
//!
//! [`MapSpec`] turns rows of characters into a [`NavGrid`] the way the real builder promises
//! to: spans per column sorted by height, symmetric links between walkable spans within
//! `max_climb`, diagonal links only where both orthogonal paths exist, clearance, islands,
//! rooms and door objects. Characters: `' '` no span, `'#'` a non-walkable span, `'.'` floor,
//! `'a'..='z'` floor of room `letter - 'a'`, `'A'..='Z'` floor under door object `door_<L>`
//! (doors are numbered in alphabetical order), `'*'` floor under a table (not a door).
//!
//! The references work on the raster alone, with exact integer geometry: whether a segment
//! touches a closed cell, whether it stays inside the union of free cells, and the exact
//! shortest path through that union (a visibility graph over its reflex corners).

use super::grid::{Island, NavGrid, NavObject, NavRoom, Span, DIRS, NONE};
use super::params::NavParams;

/// A test map: per column the `(height, character)` of each span, ground span first.
#[derive(Debug, Clone)]
pub(crate) struct MapSpec {
    pub nx: usize,
    pub nz: usize,
    pub cell: f32,
    cols: Vec<Vec<(f32, char)>>,
}

impl MapSpec {
    /// Ground layer at height 0 from rows (row index = z, character index = x).
    pub fn ascii(rows: &[&str], cell: f32) -> Self {
        let nz = rows.len();
        let nx = rows.iter().map(|r| r.chars().count()).max().unwrap_or(0);
        let mut cols = vec![Vec::new(); nx * nz];
        for (iz, row) in rows.iter().enumerate() {
            for (ix, ch) in row.chars().enumerate() {
                if ch != ' ' {
                    cols[iz * nx + ix].push((0.0, ch));
                }
            }
        }
        MapSpec { nx, nz, cell, cols }
    }

    /// Adds a span of character `ch` at height `y` to column `(ix, iz)`.
    pub fn add(&mut self, ix: usize, iz: usize, y: f32, ch: char) {
        self.cols[iz * self.nx + ix].push((y, ch));
    }

    /// Sets the height of the ground (first added) span of a column.
    pub fn set_height(&mut self, ix: usize, iz: usize, y: f32) {
        self.cols[iz * self.nx + ix][0].0 = y;
    }

    /// Sets the character of the ground span in the rectangle `[x0, x1) x [z0, z1)`,
    /// creating ground spans (height 0) where there are none; `' '` removes them.
    pub fn fill(&mut self, x0: usize, z0: usize, x1: usize, z1: usize, ch: char) {
        for iz in z0..z1.min(self.nz) {
            for ix in x0..x1.min(self.nx) {
                let col = &mut self.cols[iz * self.nx + ix];
                if ch == ' ' {
                    col.clear();
                } else if col.is_empty() {
                    col.push((0.0, ch));
                } else {
                    col[0].1 = ch;
                }
            }
        }
    }

    /// The character of the ground span of a column (`' '` when none).
    pub fn ground(&self, ix: usize, iz: usize) -> char {
        self.cols[iz * self.nx + ix].first().map_or(' ', |s| s.1)
    }

    /// Is the ground of cell `(ix, iz)` walkable floor (any character but `'#'` and `' '`)?
    pub fn free(&self, ix: i64, iz: i64) -> bool {
        ix >= 0
            && iz >= 0
            && (ix as usize) < self.nx
            && (iz as usize) < self.nz
            && !matches!(self.ground(ix as usize, iz as usize), '#' | ' ')
    }

    /// Builds the grid.
    pub fn build(&self, params: NavParams) -> NavGrid {
        let (nx, nz) = (self.nx, self.nz);
        let mut column_start = Vec::with_capacity(nx * nz + 1);
        let mut spans: Vec<Span> = Vec::new();
        let mut chars: Vec<char> = Vec::new();
        let mut door_letters: Vec<char> = self
            .cols
            .iter()
            .flatten()
            .map(|s| s.1)
            .filter(char::is_ascii_uppercase)
            .collect();
        door_letters.sort_unstable();
        door_letters.dedup();
        let max_room = self
            .cols
            .iter()
            .flatten()
            .filter(|s| s.1.is_ascii_lowercase())
            .map(|s| s.1 as u32 - 'a' as u32)
            .max();
        for col in &self.cols {
            column_start.push(spans.len() as u32);
            let mut sorted = col.clone();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (i, &(y, ch)) in sorted.iter().enumerate() {
                let headroom = sorted.get(i + 1).map_or(f32::INFINITY, |n| n.0 - y);
                let walkable = ch != '#' && headroom >= params.body.height;
                let room = if ch.is_ascii_lowercase() {
                    ch as u32 - 'a' as u32
                } else {
                    NONE
                };
                spans.push(Span {
                    y,
                    headroom,
                    clearance: 0.0,
                    links: [NONE; 8],
                    walkable,
                    room,
                    island: NONE,
                    level: 0,
                });
                chars.push(ch);
            }
        }
        column_start.push(spans.len() as u32);
        let col_of = |ix: i64, iz: i64| -> Option<usize> {
            (ix >= 0 && iz >= 0 && (ix as usize) < nx && (iz as usize) < nz)
                .then(|| iz as usize * nx + ix as usize)
        };
        // Orthogonal links: the nearest walkable span within max_climb.
        for iz in 0..nz as i64 {
            for ix in 0..nx as i64 {
                let c = iz as usize * nx + ix as usize;
                for s in column_start[c] as usize..column_start[c + 1] as usize {
                    if !spans[s].walkable {
                        continue;
                    }
                    for (d, &(dx, dz)) in DIRS.iter().enumerate().take(4) {
                        let Some(nc) = col_of(ix + dx as i64, iz + dz as i64) else {
                            continue;
                        };
                        let y = spans[s].y;
                        let best = (column_start[nc] as usize..column_start[nc + 1] as usize)
                            .filter(|&t| {
                                spans[t].walkable && (spans[t].y - y).abs() <= params.body.max_climb
                            })
                            .min_by(|&p, &q| {
                                (spans[p].y - y).abs().total_cmp(&(spans[q].y - y).abs())
                            });
                        if let Some(t) = best {
                            spans[s].links[d] = t as u32;
                        }
                    }
                }
            }
        }
        // Diagonals where both orthogonal paths exist and meet.
        for s in 0..spans.len() {
            for (d, &(dx, dz)) in DIRS.iter().enumerate().skip(4) {
                let xd = if dx > 0 { 0 } else { 2 };
                let zd = if dz > 0 { 1 } else { 3 };
                let step = |from: u32, dir: usize| -> u32 {
                    if from == NONE {
                        NONE
                    } else {
                        spans[from as usize].links[dir]
                    }
                };
                let c1 = step(step(s as u32, xd), zd);
                let c2 = step(step(s as u32, zd), xd);
                if c1 != NONE && c1 == c2 {
                    spans[s].links[d] = c1;
                }
            }
        }
        // Clearance (only the weighted mode reads it): distance from the centre to the
        // nearest cell without walkable ground.
        let window = if params.clearance_weight > 1.0 {
            12i64
        } else {
            0
        };
        for iz in 0..nz as i64 {
            for ix in 0..nx as i64 {
                let c = iz as usize * nx + ix as usize;
                for s in column_start[c] as usize..column_start[c + 1] as usize {
                    if !spans[s].walkable {
                        continue;
                    }
                    let mut best = window as f32 * self.cell;
                    for jz in iz - window..=iz + window {
                        for jx in ix - window..=ix + window {
                            let blocked = match col_of(jx, jz) {
                                None => true,
                                Some(j) => !(column_start[j]..column_start[j + 1])
                                    .any(|t| spans[t as usize].walkable),
                            };
                            if blocked {
                                let gx = ((jx - ix).abs() as f32 - 0.5).max(0.0);
                                let gz = ((jz - iz).abs() as f32 - 0.5).max(0.0);
                                best = best.min((gx * gx + gz * gz).sqrt() * self.cell);
                            }
                        }
                    }
                    spans[s].clearance = best;
                }
            }
        }
        // Islands: flood fill over links.
        let mut islands = Vec::new();
        let mut stack = Vec::new();
        for s in 0..spans.len() {
            if !spans[s].walkable || spans[s].island != NONE {
                continue;
            }
            let id = islands.len() as u32;
            let mut count = 0u32;
            spans[s].island = id;
            stack.push(s as u32);
            while let Some(t) = stack.pop() {
                count += 1;
                for l in spans[t as usize].links {
                    if l != NONE && spans[l as usize].island == NONE {
                        spans[l as usize].island = id;
                        stack.push(l);
                    }
                }
            }
            islands.push(Island {
                area: count as f32 * self.cell * self.cell,
                radius: 0.0,
                spans: count,
                centroid: [0.0; 3],
            });
        }
        let rooms = (0..max_room.map_or(0, |m| m + 1))
            .map(|i| NavRoom {
                id: format!("room_{}", char::from(b'a' + i as u8)),
                class: 0,
                level: 0,
            })
            .collect();
        let mut objects: Vec<NavObject> = door_letters
            .iter()
            .map(|l| NavObject {
                id: format!("door_{l}"),
                category: "door".into(),
                door: true,
                arch: false,
                min: [0.0; 3],
                max: [0.0; 3],
            })
            .collect();
        let table = objects.len() as u32;
        objects.push(NavObject {
            id: "table".into(),
            category: "table".into(),
            door: false,
            arch: false,
            min: [0.0; 3],
            max: [0.0; 3],
        });
        let mut span_objects = Vec::new();
        for (s, &ch) in chars.iter().enumerate() {
            if let Some(i) = door_letters.iter().position(|&l| l == ch) {
                span_objects.push((s as u32, i as u32));
            } else if ch == '*' {
                span_objects.push((s as u32, table));
            }
        }
        NavGrid {
            scene: "test".into(),
            params: NavParams {
                cell_size: self.cell,
                ..params
            },
            x0: 0.0,
            z0: 0.0,
            nx: nx as u32,
            nz: nz as u32,
            column_start,
            spans,
            rooms,
            objects,
            span_objects,
            islands,
            level_heights: vec![0.0],
            baked: Default::default(),
        }
    }
}

/// Rows of a map that is `'#'` everywhere except where `free(ix, iz)` says `'.'`.
pub(crate) fn rows_from(nx: usize, nz: usize, free: impl Fn(usize, usize) -> bool) -> Vec<String> {
    (0..nz)
        .map(|iz| {
            (0..nx)
                .map(|ix| if free(ix, iz) { '.' } else { '#' })
                .collect()
        })
        .collect()
}

/// Does the segment between the centres of cells `a` and `b` touch the closed square of
/// cell `c`? Exact (integer) separating-axis test in doubled coordinates.
pub(crate) fn segment_hits_closed_cell(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> bool {
    let p = (2 * a.0 + 1, 2 * a.1 + 1);
    let q = (2 * b.0 + 1, 2 * b.1 + 1);
    let (lo, hi) = ((2 * c.0, 2 * c.1), (2 * c.0 + 2, 2 * c.1 + 2));
    if p.0.max(q.0) < lo.0 || p.0.min(q.0) > hi.0 || p.1.max(q.1) < lo.1 || p.1.min(q.1) > hi.1 {
        return false;
    }
    let d = (q.0 - p.0, q.1 - p.1);
    let side = |x: i64, z: i64| (d.0 * (z - p.1) - d.1 * (x - p.0)).signum();
    let s = [
        side(lo.0, lo.1),
        side(hi.0, lo.1),
        side(lo.0, hi.1),
        side(hi.0, hi.1),
    ];
    !(s.iter().all(|&v| v > 0) || s.iter().all(|&v| v < 0))
}

/// Does the segment between points `p` and `q` (doubled cell coordinates: cell `i` spans
/// `[2i, 2i + 2]`) stay inside the union of the closed free cells?
fn segment_in_free(free: &impl Fn(i64, i64) -> bool, p: (i64, i64), q: (i64, i64)) -> bool {
    let mut ts = vec![0.0f64, 1.0];
    let crossings = |a: i64, b: i64, ts: &mut Vec<f64>| {
        if a == b {
            return;
        }
        let (lo, hi) = (a.min(b), a.max(b));
        let mut k = lo.div_euclid(2) * 2;
        while k <= hi {
            if k > lo && k < hi {
                ts.push((k - a) as f64 / (b - a) as f64);
            }
            k += 2;
        }
    };
    crossings(p.0, q.0, &mut ts);
    crossings(p.1, q.1, &mut ts);
    ts.sort_by(f64::total_cmp);
    for w in ts.windows(2) {
        if w[1] - w[0] < 1e-12 {
            continue;
        }
        let t = 0.5 * (w[0] + w[1]);
        // Candidate cells along each axis: both neighbours when the segment runs on a line.
        let axis = |a: i64, b: i64| -> (i64, i64) {
            if a == b && a % 2 == 0 {
                (a / 2 - 1, a / 2)
            } else {
                let m = a as f64 + t * (b - a) as f64;
                let c = (m / 2.0).floor() as i64;
                (c, c)
            }
        };
        let (x0, x1) = axis(p.0, q.0);
        let (z0, z1) = axis(p.1, q.1);
        if !(free(x0, z0) || free(x1, z0) || free(x0, z1) || free(x1, z1)) {
            return false;
        }
    }
    true
}

/// Exact shortest path length (in cells) between the centres of cells `a` and `b` through
/// the union of the closed free cells: Dijkstra over the visibility graph of the two
/// endpoints and the reflex corners of the free region.
pub(crate) fn reference_geodesic(
    free: impl Fn(i64, i64) -> bool,
    nx: usize,
    nz: usize,
    a: (i64, i64),
    b: (i64, i64),
) -> Option<f64> {
    let mut pts = vec![(2 * a.0 + 1, 2 * a.1 + 1), (2 * b.0 + 1, 2 * b.1 + 1)];
    for z in 0..=nz as i64 {
        for x in 0..=nx as i64 {
            let around = [
                free(x - 1, z - 1),
                free(x, z - 1),
                free(x - 1, z),
                free(x, z),
            ];
            if around.iter().filter(|&&f| f).count() == 3 {
                pts.push((2 * x, 2 * z));
            }
        }
    }
    let n = pts.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut done = vec![false; n];
    dist[0] = 0.0;
    for _ in 0..n {
        let u = (0..n)
            .filter(|&i| !done[i] && dist[i].is_finite())
            .min_by(|&i, &j| dist[i].total_cmp(&dist[j]))?;
        if u == 1 {
            return Some(dist[1] / 2.0);
        }
        done[u] = true;
        for v in 0..n {
            if done[v] || !segment_in_free(&free, pts[u], pts[v]) {
                continue;
            }
            let (dx, dz) = ((pts[v].0 - pts[u].0) as f64, (pts[v].1 - pts[u].1) as f64);
            let nd = dist[u] + (dx * dx + dz * dz).sqrt();
            if nd < dist[v] {
                dist[v] = nd;
            }
        }
    }
    None
}

/// Ground floor (80 x 20 cells of 0.1 m), a ramp along x (z in 2..6, walled on both sides)
/// rising 0.05 m per cell from x = 10 to x = 69 (27°, 3 m in all), and an upper floor at 3 m
/// over x in 70..78 (above the ground floor, which continues under it and under the high
/// part of the ramp).
pub(crate) fn stairs() -> MapSpec {
    let rows = rows_from(80, 20, |x, z| x > 0 && z > 0 && x < 79 && z < 19);
    let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
    let mut spec = MapSpec::ascii(&refs, 0.1);
    spec.fill(10, 1, 70, 2, '#');
    spec.fill(10, 6, 70, 7, '#');
    for x in 10..70 {
        for z in 2..6 {
            spec.add(x, z, (x as f32 - 9.0) * 0.05, '.');
        }
    }
    for x in 70..78 {
        for z in 1..19 {
            spec.add(x, z, 3.0, '.');
        }
    }
    spec
}

/// Exact surface distance (m) for [`stairs`] between ground point `a` (x < 0.95 m) and
/// upper-floor point `b` (x > 6.95 m): flat to the ramp foot line, up the ramp plane, flat to
/// the goal, minimised over where the path crosses the foot and the top. The ramp plane
/// runs from x = 0.95 m (height 0, the centre of the last ground cell) to x = 6.95 m
/// (height 3) over z in [0.2, 0.6].
pub(crate) fn stairs_reference(a: (f64, f64), b: (f64, f64)) -> f64 {
    let mut best = f64::INFINITY;
    let steps = 400;
    for i in 0..=steps {
        let pz = 0.2 + 0.4 * i as f64 / steps as f64;
        for j in 0..=steps {
            let qz = 0.2 + 0.4 * j as f64 / steps as f64;
            let (p, q) = ((0.95, pz), (6.95, qz));
            let flat1 = ((p.0 - a.0).powi(2) + (p.1 - a.1).powi(2)).sqrt();
            let ramp = ((q.0 - p.0).powi(2) + (q.1 - p.1).powi(2) + 9.0).sqrt();
            let flat2 = ((b.0 - q.0).powi(2) + (b.1 - q.1).powi(2)).sqrt();
            best = best.min(flat1 + ramp + flat2);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builder_links_are_symmetric_and_respect_corners() {
        let rows = ["#####", "#..##", "#...#", "#####"];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        for (s, span) in grid.spans.iter().enumerate() {
            for (d, &l) in span.links.iter().enumerate() {
                if l == NONE {
                    continue;
                }
                let back = [2, 3, 0, 1, 6, 7, 4, 5][d];
                assert_eq!(grid.spans[l as usize].links[back], s as u32);
            }
        }
        // (2,1) -> (3,2) would cut the corner of the wall at (3,1).
        let s = grid.column_start[5 + 2] as usize;
        assert_eq!(grid.spans[s].links[4], NONE);
        assert_eq!(grid.islands.len(), 1);
    }

    #[test]
    fn reference_geometry_is_exact() {
        assert!(
            segment_hits_closed_cell((0, 0), (2, 2), (1, 0)),
            "corner touch"
        );
        assert!(!segment_hits_closed_cell((0, 0), (2, 3), (1, 0)));
        // Around one blocked cell in a 3x3 room: from (0,1) to (2,1) past the corner.
        let free = |x: i64, z: i64| (0..3).contains(&x) && (0..3).contains(&z) && (x, z) != (1, 1);
        let d = reference_geodesic(free, 3, 3, (0, 1), (2, 1)).unwrap();
        let expect = 1.0 + 2.0 * 0.5f64.sqrt();
        assert!((d - expect).abs() < 1e-9, "{d} vs {expect}");
        let closed = |x: i64, z: i64| (x, z) == (0, 0) || (x, z) == (2, 2);
        assert!(reference_geodesic(closed, 3, 3, (0, 0), (2, 2)).is_none());
    }
}
