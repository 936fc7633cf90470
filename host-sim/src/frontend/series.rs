//! The record as the front end fits it: block means of the native samples (so that a
//! 600 s, 1 kHz file costs the same as a 10 s one) and a zero-phase rate estimate.

/// Most fitting points; a longer record is averaged in blocks.
pub const MAX_POINTS: usize = 6000;

/// Half-widths \[s\] tried for the symmetric difference that estimates the rate, shortest
/// first: 4 ms follows a 10 Hz tap; a slow indentation with nanometre jitter needs up to
/// 0.5 s before its rate is more than noise.
pub const RATE_HALF_WINDOWS_S: [f64; 7] = [4.0e-3, 10.0e-3, 25.0e-3, 50.0e-3, 0.1, 0.25, 0.5];

/// Largest rate noise the chosen half-width may leave, as a fraction of the record's
/// 99.9th-percentile speed.
pub const MAX_RATE_NOISE: f64 = 0.02;

/// Block means of a record.
#[derive(Debug, Clone)]
pub struct Series {
    /// Time \[s\] of each point (block mean).
    pub time_s: Vec<f64>,
    /// Position \[m\] on the record's own axis (block mean).
    pub position_m: Vec<f64>,
    /// Rate of the position \[m/s\] (symmetric difference over ±4 ms or one point).
    pub rate_m_per_s: Vec<f64>,
    /// Force \[N\] (block mean).
    pub force_n: Vec<f64>,
    /// Native samples per point.
    pub block: usize,
}

impl Series {
    /// Block means of `time_s`, `position_m`, `force_n` (same length ≥ 2, time increasing).
    pub fn new(time_s: &[f64], position_m: &[f64], force_n: &[f64]) -> Series {
        let n = time_s.len().min(position_m.len()).min(force_n.len());
        let block = n.div_ceil(MAX_POINTS).max(1);
        let points = (n / block).max(1);
        let mean = |v: &[f64], b: usize| {
            let s = &v[b * block..((b + 1) * block).min(n)];
            s.iter().sum::<f64>() / s.len() as f64
        };
        let time: Vec<f64> = (0..points).map(|b| mean(time_s, b)).collect();
        let position: Vec<f64> = (0..points).map(|b| mean(position_m, b)).collect();
        let force: Vec<f64> = (0..points).map(|b| mean(force_n, b)).collect();
        let rate = rate_estimate(&time, &position);
        Series {
            time_s: time,
            position_m: position,
            rate_m_per_s: rate,
            force_n: force,
            block,
        }
    }

    /// The points where `keep` is true (rates kept as computed on the whole series).
    pub fn subset(&self, keep: &[bool]) -> Series {
        let pick = |v: &[f64]| {
            v.iter()
                .zip(keep)
                .filter(|(_, k)| **k)
                .map(|(x, _)| *x)
                .collect()
        };
        Series {
            time_s: pick(&self.time_s),
            position_m: pick(&self.position_m),
            rate_m_per_s: pick(&self.rate_m_per_s),
            force_n: pick(&self.force_n),
            block: self.block,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// `true` without points.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// The rate of `position` by the shortest symmetric difference of [`RATE_HALF_WINDOWS_S`]
/// whose noise (σ_x/(√2·h), σ_x the position noise from second differences) stays below
/// [`MAX_RATE_NOISE`] of the 99.9th-percentile speed it gives (not the 99th: the ramps of
/// a ramp-and-hold are 1-2 % of its samples).
pub fn rate_estimate(time_s: &[f64], position: &[f64]) -> Vec<f64> {
    let sigma_x = crate::setup::noise_level(position);
    let mut last = Vec::new();
    for &h in &RATE_HALF_WINDOWS_S {
        let rate = symmetric_rate(time_s, position, h);
        let mut speeds: Vec<f64> = rate.iter().map(|v| v.abs()).collect();
        speeds.sort_by(f64::total_cmp);
        let fast = speeds
            .get(((speeds.len().max(1) - 1) as f64 * 0.999) as usize)
            .copied()
            .unwrap_or(0.0);
        if sigma_x / (std::f64::consts::SQRT_2 * h) <= MAX_RATE_NOISE * fast {
            return rate;
        }
        last = rate;
    }
    last
}

/// (x\[i+k\] − x\[i−k\]) / (t\[i+k\] − t\[i−k\]) with k the number of samples in
/// `half_window_s` (at least 1, clipped at the ends): zero-phase, unlike the causal
/// state-variable filter, which the batch fits have no need for.
pub fn symmetric_rate(time_s: &[f64], position: &[f64], half_window_s: f64) -> Vec<f64> {
    let n = time_s.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let k = ((half_window_s / dt).round() as usize).max(1);
    (0..n)
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(k), (i + k).min(n - 1));
            let span = time_s[hi] - time_s[lo];
            if span > 0.0 {
                (position[hi] - position[lo]) / span
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_records_are_averaged_in_blocks_and_rates_are_exact_on_ramps() {
        let n = 20_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| 2e-3 * t).collect();
        let f: Vec<f64> = t.iter().map(|t| 3.0 + t).collect();
        let s = Series::new(&t, &x, &f);
        assert_eq!(s.block, 4);
        assert_eq!(s.len(), 5000);
        assert!((s.time_s[0] - 1.5e-3).abs() < 1e-12);
        assert!(s.rate_m_per_s.iter().all(|v| (v - 2e-3).abs() < 1e-9));
    }
}
