//! Quality control of a recorded demonstration: the figures a lab checks before a person's
//! episode goes into a training set (success, path length against the geodesic, idle time,
//! collisions, actions per second, time to first move), computed from the episode's metrics
//! and the wall-clock times of its actions, and the verdict of a campaign's thresholds
//! (accepted, or flagged with the reasons).
//!
//! Times are seconds since the episode was shown. The trajectory tables carry no clock (a
//! replay must give the same bytes), so the times come from whoever recorded the episode
//! (`minos serve`) and are kept beside it in its QC record.

use serde::{Deserialize, Serialize};

use crate::invalid::Invalid;

use super::metrics::EpisodeMetrics;

/// A pause between two actions longer than this counts as idle for what exceeds it (s).
pub const IDLE_GAP: f32 = 2.0;

/// What a demonstration's quality is computed from.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoRecord<'a> {
    /// The episode's metrics (success, path length, collisions, steps).
    pub metrics: &'a EpisodeMetrics,
    /// The episode's shortest-path length from its start (m; NaN or ≤ 0 when unknown).
    pub geodesic: f32,
    /// When each action (stop included) was taken, in seconds since the episode was shown,
    /// in order.
    pub action_times: &'a [f32],
}

/// The quality figures of one demonstration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DemoQc {
    /// Reached the goal and stopped.
    pub success: bool,
    /// Length of the path walked (m).
    pub path_length: f32,
    /// Shortest-path length from the start (m; null when unknown).
    pub geodesic: Option<f32>,
    /// `path_length / geodesic` (null when the geodesic is unknown or 0).
    pub path_ratio: Option<f32>,
    /// Steps with a collision.
    pub collisions: u32,
    /// Actions taken (stop included).
    pub actions: u32,
    /// Seconds from the episode being shown to its last action.
    pub duration: f32,
    /// Actions per second over `duration` (0 when it is 0).
    pub actions_per_second: f32,
    /// Seconds from the episode being shown to the first action (null without actions).
    pub time_to_first_move: Option<f32>,
    /// Seconds of pauses between actions beyond [`IDLE_GAP`] each.
    pub idle_seconds: f32,
}

impl DemoQc {
    /// The figures of `record`.
    pub fn of(record: &DemoRecord<'_>) -> DemoQc {
        let m = record.metrics;
        let times = record.action_times;
        let geodesic =
            (record.geodesic.is_finite() && record.geodesic >= 0.0).then_some(record.geodesic);
        let path_ratio = geodesic.filter(|g| *g > 0.0).map(|g| m.path_length / g);
        let duration = times.last().copied().unwrap_or(0.0).max(0.0);
        let idle_seconds = times
            .windows(2)
            .map(|w| (w[1] - w[0] - IDLE_GAP).max(0.0))
            .sum();
        DemoQc {
            success: m.success,
            path_length: m.path_length,
            geodesic,
            path_ratio,
            collisions: m.collisions,
            actions: times.len() as u32,
            duration,
            actions_per_second: if duration > 0.0 {
                times.len() as f32 / duration
            } else {
                0.0
            },
            time_to_first_move: times.first().copied(),
            idle_seconds,
        }
    }
}

/// A campaign's thresholds: a demonstration breaking any of them is flagged. Every bound is
/// optional; `require_success` is on unless turned off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QcThresholds {
    /// A failed episode is flagged.
    #[serde(default = "yes")]
    pub require_success: bool,
    /// Most `path_length / geodesic`.
    pub max_path_ratio: Option<f32>,
    /// Most idle seconds.
    pub max_idle_seconds: Option<f32>,
    /// Most steps with a collision.
    pub max_collisions: Option<u32>,
    /// Fewest actions per second.
    pub min_actions_per_second: Option<f32>,
    /// Most actions per second (a held key or a script).
    pub max_actions_per_second: Option<f32>,
    /// Most seconds before the first action.
    pub max_time_to_first_move: Option<f32>,
}

fn yes() -> bool {
    true
}

impl Default for QcThresholds {
    fn default() -> Self {
        QcThresholds {
            require_success: true,
            max_path_ratio: None,
            max_idle_seconds: None,
            max_collisions: None,
            min_actions_per_second: None,
            max_actions_per_second: None,
            max_time_to_first_move: None,
        }
    }
}

/// Accepted, or flagged with why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// No threshold broken.
    pub accepted: bool,
    /// One line per broken threshold (empty when accepted).
    pub reasons: Vec<String>,
}

impl QcThresholds {
    /// Checks that every bound is a finite number ≥ 0 and the rate bounds are ordered;
    /// otherwise one line naming the field.
    pub fn validate(&self) -> Result<(), Invalid> {
        let bounds = [
            ("max_path_ratio", self.max_path_ratio),
            ("max_idle_seconds", self.max_idle_seconds),
            ("min_actions_per_second", self.min_actions_per_second),
            ("max_actions_per_second", self.max_actions_per_second),
            ("max_time_to_first_move", self.max_time_to_first_move),
        ];
        for (name, v) in bounds {
            if let Some(v) = v {
                if !v.is_finite() || v < 0.0 {
                    return Err(format!("qc.{name}: {v} is not a number ≥ 0").into());
                }
            }
        }
        if let (Some(lo), Some(hi)) = (self.min_actions_per_second, self.max_actions_per_second) {
            if lo > hi {
                return Err(format!(
                    "qc.min_actions_per_second {lo} is above qc.max_actions_per_second {hi}"
                )
                .into());
            }
        }
        Ok(())
    }

    /// The verdict on `qc`.
    pub fn judge(&self, qc: &DemoQc) -> Verdict {
        let mut reasons = Vec::new();
        if self.require_success && !qc.success {
            reasons.push("did not reach the goal".to_string());
        }
        if let (Some(max), Some(r)) = (self.max_path_ratio, qc.path_ratio) {
            if r > max {
                reasons.push(format!("path {r:.2}× the shortest (at most {max})"));
            }
        }
        if let Some(max) = self.max_idle_seconds {
            if qc.idle_seconds > max {
                reasons.push(format!("idle {:.1} s (at most {max} s)", qc.idle_seconds));
            }
        }
        if let Some(max) = self.max_collisions {
            if qc.collisions > max {
                reasons.push(format!("{} collisions (at most {max})", qc.collisions));
            }
        }
        if let Some(min) = self.min_actions_per_second {
            if qc.actions_per_second < min {
                reasons.push(format!(
                    "{:.2} actions/s (at least {min})",
                    qc.actions_per_second
                ));
            }
        }
        if let Some(max) = self.max_actions_per_second {
            if qc.actions_per_second > max {
                reasons.push(format!(
                    "{:.2} actions/s (at most {max})",
                    qc.actions_per_second
                ));
            }
        }
        if let Some(max) = self.max_time_to_first_move {
            match qc.time_to_first_move {
                Some(t) if t > max => {
                    reasons.push(format!("first move after {t:.1} s (at most {max} s)"))
                }
                None => reasons.push("no action taken".to_string()),
                _ => {}
            }
        }
        Verdict {
            accepted: reasons.is_empty(),
            reasons,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(success: bool, path: f32, collisions: u32) -> EpisodeMetrics {
        EpisodeMetrics {
            success,
            path_length: path,
            collisions,
            ..Default::default()
        }
    }

    #[test]
    fn figures_match_a_hand_computation() {
        // Actions at 1.5, 2.0, 6.0, 6.5, 10.0 s: gaps 0.5, 4.0, 0.5, 3.5 → idle (4−2)+(3.5−2)
        // = 3.5 s; 5 actions over 10 s = 0.5/s; path 6 m over a 4 m geodesic = 1.5.
        let m = metrics(true, 6.0, 2);
        let times = [1.5, 2.0, 6.0, 6.5, 10.0];
        let qc = DemoQc::of(&DemoRecord {
            metrics: &m,
            geodesic: 4.0,
            action_times: &times,
        });
        assert!(qc.success);
        assert_eq!(qc.path_ratio, Some(1.5));
        assert_eq!(qc.geodesic, Some(4.0));
        assert_eq!(qc.actions, 5);
        assert_eq!(qc.duration, 10.0);
        assert_eq!(qc.actions_per_second, 0.5);
        assert_eq!(qc.time_to_first_move, Some(1.5));
        assert!((qc.idle_seconds - 3.5).abs() < 1e-6, "{}", qc.idle_seconds);
        assert_eq!(qc.collisions, 2);
        // No actions, unknown geodesic: no rates, no ratio.
        let qc = DemoQc::of(&DemoRecord {
            metrics: &m,
            geodesic: f32::NAN,
            action_times: &[],
        });
        assert_eq!((qc.path_ratio, qc.geodesic), (None, None));
        assert_eq!((qc.actions_per_second, qc.time_to_first_move), (0.0, None));
    }

    #[test]
    fn thresholds_flag_with_reasons_and_accept_otherwise() {
        let m = metrics(true, 6.0, 2);
        let times = [1.5, 2.0, 6.0, 6.5, 10.0];
        let qc = DemoQc::of(&DemoRecord {
            metrics: &m,
            geodesic: 4.0,
            action_times: &times,
        });
        let lenient = QcThresholds {
            max_path_ratio: Some(2.0),
            max_idle_seconds: Some(5.0),
            max_collisions: Some(2),
            min_actions_per_second: Some(0.2),
            max_actions_per_second: Some(8.0),
            max_time_to_first_move: Some(2.0),
            ..Default::default()
        };
        assert_eq!(
            lenient.judge(&qc),
            Verdict {
                accepted: true,
                reasons: vec![]
            }
        );
        let strict = QcThresholds {
            max_path_ratio: Some(1.4),
            max_idle_seconds: Some(3.0),
            max_collisions: Some(1),
            min_actions_per_second: Some(0.6),
            max_time_to_first_move: Some(1.0),
            ..Default::default()
        };
        let v = strict.judge(&qc);
        assert!(!v.accepted);
        assert_eq!(v.reasons.len(), 5, "{:?}", v.reasons);
        assert!(v.reasons[0].contains("1.50×"), "{:?}", v.reasons);
        let failed = metrics(false, 6.0, 0);
        let qc = DemoQc::of(&DemoRecord {
            metrics: &failed,
            geodesic: 4.0,
            action_times: &times,
        });
        assert_eq!(
            QcThresholds::default().judge(&qc).reasons,
            vec!["did not reach the goal"]
        );
    }

    #[test]
    fn nonsense_thresholds_are_refused() {
        let t = QcThresholds {
            max_idle_seconds: Some(-1.0),
            ..Default::default()
        };
        assert!(t
            .validate()
            .unwrap_err()
            .to_string()
            .contains("qc.max_idle_seconds"));
        let t = QcThresholds {
            min_actions_per_second: Some(3.0),
            max_actions_per_second: Some(1.0),
            ..Default::default()
        };
        assert!(t.validate().is_err());
        assert!(QcThresholds::default().validate().is_ok());
    }
}
