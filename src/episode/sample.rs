//! Sampling episodes in one scene: a uniformly random walkable start (by area) with a uniform
//! yaw on an island large enough, and a goal on the same island, filtered by distance, the
//! geodesic/Euclidean ratio, doors and rooms on the shortest path, level, and distance bins.
//!
//! Starts can instead be given ([`sample_scene_from`]): each start of a list, in order, gets a
//! goal drawn for the task, as MINOS's tasks drew their goals from the starts of one
//! episode-states file (`states_file`, filtered by its PointGoal paths' doors and rooms).
//!
//! Every choice draws from one generator seeded from `(seed, scene id, task)`, so a scene's
//! episodes never depend on thread count, scene order or sharding. Rejected draws are counted
//! by reason so users can see why a scene yields few episodes.
//!
//! A PointGoal draw costs one point-to-point query (`navmesh::path`); pairs farther apart
//! than `max_geodesic` are rejected before it, and the walk listing rooms and doors is done
//! only for kept pairs (before the filters only when `min_doors`/`min_rooms` need it). On
//! the generated houses of `cargo bench --bench episodes` about half the draws are rejected
//! (mostly by the ratio rule), and a scene of 100 episodes costs about 8 ms on one core, of
//! which the per-scene setup (line-of-sight index, sparse graph) is about 3 ms.

use std::collections::BTreeMap;

use glam::Vec3;

use crate::navmesh::geodesic::{DistanceField, Geodesic, GoalRegions};
use crate::navmesh::path::{
    add_rooms_and_doors, nearest_polyline_in, path_from_field, shortest_polyline_in, Path,
    PathResult,
};
use crate::navmesh::{NavGrid, NONE};
use crate::scene::RoomClass;
use crate::seed::{derive_seed, Rng};

use super::vln::landmarks::SceneIndex;
use super::vln::{describe_route, instruction_seed, RouteEnds};
use super::{Difficulty, Episode, Goal, GoalTarget, TargetRoom, Task};

/// Which instance(s) of the goal category count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Select {
    /// Every instance counts (distance to the nearest).
    Any,
    /// One instance drawn at random.
    Random,
    /// The instance geodesically closest to the start.
    Closest,
}

impl crate::vocab::Vocabulary for Select {
    const WHAT: &'static str = "selection";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Select::Any,
            name: "any",
            aliases: &[],
            help: "every instance counts",
        },
        crate::vocab::Term {
            value: Select::Random,
            name: "random",
            aliases: &[],
            help: "one random instance",
        },
        crate::vocab::Term {
            value: Select::Closest,
            name: "closest",
            aliases: &[],
            help: "the geodesically closest instance",
        },
    ];
}

crate::vocab::name_traits!(Select);

/// How episodes are sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleConfig {
    /// The task.
    pub task: Task,
    /// Episodes wanted per scene.
    pub per_scene: usize,
    /// User seed.
    pub seed: u64,
    /// Smallest island radius (m) a start may lie on (Habitat: 1.5).
    pub min_island_radius: f32,
    /// Success radius (m).
    pub success_radius: f32,
    /// ObjectGoal categories.
    pub categories: Vec<String>,
    /// ObjectGoal: every category of the scene's grid (its objects' most specific labels,
    /// structure such as walls and floors left out) instead of `categories`.
    pub all_categories: bool,
    /// ObjectGoal: fewest reachable instances a category needs in a scene to be a goal.
    pub min_instances: u32,
    /// VLN: instructions generated per route.
    pub instructions: usize,
    /// RoomGoal classes (`None`: any class).
    pub room_classes: Option<Vec<RoomClass>>,
    /// Which instances count.
    pub select: Select,
    /// Shortest allowed geodesic distance (m).
    pub min_geodesic: f32,
    /// Longest allowed geodesic distance (m).
    pub max_geodesic: f32,
    /// Habitat's rule: pairs with geodesic/Euclidean < 1.1 are kept with probability
    /// 20·(ratio − 0.98)².
    pub ratio_rule: bool,
    /// Fewest doorways (doors and arches) on the shortest path (MINOS).
    pub min_doors: u32,
    /// Fewest rooms on the shortest path (MINOS).
    pub min_rooms: u32,
    /// Start and goal on the same level.
    pub same_level: bool,
    /// Geodesic thresholds between easy/medium and medium/hard (m).
    pub bins: [f32; 2],
    /// Draw the same number of episodes in each bin (val/test sets).
    pub stratified: bool,
    /// Step limit written into episodes.
    pub max_steps: u32,
    /// Draws allowed per wanted episode before the scene gives up.
    pub attempts_per_episode: usize,
}

impl Default for SampleConfig {
    fn default() -> Self {
        SampleConfig {
            task: Task::PointGoal,
            per_scene: 10,
            seed: 0,
            min_island_radius: 1.5,
            success_radius: 0.2,
            categories: vec!["door".into(), "arch".into()],
            all_categories: false,
            min_instances: 1,
            instructions: crate::episode::vln::DEFAULT_INSTRUCTIONS,
            room_classes: None,
            select: Select::Any,
            min_geodesic: 1.0,
            max_geodesic: 30.0,
            ratio_rule: true,
            min_doors: 0,
            min_rooms: 0,
            same_level: false,
            bins: [4.0, 8.0],
            stratified: false,
            max_steps: crate::episode::interchange::DEFAULT_MAX_STEPS,
            attempts_per_episode: 200,
        }
    }
}

/// A given start: where the agent stands (on the floor) and where it faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    /// Position (m, world frame, on the floor).
    pub position: [f32; 3],
    /// Yaw (radians, [`Episode::start_yaw`]'s convention).
    pub yaw: f32,
}

/// Why draws were rejected, with counts.
pub type Rejections = BTreeMap<&'static str, u64>;

/// What one scene yielded.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneEpisodes {
    /// The episodes, in index order.
    pub episodes: Vec<Episode>,
    /// Rejected draws by reason.
    pub rejected: Rejections,
    /// Why the scene yields nothing at all, if so.
    pub unusable: Option<String>,
}

/// A goal candidate: what counts, and the walkable spans from which it counts as reached.
struct GoalSet {
    name: String,
    targets: Vec<GoalTarget>,
    /// Goal spans per target.
    spans: Vec<Vec<u32>>,
}

impl GoalSet {
    /// Targets with a goal span on `island`.
    fn targets_on(&self, grid: &NavGrid, island: u32) -> Vec<usize> {
        (0..self.targets.len())
            .filter(|&t| {
                self.spans[t]
                    .iter()
                    .any(|&s| grid.spans[s as usize].island == island)
            })
            .collect()
    }
}

/// Up to this many view points are stored per target.
const MAX_VIEW_POINTS: usize = 16;

fn bin(cfg: &SampleConfig, geodesic: f32) -> Difficulty {
    if geodesic < cfg.bins[0] {
        Difficulty::Easy
    } else if geodesic < cfg.bins[1] {
        Difficulty::Medium
    } else {
        Difficulty::Hard
    }
}

fn position_of(grid: &NavGrid, spans: &[u32]) -> [f32; 3] {
    if spans.is_empty() {
        return [0.0; 3];
    }
    let c = spans
        .iter()
        .map(|&s| grid.span_position(s as usize))
        .sum::<Vec3>()
        / spans.len() as f32;
    // The walkable span nearest to the centroid stands for the region.
    let best = spans
        .iter()
        .min_by(|&&a, &&b| {
            grid.span_position(a as usize)
                .distance(c)
                .total_cmp(&grid.span_position(b as usize).distance(c))
        })
        .copied()
        .unwrap_or(spans[0]);
    grid.span_position(best as usize).to_array()
}

/// The view points of a target reached from `spans` (walkable spans near an object, or inside
/// a room): at most [`MAX_VIEW_POINTS`] of them, every `⌈n / MAX⌉`-th span in the spans'
/// order, so the choice is deterministic and spread over the region.
fn view_points(grid: &NavGrid, spans: &[u32]) -> Vec<[f32; 3]> {
    let step = spans.len().div_ceil(MAX_VIEW_POINTS).max(1);
    spans
        .iter()
        .step_by(step)
        .map(|&s| grid.span_position(s as usize).to_array())
        .collect()
}

/// The room most of `spans` lie in (ties: the lowest room index), `None` when none is in a
/// room.
fn room_of(grid: &NavGrid, spans: &[u32]) -> Option<TargetRoom> {
    let mut counts: BTreeMap<u32, usize> = BTreeMap::new();
    for &s in spans {
        let room = grid.spans.get(s as usize)?.room;
        if (room as usize) < grid.rooms.len() {
            *counts.entry(room).or_default() += 1;
        }
    }
    let (&best, _) = counts
        .iter()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))?;
    let room = &grid.rooms[best as usize];
    Some(TargetRoom {
        id: room.id.clone(),
        class: RoomClass::ALL
            .iter()
            .find(|c| c.index() == room.class)
            .unwrap_or(&RoomClass::Other)
            .name()
            .to_string(),
    })
}

/// The goal sets of a scene for the task: one per category (ObjectGoal) or room class (RoomGoal).
fn goal_sets(grid: &NavGrid, cfg: &SampleConfig) -> Vec<GoalSet> {
    match cfg.task {
        Task::PointGoal | Task::Vln => Vec::new(),
        Task::ObjectGoal => object_categories(grid, cfg)
            .iter()
            .filter_map(|cat| {
                let mut set = GoalSet {
                    name: cat.clone(),
                    targets: Vec::new(),
                    spans: Vec::new(),
                };
                for (i, o) in grid.objects.iter().enumerate() {
                    if !o.category.eq_ignore_ascii_case(cat) {
                        continue;
                    }
                    let spans = grid.object_spans(i as u32, cfg.success_radius);
                    if spans.is_empty() {
                        continue;
                    }
                    let centre = [
                        (o.min[0] + o.max[0]) / 2.0,
                        (o.min[1] + o.max[1]) / 2.0,
                        (o.min[2] + o.max[2]) / 2.0,
                    ];
                    set.targets.push(GoalTarget {
                        id: o.id.clone(),
                        position: centre,
                        view_points: view_points(grid, &spans),
                        room: room_of(grid, &spans),
                    });
                    set.spans.push(spans);
                }
                (!set.targets.is_empty() && set.targets.len() >= cfg.min_instances as usize)
                    .then_some(set)
            })
            .collect(),
        Task::RoomGoal => {
            let classes: Vec<RoomClass> = cfg
                .room_classes
                .clone()
                .unwrap_or_else(|| RoomClass::ALL.to_vec());
            classes
                .iter()
                .filter_map(|class| {
                    let mut set = GoalSet {
                        name: class.name().to_string(),
                        targets: Vec::new(),
                        spans: Vec::new(),
                    };
                    for (i, r) in grid.rooms.iter().enumerate() {
                        if r.class != class.index() {
                            continue;
                        }
                        let spans = grid.room_spans(i as u32);
                        if spans.is_empty() {
                            continue;
                        }
                        // View points as for objects: walkable points of the room,
                        // subsampled; exports turn them to face `position`, its centre.
                        set.targets.push(GoalTarget {
                            id: r.id.clone(),
                            position: position_of(grid, &spans),
                            view_points: view_points(grid, &spans),
                            room: Some(TargetRoom {
                                id: r.id.clone(),
                                class: class.name().to_string(),
                            }),
                        });
                        set.spans.push(spans);
                    }
                    (!set.targets.is_empty()).then_some(set)
                })
                .collect()
        }
    }
}

/// Categories that are structure, never ObjectGoal goals under `--categories all`.
const STRUCTURE: [&str; 6] = ["ceiling", "floor", "unknown", "void", "wall", ""];

/// The ObjectGoal categories of a scene: the configured list, or every category of the
/// grid's objects (lower case, sorted, structure left out).
fn object_categories(grid: &NavGrid, cfg: &SampleConfig) -> Vec<String> {
    if !cfg.all_categories {
        return cfg.categories.clone();
    }
    let set: std::collections::BTreeSet<String> = grid
        .objects
        .iter()
        .map(|o| o.category.trim().to_ascii_lowercase())
        .filter(|c| !STRUCTURE.contains(&c.as_str()))
        .collect();
    set.into_iter().collect()
}

/// How far (m) above a level's floor height a floor still counts as that level's.
const LEVEL_TOLERANCE: f32 = 0.3;

/// The level a floor at height `y` is on: the level whose floor height is the highest at or
/// below `y` + a tolerance (the lowest level when none is). Heights, not the spans'
/// level labels, so that floor beside a stairwell (labelled with the stairs' level) and a
/// half landing count as the floor they are at.
pub fn level_at_height(grid: &NavGrid, y: f32) -> u32 {
    let mut best: Option<(f32, usize)> = None;
    let mut lowest: Option<(f32, usize)> = None;
    for (k, &h) in grid.level_heights.iter().enumerate() {
        if lowest.is_none_or(|(lh, _)| h < lh) {
            lowest = Some((h, k));
        }
        if h <= y + LEVEL_TOLERANCE && best.is_none_or(|(bh, _)| h > bh) {
            best = Some((h, k));
        }
    }
    best.or(lowest).map_or(0, |(_, k)| k as u32)
}

/// Levels a path climbs or descends: the sum of the level changes ([`level_at_height`])
/// between its consecutive corner spans.
pub fn levels_crossed(grid: &NavGrid, spans: &[u32]) -> u32 {
    let level = |s: u32| {
        grid.spans
            .get(s as usize)
            .map_or(0, |s| i64::from(level_at_height(grid, s.y)))
    };
    spans
        .windows(2)
        .map(|w| (level(w[1]) - level(w[0])).unsigned_abs() as u32)
        .sum()
}

/// Lazily computed distance fields of goal span sets, keyed by (goal set, target or all).
struct FieldCache<'g> {
    geo: &'g Geodesic<'g>,
    fields: BTreeMap<(usize, Option<usize>), DistanceField>,
}

impl<'g> FieldCache<'g> {
    fn get(&mut self, sets: &[GoalSet], set: usize, target: Option<usize>) -> &DistanceField {
        let geo = self.geo;
        self.fields.entry((set, target)).or_insert_with(|| {
            let goals: Vec<u32> = match target {
                Some(t) => sets[set].spans[t].clone(),
                None => sets[set].spans.iter().flatten().copied().collect(),
            };
            geo.field(&goals)
        })
    }
}

/// Draws of one goal set (and target) answered by sparse queries before its distance field
/// is built: a field costs about as much as this many queries.
const SPARSE_DRAWS: usize = 32;

/// Goal regions for the sparse nearest-goal query, keyed by (goal set, target or all, island):
/// the targets' spans on that island.
struct RegionCache<'g> {
    geo: &'g Geodesic<'g>,
    regions: BTreeMap<(usize, Option<usize>, u32), GoalRegions>,
}

impl<'g> RegionCache<'g> {
    fn get(
        &mut self,
        sets: &[GoalSet],
        set: usize,
        target: Option<usize>,
        island: u32,
    ) -> &GoalRegions {
        let geo = self.geo;
        self.regions
            .entry((set, target, island))
            .or_insert_with(|| {
                let spans = &geo.grid().spans;
                let on_island: Vec<Vec<u32>> = match target {
                    Some(t) => vec![&sets[set].spans[t]],
                    None => sets[set].spans.iter().collect(),
                }
                .into_iter()
                .map(|s| {
                    s.iter()
                        .copied()
                        .filter(|&s| spans[s as usize].island == island)
                        .collect()
                })
                .collect();
                let refs: Vec<&[u32]> = on_island.iter().map(Vec::as_slice).collect();
                geo.goal_regions(&refs)
            })
    }
}

/// Samples the episodes of one scene (`scene_id` names it in ids; `split` is written as is).
pub fn sample_scene(
    grid: &NavGrid,
    scene_id: &str,
    split: &str,
    cfg: &SampleConfig,
) -> SceneEpisodes {
    sample_scene_from(grid, scene_id, split, cfg, None)
}

/// [`sample_scene`], with the starts given where `starts` is: each start, in order, is used
/// once, with a goal drawn for it and the same filters (a draw the filters reject leaves
/// that start without an episode); a start off the floor the sampler would draw from
/// (walkable, in a room, on an island large enough) is rejected.
pub fn sample_scene_from(
    grid: &NavGrid,
    scene_id: &str,
    split: &str,
    cfg: &SampleConfig,
    starts: Option<&[Start]>,
) -> SceneEpisodes {
    let seed = derive_seed(cfg.seed, &[scene_id, cfg.task.name(), "episodes"]);
    let mut rng = Rng::new(seed);
    let mut out = SceneEpisodes::default();
    let islands: Vec<bool> = grid
        .islands
        .iter()
        .map(|i| i.radius >= cfg.min_island_radius)
        .collect();
    // Where a start may stand: walkable floor inside a room, on an island large enough.
    let usable = |s: u32| {
        let span = &grid.spans[s as usize];
        span.walkable && islands[span.island as usize] && span.room != NONE
    };
    let floor: Vec<u32> = grid
        .walkable_spans(None)
        .into_iter()
        .filter(|&s| usable(s))
        .collect();
    if starts.is_some_and(|given| given.is_empty()) {
        out.unusable = Some("no starts given for this scene".into());
        return out;
    }
    if floor.is_empty() {
        out.unusable = Some(format!(
            "no walkable floor inside a room on an island of radius >= {} m",
            cfg.min_island_radius
        ));
        return out;
    }
    let by_island: BTreeMap<u32, Vec<u32>> = floor.iter().fold(BTreeMap::new(), |mut m, &s| {
        m.entry(grid.spans[s as usize].island)
            .or_insert_with(Vec::new)
            .push(s);
        m
    });
    let sets = goal_sets(grid, cfg);
    if matches!(cfg.task, Task::ObjectGoal | Task::RoomGoal) && sets.is_empty() {
        out.unusable = Some(match cfg.task {
            Task::ObjectGoal if cfg.all_categories => format!(
                "no object category with {} or more reachable instances",
                cfg.min_instances
            ),
            Task::ObjectGoal => format!(
                "no reachable object of categories {}{}",
                cfg.categories.join(","),
                if cfg.min_instances > 1 {
                    format!(" with {} or more reachable instances", cfg.min_instances)
                } else {
                    String::new()
                }
            ),
            _ => "no room of the requested classes with walkable floor".into(),
        });
        return out;
    }
    // VLN: the scene's objects by room, and the objects a route may end next to, by island.
    let vln_index = (cfg.task == Task::Vln).then(|| SceneIndex::new(grid));
    let mut vln_goals: BTreeMap<u32, Vec<(u32, Vec<u32>)>> = BTreeMap::new();
    for g in vln_index.iter().flat_map(|x| &x.goals) {
        let mut by: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for &s in &g.spans {
            by.entry(grid.spans[s as usize].island).or_default().push(s);
        }
        for (island, spans) in by {
            vln_goals.entry(island).or_default().push((g.object, spans));
        }
    }
    let geo = Geodesic::new(grid);
    let mut fields = FieldCache {
        geo: &geo,
        fields: BTreeMap::new(),
    };
    // Sparse queries where goal sets are drawn a few times each (many categories); fields
    // at once where each set will be drawn more often than a field costs in queries.
    let sparse_draws = if cfg.per_scene >= SPARSE_DRAWS.saturating_mul(sets.len()) {
        0
    } else {
        SPARSE_DRAWS
    };
    let mut draws: BTreeMap<(usize, Option<usize>), usize> = BTreeMap::new();
    let mut regions = RegionCache {
        geo: &geo,
        regions: BTreeMap::new(),
    };
    let per_bin = cfg.per_scene.div_ceil(3);
    let door_filters = cfg.min_doors > 0 || cfg.min_rooms > 0;
    let mut bin_counts = [0usize; 3];
    let attempts = match starts {
        Some(given) => given.len(),
        None => cfg
            .per_scene
            .saturating_mul(cfg.attempts_per_episode)
            .max(1),
    };
    let reject =
        |out: &mut SceneEpisodes, why: &'static str| *out.rejected.entry(why).or_insert(0) += 1;
    for attempt in 0..attempts {
        if out.episodes.len() >= cfg.per_scene {
            break;
        }
        let (start_span, start, yaw) = match starts.and_then(|given| given.get(attempt)) {
            Some(given) => {
                let at = Vec3::from_array(given.position);
                match grid.snap(at).filter(|&s| usable(s)) {
                    Some(span) => (span, at, given.yaw),
                    None => {
                        reject(&mut out, "given start off the usable floor");
                        continue;
                    }
                }
            }
            None => {
                let Some((span, at)) = grid.random_point_from(&mut rng, &floor) else {
                    break;
                };
                (span, at, rng.range_f64(0.0, std::f64::consts::TAU) as f32)
            }
        };
        let island = grid.spans[start_span as usize].island;
        let mut goal_object = None;
        // The path's rooms and doors are still to be listed (once it passes the filters).
        let mut unlisted = false;
        let (goal, mut path, goal_point) = match cfg.task {
            Task::Vln => {
                // An object that is the only one of its category in its room, and the centre
                // of a span next to it in that room (so within GOAL_RADIUS of it); a random
                // point where the island has none.
                let drawn = match vln_goals.get(&island).and_then(|c| rng.pick(c)) {
                    Some((object, spans)) => {
                        goal_object = Some(*object);
                        rng.pick(spans)
                            .map(|&s| (s, grid.span_position(s as usize)))
                    }
                    None => grid.random_point_from(&mut rng, &by_island[&island]),
                };
                let Some((goal_span, goal)) = drawn else {
                    continue;
                };
                if start.distance(goal) > cfg.max_geodesic {
                    reject(&mut out, "geodesic above max_geodesic");
                    continue;
                }
                match shortest_polyline_in(&geo, start_span, goal_span) {
                    PathResult::Found(mut p) => {
                        add_rooms_and_doors(grid, &mut p);
                        (
                            Goal::Point {
                                position: goal.to_array(),
                            },
                            p,
                            goal,
                        )
                    }
                    PathResult::Unreachable => {
                        reject(&mut out, "unreachable");
                        continue;
                    }
                }
            }
            Task::PointGoal => {
                let Some((goal_span, goal)) = grid.random_point_from(&mut rng, &by_island[&island])
                else {
                    continue;
                };
                // A polyline is never shorter than the straight line between its ends.
                if start.distance(goal) > cfg.max_geodesic {
                    reject(&mut out, "geodesic above max_geodesic");
                    continue;
                }
                // Rooms and doors are listed once the pair passes the distance filters,
                // unless a filter needs them.
                match shortest_polyline_in(&geo, start_span, goal_span) {
                    PathResult::Found(mut p) => {
                        if door_filters {
                            add_rooms_and_doors(grid, &mut p);
                        }
                        (
                            Goal::Point {
                                position: goal.to_array(),
                            },
                            p,
                            goal,
                        )
                    }
                    PathResult::Unreachable => {
                        reject(&mut out, "unreachable");
                        continue;
                    }
                }
            }
            Task::ObjectGoal | Task::RoomGoal => {
                // Goals reachable from the start's island: a category or class is drawn among
                // those with an instance there, and a random instance among those.
                let reachable: Vec<usize> = (0..sets.len())
                    .filter(|&k| !sets[k].targets_on(grid, island).is_empty())
                    .collect();
                let Some(&set) = rng.pick(&reachable) else {
                    reject(&mut out, "no goal on the start's island");
                    continue;
                };
                let target = match cfg.select {
                    Select::Random => rng.pick(&sets[set].targets_on(grid, island)).copied(),
                    Select::Any | Select::Closest => None,
                };
                // One sparse query to the nearest goal region where it can answer (a field
                // per category costs a whole island for a few draws each); the category's
                // field otherwise.
                let drawn = draws.entry((set, target)).or_insert(0usize);
                *drawn += 1;
                let nearest = if *drawn <= sparse_draws {
                    let goals = regions.get(&sets, set, target, island);
                    nearest_polyline_in(&geo, start_span, goals)
                } else {
                    None
                };
                let p = match nearest {
                    Some(mut p) => {
                        if door_filters {
                            add_rooms_and_doors(grid, &mut p);
                        } else {
                            unlisted = true;
                        }
                        p
                    }
                    None => {
                        let field = fields.get(&sets, set, target);
                        let PathResult::Found(p) = path_from_field(grid, field, start_span) else {
                            reject(&mut out, "goal not reachable from start");
                            continue;
                        };
                        p
                    }
                };
                let end = *p.spans.last().unwrap_or(&start_span);
                let targets: Vec<GoalTarget> = match target {
                    Some(t) => vec![sets[set].targets[t].clone()],
                    None if cfg.select == Select::Closest => {
                        let t = sets[set]
                            .spans
                            .iter()
                            .position(|s| s.contains(&end))
                            .unwrap_or(0);
                        vec![sets[set].targets[t].clone()]
                    }
                    None => sets[set].targets.clone(),
                };
                let goal = match cfg.task {
                    Task::ObjectGoal => Goal::Object {
                        category: sets[set].name.clone(),
                        targets,
                    },
                    _ => Goal::Room {
                        class: sets[set].name.clone(),
                        targets,
                    },
                };
                (goal, p, grid.span_position(end as usize))
            }
        };
        let Some(ep) = check(grid, cfg, &mut rng, &path, start, goal_point, &mut |why| {
            reject(&mut out, why)
        }) else {
            continue;
        };
        let difficulty = bin(cfg, ep.0);
        if cfg.stratified && bin_counts[difficulty as usize] >= per_bin {
            reject(&mut out, "distance bin full");
            continue;
        }
        if unlisted || (cfg.task == Task::PointGoal && !door_filters) {
            add_rooms_and_doors(grid, &mut path);
        }
        let index = out.episodes.len();
        let route = match &vln_index {
            Some(vi) => {
                let described = describe_route(
                    grid,
                    vi,
                    &path,
                    RouteEnds {
                        start,
                        goal: goal_point,
                        yaw,
                        goal_object,
                    },
                    instruction_seed(seed, index),
                    cfg.instructions,
                );
                Some(Box::new(described.route))
            }
            None => None,
        };
        bin_counts[difficulty as usize] += 1;
        out.episodes.push(Episode {
            episode_id: format!("{scene_id}:{}:{index:05}", cfg.task.name()),
            scene_id: scene_id.to_string(),
            split: split.to_string(),
            task: cfg.task,
            seed,
            start_position: start.to_array(),
            start_yaw: yaw,
            goal,
            euclidean_distance: ep.1,
            geodesic_distance: ep.0,
            path_num_doors: path.doors.len() as u32,
            path_num_rooms: path.rooms.len() as u32,
            difficulty,
            success_radius: cfg.success_radius,
            max_steps: cfg.max_steps,
            levels_crossed: levels_crossed(grid, &path.spans),
            route,
        });
    }
    out
}

/// Geodesic length of a path whose end points are replaced by the sampled points.
pub fn path_length_between(path: &Path, start: Vec3, goal: Vec3) -> f32 {
    let mut pts = path.points.clone();
    if pts.len() < 2 {
        return start.distance(goal);
    }
    pts[0] = start;
    let n = pts.len();
    pts[n - 1] = goal;
    pts.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// Applies the filters; returns (geodesic, euclidean) of an accepted pair.
fn check(
    grid: &NavGrid,
    cfg: &SampleConfig,
    rng: &mut Rng,
    path: &Path,
    start: Vec3,
    goal: Vec3,
    reject: &mut dyn FnMut(&'static str),
) -> Option<(f32, f32)> {
    let geodesic = match cfg.task {
        Task::PointGoal | Task::Vln => path_length_between(path, start, goal),
        // Object and room goals end at the nearest goal span.
        _ => path_length_between(path, start, *path.points.last().unwrap_or(&goal)),
    };
    let euclidean = start.distance(goal);
    if cfg.task == Task::RoomGoal && geodesic <= 0.0 {
        reject("start inside the goal room");
        return None;
    }
    if geodesic < cfg.min_geodesic {
        reject("geodesic below min_geodesic");
        return None;
    }
    if geodesic > cfg.max_geodesic {
        reject("geodesic above max_geodesic");
        return None;
    }
    if cfg.ratio_rule && cfg.task == Task::PointGoal && euclidean > 0.0 {
        let ratio = geodesic / euclidean;
        if ratio < 1.1 && rng.unit_f64() > 20.0 * f64::from(ratio - 0.98).powi(2) {
            reject("geodesic/euclidean ratio rule");
            return None;
        }
    }
    if (path.doors.len() as u32) < cfg.min_doors {
        reject("fewer doors than min_doors");
        return None;
    }
    if (path.rooms.len() as u32) < cfg.min_rooms {
        reject("fewer rooms than min_rooms");
        return None;
    }
    if cfg.same_level {
        let level = |p: Vec3| grid.snap(p).map(|s| grid.spans[s as usize].level);
        if level(start) != level(goal) {
            reject("start and goal on different levels");
            return None;
        }
    }
    Some((geodesic, euclidean))
}

/// HM3D ObjectNav's six goal categories (Habitat challenge 2022–2023).
pub const HM3D_OBJECTNAV: [&str; 6] = ["chair", "bed", "plant", "toilet", "tv_monitor", "sofa"];

/// MINOS's ObjectGoal categories.
pub const MINOS_OBJECTGOAL: [&str; 2] = ["door", "arch"];

/// The 21 mpcat40 goal categories of Matterport3D ObjectNav (Habitat challenge 2020–2021).
pub const MPCAT40_OBJECTNAV: [&str; 21] = [
    "chair",
    "table",
    "picture",
    "cabinet",
    "cushion",
    "sofa",
    "bed",
    "chest_of_drawers",
    "plant",
    "sink",
    "toilet",
    "stool",
    "towel",
    "tv_monitor",
    "shower",
    "bathtub",
    "counter",
    "fireplace",
    "gym_equipment",
    "seating",
    "clothes",
];

/// The categories of a named preset (`hm3d`, `minos`, `mpcat40`), `None` for other names.
pub fn category_preset(name: &str) -> Option<&'static [&'static str]> {
    match name {
        "hm3d" => Some(&HM3D_OBJECTNAV),
        "minos" => Some(&MINOS_OBJECTGOAL),
        "mpcat40" => Some(&MPCAT40_OBJECTNAV),
        _ => None,
    }
}
