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

impl Reward {
    /// `dist_time`, `path_delta` or `geodesic`.
    pub fn name(self) -> &'static str {
        match self {
            Reward::DistTime => "dist_time",
            Reward::PathDelta => "path_delta",
            Reward::Geodesic => "geodesic",
        }
    }

    /// A reward function by its [`Reward::name`].
    pub fn from_name(s: &str) -> Option<Reward> {
        match s {
            "dist_time" => Some(Reward::DistTime),
            "path_delta" => Some(Reward::PathDelta),
            "geodesic" => Some(Reward::Geodesic),
            _ => None,
        }
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
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
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
        }
    }
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
}

impl Aggregate {
    /// Means of `metrics`; `None` is an episode that failed with an error.
    pub fn of<'a>(metrics: impl Iterator<Item = Option<&'a EpisodeMetrics>>) -> Self {
        let mut a = Aggregate::default();
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
        }
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
    let mut s = format!(
        "{:<24}{:>9}{:>8}{:>9}{:>8}{:>8}{:>9}{:>9}{:>8}\n",
        "group", "episodes", "failed", "success", "SPL", "SoftSPL", "speed", "path m", "coll."
    );
    for (k, a) in groups {
        s.push_str(&format!(
            "{:<24}{:>9}{:>8}{:>8.1}%{:>8.3}{:>8.3}{:>9.3}{:>9.2}{:>8.1}\n",
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
