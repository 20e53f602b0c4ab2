//! Feature statistics as LeRobot keeps them (`meta/stats.json` and the `stats/…` columns of
//! `meta/episodes`): per channel `min`, `max`, `mean`, `std` (population), `count` (frames)
//! and the quantiles `q01`, `q10`, `q50`, `q90`, `q99`.
//!
//! Per-episode statistics are exact (quantiles interpolate linearly between order
//! statistics, NumPy's default; LeRobot's own recorder approximates them with histograms and
//! samples image frames). Dataset statistics combine the episodes' exactly as LeRobot's
//! `aggregate_stats` does: extreme of extremes, count-weighted means and quantiles, and the
//! parallel-variance rule for `std`.

use serde_json::{json, Value};

/// The quantiles LeRobot records, with their keys.
pub const QUANTILES: [(f64, &str); 5] = [
    (0.01, "q01"),
    (0.10, "q10"),
    (0.50, "q50"),
    (0.90, "q90"),
    (0.99, "q99"),
];

/// How a feature's per-channel statistics are nested in JSON and in `meta/episodes`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatLayout {
    /// A flat list, one value per element or channel (`[v, …]`).
    Flat,
    /// An image's channels as LeRobot's `(C, 1, 1)` (`[[[r]], [[g]], [[b]]]`).
    Image,
}

/// Statistics of one feature: one value per channel for each statistic.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureStats {
    /// Per-channel minimum.
    pub min: Vec<f64>,
    /// Per-channel maximum.
    pub max: Vec<f64>,
    /// Per-channel mean.
    pub mean: Vec<f64>,
    /// Per-channel population standard deviation.
    pub std: Vec<f64>,
    /// Frames the statistics cover.
    pub count: u64,
    /// Per-channel quantiles, in [`QUANTILES`] order.
    pub quantiles: [Vec<f64>; 5],
}

impl FeatureStats {
    /// No channels yet, covering `count` frames.
    fn empty(count: u64) -> FeatureStats {
        FeatureStats {
            min: Vec::new(),
            max: Vec::new(),
            mean: Vec::new(),
            std: Vec::new(),
            count,
            quantiles: Default::default(),
        }
    }

    /// Statistics of `channels[c]` (every value of channel c over the episode's frames),
    /// counting `frames` frames. The value lists are reordered (partially sorted).
    pub fn of_channels(channels: &mut [Vec<f64>], frames: u64) -> FeatureStats {
        let mut s = FeatureStats::empty(frames);
        for values in channels.iter_mut() {
            let n = values.len().max(1) as f64;
            let mean = values.iter().sum::<f64>() / n;
            let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
            s.mean.push(mean);
            s.std.push(var.sqrt());
            s.min
                .push(values.iter().copied().fold(f64::INFINITY, f64::min));
            s.max
                .push(values.iter().copied().fold(f64::NEG_INFINITY, f64::max));
            for (k, (q, _)) in QUANTILES.iter().enumerate() {
                s.quantiles[k].push(quantile(values, *q));
            }
        }
        s
    }

    /// Statistics of 8-bit channels given as histograms (`histograms[c][v]` = how many
    /// pixels of channel c have value v), scaled by 1/255 as LeRobot scales images.
    pub fn of_histograms(histograms: &[[u64; 256]], frames: u64) -> FeatureStats {
        let mut s = FeatureStats::empty(frames);
        for h in histograms {
            let n: u64 = h.iter().sum();
            let nf = n.max(1) as f64;
            let mean = h
                .iter()
                .enumerate()
                .map(|(v, c)| v as f64 * *c as f64)
                .sum::<f64>()
                / nf;
            let var = h
                .iter()
                .enumerate()
                .map(|(v, c)| (v as f64 - mean).powi(2) * *c as f64)
                .sum::<f64>()
                / nf;
            let lo = h.iter().position(|c| *c > 0).unwrap_or(0);
            let hi = h.iter().rposition(|c| *c > 0).unwrap_or(0);
            s.min.push(lo as f64 / 255.0);
            s.max.push(hi as f64 / 255.0);
            s.mean.push(mean / 255.0);
            s.std.push(var.sqrt() / 255.0);
            for (k, (q, _)) in QUANTILES.iter().enumerate() {
                s.quantiles[k].push(histogram_quantile(h, n, *q) / 255.0);
            }
        }
        s
    }

    /// Combines per-episode statistics into the dataset's, as LeRobot's `aggregate_stats`.
    pub fn aggregate(parts: &[&FeatureStats]) -> Option<FeatureStats> {
        let first = parts.first()?;
        let channels = first.mean.len();
        if parts.iter().any(|p| p.mean.len() != channels) {
            return None;
        }
        let total: u64 = parts.iter().map(|p| p.count).sum();
        let total_f = total.max(1) as f64;
        let weighted = |get: &dyn Fn(&FeatureStats) -> &Vec<f64>, c: usize| {
            parts
                .iter()
                .map(|p| get(p)[c] * p.count as f64)
                .sum::<f64>()
                / total_f
        };
        let mut out = FeatureStats::empty(total);
        for c in 0..channels {
            let mean = weighted(&|p| &p.mean, c);
            let var = parts
                .iter()
                .map(|p| (p.std[c].powi(2) + (p.mean[c] - mean).powi(2)) * p.count as f64)
                .sum::<f64>()
                / total_f;
            out.min
                .push(parts.iter().map(|p| p.min[c]).fold(f64::INFINITY, f64::min));
            out.max.push(
                parts
                    .iter()
                    .map(|p| p.max[c])
                    .fold(f64::NEG_INFINITY, f64::max),
            );
            out.mean.push(mean);
            out.std.push(var.sqrt());
            for k in 0..QUANTILES.len() {
                out.quantiles[k].push(weighted(&|p| &p.quantiles[k], c));
            }
        }
        Some(out)
    }

    /// The statistics by name (`min`, …, `count`, `q01`, …), each nested as `layout` says.
    pub fn named(&self, layout: StatLayout) -> Vec<(&'static str, Value)> {
        let nest = |v: &Vec<f64>| match layout {
            StatLayout::Flat => json!(v),
            StatLayout::Image => json!(v.iter().map(|x| [[*x]]).collect::<Vec<_>>()),
        };
        let mut out = vec![
            ("min", nest(&self.min)),
            ("max", nest(&self.max)),
            ("mean", nest(&self.mean)),
            ("std", nest(&self.std)),
            ("count", json!([self.count])),
        ];
        for (k, (_, name)) in QUANTILES.iter().enumerate() {
            out.push((*name, nest(&self.quantiles[k])));
        }
        out
    }
}

/// The `q` quantile of `values` (linear between order statistics; NaN when empty).
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let pos = q * (values.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let (_, a, _) = values.select_nth_unstable_by(lo, f64::total_cmp);
    let a = *a;
    let b = if hi == lo {
        a
    } else {
        // After the selection everything above index lo is ≥ a: the next order statistic is
        // the smallest of them.
        values[lo + 1..]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    };
    a + (b - a) * (pos - lo as f64)
}

/// The `q` quantile of `n` values given as a 256-bin histogram.
fn histogram_quantile(h: &[u64; 256], n: u64, q: f64) -> f64 {
    if n == 0 {
        return f64::NAN;
    }
    let pos = q * (n - 1) as f64;
    let lo = pos.floor() as u64;
    let order = |k: u64| {
        let mut seen = 0;
        for (v, c) in h.iter().enumerate() {
            seen += c;
            if seen > k {
                return v as f64;
            }
        }
        255.0
    };
    let a = order(lo);
    let b = order(pos.ceil() as u64);
    a + (b - a) * (pos - lo as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// NumPy's `quantile` (linear), computed from a fully sorted copy.
    fn sorted_quantile(values: &[f64], q: f64) -> f64 {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let pos = q * (v.len() - 1) as f64;
        let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
        v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
    }

    #[test]
    fn channel_statistics_match_a_direct_computation() {
        let a: Vec<f64> = (0..101)
            .map(|i| ((i * 37) % 101) as f64 * 0.5 - 3.0)
            .collect();
        let b: Vec<f64> = (0..101).map(|i| (i as f64).sin()).collect();
        let s = FeatureStats::of_channels(&mut [a.clone(), b.clone()], 101);
        for (c, v) in [a, b].iter().enumerate() {
            let mean = v.iter().sum::<f64>() / 101.0;
            let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 101.0).sqrt();
            assert!((s.mean[c] - mean).abs() < 1e-12);
            assert!((s.std[c] - std).abs() < 1e-12);
            assert_eq!(s.min[c], sorted_quantile(v, 0.0));
            assert_eq!(s.max[c], sorted_quantile(v, 1.0));
            for (k, (q, _)) in QUANTILES.iter().enumerate() {
                assert!((s.quantiles[k][c] - sorted_quantile(v, *q)).abs() < 1e-12);
            }
        }
        assert_eq!(s.count, 101);
    }

    #[test]
    fn histogram_statistics_equal_the_value_statistics_scaled() {
        let pixels: Vec<u8> = (0..1000u32).map(|i| ((i * i) % 251) as u8).collect();
        let mut h = [0u64; 256];
        for p in &pixels {
            h[*p as usize] += 1;
        }
        let from_hist = FeatureStats::of_histograms(&[h], 7);
        let mut values: Vec<f64> = pixels.iter().map(|p| f64::from(*p) / 255.0).collect();
        let direct = FeatureStats::of_channels(std::slice::from_mut(&mut values), 7);
        for (a, b) in [
            (&from_hist.min, &direct.min),
            (&from_hist.max, &direct.max),
            (&from_hist.mean, &direct.mean),
            (&from_hist.std, &direct.std),
        ] {
            assert!((a[0] - b[0]).abs() < 1e-12, "{a:?} {b:?}");
        }
        for k in 0..5 {
            assert!((from_hist.quantiles[k][0] - direct.quantiles[k][0]).abs() < 1e-12);
        }
    }

    #[test]
    fn aggregation_of_episodes_equals_the_statistics_of_their_union() {
        let e1: Vec<f64> = (0..40).map(|i| i as f64 * 0.25).collect();
        let e2: Vec<f64> = (0..60).map(|i| 5.0 - i as f64 * 0.1).collect();
        let s1 = FeatureStats::of_channels(&mut [e1.clone()], 40);
        let s2 = FeatureStats::of_channels(&mut [e2.clone()], 60);
        let all: Vec<f64> = e1.iter().chain(&e2).copied().collect();
        let union = FeatureStats::of_channels(&mut [all], 100);
        let agg = FeatureStats::aggregate(&[&s1, &s2]).expect("same channels");
        // min, max, mean and std of the union are exact; quantiles are LeRobot's weighted
        // average of the episodes' quantiles.
        assert_eq!(agg.min, union.min);
        assert_eq!(agg.max, union.max);
        assert!((agg.mean[0] - union.mean[0]).abs() < 1e-12);
        assert!((agg.std[0] - union.std[0]).abs() < 1e-12);
        assert_eq!(agg.count, 100);
        let q50 = (s1.quantiles[2][0] * 40.0 + s2.quantiles[2][0] * 60.0) / 100.0;
        assert!((agg.quantiles[2][0] - q50).abs() < 1e-12);
        let mismatched = FeatureStats::of_channels(&mut [vec![1.0], vec![2.0]], 1);
        assert!(FeatureStats::aggregate(&[&s1, &mismatched]).is_none());
    }

    #[test]
    fn layouts_nest_as_lerobot_expects() {
        let s = FeatureStats::of_channels(&mut [vec![1.0], vec![2.0], vec![3.0]], 1);
        let named: std::collections::BTreeMap<_, _> =
            s.named(StatLayout::Image).into_iter().collect();
        assert_eq!(named["mean"], json!([[[1.0]], [[2.0]], [[3.0]]]));
        assert_eq!(named["count"], json!([1]));
        let flat: std::collections::BTreeMap<_, _> =
            s.named(StatLayout::Flat).into_iter().collect();
        assert_eq!(flat["max"], json!([1.0, 2.0, 3.0]));
        assert_eq!(flat.len(), 10);
    }
}
