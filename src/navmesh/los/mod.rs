//! Line of sight over the span grid: can the agent walk a straight line between two spans?
//!
//! The segment in XZ between two span centres is traversed column by column with an exact
//! integer supercover DDA (Amanatides–Woo on cell centres, so no floating point decides which
//! cell comes next): every cell boundary the segment crosses is one step along the current
//! span's link in that direction, and a segment through a cell corner takes the diagonal link
//! (which the builder only creates when both orthogonal paths exist). The walk must end on the
//! target span itself, not on another layer of the same column.
//!
//! [`SightIndex`] answers the same question faster for repeated queries. It keeps a compact
//! copy of what a walk reads (16 bytes per span instead of the whole [`Span`]), and per span
//! and quadrant the size of the square of floor ahead in which every span is walkable, linked
//! forwards, flat and on the same layer, so that a walk jumps across open floor instead of
//! stepping cell by cell. Both the plain walk and the index also offer a `straight_line`
//! variant, which additionally requires the floor heights along the walk to follow the
//! straight 3D line between the two spans, so that the straight-line distance between them is
//! a fair length of the walk.
//!
//! The clear squares are the costly part of the index (row sweeps over every quadrant), so a
//! `.nav` file stores them ([`NavGrid::baked`], written by `file::write_nav`):
//! [`SightIndex::new`] takes them from there when the grid carries one record per span and
//! only packs the spans and their link masks, recomputed from the spans' own links (so stored
//! data never decides which span a step lands on; a wrong square can only jump where the walk
//! would have stepped, onto a span checked to exist). [`SightIndex::build`] always builds.
//! Packing is one pass over the columns that sets the stored squares as it goes and compares
//! a span's eight links four at a time (SSE2 on x86-64, a branch-free loop elsewhere):
//! `Geodesic::new` of a 55k-span grid read from its file, packing and search records, takes
//! about 0.48 ms (0.7 ms with the scalar loop; `cargo bench --bench episodes`).
//!
//! Where this module's job ends: it answers "is this straight walk possible" and visits the
//! spans it covers; costs and distance fields are `geodesic`, paths are `path`.
//!
//! [`Span`]: super::grid::Span

use super::grid::{NavGrid, DIRS, NONE};

mod sight_index;

pub use sight_index::SightIndex;
#[cfg(test)]
use sight_index::*;

/// [`DIRS`] index of the step `(sx, sz)`, indexed `[sx + 1][sz + 1]` (the centre entry is
/// never used).
const DIR_OF: [[usize; 3]; 3] = [[6, 2, 5], [3, 8, 1], [7, 0, 4]];

/// Largest height change between linked spans inside a jumped square, as a fraction of
/// `max_climb`: steeper ground (stairs) is walked cell by cell.
const FLAT_FRACTION: f32 = 0.25;

/// How far (m) the floor along a straight walk may leave the straight 3D line between its
/// ends for [`straight_line`]: half of `max_climb` plus one cell (at least 2 cm). Treads of
/// real stairs (risers up to `max_climb`) stay within half a riser of the line through them,
/// and a cell straddling a riser takes the upper tread's height, which adds up to one cell of
/// slope (≤ 45°): so stairs count as straight ramps, while a line from a floor onto a ramp
/// must still bend where the slope changes.
pub fn profile_tolerance(grid: &NavGrid) -> f32 {
    (0.5 * grid.params.body.max_climb + grid.params.cell_size).max(0.02)
}

/// Exact integer DDA over the cells a segment between two cell centres passes.
///
/// The segment from the centre of cell `a` to the centre of cell `b` crosses `|dx|` vertical
/// and `|dz|` horizontal cell boundaries; the `k`-th vertical crossing happens at parameter
/// `(2k + 1) / (2|dx|)`, so which comes first is decided by comparing integers.
#[derive(Debug, Clone, Copy)]
struct Dda {
    nx: u64,
    nz: u64,
    kx: u64,
    kz: u64,
    x_dir: usize,
    z_dir: usize,
    d_dir: usize,
}

impl Dda {
    fn new(dx: i64, dz: i64) -> Self {
        let (sx, sz) = (dx.signum(), dz.signum());
        Dda {
            nx: dx.unsigned_abs(),
            nz: dz.unsigned_abs(),
            kx: 0,
            kz: 0,
            x_dir: DIR_OF[(sx + 1) as usize][1],
            z_dir: DIR_OF[1][(sz + 1) as usize],
            d_dir: DIR_OF[(sx + 1) as usize][(sz + 1) as usize],
        }
    }

    #[inline]
    fn done(&self) -> bool {
        self.kx == self.nx && self.kz == self.nz
    }

    /// The direction of the next crossing, advancing past it. Only call when not `done`.
    #[inline]
    fn step(&mut self) -> usize {
        if self.kx < self.nx {
            if self.kz < self.nz {
                let lhs = u128::from(2 * self.kx + 1) * u128::from(self.nz);
                let rhs = u128::from(2 * self.kz + 1) * u128::from(self.nx);
                match lhs.cmp(&rhs) {
                    std::cmp::Ordering::Less => {
                        self.kx += 1;
                        self.x_dir
                    }
                    std::cmp::Ordering::Greater => {
                        self.kz += 1;
                        self.z_dir
                    }
                    std::cmp::Ordering::Equal => {
                        self.kx += 1;
                        self.kz += 1;
                        self.d_dir
                    }
                }
            } else {
                self.kx += 1;
                self.x_dir
            }
        } else {
            self.kz += 1;
            self.z_dir
        }
    }

    /// Counters `(kx, kz)` just before the segment leaves the square that extends `r` cells
    /// ahead of the current cell on both axes (only when it does leave it, i.e. more than `r`
    /// crossings remain on some axis).
    #[inline]
    fn before_leaving(&self, r: u64) -> (u64, u64) {
        let x_lim = (self.nx - self.kx > r).then_some(self.kx + r);
        let z_lim = (self.nz - self.kz > r).then_some(self.kz + r);
        match (x_lim, z_lim) {
            (Some(kx), Some(kz)) => {
                let lhs = u128::from(2 * kx + 1) * u128::from(self.nz);
                let rhs = u128::from(2 * kz + 1) * u128::from(self.nx);
                if lhs <= rhs {
                    (kx, crossings_before(kx, self.nx, self.nz))
                } else {
                    (crossings_before(kz, self.nz, self.nx), kz)
                }
            }
            (Some(kx), None) => (kx, crossings_before(kx, self.nx, self.nz)),
            (None, Some(kz)) => (crossings_before(kz, self.nz, self.nx), kz),
            (None, None) => (self.kx, self.kz),
        }
    }
}

/// Number of crossings of the other axis (`n_other` in all) that come strictly before the
/// `k`-th crossing of this axis (`n_this` in all).
#[inline]
fn crossings_before(k: u64, n_this: u64, n_other: u64) -> u64 {
    // Crossing m of the other axis is before when (2m + 1) n_this < (2k + 1) n_other, so
    // the count is the number of odd numbers up to ((2k + 1) n_other - 1) / n_this.
    if n_this == 0 || n_other == 0 {
        return 0;
    }
    let count = match (2 * k + 1).checked_mul(n_other) {
        Some(num) => ((num - 1) / n_this).div_ceil(2),
        None => {
            let num = u128::from(2 * k + 1) * u128::from(n_other);
            ((num - 1) / u128::from(n_this))
                .div_ceil(2)
                .min(u128::from(n_other)) as u64
        }
    };
    count.min(n_other)
}

/// One straight walk: endpoints, their cells, and the optional height profile.
#[derive(Debug, Clone, Copy)]
struct Walk {
    from: u32,
    to: u32,
    a: (i64, i64),
    b: (i64, i64),
    /// Check the height profile.
    profile: bool,
    ya: f32,
    dy: f32,
    tolerance: f32,
    /// `(dx, dz) / (dx² + dz²)`: projecting a cell offset on it gives the parameter.
    proj: (f32, f32),
}

impl Walk {
    fn new(
        grid: &NavGrid,
        from: u32,
        to: u32,
        a: (i64, i64),
        b: (i64, i64),
        profile: bool,
    ) -> Self {
        let (ya, yb) = (grid.spans[from as usize].y, grid.spans[to as usize].y);
        Walk::with_heights(from, to, (a, b), (ya, yb), profile, profile_tolerance(grid))
    }

    #[inline]
    fn with_heights(
        from: u32,
        to: u32,
        (a, b): ((i64, i64), (i64, i64)),
        (ya, yb): (f32, f32),
        profile: bool,
        tolerance: f32,
    ) -> Self {
        let (dx, dz) = (b.0 - a.0, b.1 - a.1);
        let len2 = ((dx * dx + dz * dz) as f32).max(1.0);
        Walk {
            from,
            to,
            a,
            b,
            profile,
            ya,
            dy: yb - ya,
            tolerance,
            proj: (dx as f32 / len2, dz as f32 / len2),
        }
    }

    /// Does a span of height `y` at cell offset `(ox, oz)` from `a` lie on the profile?
    #[inline]
    fn on_profile(&self, ox: i64, oz: i64, y: f32) -> bool {
        if !self.profile {
            return true;
        }
        let t = (ox as f32 * self.proj.0 + oz as f32 * self.proj.1).clamp(0.0, 1.0);
        (y - (self.ya + t * self.dy)).abs() <= self.tolerance
    }
}

/// Walks `walk` over the links of `grid`, calling `visit` on every span stepped on
/// (including both ends).
fn trace_links<V: FnMut(u32)>(grid: &NavGrid, walk: &Walk, visit: &mut V) -> bool {
    let spans = &grid.spans;
    visit(walk.from);
    if walk.from == walk.to {
        return true;
    }
    let (dx, dz) = (walk.b.0 - walk.a.0, walk.b.1 - walk.a.1);
    if dx == 0 && dz == 0 {
        // Another layer of the same column: not reachable by a straight walk.
        return false;
    }
    let (sx, sz) = (dx.signum(), dz.signum());
    let mut dda = Dda::new(dx, dz);
    let mut cur = walk.from;
    while !dda.done() {
        cur = spans[cur as usize].links[dda.step()];
        if cur == NONE {
            return false;
        }
        visit(cur);
        let (ox, oz) = (sx * dda.kx as i64, sz * dda.kz as i64);
        if !walk.on_profile(ox, oz, spans[cur as usize].y) {
            return false;
        }
    }
    cur == walk.to
}

/// Cell coordinates of a span by binary search over the columns.
fn cell_of_span(grid: &NavGrid, span: u32) -> (i64, i64) {
    let c = grid.column_of_span(span as usize) as i64;
    let nx = i64::from(grid.nx.max(1));
    (c % nx, c / nx)
}

/// Both spans exist and are walkable.
fn walkable_pair(grid: &NavGrid, from: u32, to: u32) -> bool {
    let ok = |s: u32| grid.spans.get(s as usize).is_some_and(|s| s.walkable);
    ok(from) && ok(to)
}

fn plain_walk(grid: &NavGrid, from: u32, to: u32, profile: bool) -> Walk {
    let (a, b) = (cell_of_span(grid, from), cell_of_span(grid, to));
    Walk::new(grid, from, to, a, b, profile)
}

/// True when the agent can walk the straight XZ segment between the centres of spans `from`
/// and `to` by following links, ending on `to` itself (not on another layer of its column).
///
/// Both spans must be walkable; invalid indices give `false`. Allocation-free; costs one
/// binary search per end plus one step per cell crossed. The plain walk the [`SightIndex`]'s
/// jumps are checked against (the library walks with the index).
#[cfg(test)]
pub(crate) fn line_of_sight(grid: &NavGrid, from: u32, to: u32) -> bool {
    walkable_pair(grid, from, to)
        && trace_links(grid, &plain_walk(grid, from, to, false), &mut |_| {})
}

/// Like `line_of_sight`, and the floor heights along the walk stay within
/// [`profile_tolerance`] of the straight 3D line between the two span positions (so a
/// straight line from a floor up a ramp is refused where the slope changes).
pub fn straight_line(grid: &NavGrid, from: u32, to: u32) -> bool {
    walkable_pair(grid, from, to)
        && trace_links(grid, &plain_walk(grid, from, to, true), &mut |_| {})
}

/// Walks the straight XZ segment from span `from` to span `to` like `line_of_sight`,
/// calling `visit` on every span stepped on in order, `from` first; returns whether the walk
/// ended on `to` (when it did not, the spans visited are those up to where it stopped).
pub fn walk_line(grid: &NavGrid, from: u32, to: u32, mut visit: impl FnMut(u32)) -> bool {
    walkable_pair(grid, from, to)
        && trace_links(grid, &plain_walk(grid, from, to, false), &mut visit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_bits_match_the_one_at_a_time_reference() {
        // Values around the interesting boundaries: 0, the span count, NONE, the top bit.
        let pick = [
            0u32,
            1,
            2,
            3,
            7,
            99,
            100,
            101,
            1 << 31,
            (1 << 31) - 1,
            (1 << 31) + 1,
            NONE - 1,
            NONE,
        ];
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            pick[(x % pick.len() as u64) as usize]
        };
        for _ in 0..20_000 {
            let links: [u32; 8] = std::array::from_fn(|_| next());
            let lo: [u32; 8] = std::array::from_fn(|_| next());
            let count: [u32; 8] = std::array::from_fn(|_| next());
            let (n, rank) = (next(), next());
            assert_eq!(
                link_bits(&links, n, &lo, &count, rank),
                link_bits_plain(&links, n, &lo, &count, rank),
                "{links:?} {n} {lo:?} {count:?} {rank}"
            );
        }
        // Links that land on the same rank.
        let lo = [10, 20, 30, 40, 50, 60, 70, 80];
        let count = [1, 2, 3, 4, 0, 2, 1, 9];
        let links = [11, 21, 31, 41, 51, 61, NONE, 200];
        for rank in 0..4 {
            assert_eq!(
                link_bits(&links, 150, &lo, &count, rank),
                link_bits_plain(&links, 150, &lo, &count, rank)
            );
        }
        assert_eq!(
            link_bits(&links, 150, &lo, &count, 1),
            (0b0010_1110, 0b0011_1111)
        );
    }
    use crate::navmesh::testmaps::{segment_hits_closed_cell, MapSpec};
    use crate::navmesh::NavParams;
    use crate::seed::Rng;

    fn span_at(grid: &NavGrid, ix: usize, iz: usize) -> u32 {
        let c = iz * grid.nx as usize + ix;
        grid.column_start[c]
    }

    #[test]
    fn square_sizes_match_the_straightforward_recurrence() {
        // Regular wall cells, random bumps and a gently sloping upper floor over part of the
        // ground: many ranks and sizes.
        let (nx, nz) = (70usize, 50usize);
        let mut rng = Rng::new(5);
        let rows = crate::navmesh::testmaps::rows_from(nx, nz, |x, z| {
            x > 0 && z > 0 && x < nx - 1 && z < nz - 1 && (x * 7 + z * 3) % 23 != 0
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let mut spec = MapSpec::ascii(&refs, 0.05);
        for ix in 1..nx - 1 {
            for iz in 1..nz - 1 {
                if rng.chance(0.05) {
                    spec.set_height(ix, iz, 0.08 * rng.unit_f64() as f32);
                }
                if (20..45).contains(&ix) && (10..30).contains(&iz) {
                    spec.add(ix, iz, 2.5 + 0.01 * (ix as f32 - 20.0), '.');
                }
            }
        }
        let grid = spec.build(NavParams::default());
        let index = SightIndex::new(&grid);
        let mut expect = index.spans.clone();
        for s in &mut expect {
            s.ahead = [0; 4];
        }
        squares_ahead_reference(&grid, &mut expect);
        let mut big = 0;
        for (got, want) in index.spans.iter().zip(&expect) {
            assert_eq!(got.ahead, want.ahead);
            big += usize::from(got.ahead.iter().any(|&a| a > 4));
        }
        assert!(big > 1000, "large squares exercised: {big}");
        assert!(grid.spans.len() > nx * nz, "several ranks");
    }

    /// [`squares_ahead`] as it was first written, span by span from the packed records: the
    /// reference its row sweeps must match.
    fn squares_ahead_reference(grid: &NavGrid, packed: &mut [SightSpan]) {
        let flat = FLAT_FRACTION * grid.params.body.max_climb;
        let (nx, nz) = (grid.nx as usize, grid.nz as usize);
        let start = &grid.column_start;
        if nx == 0 || start.len() < nx * nz + 1 {
            return;
        }
        let n = packed.len();
        for sz in [1i32, -1] {
            for step_z in 0..nz {
                let iz = if sz > 0 { nz - 1 - step_z } else { step_z };
                for sx in [1i32, -1] {
                    let q = usize::from(sx < 0) | (usize::from(sz < 0) << 1);
                    let dir =
                        |dx: i32, dz: i32| DIRS.iter().position(|&d| d == (dx, dz)).unwrap_or(0);
                    let (xd, zd, dd) = (dir(sx, 0), dir(0, sz), dir(sx, sz));
                    let forward = (1u8 << xd) | (1u8 << zd) | (1u8 << dd);
                    let offs = [xd, zd, dd]
                        .map(|d| i64::from(DIRS[d].0) + i64::from(DIRS[d].1) * nx as i64);
                    for step_x in 0..nx {
                        let ix = if sx > 0 { nx - 1 - step_x } else { step_x };
                        let c = iz * nx + ix;
                        let (s0, s1) = (start[c] as usize, (start[c + 1] as usize).min(n));
                        for s in s0.min(s1)..s1 {
                            let (y, same_rank) = (packed[s].y, packed[s].same_rank);
                            let size = if same_rank & forward != forward {
                                1
                            } else {
                                let rank = (s - s0) as u32;
                                let mut min = u8::MAX;
                                let mut ok = true;
                                for off in offs {
                                    let l = (start[(c as i64 + off) as usize] + rank) as usize;
                                    // Field by field: the square size of the previous column
                                    // was just stored, and a whole-record load would stall.
                                    ok &= (packed[l].y - y).abs() <= flat;
                                    min = min.min(packed[l].ahead[q]);
                                }
                                if ok {
                                    min.saturating_add(1)
                                } else {
                                    1
                                }
                            };
                            packed[s].ahead[q] = size;
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn open_floor_is_visible_and_walls_block() {
        let rows = [
            "##########",
            "#........#",
            "#........#",
            "#...#....#",
            "#........#",
            "##########",
        ];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        let a = span_at(&grid, 1, 3);
        let b = span_at(&grid, 8, 3);
        assert!(!line_of_sight(&grid, a, b), "wall cell in between");
        let c = span_at(&grid, 8, 1);
        assert!(line_of_sight(&grid, span_at(&grid, 1, 1), c));
        // Non-walkable endpoint and bad indices.
        assert!(!line_of_sight(&grid, a, span_at(&grid, 4, 3)));
        assert!(!line_of_sight(&grid, a, u32::MAX));
        assert!(line_of_sight(&grid, a, a));
    }

    #[test]
    fn passing_exactly_through_a_corner_needs_the_diagonal() {
        // The segment from (1,1) to (3,3) passes the cell corners (2,2) and (3,3). A wall
        // cell touching the first corner from either side removes the diagonal link, even
        // though a path around it on the other side exists.
        let x_side = ["######", "#.#..#", "#....#", "#....#", "######"];
        let z_side = ["######", "#....#", "##...#", "#....#", "######"];
        for rows in [x_side, z_side] {
            let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
            let (a, b) = (span_at(&grid, 1, 1), span_at(&grid, 3, 3));
            assert!(!line_of_sight(&grid, a, b), "{rows:?}");
            assert!(!SightIndex::new(&grid).line_of_sight(a, b), "{rows:?}");
            // Just off the corner the segment is clear.
            assert!(line_of_sight(
                &grid,
                span_at(&grid, 2, 2),
                span_at(&grid, 4, 3)
            ));
        }
        let rows = ["######", "#....#", "#....#", "#....#", "######"];
        let open = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        assert!(line_of_sight(
            &open,
            span_at(&open, 1, 1),
            span_at(&open, 3, 3)
        ));
    }

    #[test]
    fn agrees_with_exact_segment_geometry_on_random_maps() {
        // Sight on a flat single-layer map holds exactly when the segment between the two
        // centres touches no blocked closed cell (corner touches included: the corner rule).
        let (nx, nz) = (64usize, 48usize);
        let mut rng = Rng::new(11);
        let mut rows: Vec<String> = Vec::new();
        for iz in 0..nz {
            let row: String = (0..nx)
                .map(|ix| {
                    let border = ix == 0 || iz == 0 || ix == nx - 1 || iz == nz - 1;
                    if border || rng.chance(0.02) {
                        '#'
                    } else {
                        '.'
                    }
                })
                .collect();
            rows.push(row);
        }
        // A few solid blocks so that long jumps happen next to walls.
        for (x0, z0, w, h) in [(10, 10, 6, 3), (30, 20, 2, 15), (45, 5, 10, 10)] {
            for row in rows.iter_mut().skip(z0).take(h) {
                let mut chars: Vec<char> = row.chars().collect();
                for ch in chars.iter_mut().skip(x0).take(w) {
                    *ch = '#';
                }
                *row = chars.into_iter().collect();
            }
        }
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let spec = MapSpec::ascii(&refs, 0.05);
        let grid = spec.build(NavParams::default());
        let index = SightIndex::new(&grid);
        let blocked: Vec<(i64, i64)> = (0..nz)
            .flat_map(|iz| (0..nx).map(move |ix| (ix, iz)))
            .filter(|&(ix, iz)| refs[iz].as_bytes()[ix] == b'#')
            .map(|(ix, iz)| (ix as i64, iz as i64))
            .collect();
        let free: Vec<(usize, usize)> = (0..nz)
            .flat_map(|iz| (0..nx).map(move |ix| (ix, iz)))
            .filter(|&(ix, iz)| refs[iz].as_bytes()[ix] == b'.')
            .collect();
        let (mut visible, mut jumped) = (0, 0);
        for _ in 0..3000 {
            let &(ax, az) = rng.pick(&free).unwrap();
            let &(bx, bz) = rng.pick(&free).unwrap();
            let (a, b) = (span_at(&grid, ax, az), span_at(&grid, bx, bz));
            let expect = !blocked.iter().any(|&cell| {
                segment_hits_closed_cell((ax as i64, az as i64), (bx as i64, bz as i64), cell)
            });
            assert_eq!(
                line_of_sight(&grid, a, b),
                expect,
                "({ax},{az})->({bx},{bz})"
            );
            assert_eq!(
                index.line_of_sight(a, b),
                expect,
                "indexed ({ax},{az})->({bx},{bz})"
            );
            assert_eq!(index.straight_line(a, b), expect, "flat floor is straight");
            visible += usize::from(expect);
            jumped += usize::from(index.jump_reach(a) > 0);
        }
        assert!(
            visible > 300 && visible < 2700,
            "both outcomes tested: {visible}"
        );
        assert!(jumped > 600, "the jump path is exercised: {jumped}");
    }

    #[test]
    fn sight_ends_on_the_same_layer_only() {
        // Ground floor everywhere, an upper floor at 3 m over x >= 6 joined by nothing.
        let rows = [
            "############",
            "#..........#",
            "#..........#",
            "############",
        ];
        let mut spec = MapSpec::ascii(&rows, 0.1);
        for ix in 6..11 {
            for iz in 1..3 {
                spec.add(ix, iz, 3.0, '.');
            }
        }
        let grid = spec.build(NavParams::default());
        let a = span_at(&grid, 1, 1);
        let ground = span_at(&grid, 9, 2);
        let upper = ground + 1;
        assert!((grid.spans[upper as usize].y - 3.0).abs() < 1e-6);
        assert!(line_of_sight(&grid, a, ground));
        assert!(!line_of_sight(&grid, a, upper));
        let index = SightIndex::new(&grid);
        assert!(index.line_of_sight(a, ground));
        assert!(!index.line_of_sight(a, upper));
        assert!(
            !line_of_sight(&grid, ground, upper),
            "same column, other layer"
        );
    }

    #[test]
    fn walk_line_visits_every_span_in_order() {
        let rows = ["#######", "#.....#", "#.....#", "#######"];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        let mut seen = Vec::new();
        let ok = walk_line(&grid, span_at(&grid, 1, 1), span_at(&grid, 5, 2), |s| {
            seen.push(s)
        });
        assert!(ok);
        // (1,1) -> (5,2): crossings x at t = 1/8, 3/8, 5/8, 7/8 and z at 1/2.
        let expect: Vec<u32> = [(1, 1), (2, 1), (3, 1), (3, 2), (4, 2), (5, 2)]
            .iter()
            .map(|&(x, z)| span_at(&grid, x, z))
            .collect();
        assert_eq!(seen, expect);
    }

    #[test]
    fn straight_line_refuses_bending_floors() {
        // Floor at 0, a ramp rising 0.1 m per cell from x = 4 to x = 13, a floor at 1 m after.
        let mut row_floor = String::from("#");
        row_floor.push_str(&".".repeat(18));
        row_floor.push('#');
        let wall = "#".repeat(20);
        let rows = [
            wall.as_str(),
            row_floor.as_str(),
            row_floor.as_str(),
            wall.as_str(),
        ];
        let mut spec = MapSpec::ascii(&rows, 0.1);
        for ix in 4..19 {
            let y = ((ix as f32 - 3.0) * 0.1).min(1.0);
            for iz in 1..3 {
                spec.set_height(ix, iz, y);
            }
        }
        let grid = spec.build(NavParams::default());
        let low = span_at(&grid, 1, 1);
        let ramp_foot = span_at(&grid, 3, 1);
        let top = span_at(&grid, 13, 1);
        let far = span_at(&grid, 18, 1);
        assert!(line_of_sight(&grid, low, far));
        assert!(!straight_line(&grid, low, far), "floor bends twice");
        assert!(straight_line(&grid, ramp_foot, top), "a ramp is straight");
        assert!(SightIndex::new(&grid).straight_line(ramp_foot, top));
        assert!(!SightIndex::new(&grid).straight_line(low, far));
    }
}
