//! The discrepancy workflow: fit a baseline model to a measured log, localise where the
//! simulation and the measurement disagree, name the missing effect among physical
//! candidates, add it, and repeat while an addition is significant.
//!
//! Each step fits every candidate effect added to the current model (variable
//! projection, [`model::fit`]) and ranks them by blocked 5-fold cross-validation RMSE.
//! The best is accepted only if all of these hold:
//! - its parameters are physical (a relaxed fraction in [0, 1), friction c ≥ 0);
//! - BIC falls by more than 10 (Kass & Raftery's "very strong" evidence), with the
//!   number of fitting samples N;
//! - the held-out error improves on every one of the 5 contiguous time blocks (a sign
//!   test at p = 1/32 < 0.05 that the gain is not confined to one stretch of the record);
//! - the mean held-out error improves by at least 1 %.
//!
//! The loop stops when no candidate passes, or after [`Options::max_steps`].

pub mod data;
pub mod model;
pub mod report;

use std::collections::{BTreeMap, BTreeSet};

use rayon::prelude::*;
use serde::Serialize;

use self::data::Prepared;
use self::model::{Effect, Effort, Fit};

/// Candidates fitted fully in each round (the rest only screened).
pub const SHORTLIST: usize = 3;
use crate::phases::Phase;

/// The model the workflow starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Baseline {
    /// Linear spring and damper (eq. 1): the default, the model designs are tied to.
    KelvinVoigt,
    /// Power-law elasticity and depth-dependent damping (eq. 3).
    HuntCrossley,
    /// Kelvin-Voigt with one relaxation mode (a Zener arm, eq. 2).
    Zener,
    /// Power-law elasticity with one relaxation mode (QLV / Hammerstein).
    Hammerstein,
}

impl Baseline {
    /// Effects the baseline already contains on top of Kelvin-Voigt.
    pub fn effects(self) -> BTreeSet<Effect> {
        match self {
            Baseline::KelvinVoigt => BTreeSet::new(),
            Baseline::HuntCrossley => {
                [Effect::PowerLawStiffness, Effect::DepthDependentDamping].into()
            }
            Baseline::Zener => [Effect::Relaxation].into(),
            Baseline::Hammerstein => [Effect::PowerLawStiffness, Effect::Relaxation].into(),
        }
    }

    /// Kebab-case name.
    pub fn name(self) -> &'static str {
        match self {
            Baseline::KelvinVoigt => "kelvin-voigt",
            Baseline::HuntCrossley => "hunt-crossley",
            Baseline::Zener => "zener",
            Baseline::Hammerstein => "hammerstein",
        }
    }
}

/// Settings of the workflow.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Starting model.
    pub baseline: Baseline,
    /// At most this many effects are added.
    pub max_steps: usize,
    /// BIC must fall by more than this.
    pub min_bic_drop: f64,
    /// Mean held-out error must improve by at least this fraction.
    pub min_cv_improvement: f64,
    /// Held-out error must improve on at least this many of the folds.
    pub min_folds_better: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            baseline: Baseline::KelvinVoigt,
            max_steps: 4,
            min_bic_drop: 10.0,
            min_cv_improvement: 0.01,
            min_folds_better: 3,
        }
    }
}

/// One candidate tried at a step.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Effect identifier.
    pub effect: Effect,
    /// The present effect it replaces (same model piece), if any.
    pub replaces: Option<Effect>,
    /// Its fit added to the current model.
    pub fit: Fit,
    /// BIC change (negative is better).
    pub delta_bic: f64,
    /// Relative held-out error improvement (positive is better).
    pub cv_improvement: f64,
    /// Folds whose held-out error improved.
    pub folds_better: usize,
    /// Passes the acceptance rule.
    pub significant: bool,
    /// Whether its parameters describe a passive material ([`physical`]).
    pub physical: bool,
}

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

/// One accepted addition.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// The effect added.
    pub effect: Effect,
    /// The effect it replaced, if any (power law ↔ exponential elasticity).
    pub replaces: Option<Effect>,
    /// The model before and after.
    pub before: Fit,
    /// After (jointly refitted).
    pub after: Fit,
    /// All candidates tried at this step, best first.
    pub candidates: Vec<Candidate>,
    /// Residual localisation before and after.
    pub localisation_before: Localisation,
    /// After.
    pub localisation_after: Localisation,
}

/// The workflow's result.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// Starting model.
    pub baseline: Baseline,
    /// Its fit.
    pub baseline_fit: Fit,
    /// Accepted additions in order.
    pub steps: Vec<Step>,
    /// Candidates of the last, unsuccessful round (why the loop stopped).
    pub final_candidates: Vec<Candidate>,
    /// The final model.
    pub final_fit: Fit,
    /// Its residual localisation.
    pub final_localisation: Localisation,
}

impl Diagnosis {
    /// Identifiers of the effects added, in order (one replaced by a later step is
    /// dropped: this is the final model's list).
    pub fn effects_added(&self) -> Vec<&'static str> {
        let mut out: Vec<Effect> = Vec::new();
        for s in &self.steps {
            if let Some(r) = s.replaces {
                out.retain(|e| *e != r);
            }
            out.push(s.effect);
        }
        out.into_iter().map(Effect::id).collect()
    }

    /// "kelvin-voigt + power_law_stiffness + …".
    pub fn final_model(&self) -> String {
        let mut s = self.baseline.name().to_string();
        for e in self.effects_added() {
            s.push_str(" + ");
            s.push_str(e);
        }
        s
    }
}

/// Runs the workflow on a prepared log. `None` if even the baseline cannot be fitted
/// (no contact samples).
pub fn diagnose(data: &Prepared, options: &Options) -> Option<Diagnosis> {
    let mut effects = options.baseline.effects();
    let duration_s = data.dt * (data.len() - data.fit_start()) as f64;
    let baseline_fit = model::fit(
        data,
        &effects,
        &model::Nonlinear::default(),
        &model::knobs_of(&effects),
        Effort::FULL,
    )?;
    let mut current = baseline_fit.clone();
    let mut steps = Vec::new();
    let mut final_candidates = Vec::new();
    for _ in 0..options.max_steps {
        // Every absent effect; one that replaces the same model piece as a present one
        // (power law ↔ exponential) is tried as a swap: an early choice made while
        // another effect was still missing can be revised.
        let untried: Vec<(Effect, Option<Effect>)> = Effect::ALL
            .into_iter()
            .filter(|e| !effects.contains(e))
            .map(|e| (e, effects.iter().copied().find(|p| p.conflicts_with(e))))
            .collect();
        // Candidates are independent fits: one per core. All are screened with a quick
        // fit; the best few by RSS are fitted fully, and only those can be accepted.
        let set = |e: Effect, replaces: Option<Effect>| {
            let mut with = effects.clone();
            if let Some(p) = replaces {
                with.remove(&p);
            }
            with.insert(e);
            with
        };
        let fit_one =
            |(e, replaces): (Effect, Option<Effect>), from: &model::Nonlinear, effort: Effort| {
                let fit = model::fit(
                    data,
                    &set(e, replaces),
                    from,
                    &e.knob().into_iter().collect::<Vec<_>>(),
                    effort,
                )?;
                Some(score(e, replaces, fit, &current, options, duration_s))
            };
        let mut screened: Vec<Candidate> = untried
            .into_par_iter()
            .filter_map(|c| fit_one(c, &current.nonlinear, Effort::QUICK))
            .collect();
        screened.sort_by(|a, b| a.fit.rss.total_cmp(&b.fit.rss));
        let rest = screened.split_off(SHORTLIST.min(screened.len()));
        let mut candidates: Vec<Candidate> = screened
            .into_par_iter()
            .map(|c| {
                fit_one((c.effect, c.replaces), &c.fit.nonlinear, Effort::REFINE)
                    .filter(|r| r.fit.rss <= c.fit.rss)
                    .unwrap_or(c)
            })
            .collect();
        candidates.extend(rest.into_iter().map(|mut c| {
            c.significant = false;
            c
        }));
        candidates.sort_by(|a, b| a.fit.cv_rmse.total_cmp(&b.fit.cv_rmse));
        let Some(best) = candidates.iter().find(|c| c.significant).cloned() else {
            final_candidates = candidates;
            break;
        };
        if let Some(p) = best.replaces {
            effects.remove(&p);
        }
        effects.insert(best.effect);
        // (The candidate's fit already refined every nonlinear parameter jointly.)
        steps.push(Step {
            effect: best.effect,
            replaces: best.replaces,
            localisation_before: localise(data, &current),
            localisation_after: localise(data, &best.fit),
            before: current,
            after: best.fit.clone(),
            candidates,
        });
        current = best.fit;
    }
    Some(Diagnosis {
        baseline: options.baseline,
        baseline_fit,
        final_localisation: localise(data, &current),
        steps,
        final_candidates,
        final_fit: current,
    })
}

fn score(
    effect: Effect,
    replaces: Option<Effect>,
    fit: Fit,
    current: &Fit,
    options: &Options,
    duration_s: f64,
) -> Candidate {
    let delta_bic = fit.bic - current.bic;
    let cv_improvement = 1.0 - fit.cv_rmse / current.cv_rmse;
    let folds_better = fit
        .cv_rmse_per_fold
        .iter()
        .zip(&current.cv_rmse_per_fold)
        .filter(|(a, b)| a < b)
        .count();
    let is_physical = physical(&fit, duration_s);
    let significant = is_physical
        && delta_bic < -options.min_bic_drop
        && folds_better >= options.min_folds_better
        && cv_improvement >= options.min_cv_improvement;
    Candidate {
        effect,
        replaces,
        fit,
        delta_bic,
        cv_improvement,
        folds_better,
        significant,
        physical: is_physical,
    }
}

/// Whether the fitted linear parameters describe a passive material over the
/// `duration_s` of the fit: a relaxation mode relaxes (relaxed fraction c ≥ 0; a negative
/// one is a force that grows while the depth is held, mimicking stiffening) and never
/// by more than the whole force within the record (c·(1 − e^(−ν·T)) < 1: a mode slower
/// than the record only fixes the product c·ν, so c alone may exceed 1); friction
/// opposes motion (c ≥ 0).
pub fn physical(fit: &Fit, duration_s: f64) -> bool {
    let rate = fit.parameter("rate_per_s").unwrap_or(0.0);
    fit.parameter("relaxed_fraction")
        .is_none_or(|c| c >= 0.0 && c * -(-rate * duration_s).exp_m1() < 1.0)
        && fit.parameter("coulomb_n").is_none_or(|c| c >= 0.0)
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
