//! Rewards, the success test ([`reached`]) and metrics: MINOS's `dist_time` and `path_delta` rewards and Habitat's geodesic
//! delta; per-episode success, MINOS speed (fraction of time left), SPL, SoftSPL, path length
//! and collisions, aggregated per task, split and difficulty.

use std::collections::BTreeMap;

use glam::Vec3;
use serde::Serialize;

use crate::episode::{Episode, Goal};
use crate::sim::{AgentState, Simulator};

/// True when the agent at `state` satisfies the episode's success test.
pub fn reached(sim: &Simulator, episode: &Episode, state: &AgentState) -> bool {
    let p = Vec3::from_array(state.position);
    match &episode.goal {
        Goal::Point { position } => {
            p.distance(Vec3::from_array(*position)) <= episode.success_radius
        }
        Goal::Object { .. } | Goal::Room { .. } => sim.goal_field_distance(p).is_some_and(|d| {
            // On a goal span: the field is 0 there; allow the offset within the cell.
            d <= sim.assets().grid.cell() * 0.75
        }),
    }
}

/// A reward function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Reward {
    /// MINOS: decrease of the Euclidean distance minus the normalised time of a step.
    #[default]
    DistTime,
    /// MINOS: decrease of the shortest-path distance.
    PathDelta,
    /// Habitat: decrease of the geodesic distance − 0.01 per step + 2.5 on success.
    Geodesic,
}

impl crate::vocab::Vocabulary for Reward {
    const WHAT: &'static str = "reward";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Reward::DistTime,
            name: "dist_time",
            aliases: &[],
            help: "MINOS: decrease of the Euclidean distance minus the normalised time of a step",
        },
        crate::vocab::Term {
            value: Reward::PathDelta,
            name: "path_delta",
            aliases: &[],
            help: "MINOS: decrease of the shortest-path distance",
        },
        crate::vocab::Term {
            value: Reward::Geodesic,
            name: "geodesic",
            aliases: &[],
            help: "Habitat: decrease of the geodesic distance - 0.01 per step + 2.5 on success",
        },
    ];
}

crate::vocab::name_traits!(Reward);

impl Reward {
    /// `dist_time`, `path_delta` or `geodesic` (its [`Vocabulary`](crate::vocab::Vocabulary)
    /// name).
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }

    /// The reward of a step from `before` to `after` (Euclidean, geodesic distances).
    pub fn of_step(
        self,
        before: (f32, Option<f32>),
        after: (f32, Option<f32>),
        max_steps: u32,
        success: bool,
    ) -> f32 {
        let geo = |b: Option<f32>, a: Option<f32>| match (b, a) {
            (Some(b), Some(a)) => b - a,
            _ => 0.0,
        };
        match self {
            Reward::DistTime => (before.0 - after.0) - 1.0 / max_steps.max(1) as f32,
            Reward::PathDelta => geo(before.1, after.1),
            Reward::Geodesic => geo(before.1, after.1) - 0.01 + if success { 2.5 } else { 0.0 },
        }
    }
}

/// The metrics of one episode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EpisodeMetrics {
    /// Reached the goal (and stopped, for agents that must).
    pub success: bool,
    /// MINOS speed: fraction of the step budget left on success, else 0.
    pub speed: f32,
    /// Success weighted by (shortest path / max(shortest path, path taken)).
    pub spl: f32,
    /// (1 − final geodesic / start geodesic) weighted like SPL.
    pub soft_spl: f32,
    /// Length of the path taken (m).
    pub path_length: f32,
    /// Steps taken.
    pub steps: u32,
    /// Steps with a collision.
    pub collisions: u32,
    /// Geodesic distance left at the end (m; NaN when unknown).
    pub final_geodesic: f32,
    /// How closely the agent followed a VLN episode's reference path ([`ndtw`]); NaN for the
    /// other tasks.
    pub ndtw: f32,
}

impl EpisodeMetrics {
    /// Computes the derived fields from the raw ones.
    pub fn finish(
        success: bool,
        steps: u32,
        max_steps: u32,
        path_length: f32,
        collisions: u32,
        start_geodesic: f32,
        final_geodesic: f32,
    ) -> Self {
        let weight = if path_length.max(start_geodesic) > 0.0 {
            start_geodesic / path_length.max(start_geodesic)
        } else {
            1.0
        };
        let progress = if start_geodesic > 0.0 && final_geodesic.is_finite() {
            (1.0 - final_geodesic / start_geodesic).clamp(0.0, 1.0)
        } else {
            0.0
        };
        EpisodeMetrics {
            success,
            speed: if success {
                1.0 - steps as f32 / max_steps.max(1) as f32
            } else {
                0.0
            },
            spl: if success { weight } else { 0.0 },
            soft_spl: if success { weight } else { progress * weight },
            path_length,
            steps,
            collisions,
            final_geodesic,
            ndtw: f32::NAN,
        }
    }
}

impl Default for EpisodeMetrics {
    /// A failed episode of no steps, with the distances left and nDTW unknown (NaN).
    fn default() -> Self {
        EpisodeMetrics {
            success: false,
            speed: 0.0,
            spl: 0.0,
            soft_spl: 0.0,
            path_length: 0.0,
            steps: 0,
            collisions: 0,
            final_geodesic: f32::NAN,
            ndtw: f32::NAN,
        }
    }
}

/// nDTW's distance threshold (m): VLN-CE's success distance.
pub const NDTW_THRESHOLD: f32 = 3.0;

/// The spacing (m) a reference path is resampled at for [`ndtw`]: the Habitat agent's step,
/// as VLN-CE's reference locations are one per step.
pub const NDTW_SPACING: f32 = 0.25;

/// Normalised dynamic time warping (Ilharco et al. 2019, "General Evaluation for Instruction
/// Conditioned Navigation using Dynamic Time Warping"): how closely `query` — the positions
/// the agent passed, its start first — follows `reference`, a path's corners.
/// `exp(−DTW(R, Q) / (|R| · NDTW_THRESHOLD))`, where `R` is the reference resampled every
/// [`NDTW_SPACING`] metres along its segments (its corners kept) and DTW sums the Euclidean
/// distances of the best monotone matching of `R`'s points to `Q`'s. 1 when the query visits
/// the reference's points in order, falling towards 0 as it strays; NaN when either is
/// empty.
pub fn ndtw(reference: &[[f32; 3]], query: &[[f32; 3]]) -> f32 {
    let r = resample(reference, NDTW_SPACING);
    if r.is_empty() || query.is_empty() {
        return f32::NAN;
    }
    let q: Vec<glam::Vec3> = query.iter().map(|p| glam::Vec3::from_array(*p)).collect();
    // dtw[j] over the query for the previous and the current reference point.
    let mut prev = vec![f64::INFINITY; q.len() + 1];
    prev[0] = 0.0;
    let mut cur = vec![f64::INFINITY; q.len() + 1];
    for a in &r {
        cur[0] = f64::INFINITY;
        for (j, b) in q.iter().enumerate() {
            let d = f64::from(a.distance(*b));
            cur[j + 1] = d + prev[j].min(prev[j + 1]).min(cur[j]);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    let dtw = prev[q.len()];
    (-dtw / (r.len() as f64 * f64::from(NDTW_THRESHOLD))).exp() as f32
}

/// `path`'s corners with points every `spacing` metres along each segment between them.
fn resample(path: &[[f32; 3]], spacing: f32) -> Vec<glam::Vec3> {
    let mut out = Vec::new();
    for w in path.windows(2) {
        let (a, b) = (glam::Vec3::from_array(w[0]), glam::Vec3::from_array(w[1]));
        let n = (a.distance(b) / spacing).ceil().max(1.0) as usize;
        out.extend((0..n).map(|k| a.lerp(b, k as f32 / n as f32)));
    }
    out.extend(path.last().map(|p| glam::Vec3::from_array(*p)));
    out
}

/// Means over a group of episodes. Episodes that failed with an error (the oracle found no
/// plan, an external agent crashed, the scene did not load) count in `episodes` and
/// `failed`, and as failures (0) in `success`, `speed`, `spl` and `soft_spl`: rates are over
/// every episode attempted, never over the survivors. Path length, steps and collisions are
/// means over the episodes that ran to their end (`episodes - failed`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Aggregate {
    /// Episodes attempted (finished and failed).
    pub episodes: usize,
    /// Episodes that failed with an error.
    pub failed: usize,
    /// Success rate.
    pub success: f64,
    /// Mean MINOS speed.
    pub speed: f64,
    /// Mean SPL.
    pub spl: f64,
    /// Mean SoftSPL.
    pub soft_spl: f64,
    /// Mean path length (m) of the finished episodes.
    pub path_length: f64,
    /// Mean steps of the finished episodes.
    pub steps: f64,
    /// Mean collisions of the finished episodes.
    pub collisions: f64,
    /// Mean nDTW of the finished episodes that have one (VLN); absent when none has.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ndtw: Option<f64>,
}

impl Aggregate {
    /// Means of `metrics`; `None` is an episode that failed with an error.
    pub fn of<'a>(metrics: impl Iterator<Item = Option<&'a EpisodeMetrics>>) -> Self {
        let mut a = Aggregate::default();
        let (mut ndtw_sum, mut ndtw_n) = (0.0, 0usize);
        for m in metrics {
            a.episodes += 1;
            let Some(m) = m else {
                a.failed += 1;
                continue;
            };
            a.success += f64::from(u8::from(m.success));
            a.speed += f64::from(m.speed);
            a.spl += f64::from(m.spl);
            a.soft_spl += f64::from(m.soft_spl);
            a.path_length += f64::from(m.path_length);
            a.steps += f64::from(m.steps);
            a.collisions += f64::from(m.collisions);
            if m.ndtw.is_finite() {
                ndtw_sum += f64::from(m.ndtw);
                ndtw_n += 1;
            }
        }
        a.ndtw = (ndtw_n > 0).then(|| ndtw_sum / ndtw_n as f64);
        let all = a.episodes.max(1) as f64;
        for v in [&mut a.success, &mut a.speed, &mut a.spl, &mut a.soft_spl] {
            *v /= all;
        }
        let finished = (a.episodes - a.failed).max(1) as f64;
        for v in [&mut a.path_length, &mut a.steps, &mut a.collisions] {
            *v /= finished;
        }
        a
    }
}

/// One episode for [`aggregate`]: task, split, difficulty and its metrics (`None` when it
/// failed with an error).
pub type MetricRow = (String, String, String, Option<EpisodeMetrics>);

/// Aggregates keyed by group name (`all`, `task=…`, `split=…`, `difficulty=…`).
pub fn aggregate(rows: &[MetricRow]) -> BTreeMap<String, Aggregate> {
    let mut out = BTreeMap::new();
    out.insert(
        "all".to_string(),
        Aggregate::of(rows.iter().map(|r| r.3.as_ref())),
    );
    for (k, f) in [("task", 0usize), ("split", 1), ("difficulty", 2)] {
        let mut values: Vec<&String> = rows.iter().map(|r| [&r.0, &r.1, &r.2][f]).collect();
        values.sort();
        values.dedup();
        for v in values {
            out.insert(
                format!("{k}={v}"),
                Aggregate::of(
                    rows.iter()
                        .filter(|r| [&r.0, &r.1, &r.2][f] == v)
                        .map(|r| r.3.as_ref()),
                ),
            );
        }
    }
    out
}

/// The printed table of aggregates (`failed`: episodes that failed with an error, counted
/// as failures in every rate).
pub fn render_table(groups: &BTreeMap<String, Aggregate>) -> String {
    // An nDTW column only where some group has VLN episodes.
    let with_ndtw = groups.values().any(|a| a.ndtw.is_some());
    let mut s = format!(
        "{:<24}{:>9}{:>8}{:>9}{:>8}{:>8}{:>9}{:>9}{:>8}",
        "group", "episodes", "failed", "success", "SPL", "SoftSPL", "speed", "path m", "coll."
    );
    if with_ndtw {
        s.push_str(&format!("{:>8}", "nDTW"));
    }
    s.push('\n');
    for (k, a) in groups {
        s.push_str(&format!(
            "{:<24}{:>9}{:>8}{:>8.1}%{:>8.3}{:>8.3}{:>9.3}{:>9.2}{:>8.1}",
            k,
            a.episodes,
            a.failed,
            100.0 * a.success,
            a.spl,
            a.soft_spl,
            a.speed,
            a.path_length,
            a.collisions
        ));
        if with_ndtw {
            match a.ndtw {
                Some(v) => s.push_str(&format!("{v:>8.3}")),
                None => s.push_str(&format!("{:>8}", "–")),
            }
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spl_and_soft_spl_follow_their_definitions() {
        let m = EpisodeMetrics::finish(true, 50, 500, 10.0, 2, 8.0, 0.1);
        assert!((m.spl - 0.8).abs() < 1e-6 && (m.speed - 0.9).abs() < 1e-6);
        let f = EpisodeMetrics::finish(false, 500, 500, 4.0, 0, 8.0, 6.0);
        assert_eq!(f.spl, 0.0);
        assert!((f.soft_spl - 0.25).abs() < 1e-6, "{}", f.soft_spl);
        assert!(
            (Reward::DistTime.of_step((5.0, None), (4.8, None), 100, false) - (0.2 - 0.01)).abs()
                < 1e-5
        );
        assert!(
            (Reward::Geodesic.of_step((5.0, Some(6.0)), (4.8, Some(5.7)), 100, true)
                - (0.3 - 0.01 + 2.5))
                .abs()
                < 1e-5
        );
    }

    /// DTW by its recursive definition, memoised: the reference for the rolling-row one.
    fn dtw_by_definition(r: &[glam::Vec3], q: &[glam::Vec3]) -> f64 {
        fn go(
            i: usize,
            j: usize,
            r: &[glam::Vec3],
            q: &[glam::Vec3],
            memo: &mut std::collections::HashMap<(usize, usize), f64>,
        ) -> f64 {
            if let Some(v) = memo.get(&(i, j)) {
                return *v;
            }
            let d = f64::from(r[i].distance(q[j]));
            let v = match (i, j) {
                (0, 0) => d,
                (0, _) => d + go(0, j - 1, r, q, memo),
                (_, 0) => d + go(i - 1, 0, r, q, memo),
                _ => {
                    d + go(i - 1, j - 1, r, q, memo)
                        .min(go(i - 1, j, r, q, memo))
                        .min(go(i, j - 1, r, q, memo))
                }
            };
            memo.insert((i, j), v);
            v
        }
        go(r.len() - 1, q.len() - 1, r, q, &mut Default::default())
    }

    #[test]
    fn ndtw_follows_its_definition() {
        // An L-shaped reference, 2 m then 1.5 m: resampled every 0.25 m, corners kept.
        let reference = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, -1.5]];
        let r = resample(&reference, NDTW_SPACING);
        assert_eq!(r.len(), 8 + 6 + 1);
        assert!(r
            .windows(2)
            .all(|w| (w[0].distance(w[1]) - 0.25).abs() < 1e-5));
        // Walking the reference's own points: a perfect follow.
        let on: Vec<[f32; 3]> = r.iter().map(|p| p.to_array()).collect();
        assert!((ndtw(&reference, &on) - 1.0).abs() < 1e-6);
        // The same walk 1 m to the side: every point matched 1 m away, exp(−1/3).
        let beside: Vec<[f32; 3]> = r.iter().map(|p| (*p + glam::Vec3::Y).to_array()).collect();
        assert!((ndtw(&reference, &beside) - (-1.0f32 / 3.0).exp()).abs() < 1e-5);
        // A walk that cuts the corner and stops short, at agent-sized steps: the rolling
        // rows equal the recursive definition.
        let cut: Vec<[f32; 3]> = (0..12)
            .map(|k| {
                let t = k as f32 / 11.0;
                [1.8 * t, 0.0, -1.2 * t * t]
            })
            .collect();
        let q: Vec<glam::Vec3> = cut.iter().map(|p| glam::Vec3::from_array(*p)).collect();
        let want = (-dtw_by_definition(&r, &q) / (r.len() as f64 * 3.0)).exp() as f32;
        let got = ndtw(&reference, &cut);
        assert!((got - want).abs() < 1e-6, "{got} against {want}");
        assert!(got < 1.0 && got > (-1.0f32 / 3.0).exp(), "{got}");
        assert!(ndtw(&reference, &[]).is_nan() && ndtw(&[], &cut).is_nan());
    }

    #[test]
    fn the_mean_ndtw_is_over_the_episodes_that_have_one() {
        let mut vln = EpisodeMetrics::finish(true, 50, 500, 10.0, 2, 8.0, 0.1);
        vln.ndtw = 0.8;
        let mut other = vln;
        other.ndtw = 0.4;
        let point = EpisodeMetrics::finish(true, 50, 500, 10.0, 2, 8.0, 0.1);
        let a = Aggregate::of([Some(&vln), Some(&other), Some(&point), None].into_iter());
        assert!((a.ndtw.unwrap() - 0.6).abs() < 1e-6, "{:?}", a.ndtw);
        let none = Aggregate::of([Some(&point)].into_iter());
        assert_eq!(none.ndtw, None);
        assert!(!serde_json::to_string(&none).unwrap().contains("ndtw"));
        let table = render_table(&[("all".to_string(), a)].into_iter().collect());
        assert!(table.contains("nDTW") && table.contains("0.600"), "{table}");
    }

    #[test]
    fn failed_episodes_count_as_failures_in_every_rate() {
        let ok = EpisodeMetrics::finish(true, 50, 500, 10.0, 2, 8.0, 0.1);
        let row = |task: &str, m: Option<EpisodeMetrics>| {
            (task.to_string(), "val".to_string(), "easy".to_string(), m)
        };
        let rows = vec![
            row("pointgoal", Some(ok)),
            row("pointgoal", None),
            row("objectgoal", None),
        ];
        let groups = aggregate(&rows);
        let all = &groups["all"];
        assert_eq!((all.episodes, all.failed), (3, 2));
        assert!((all.success - 1.0 / 3.0).abs() < 1e-12, "{}", all.success);
        assert!((all.spl - 0.8 / 3.0).abs() < 1e-6, "{}", all.spl);
        assert!((all.speed - 0.9 / 3.0).abs() < 1e-6, "{}", all.speed);
        // Means of what happened in an episode are over the finished ones.
        assert_eq!(
            (all.steps, all.path_length, all.collisions),
            (50.0, 10.0, 2.0)
        );
        let point = &groups["task=pointgoal"];
        assert_eq!((point.episodes, point.failed), (2, 1));
        assert!((point.success - 0.5).abs() < 1e-12);
        let object = &groups["task=objectgoal"];
        assert_eq!(
            (object.episodes, object.failed, object.success),
            (1, 1, 0.0)
        );
        let table = render_table(&groups);
        let line = table
            .lines()
            .find(|l| l.starts_with("all "))
            .expect("an `all` row");
        assert!(line.contains("33.3%"), "{table}");
        assert!(!table.contains("100.0%"), "{table}");
    }
}
