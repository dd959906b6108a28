//! `meta/stats.json`: per feature and per value, the minimum, maximum, mean, standard
//! deviation and count, as LeRobot's normalisers read them; episodes' statistics pooled.

/// Running statistics of one value, added one by one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    min: f64,
    max: f64,
    count: u64,
    sum: f64,
    sum_sq: f64,
}

impl Default for Moments {
    fn default() -> Moments {
        Moments {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            count: 0,
            sum: 0.0,
            sum_sq: 0.0,
        }
    }
}

impl Moments {
    /// Adds a value.
    pub fn add(&mut self, v: f64) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        self.count += 1;
        self.sum += v;
        self.sum_sq += v * v;
    }

    /// What the values come to, counted as `count` (LeRobot counts an image feature's
    /// frames, not its pixels).
    pub fn summary(&self, count: u64) -> Summary {
        let n = self.count.max(1) as f64;
        let mean = self.sum / n;
        Summary {
            min: if self.count > 0 { self.min } else { 0.0 },
            max: if self.count > 0 { self.max } else { 0.0 },
            mean,
            std: (self.sum_sq / n - mean * mean).max(0.0).sqrt(),
            count,
        }
    }
}

/// A value's statistics as `stats.json` states them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Mean.
    pub mean: f64,
    /// Population standard deviation.
    pub std: f64,
    /// How many (frames).
    pub count: u64,
}

impl Summary {
    /// The statistics of the union of parts, each weighted by its count.
    pub fn pooled(parts: &[Summary]) -> Summary {
        let n: u64 = parts.iter().map(|p| p.count).sum();
        if n == 0 {
            return Moments::default().summary(0);
        }
        let w = |p: &Summary| p.count as f64 / n as f64;
        let mean: f64 = parts.iter().map(|p| w(p) * p.mean).sum();
        let second: f64 = parts
            .iter()
            .map(|p| w(p) * (p.std * p.std + p.mean * p.mean))
            .sum();
        let counted = parts.iter().filter(|p| p.count > 0);
        Summary {
            min: counted.clone().map(|p| p.min).fold(f64::INFINITY, f64::min),
            max: counted.map(|p| p.max).fold(f64::NEG_INFINITY, f64::max),
            mean,
            std: (second - mean * mean).max(0.0).sqrt(),
            count: n,
        }
    }
}

/// `stats.json`'s entry of a feature, from each value's statistics; `wrap` shapes each
/// value (`[v]` for a vector's, `[[v]]` for an image channel's).
pub(super) fn entry(
    values: &[Summary],
    count: u64,
    wrap: fn(f64) -> serde_json::Value,
) -> serde_json::Value {
    let list = |f: fn(&Summary) -> f64| -> serde_json::Value {
        values.iter().map(|s| wrap(finite(f(s)))).collect()
    };
    serde_json::json!({
        "min": list(|s| s.min), "max": list(|s| s.max),
        "mean": list(|s| s.mean), "std": list(|s| s.std), "count": [count],
    })
}

/// Each value of `rows` (all of one length) summarised.
pub(super) fn columns(rows: &[Vec<f32>]) -> Vec<Summary> {
    let width = rows.first().map_or(0, Vec::len);
    let mut m = vec![Moments::default(); width];
    for row in rows {
        for (mi, v) in m.iter_mut().zip(row) {
            mi.add(f64::from(*v));
        }
    }
    m.iter().map(|x| x.summary(rows.len() as u64)).collect()
}

/// An image channel's statistics read back from `stats.json` (`[[v]]` per channel).
pub(super) fn read_channels(entry: &serde_json::Value) -> Option<[Summary; 3]> {
    let at = |key: &str, c: usize| entry[key][c][0][0].as_f64();
    let count = entry["count"][0].as_u64()?;
    let one = |c: usize| -> Option<Summary> {
        Some(Summary {
            min: at("min", c)?,
            max: at("max", c)?,
            mean: at("mean", c)?,
            std: at("std", c)?,
            count,
        })
    };
    Some([one(0)?, one(1)?, one(2)?])
}

fn finite(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The running statistics of a few values; an empty one is all zeros.
    #[test]
    fn moments_give_the_mean_and_std() {
        let mut m = Moments::default();
        for v in [1.0, 2.0, 3.0, 4.0] {
            m.add(v);
        }
        let s = m.summary(4);
        assert_eq!((s.min, s.max, s.count), (1.0, 4.0, 4));
        assert!((s.mean - 2.5).abs() < 1e-12);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-12);
        assert_eq!(Moments::default().summary(0).std, 0.0);
    }

    /// Pooling the statistics of two parts gives those of all their values together.
    #[test]
    fn pooled_statistics_are_those_of_the_union() {
        let (a, b) = ([1.0, 2.0, 3.0], [10.0, 20.0]);
        let sum = |v: &[f64]| {
            let mut m = Moments::default();
            v.iter().for_each(|x| m.add(*x));
            m.summary(v.len() as u64)
        };
        let all: Vec<f64> = a.iter().chain(&b).copied().collect();
        let (p, whole) = (Summary::pooled(&[sum(&a), sum(&b)]), sum(&all));
        assert_eq!((p.min, p.max, p.count), (whole.min, whole.max, whole.count));
        assert!((p.mean - whole.mean).abs() < 1e-12 && (p.std - whole.std).abs() < 1e-9);
        assert_eq!(Summary::pooled(&[]).count, 0);
    }
}
