//! Navigation on hand-made scenes with answers computed independently in the test (exact
//! shortest paths in the polygonal free space by a visibility graph), and on generated houses.

use crate::common;

use common::scenes::SceneBuilder;
use glam::Vec3;
use minos::navmesh::build::build;
use minos::navmesh::geodesic::distance_field;
use minos::navmesh::path::{shortest_path, PathResult};
use minos::navmesh::{NavGrid, NavParams};
use minos::scene::{ObjectFlags, RoomClass};

const R: f32 = 0.1;

fn grid_of(scene: &minos::scene::Scene) -> NavGrid {
    build(scene, &NavParams::default()).expect("bake")
}

fn path_len(grid: &NavGrid, a: Vec3, b: Vec3) -> Option<f32> {
    let (sa, sb) = (
        grid.snap(a).expect("start walkable"),
        grid.snap(b).expect("goal walkable"),
    );
    match shortest_path(grid, sa, sb) {
        PathResult::Found(p) => Some(p.length),
        PathResult::Unreachable => None,
    }
}

/// Exact shortest path in the plane around axis-aligned rectangular obstacles (already
/// inflated by the agent radius): Dijkstra over the visibility graph of their corners.
fn exact_shortest(a: [f32; 2], b: [f32; 2], obstacles: &[[f32; 4]]) -> f32 {
    let mut nodes = vec![a, b];
    for o in obstacles {
        let e = 1e-4;
        nodes.extend([
            [o[0] - e, o[1] - e],
            [o[2] + e, o[1] - e],
            [o[0] - e, o[3] + e],
            [o[2] + e, o[3] + e],
        ]);
    }
    let blocked = |p: [f32; 2], q: [f32; 2]| {
        obstacles.iter().any(|o| {
            // Slab test of the segment against the open rectangle.
            let (mut t0, mut t1) = (0.0f32, 1.0f32);
            for k in 0..2 {
                let (lo, hi) = if k == 0 { (o[0], o[2]) } else { (o[1], o[3]) };
                let d = q[k] - p[k];
                if d.abs() < 1e-9 {
                    if p[k] <= lo || p[k] >= hi {
                        return false;
                    }
                } else {
                    let (mut u, mut v) = ((lo - p[k]) / d, (hi - p[k]) / d);
                    if u > v {
                        std::mem::swap(&mut u, &mut v);
                    }
                    t0 = t0.max(u);
                    t1 = t1.min(v);
                }
            }
            t0 < t1 - 1e-6
        })
    };
    let n = nodes.len();
    let mut dist = vec![f32::INFINITY; n];
    let mut done = vec![false; n];
    dist[0] = 0.0;
    for _ in 0..n {
        let Some(u) = (0..n)
            .filter(|&i| !done[i])
            .min_by(|&i, &j| dist[i].total_cmp(&dist[j]))
        else {
            break;
        };
        done[u] = true;
        for v in 0..n {
            if !done[v] && !blocked(nodes[u], nodes[v]) {
                let d = dist[u]
                    + ((nodes[u][0] - nodes[v][0]).powi(2) + (nodes[u][1] - nodes[v][1]).powi(2))
                        .sqrt();
                dist[v] = dist[v].min(d);
            }
        }
    }
    dist[1]
}

fn inflate(o: [f32; 4]) -> [f32; 4] {
    [o[0] - R, o[1] - R, o[2] + R, o[3] + R]
}

/// The outside of a floor rectangle as four (inflated) obstacles: the agent keeps its radius
/// from the floor's edges too.
fn outside(floor: [f32; 4]) -> Vec<[f32; 4]> {
    let big = 100.0;
    [
        [floor[0] - big, floor[1] - big, floor[2] + big, floor[1]],
        [floor[0] - big, floor[3], floor[2] + big, floor[3] + big],
        [floor[0] - big, floor[1] - big, floor[0], floor[3] + big],
        [floor[2], floor[1] - big, floor[2] + big, floor[3] + big],
    ]
    .into_iter()
    .map(inflate)
    .collect()
}

fn assert_close(got: f32, want: f32, tol: f32) {
    assert!(
        (got - want).abs() <= tol * want,
        "geodesic {got} vs exact {want} ({:.2}%)",
        100.0 * (got - want) / want
    );
}

#[test]
fn empty_room_geodesic_is_euclidean_and_the_path_is_straight() {
    let scene = SceneBuilder::new("empty")
        .room("r", RoomClass::LivingRoom, [0.0, 0.0, 6.0, 4.0], 0.0, &[])
        .build();
    let grid = grid_of(&scene);
    let (a, b) = (Vec3::new(0.5, 0.0, 0.5), Vec3::new(5.3, 0.0, 3.2));
    let (sa, sb) = (grid.snap(a).unwrap(), grid.snap(b).unwrap());
    let (pa, pb) = (
        grid.span_position(sa as usize),
        grid.span_position(sb as usize),
    );
    let PathResult::Found(p) = shortest_path(&grid, sa, sb) else {
        panic!("unreachable")
    };
    assert_close(p.length, pa.distance(pb), 0.005);
    assert_eq!(p.points.len(), 2, "{:?}", p.points);
    assert_eq!(p.rooms, vec![0]);
    // The walkable floor is the room minus a band of the agent radius along its edges.
    assert!(grid.is_walkable(Vec3::new(3.0, 0.0, 2.0)));
    assert!(!grid.is_walkable(Vec3::new(0.04, 0.0, 2.0)));
    let area = grid.islands[0].area;
    assert!(
        area > (6.0 - 2.0 * R - 0.1) * (4.0 - 2.0 * R - 0.1) && area < 6.0 * 4.0,
        "{area}"
    );
}

#[test]
fn l_shaped_corridor_matches_the_exact_shortest_path() {
    let block = [0.0, 2.0, 4.0, 6.0];
    let scene = SceneBuilder::new("L")
        .room(
            "r",
            RoomClass::Hallway,
            [0.0, 0.0, 6.0, 6.0],
            0.0,
            &[([block[0], 0.0, block[1]], [block[2], 2.7, block[3]])],
        )
        .build();
    let grid = grid_of(&scene);
    let (a, b) = ([0.6f32, 1.0f32], [5.0f32, 5.4f32]);
    let got = path_len(
        &grid,
        Vec3::new(a[0], 0.0, a[1]),
        Vec3::new(b[0], 0.0, b[1]),
    )
    .expect("reachable");
    let mut obstacles = outside([0.0, 0.0, 6.0, 6.0]);
    obstacles.push(inflate(block));
    let want = exact_shortest(a, b, &obstacles);
    assert!(
        want > ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt() + 0.1,
        "the corner must matter"
    );
    assert_close(got, want, 0.01);
}

#[test]
fn a_wall_with_one_doorway_matches_the_exact_shortest_path() {
    let w1 = [3.95, 0.0, 4.05, 1.5];
    let w2 = [3.95, 2.5, 4.05, 4.0];
    let wall = |o: [f32; 4]| ([o[0], 0.0, o[1]], [o[2], 2.7, o[3]]);
    let scene = SceneBuilder::new("door")
        .room(
            "r",
            RoomClass::LivingRoom,
            [0.0, 0.0, 8.0, 4.0],
            0.0,
            &[wall(w1), wall(w2)],
        )
        .build();
    let grid = grid_of(&scene);
    for (a, b) in [
        ([1.0f32, 0.5f32], [7.0f32, 3.5f32]),
        ([0.5, 3.5], [7.5, 3.5]),
        ([2.0, 2.0], [6.0, 0.3]),
    ] {
        let got = path_len(
            &grid,
            Vec3::new(a[0], 0.0, a[1]),
            Vec3::new(b[0], 0.0, b[1]),
        )
        .expect("reachable");
        let mut obstacles = outside([0.0, 0.0, 8.0, 4.0]);
        obstacles.extend([inflate(w1), inflate(w2)]);
        let want = exact_shortest(a, b, &obstacles);
        assert_close(got, want, 0.01);
        let back = path_len(
            &grid,
            Vec3::new(b[0], 0.0, b[1]),
            Vec3::new(a[0], 0.0, a[1]),
        )
        .unwrap();
        assert_close(back, got, 0.01);
    }
}

#[test]
fn stairs_connect_two_floors_and_their_length_counts() {
    let steps = 18;
    let (rise, run) = (3.0 / steps as f32, 4.0 / steps as f32);
    let boxes: Vec<([f32; 3], [f32; 3])> = (0..steps)
        .map(|i| {
            (
                [1.0, 0.0, 4.0 + i as f32 * run],
                [2.5, (i + 1) as f32 * rise, 4.0 + (i + 1) as f32 * run],
            )
        })
        .collect();
    let stairs = ObjectFlags {
        stairs: true,
        ..Default::default()
    };
    let scene = SceneBuilder::new("stairs")
        .room("down", RoomClass::Hallway, [0.0, 0.0, 4.0, 4.0], 0.0, &[])
        .room("up", RoomClass::Bedroom, [0.0, 8.0, 4.0, 12.0], 3.0, &[])
        .object("s", "stairs", stairs, &boxes, vec![0])
        .build();
    let grid = grid_of(&scene);
    let (a, b) = (Vec3::new(1.75, 0.0, 2.0), Vec3::new(1.75, 3.0, 10.0));
    assert_eq!(
        grid.island_of(a),
        grid.island_of(b),
        "stairs must connect the floors"
    );
    let PathResult::Found(p) = shortest_path(&grid, grid.snap(a).unwrap(), grid.snap(b).unwrap())
    else {
        panic!("unreachable")
    };
    // 2 m of floor, a 4 m run rising 3 m (5 m of slope), 2 m of floor.
    assert!(p.length > 8.5, "the rise must count: {}", p.length);
    assert_close(p.length, 9.0, 0.02);
    assert_eq!(p.rooms.first(), Some(&0));
    assert_eq!(p.rooms.last(), Some(&1));
}

#[test]
fn a_closed_room_is_unreachable_and_its_own_island() {
    let t = 0.1;
    let ring = [
        ([5.0, 0.0, 1.0], [7.0, 2.7, 1.0 + t]),
        ([5.0, 0.0, 3.0 - t], [7.0, 2.7, 3.0]),
        ([5.0, 0.0, 1.0], [5.0 + t, 2.7, 3.0]),
        ([7.0 - t, 0.0, 1.0], [7.0, 2.7, 3.0]),
    ];
    let scene = SceneBuilder::new("closed")
        .room("r", RoomClass::Office, [0.0, 0.0, 8.0, 4.0], 0.0, &ring)
        .build();
    let grid = grid_of(&scene);
    let (out, inside) = (Vec3::new(1.0, 0.0, 2.0), Vec3::new(6.0, 0.0, 2.0));
    assert!(grid.is_walkable(inside) && grid.is_walkable(out));
    assert_ne!(grid.island_of(out), grid.island_of(inside));
    assert!(matches!(
        shortest_path(&grid, grid.snap(out).unwrap(), grid.snap(inside).unwrap()),
        PathResult::Unreachable
    ));
    let field = distance_field(&grid, &[grid.snap(out).unwrap()]);
    assert!(field.distance(grid.snap(inside).unwrap()).is_none());
    assert!(field
        .distance(grid.snap(Vec3::new(3.0, 0.0, 3.5)).unwrap())
        .is_some());
}

#[test]
fn under_a_table_is_walkable_only_if_the_agent_fits() {
    let mut boxes = vec![([2.0, 0.72, 1.0], [3.6, 0.76, 2.6])];
    for (x, z) in [(2.0, 1.0), (3.55, 1.0), (2.0, 2.55), (3.55, 2.55)] {
        boxes.push(([x, 0.0, z], [x + 0.05, 0.72, z + 0.05]));
    }
    let scene = SceneBuilder::new("table")
        .room("r", RoomClass::DiningRoom, [0.0, 0.0, 6.0, 4.0], 0.0, &[])
        .object("t", "table", ObjectFlags::default(), &boxes, vec![0])
        .build();
    let under = Vec3::new(2.8, 0.0, 1.8);
    assert!(
        !grid_of(&scene).is_walkable(under),
        "a 1.5 m agent does not fit under a 0.72 m table"
    );
    let mut small = NavParams::default();
    small.body.height = 0.6;
    let g = build(&scene, &small).unwrap();
    assert!(g.is_walkable(under), "a 0.6 m agent fits");
    // And the table top is never floor.
    assert!(g.spans.iter().all(|s| s.y < 0.5));
}
