//! Where a model and the measurement disagree: the residual by motion phase, its
//! autocorrelation, and its correlation with each effect's signature.

use std::collections::BTreeMap;

use serde::Serialize;

use super::catalogue::Effect;
use super::data::Prepared;
use super::solver::Fit;
use crate::phases::Phase;

/// Where the residual of a model sits.
#[derive(Debug, Clone, Serialize)]
pub struct Localisation {
    /// RMS residual \[N\] per phase (and the number of samples).
    pub phase_rms_n: BTreeMap<String, (f64, usize)>,
    /// The worst 0.5 s windows: (start \[s\], end \[s\], RMS \[N\], dominant phase).
    pub worst_windows: Vec<(f64, f64, f64, String)>,
    /// Residual autocorrelation at lags 0..=50 samples.
    pub autocorrelation: Vec<f64>,
    /// 99 % confidence band of a correlation of white residuals: 2.576/√N.
    pub band: f64,
    /// Largest |cross-correlation| (over lags −25..=25) of the residual with each signal
    /// (δ, δ̇, δ̈ and each candidate's signature regressor), and the lag.
    pub cross_correlation: BTreeMap<String, (f64, i32)>,
}

/// Pearson correlation of `a` and `b` shifted by `lag` (b leads for positive lags).
fn correlation(a: &[f64], b: &[f64], lag: i32) -> f64 {
    let n = a.len().min(b.len());
    let (mut sa, mut sb, mut sab, mut saa, mut sbb, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, &x) in a.iter().enumerate().take(n) {
        let j = i as i64 - i64::from(lag);
        if j < 0 || j as usize >= n {
            continue;
        }
        let y = b[j as usize];
        sa += x;
        sb += y;
        sab += x * y;
        saa += x * x;
        sbb += y * y;
        m += 1.0;
    }
    if m < 3.0 {
        return 0.0;
    }
    let cov = sab / m - sa / m * sb / m;
    let va = saa / m - (sa / m).powi(2);
    let vb = sbb / m - (sb / m).powi(2);
    if va <= 0.0 || vb <= 0.0 {
        0.0
    } else {
        cov / (va * vb).sqrt()
    }
}

/// The signature of each candidate: the signal its extra term adds to a linear model
/// (the derivative of the force with respect to its parameter at the "no effect" value).
fn signatures(data: &Prepared, start: usize) -> Vec<(String, Vec<f64>)> {
    let d = &data.depth_m[start..];
    let v = &data.rate_m_per_s[start..];
    let a = &data.accel_m_per_s2[start..];
    let g: Vec<f64> = d.iter().map(|x| if *x > 0.0 { 1.0 } else { 0.0 }).collect();
    let l = d.iter().copied().fold(0.0f64, f64::max).max(1e-12);
    let mut deepest = 0.0f64;
    let mut lp = 0.0;
    let alpha = -(-data.dt).exp_m1();
    let mut out: Vec<(String, Vec<f64>)> = vec![
        ("δ".into(), d.to_vec()),
        ("dδ/dt".into(), v.to_vec()),
        ("d²δ/dt²".into(), a.to_vec()),
    ];
    let sig = |f: &dyn Fn(usize) -> f64| (0..d.len()).map(f).collect::<Vec<f64>>();
    out.push((
        Effect::PowerLawStiffness.id().into(),
        sig(&|i| g[i] * d[i] * (d[i].max(1e-12) / l).ln()),
    ));
    out.push((
        Effect::ExponentialStiffness.id().into(),
        sig(&|i| g[i] * d[i] * d[i]),
    ));
    out.push((
        Effect::DepthDependentDamping.id().into(),
        sig(&|i| g[i] * v[i] * (d[i].max(1e-12) / l).ln()),
    ));
    out.push((
        Effect::Relaxation.id().into(),
        d.iter()
            .zip(&g)
            .map(|(x, gi)| {
                lp += alpha * (gi * x - lp);
                lp
            })
            .collect(),
    ));
    out.push((Effect::ForceOffset.id().into(), vec![1.0; d.len()]));
    out.push((Effect::ContactPointOffset.id().into(), g.clone()));
    out.push((Effect::Inertia.id().into(), sig(&|i| g[i] * a[i])));
    out.push((Effect::TimeDelay.id().into(), sig(&|i| g[i] * v[i])));
    out.push((
        Effect::CoulombFriction.id().into(),
        sig(&|i| g[i] * v[i].signum()),
    ));
    out.push((
        Effect::PlasticSet.id().into(),
        d.iter()
            .zip(&g)
            .map(|(x, gi)| {
                deepest = deepest.max(*x);
                gi * deepest
            })
            .collect(),
    ));
    out.push((
        Effect::ForceDrift.id().into(),
        (start..data.len()).map(|i| data.since_start_s(i)).collect(),
    ));
    out
}

/// Residual localisation of a fit: per phase, worst windows, correlations.
pub fn localise(data: &Prepared, fit: &Fit) -> Localisation {
    let r = fit.residual(data);
    let start = fit.start;
    let n = r.len();
    let mut phases: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for (i, e) in r.iter().enumerate() {
        let p = data.phase[start + i];
        let entry = phases.entry(p.name().to_string()).or_default();
        entry.0 += e * e;
        entry.1 += 1;
    }
    for v in phases.values_mut() {
        v.0 = (v.0 / v.1.max(1) as f64).sqrt();
    }
    let w = (0.5 / data.dt) as usize;
    let mut windows: Vec<(f64, f64, f64, String)> = (0..n / w.max(1))
        .map(|k| {
            let s = &r[k * w..(k + 1) * w];
            let rms = (s.iter().map(|e| e * e).sum::<f64>() / s.len() as f64).sqrt();
            let mut count: BTreeMap<Phase, usize> = BTreeMap::new();
            for i in k * w..(k + 1) * w {
                *count.entry(data.phase[start + i]).or_default() += 1;
            }
            let phase = count
                .into_iter()
                .max_by_key(|(_, c)| *c)
                .map_or(Phase::Loading, |(p, _)| p);
            (
                data.time_s[start + k * w],
                data.time_s[start + (k + 1) * w - 1],
                rms,
                phase.name().to_string(),
            )
        })
        .collect();
    windows.sort_by(|a, b| b.2.total_cmp(&a.2));
    windows.truncate(3);
    let autocorrelation = (0..=50).map(|k| correlation(&r, &r, k)).collect();
    let cross_correlation = signatures(data, start)
        .into_iter()
        .map(|(name, s)| {
            let best = (-25..=25)
                .map(|lag| (correlation(&r, &s, lag), lag))
                .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
                .unwrap_or((0.0, 0));
            (name, best)
        })
        .collect();
    Localisation {
        phase_rms_n: phases,
        worst_windows: windows,
        autocorrelation,
        band: 2.576 / (n as f64).sqrt(),
        cross_correlation,
    }
}

/// Phases in display order.
pub const PHASE_ORDER: [Phase; 5] = Phase::ALL;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_a_signal_with_itself_is_one() {
        let a: Vec<f64> = (0..100).map(|i| (i as f64 * 0.3).sin()).collect();
        assert!((correlation(&a, &a, 0) - 1.0).abs() < 1e-12);
        let b: Vec<f64> = a.iter().map(|x| -2.0 * x).collect();
        assert!((correlation(&a, &b, 0) + 1.0).abs() < 1e-12);
    }
}
