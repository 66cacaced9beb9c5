//! A metric summarised over frames.

use serde::{Deserialize, Serialize};

/// The mean of `v` (accumulated in f64).
pub(super) fn mean(v: &[f32]) -> f32 {
    (v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64) as f32
}

/// Mean, median, min and max of a metric over frames (the paper reports the mean).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub mean: f32,
    pub median: f32,
    pub min: f32,
    pub max: f32,
    pub count: usize,
}

impl Summary {
    /// `None` for no values.
    pub fn of(values: &[f32]) -> Option<Summary> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f32::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) };
        Some(Summary { mean: mean(&v), median, min: v[0], max: v[n - 1], count: n })
    }
}
